"""The synthetic scenes' shared base: `SynthSettings`, the ground-truth table, the move and the pendulum trace in
time, the scene geometry, polygon painting with exact coverage and the camera's degradations. Every renderer
(`render` for the painted float, `float_look`, `surface_scene`, `pbr`) builds on this module and none of them is
imported by it."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from sloshid.core.errors import SettingError, UserError
from sloshid.core.settings import check_in_metres, setting_field
from sloshid.core.tables import write_csv
from sloshid.model.conventions import SEEN_SIGN
from sloshid.model.pendulum import TABLE_I, SloshParams
from sloshid.model.simulate import integrate_pendulums
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, preset
from sloshid.video.frames import Codec

LIQUID_BGR = (200, 165, 110)
"""Pale blue water: saturation below every float preset, so no preset mistakes the liquid for the float."""
WALL_BGR = (70, 70, 70)
BACKGROUND_TOP_BGR = np.array([225, 225, 220], np.float32)
BACKGROUND_BOTTOM_BGR = np.array([165, 170, 175], np.float32)


@dataclass
class SynthSettings:
    """Everything `sloshid synth` can vary; the defaults give a clean 640x480 30 fps tap test of Table I."""

    width: int = setting_field(640, unit="px", group="timing")
    """Frame width in pixels (the video takes an even one: an odd width loses its last column, the truth stays)."""
    height: int = setting_field(480, unit="px", group="timing")
    """Frame height in pixels (an odd height loses its last row, as an odd width its last column)."""
    fps: float = setting_field(30.0, unit="frames/s", group="timing")
    """Nominal frame rate in frames per second."""
    duration_s: float = setting_field(4.0, unit="s", option="duration", group="timing")
    """Length of the video in seconds."""
    vfr_jitter: float = setting_field(0.0, unit="frame intervals", group="timing")
    """Variable frame rate: each timestamp moves by up to this fraction of a frame interval (0..0.45)."""
    motion: Literal["decay", "move"] = setting_field("decay", group="motion")
    """'decay': tap-test free decay; 'move': response to a constant-acceleration move to the image right."""
    f_hz: float | None = setting_field(None, unit="Hz", group="motion")
    """Natural frequency (give with `zeta`); not given: the liquid of `l_m`, `d_ns_per_m` and `m_kg`."""
    zeta: float | None = setting_field(None, group="motion")
    """Damping ratio (give with `f_hz`)."""
    m_kg: float = setting_field(TABLE_I.m_kg, unit="kg", group="motion")
    """Liquid mass (seed Table I by default)."""
    l_m: float = setting_field(TABLE_I.l_m, unit="m", group="motion")
    """Pendulum length l = g/omega^2."""
    d_ns_per_m: float = setting_field(TABLE_I.d_ns_per_m, unit="N s/m", group="motion")
    """Damping constant d = 2 m omega zeta."""
    amplitude_deg: float = setting_field(8.0, unit="deg", option="amplitude", group="motion")
    """Decay: first peak of the relative angle after the tap, in degrees (linearised estimate)."""
    tap_s: float = setting_field(0.5, unit="s", option="tap", group="motion")
    """Decay: time of the tap; the liquid is at rest before it."""
    accel_m_s2: float = setting_field(2.0, unit="m/s^2", option="accel", group="motion")
    """Move: acceleration magnitude of the accelerate/decelerate profile."""
    move_start_s: float = setting_field(0.5, unit="s", option="move-start", group="motion")
    """Move: start time."""
    move_duration_s: float = setting_field(1.0, unit="s", option="move-duration", group="motion")
    """Move: total time (half accelerating, half decelerating)."""
    px_per_m: float = setting_field(500.0, unit="px/m", group="motion")
    """Move: image scale used to translate the container with the move."""
    travel_px: float = setting_field(0.0, unit="px", option="travel", group="camera")
    """Decay: the container crosses this many pixels to the right over the video (smooth start and stop)."""
    container_tilt_deg: float = setting_field(0.0, unit="deg", option="tilt", group="camera")
    """Amplitude of a sinusoidal container tilt in the picture, degrees."""
    container_tilt_hz: float = setting_field(0.4, unit="Hz", option="tilt-hz", group="camera")
    """Frequency of that tilt."""
    camera_roll_deg: float = setting_field(0.0, unit="deg", option="roll", group="camera")
    """Camera not level: the whole scene appears rotated by this angle (CCW as seen)."""
    noise_sigma: float = setting_field(0.0, unit="grey levels", option="noise", group="camera")
    """Sensor noise: standard deviation in grey levels (0..255 scale), per channel and pixel."""
    blur_px: float = setting_field(0.0, unit="px", option="blur", group="camera")
    """Optical blur: Gaussian sigma in pixels (0 = sharp)."""
    flicker: float = setting_field(0.0, group="camera")
    """Lighting flicker: relative brightness swing (0.05 = +-5 %), 100 Hz mains beat plus random drift."""
    codec: Codec = setting_field("h264", group="camera")
    """Compression: 'h264' (libx264) or 'mpeg4' (MPEG-4 Part 2)."""
    quality: float | None = setting_field(None, group="camera")
    """Codec quality: x264 CRF 0..51 (default 23) or MPEG-4 qscale 1..31 (default 4); lower is better."""
    float_color: str = setting_field(DEFAULT_FLOAT_COLOR, metavar="NAME", group="camera")
    """Float colour preset name: red, orange, yellow, green, blue, magenta or dark."""
    float_length_frac: float = setting_field(0.2, unit="frame heights", option="float-length", group="camera")
    """Float length as a fraction of the frame height."""
    seed: int = setting_field(0, group="camera")
    """Seed of every random draw (noise, flicker, frame-time jitter)."""
    float_rounded: bool = setting_field(False, group="camera")
    """Float scene: rounded float ends (a capsule) instead of square ones."""
    float_bend_px: float = setting_field(0.0, unit="px", option="float-bend", group="camera")
    """Float scene: the float's ends sag this many pixels below its middle (a slightly curved float)."""
    float_specular: float = setting_field(0.0, group="camera")
    """Float scene: opacity of a specular spot fixed to the light, so the float turns under it (0 = none)."""
    float_submerged: float = setting_field(0.0, group="camera")
    """Float scene: share of the float's thickness under the tinted liquid, seen through it (0..1)."""
    motion_blur: float = setting_field(0.0, unit="frame intervals", group="camera")
    """Exposure as a share of the frame interval (0..1): each frame averages 5 poses across it, centred."""
    scene: Literal["float", "surface"] = setting_field("float", group="surface")
    """'float': a coloured float on pale liquid; 'surface': dyed liquid whose surface itself is measured."""
    liquid_color: str = setting_field("blue", metavar="NAME", group="surface")
    """Surface scene: dye colour preset name (the liquid body's colour)."""
    elevation_deg: float = setting_field(0.0, unit="deg", option="elevation", group="surface")
    """Surface scene: camera this far above the surface plane, so the round surface shows as a thin ellipse."""
    meniscus_px: float = setting_field(0.0, unit="px", option="meniscus", group="surface")
    """Surface scene: thickness of the meniscus band along the surface (curls up 3x as high at the walls)."""
    meniscus_dark: bool = setting_field(False, group="surface")
    """Surface scene: a dark meniscus band instead of a bright one."""
    specular: float = setting_field(0.0, group="surface")
    """Surface scene: opacity of two vertical highlight stripes on the glass (0 = none)."""
    reflection: float = setting_field(0.0, group="surface")
    """Surface scene: opacity of the surface's mirror image on the wall near each side (0 = none)."""
    second_mode: float = setting_field(0.0, group="surface")
    """Surface scene: wall height of an antisymmetric second mode (1.7 f, 2 zeta) relative to the first mode's."""
    container_diameter_m: float = setting_field(0.1, unit="m", option="container-diameter", group="surface")
    """Surface scene: the container's inner diameter, which sets the millimetre scale of the wall-height truth."""
    renderer: Literal["painted", "pbr"] = setting_field("painted", group="renderer")
    """'painted': analytic polygons (exact edges, fast); 'pbr': a Mitsuba 3 path tracer of a random scene
    (sloshid.synthetic.pbr), drawn from `scene_seed`."""
    scene_seed: int = setting_field(0, group="renderer")
    """pbr: seed of the scene's random draw (container, liquid, background, camera, lens, light, sensor, float)."""
    spp: int = setting_field(8, unit="samples/pixel", group="renderer")
    """pbr: path-tracing samples per pixel: a 640x480 frame takes about 0.65 s of CPU per sample per pixel (8: 5.2 s,
    2.6 s on two free cores)."""

    def __post_init__(self) -> None:
        # (holds, the setting at fault, the sentence naming it as {name} and any other setting as {that_one})
        checks = [
            (16 <= self.width <= 7680, "width", "{name} must be 16..7680 pixels"),
            (16 <= self.height <= 4320, "height", "{name} must be 16..4320 pixels"),
            (0.5 <= self.fps <= 1000, "fps", "{name} must be between 0.5 and 1000 frames per second"),
            (0 < self.duration_s <= 3600, "duration_s", "{name} must be between 0 and 3600 s"),
            (0 <= self.vfr_jitter <= 0.45, "vfr_jitter", "{name} must be between 0 and 0.45 of a frame interval"),
            (self.motion in ("decay", "move"), "motion", "{name} must be 'decay' or 'move'"),
            (self.zeta is not None or self.f_hz is None, "zeta", "give {name} with {f_hz} (or neither)"),
            (self.f_hz is not None or self.zeta is None, "f_hz", "give {name} with {zeta} (or neither)"),
            (self.f_hz is None or self.f_hz > 0, "f_hz", "{name} must be positive"),
            (self.zeta is None or 0 <= self.zeta < 1, "zeta", "{name} must be in [0, 1)"),
            (abs(self.amplitude_deg) <= 40, "amplitude_deg", "{name} must be at most 40 degrees"),
            (self.noise_sigma >= 0, "noise_sigma", "{name} must not be negative"),
            (self.blur_px >= 0, "blur_px", "{name} must not be negative"),
            (0 <= self.flicker < 0.5, "flicker", "{name} must be in [0, 0.5)"),
            (abs(self.container_tilt_deg) <= 30, "container_tilt_deg", "{name} must be within 30 degrees"),
            (abs(self.camera_roll_deg) <= 30, "camera_roll_deg", "{name} must be within 30 degrees"),
            (
                0.05 <= self.float_length_frac <= 0.3,
                "float_length_frac",
                "{name} must be 0.05..0.3 of the frame height",
            ),
            (self.move_duration_s > 0, "move_duration_s", "{name} must be positive"),
            (
                # a move's container travels by its own acceleration: the crossing was ignored without a word
                self.motion != "move" or self.travel_px == 0,
                "travel_px",
                "{name} moves a decay's container across the picture; a {motion} move travels by {accel_m_s2} and "
                "{move_duration_s}",
            ),
            (self.px_per_m > 0, "px_per_m", "{name} must be positive"),
            (self.scene in ("float", "surface"), "scene", "{name} must be 'float' or 'surface'"),
            (0 <= self.float_submerged <= 1, "float_submerged", "{name} must be 0..1"),
            (0 <= self.float_specular <= 1, "float_specular", "{name} must be 0..1"),
            (0 <= self.motion_blur <= 1, "motion_blur", "{name} must be 0..1 of the frame interval"),
            (
                0 <= self.float_bend_px <= 0.2 * self.height,
                "float_bend_px",
                "{name} must be 0..0.2 of the frame height",
            ),
            (0 <= self.elevation_deg <= 20, "elevation_deg", "{name} must be 0..20 degrees"),
            (0 <= self.meniscus_px <= 10, "meniscus_px", "{name} must be 0..10 pixels"),
            (0 <= self.specular <= 1, "specular", "{name} must be 0..1"),
            (0 <= self.reflection <= 1, "reflection", "{name} must be 0..1"),
            (0 <= self.second_mode <= 1, "second_mode", "{name} must be 0..1 of the first mode's wall height"),
            (self.tap_s >= 0, "tap_s", "{name} must not be negative"),
            (self.move_start_s >= 0, "move_start_s", "{name} must not be negative"),
            (self.renderer in ("painted", "pbr"), "renderer", "{name} must be 'painted' or 'pbr'"),
            (1 <= self.spp <= 4096, "spp", "{name} must be 1..4096 samples per pixel"),
            (0 <= self.scene_seed < 2**63, "scene_seed", "{name} must be a non-negative integer"),
            (0 <= self.seed < 2**63, "seed", "{name} must be a non-negative integer"),
            (
                # the encoders' own ranges: PyAV raised (a traceback) outside them or clipped without a word
                self.quality is None or (0 <= self.quality <= 51 if self.codec == "h264" else 1 <= self.quality <= 31),
                "quality",
                "{name} must be an H.264 CRF of 0..51, or an MPEG-4 qscale of 1..31",
            ),
        ]
        for ok, setting, message in checks:
            if not ok:
                raise SettingError(setting, f"{message}.", *("f_hz", "zeta", "motion", "accel_m_s2", "move_duration_s"))
        check_in_metres("container_diameter_m", self.container_diameter_m, "0.1 for 100 mm")
        if self.renderer == "pbr":  # first: the other scene would refuse the option too, so it is no way out
            check_pbr_settings(self)
        # a look of the other scene would be rendered nowhere: refused, not ignored
        other = "surface" if self.scene == "float" else "float"
        for name, label in SCENE_ONLY[other].items():
            if getattr(self, name) != getattr(SynthSettings, name):
                raise SettingError(
                    name,
                    f"{{name}} ({label}) applies only to the {other} scene ({{scene}} {other}), not the {self.scene} "
                    "one.",
                    "scene",
                )
        if self.renderer != "pbr":
            for name in ("scene_seed", "spp"):
                if getattr(self, name) != getattr(SynthSettings, name):
                    raise SettingError(name, "{name} applies only to {renderer} pbr.", "renderer")
        for name in ("float_color", "liquid_color"):
            try:
                preset(getattr(self, name))
            except UserError as exc:  # named as the option given: synth --float-color and --liquid-color both check
                raise SettingError(name, f"{{name}}: {exc}") from None
        _ = self.params  # validates m, l, d

    @property
    def at_rest(self) -> str | None:
        """Why the liquid rests in every frame although a motion is asked for (a tap or a move after the video's end),
        or None: a still clip is a use, so it is said, not refused."""
        start, what = (self.tap_s, "tap") if self.motion == "decay" else (self.move_start_s, "move")
        moved = self.amplitude_deg != 0 if self.motion == "decay" else self.accel_m_s2 != 0
        if moved and start >= self.duration_s:
            return f"the {what} at {start:g} s comes after the video's end ({self.duration_s:g} s): the liquid rests in every frame"
        return None

    @property
    def params(self) -> SloshParams:
        """The liquid's pendulum parameters, from (f_hz, zeta) if given, else (m_kg, l_m, d_ns_per_m)."""
        if self.f_hz is not None and self.zeta is not None:  # given together (checked on construction)
            return SloshParams.from_modal(2 * math.pi * self.f_hz, self.zeta, self.m_kg)
        return SloshParams(self.m_kg, self.l_m, self.d_ns_per_m)


