"""The `sloshid` command line: one module per command (`<name>_cmd.py` with add_arguments and run), each
turning its options into a stage's settings and calling the same library function as the pipeline and the batch.

May import: everything except sloshid.api.
"""
