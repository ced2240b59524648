"""Stage 1, the tracker: find the float (or the dyed liquid's surface) in every frame, measure its angle relative
to the image or the container walls, mark frames the encoder repeated, Kalman/RTS smoothing across lost frames,
overlay video; and the first look at one frame of a user's video (`inspect`): what each target would track there.

May import: sloshid.core, sloshid.video, sloshid.report.
"""