@dataclass
class Truth:
    """Ground truth of a rendered video, one entry per frame (the truth CSV's columns, listed in docs/guides/synth.md; angles
    counter-clockwise positive as seen, pixel coordinates with (0,0) the top-left pixel centre)."""

    columns: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["t_s"])

    def to_csv(self, path: str | Path) -> None:
        """Write the truth table atomically as CSV (full float precision)."""
        write_csv(path, self.columns)


SCENE_ONLY = {
    "surface": {
        "liquid_color": "the dye colour",
        "elevation_deg": "a camera elevation",
        "meniscus_px": "a meniscus",
        "meniscus_dark": "a dark meniscus",
        "specular": "highlight stripes",
        "reflection": "a wall reflection",
        "second_mode": "a second mode",
        "container_diameter_m": "the container diameter",
    },
    "float": {
        "float_color": "the float colour",
        "float_length_frac": "the float length",
        "float_rounded": "a rounded float",
        "float_bend_px": "a bent float",
        "float_specular": "a specular spot on the float",
        "float_submerged": "a submerged float",
    },
}
"""SynthSettings fields that only one scene renders, with how a message names them."""


def frame_times(s: SynthSettings) -> np.ndarray:
    """Presentation times: k/fps, each jittered by up to vfr_jitter of an interval (first frame at 0)."""
    n = max(1, math.floor(s.duration_s * s.fps + 1e-9))
    t = np.arange(n) / s.fps
    if s.vfr_jitter > 0:
        rng = np.random.default_rng([s.seed, 1])
        t = t + rng.uniform(-s.vfr_jitter, s.vfr_jitter, n) / s.fps
        t[0] = 0.0
    return t


