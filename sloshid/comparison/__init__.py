"""Stage 4, the comparison: the alternatives a user would otherwise run (constant acceleration,
input shaping, ruckig jerk-limited moves, camera feedback), robot tracking, model-error sweeps, the verdict and
the comparison report.

May import: sloshid.core, sloshid.model, sloshid.report, sloshid.planning.
"""
