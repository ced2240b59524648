"""The dyed-liquid scene of `sloshid synth --scene surface`: the liquid surface itself is what a tracker measures.

A round transparent container holds dyed liquid; the camera looks through the front wall, optionally from
slightly above (`elevation_deg`), so that the circular surface shows as a thin ellipse whose front and back
edges are both visible and whose mid-line is the surface's height. The surface is the pendulum's tilt
(the same trace as the float scene) plus an optional antisymmetric second mode whose best-fit line is flat, so
the truth angle is the best-fit line across the inner width and the truth wall heights include the second
mode. Real-footage effects: a meniscus band along the front edge that curls up at the walls, highlight stripes
on the glass, a mirror image of the surface on the wall, exposure changes, noise, blur and compression.
Every layer is painted per pixel in container coordinates with analytic edge coverage, so the truth is exact.
"""

from __future__ import annotations

import math

import numpy as np

from sloshid.synthetic.scene import (
    Motion,
    NoisePool,
    SynthSettings,
    background_image,
    check_in_picture,
    degrade_picture,
    paint_polygon,
    rectangle_points,
    rotation_matrix,
    scene_geometry,
)
from sloshid.video.colors import preset

SECOND_MODE_FREQ_RATIO = 1.7
"""Second antisymmetric mode of a cylinder relative to the first: sqrt(5.331 / 1.841) in deep liquid."""
_G1 = 0.4
"""Wall value of the second mode's shape g(s) = s^3 - 0.6 s, whose least-squares line over the width is flat."""


def _second_mode_height(s: SynthSettings, t: np.ndarray, amplitude_px: float) -> np.ndarray:
    """Wall height of the second mode (px): a damped oscillation started with the tap or the move."""
    p = s.params
    w2, z2 = SECOND_MODE_FREQ_RATIO * p.omega_rad_s, min(0.5, 2 * p.zeta)
    start = s.tap_s if s.motion == "decay" else s.move_start_s
    tau = np.clip(t - start, 0, None)
    return s.second_mode * amplitude_px * np.exp(-z2 * w2 * tau) * np.sin(w2 * math.sqrt(1 - z2 * z2) * tau)


