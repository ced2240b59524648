"""Stage 2, the identification: load signals, find the free decay, Welch PSD, least-squares PT2
fit with intervals, cross-checks, second mode, agreement of jointly fitted signals, verdict, and the identification
report.

May import: sloshid.core, sloshid.model, sloshid.report.
"""
