"""The self-contained HTML report (MNE-style): collect figures, tables and text into one index.html.
Stage-specific pages live with their stage (identification.report, planning.report, comparison.report).

May import: sloshid.core.
"""
