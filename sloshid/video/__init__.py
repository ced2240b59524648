"""Video files in and out (OpenCV/FFmpeg reading with presentation timestamps, PyAV writing with exact
timestamps) and the named float colours shared by the renderer and the tracker.

May import: sloshid.core.
"""
