"""Video files in and out (PyAV/FFmpeg reading with presentation timestamps, converting to BGR only the parts
looked at; which pictures are key frames; PyAV writing with exact timestamps) and the named float colours shared
by the renderer and the tracker.

May import: sloshid.core.
"""
