"""Which pictures of a video are key frames: coded without reference to earlier pictures, so whatever an encoder
held over from earlier frames (an edge it did not bother to move) is gone there."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def key_frame_times(path: str | Path) -> np.ndarray:
    """Presentation times (s from the stream's start, as `FrameReader` gives them) of the video's key frames, sorted;
    read from the packets' flags without decoding. A file cut off mid-way gives the key frames before the cut."""
    import av

    times = []
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        start = stream.start_time or 0
        try:
            for packet in container.demux(stream):
                if packet.is_keyframe and packet.pts is not None:
                    times.append(float((packet.pts - start) * packet.time_base))
        except (av.FFmpegError, EOFError):
            pass  # truncated: the frames before the cut are all FrameReader decodes too
    return np.sort(np.array(times, float))
