"""The physically based renderer of `sloshid synth --renderer pbr`: Mitsuba 3 path-traces a random scene per frame.

A glass container (dielectric, IOR 1.5, real wall and bottom thickness) holds a dielectric liquid (IOR 1.33) whose
dye is an absorbing (or, for juice, scattering) homogeneous medium, with its top a mesh: the pendulum's tilted plane
(the same trace as the painted renderer, `relative_angle_rad` through `_motion`), a weak second mode and a meniscus.
Refraction, the surface's reflection, total internal reflection and caustics come from the path tracer (`volpath`,
`scalar_rgb`: Mitsuba's LLVM variants crash on these machines); glare from a hard light is a bloom of the
over-exposed pixels, lens distortion is applied with OpenCV to the picture and to the truth alike. The truth is the
scene's 3-D geometry projected through the same camera (the surface's mid-line across the inner width, the wall
heights at the inner walls above the rest level, the float's long axis, the container's axis), in the painted
renderer's columns, plus the container's image box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np

from sloshid.core.errors import UserError
from sloshid.synthetic.pbr_scene import (
    Mesh,
    PbrScene,
    Surface,
    container_meshes,
    draw_scene,
    dressing_meshes,
    float_half_height_m,
    float_mesh,
    json_ready,
)
from sloshid.synthetic.scene import NoisePool, SynthSettings, _motion, _smoothstep, move_position_m
from sloshid.synthetic.surface_scene import _second_mode_height
from sloshid.video.colors import preset

MAX_DEPTH = 24
"""Path length: a ray through a glass of liquid crosses eight interfaces before it reaches the wall behind."""
IOR_GLASS, IOR_LIQUID = 1.5, 1.33
AMBIENT = {"soft": 0.8, "hard": 0.35}
"""The room's light on the background, as a glow of its own colour: the path tracer's shadow rays stop at glass, so a
background lit only by the key light would be seen through the liquid by caustic paths alone (speckled noise)."""
SPECK_GREY = 30
"""A pixel this far (grey levels) from its 3x3 median is a speck of chance reflection and takes the median: a
feature two pixels wide (a graduation mark) keeps its median and stays."""
SMOOTH_GREY = 24.0
"""An edge-keeping smoothing (bilateral, grey levels) takes the path tracer's grain out before the sensor's own noise
goes in: at a few samples per pixel, chance reflections in the glass speckle a dark liquid."""
GLOW_SAMPLING = 0.02
"""The background's glow is seen, not sampled as a light: the key light then gets the emitter samples."""
BLOOM_SHARE = 0.02
"""Glare: the light above full scale is spread over this share of the picture's width and added back."""


def _linear(name: str) -> np.ndarray:
    """A colour preset's RGB as linear reflectance (sRGB decoded)."""
    c = np.asarray(preset(name).bgr[::-1], float) / 255
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


MEDIUM_ABSORBANCE = 0.4
"""Largest absorbance (across the inner diameter) the dye's medium carries; the rest of the dye is a tint at each
crossing of the liquid's interfaces. A path tracer samples an absorber's transmittance by chance (a ray survives or
dies), so a strong dye as a medium alone was speckled even at 64 samples per pixel; this keeps the path-length shading
of the liquid (lighter at the walls and in the meniscus) at a noise a denoise step removes."""


def liquid_optics(sc: PbrScene) -> tuple[dict | None, np.ndarray, np.ndarray | None]:
    """The liquid's medium (None for juice), the tint per crossing of its interfaces, and juice's diffuse colour
    (None for a clear liquid): a dye (strong or faint) of the preset's hue, cola (near black), or an opaque juice."""
    if sc.liquid == "juice":  # scattering within a fraction of a millimetre: a diffuse body under a glossy surface
        return None, np.ones(3), np.clip(0.05 + 0.9 * _linear(sc.liquid_color), 0, 0.95)
    if sc.liquid == "cola":
        absorbance = -np.log([0.3, 0.16, 0.08]) * 5
    else:
        strength = 3.0 if sc.liquid == "strong_dye" else 0.6
        absorbance = -np.log(np.clip(_linear(sc.liquid_color), 0.02, 0.95)) * strength
    share = min(1.0, MEDIUM_ABSORBANCE / max(float(absorbance.max()), 1e-9))
    sigma = np.maximum(share * absorbance / (2 * sc.inner_radius_m), 1e-4)
    tint = np.exp(-(1 - share) * absorbance / 2)  # a ray through the body crosses two interfaces
    scale = float(sigma.max())  # Mitsuba reads an RGB as a reflectance (0..1): the extinction is scaled
    medium = {
        "type": "homogeneous",
        "scale": scale,
        "sigma_t": {"type": "rgb", "value": (sigma / scale).tolist()},
        "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]},
    }
    return medium, tint, None


