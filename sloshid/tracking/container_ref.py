"""Measure the container's own orientation in every frame from its two straight, near-vertical side walls.

The walls are found once with a Hough transform (the nearest near-vertical lines left and right of
the float) and then followed frame to frame: in a narrow band around each predicted wall, every row's
strongest falling and rising intensity edge is located to sub-pixel precision (parabola through the
gradient peak, unbiased for any edge contrast), and a robust straight-line fit per edge gives the wall's
angle. Each wall's angle is the precision-weighted mean of its well-fitting edges, and the container
angle is the mean of the two walls (CCW positive as seen, 0 when the walls are vertical in the picture),
so a tapered glass, whose walls lean in opposite directions, reads upright.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from sloshid.tracking.robust import median, robust_polyfit

BAND_PX = 9
"""Half-width of the band searched around a predicted wall line, pixels."""


@dataclass
class EdgeLine:
    """A wall edge as x = a * y + b in image coordinates (near-vertical lines are single-valued in y)."""

    a: float
    b: float
    y0: int
    y1: int
    rms_px: float
    rows: int

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


def _band_gray(frame: np.ndarray, line: EdgeLine) -> tuple[tuple[int, int], np.ndarray]:
    """Grey levels (float32: edge profiles are differenced) of the box the band around `line` covers, and the box's
    top-left corner (x, y): only that part of the frame is converted (a wall's band, not the container between)."""
    h, w = frame.shape[:2]
    y0, y1 = max(0, line.y0), min(h, line.y1)
    xs = [line.x_at(y) for y in (y0, y1)]
    x0, x1 = max(0, int(min(xs)) - BAND_PX - 2), min(w, int(max(xs)) + BAND_PX + 3)
    if x1 <= x0 or y1 <= y0:
        return (0, 0), np.zeros((0, 0), np.float32)
    return (x0, y0), cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY).astype(np.float32)


