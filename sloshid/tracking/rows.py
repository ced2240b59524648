"""One frame's row of the track table as the tracker passes it between its steps, by name instead of by position."""

from __future__ import annotations

import math
from typing import NamedTuple

VALID_QUALITY = 0.5
"""Frames whose quality (float or surface) is below this are marked valid = 0 (not used by the smoother)."""


class SurfaceGeometry(NamedTuple):
    """The surface step's raw measurement of a frame, which its `finish` turns into elevation-corrected angles and
    wall heights: slope against the container's axis, its tilt (deg), the wall heights and widths (px), and the tilt
    of the liquid's sides (deg; the axis unless the glass's walls gave it)."""

    rel_slope: float
    container_angle_deg: float
    left_w: float
    right_w: float
    width_px: float
    opening_px: float
    sides_deg: float = math.nan


class TrackRow(NamedTuple):
    """A frame's row: the first nine columns of the track table (`TRACK_COLUMNS`); a step gives it with frame 0 and
    no time, the span fills in the time and the video the frame's number. `surface` is the surface step's raw
    geometry until its `finish` (None in the finished table)."""

    frame: int
    t_s: float
    angle_deg: float
    float_angle_deg: float
    container_angle_deg: float
    x_px: float
    y_px: float
    quality: float
    valid: int
    surface: SurfaceGeometry | None = None


def step_row(
    angle_deg: float,
    float_angle_deg: float,
    container_angle_deg: float,
    x_px: float,
    y_px: float,
    quality: float,
    valid: int,
    surface: SurfaceGeometry | None = None,
) -> TrackRow:
    """A step's row of one frame: its frame number and time are not known yet (0 and NaN)."""
    return TrackRow(0, math.nan, angle_deg, float_angle_deg, container_angle_deg, x_px, y_px, quality, valid, surface)