def _below(curve: np.ndarray, slope: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Coverage of the region below a curve w = curve(u): signed distance along the curve's normal, one pixel ramp."""
    return np.clip(0.5 + (curve - w) / np.sqrt(1 + np.minimum(slope * slope, 400.0)), 0, 1)


def _blend(img: np.ndarray, alpha: np.ndarray, bgr) -> None:
    """img += alpha * (colour - img) in place (alpha per pixel, colour per channel or per pixel)."""
    img += alpha[..., None] * (np.asarray(bgr, np.float32) - img)


def _surface_layers(img, u, w, z, dz, walls_z: tuple[float, float], s: SynthSettings, sc) -> None:
    """Paint body, ellipse top, meniscus, wall reflection and highlight stripes into `img` (container coordinates)."""
    half = sc.inner_w / 2
    dye = np.asarray(preset(s.liquid_color).bgr, np.float32)
    eps = math.radians(s.elevation_deg)
    inside = np.clip(0.5 + half - np.abs(u), 0, 1) * np.clip(0.5 + w + sc.depth, 0, 1)
    chord = np.sqrt(np.clip(half * half - u * u, 0, None))
    dchord = -u / np.maximum(chord, 1.0)
    seen, dseen = z * math.cos(eps), dz * math.cos(eps)
    front, back = seen - chord * math.sin(eps), seen + chord * math.sin(eps)
    below_front = _below(front, dseen - dchord * math.sin(eps), w)
    below_back = _below(back, dseen + dchord * math.sin(eps), w)
    _blend(img, 0.25 * inside, (235, 240, 240))  # the glass
    _blend(img, 0.9 * inside * np.clip(below_back - below_front, 0, 1), 0.45 * dye + 0.55 * 245)  # top, seen from above
    _blend(img, 0.88 * inside * below_front, dye)  # the liquid body through the front wall
    if s.meniscus_px > 0:
        curl = 3 * s.meniscus_px * np.exp(-(half - np.abs(u)) / 3.0)
        band = np.clip(_below(front + s.meniscus_px + curl, dseen, w) - below_front, 0, 1)
        _blend(img, 0.8 * inside * band, 0.35 * dye if s.meniscus_dark else (250, 250, 250))
    if s.reflection > 0:  # mirror image of the surface about its wall contact height, below it, near each wall
        mirror = np.minimum(2 * np.where(u < 0, walls_z[0], walls_z[1]) * math.cos(eps) - front, front) - 6.0
        line = np.clip(1.5 - np.abs(w - mirror), 0, 1) * np.clip((np.abs(u) - 0.75 * half) / (0.1 * half), 0, 1)
        _blend(img, s.reflection * inside * line, 0.6 * dye + 0.4 * 245)
    if s.specular > 0:  # two vertical highlight stripes on the front glass, fixed to the container
        for centre, width in ((-0.55 * half, 0.02 * sc.inner_w), (0.3 * half, 0.012 * sc.inner_w)):
            stripe = np.exp(-0.5 * ((u - centre) / width) ** 2) * np.clip(0.5 + w + sc.depth, 0, 1)
            _blend(img, s.specular * stripe * np.clip(0.5 + sc.head - w, 0, 1), (255, 255, 255))


def surface_frames(s: SynthSettings, mo: Motion):
    """Yield (truth row dict, BGR uint8 frame) for every frame of the dyed-liquid scene."""
    sc = scene_geometry(s)
    half = sc.inner_w / 2
    roll = math.radians(s.camera_roll_deg)
    R_roll = rotation_matrix(roll)
    base = background_image(s)
    noise = NoisePool(base.shape, s.noise_sigma, mo.rng) if s.noise_sigma > 0 else None
    tan_amp = math.tan(math.radians(abs(s.amplitude_deg)) if s.motion == "decay" else 0.1)
    h2 = _second_mode_height(s, mo.t, half * tan_amp)
    check_in_picture(s, sc, mo, h2)
    mm_per_px = 1000 * s.container_diameter_m / sc.inner_w
    walls = {
        "left": rectangle_points(-half - sc.wall, -half, -sc.depth - sc.wall, sc.head),
        "right": rectangle_points(half, half + sc.wall, -sc.depth - sc.wall, sc.head),
        "bottom": rectangle_points(-half, half, -sc.depth - sc.wall, -sc.depth),
    }
    centre = np.array([s.width / 2, s.height / 2])
    for k in range(len(mo.t)):
        R_c, pos = rotation_matrix(mo.tilt[k]), np.array([sc.x0 + mo.dx[k], s.height - sc.y0])

        def to_img(pts: np.ndarray, R_c: np.ndarray = R_c, pos: np.ndarray = pos) -> np.ndarray:
            """Container coordinates (x right, y up) -> image pixels (y down), through tilt, pose and roll."""
            cam = (pts @ R_c.T + pos - centre) @ R_roll.T
            return np.column_stack([cam[:, 0] + centre[0], centre[1] - cam[:, 1]])

        corners = to_img(
            rectangle_points(-half - sc.wall - 2, half + sc.wall + 2, -sc.depth - sc.wall - 2, sc.head + 2)
        )
        x0, y0 = np.maximum(np.floor(corners.min(axis=0)).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(corners.max(axis=0)).astype(int) + 1, [s.width, s.height])
        ys, xs = np.mgrid[y0:y1, x0:x1].astype(np.float64)
        cam = np.stack([xs - centre[0], centre[1] - ys], axis=-1)
        local = (cam @ R_roll + centre - pos) @ R_c  # image -> container coordinates (the inverse of to_img)
        u, w = local[..., 0], local[..., 1]
        srel = np.clip(u / half, -1, 1)
        tan_t = math.tan(mo.rel[k])
        z = u * tan_t + h2[k] * (srel**3 - 0.6 * srel) / _G1
        dz = tan_t + h2[k] * (3 * srel**2 - 0.6) / (_G1 * half)
        left, right = -half * tan_t - h2[k], half * tan_t + h2[k]
        img = base.copy()
        f32 = np.float32
        _surface_layers(img[y0:y1, x0:x1], u.astype(f32), w.astype(f32), z.astype(f32), dz, (left, right), s, sc)
        for part in ("left", "right", "bottom"):
            paint_polygon(img, to_img(walls[part]), (70, 70, 70), 0.92)
        img = degrade_picture(img, s, mo.t[k], mo.drift[k], noise)
        rel_deg = math.degrees(mo.rel[k])
        origin, bottom = to_img(np.array([[0.0, 0.0], [0.0, -sc.depth]]))
        row = {
            "frame": k,
            "t_s": mo.t[k],
            "rel_angle_deg": rel_deg,
            "container_angle_deg": math.degrees(mo.tilt[k] + roll),
            "surface_angle_deg": rel_deg + math.degrees(mo.tilt[k] + roll),
            "left_wall_px": left,
            "right_wall_px": right,
            "left_wall_mm": left * mm_per_px,
            "right_wall_mm": right * mm_per_px,
            "surface_x_px": origin[0],
            "surface_y_px": origin[1],
            "container_x_px": bottom[0],
            "container_y_px": bottom[1],
            "accel_m_s2": mo.accel[k],
        }
        yield row, img
