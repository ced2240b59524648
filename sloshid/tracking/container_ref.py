"""Measure the container's own orientation in every frame from its two straight, near-vertical side walls.

The walls are found once with a Hough transform (the nearest near-vertical lines left and right of
the float) and then followed frame to frame: in a narrow band around each predicted wall, every row's
strongest falling and rising intensity edge is located to sub-pixel precision (parabola through the
gradient peak, unbiased for any edge contrast), and a robust straight-line fit per edge gives the wall's
angle. Each wall's angle is the precision-weighted mean of its well-fitting edges, and the container
angle is the mean of the two walls (CCW positive as seen, 0 when the walls are vertical in the picture),
so a tapered glass, whose walls lean in opposite directions, reads upright. That mean is the projected axis of a
body of revolution seen by a camera whose view centre lies in the plane of the axis and the camera (its two outlines
are mirror images in that plane); on the physically based renders it is within 0.04 deg of the axis. Where the rows'
edges do not hold (faint glass), the walls are the glass's longest straight edges near the liquid's sides or the Hough
lines (`glass_walls`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import overload

import cv2
import numpy as np

from sloshid.tracking.robust import MAD_SIGMA, masked_median, median, robust_lines, running_median, scatter
from sloshid.video.frames import Picture

BAND_PX = 9
"""Half-width of the band searched around a predicted wall line, pixels."""
HOLD_FRAMES = 6
"""While the container stands still, the walls are measured in every HOLD_FRAMES-th frame and the last measurement is
returned, marked held, in between, as long as they turned by less than STEADY_DEG per HOLD_FRAMES - 1 frames between
their last two measurements (and shifted by less than STEADY_PX): a tilt too slow to move the liquid's bottom by half
a pixel. A frame is held when the caller saw nothing move (the surface tracker: a band frame, the liquid's sides and
bottom where they were in the last whole-body frame; the float tracker cannot tell) and the walls' own ends confirm
it (GUARD_PX). The caller gives the held frames their angles from the measurements around them (`held_angles`)."""
STEADY_DEG = 0.02
"""Largest turn of walls held over HOLD_FRAMES - 1 frames: about 3 standard deviations of the difference of two
measurements (0.005 deg each on a two-minute 640x480 H.264 clip)."""
STEADY_PX = 0.1
"""Largest sideways shift of walls held over HOLD_FRAMES - 1 frames, pixels."""
GUARD_ROWS = 8
"""Rows at each end of a wall's band that a frame compares with the last measurement's (GUARD_PX)."""
GUARD_PX = 0.25
"""A frame is held only when each wall's two ends (GUARD_ROWS rows at the top and at the bottom of the edges followed)
moved by less than this since the walls were measured (a Lucas-Kanade shift of their grey profiles against the
measured frame's luma, and their edges' centroid by less than a pixel); more is a jolt or a turn, measured at once."""


@dataclass
class EdgeLine:
    """A wall edge as x = a * y + b in image coordinates (near-vertical lines are single-valued in y)."""

    a: float
    b: float
    y0: int
    y1: int
    rms_px: float
    rows: int

    @overload
    def x_at(self, y: float) -> float: ...
    @overload
    def x_at(self, y: np.ndarray) -> np.ndarray: ...
    def x_at(self, y: np.ndarray | float) -> np.ndarray | float:
        """x of the line at image row(s) y."""
        return self.a * y + self.b

    @property
    def angle_deg(self) -> float:
        """CCW-as-seen tilt of the line from the image vertical (top leaning left is positive)."""
        return math.degrees(math.atan(self.a))


@dataclass
class ContainerMeasurement:
    """The container's measured orientation in one frame."""

    found: bool
    angle_deg: float = math.nan
    edges: tuple[EdgeLine, ...] = ()
    held: bool = False
    """Not measured in this frame: the last measurement, returned again (see HOLD_FRAMES)."""
    unmoved: bool = False
    """Measured at the end of a hold, with the walls' ends where the measurement before saw them (GUARD_PX): the held
    frames between may be interpolated (`held_angles`)."""


