"""Stage 1, the tracker: find the float (or the dyed liquid's surface) in every frame, measure its angle relative
to the image or the container walls, mark frames the encoder repeated, Kalman/RTS smoothing across lost frames,
overlay video.

May import: sloshid.core, sloshid.video, sloshid.report.
"""
