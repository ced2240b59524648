"""Synthetic side-view videos of a float on sloshing liquid, with the exact angle trace as ground truth.

The scene is a transparent container with tinted liquid and an elongated float lying on the surface.
The float's angle relative to the container follows a known pendulum trace (sloshid.model.pendulum, solved with
solve_ivp): a tap-test free decay, or the response to a constant-acceleration move. Every shape is a
convex polygon painted with analytic per-pixel coverage (signed distance to each edge, clipped to one
pixel), so edges sit at their exact sub-pixel position and the truth needs no rasterisation tolerance.
Camera roll and the container's travel and tilt are transforms of the polygon vertices, so they are
exact too. Blur, flicker, sensor noise and H.264/MPEG-4 compression then degrade the picture.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from tqdm import tqdm

from sloshid.core.atomic import atomic_path, write_json
from sloshid.core.errors import UserError
from sloshid.synthetic.float_look import paint_float
from sloshid.synthetic.pbr import pbr_frames, scene_record
from sloshid.synthetic.pbr_scene import draw_scene
from sloshid.synthetic.scene import (
    LIQUID_BGR,
    WALL_BGR,
    NoisePool,
    SynthSettings,
    Truth,
    _motion,
    _poses_at,
    background_image,
    check_in_picture,
    degrade_picture,
    frame_times,
    paint_polygon,
    rectangle_points,
    relative_angle_rad,
    rotation_matrix,
    scene_geometry,
)
from sloshid.synthetic.surface_scene import surface_frames
from sloshid.video.colors import preset
from sloshid.video.frames import VideoWriter

__all__ = [  # SynthSettings and the truth's helpers live in `scene` (the renderers' shared base); kept importable here
    "SynthSettings",
    "Truth",
    "frame_times",
    "relative_angle_rad",
    "render_frames",
    "render_video",
    "scene_geometry",
]


class _FloatScene:
    """The float scene's fixed parts and its painter: one undegraded picture per pose."""

    def __init__(self, s: SynthSettings) -> None:
        self.s, self.sc = s, scene_geometry(s)
        self.R_roll = rotation_matrix(math.radians(s.camera_roll_deg))
        self.centre = np.array([s.width / 2, s.height / 2])
        self.base = background_image(s)
        half = self.sc.inner_w / 2
        sc = self.sc
        self.shapes = {
            "glass": rectangle_points(-half, half, -sc.depth, sc.head),
            "left": rectangle_points(-half - sc.wall, -half, -sc.depth - sc.wall, sc.head),
            "right": rectangle_points(half, half + sc.wall, -sc.depth - sc.wall, sc.head),
            "bottom": rectangle_points(-half, half, -sc.depth - sc.wall, -sc.depth),
        }
        L, T = sc.float_l / 2, sc.float_t / 2
        self.float_local = rectangle_points(-L, L, -T, T)
        self.looks = s.float_rounded or s.float_bend_px or s.float_specular or s.float_submerged

    def transforms(self, tilt: float, dx: float):
        """(to_img, to_container): container coordinates (x right, y up) <-> image pixels (y down)."""
        R_c, pos = rotation_matrix(tilt), np.array([self.sc.x0 + dx, self.s.height - self.sc.y0])  # y up in world
        R_roll, centre = self.R_roll, self.centre

        def to_img(pts: np.ndarray) -> np.ndarray:
            cam = (pts @ R_c.T + pos - centre) @ R_roll.T
            return np.column_stack([cam[:, 0] + centre[0], centre[1] - cam[:, 1]])

        def to_container(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            local = (np.stack([x - centre[0], centre[1] - y], axis=-1) @ R_roll + centre - pos) @ R_c
            return local[..., 0], local[..., 1]

        return to_img, to_container

    def paint(self, rel: float, tilt: float, dx: float) -> np.ndarray:
        """The undegraded picture of one pose."""
        to_img, to_container = self.transforms(tilt, dx)
        img = self.base.copy()
        paint_polygon(img, to_img(self.shapes["glass"]), (235, 240, 240), 0.25)
        # liquid: the container interior below the surface line through the float centre (a convex polygon)
        paint_polygon(img, to_img(_liquid_polygon(self.sc.inner_w / 2, self.sc.depth, rel)), LIQUID_BGR, 0.8)
        for part in ("left", "right", "bottom"):
            paint_polygon(img, to_img(self.shapes[part]), WALL_BGR, 0.92)
        corners, bgr = to_img(self.float_local @ rotation_matrix(rel).T), preset(self.s.float_color).bgr
        if self.looks:
            paint_float(img, self.s, self.sc, rel, corners, to_container, bgr)
        else:
            paint_polygon(img, corners, bgr, 1.0)
        return img


def render_frames(s: SynthSettings):
    """Yield (truth row dict, BGR uint8 frame) for every frame; the generator behind render_video."""
    if s.renderer == "pbr":
        yield from pbr_frames(s)
        return
    if s.scene == "surface":
        yield from surface_frames(s, _motion(s))
        return
    mo = _motion(s)
    t, rel, tilt, dx, accel, drift = mo.t, mo.rel, mo.tilt, mo.dx, mo.accel, mo.drift
    scene = _FloatScene(s)
    check_in_picture(s, scene.sc, mo, surface=False)
    sc, roll = scene.sc, math.radians(s.camera_roll_deg)
    noise = NoisePool(scene.base.shape, s.noise_sigma, mo.rng) if s.noise_sigma > 0 else None
    offsets = (np.linspace(0, 1, 5) - 0.5) * s.motion_blur / s.fps if s.motion_blur > 0 else np.zeros(1)
    sub = _poses_at(s, (t[:, None] + offsets[None, :]).ravel()) if s.motion_blur > 0 else None
    for k in range(len(t)):
        to_img, _ = scene.transforms(tilt[k], dx[k])
        if sub is None:
            img = scene.paint(rel[k], tilt[k], dx[k])
        else:  # motion blur: the exposure's poses averaged, centred on the frame time
            n = len(offsets)
            img = sum(scene.paint(*(p[k * n + j] for p in sub)) for j in range(n)) / np.float32(n)
        img = degrade_picture(img, s, t[k], drift[k], noise)
        centre = to_img(np.zeros((1, 2)))[0]
        ctr_base = to_img(np.array([[0.0, -sc.depth]]))[0]
        row = {
            "frame": k,
            "t_s": t[k],
            "rel_angle_deg": math.degrees(rel[k]),
            "container_angle_deg": math.degrees(tilt[k] + roll),
            "float_angle_deg": math.degrees(rel[k] + tilt[k] + roll),
            "float_x_px": centre[0],
            "float_y_px": centre[1],
            "container_x_px": ctr_base[0],
            "container_y_px": ctr_base[1],
            "accel_m_s2": accel[k],
        }
        yield row, img


def _liquid_polygon(half: float, depth: float, angle: float) -> np.ndarray:
    """The container interior below a surface line through the origin at `angle` (CCW), as a convex polygon."""
    slope = math.tan(angle)
    yl, yr = -half * slope, half * slope
    return np.array([[-half, -depth], [half, -depth], [half, yr], [-half, yl]], float)


def render_video(
    path: str | Path,
    settings: SynthSettings,
    truth_csv: str | Path | None = None,
    progress: bool = False,
    scene_json: str | Path | None = None,
) -> Truth:
    """Render the video to `path` (atomically) and return its ground truth; also write it to `truth_csv`, and with
    the pbr renderer the scene's random draw to `scene_json`."""
    s = settings
    path = Path(path)
    if path.suffix.lower() not in (".mp4", ".mov", ".m4v"):
        raise UserError(f"output video {path} must end in .mp4, .mov or .m4v.")
    rows: list[dict] = []
    n = len(frame_times(s))
    quality = s.quality
    if s.renderer == "pbr" and quality is None and s.codec == "h264":
        quality = draw_scene(s.scene_seed, s.scene).crf
    with atomic_path(path) as tmp:
        with VideoWriter(tmp, s.width, s.height, s.fps, s.codec, quality) as writer:
            for row, frame in tqdm(
                render_frames(s), total=n, desc="render", unit="frame", disable=None if progress else True, leave=False
            ):
                writer.write(frame, row["t_s"])
                rows.append(row)
        truth = Truth({c: np.array([r[c] for r in rows]) for c in rows[0]})
        if truth_csv is not None:
            truth.to_csv(truth_csv)
        if scene_json is not None and s.renderer == "pbr":
            write_json(scene_json, scene_record(s))
    return truth
