"""Stage 3, the planner: the scenario file, the time-optimal slosh-free optimal-control problem in
CasADi, its solution sampled at the robot's 1 kHz, the independent verification, and the plan report.

May import: sloshid.core, sloshid.model, sloshid.report.
"""
