"""Stage 3, the planner: the scenario file, the time-optimal slosh-free optimal-control problems in
CasADi (free rest-to-rest segments, and motion along a prescribed path) apart from their multiple-shooting
transcription, the solution sampled at the robot's 1 kHz, the independent verification, the arm's joint
space (Franka Panda via pinocchio), and the plan report.


May import: sloshid.core, sloshid.model, sloshid.report.
"""
