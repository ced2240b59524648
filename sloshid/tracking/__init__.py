"""Stage 1, the tracker: find the float in every frame, measure its angle relative to the image or
the container walls, Kalman/RTS smoothing across lost frames, overlay video.

May import: sloshid.core, sloshid.video.
"""