_RING = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], np.uint8)


def despeckled(rgb: np.ndarray) -> np.ndarray:
    """Single-pixel fireflies (a light found by chance through glass) clamped to 1.5x their brightest neighbour:
    a glint of the light in the glass covers several pixels and stays."""
    ceiling = cv2.dilate(rgb, _RING) * np.float32(1.5) + np.float32(1e-3)
    return np.minimum(rgb, ceiling)


def rot_seen(angle: float) -> np.ndarray:
    """Rotation of world points that turns the picture counter-clockwise as seen by `angle` (about -y: x toward z)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


@dataclass
class Camera:
    """A pinhole camera with OpenCV's lens distortion: world -> pixel (top-left pixel centre at 0, 0)."""

    R: np.ndarray
    """World to camera rotation (OpenCV axes: x right, y down, z forward)."""
    C: np.ndarray
    K: np.ndarray
    dist: np.ndarray
    width: int
    height: int

    def project(self, pts: np.ndarray) -> np.ndarray:
        """Pixel positions of world points (n x 3), lens distortion included."""
        rvec, _ = cv2.Rodrigues(self.R)
        out, _ = cv2.projectPoints(np.asarray(pts, float).reshape(-1, 1, 3), rvec, -self.R @ self.C, self.K, self.dist)
        return out.reshape(-1, 2)

    def mitsuba_to_world(self) -> list[list[float]]:
        """The sensor's to_world matrix: Mitsuba's camera looks along +z with +x to the picture's left, +y up."""
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = -self.R[0], -self.R[1], self.R[2], self.C
        return m.tolist()

    @property
    def fov_x_deg(self) -> float:
        return math.degrees(2 * math.atan(self.width / 2 / self.K[0, 0]))

    def distortion_maps(self) -> tuple[np.ndarray, np.ndarray] | None:
        """For every output (distorted) pixel, where it lies in the undistorted render (None without distortion)."""
        if not np.any(self.dist):
            return None
        ys, xs = np.mgrid[0 : self.height, 0 : self.width].astype(np.float64)
        pts = np.stack([xs.ravel(), ys.ravel()], axis=-1).reshape(-1, 1, 2)
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-6)
        und = cv2.undistortPoints(pts, self.K, self.dist, None, None, self.K, crit).reshape(self.height, self.width, 2)
        return und[..., 0].astype(np.float32), und[..., 1].astype(np.float32)


