"""Video in and out through PyAV (FFmpeg): sequential reading with presentation timestamps, writing with exact pts.

Frames come in order with the stream's own presentation time (from its start, as OpenCV's CAP_PROP_POS_MSEC), so
variable-frame-rate files keep their real timing, and orientation metadata turns the picture as players show it.
A reader seeks only to start a span of the video at one of its key frames (`start_s`), and then yields exactly the
frames a reader from the beginning yields from that time on. A decoded 4:2:0 frame stays in its YUV planes (`Picture`) until a part of it is
looked at: converting the whole frame to BGR costs about as much as decoding a 640x480 H.264 frame, and the tracker
needs a box around the float or the liquid. Writing uses PyAV because OpenCV's writer in this environment has no
H.264 encoder; every frame gets an explicit pts, so VFR files can be written.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import queue
import threading
from collections.abc import Generator, Iterator
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import cv2
import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.parallel import signals_held

if TYPE_CHECKING:
    import av

Codec = Literal["h264", "mpeg4"]
_ENCODERS: dict[str, Literal["libx264", "mpeg4"]] = {"h264": "libx264", "mpeg4": "mpeg4"}
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
    timed: bool = True
    """The frames carry presentation timestamps, so a reader can start a span at a key frame (`start_s`)."""

    @property
    def duration_s(self) -> float:
        """Declared length in seconds (0 when the frame count or the rate is unknown)."""
        return self.frame_count / self.fps if self.fps else 0.0


class Picture:
    """A decoded 4:2:0 picture kept in its planes; slicing converts only the sliced part to BGR.

    `picture[y0:y1, x0:x1]` equals the same slice of the whole BGR frame (BT.601 limited range, as OpenCV's and
    FFmpeg's default conversion), so a tracker that looks at a box around the float or the liquid does not pay for
    converting the whole picture; `np.asarray(picture)` converts it all (for drawing an overlay). The last converted
    box is kept, and a slice inside it is a read-only view of it: a tracker looks at nested boxes of one frame.
    """

    __slots__ = ("_last", "_u", "_v", "_y", "shape")

    def __init__(self, y: np.ndarray, u: np.ndarray, v: np.ndarray) -> None:
        self._y, self._u, self._v = y, u, v
        self.shape = (*y.shape, 3)
        self._last: tuple[int, int, int, int, np.ndarray] | None = None

    def __getitem__(self, key: tuple[slice, slice]) -> np.ndarray:
        """The BGR pixels of a (rows, columns) slice; the crop is widened to even edges for the half-size chroma."""
        h, w = self._y.shape
        y0, y1, _ = key[0].indices(h)
        x0, x1, _ = key[1].indices(w)
        if y1 <= y0 or x1 <= x0:
            return np.zeros((max(0, y1 - y0), max(0, x1 - x0), 3), np.uint8)
        if self._last is not None:
            Y0, X0, Y1, X1, bgr = self._last
            if Y0 <= y0 < y1 <= Y1 and X0 <= x0 < x1 <= X1:
                return bgr[y0 - Y0 : y1 - Y0, x0 - X0 : x1 - X0]
        Y0, X0, Y1, X1 = y0 - y0 % 2, x0 - x0 % 2, y1 + y1 % 2, x1 + x1 % 2
        hh, ww = Y1 - Y0, X1 - X0
        n, q = hh * ww, hh * ww // 4
        buf = np.empty(n + 2 * q, np.uint8)  # I420 layout: Y rows, then the U plane, then the V plane
        buf[:n].reshape(hh, ww)[:] = self._y[Y0:Y1, X0:X1]
        buf[n : n + q].reshape(hh // 2, ww // 2)[:] = self._u[Y0 // 2 : Y1 // 2, X0 // 2 : X1 // 2]
        buf[n + q :].reshape(hh // 2, ww // 2)[:] = self._v[Y0 // 2 : Y1 // 2, X0 // 2 : X1 // 2]
        bgr = cv2.cvtColor(buf.reshape(hh * 3 // 2, ww), cv2.COLOR_YUV2BGR_I420)
        bgr.flags.writeable = False
        self._last = (Y0, X0, Y1, X1, bgr)
        return bgr[y0 - Y0 : y1 - Y0, x0 - X0 : x1 - X0]

    def convert_all(self) -> None:
        """Convert the whole picture now, so that every slice after is a view of it (a picture an overlay is drawn on:
        the tracker reads the same pixels as without one)."""
        self[:, :]

    @property
    def luma(self) -> np.ndarray:
        """The luma plane as decoded (a read-only view): grey levels for comparing pictures, converting nothing."""
        view = self._y.view()
        view.flags.writeable = False
        return view

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        """The whole picture as a new, writable BGR array."""
        return np.array(self[:, :], dtype=dtype)

    def shrunk(self, factor: int) -> Picture:
        """The picture reduced `factor` times each way (`shrunk`), its planes averaged before any conversion."""
        h, w = shrunk_size(self._y.shape, factor)
        return Picture(
            _area(self._y, h, w, factor), _area(self._u, h // 2, w // 2, factor), _area(self._v, h // 2, w // 2, factor)
        )


def shrunk_size(shape: tuple[int, ...], factor: int) -> tuple[int, int]:
    """(height, width) of a picture of `shape` reduced `factor` times each way: even, for the half-size chroma."""
    return shape[0] // factor & ~1, shape[1] // factor & ~1


def _area(plane: np.ndarray, h: int, w: int, factor: int) -> np.ndarray:
    """`plane`'s top-left h x w blocks of factor x factor pixels, each averaged into one."""
    return cv2.resize(plane[: h * factor, : w * factor], (w, h), interpolation=cv2.INTER_AREA)


def shrunk(picture: np.ndarray | Picture, factor: int) -> np.ndarray | Picture:
    """The picture reduced `factor` (a whole number) times each way by averaging blocks of factor x factor pixels (the
    rows and columns beyond the last whole block of an even-sized result left out): a pixel (x, y) of the result
    covers x * factor .. x * factor + factor - 1 of the picture's. A Picture stays one."""
    if factor == 1:
        return picture
    if isinstance(picture, Picture):
        return picture.shrunk(factor)
    h, w = shrunk_size(picture.shape, factor)
    return _area(picture, h, w, factor)


_ROTATIONS = {90: cv2.ROTATE_90_COUNTERCLOCKWISE, 180: cv2.ROTATE_180, 270: cv2.ROTATE_90_CLOCKWISE}
"""Display-matrix rotations (counter-clockwise degrees, as FFmpeg reports them) and the turn that shows the picture."""


def _plane(frame: av.VideoFrame, index: int) -> np.ndarray:
    """One plane of a decoded frame as a 2-D uint8 view (no copy; row padding cut off)."""
    plane = frame.planes[index]
    return np.frombuffer(memoryview(plane), np.uint8).reshape(plane.height, plane.line_size)[:, : plane.width]


def _as_shown(frame: av.VideoFrame, lazy: bool) -> np.ndarray | Picture:
    """The decoded frame as displayed: a Picture (when `lazy`) or a BGR array; other pixel formats, full-range
    video and turned pictures go through FFmpeg's own conversion to BGR."""
    rotation = round(frame.rotation) % 360
    plain = frame.format.name == "yuv420p" and frame.color_range != 2 and frame.width % 2 == 0 == frame.height % 2
    if plain and rotation == 0:
        picture = Picture(_plane(frame, 0), _plane(frame, 1), _plane(frame, 2))
        return picture if lazy else picture[:, :]
    bgr = frame.to_ndarray(format="bgr24")
    return cv2.rotate(bgr, _ROTATIONS[rotation]) if rotation in _ROTATIONS else bgr


def _decode_threads(multithreaded: bool) -> int:
    """FFmpeg decoding threads: one per core (on a busy machine a reader with fewer runnable threads than the
    other programs gets less of the processor), one when many videos run side by side."""
    return max(1, os.cpu_count() or 1) if multithreaded else 1


X264_UP_TO_AVX2 = "MMX2,SSE,SSE2,SSE3,SSSE3,SSE4.1,SSE4.2,AVX,FMA3,BMI1,BMI2,AVX2,LZCNT"
"""x264's instruction sets up to AVX2, every one of which a CPU with AVX-512 has."""


def _x264_determinism() -> dict[str, str]:
    """x264 options that make the same frames encode to the same video on this CPU.

    On CPUs with AVX-512, x264's AVX-512 code gave a different video for the same frames from run to run
    (PyAV 18.1's libx264: every frame of a seeded 4 s render differed; with AVX2 code and with C code, none did).
    A seeded render must repeat, so x264 is held to AVX2 there. The AVX2 code is as fast. Other CPUs keep x264's own
    choice: naming instruction sets a CPU lacks would crash it.
    """
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        return {}
    return {"x264-params": f"asm={X264_UP_TO_AVX2}"} if " avx512f" in flags else {}


@dataclass
class FrameReader:
    """Iterate (index, t_s, frame) over a video sequentially; afterwards `decoded` and `lost_share` tell
    how much of the declared content could actually be decoded (a truncated file decodes only a prefix)."""

    path: Path
    multithreaded: bool = True
    """Decode in a background thread (FFmpeg releases the GIL), so the caller's per-frame work overlaps decoding;
    off when many videos run side by side and each should use one core."""
    pictures: bool = False
    """Yield `Picture`s, which convert only the sliced part to BGR, instead of whole BGR arrays (the tracker)."""
    start_s: float | None = None
    """Yield the frames from this presentation time on (a key frame's, as `key_frame_times` gives them): decoding
    starts at the key frame at or before it, found by seeking."""
    end_s: float | None = None
    """Yield only the frames before this presentation time."""
    shrink: int = 1
    """Yield the pictures reduced this many times each way (`shrunk`); `info` keeps the video's own size."""
    info: VideoInfo = field(init=False)
    decoded: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        import av  # PyAV decodes: its frames keep the YUV planes, so only the parts looked at are converted

        self.path = Path(self.path)
        if not self.path.exists():
            raise UserError(f"video {self.path} does not exist.")
        if not self.path.is_file():
            raise UserError(f"video {self.path} is not a file.")
        if self.path.stat().st_size == 0:
            raise UserError(f"video {self.path} is empty (0 bytes).")
        try:
            self._container = av.open(str(self.path))
        except (av.FFmpegError, ValueError) as exc:
            raise UserError(
                f"{self.path} is not a video FFmpeg can decode (or it is cut off before its index)."
            ) from exc
        streams = self._container.streams.video
        if not streams:
            self._container.close()
            raise UserError(f"{self.path} contains no video frames.")
        stream = self._stream = streams[0]
        threads = _decode_threads(self.multithreaded)
        stream.thread_type, stream.thread_count = ("AUTO" if threads > 1 else "NONE"), threads
        self._start = stream.start_time or 0
        if self.start_s is not None:  # the last key frame at or before start_s: a frame early, never a frame late
            ticks = int(self.start_s / self._time_base()) + self._start
            self._container.seek(ticks, stream=stream, backward=True, any_frame=False)
        self._frames = self._decode_frames(av.FFmpegError)
        self._first = next(self._frames, None)
        if self._first is None:
            self._container.close()
            raise UserError(f"{self.path} contains no video frames.")
        h, w = _as_shown(self._first, True).shape[:2]
        fps = float(stream.average_rate or stream.guessed_rate or 0.0)
        count = stream.frames or (round(float(stream.duration * self._time_base()) * fps) if stream.duration else 0)
        self.info = VideoInfo(self.path, w, h, fps, int(count), self._first.pts is not None)

    def _time_base(self) -> Fraction:
        """The video stream's time base (seconds per timestamp tick)."""
        if self._stream.time_base is None:
            raise UserError(f"{self.path}: its video stream has no time base, so its timestamps cannot be read.")
        return self._stream.time_base

    def _decode_frames(self, errors: type[Exception]) -> Generator[av.VideoFrame, None, None]:
        """PyAV frames in order until the end or the first undecodable data (a truncated file)."""
        frames = self._container.decode(self._stream)
        while True:
            try:
                frame = next(frames)
            except (StopIteration, EOFError, errors):
                return
            yield frame

    def _timed(self, frame: av.VideoFrame) -> tuple[float, np.ndarray | Picture]:
        """(presentation time in seconds from the stream's start, picture as shown)."""
        if frame.pts is None:  # no timestamp: evenly spaced at the declared rate
            t_s = self.decoded / (self.info.fps or 30.0)
        elif frame.time_base is None:
            raise UserError(f"{self.path}: frame {self.decoded} has a timestamp but no time base.")
        else:
            t_s = float((frame.pts - self._start) * frame.time_base)
        return t_s, shrunk(_as_shown(frame, self.pictures), self.shrink)

    def _produce(self) -> Generator[tuple[float, np.ndarray | Picture], None, None]:
        """(t_s, picture) of every frame of the span, the one decoded at opening first."""
        frames: Iterator[av.VideoFrame] = self._frames
        if self._first is not None:
            frames = itertools.chain([self._first], frames)
            self._first = None
        for frame in frames:
            t_s, picture = self._timed(frame)
            if self.start_s is not None and t_s < self.start_s:
                continue
            if self.end_s is not None and t_s >= self.end_s:
                return
            yield t_s, picture

    def __iter__(self) -> Generator[tuple[int, float, np.ndarray | Picture], None, None]:
        """Frames in order (decoded in a background thread unless multithreaded is off)."""
        items = self._threaded() if self.multithreaded else self._produce()
        try:
            for t_s, picture in items:
                yield self.decoded, t_s, picture
                self.decoded += 1
        finally:
            items.close()  # stops and joins the decoding thread: closing the file under it crashes FFmpeg
            self._container.close()

    def _threaded(self) -> Generator[tuple[float, np.ndarray | Picture], None, None]:
        """The producer's items, decoded and converted in a background thread (FFmpeg releases the GIL)."""
        frames: queue.Queue[tuple[float, np.ndarray | Picture] | None] = queue.Queue(maxsize=8)
        stop = threading.Event()

        def produce() -> None:
            try:
                for item in self._produce():
                    if stop.is_set():
                        return
                    frames.put(item)
            finally:
                frames.put(None) if not stop.is_set() else None

        worker = threading.Thread(target=produce, daemon=True)
        try:
            with signals_held():  # interrupted while starting, the thread would run on unseen and decode a closed file
                worker.start()
            while (item := frames.get()) is not None:
                yield item
        finally:
            stop.set()
            while worker.is_alive():  # unblock a producer waiting on a full queue
                with contextlib.suppress(queue.Empty):
                    frames.get_nowait()
                worker.join(timeout=0.01)

    def close(self) -> None:
        """Close the file of a reader whose frames will not be iterated (iterating closes it at the end). The decoding
        generator goes too: it refers back to the reader, which would otherwise wait for the garbage collector with
        FFmpeg's decoding threads, and a process forked later would free them there and hang."""
        self._frames.close()
        self._first = None
        self._container.close()

    @property
    def lost_share(self) -> float:
        """Share of the declared frames that did not decode (0 when complete or when the count is unknown)."""
        return lost_share(self.info.frame_count, self.decoded)

    def first_picture(self) -> np.ndarray | Picture:
        """The first frame decoded at opening, as iterating would give it (without taking it from the iteration)."""
        if self._first is None:
            raise ValueError("the reader's first picture was already taken by iterating it (or it was closed)")
        return shrunk(_as_shown(self._first, self.pictures), self.shrink)

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) in pixels after orientation is applied."""
        return self.info.width, self.info.height


def lost_share(declared: int, decoded: int) -> float:
    """Share of the declared frames that did not decode (0 when complete or when the count is unknown)."""
    return max(0.0, (declared - decoded) / declared) if declared else 0.0


def encoded_size(width: int, height: int) -> tuple[int, int]:
    """(width, height) a VideoWriter writes frames of this size at: even, for yuv420p's half-size chroma (an odd size
    loses its last column or row)."""
    return width - width % 2, height - height % 2


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
        (stream.width, stream.height), stream.pix_fmt = encoded_size(width, height), "yuv420p"
        if codec == "h264":
            crf = 23 if quality is None else quality
            stream.options = {"crf": f"{crf:g}", "preset": "veryfast", **_x264_determinism()}
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