def _band_profiles(
    gray: np.ndarray, origin: tuple[int, int], predicted: EdgeLine
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Rows, columns and rising-edge gradient (central difference, index j <-> column j+1) of the band around
    `predicted`, in the rows whose band lies inside `gray` (whose top-left pixel is `origin`); None under 10 rows."""
    ox, oy = origin
    h, w = gray.shape
    ys = np.arange(max(predicted.y0, oy), min(predicted.y1, oy + h))
    if len(ys) < 10:
        return None
    xc = np.rint(predicted.x_at(ys)).astype(int)
    offs = np.arange(-BAND_PX, BAND_PX + 1)
    cols = xc[:, None] + offs[None, :]
    inside = (cols.min(axis=1) >= ox) & (cols.max(axis=1) < ox + w)
    ys, cols = ys[inside], cols[inside]
    if len(ys) < 10:
        return None
    prof = gray[ys[:, None] - oy, cols - ox]
    return ys, cols, (prof[:, 2:] - prof[:, :-2]) * 0.5


def _fit_edge(ys: np.ndarray, cols: np.ndarray, grad: np.ndarray) -> EdgeLine | None:
    """Sub-pixel points of the edge whose gradient (`_band_profiles`', signed for its polarity) peaks in each row,
    and their robust line fit (frame coordinates)."""
    j = np.argmax(grad, axis=1)
    ok = (j > 0) & (j < grad.shape[1] - 1)
    rows = np.arange(len(ys))
    g0, g1, g2 = grad[rows, np.clip(j - 1, 0, None)], grad[rows, j], grad[rows, np.clip(j + 1, None, grad.shape[1] - 1)]
    strength = g1
    ok &= strength > max(4.0, 0.35 * median(strength[ok]) if ok.any() else 4.0)
    denom = g0 - 2 * g1 + g2
    ok &= denom < 0
    if ok.sum() < 10:
        return None
    frac = 0.5 * (g0[ok] - g2[ok]) / denom[ok]
    x = cols[ok, 0] + 1 + j[ok] + frac
    y = ys[ok].astype(float)
    fit = robust_polyfit(y, x, 1, 0.3)
    if fit is None:
        return None
    (a, b), keep = fit
    rms = float(np.sqrt(np.mean((x[keep] - (a * y[keep] + b)) ** 2)))
    return EdgeLine(float(a), float(b), int(y[keep].min()), int(y[keep].max()) + 1, rms, int(keep.sum()))


def detect_walls(
    frame: np.ndarray, float_x: float, float_y: float, float_len: float, roi: tuple[int, int, int, int]
) -> list[EdgeLine]:
    """First frame: the nearest long near-vertical Hough lines left and right of the float, as coarse edges."""
    x, y, w, h = roi
    gray = cv2.GaussianBlur(cv2.cvtColor(frame[y : y + h, x : x + w], cv2.COLOR_BGR2GRAY), (0, 0), 1.0)
    edges = cv2.Canny(gray, 30, 90)
    min_len = max(20, int(0.6 * float_len))
    lines = cv2.HoughLines(edges, 1, np.pi / 720, min_len, min_theta=0, max_theta=np.pi)
    if lines is None:
        return []
    best: dict[int, tuple[float, EdgeLine]] = {}
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
        dist = abs(xf - float_x)
        if side not in best or dist < best[side][0]:
            span = int(1.5 * float_len)
            best[side] = (dist, EdgeLine(a, b, int(float_y - span), int(float_y + span), math.inf, 0))
    return [best[s][1] for s in sorted(best)]


def _weighted_angle(edges: list[EdgeLine]) -> float:
    """Mean angle of a wall's edges, weighted by slope precision (~ rows * span^2 / rms^2)."""
    wts = np.array([e.rows * (e.y1 - e.y0) ** 2 / max(e.rms_px, 0.05) ** 2 for e in edges])
    return float(np.sum(wts * np.array([e.angle_deg for e in edges])) / np.sum(wts))


class ContainerTracker:
    """Follows the container walls from frame to frame and returns the container's angle."""

    def __init__(self, roi: tuple[int, int, int, int]) -> None:
        self.roi = roi
        self._walls: list[EdgeLine] = []
        self._shift = 0.0  # last frame-to-frame horizontal motion of the walls, px

    def measure(self, frame: np.ndarray, float_x: float, float_y: float, float_len: float) -> ContainerMeasurement:
        """Container angle in this frame; re-detects the walls with Hough when following them fails."""
        if not np.isfinite(float_x):
            return ContainerMeasurement(False)
        rows = (int(float_y - 1.5 * float_len), int(float_y + 1.5 * float_len))
        if self._walls:
            m = self._follow(frame, rows)
            if m.found:
                return m
        self._walls, self._shift = detect_walls(frame, float_x, float_y, float_len, self.roi), 0.0
        return self._follow(frame, rows) if self._walls else ContainerMeasurement(False)

    def _follow(self, frame: np.ndarray, rows: tuple[int, int]) -> ContainerMeasurement:
        """Refit every wall edge near its predicted position (last line moved by the last shift)."""
        preds = [EdgeLine(w.a, w.b + self._shift, rows[0], rows[1], w.rms_px, w.rows) for w in self._walls]
        fitted: list[EdgeLine] = []
        wall_angles: list[float] = []
        new_walls: list[EdgeLine] = []
        for pred in preds:
            origin, gray = _band_gray(frame, pred)
            band = _band_profiles(gray, origin, pred)
            # the rising and the falling edge (e.g. the wall's outer and inner face) from the same profiles
            edges = () if band is None else (_fit_edge(*band[:2], band[2]), _fit_edge(*band[:2], -band[2]))
            fits = [f for f in edges if f is not None and f.rms_px < 1.0]
            if not fits:
                continue
            fitted.extend(fits)
            wall_angles.append(_weighted_angle(fits))
            mid_a = float(np.mean([f.a for f in fits]))
            mid_b = float(np.mean([f.b for f in fits]))
            new_walls.append(EdgeLine(mid_a, mid_b, rows[0], rows[1], 0.0, 0))
        if len(new_walls) < len(self._walls) or not fitted:
            self._walls = []
            return ContainerMeasurement(False)
        yc = 0.5 * (rows[0] + rows[1])
        self._shift = float(np.mean([nw.x_at(yc) - ow.x_at(yc) for nw, ow in zip(new_walls, self._walls)]))
        self._walls = new_walls
        # each wall counts once, so a tapered glass (walls leaning in opposite directions) reads as upright
        return ContainerMeasurement(True, float(np.mean(wall_angles)), tuple(fitted))