def move_accel(s: SynthSettings, t: np.ndarray | float) -> np.ndarray:
    """Container acceleration of the constant-acceleration move: +a, then -a, zero outside the move."""
    t = np.asarray(t, float)
    half = s.move_duration_s / 2
    rel = t - s.move_start_s
    return np.where(
        (rel >= 0) & (rel < half), s.accel_m_s2, np.where((rel >= half) & (rel < 2 * half), -s.accel_m_s2, 0.0)
    )


def move_position_m(s: SynthSettings, t: np.ndarray) -> np.ndarray:
    """Container position along the move (m), the exact double integral of move_accel."""
    half, a = s.move_duration_s / 2, s.accel_m_s2
    rel = np.clip(t - s.move_start_s, 0, 2 * half)
    first = 0.5 * a * np.minimum(rel, half) ** 2
    second_t = np.clip(rel - half, 0, half)
    return first + a * half * second_t - 0.5 * a * second_t**2


def relative_angle_rad(s: SynthSettings, t: np.ndarray) -> np.ndarray:
    """The float's angle relative to the container (CCW as seen) at times t, from the nonlinear pendulum.

    Decay: at rest until the tap, then an impulse sets the rate so the first peak is about amplitude_deg.
    Move: the model angle tilts toward the acceleration (design.md); seen with the move going to the
    image right, the surface then turns clockwise, so the CCW angle is its negative.
    """
    p = s.params
    if s.motion == "decay":
        start = s.tap_s
        omega_d = p.omega_rad_s * math.sqrt(max(1 - p.zeta**2, 1e-12))
        t_peak = math.atan2(omega_d, p.zeta * p.omega_rad_s) / omega_d
        rate0 = (
            math.radians(s.amplitude_deg)
            * omega_d
            / (math.exp(-p.zeta * p.omega_rad_s * t_peak) * math.sin(omega_d * t_peak))
        )
        y0, u = [0.0, rate0], (lambda _t: 0.0)
        sign = 1.0
    else:
        start, y0, sign = 0.0, [0.0, 0.0], SEEN_SIGN
        u = lambda tt: float(move_accel(s, tt))  # noqa: E731
    out = np.zeros_like(t)
    after = t >= start
    if after.any():
        breaks = (
            [s.move_start_s + s.move_duration_s / 2, s.move_start_s + s.move_duration_s] if s.motion == "move" else []
        )
        t_end = float(t[after].max())
        edges = [start] + [b for b in breaks if start < b < t_end] + [t_end]
        # the 1-D move is the model's pitch theta under ux; pieces restart at the steps of u so they are not smeared
        pieces = [(a, b, lambda tt: (u(tt), 0.0, 0.0)) for a, b in itertools.pairwise(edges)]
        state = integrate_pendulums(pieces, t[after], p, (0.0, y0[0], 0.0, y0[1]), max_step=0.25 / p.f_hz)
        out[after] = state[:, 1]
    return sign * out


