"""Video in and out: sequential OpenCV/FFmpeg reading with presentation timestamps, PyAV writing with exact pts.

Reading never seeks: frames come in decode order with the container's own presentation time
(CAP_PROP_POS_MSEC), so variable-frame-rate files keep their real timing. Orientation metadata is
applied by OpenCV (CAP_PROP_ORIENTATION_AUTO). Writing uses PyAV because OpenCV's writer in this
environment has no H.264 encoder; every frame gets an explicit pts, so VFR files can be written.
"""

from __future__ import annotations

import contextlib
import math
import os
import queue
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from sloshid.core.errors import UserError

Codec = Literal["h264", "mpeg4"]
_ENCODERS = {"h264": "libx264", "mpeg4": "mpeg4"}
_TIME_BASES = {"h264": Fraction(1, 90000), "mpeg4": Fraction(1, 60000)}
"""Time base of written files: the MPEG 90 kHz clock; MPEG-4 Part 2 allows at most 65535 ticks per second."""


VIDEO_SUFFIXES = (".mp4", ".mov", ".m4v")
"""Names of the MP4-family container VideoWriter produces; other suffixes would mislabel the file."""


@dataclass
class VideoInfo:
    """What the container claims about a video before decoding (frame count and fps may be estimates)."""

    path: Path
    width: int
    height: int
    fps: float
    frame_count: int
    """Frames the container declares (0 when unknown)."""


FFMPEG_QUIET = "-8"
"""AV_LOG_QUIET: FFmpeg's own decoder complaints would print before sloshid's one sentence about the file."""


