"""Draw what the tracker measured onto a frame, so a user can check it by eye.

Green line: the float's measured long axis through its measured centre, or the liquid surface's best-fit line
across the inner width (red when the frame is not valid). Yellow circles: the surface height at each inner
wall. Blue lines: the reference (the image horizontal, or the fitted container walls). Yellow box: the
region of interest. Text: the angle, with what it is against (the image or the walls, as the CSV's angle_deg),
and quality.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from sloshid.tracking.container_ref import ContainerMeasurement
from sloshid.tracking.float_angle import FloatMeasurement
from sloshid.tracking.surface import SurfaceMeasurement

_SHIFT = 4  # OpenCV fixed-point bits: draw at 1/16 pixel
_GREEN, _RED, _BLUE, _YELLOW = (60, 220, 60), (40, 40, 255), (255, 140, 30), (0, 220, 255)


def _pt(x: float, y: float) -> tuple[int, int]:
    """Sub-pixel point in OpenCV's fixed-point drawing coordinates."""
    return round(x * (1 << _SHIFT)), round(y * (1 << _SHIFT))


def draw_overlay(
    frame: np.ndarray,
    fm: FloatMeasurement,
    cm: ContainerMeasurement,
    angle_deg: float,
    valid: bool,
    roi: tuple[int, int, int, int],
) -> np.ndarray:
    """A copy of `frame` with the float axis, the reference, the ROI and the numbers drawn on it."""
    out, thick = _canvas(frame, roi)
    if fm.found:
        half = 0.6 * fm.length_px
        a = math.radians(fm.angle_deg)
        dx, dy = half * math.cos(a), -half * math.sin(a)  # CCW as seen, image y down
        colour = _GREEN if valid else _RED
        cv2.line(
            out, _pt(fm.x_px - dx, fm.y_px - dy), _pt(fm.x_px + dx, fm.y_px + dy), colour, thick, cv2.LINE_AA, _SHIFT
        )
        cv2.circle(out, _pt(fm.x_px, fm.y_px), 3 << _SHIFT, colour, -1, cv2.LINE_AA, _SHIFT)
        if not cm.edges and cm.found:  # image reference: the horizontal through the float
            cv2.line(out, _pt(fm.x_px - half, fm.y_px), _pt(fm.x_px + half, fm.y_px), _BLUE, 1, cv2.LINE_AA, _SHIFT)
    for e in cm.edges:
        cv2.line(out, _pt(e.x_at(e.y0), e.y0), _pt(e.x_at(e.y1), e.y1), _BLUE, 1, cv2.LINE_AA, _SHIFT)
    text = (
        f"angle {angle_deg:+.2f} deg {'to the walls' if cm.edges else 'to the image'}  q {fm.quality:.2f}"
        if valid
        else ("float not valid" if fm.found else "float not found")
    )
    _label(out, text, valid)
    return out


def draw_surface_overlay(
    frame: np.ndarray, m: SurfaceMeasurement, angle_deg: float, valid: bool, roi: tuple[int, int, int, int], reference
) -> np.ndarray:
    """A copy of `frame` with the fitted surface line, the wall points, the reference, the ROI and the numbers."""
    out, thick = _canvas(frame, roi)
    if m.found:
        line_l, line_r, wall_l, wall_r = m.ends
        colour = _GREEN if valid else _RED
        for a, b, y0, y1 in m.walls:  # the inner walls: the container reference (and where heights are read)
            cv2.line(out, _pt(a * y0 + b, y0), _pt(a * y1 + b, y1), _BLUE, 1, cv2.LINE_AA, _SHIFT)
        if reference == "image":  # the image horizontal through the surface centre
            cv2.line(out, _pt(line_l[0], m.y_px), _pt(line_r[0], m.y_px), _BLUE, 1, cv2.LINE_AA, _SHIFT)
        cv2.line(out, _pt(*line_l), _pt(*line_r), colour, thick, cv2.LINE_AA, _SHIFT)
        for p in (wall_l, wall_r):
            cv2.circle(out, _pt(*p), 4 << _SHIFT, _YELLOW, thick, cv2.LINE_AA, _SHIFT)
    if valid:
        to = "to the walls" if reference == "container" else "to the image"  # as the CSV's angle_deg
        text = f"angle {angle_deg:+.2f} deg {to}  q {m.quality:.2f}"
    else:
        text = (
            f"surface not valid  q {m.quality:.2f}"
            if m.found
            else ("container not found" if m.liquid else "liquid not found")
        )
    _label(out, text, valid)
    return out


def _canvas(frame: np.ndarray, roi: tuple[int, int, int, int]) -> tuple[np.ndarray, int]:
    """A copy of the frame (BGR, or a Picture converted) with the ROI drawn (when it is not the whole frame), and the line
    thickness for its size."""
    out = np.array(frame)
    h, w = out.shape[:2]
    x, y, rw, rh = roi
    if (rw, rh) != (w, h):
        cv2.rectangle(out, (x, y), (x + rw - 1, y + rh - 1), _YELLOW, 1)
    return out, max(1, round(h / 360))


def _label(out: np.ndarray, text: str, valid: bool) -> None:
    """The status text at the top left on a dark box, readable on any scene."""
    scale = max(0.45, out.shape[0] / 800)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    cv2.rectangle(out, (4, 4), (12 + tw, 12 + th + base), (0, 0, 0), -1)
    cv2.putText(out, text, (8, 8 + th), cv2.FONT_HERSHEY_SIMPLEX, scale, _GREEN if valid else _RED, 1, cv2.LINE_AA)