def _smoothstep(x: np.ndarray) -> np.ndarray:
    """0 -> 1 with zero slope at both ends (the container starts and stops crossing the frame smoothly)."""
    x = np.clip(x, 0, 1)
    return x * x * (3 - 2 * x)


@dataclass
class SceneGeometry:
    """Fixed scene geometry in pixels, derived from the frame size."""

    inner_w: float
    wall: float
    depth: float  # liquid depth below the float centre
    head: float  # rim height above the float centre
    float_l: float
    float_t: float
    x0: float
    y0: float


def scene_geometry(s: SynthSettings) -> SceneGeometry:
    """Scene proportions from the frame height (container, walls, float) and the travel's start."""
    h = s.height
    return SceneGeometry(
        inner_w=0.5 * h,
        wall=max(3.0, 0.012 * h),
        depth=0.32 * h,
        head=0.18 * h,
        float_l=s.float_length_frac * h,
        float_t=max(4.0, 0.035 * h),
        x0=s.width / 2 - _total_travel_px(s) / 2,
        y0=0.55 * h,
    )


def _total_travel_px(s: SynthSettings) -> float:
    """How far the container moves across the picture in total (the scene is centred on the travel)."""
    if s.motion == "move":
        return s.px_per_m * s.accel_m_s2 * (s.move_duration_s / 2) ** 2
    return s.travel_px


