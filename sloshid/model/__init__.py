"""The liquid model and what it acts on: pendulum parameters and equations (seed eq. 2, reconstructed
eq. 3, linearised eq. 4-6), the sign conventions, the one pendulum integrator, and the container trajectory a
robot executes with its limits.

May import: sloshid.core.
"""