@dataclass
class Pose:
    """The container's pose at one instant: container coordinates -> world, and the liquid's surface in them."""

    rot: np.ndarray
    shift: np.ndarray
    surface: Surface

    def world(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(p, float) @ self.rot.T + self.shift


def make_camera(sc: PbrScene, s: SynthSettings, rest_pose: Pose) -> Camera:
    """The camera the draw describes: elevation above the surface's centre, distance, framing, roll, distortion."""
    surf_c = rest_pose.world(np.array([0.0, 0.0, sc.rest_m]))
    e = math.radians(sc.elevation_deg)
    C = surf_c + sc.distance_m * np.array([0.0, -math.cos(e), math.sin(e)])
    target = rest_pose.world(np.array([0.0, 0.0, (sc.height_m - sc.bottom_m) / 2]))
    f = (target - C) / np.linalg.norm(target - C)
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    R0 = np.array([r, np.cross(f, r), f])
    a = math.radians(sc.roll_deg)  # the picture turns counter-clockwise as seen: the camera turns the other way
    R_img = np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    focal = sc.frame_fill * s.height * np.linalg.norm(target - C) / (sc.height_m + sc.bottom_m)
    K = np.array([[focal, 0, s.width / 2 - 0.5], [0, focal, s.height / 2 - 0.5], [0, 0, 1.0]])
    return Camera(R_img @ R0, C, K, np.array([sc.k1, sc.k2, 0.0, 0.0, 0.0]), s.width, s.height)


def _tumbler_bottom_z(sc: PbrScene, s: SynthSettings) -> float:
    """The table's height: under the glass, lowered when the container leans or tilts so that it never cuts it."""
    tilt = abs(sc.lean_deg) + abs(s.container_tilt_deg)
    gap = 0.0 if tilt == 0 else sc.outer_half_width_m * math.sin(math.radians(tilt)) + 0.002
    return -sc.bottom_m - gap


def _travel_m(s: SynthSettings, sc: PbrScene, t: np.ndarray, m_per_px: float) -> np.ndarray:
    """The container's travel to the right (m): the robot's move itself, or --travel's crossing in pixels."""
    if s.motion == "move":
        return move_position_m(s, t)
    return s.travel_px * m_per_px * _smoothstep(t / max(s.duration_s, 1e-9))


def _load_in_order(mi, d: dict, tries: int = 50):
    """The scene with its shapes in the order given: Mitsuba's loader put two of them the other way round about one
    time in twenty, which reorders the lights a sample picks from and so changes every pixel; such a load is
    repeated, so that the same scene always renders the same picture."""
    shape_types = ("cube", "sphere", "rectangle")
    d = {k: mi.load_dict(v) if isinstance(v, dict) and v.get("type") in shape_types else v for k, v in d.items()}
    want = [k for k, v in d.items() if isinstance(v, mi.Shape)]
    for _ in range(tries):
        scene = mi.load_dict(d, parallel=False)
        if [sh.id() for sh in scene.shapes()] == want:
            return scene
    raise RuntimeError(f"Mitsuba loaded the scene's shapes out of order {tries} times")


class PbrRenderer:
    """One clip's fixed parts (scene draw, camera, lens maps, media) and its per-frame path tracing."""

    def __init__(self, s: SynthSettings, sc: PbrScene) -> None:
        import mitsuba as mi

        if mi.variant() != "scalar_rgb":
            mi.set_variant("scalar_rgb")
        self.mi, self.s, self.sc = mi, s, sc
        self.mo = _motion(s)
        rest = self.pose(0.0, 0.0, 0.0, 0.0)
        cam = make_camera(sc, s, rest)
        m_per_px = np.linalg.norm(cam.C - rest.world(np.array([0, 0, sc.rest_m]))) / cam.K[0, 0]
        self.dx_m = _travel_m(s, sc, self.mo.t, m_per_px)
        mid = (self.dx_m.min() + self.dx_m.max()) / 2
        self.camera = make_camera(sc, s, replace(rest, shift=rest.shift + np.array([mid, 0.0, 0.0])))
        self.maps = self.camera.distortion_maps()
        half = sc.rest_half_width_m
        tan_amp = math.tan(math.radians(abs(s.amplitude_deg)) if s.motion == "decay" else 0.1)
        painted = replace(s, renderer="painted", scene_seed=0, spp=SynthSettings.spp, scene="surface")
        self.h2 = _second_mode_height(replace(painted, second_mode=sc.second_mode), self.mo.t, half * tan_amp)
        self.table_z = _tumbler_bottom_z(sc, s)
        self.exposure: float | None = None
        self._check_in_picture()

    def pose(self, rel: float, tilt: float, dx: float, h2: float) -> Pose:
        """The container's pose (static lean plus the robot's tilt, travel) and the surface relative to it."""
        sc = self.sc
        rot = rot_seen(math.radians(sc.lean_deg) + tilt)
        surface = Surface(rel - math.radians(sc.lean_deg), h2, sc.meniscus_m)
        return Pose(rot, np.array([dx, 0.0, 0.0]), surface)

    def frame_pose(self, k: int) -> Pose:
        return self.pose(self.mo.rel[k], self.mo.tilt[k], self.dx_m[k], self.h2[k])

    def _check_in_picture(self) -> None:
        """Refuse a motion whose picture cannot show it: the liquid over the rim, the container outside the frame."""
        sc, mo = self.sc, self.mo
        peak = float(np.max(sc.rest_half_width_m * np.abs(np.tan(mo.rel - math.radians(sc.lean_deg))) + abs(self.h2)))
        room = sc.height_m - sc.rest_m - sc.meniscus_m
        if peak > room:
            raise UserError(
                f"the liquid would rise {1000 * peak:.0f} mm up a wall, above the rim ({1000 * room:.0f} mm above the "
                f"liquid at rest in scene {sc.seed}): lower `amplitude_deg` or `accel_m_s2`, or draw another `scene_seed`."
            )
        for k in (int(np.argmin(self.dx_m)), int(np.argmax(self.dx_m))):
            box = self.box_px(self.frame_pose(k))
            if box[0] < 0 or box[1] < 0 or box[2] > self.s.width - 1 or box[3] > self.s.height - 1:
                raise UserError(
                    f"the container would leave the {self.s.width}x{self.s.height} picture (scene {sc.seed} spans x = "
                    f"{box[0]:.0f} to {box[2]:.0f} px, y = {box[1]:.0f} to {box[3]:.0f} px): lower `travel_px` or "
                    "`accel_m_s2`, shorten `move_duration_s`, or draw another `scene_seed`."
                )

    def box_px(self, pose: Pose) -> np.ndarray:
        """The container's image box (x0, y0, x1, y1) from its outer hull's projection."""
        sc = self.sc
        th = np.linspace(-math.pi, math.pi, 48, endpoint=False)
        pts = []
        for z in (-sc.bottom_m, sc.height_m):
            r = sc.inner_radius(th, max(z, 0.0)) + sc.glass_m
            pts.append(np.column_stack([r * np.cos(th), r * np.sin(th), np.full_like(th, z)]))
        px = self.camera.project(pose.world(np.concatenate(pts)))
        return np.concatenate([px.min(axis=0), px.max(axis=0)])

    # --- the Mitsuba scene -------------------------------------------------------------------------------------
    def _glow(self, rgb, share: float = 1.0) -> dict:
        """The room's light on a surface as a glow of its own colour (see AMBIENT), seen but not sampled."""
        radiance = [share * AMBIENT[self.sc.light] * c for c in rgb]
        return {"type": "area", "radiance": {"type": "rgb", "value": radiance}, "sampling_weight": GLOW_SAMPLING}

    def _mesh(self, name: str, mesh: Mesh, bsdf: dict, pose: Pose | None, interior=None, glow: dict | None = None):
        mi = self.mi
        v, f = mesh
        if pose is not None:
            v = pose.world(v)
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        if interior is not None:
            props["interior"] = interior
        if glow is not None:
            props["emitter"] = mi.load_dict(glow)
        m = mi.Mesh(name, len(v), len(f), props=props)
        p = mi.traverse(m)
        p["vertex_positions"] = type(p["vertex_positions"])(np.asarray(v, np.float32).ravel())
        p["faces"] = type(p["faces"])(np.asarray(f, np.uint32).ravel())
        p.update()
        return m

    def _background(self) -> dict:
        """Wall, table (or the shelf whose edge runs behind the liquid), clutter, lights: fixed for the clip."""
        sc = self.sc
        tz = self.table_z

        def diffuse(rgb) -> dict:
            return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}}

        def box(name, lo, hi, rgb) -> tuple[str, dict]:
            lo, hi = np.asarray(lo, float), np.asarray(hi, float)
            mi = self.mi
            to_world = mi.ScalarTransform4f().translate(((lo + hi) / 2).tolist()).scale(((hi - lo) / 2).tolist())
            return name, {"type": "cube", "to_world": to_world, "bsdf": diffuse(rgb), "emitter": self._glow(rgb)}

        x_mid = float(np.mean(self.dx_m))
        back = 0.35 + sc.outer_half_width_m
        d: dict[str, dict] = dict(
            [
                box("wall", [x_mid - 3, back, tz - 2], [x_mid + 3, back + 0.01, tz + 2], list(sc.wall_rgb)),
                box("table", [x_mid - 3, -3, tz - 0.05], [x_mid + 3, back, tz], list(sc.table_rgb)),
            ]
        )
        if sc.background == "table_edge":
            y0 = sc.outer_half_width_m + 0.04
            top = tz + sc.bottom_m + 0.55 * sc.rest_m
            d.update([box("shelf", [x_mid - 3, y0, tz], [x_mid + 3, back, top], [0.8 * c for c in sc.table_rgb])])
        for i, (x, y, hx, hy, h, r, g, b) in enumerate(sc.clutter):
            yy = sc.outer_half_width_m + hy + y
            d.update([box(f"clutter{i}", [x_mid + x - hx, yy - hy, tz], [x_mid + x + hx, yy + hy, tz + h], [r, g, b])])
        mi = self.mi
        az = math.radians(sc.light_azimuth_deg)
        aim = np.array([x_mid, 0.0, sc.rest_m])
        if sc.light == "soft":
            pos = aim + 0.9 * np.array([math.sin(az) * math.cos(0.7), -math.cos(az) * math.cos(0.7), math.sin(0.7)])
            to_world = (
                mi.ScalarTransform4f()
                .look_at(origin=pos.tolist(), target=aim.tolist(), up=[0, 0, 1])
                .scale([0.35, 0.35, 1.0])
            )
            d["light"] = {
                "type": "rectangle",
                "to_world": to_world,
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [6.0, 6.0, 6.0]}},
            }
            d["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}
        else:
            pos = aim + 0.6 * np.array([math.sin(az) * math.cos(0.5), -math.cos(az) * math.cos(0.5), math.sin(0.5)])
            d["light"] = {
                "type": "sphere",
                "center": pos.tolist(),
                "radius": 0.02,
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [600.0, 580.0, 540.0]}},
            }
            d["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [0.3, 0.3, 0.32]}}
        return d

    def scene(self, pose: Pose, spp: int):
        """The Mitsuba scene of one pose."""
        mi, sc = self.mi, self.sc
        medium_dict, tint, juice = liquid_optics(sc)
        medium = mi.load_dict(medium_dict) if medium_dict is not None else None
        parts = container_meshes(sc, pose.surface)
        glass = {"type": "dielectric", "int_ior": IOR_GLASS, "ext_ior": 1.0}
        tinted = {"specular_transmittance": {"type": "rgb", "value": tint.tolist()}}
        if juice is None:
            wet = {"type": "dielectric", "int_ior": IOR_LIQUID, "ext_ior": IOR_GLASS, **tinted}
            top = {"type": "dielectric", "int_ior": IOR_LIQUID, "ext_ior": 1.0, **tinted}
        else:
            # lit mostly by its glow: the key light reaches the body through glass only
            body = {"type": "rgb", "value": (0.3 * juice).tolist()}
            wet = {"type": "plastic", "diffuse_reflectance": body, "int_ior": IOR_LIQUID, "ext_ior": IOR_GLASS}
            top = {"type": "plastic", "diffuse_reflectance": body, "int_ior": IOR_LIQUID, "ext_ior": 1.0}
        body_glow = None if juice is None else self._glow(juice, 1.0)  # lit inside the glass by caustics alone
        d = {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": MAX_DEPTH, "rr_depth": 12},
            "sensor": {
                "type": "perspective",
                "fov": self.camera.fov_x_deg,
                "fov_axis": "x",
                "to_world": mi.ScalarTransform4f(self.camera.mitsuba_to_world()),
                "film": {
                    "type": "hdrfilm",
                    "width": self.s.width,
                    "height": self.s.height,
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgb",
                },
                "sampler": {"type": "multijitter", "sample_count": spp},
            },
            "glass_air": self._mesh("glass_air", parts["glass_air"], glass, pose),
            "glass_liquid": self._mesh("glass_liquid", parts["glass_liquid"], wet, pose, medium, body_glow),
            "liquid_air": self._mesh("liquid_air", parts["liquid_air"], top, pose, medium, body_glow),
            **self._background(),
        }
        dye = _linear(sc.liquid_color) if sc.liquid_color != "none" else np.array([0.05, 0.03, 0.02])
        for name, mesh in dressing_meshes(sc).items():
            rgb = [0.85, 0.85, 0.85] if name == "marks" else (0.8 * dye).tolist()
            bsdf = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}}
            d[name] = self._mesh(name, mesh, bsdf, pose)
        if self.s.scene == "float":
            d["float"] = self._mesh(
                "float",
                self._float_local(pose),
                {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": _linear(sc.float_color).tolist()}},
                pose,
                glow=self._glow(_linear(sc.float_color), 0.6),
            )
        return _load_in_order(mi, d)

    def _float_local(self, pose: Pose) -> Mesh:
        """The float in container coordinates: at the surface's centre, along its slope, a third of it below."""
        v, f = float_mesh(self.sc)
        a = pose.surface.tilt_rad
        lift = float(pose.surface.mid_line(self.sc, np.zeros(1))[0]) + float_half_height_m(self.sc) / 3
        return v @ rot_seen(a).T + [0.0, 0.0, lift], f

    # --- pictures and truth --------------------------------------------------------------------------------------
    def radiance(self, k: int, spp: int) -> np.ndarray:
        """The linear RGB picture of frame k (undistorted, seeded by the frame's index)."""
        img = self.mi.render(self.scene(self.frame_pose(k), spp), seed=int(k))  # type: ignore[arg-type]  # stub: UInt32
        return np.array(img, dtype=np.float32)[..., :3]

    def develop(self, rgb: np.ndarray, noise: NoisePool | None) -> np.ndarray:
        """The camera's part: exposure (fixed by the first frame), lens distortion, glare, sRGB, noise, 8 bits BGR."""
        if self.exposure is None:
            self.exposure = 0.8 / max(float(np.percentile(rgb.mean(axis=2), 97)), 1e-6)
        img = despeckled(rgb) * np.float32(self.exposure)
        if self.maps is not None:
            img = cv2.remap(img, *self.maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        over = np.maximum(img - 1.0, 0)
        if over.any():
            img = img + 0.5 * cv2.GaussianBlur(over, (0, 0), BLOOM_SHARE * self.s.width)
        img = np.clip(img, 0, 1)
        srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * np.power(img, 1 / 2.4) - 0.055)
        out = np.clip(255 * srgb[..., ::-1] + 0.5, 0, 255).astype(np.uint8)
        med = cv2.medianBlur(out, 3)
        specks = np.abs(out.astype(np.int16) - med).max(axis=2) > SPECK_GREY
        out[specks] = med[specks]
        out = cv2.bilateralFilter(out.astype(np.float32), 5, SMOOTH_GREY, 1.5)
        if noise is not None:
            out += noise.draw()
        return np.clip(out + 0.5, 0, 255).astype(np.uint8)

    def truth_row(self, k: int) -> dict:
        """The frame's truth from the scene's geometry through the camera (angles counter-clockwise as seen)."""
        sc, pose = self.sc, self.frame_pose(k)
        half, rest = sc.rest_half_width_m, sc.rest_m
        surf = pose.surface
        slope = math.tan(surf.tilt_rad)  # the mid-line's best-fit line: the second mode's own is flat
        ends = np.array([[-half, 0, rest - half * slope], [half, 0, rest + half * slope]])
        # at rest the liquid is level, so in a leaning container its rest surface at the walls is not `rest`: the wall
        # heights are the rise above that (what a tracker reads against the clip's frames at rest)
        level = [rest + x * math.tan(-math.radians(sc.lean_deg)) for x in (-half, half)]
        axis_pts = np.array([[-half, 0, level[0]], [half, 0, level[1]], [0, 0, rest], [0, 0, 0.0]])
        walls = [surf.mid_line(sc, np.array([x]))[0] - z for x, z in zip((-half, half), level)]
        wall_pts = np.array([[-half, 0, level[0] + walls[0]], [half, 0, level[1] + walls[1]]])
        px = self.camera.project(pose.world(np.vstack([ends, axis_pts, wall_pts])))

        def angle(a, b) -> float:
            return math.degrees(math.atan2(-(b[1] - a[1]), b[0] - a[0]))

        # the container's angle is its axis's (inner bottom to rest surface) less 90 deg, what its walls show: seen from
        # above, a leaning container's cross-wise axis turns less than its walls (5.8 against 6.2 deg at 6 and 15 deg)
        surface_deg, container_deg = angle(px[0], px[1]), angle(px[5], px[4]) - 90.0
        wall_px = [math.copysign(float(np.hypot(*(px[6 + i] - px[2 + i]))), walls[i]) for i in (0, 1)]
        box = self.box_px(pose)
        row = {
            "frame": k,
            "t_s": self.mo.t[k],
            "rel_angle_deg": surface_deg - container_deg,
            "container_angle_deg": container_deg,
        }
        if self.s.scene == "float":
            L = sc.float_length_m
            centre = self._float_local(pose)[0].mean(axis=0)
            axis = rot_seen(surf.tilt_rad) @ np.array([L / 2, 0, 0])
            fp = self.camera.project(pose.world(np.array([centre - axis, centre + axis, centre])))
            row |= {"float_angle_deg": angle(fp[0], fp[1]), "float_x_px": fp[2, 0], "float_y_px": fp[2, 1]}
        else:
            row |= {
                "surface_angle_deg": surface_deg,
                "left_wall_px": wall_px[0],
                "right_wall_px": wall_px[1],
                "left_wall_mm": 1000 * walls[0],
                "right_wall_mm": 1000 * walls[1],
                "surface_x_px": px[4, 0],
                "surface_y_px": px[4, 1],
            }
        row |= {
            "container_x_px": px[5, 0],
            "container_y_px": px[5, 1],
            "accel_m_s2": self.mo.accel[k],
            "box_x0_px": box[0],
            "box_y0_px": box[1],
            "box_x1_px": box[2],
            "box_y1_px": box[3],
        }
        return row

    def frames(self, spp: int, reuse_still: bool = False):
        """Yield (truth row, BGR frame) per frame; `reuse_still` renders a clip without motion once and adds fresh
        sensor noise per frame (a still scene)."""
        rng = np.random.default_rng([self.s.seed, self.sc.seed, 3])
        noise = NoisePool((self.s.height, self.s.width, 3), self.sc.noise_sigma, rng) if self.sc.noise_sigma else None
        still = None
        for k in range(len(self.mo.t)):
            if reuse_still and still is not None:
                rgb = still
            else:
                rgb = self.radiance(k, spp)
                still = rgb
            yield self.truth_row(k), self.develop(rgb, noise)


def is_still(s: SynthSettings) -> bool:
    """Whether nothing moves in the clip (no tap, no move, no tilt, no travel): one render serves every frame."""
    if s.container_tilt_deg or s.travel_px or s.motion == "move":
        return False
    return s.amplitude_deg == 0 or s.tap_s >= s.duration_s


def pbr_frames(s: SynthSettings, sc: PbrScene | None = None):
    """The pbr renderer's (truth row, frame) generator, `render_frames`' counterpart (`sc`: a scene of one's own
    instead of the draw from s.scene_seed, e.g. with the camera's roll set)."""
    sc = draw_scene(s.scene_seed, s.scene) if sc is None else sc
    yield from PbrRenderer(s, sc).frames(s.spp, reuse_still=is_still(s))


def scene_record(s: SynthSettings) -> dict:
    """What a user reads beside the truth: the scene's random draw and the renderer's settings."""
    return {
        "renderer": "pbr",
        "scene_seed": s.scene_seed,
        "spp": s.spp,
        "mitsuba_variant": "scalar_rgb",
        "scene": json_ready(draw_scene(s.scene_seed, s.scene).to_dict()),
    }