def rotation_matrix(angle: float) -> np.ndarray:
    """2x2 rotation CCW as seen, acting on (x right, y up) vectors."""
    c, si = math.cos(angle), math.sin(angle)
    return np.array([[c, -si], [si, c]])


def rectangle_points(x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    """Corners of an axis-aligned rectangle, counter-clockwise in (x right, y up) coordinates."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)


def _coverage(poly_img: np.ndarray, shape: tuple[int, int]) -> tuple[tuple[slice, slice], np.ndarray] | None:
    """Analytic pixel coverage of a convex polygon (image coordinates, y down) over its bounding box.

    Coverage is the product over edges of clip(0.5 + signed distance, 0, 1): exact for straight edges
    (a half-plane's coverage ramp is symmetric about the edge), close at corners.
    """
    h, w = shape
    x0, y0 = np.floor(poly_img.min(axis=0) - 1).astype(int)
    x1, y1 = np.ceil(poly_img.max(axis=0) + 2).astype(int)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    if x1 <= x0 or y1 <= y0:
        return None
    xs = np.arange(x0, x1, dtype=np.float32)[None, :]
    ys = np.arange(y0, y1, dtype=np.float32)[:, None]
    # orientation-independent inside test: the polygon's centroid is inside
    centre = poly_img.mean(axis=0)
    cov = np.ones((y1 - y0, x1 - x0), np.float32)
    for a, b in zip(poly_img, np.roll(poly_img, -1, axis=0)):
        edge = b - a
        n = np.array([-edge[1], edge[0]]) / np.hypot(*edge)
        if np.dot(centre - a, n) < 0:
            n = -n
        d = n[0] * (xs - a[0]) + n[1] * (ys - a[1])
        cov *= np.clip(0.5 + d, 0, 1)
    return (slice(y0, y1), slice(x0, x1)), cov


def paint_polygon(img: np.ndarray, poly_img: np.ndarray, bgr: tuple[int, int, int], alpha: float = 1.0) -> None:
    """Alpha-blend a convex polygon of colour `bgr` into the float32 image with its analytic coverage."""
    res = _coverage(poly_img, img.shape[:2])
    if res is None:
        return
    sl, cov = res
    a = (alpha * cov)[..., None]
    img[sl] += a * (np.asarray(bgr, np.float32) - img[sl])


def background_image(s: SynthSettings) -> np.ndarray:
    """A static vertical gradient backdrop (rolled with the camera) with a faint shelf line."""
    ys, xs = np.mgrid[0 : s.height, 0 : s.width].astype(np.float32)
    roll = math.radians(s.camera_roll_deg)
    # distance "down" the rolled world: the world's down vector appears rotated by the roll
    down = (ys - s.height / 2) * math.cos(roll) + (xs - s.width / 2) * math.sin(roll)
    frac = np.clip(0.5 + down / s.height, 0, 1)[..., None]
    return BACKGROUND_TOP_BGR * (1 - frac) + BACKGROUND_BOTTOM_BGR * frac


@dataclass
class Motion:
    """Per-frame container pose and liquid angle shared by both scenes (arrays, one entry per frame)."""

    t: np.ndarray
    rel: np.ndarray
    tilt: np.ndarray
    dx: np.ndarray
    accel: np.ndarray
    drift: np.ndarray
    rng: np.random.Generator


def _poses_at(s: SynthSettings, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(relative angle rad, container tilt rad, container travel px) at times t."""
    tilt = np.radians(s.container_tilt_deg) * np.sin(2 * np.pi * s.container_tilt_hz * t)
    if s.motion == "move":
        dx = s.px_per_m * move_position_m(s, t)
    else:
        dx = s.travel_px * _smoothstep(t / max(s.duration_s, 1e-9))
    return relative_angle_rad(s, t), tilt, dx


def _motion(s: SynthSettings) -> Motion:
    """Frame times, the pendulum's relative angle, the container's travel and tilt, the lighting drift."""
    t = frame_times(s)
    rel, tilt, dx = _poses_at(s, t)
    accel = move_accel(s, t) if s.motion == "move" else np.zeros_like(t)
    rng = np.random.default_rng([s.seed, 2])
    drift = np.cumsum(rng.normal(0, 0.002, len(t)))
    return Motion(t, rel, tilt, dx, accel, drift, rng)


def check_in_picture(
    s: SynthSettings, sc: SceneGeometry, mo: Motion, h2: np.ndarray | float = 0.0, surface: bool = True
) -> None:
    """Refuse a motion whose picture cannot be drawn: the liquid turned past the vertical, or, for the dyed `surface`
    (whose wall heights are truth), above the container's rim (drawn cut off at it, with the truth going on: a trial's
    move reached 233 px up a wall and 63 deg); and what is measured beyond the picture's side at some frame: the
    container's walls for the surface, the float for the float scene (whose truth holds with the liquid above the
    rim, or the walls cut off by a tight picture)."""
    turn = float(np.max(np.abs(mo.rel)))
    # past the vertical the surface's tangent wraps round: the liquid is over the rim whatever it gives
    peak = math.inf if turn >= math.pi / 2 else float(np.max(sc.inner_w / 2 * np.abs(np.tan(mo.rel)) + np.abs(h2)))
    if peak > (sc.head if surface else math.inf) or not math.isfinite(peak):
        where = f"reach {peak:.0f} px up a wall" if math.isfinite(peak) else f"turn {math.degrees(turn):.0f} deg"
        raise UserError(
            f"the liquid would {where}, above the container's rim ({sc.head:.0f} px above the liquid at rest): a "
            "picture cannot show it; lower `amplitude_deg`, `accel_m_s2` or `second_mode`."
        )
    lo, hi = float(np.min(sc.x0 + mo.dx)), float(np.max(sc.x0 + mo.dx))
    measured = sc.inner_w / 2 + sc.wall if surface else 0.5 * s.float_length_frac * s.height
    if lo - measured < 0 or hi + measured > s.width:  # the float leaving, the container (wider) leaves too
        reach = sc.inner_w / 2 + sc.wall
        raise UserError(
            f"the container would leave the {s.width} px wide picture (its sides reach x = {lo - reach:.0f} to "
            f"{hi + reach:.0f} px): lower `travel_px`, `px_per_m` or `accel_m_s2`, or widen `width`."
        )


class NoisePool:
    """Seeded Gaussian sensor noise, fast: a few pre-drawn noise fields read at random offsets per frame."""

    def __init__(self, shape: tuple[int, ...], sigma: float, rng: np.random.Generator, fields: int = 4) -> None:
        h, w, c = shape
        self._pad = 32
        self._fields = rng.standard_normal((fields, h + self._pad, w + self._pad, c), dtype=np.float32) * np.float32(
            sigma
        )
        self._shape, self._rng = shape, rng

    def draw(self) -> np.ndarray:
        """A noise field of the frame's shape (a view, do not modify)."""
        i, dy, dx = self._rng.integers(0, [len(self._fields), self._pad, self._pad])
        h, w, _ = self._shape
        return self._fields[i, dy : dy + h, dx : dx + w]


def degrade_picture(img: np.ndarray, s: SynthSettings, t: float, drift: float, noise: NoisePool | None) -> np.ndarray:
    """Camera effects in order of the optical path: blur, lighting flicker, sensor noise, 8-bit quantisation."""
    if s.blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), s.blur_px)
    if s.flicker > 0:
        img *= np.float32(1 + s.flicker * (0.6 * math.sin(2 * math.pi * 100 * t) + 0.4 * math.tanh(drift / 0.02)))
    if noise is not None:
        img += noise.draw()
    img += np.float32(0.5)
    np.clip(img, 0, 255, out=img)
    return img.astype(np.uint8)


PAINTED_ONLY = (
    "px_per_m",
    "camera_roll_deg",
    "noise_sigma",
    "blur_px",
    "flicker",
    "float_color",
    "float_length_frac",
    "float_rounded",
    "float_bend_px",
    "float_specular",
    "float_submerged",
    "motion_blur",
    "liquid_color",
    "elevation_deg",
    "meniscus_px",
    "meniscus_dark",
    "specular",
    "reflection",
    "second_mode",
    "container_diameter_m",
)
"""SynthSettings fields the pbr renderer draws from the scene seed (or has no use for): refused there when set."""


def check_pbr_settings(s: SynthSettings) -> None:
    """Refuse a painted-only setting given with the pbr renderer: one sentence naming it."""
    for name in PAINTED_ONLY:
        if getattr(s, name) != getattr(SynthSettings, name):
            raise SettingError(
                name,
                "{name} is not an option of the pbr renderer (it draws the scene from {scene_seed}); leave it out or "
                "use {renderer} painted.",
                "scene_seed",
                "renderer",
            )
