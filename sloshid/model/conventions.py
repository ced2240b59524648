"""The sign conventions of sloshid, stated once (design.md; tested in tests/test_foundation.py and test_synth.py).

- SI units inside; every file column and JSON key carries its unit in its name (`t_s`, `angle_deg`, `l_m`).
- z is up; gravity is G = 9.81 m/s^2 along -z. Vertical acceleration uz changes the effective gravity to G + uz.
- theta is the pitch of the liquid surface about +y and is driven by ux; phi is its roll about +x and is driven
  by uy. Under a steady acceleration the surface normal tilts into the acceleration: theta -> atan(ux / g),
  phi -> -atan(uy / g) (`steady_tilt`). The 1-D model (seed eq. 2) has one angle that tilts toward +u: theta for
  a move along x, -phi for a move along y (`TILT_AXES`).
- Container orientation: Euler angles (phi, theta, psi) about x, y, z, applied z-y-x; the container tilted to
  the liquid's surface angles is what makes a move slosh-free.
- Image angles are counter-clockwise positive as a viewer sees the picture. A camera looking along +y at a move
  toward the image right sees a surface that tilts toward +u turn clockwise: `SEEN_SIGN` = -1 maps the model
  angle to the angle seen.
- Timestamps are the video's own presentation times, never frame index / fps.
"""

from __future__ import annotations

from typing import Any

import numpy as np

G = 9.81
"""Gravitational acceleration in m/s^2 (the seed's value)."""

TILT_AXES = ((0, 1, 1.0), (1, 0, -1.0))
"""Per horizontal axis: (acceleration column, Euler column, sign); sign * euler is the angle that tilts toward +u."""

SEEN_SIGN = -1.0
"""Model angle (tilting toward +u, the move going to the image right) -> counter-clockwise angle as seen."""


def steady_tilt(ux: Any, uy: Any, uz: Any = 0.0) -> tuple[Any, Any]:
    """(phi, theta) in rad at which the surface settles under a constant acceleration (numbers or arrays)."""
    return -np.arctan2(uy, G + uz), np.arctan2(ux, G + uz)


WALL_ANGLE_CAP_RAD = 1.4
"""Relative angles are capped here (80 deg) before the tangent of the wall reading: a surface past the vertical has
no wall height."""


def wall_height_mm(radius_m: float, rel_angle_rad: Any) -> Any:
    """The wall reading of a planar surface tilted `rel_angle_rad` from the container's axis: its highest point at the
    wall of a container of `radius_m`, R tan(angle), in mm (numbers or arrays)."""
    return 1000.0 * radius_m * np.tan(np.minimum(rel_angle_rad, WALL_ANGLE_CAP_RAD))