@contextlib.contextmanager
def _quiet_decoding() -> Iterator[None]:
    """Silence OpenCV's log while sloshid opens a video and restore the caller's level afterwards; FFmpeg inside
    OpenCV reads its level once, at the first capture, so it is quiet unless the user chose a level."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", FFMPEG_QUIET)
    previous = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(previous)


def _why_unreadable(path: Path) -> str:
    """One sentence on why OpenCV could not open `path`: no video frames, or not a video at all."""
    import av  # PyAV only for writing and for this diagnosis: reading alone starts faster without it

    try:
        with av.open(str(path)) as probe:
            streams = probe.streams.video
            if not streams or not streams[0].frames:
                return f"{path} contains no video frames."
    except (av.FFmpegError, OSError, ValueError):
        pass
    return f"{path} is not a video OpenCV/FFmpeg can decode (or it is cut off before its index)."


@dataclass
class FrameReader:
    """Iterate (index, t_s, BGR frame) over a video sequentially; afterwards `decoded` and `lost_share` tell
    how much of the declared content could actually be decoded (a truncated file decodes only a prefix)."""

    path: Path
    multithreaded: bool = True
    """Let FFmpeg decode with several threads, in a background thread that overlaps the caller's work (one
    video, several cores); off when many videos run side by side and each should use one core."""
    info: VideoInfo = field(init=False)
    decoded: int = field(init=False, default=0)
    _cap: cv2.VideoCapture = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.path = Path(self.path)
        if not self.path.exists():
            raise UserError(f"video {self.path} does not exist.")
        if not self.path.is_file():
            raise UserError(f"video {self.path} is not a file.")
        params = [] if self.multithreaded else [cv2.CAP_PROP_N_THREADS, 1]
        with _quiet_decoding():
            cap = cv2.VideoCapture(str(self.path), cv2.CAP_FFMPEG, params)
        if not cap.isOpened():
            raise UserError(_why_unreadable(self.path))
        cap.set(cv2.CAP_PROP_ORIENTATION_AUTO, 1)
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        if w <= 0 or h <= 0:
            cap.release()
            raise UserError(f"{self.path} is not a video OpenCV/FFmpeg can decode (no picture size).")
        count = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        count = int(count) if math.isfinite(count) and count > 0 else 0
        self._cap = cap
        self.info = VideoInfo(self.path, w, h, float(cap.get(cv2.CAP_PROP_FPS) or 0.0), count)

    def __iter__(self) -> Iterator[tuple[int, float, np.ndarray]]:
        """Frames in order. Decoding runs in a background thread (OpenCV releases the GIL while decoding),
        so the caller's per-frame work overlaps with decoding the next frames (unless multithreaded is off)."""
        if not self.multithreaded:
            yield from self._in_this_thread()
            return
        frames: queue.Queue = queue.Queue(maxsize=8)
        stop = threading.Event()
        worker = threading.Thread(target=self._decode, args=(frames, stop), daemon=True)
        worker.start()
        try:
            while True:
                item = frames.get()
                if item is None:
                    break
                t_s, frame = item
                yield self.decoded, t_s, frame
                self.decoded += 1
        finally:
            stop.set()
            while worker.is_alive():  # unblock a producer waiting on a full queue
                with contextlib.suppress(queue.Empty):
                    frames.get_nowait()
                worker.join(timeout=0.01)
            self._cap.release()
        if self.decoded == 0:
            raise UserError(f"{self.path} contains no decodable video frames.")

    def _in_this_thread(self) -> Iterator[tuple[int, float, np.ndarray]]:
        """Frames in order, decoded in the caller's thread."""
        try:
            while True:
                ok, frame = self._cap.read()
                if not ok or frame is None:
                    break
                yield self.decoded, self._cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0, frame
                self.decoded += 1
        finally:
            self._cap.release()
        if self.decoded == 0:
            raise UserError(f"{self.path} contains no decodable video frames.")

    def _decode(self, frames: queue.Queue, stop: threading.Event) -> None:
        """Producer: read frames sequentially with their presentation time until the end or `stop`."""
        cap = self._cap
        try:
            while not stop.is_set():
                ok, frame = cap.read()
                if not ok or frame is None:
                    break
                frames.put((cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0, frame))
        finally:
            frames.put(None) if not stop.is_set() else None

    @property
    def lost_share(self) -> float:
        """Share of the declared frames that did not decode (0 when complete or when the count is unknown)."""
        declared = self.info.frame_count
        return max(0.0, (declared - self.decoded) / declared) if declared else 0.0

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) in pixels after orientation is applied."""
        return self.info.width, self.info.height


class VideoWriter:
    """Write BGR frames with explicit presentation times (seconds) through PyAV: H.264 (libx264) or MPEG-4 Part 2.

    `quality` is the codec's own scale: x264 CRF for h264 (0..51, lower is better, 23 typical) and
    qscale for mpeg4 (1..31, lower is better, 4 typical). `display_rotation_deg` (CCW) is stored as
    orientation metadata, not applied to the pixels. Use as a context manager.
    """

    def __init__(
        self,
        path: str | Path,
        width: int,
        height: int,
        fps: float,
        codec: Codec = "h264",
        quality: float | None = None,
        display_rotation_deg: int = 0,
    ) -> None:
        if codec not in _ENCODERS:
            raise UserError(f"codec must be one of {', '.join(_ENCODERS)}, got {codec!r}.")
        import av

        self._av = av
        self._out = av.open(str(path), "w", format="mp4", options={"movflags": "faststart"})
        stream = self._out.add_stream(_ENCODERS[codec], rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height, stream.pix_fmt = width - width % 2, height - height % 2, "yuv420p"
        if codec == "h264":
            crf = 23 if quality is None else quality
            stream.options = {"crf": f"{crf:g}", "preset": "veryfast"}
        else:
            qscale = 4 if quality is None else quality
            stream.codec_context.qmin = stream.codec_context.qmax = round(qscale)  # fixed quantiser
        if display_rotation_deg:  # orientation metadata, as phones write it: players turn the picture
            stream.set_display_rotation(display_rotation_deg)
        self._time_base = _TIME_BASES[codec]
        stream.codec_context.time_base = self._time_base
        self._stream = stream
        self._last_pts = -1

    def write(self, frame_bgr: np.ndarray, t_s: float) -> None:
        """Encode one frame shown at presentation time t_s (must increase by at least one time-base tick)."""
        h, w = self._stream.height, self._stream.width
        frame = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(frame_bgr[:h, :w]), format="bgr24")
        pts = round(t_s / self._time_base)
        if pts <= self._last_pts:
            raise ValueError(
                f"presentation times must increase, got {t_s} s after {float(self._last_pts * self._time_base)} s"
            )
        frame.pts, frame.time_base = pts, self._time_base
        self._last_pts = pts
        for packet in self._stream.encode(frame):
            self._out.mux(packet)

    def close(self) -> None:
        """Flush the encoder and finish the file."""
        for packet in self._stream.encode():
            self._out.mux(packet)
        self._out.close()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self._out.close()
