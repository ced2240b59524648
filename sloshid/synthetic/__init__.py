"""Synthetic data with exact ground truth: rendered float and dyed-liquid videos and free-decay traces, for tests,
benchmarks and demos.

May import: sloshid.core, sloshid.model, sloshid.video, sloshid.identification.
"""