def _band_luma(frame: np.ndarray, ys: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Grey levels (float32: edge profiles are differenced) of the pixels (ys, cols[k]) of each wall k (`cols`: walls
    x rows x band columns, inside the picture): only the box each wall's band spans is converted, not the container
    between them."""
    grey = np.empty(cols.shape, np.float32)
    rows = (ys - ys[0])[:, None]
    for k, c in enumerate(cols):
        x0 = int(c.min())
        box = cv2.cvtColor(frame[ys[0] : ys[-1] + 1, x0 : int(c.max()) + 1], cv2.COLOR_BGR2GRAY)
        grey[k] = box[rows, c - x0]
    return grey


def _grey_at(frame: np.ndarray | Picture, ys: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Grey levels of the pixels (ys, cols[k]) as `_band_luma` indexes them, for comparing frames: a Picture's luma
    plane as decoded (nothing converted), else the converted boxes."""
    if isinstance(frame, Picture):
        return frame.luma[ys[:, None], cols].astype(np.float32)
    return _band_luma(frame, ys, cols)


def _edges_of(grey: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of each block of grey profiles (blocks, e.g. a wall's end, x rows x band columns): the gradient along the
    columns (central differences: column j + 1), its energy and the energy's centroid column."""
    grad = 0.5 * (grey[..., 2:] - grey[..., :-2])
    per_column = np.einsum("brc,brc->bc", grad, grad)
    energy = per_column.sum(axis=1)
    return grad, energy, per_column @ np.arange(grad.shape[2]) / np.maximum(energy, 1.0)


def _band_shift(reference: np.ndarray, edges: tuple, now: np.ndarray) -> np.ndarray:
    """The sideways shift (px) of each block of grey profiles from `reference` (its `_edges_of`) to `now`: one
    Lucas-Kanade step over the block's rows, each row's mean change removed (exposure). NaN where the reference has
    no edge, or where the edges moved by a pixel or more (their energy's centroid): one step reads a thin wall moved
    by several pixels as a small shift (6 px as 0.07 px)."""
    grad, energy, centroid = edges
    change = (now - reference)[..., 1:-1]
    change -= change.mean(axis=2, keepdims=True)
    shift = -np.einsum("brc,brc->b", grad, change) / np.maximum(energy, 1.0)
    return np.where((energy > 1.0) & (np.abs(_edges_of(now)[2] - centroid) < 1.0), shift, np.nan)


def held_angles(measured: list[tuple[int, float, bool]], held: list[int], copied: Sequence[int] = ()) -> np.ndarray:
    """Container angles of the held frames `held` (frame numbers, each after a measurement) from the measured ones
    (frame number, angle, `ContainerMeasurement.unmoved`; in order): linear between the measurements that began and
    ended a frame's hold when the walls' ends at its end were where they were at its start (a slow tilt); else the
    held value: the turn or jolt came at the hold's end, after the frames held. The held value too when the next
    measurement is not the hold's end (the walls were lost) or there is none. `copied`: frames (in order) that
    copied a measured picture (`Copies`): nobody asked for the walls there, so they do not lengthen a hold."""
    at, angle, unmoved = (np.array(v) for v in zip(*measured))
    frames = np.asarray(held)
    k = np.searchsorted(at, frames)  # at[k - 1] < frame < at[k]: the measurements before and after
    if (k == 0).any():
        raise ValueError("a held frame comes before the walls' first measurement")
    after = np.minimum(k, at.size - 1)
    gap = at[after] - at[k - 1]
    asked = gap - (np.searchsorted(copied, at[after]) - np.searchsorted(copied, at[k - 1]))
    smooth = (k < at.size) & (asked <= HOLD_FRAMES) & unmoved[after]
    return angle[k - 1] + np.where(smooth, (frames - at[k - 1]) / np.maximum(gap, 1), 0.0) * (
        angle[after] - angle[k - 1]
    )


STEADY_RUN = 5
"""... and whose running median over this many frames (a misread frame or two, as a meniscus or a label gives, left
out) stays within STEADY_DEPART noises of the median."""
STEADY_DEPART = 12.0
"""A real frame turned by 4 deg in 14 of 30 frames had both robust scatters at the noise's and was taken for still (its
moving frames measured in the still ones' axes: a 3.4 deg slosh that was the turn); its running median left the median
by 33-142 noises, a robot's move in the corpus by 16. The walls read along a sloshing liquid wander with it by up to 6
(a path-traced tap decay), where the median reads the container better than each frame."""
STEADY_FLOOR_DEG = 0.03
"""Walls whose robust scatter and running median stay within this of their median stood still, however small their
frame-to-frame noise: a Blender tap decay's walls, read every frame to 0.002 deg, drifted 0.02 deg with the slosh
(their scatter 5 noises), so its first frame's walls, read 2.2 deg off, went into its relative angle. At 0.1 a painted
container rocking by 0.06 deg was taken for still (0.044 deg RMS into the angle)."""
STEADY_SPREAD = 1.3
"""A container angle series (valid frames) whose robust scatter about its median is at most this many times its
frame-to-frame noise (the differences' robust scatter over sqrt 2) shows no motion beyond that noise: white noise
gives 1 within a tenth at 100 frames, a slosh's tilt or a robot's move many times more."""


def steady_angle(angle: np.ndarray, valid: np.ndarray, floor: float = 0.0) -> float | None:
    """The container's angle when it stood still for the whole clip while its walls were measured in every frame (a
    noisy picture keeps them from being held): the median of the measurements, or None when they show motion (or
    the walls were held, so that consecutive frames repeat a value), or fewer than 20 frames are valid. `floor`: a
    scatter and a running median within this of the median never show motion (`STEADY_FLOOR_DEG`)."""
    a = np.asarray(angle, float)[np.asarray(valid, bool)]
    if a.size < 20:
        return None
    d = np.diff(a)
    noise = scatter(d) / math.sqrt(2)
    if noise <= 0:
        return None
    centre = median(a)
    if scatter(a) > max(STEADY_SPREAD * noise, floor):
        return None
    # a move in fewer than half the frames leaves both robust scatters at the noise: the frames' running median shows it
    running = running_median(a, STEADY_RUN)
    return float(centre) if np.max(np.abs(running - centre)) <= max(STEADY_DEPART * noise, floor) else None


@dataclass
class WallsRecord:
    """A span's wall measurements by frame, from which its held frames get their angles at its end (`held_angles`)."""

    measured: list[tuple[int, float, bool]] = field(default_factory=list)
    """(frame, container angle, `ContainerMeasurement.unmoved`) of the frames whose walls were measured."""
    held: list[int] = field(default_factory=list)
    """The frames whose walls were held."""
    copied: list[int] = field(default_factory=list)
    """The frames that copied a measured picture (`Copies`): the walls were not asked for."""

    def add(self, frame: int, cm: ContainerMeasurement) -> None:
        """Note frame `frame`'s walls: measured, held, or (not found) nothing."""
        if cm.held:
            self.held.append(frame)
        elif cm.found:
            self.measured.append((frame, cm.angle_deg, cm.unmoved))

    def held_angles(self) -> dict[int, float]:
        """The held frames' container angles (`held_angles`); the record starts afresh."""
        angles: np.ndarray | list[float] = held_angles(self.measured, self.held, self.copied) if self.held else []
        out = dict(zip(self.held, map(float, angles)))
        self.measured, self.held, self.copied = [], [], []
        return out


def _edge_points(grad: np.ndarray, usable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of each edge's gradient profiles (`grad`: edges, rows, columns; signed so that the edge's polarity
    is positive), the sub-pixel column where the gradient peaks (parabola through the peak and its neighbours,
    unbiased for any edge contrast), and whether the row has a clear peak: inside the profile, strong (above 4 grey
    levels and 0.35 of the edge's median peak) and curved. `usable`: rows whose profile lies in the picture."""
    width = grad.shape[2]
    j = np.argmax(grad, axis=2)
    flat = grad.reshape(-1)  # the peak and its neighbours by flat index: a third of take_along_axis' cost
    at = np.arange(0, flat.size, width).reshape(j.shape) + j
    g0, g1, g2 = flat[np.maximum(at - 1, 0)], flat[at], flat[np.minimum(at + 1, flat.size - 1)]
    ok = usable & (j > 0) & (j < width - 1)
    typical = np.nan_to_num(masked_median(g1, ok), nan=0.0)
    denom = g0 - 2 * g1 + g2
    ok &= (g1 > np.maximum(4.0, 0.35 * typical)[:, None]) & (denom < 0)
    return j + 0.5 * (g0 - g2) / np.where(ok, denom, -1.0), ok


def detect_walls(
    frame: np.ndarray, float_x: float, float_y: float, float_len: float, roi: tuple[int, int, int, int]
) -> tuple[list[EdgeLine], list[EdgeLine]]:
    """First frame: long near-vertical Hough lines left and right of the float, as coarse edges: the nearest on each
    side (whose edges `_follow` fits row by row), and the strongest within WALL_REACH float lengths (the glass's
    edges' seeds when those rows are too noisy: there the nearest were often lines inside the liquid, its refraction
    or a label's edge)."""
    x, y, w, h = roi
    gray = cv2.GaussianBlur(cv2.cvtColor(frame[y : y + h, x : x + w], cv2.COLOR_BGR2GRAY), (0, 0), 1.0)
    edges = cv2.Canny(gray, 30, 90)
    min_len = max(20, int(0.6 * float_len))
    lines = cv2.HoughLines(edges, 1, np.pi / 720, min_len, min_theta=0, max_theta=np.pi)
    if lines is None:
        return [], []
    nearest: dict[int, tuple[float, EdgeLine]] = {}
    strongest: dict[int, EdgeLine] = {}
    span = int(1.5 * float_len)
    for rho, theta in lines[:, 0]:
        if theta > np.pi / 2:
            rho, theta = -rho, theta - np.pi
        if abs(theta) > math.radians(25):
            continue
        # rho = x cos(t) + y sin(t)  ->  x = (rho - y sin t)/cos t in ROI coordinates
        a = -math.tan(theta)
        b = rho / math.cos(theta) - a * y + x  # back to frame coordinates
        xf = a * float_y + b
        side = -1 if xf < float_x - 0.5 * float_len else (1 if xf > float_x + 0.5 * float_len else 0)
        if side == 0:
            continue
        line, dist = EdgeLine(a, b, int(float_y - span), int(float_y + span), math.inf, 0), abs(xf - float_x)
        if side not in nearest or dist < nearest[side][0]:
            nearest[side] = (dist, line)
        if side not in strongest and dist <= WALL_REACH * float_len:  # OpenCV lists the lines by their votes
            strongest[side] = line
    return [nearest[s][1] for s in sorted(nearest)], [strongest[s] for s in sorted(strongest)]


WALL_REACH = 4.0
"""How far from the float (in float lengths) a wall may be: a float spans a quarter of the width or more."""


GLASS_SLOPES = np.linspace(-0.03, 0.03, 31)
"""Slope changes (x per row, about +-1.7 deg) tried about a wall's seed line by `glass_edges`: the liquid's sides give
the walls to about a degree. The best is searched again about itself in GLASS_FINE steps, with offsets in quarter
pixels: on whole-pixel offsets a sharp edge half-way between two of them reads best on a line that crosses it (0.2 deg
off on a 250-row wall)."""
GLASS_FINE = 0.0002
GLASS_BLUR = 1.0
"""Gaussian blur (px) of the grey levels before their gradient: a smooth edge profile, so that the line sums' peak
between the tried offsets and slopes is found by parabolas."""


def glass_edges(frame: np.ndarray | Picture, seeds: list[EdgeLine], rows: tuple[int, int]) -> list[EdgeLine]:
    """The container's walls from the glass's own edges: for each seed line (a wall as the liquid's side gives it), the
    straight lines within BAND_PX of it, over `rows` (the glass above the liquid as well as the liquid's side), along
    which the horizontal luma gradient adds up to the most, one rising and one falling (line integrals, as a Radon
    transform's): the faint edge of empty glass counts over its whole length, and a curved or broken stretch (a bottom
    corner, a meniscus, a holder) moves them little. A wall is their mean, weighted by how far their sums exceed
    GLASS_WEAK of the stronger one's: a glass wall's two faces err independently."""
    h, w = frame.shape[:2]
    ys = np.arange(max(0, rows[0]), min(h, rows[1]))
    if ys.size < 20:
        return []
    yc = 0.5 * (ys[0] + ys[-1])
    dy = (ys - yc).astype(np.float32)[:, None]
    walls = []
    for seed in seeds:
        xs = seed.x_at(ys)
        x0, x1 = int(xs.min()) - BAND_PX - 6, int(xs.max()) + BAND_PX + 7
        if x0 < 0 or x1 > w:
            return []
        box = (slice(ys[0], ys[-1] + 1), slice(x0, x1))
        grey = frame.luma[box] if isinstance(frame, Picture) else cv2.cvtColor(frame[box], cv2.COLOR_BGR2GRAY)
        smooth = cv2.GaussianBlur(grey.astype(np.float32), (0, 0), GLASS_BLUR)
        line = _LineSums(cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3), seed.x_at(yc) - x0, dy)
        offs = np.arange(-BAND_PX, BAND_PX + 1, dtype=np.float32)
        coarse = line.sums(seed.a + GLASS_SLOPES, offs)
        edges = [e for e in (_edge_line(line, coarse * sign, seed.a, offs, sign) for sign in (1, -1)) if e]
        if edges:
            # weights that fall to zero at GLASS_WEAK of the stronger face: a face near it does not switch on and off
            top = max(e[2] for e in edges)
            weights = [e[2] - GLASS_WEAK * top for e in edges]
            a = sum(e[0] * q for e, q in zip(edges, weights)) / sum(weights)
            x_mid = seed.x_at(yc) + sum(e[1] * q for e, q in zip(edges, weights)) / sum(weights)
            walls.append(EdgeLine(float(a), float(x_mid - a * yc), int(ys[0]), int(ys[-1]) + 1, 0.0, int(ys.size)))
    return walls


GLASS_WEAK = 0.3
"""A wall's weaker face counts when its line sum is above this share of the stronger one's."""

WALL_SLOPES = 0.25
"""Slopes (x per row, about +-14 deg) about a seed that `glass_walls` tries: a liquid's side cut by a label or a holder
of its colour gave seeds 15 deg off."""
WALL_NEAR = 0.12
"""How far (share of the width between the seeds, at least BAND_PX) a wall may pass from its seed at the pivot row."""
WALL_TOL_PX = 0.8
"""Edge points this close to a line (px) support it."""
WALL_CANDIDATES = 24
"""The lines with the most points whose runs `glass_walls` compares."""
WALL_FACE = 0.5
"""A wall's second face (the other polarity's longest run) counts when it runs at least this share of the first's
length: a wall read as one face on one side and as two on the other tilts the axis (0.15 deg on a painted glass)."""
WALL_DRIFT = 0.5
"""Share of WALL_NEAR's reach by which a followed wall's offset from its liquid side may change, once both sides moved
by more than the reach, before the walls are searched afresh: a glass's walls move with its liquid, a box's edge behind
it does not (docs/design/tracking.md, "A wall held by a box behind the glass")."""
FOLLOW_SLOPE = 0.04
"""Slope change (x per row, about 2.3 deg) about a wall's last line, predicted on at its last turn, searched in the next
frame; FOLLOW_PX its sideways shift: a container swung by 20 deg at 0.3 Hz turns by 1.3 deg per frame at 30 fps."""
FOLLOW_PX = 4.0
WALL_GAP = 8
"""Rows without a point that a run of a wall's edge bridges (a faint stretch of glass, a highlight)."""
RUN_WIDTH_PX = 960.0
"""A wall's run keeps the edge points within a pixel of its line in a picture this wide, and proportionally more in a
wider one (the real frame at its native 1920 px: the glass's runs broke at half their length and another edge won,
turning the container's angle by 2.5 deg at one of seven rotations)."""


def _longest_run(rows: np.ndarray) -> tuple[int, float, float]:
    """The longest run of sorted rows with gaps of at most WALL_GAP: (rows in it, first, last)."""
    if rows.size == 0:
        return 0, 0.0, 0.0
    breaks = np.flatnonzero(np.diff(rows) > WALL_GAP + 1)
    starts, ends = np.r_[0, breaks + 1], np.r_[breaks, rows.size - 1]
    n = int(np.argmax(ends - starts))
    return int(ends[n] - starts[n] + 1), float(rows[starts[n]]), float(rows[ends[n]])


def _edge_points_2d(grey: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each row's sub-pixel edge points in a grey box: the local maxima of the horizontal gradient's magnitude above
    three robust standard deviations of it, as (row, column, sign of the gradient)."""
    g = cv2.Sobel(cv2.GaussianBlur(grey.astype(np.float32), (0, 0), GLASS_BLUR), cv2.CV_32F, 1, 0, ksize=3)
    m = np.abs(g)
    c = m[:, 1:-1]
    r, j = np.nonzero((c > 3 * MAD_SIGMA * float(np.median(m)) + 1.0) & (c >= m[:, :-2]) & (c > m[:, 2:]))
    j = j + 1
    g0, g1, g2 = m[r, j - 1], m[r, j], m[r, j + 1]
    den = g0 - 2 * g1 + g2
    return r, j + 0.5 * (g0 - g2) / np.where(den < 0, den, -np.inf), np.sign(g[r, j])


def _votes(dy: np.ndarray, dx: np.ndarray, slopes: np.ndarray, reach: float) -> np.ndarray:
    """How many points lie on each line dx = o + a dy (a in `slopes`, o = -reach..reach in 1 px steps) within a pixel:
    a Hough transform's votes (slopes x offsets)."""
    bins = int(2 * reach) + 3
    out = np.empty((slopes.size, bins - 2), int)
    for n, a in enumerate(slopes):
        k = np.rint(dx - a * dy + reach + 1).astype(np.intp)
        votes = np.bincount(k[(k >= 0) & (k < bins)], minlength=bins)
        out[n] = votes[:-2] + votes[1:-1] + votes[2:]
    return out


def glass_walls(
    frame: np.ndarray | Picture,
    seeds: list[EdgeLine],
    rows: tuple[int, int],
    prior: list | None = None,
    sides: bool = False,
) -> list[list[tuple[EdgeLine, int]]]:
    """The container's walls as the straight edges near the seeds (the liquid's sides over rows y0..y1) that run
    unbroken along the most rows of `rows`, each with its polarity: a Hough vote of every row's sub-pixel edge points
    picks the candidates, the longest run of points on a line wins, and the line sums of the gradient along its run
    place it. An edge counts by its length, so the glass's outline wins over a label's edge, a bent liquid side or a
    background edge that leaves the line at the rim. `prior`: the last frame's walls and polarities, placed again
    over their own rows (a few pixels and a degree about them). `sides`: the seeds are the liquid's sides, whose direction
    picks between a wall's two faces that are not parallel."""
    h = frame.shape[0]
    ys = np.arange(max(0, rows[0]), min(h, rows[1]))
    if len(seeds) < 2:
        return []
    for seed in seeds:  # the rows where every wall's band (as `glass_edges` reads it) lies in the picture: a seed
        xs = seed.x_at(ys)  # carried up above the liquid leaves a picture its container fills at one end only
        ys = ys[(xs - BAND_PX - 6 >= 0) & (xs + BAND_PX + 7 <= frame.shape[1])]
    if ys.size < 20:
        return []
    reach = _reach(seeds)
    out = []
    for i, seed in enumerate(seeds):
        if prior is not None:
            faces = []
            for line, sign in prior[i]:
                y0, y1 = max(line.y0, ys[0]), min(line.y1, ys[-1] + 1)
                faces.append(_place(frame, line.a, line.x_at(0.5 * (y0 + y1)), (y0, y1), sign, FOLLOW_SLOPE, FOLLOW_PX))
        else:
            faces = _longest_edges(frame, seed, ys, reach, sides)
        if not faces or None in faces:
            return []
        out.append(faces)
    return out


def _longest_edges(frame: np.ndarray | Picture, seed: EdgeLine, ys: np.ndarray, reach: float, sides: bool = False):
    """`glass_walls`' search about one seed: the longest run of each polarity that is at least WALL_FACE as long as
    the longest (a glass wall's two faces), as (line, polarity); none found: []. With `sides`, of two faces more than
    FACE_AGREE_DEG apart only the one nearer the seed's direction."""
    w = frame.shape[1]
    yc = 0.5 * (seed.y0 + seed.y1)
    xc = seed.x_at(yc)
    slopes = seed.a + np.arange(-WALL_SLOPES, WALL_SLOPES + 1e-9, 0.005)
    corners = [xc + a * (y - yc) for a in (slopes[0], slopes[-1]) for y in (ys[0], ys[-1])]
    x0, x1 = max(0, int(min(corners) - reach) - 4), min(w, int(max(corners) + reach) + 5)
    if x1 - x0 < 8:
        return None
    box = (slice(ys[0], ys[-1] + 1), slice(x0, x1))
    grey = frame.luma[box] if isinstance(frame, Picture) else cv2.cvtColor(frame[box], cv2.COLOR_BGR2GRAY)
    r, x, sg = _edge_points_2d(grey)
    dy, dx = (r + ys[0] - yc).astype(float), x + x0 - xc
    tol = max(1.0, w / RUN_WIDTH_PX)  # an edge's points scatter in proportion to the picture's size
    found = []
    for sign in (1, -1):
        best = (0, 0.0, 0.0, 0, 0.0, 0.0)
        on = sg == sign
        votes = _votes(dy[on], dx[on], slopes, reach)
        # the longest unbroken run among the lines with the most points: a line that crosses from one edge to
        # another (or through a textured liquid) gathers points, but in pieces
        for cell in np.argsort(votes, axis=None)[::-1][:WALL_CANDIDATES]:
            k, j = np.unravel_index(cell, votes.shape)
            a, o = float(slopes[k]), float(j - reach)
            near = np.abs(dx[on] - o - a * dy[on]) < tol
            run = _longest_run(np.unique(dy[on][near]))
            if run[0] > best[0]:
                best = (run[0], a, o, sign, run[1] + yc, run[2] + yc)
        found.append(best)
    longest = max(f[0] for f in found)
    faces = []
    for n, a, o, sign, y0, y1 in found:
        if n >= max(20, WALL_FACE * longest):
            faces.append(
                _place(frame, a, xc + o + a * (0.5 * (y0 + y1) - yc), (int(y0), int(y1) + 1), sign, 0.005, 1.5)
            )
    faces = [f for f in faces if f is not None]
    if sides and len(faces) == 2 and abs(faces[0][0].angle_deg - faces[1][0].angle_deg) > FACE_AGREE_DEG:
        # a glass wall's two faces are parallel: two edges that are not belong to different things; the one nearer the
        # liquid's side in direction counts
        faces = [min(faces, key=lambda f: abs(f[0].angle_deg - seed.angle_deg))]
    return faces


def _moved(line: EdgeLine, shift: float, turn: float, lift: float) -> EdgeLine:
    """A line moved sideways by `shift` (px, at its rows' middle), turned by `turn` (slope) about there and its rows
    moved down by `lift`."""
    ym = 0.5 * (line.y0 + line.y1)
    x = line.x_at(ym) + shift
    a = line.a + turn
    return replace(line, a=a, b=x - a * (ym + lift), y0=int(line.y0 + lift), y1=int(line.y1 + lift))


def mean_line(faces: list[EdgeLine]) -> EdgeLine:
    """A wall as the mean of its faces' lines (slope, and position at their rows' middle), over their rows."""
    y0, y1 = min(f.y0 for f in faces), max(f.y1 for f in faces)
    ym = 0.5 * (y0 + y1)
    a = sum(f.a for f in faces) / len(faces)
    x = sum(f.x_at(ym) for f in faces) / len(faces)
    return EdgeLine(a, x - a * ym, y0, y1, 0.0, sum(f.rows for f in faces))


def _mid_rows(seeds: list[EdgeLine]) -> list[float]:
    """Each seed's middle row."""
    return [0.5 * (s.y0 + s.y1) for s in seeds]


def _mid_xs(seeds: list[EdgeLine], lines: list[EdgeLine] | None = None) -> np.ndarray:
    """The x of each of `lines` (default the seeds themselves) at its seed's middle row."""
    return np.array([line.x_at(y) for y, line in zip(_mid_rows(seeds), seeds if lines is None else lines)])


def _reach(seeds: list[EdgeLine]) -> float:
    """How far a wall may pass from its seed at the seed's middle row: WALL_NEAR of the seeds' distance apart, at least
    BAND_PX."""
    mid = _mid_xs(seeds)
    return max(BAND_PX, WALL_NEAR * abs(mid[-1] - mid[0]))


def wall_lines(found: list[list[tuple[EdgeLine, int]]]) -> list[EdgeLine]:
    """The walls `glass_walls` found, each as the mean line of its faces."""
    return [mean_line([f for f, _ in faces]) for faces in found]


def _place(frame: np.ndarray | Picture, a: float, xm: float, rows: tuple[int, int], sign: int, da: float, do: float):
    """The line of one polarity near (xm, the rows' middle), within slope +-da and +-do px, along which the gradient
    sums to a peak over `rows` (the peak nearest xm: a wall's other face may be stronger), to a fraction of a pixel
    (line sums, parabola vertices): (line, sign), or None."""
    h, w = frame.shape[:2]
    y0, y1 = max(0, rows[0]), min(h, rows[1])
    yc = 0.5 * (rows[0] + rows[1])
    spread = abs(a) * (y1 - y0) / 2 + da * (y1 - y0) / 2 + do + 6
    x0, x1 = max(0, int(xm - spread)), min(w, int(xm + spread) + 1)
    if y1 - y0 < 20 or x1 - x0 < 8:
        return None
    box = (slice(y0, y1), slice(x0, x1))
    grey = frame.luma[box] if isinstance(frame, Picture) else cv2.cvtColor(frame[box], cv2.COLOR_BGR2GRAY)
    smooth = cv2.GaussianBlur(grey.astype(np.float32), (0, 0), GLASS_BLUR)
    dy = (np.arange(y0, y1) - yc).astype(np.float32)[:, None]
    line = _LineSums(sign * cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3), xm - x0, dy)
    slopes = a + np.linspace(-da, da, 2 * max(1, round(da / 0.002)) + 1)
    offs = np.arange(-do, do + 0.125, 0.25, dtype=np.float32)
    score = line.sums(slopes, offs)
    best = score.max(axis=0)
    peaks = np.flatnonzero((best[1:-1] > best[:-2]) & (best[1:-1] >= best[2:]) & (best[1:-1] > 0)) + 1
    if peaks.size == 0:
        return None
    j = int(peaks[np.argmin(np.abs(offs[peaks]))])
    k = int(np.argmax(score[:, j]))
    step = slopes[1] - slopes[0] if slopes.size > 1 else 0.0
    dk = _vertex(*score[k - 1 : k + 2, j]) if 0 < k < slopes.size - 1 else 0.0
    dj = _vertex(*score[k, j - 1 : j + 2])
    a_fit, x_fit = slopes[k] + dk * step, xm + offs[j] + 0.25 * dj
    return EdgeLine(float(a_fit), float(x_fit - a_fit * yc), y0, y1, 0.0, y1 - y0), sign


FACE_AGREE_DEG = 2.5
"""Largest angle between a wall's two faces (one of each polarity) that are both kept: a glass's outer and inner
faces are parallel, while a face and a label's, a graduation's or a background's edge need not be. On the path-traced
renders a face read over 60-150 rows scatters by about 0.7 deg, so two faces of one wall differ by up to 2 deg by
noise alone, and then their mean is the better reading (1.3-2.3 deg apart on held-out stills)."""


def _edge_line(line: _LineSums, coarse: np.ndarray, a0: float, offs: np.ndarray, sign: int):
    """The best line of one polarity (`coarse`: its signed sums on GLASS_SLOPES x `offs`, sign applied), searched
    again finely about itself: (slope, offset from the seed, line sum), or None when it lies at the band's edge."""
    k, j = np.unravel_index(int(np.argmax(coarse)), coarse.shape)
    if not 0 < j < offs.size - 1 or coarse[k, j] <= 0:
        return None
    slopes = a0 + GLASS_SLOPES[k] + GLASS_FINE * np.arange(-10, 11)
    fine_offs = offs[j] + np.arange(-1.5, 1.75, 0.25, dtype=np.float32)
    score = sign * line.sums(slopes, fine_offs)
    k, j = np.unravel_index(int(np.argmax(score)), score.shape)
    dk = _vertex(*score[k - 1 : k + 2, j]) if 0 < k < slopes.size - 1 else 0.0
    dj = _vertex(*score[k, j - 1 : j + 2]) if 0 < j < fine_offs.size - 1 else 0.0
    return slopes[k] + dk * GLASS_FINE, fine_offs[j] + 0.25 * dj, float(score[k, j])


@dataclass
class _LineSums:
    """Sums of a gradient image along straight lines x = centre + offset + slope * dy over its rows."""

    grad: np.ndarray
    centre: float
    dy: np.ndarray
    """Each row's distance from the pivot row (rows x 1)."""

    def sums(self, slopes: np.ndarray, offs: np.ndarray) -> np.ndarray:
        """Sum of the gradient along each (slope, offset) line (slopes x offsets), sampled by cubic interpolation:
        a linear one makes the sums flat between two equal samples (an edge half-way between pixels), where a line
        that crosses the edge sums as much as one along it."""
        map_y = np.ascontiguousarray(
            np.broadcast_to(np.arange(self.dy.shape[0], dtype=np.float32)[:, None], (self.dy.shape[0], offs.size))
        )
        out = np.empty((slopes.size, offs.size))
        for k, slope in enumerate(slopes):
            map_x = (self.centre + offs[None, :] + np.float32(slope) * self.dy).astype(np.float32)
            out[k] = cv2.remap(self.grad, map_x, map_y, cv2.INTER_CUBIC).sum(axis=0)
        return out


def _vertex(left: float, mid: float, right: float) -> float:
    """Offset (-0.5..0.5 steps) of the top of the parabola through three equally spaced values."""
    curve = left - 2 * mid + right
    return float(np.clip(0.5 * (left - right) / curve, -0.5, 0.5)) if curve < 0 else 0.0


def beside_sides(edges: Sequence[EdgeLine], sides: list[EdgeLine]) -> bool:
    """Every one of the liquid's sides has an edge within WALL_NEAR of the width between them (at least BAND_PX) at
    its middle row: walls found elsewhere (a box's edge behind the glass, one side only) are not the container's."""
    reach = _reach(sides)
    return all(any(abs(e.x_at(y) - side.x_at(y)) <= reach for e in edges) for side, y in zip(sides, _mid_rows(sides)))


def _weighted_angle(edges: list[EdgeLine]) -> float:
    """Mean angle of a wall's edges, weighted by slope precision (~ rows * span^2 / rms^2)."""
    wts = np.array([e.rows * (e.y1 - e.y0) ** 2 / max(e.rms_px, 0.05) ** 2 for e in edges])
    return float(np.sum(wts * np.array([e.angle_deg for e in edges])) / np.sum(wts))


class ContainerTracker:
    """Follows the container walls from frame to frame and returns the container's angle."""

    def __init__(self, roi: tuple[int, int, int, int]) -> None:
        self.roi = roi
        self._walls: list[EdgeLine] = []
        self._shift = 0.0  # horizontal motion of the walls per frame between their last two measurements, px
        self._last = ContainerMeasurement(False)  # the last measurement
        self._steady = False  # the walls moved slowly enough to be held since the measurement before (STEADY_DEG, _PX)
        self._held = 0  # frames it has been held for since
        self._ends: tuple | None = None  # the measured frame's wall ends: rows, columns, grey, `_edges_of` the grey
        self._surface = False  # the walls are the surface target's (`glass_walls` about the liquid's sides)
        self._found: list[list[tuple[EdgeLine, int]]] = []  # their faces' last lines and polarities
        self._found_bottom = 0  # the liquid's bottom row then
        self._sides_x: np.ndarray | None = None  # the liquid's sides' x (`_mid_xs`) at the last `_glass`
        self._anchor: tuple[np.ndarray, np.ndarray] | None = None  # sides' and walls' x when last found afresh
        self._turn = 0.0  # their slope's change per frame between the last two measurements
        self._on_glass = False  # the walls are found on the glass (`glass_walls`, `glass_edges`: Hough and the rows' edges found none)
        self._hough: list[
            EdgeLine
        ] = []  # the strongest Hough lines of the last detection whose edges were not followed

    def measure(
        self,
        frame: np.ndarray,
        float_x: float,
        float_y: float,
        float_len: float,
        still: bool = False,
        glass: tuple[list[EdgeLine], tuple[int, int], tuple[int, int]] | None = None,
    ) -> ContainerMeasurement:
        """Container angle in this frame; re-detects the walls with Hough when following them fails. `still`: the
        caller saw no motion of the container (or cannot tell), so the walls may be held if their ends agree (see
        HOLD_FRAMES); False: measured in this frame. `glass`: the surface target's (seed walls, their rows, the rows of
        their ends to watch): when Hough and the rows' edges find no walls (faint glass, as in real footage), the walls
        are the glass's longest straight edges near the liquid's sides (`glass_walls`), in this frame and every later one. Without it (the
        float), Hough lines whose edges are too noisy to follow row by row seed `glass_edges` likewise."""
        if not np.isfinite(float_x):
            return ContainerMeasurement(False)
        self._surface = glass is not None
        unmoved = None  # the walls' ends where the last measurement saw them: asked when a hold may go on or ends
        if still and self._steady and self._held < HOLD_FRAMES - 1:
            unmoved = self._unmoved(frame)
            if unmoved:
                self._held += 1
                return replace(self._last, held=True)
        if self._held and unmoved is None:
            unmoved = self._unmoved(frame)
        before, frames = self._last, self._held + 1
        if self._on_glass:
            m, anew = self._glass(frame, *self._glass_seeds(glass, float_y, float_len, frames), frames), False
            self._on_glass = m.found or glass is not None  # a float's walls lost: Hough anew
        if not self._on_glass:
            m, anew = self._measure(frame, float_x, float_y, float_len, frames)
            if m.found and glass is not None and not beside_sides(m.edges, glass[0]):
                # another thing's edges, and their motion: the glass's, about the sides
                m, self._walls, self._shift = ContainerMeasurement(False), [], 0.0
            if not m.found and (glass is not None or self._hough):
                # no wall edge found row by row (faint glass, a noisy picture): the glass's line sums from now on
                self._on_glass = True
                seeds = self._glass_seeds(glass, float_y, float_len, frames)
                m, anew = self._glass(frame, *seeds, frames), anew and glass is None
        m.unmoved = bool(unmoved) and not anew  # walls found anew may sit elsewhere than the ends watched
        turn = abs(m.angle_deg - before.angle_deg) / frames if m.found and before.found else math.inf
        self._steady = max(turn / STEADY_DEG, abs(self._shift) / STEADY_PX) * (HOLD_FRAMES - 1) < 1
        self._last, self._held = m, 0
        return m

    def _unmoved(self, frame: np.ndarray) -> bool:
        """Both ends of every wall are within GUARD_PX of where the last measurement saw them."""
        if self._ends is None:
            return False
        ys, cols, grey, edges = self._ends
        shifts = _band_shift(grey, edges, _grey_at(frame, ys, cols).reshape(grey.shape))
        return bool(np.all(np.abs(shifts) < GUARD_PX))

    def _measure(
        self, frame: np.ndarray, float_x: float, float_y: float, float_len: float, frames: int = 1
    ) -> tuple[ContainerMeasurement, bool]:
        """The walls followed from their last lines (`frames` ago), or found anew (then True)."""
        rows = (int(float_y - 1.5 * float_len), int(float_y + 1.5 * float_len))
        if self._walls:
            m = self._follow(frame, rows, frames)
            if m.found:
                return m, False
        self._walls, strongest = detect_walls(frame, float_x, float_y, float_len, self.roi)
        self._shift = 0.0  # the Hough lines are sought where they are, not moved on at the last walls' motion
        m = self._follow(frame, rows) if self._walls else ContainerMeasurement(False)
        self._shift = 0.0  # nor is the edges' offset from the Hough lines they were refitted from a motion
        self._hough = [] if m.found else strongest
        return m, True

    def _glass_seeds(
        self, glass: tuple | None, float_y: float, float_len: float, frames: int
    ) -> tuple[list[EdgeLine], tuple[int, int], tuple[int, int]]:
        """`glass_edges`' seeds, rows and watched ends: the surface target's, or about the float the last walls moved
        on at their last shift (the Hough lines when there are none), over the rows `_follow` reads (in the ROI)."""
        if glass is not None:
            return glass
        top, bottom = self.roi[1], self.roi[1] + self.roi[3]
        rows = (max(top, int(float_y - 1.5 * float_len)), min(bottom, int(float_y + 1.5 * float_len)))
        moved = [replace(wall, b=wall.b + self._shift * frames) for wall in self._walls]
        return moved or self._hough, rows, rows

    def _glass(
        self, frame: np.ndarray, seeds: list[EdgeLine], rows: tuple[int, int], ends: tuple[int, int], frames: int
    ) -> ContainerMeasurement:
        """The walls as the glass's edges near the seed lines (the surface's: `glass_walls`, followed from frame to
        frame; the float's: `glass_edges`); their ends watched in rows `ends`."""
        # about the last frame's walls (moved on at their last shift; a surface's rows with the liquid's bottom), so that
        # the same edges are followed; a float's walls too faint for that: the old band search about the Hough lines
        lift = seeds[0].y1 - self._found_bottom if self._surface else 0
        move, turn = self._shift * frames, (self._turn * frames if self._surface else 0.0)
        prior = [[(_moved(f, move, turn, lift), sign) for f, sign in faces] for faces in self._found]
        found = len(prior) == len(seeds) and glass_walls(frame, seeds, rows, prior)
        before, now = self._sides_x, _mid_xs(seeds) if self._surface else None
        self._sides_x = now
        if found and now is not None and self._astray(found, seeds, now):
            # not the glass's walls: the walls found afresh move on as the liquid's sides moved, with no turn predicted
            found, self._found, self._walls = [], [], []
            same = before is not None and before.shape == now.shape
            self._shift = float(np.mean(now - before)) / frames if same else 0.0
        if not found:
            found = glass_walls(frame, seeds, rows, sides=self._surface)
            self._anchor = (now, _mid_xs(seeds, wall_lines(found))) if now is not None and found else None
        if found and len(found) == len(self._found):
            self._turn = sum(
                mean_line([f for f, _ in new]).a - mean_line([f for f, _ in old]).a
                for new, old in zip(found, self._found)
            ) / (len(found) * frames)
        else:
            self._turn = 0.0
        self._found = found if len(found) == len(seeds) else []
        self._found_bottom = seeds[0].y1 if seeds else 0
        walls = wall_lines(found)
        if not walls and not self._surface:
            walls = glass_edges(frame, seeds, rows)
        if len(walls) < len(seeds):
            self._walls = []
            return ContainerMeasurement(False)
        if self._walls:
            yc = 0.5 * (rows[0] + rows[1])
            self._shift = sum(nw.x_at(yc) - ow.x_at(yc) for nw, ow in zip(walls, self._walls)) / (len(walls) * frames)
        self._walls = walls
        xc = np.rint([[wall.x_at(y) for y in range(*ends)] for wall in walls]).astype(np.intp)
        self._watch(frame, np.arange(*ends), xc[..., None] + np.arange(-BAND_PX, BAND_PX + 1), 0, ends[1] - ends[0])
        return ContainerMeasurement(True, sum(wall.angle_deg for wall in walls) / len(walls), tuple(walls))

    def _astray(self, found: list[list[tuple[EdgeLine, int]]], seeds: list[EdgeLine], now: np.ndarray) -> bool:
        """Walls followed from the last frame (`found`) that left the liquid's sides (`seeds`, at x `now`) by more than
        WALL_DRIFT of the reach since they were found afresh, once both sides moved one way by more than the reach (one
        side read elsewhere in a still picture is not a move)."""
        if self._anchor is None or self._anchor[0].shape != now.shape:
            return False
        sides, walls = self._anchor
        reach, moved = _reach(seeds), now - sides
        drift = (_mid_xs(seeds, wall_lines(found)) - now) - (walls - sides)
        together = bool(np.all(moved > reach) or np.all(moved < -reach))
        return together and bool(np.any(np.abs(drift) > WALL_DRIFT * reach))

    def _watch(self, frame: np.ndarray, ys: np.ndarray, cols: np.ndarray, lo: int, hi: int) -> None:
        """Keep the walls' ends as this frame shows them, for `_unmoved`: GUARD_ROWS at each end of rows lo..hi of
        `ys` (the rows of the bands `cols`: walls x rows x band columns)."""
        self._ends = None
        if hi - lo >= 4 * GUARD_ROWS and cols.min() >= 0 and cols.max() < frame.shape[1]:
            ends = np.r_[lo : lo + GUARD_ROWS, hi - GUARD_ROWS : hi]
            # as blocks of GUARD_ROWS rows: walls x both ends
            grey = _grey_at(frame, ys[ends], cols[:, ends]).reshape(-1, GUARD_ROWS, cols.shape[2])
            self._ends = (ys[ends], cols[:, ends], grey, _edges_of(grey))

    def _follow(self, frame: np.ndarray, rows: tuple[int, int], frames: int = 1) -> ContainerMeasurement:
        """Refit every wall edge near its predicted position (last line moved on at the last shift per frame for
        `frames` frames): the rising and the falling edge (e.g. the wall's outer and inner face) of every wall, from
        one read of their bands' luma."""
        h, w = frame.shape[:2]
        ys = np.arange(max(0, rows[0]), min(h, rows[1]))
        if len(ys) < 10:
            self._walls = []
            return ContainerMeasurement(False)
        n = len(self._walls)
        a = np.array([[wall.a] for wall in self._walls])
        b = np.array([[wall.b + self._shift * frames] for wall in self._walls])
        xc = np.rint(a * ys + b).astype(np.intp)  # walls x rows
        usable = (xc >= BAND_PX) & (xc < w - BAND_PX)  # the band lies in the picture
        cols = np.clip(xc, BAND_PX, w - 1 - BAND_PX)[..., None] + np.arange(-BAND_PX, BAND_PX + 1)
        profile = _band_luma(frame, ys, cols)
        grad = (profile[..., 2:] - profile[..., :-2]) * 0.5  # central difference: index j <-> column j + 1
        x, ok = _edge_points(np.concatenate([grad, -grad]), np.concatenate([usable, usable]))
        x += np.concatenate([cols[..., 0], cols[..., 0]]) + 1
        coef, keep = robust_lines(ys.astype(float), x, ok, 0.3)
        fitted: list[EdgeLine] = []
        wall_angles: list[float] = []
        new_walls: list[EdgeLine] = []
        for i in range(n):
            fits = []
            for k in (i, i + n):  # the wall's rising and falling edge
                if np.isnan(coef[k, 0]):
                    continue
                yk, xk = ys[keep[k]], x[k, keep[k]]
                rms = float(np.sqrt(np.mean((xk - (coef[k, 0] * yk + coef[k, 1])) ** 2)))
                if rms < 1.0:
                    fits.append(
                        EdgeLine(float(coef[k, 0]), float(coef[k, 1]), int(yk[0]), int(yk[-1]) + 1, rms, yk.size)
                    )
            if not fits:
                continue
            fitted.extend(fits)
            wall_angles.append(_weighted_angle(fits))
            mid_a = sum(f.a for f in fits) / len(fits)
            mid_b = sum(f.b for f in fits) / len(fits)
            new_walls.append(EdgeLine(mid_a, mid_b, rows[0], rows[1], 0.0, 0))
        if len(new_walls) < n:
            self._walls = []
            return ContainerMeasurement(False)
        yc = 0.5 * (rows[0] + rows[1])
        self._shift = sum(nw.x_at(yc) - ow.x_at(yc) for nw, ow in zip(new_walls, self._walls)) / (n * frames)
        self._walls = new_walls
        # the walls' ends as this frame shows them, for `_unmoved`: GUARD_ROWS at each end of the rows where every
        # edge was followed (the band reaches beyond the container's rim)
        self._watch(frame, ys, cols, max(f.y0 for f in fitted) - ys[0], min(f.y1 for f in fitted) - ys[0])
        # each wall counts once, so a tapered glass (walls leaning in opposite directions) reads as upright
        return ContainerMeasurement(True, sum(wall_angles) / n, tuple(fitted))
