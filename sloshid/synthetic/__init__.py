"""Synthetic data with exact ground truth: rendered float videos and free-decay traces, for tests,
benchmarks and demos.

May import: sloshid.core, sloshid.model, sloshid.video, sloshid.identification.
"""
