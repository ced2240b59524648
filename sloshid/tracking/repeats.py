"""Frames the encoder repeated: an object whose edges are copies of the previous frame was not measured anew.

Inter-frame codecs (H.264, MPEG-4) copy a block from the previous frame when its motion is below what they
bother to code ("skip" blocks). While a float or a surface moves by a fraction of a pixel per frame (small
amplitudes, high frame rates, low bit rates) its edges then freeze for several frames and jump later: a
measurement of a frozen picture is an old measurement under a new timestamp. Such lags grow as the slosh
decays, so they bias the identified frequency low and the damping high. Marking those frames as not valid
keeps only measurements of pictures the encoder actually updated. A run of repeats counts only when the object
moved across it (the fresh measurements on either side differ by more than noise): a float at rest is
rightly copied, and its frames stay valid.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from sloshid.video.frames import Picture

REPEAT_SHARE = 0.5
"""A frame whose object edges are at least this share unchanged copies of the previous frame is a repeat."""
MOVED_DEG = 0.15
"""A run of repeats hides motion when the fresh angles around it differ by more than this (about 2 sigma of the
difference of two measurements at the tracker's 0.05 deg noise)."""
LOOKBACK_FRAMES = 10
"""A run of repeats whose object stood still over this many frames before it (its fresh angles there within
MOVED_DEG) and moved only after it is a copy of an object at rest (a tap after a still start)."""


def repeated_share(
    frame: np.ndarray | Picture,
    previous: np.ndarray | Picture | None,
    box: tuple[int, int, int, int],
    dy_only: bool,
    lumas: tuple = (None, None),
) -> float:
    """Share of the strong edge pixels in `box` (x0, y0, x1, y1) whose grey level equals the previous frame's.

    dy_only counts only vertical intensity steps (a surface line), so static vertical edges such as highlight
    stripes on the glass do not count as repeated. OpenCV calls only: this runs for every frame. `lumas`: grey
    crops of this and the previous frame that the tracker made anyway, each (array, (x, y) of its corner) or None;
    the box is read from them when both hold it (the same grey levels, without converting the pictures again), else
    from the luma planes of two decoded pictures (`Picture`), else converted.
    """
    if previous is None or previous.shape != frame.shape:
        return 0.0
    x0, y0, x1, y1 = (int(v) for v in box)
    x0, y0 = max(x0, 0), max(y0, 0)
    if x1 - x0 < 3 or y1 - y0 < 3:
        return 0.0
    cur, old = (_box_of(luma, (x0, y0, x1, y1)) for luma in lumas)
    if (cur is None or old is None) and isinstance(frame, Picture) and isinstance(previous, Picture):
        cur, old = frame.luma[y0:y1, x0:x1], previous.luma[y0:y1, x0:x1]  # as decoded: nothing to convert
    elif cur is None or old is None:
        cur = cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY)
        old = cv2.cvtColor(previous[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY)
    grad = cv2.convertScaleAbs(cv2.Sobel(cur, cv2.CV_16S, 0, 1, ksize=3), alpha=0.25)
    if not dy_only:
        grad = cv2.add(grad, cv2.convertScaleAbs(cv2.Sobel(cur, cv2.CV_16S, 1, 0, ksize=3), alpha=0.25))
    top = cv2.minMaxLoc(grad)[1]
    # OpenCV's stubs type compare's src2 as an array only; OpenCV takes a scalar there too (its docs: "array or scalar")
    edges = cv2.compare(grad, 0.3 * top, cv2.CMP_GT)  # type: ignore[call-overload]
    n = cv2.countNonZero(edges)
    if top <= 0 or n == 0:
        return 0.0
    same = cv2.compare(cur, old, cv2.CMP_EQ)
    return cv2.countNonZero(cv2.bitwise_and(same, edges)) / n


class Copies:
    """The frames whose picture, where the last measured frame's row was read (the float, or the surface, the liquid's
    sides and its bottom, and the container walls when they are measured), is the encoder's copy of that frame's
    (every strong edge pixel of each region unchanged): they are not measured again, as a copied picture measures as
    its original, and take the measured frame's row. They are repeats (`stale_repeats` judges them with the others).
    Compared with the measured frame, not the one before: an encoder updates a slowly moving float's blocks a few at a
    time (frames each half the same as the one before drifted 0.3 deg over nine of them); and over the walls and the
    bottom too: a flat surface band stays the same while the container turns or slides under it (a container turning
    3 deg under level liquid read a staircase of 0.7 deg when only the band was compared). Only the edges: the noise
    an encoder re-codes in flat parts (the liquid's body) moves no measurement, and left 6 of 7 copies uncounted."""

    def __init__(self) -> None:
        self.last: tuple | None = None  # (frame in the span, its picture, regions, what the step keeps) of the last
        self.of: dict[int, int] = {}  # copied frame -> the measured frame whose row it takes

    def source(self, frame: np.ndarray, index: int) -> tuple | None:
        """What the step kept of the last measured frame when frame `index` copies its picture in every region (noted
        as that frame's copy), else None."""
        if self.last is None:
            return None
        _, picture, regions, kept = self.last
        if not all(repeated_share(frame, picture, box, dy_only) >= 1.0 for box, dy_only in regions):
            return None
        self.of[index] = self.last[0]
        return kept

    def measured(self, index: int, frame: np.ndarray, regions: list[tuple] | None, kept: tuple) -> None:
        """Frame `index` was measured from `regions` ((x0, y0, x1, y1), dy_only as `repeated_share` takes them; None:
        the object was not found, so no frame copies it)."""
        self.last = None if regions is None else (index, frame, regions, kept)

    def fill(self, rows: list) -> None:
        """Give each copied frame (in `rows`: the span's TrackRows, or tuples with the time first; changed in place)
        its measured frame's row at its own time; the measured frame is let go (its picture holds the decoder's
        buffers)."""
        for i, source in self.of.items():  # a source is a measured frame, final by now
            own = rows[i]
            rows[i] = rows[source]._replace(t_s=own.t_s) if hasattr(own, "t_s") else (own[0], *rows[source][1:])
        self.of, self.last = {}, None


def line_regions(lines, pad: int = 4) -> list[tuple]:
    """`Copies` regions along near-vertical lines x = a y + b from row y0 to y1 (walls: `(a, b, y0, y1)`, or objects
    with those attributes), `pad` pixels on each side, with their edges in either direction."""
    regions = []
    for line in lines:
        a, b, y0, y1 = (line.a, line.b, line.y0, line.y1) if hasattr(line, "a") else line
        xs = (a * y0 + b, a * y1 + b)
        box = (math.floor(min(xs)) - pad, math.floor(y0), math.ceil(max(xs)) + pad + 1, math.ceil(y1) + 1)
        regions.append((box, False))
    return regions


def _box_of(luma: tuple | None, box: tuple[int, int, int, int]) -> np.ndarray | None:
    """The frame box (x0, y0, x1, y1) of a grey crop (array, (x, y) of its corner), or None when it is not all in it."""
    if luma is None:
        return None
    grey, (x, y) = luma
    x0, y0, x1, y1 = box
    if x0 < x or y0 < y or x1 > x + grey.shape[1] or y1 > y + grey.shape[0]:
        return None
    return grey[y0 - y : y1 - y, x0 - x : x1 - x]


def stale_repeats(angle: np.ndarray, valid: np.ndarray, repeated: list[bool]) -> np.ndarray:
    """Repeated frames inside runs across which the object moved: the frames whose measurement is out of date. A run
    whose object was at rest before it, and moved only after it, is a still picture copied: its frames are not."""
    rep = np.asarray(repeated, bool)
    fresh = np.flatnonzero(valid & ~rep)
    stale = np.zeros(len(rep), bool)
    k = 0
    while k < len(rep):
        if not rep[k]:
            k += 1
            continue
        end = k
        while end < len(rep) and rep[end]:
            end += 1
        before, after = fresh[fresh < k], fresh[fresh >= end]
        if before.size and after.size and abs(angle[after[0]] - angle[before[-1]]) > MOVED_DEG:
            stale[k:end] = not _still_until(angle, before, after, k)
        k = end
    return stale


def _still_until(angle: np.ndarray, before: np.ndarray, after: np.ndarray, start: int) -> bool:
    """The object stood still up to a run of repeats starting at `start` and began to move at its end (`before`,
    `after`: the fresh frames around the run): the jump across the run is no larger than two frames of the motion
    that follows it, or spread over the run's frames it is less than half a frame of that motion (a run that held
    motion jumps by its length of it; a tap's first frame can hold most of its rise: 5.6 deg, then 2.3 deg a frame),
    and the fresh angles in the LOOKBACK_FRAMES before the run, when three lie there, span no more than MOVED_DEG."""
    if after.size < 2:
        return False
    jump = abs(angle[after[0]] - angle[before[-1]])
    rate = abs(angle[after[1]] - angle[after[0]]) / (after[1] - after[0])
    if jump > 2 * rate and jump / (after[0] - before[-1]) > 0.5 * rate:
        return False
    recent = angle[before[before >= start - LOOKBACK_FRAMES]]
    return recent.size < 3 or float(recent.max() - recent.min()) <= MOVED_DEG
