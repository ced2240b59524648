"""Draw what the tracker measured onto a frame, so a user can check it by eye.

Green line: the float's measured long axis through its measured centre (red when the frame is not
valid). Blue lines: the reference (the image horizontal through the float, or the fitted container
wall edges). Yellow box: the region of interest. Text: time, angle and quality.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from sloshid.tracking.container_ref import ContainerMeasurement
from sloshid.tracking.float_angle import FloatMeasurement

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
    out = frame.copy()
    h, w = out.shape[:2]
    x, y, rw, rh = roi
    if (rw, rh) != (w, h):
        cv2.rectangle(out, (x, y), (x + rw - 1, y + rh - 1), _YELLOW, 1)
    thick = max(1, round(h / 360))
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
        f"angle {angle_deg:+.2f} deg  q {fm.quality:.2f}"
        if valid
        else ("float not valid" if fm.found else "float not found")
    )
    scale = max(0.45, h / 800)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    cv2.rectangle(out, (4, 4), (12 + tw, 12 + th + base), (0, 0, 0), -1)  # dark box: readable on any scene
    cv2.putText(out, text, (8, 8 + th), cv2.FONT_HERSHEY_SIMPLEX, scale, _GREEN if valid else _RED, 1, cv2.LINE_AA)
    return out
