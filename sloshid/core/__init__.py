"""Foundation shared by every stage: the user-error type, atomic file writes, column tables (CSV),
typed settings loading with "did you mean", content hashes, the Welch spectrum and dominant-frequency estimate,
and the parallel back-end.

May import: nothing from sloshid.
"""
