"""The model against measured moves: predict the liquid's response to any recorded container motion, validate the
prediction against a measured signal (alignment, fit %, peak error, report), and identify the model from input and
output together (forced response and free decay).

May import: sloshid.core, sloshid.model, sloshid.report, sloshid.identification.
"""
