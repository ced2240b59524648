"""The random scene of `sloshid synth --renderer pbr`: what is drawn from a seed, and the meshes it is built from.

`draw_scene(seed)` draws the container (straight cylinder, tapered tumbler, beaker with graduation marks, square
bottle), its glass, the fill, the liquid, the background, the camera, the lens, the light, the sensor and the float,
every draw from one seeded generator, so the same seed gives the same scene. The meshes (plain numpy, no renderer)
are in the container's own coordinates: metres, z up along the axis, the inner bottom's centre at the origin, x to
the picture's right, y away from the camera. Each interface between two materials is its own mesh (glass/air,
glass/liquid, liquid/air), sharing exact vertices along the contact line, so a path tracer knows which medium a ray
is in.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import cast

import numpy as np

from sloshid.synthetic.surface_scene import _G1

RGB = tuple[float, float, float]
"""A linear RGB colour, each channel 0-1."""

CONTAINERS = ("cylinder", "tumbler", "beaker", "square")
LIQUIDS = ("strong_dye", "faint_dye", "juice", "cola")
BACKGROUNDS = ("plain", "table_edge", "clutter", "holder", "label")
LIGHTS = ("soft", "hard")
FLOAT_SHAPES = ("stick", "capsule", "plank")
DYE_COLORS = ("red", "orange", "yellow", "green", "blue", "magenta")
"""Dyes are drawn with the hue of a colour preset (sloshid.video.colors), so a user's tracker setting can name it."""
JUICE_COLORS = ("orange", "yellow", "red")
THETAS = 144
"""Vertices around the container: a 60 mm glass then has 1.3 mm facets, below a pixel at the default framing."""
MENISCUS_DECAY_M = 0.002
"""The meniscus falls off over this distance from the wall (water's capillary length is 2.7 mm)."""


@dataclass(frozen=True)
class PbrScene:
    """One random draw: every quantity the picture depends on besides the liquid's motion (SI units, degrees)."""

    seed: int
    container: str
    inner_radius_m: float
    """Inner radius at the inner bottom (for the square bottle: half the inner side)."""
    taper: float
    """Growth of the inner radius per metre of height (a tapered tumbler widens upward)."""
    glass_m: float
    """Wall thickness."""
    bottom_m: float
    """Thickness of the glass bottom."""
    height_m: float
    """Inner bottom to rim."""
    fill: float
    """Rest level as a share of height_m."""
    liquid: str
    liquid_color: str
    """The dye's colour preset, or 'none' (cola)."""
    background: str
    wall_rgb: RGB
    table_rgb: RGB
    clutter: tuple[tuple[float, ...], ...]
    """Boxes behind the container: (x, y, half width, half depth, height, r, g, b) each."""
    elevation_deg: float
    """The camera's ray to the surface's centre is this far above the horizontal."""
    roll_deg: float
    """The picture appears rotated by this angle, counter-clockwise as seen."""
    distance_m: float
    frame_fill: float
    """The container's height as a share of the picture's height (sets the focal length)."""
    k1: float
    k2: float
    light: str
    light_azimuth_deg: float
    noise_sigma: float
    crf: float
    lean_deg: float
    """A static tilt of the container in the picture plane (counter-clockwise as seen); the liquid stays level."""
    meniscus_m: float
    second_mode: float
    float_shape: str
    float_length_m: float
    float_color: str

    def to_dict(self) -> dict:
        """The draw as JSON-ready values (written beside the truth)."""
        return asdict(self)

    @property
    def rest_m(self) -> float:
        """Height of the liquid at rest above the inner bottom."""
        return self.fill * self.height_m

    def inner_radius(self, theta: np.ndarray, z: np.ndarray | float) -> np.ndarray:
        """Inner wall's distance from the axis at angle theta (from +x) and height z (a superellipse for the square)."""
        r = self.inner_radius_m + self.taper * np.maximum(z, 0.0)
        if self.container == "square":
            p = 6.0
            r = r * (np.abs(np.cos(theta)) ** p + np.abs(np.sin(theta)) ** p) ** (-1 / p)
        return r

    @property
    def rest_half_width_m(self) -> float:
        """Half the inner width across the picture at the rest level (where the surface truth is measured)."""
        return float(self.inner_radius(np.array(0.0), self.rest_m))

    @property
    def outer_half_width_m(self) -> float:
        """Half the outer width at the rim (the widest point)."""
        return float(self.inner_radius(np.array(0.0), self.height_m)) + self.glass_m


def draw_scene(seed: int, scene: str = "surface") -> PbrScene:
    """The scene drawn from `seed`: the same seed gives the same scene (one generator, a fixed order of draws)."""
    rng = np.random.default_rng([int(seed), 37])
    u = rng.uniform
    container = str(rng.choice(CONTAINERS))
    radius = u(0.025, 0.042)
    height = u(2.0, 3.2) * radius if container != "beaker" else u(2.2, 2.8) * radius
    liquid = str(rng.choice(LIQUIDS))
    dye = str(rng.choice(JUICE_COLORS if liquid == "juice" else DYE_COLORS)) if liquid != "cola" else "none"
    background = str(rng.choice(BACKGROUNDS))
    grey = u(0.55, 0.9)
    wall = cast(RGB, tuple(float(grey * c) for c in u(0.92, 1.0, 3)))
    table = cast(RGB, tuple(float(c) for c in (u(0.35, 0.75) * np.array([1.0, 0.85, 0.65]) * u(0.9, 1.0, 3))))
    n_clutter = int(rng.integers(3, 7)) if background == "clutter" else 0
    clutter = tuple(
        (
            float(u(-0.15, 0.15)),
            float(u(0.07, 0.25)),
            float(u(0.01, 0.04)),
            float(u(0.01, 0.04)),
            float(u(0.03, 0.15)),
            *(float(c) for c in u(0.05, 0.9, 3)),
        )
        for _ in range(n_clutter)
    )
    distorted = u() < 0.7
    k1 = float(u(-0.15, 0.05)) if distorted else 0.0
    k2 = float(u(-0.02, 0.02)) if distorted else 0.0
    float_color = str(rng.choice([c for c in DYE_COLORS if c != dye and not (dye == "red" and c == "orange")]))
    return PbrScene(
        seed=int(seed),
        container=container,
        inner_radius_m=float(radius),
        taper=float(u(0.08, 0.2)) if container == "tumbler" else 0.0,
        glass_m=float(u(0.0015, 0.005)),
        bottom_m=float(u(0.004, 0.015)),
        height_m=float(height),
        fill=float(u(0.45, 0.8)),
        liquid=liquid,
        liquid_color=dye,
        background=background,
        wall_rgb=wall,
        table_rgb=table,
        clutter=clutter,
        elevation_deg=float(u(0.0, 15.0)),
        roll_deg=float(u(-3.0, 3.0)),
        distance_m=float(u(0.3, 0.8)),
        frame_fill=float(u(0.45, 0.62)),
        k1=k1,
        k2=k2,
        light=str(rng.choice(LIGHTS)),
        light_azimuth_deg=float(u(-70, 70)),
        noise_sigma=float(u(1.0, 5.0)),
        crf=float(rng.integers(16, 27)),
        lean_deg=float(u(-6.0, 6.0)),
        meniscus_m=float(u(0.0005, 0.0025)),
        second_mode=float(u(0.0, 0.3)),
        float_shape=str(rng.choice(FLOAT_SHAPES)),
        float_length_m=float(u(0.35, 0.6) * radius * 2),
        float_color=float_color if scene == "float" else "none",
    )


@dataclass
class Surface:
    """The liquid's top at one instant, in container coordinates: a tilted plane through the axis at the rest level
    (angle `tilt_rad`, counter-clockwise as seen), a second mode of wall height `h2_m` whose best-fit line is flat,
    and the meniscus curling up `meniscus_m` at the wall."""

    tilt_rad: float
    h2_m: float
    meniscus_m: float

    def mid_line(self, sc: PbrScene, x: np.ndarray) -> np.ndarray:
        """Height of the surface's mid-line (the plane through the axis across the picture) without the meniscus."""
        s = np.clip(x / sc.rest_half_width_m, -1.2, 1.2)
        return sc.rest_m + x * math.tan(self.tilt_rad) + self.h2_m * (s**3 - 0.6 * s) / _G1

    def height(self, sc: PbrScene, x: np.ndarray, to_wall: np.ndarray) -> np.ndarray:
        """Height at x with the meniscus, `to_wall` metres from the inner wall."""
        return self.mid_line(sc, x) + self.meniscus_m * np.exp(-np.maximum(to_wall, 0) / MENISCUS_DECAY_M)


Mesh = tuple[np.ndarray, np.ndarray]
"""(vertices n x 3, faces m x 3) of one surface."""


def _ring_grid(rings: list[np.ndarray]) -> Mesh:
    """Quads between consecutive rings of THETAS points each (closed around), as triangles."""
    v = np.concatenate(rings)
    n = len(rings[0])
    faces = []
    j = np.arange(n)
    for i in range(len(rings) - 1):
        a, b = i * n + j, i * n + (j + 1) % n
        c, d = a + n, b + n
        faces += [np.column_stack([a, b, d]), np.column_stack([a, d, c])]
    return v, np.concatenate(faces)


def _fan(centre: np.ndarray, ring: np.ndarray) -> Mesh:
    """A disc: triangles from `centre` to each edge of the closed `ring`."""
    n = len(ring)
    j = np.arange(n)
    return np.vstack([ring, centre[None]]), np.column_stack([np.full(n, n), j, (j + 1) % n])


def _oriented(mesh: Mesh, outward) -> Mesh:
    """Faces wound so their normals point along `outward(face centroids)` (a path tracer reads sides from them)."""
    v, f = mesh
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    n = np.cross(b - a, c - a)
    flip = np.einsum("ij,ij->i", n, outward((a + b + c) / 3)) < 0
    f = f.copy()
    f[flip] = f[flip][:, ::-1]
    return v, f


def _joined(meshes: list[Mesh]) -> Mesh:
    """One mesh of several, vertex indices offset."""
    vs, fs, k = [], [], 0
    for v, f in meshes:
        vs.append(v)
        fs.append(f + k)
        k += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def _radial(p: np.ndarray) -> np.ndarray:
    """Unit horizontal directions away from the axis."""
    d = p.copy()
    d[:, 2] = 0
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)


def _ring(sc: PbrScene, theta: np.ndarray, z: np.ndarray | float, extra: float = 0.0) -> np.ndarray:
    """Points on the inner wall (plus `extra` outward) at heights z."""
    z = np.broadcast_to(np.asarray(z, float), theta.shape)
    r = sc.inner_radius(theta, z) + extra
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), z])


def contact_ring(sc: PbrScene, surf: Surface, theta: np.ndarray) -> np.ndarray:
    """Where the surface meets the inner wall (meniscus included), solved for the tapered wall by a few iterations."""
    z = np.full(theta.shape, sc.rest_m)
    for _ in range(6):
        r = sc.inner_radius(theta, z)
        z = surf.height(sc, r * np.cos(theta), np.zeros_like(theta))
    return _ring(sc, theta, z)


RHO = np.concatenate([np.linspace(0.0, 0.85, 14)[1:], 1 - np.geomspace(0.15, 0.003, 18)[1:], [1.0]])
"""Rings of the surface mesh as shares of the way to the wall: dense near it, where the meniscus curls."""


def container_meshes(sc: PbrScene, surf: Surface) -> dict[str, Mesh]:
    """The glass (its air side, its liquid side) and the liquid's top, each oriented out of its material's interior:
    'glass_air' out of the glass, 'glass_liquid' and 'liquid_air' out of the liquid."""
    th = np.linspace(-math.pi, math.pi, THETAS, endpoint=False)
    H, b, g = sc.height_m, sc.bottom_m, sc.glass_m
    contact = contact_ring(sc, surf, th)
    bottom_in, rim_in = _ring(sc, th, 0.0), _ring(sc, th, H)
    out_bottom, out_zero, out_rim = _ring(sc, th, -b, g), _ring(sc, th, 0.0, g), _ring(sc, th, H, g)
    inward = lambda p: -_radial(p)  # noqa: E731
    glass_air = _joined(
        [
            _oriented(_ring_grid([out_bottom, out_zero, out_rim]), _radial),
            _oriented(_fan(np.array([0, 0, -b]), out_bottom), lambda p: np.array([[0, 0, -1.0]])),
            _oriented(_ring_grid([rim_in, out_rim]), lambda p: np.array([[0, 0, 1.0]])),
            _oriented(_ring_grid([contact, rim_in]), inward),
        ]
    )
    glass_liquid = _joined(
        [
            _oriented(_ring_grid([bottom_in, contact]), _radial),
            _oriented(_fan(np.zeros(3), bottom_in), lambda p: np.array([[0, 0, -1.0]])),
        ]
    )
    r_c = np.hypot(contact[:, 0], contact[:, 1])
    rings = []
    for rho in RHO[:-1]:
        x, y = rho * r_c * np.cos(th), rho * r_c * np.sin(th)
        rings.append(np.column_stack([x, y, surf.height(sc, x, (1 - rho) * r_c)]))
    rings.append(contact)
    centre = np.array([0.0, 0.0, float(surf.height(sc, np.zeros(1), np.array([r_c.min()]))[0])])
    liquid_air = _joined(
        [
            _oriented(_ring_grid(rings), lambda p: np.array([[0, 0, 1.0]])),
            _oriented(_fan(centre, rings[0]), lambda p: np.array([[0, 0, 1.0]])),
        ]
    )
    return {"glass_air": glass_air, "glass_liquid": glass_liquid, "liquid_air": liquid_air}


def dressing_meshes(sc: PbrScene) -> dict[str, Mesh]:
    """What the background draw fixes to the container: a holder sleeve or a label in the liquid's colour, and a
    beaker's graduation marks (container coordinates; rendered two-sided, so not oriented)."""
    th = np.linspace(-math.pi, math.pi, THETAS, endpoint=False)
    g, b = sc.glass_m, sc.bottom_m
    out: dict[str, Mesh] = {}
    if sc.background == "holder":
        top = 0.35 * sc.rest_m
        gap, thick = 0.0003, 0.006
        out["holder"] = _joined(
            [
                _ring_grid([_ring(sc, th, -b, g + gap), _ring(sc, th, top, g + gap)]),
                _ring_grid([_ring(sc, th, top, g + gap), _ring(sc, th, top, g + thick)]),
                _ring_grid([_ring(sc, th, top, g + thick), _ring(sc, th, -b, g + thick)]),
            ]
        )
    if sc.background == "label":
        z0, z1 = 0.25 * sc.rest_m, 0.6 * sc.rest_m
        out["label"] = _ring_grid([_ring(sc, th, z0, g + 0.0003), _ring(sc, th, z1, g + 0.0003)])
    if sc.container == "beaker":
        marks = []
        for i, z in enumerate(np.arange(0.01, 0.85 * sc.height_m, 0.005)):
            span = math.radians(14 if i % 2 == 0 else 7)
            t = np.linspace(-math.radians(120), -math.radians(120) + span, 6)
            lo, hi = _ring(sc, t, z - 0.0003, g + 0.0002), _ring(sc, t, z + 0.0003, g + 0.0002)
            v = np.vstack([lo, hi])
            k = np.arange(len(t) - 1)
            n = len(t)
            marks.append(
                (v, np.concatenate([np.column_stack([k, k + 1, k + n + 1]), np.column_stack([k, k + n + 1, k + n])]))
            )
        out["marks"] = _joined(marks)
    return out


def float_mesh(sc: PbrScene) -> Mesh:
    """The float in its own coordinates (long axis x, centred), outward-oriented: a square stick, a capsule, a plank."""
    L = sc.float_length_m
    if sc.float_shape == "capsule":
        r = 0.09 * L
        ends = np.linspace(0, math.pi / 2, 7)
        profile = [(-L / 2 + r - r * math.cos(a), r * math.sin(a)) for a in ends]
        profile += [(L / 2 - r + r * math.sin(a), r * math.cos(a)) for a in ends]
        profile = [(x, max(rad, 1e-5)) for x, rad in profile]
        th = np.linspace(0, 2 * math.pi, 24, endpoint=False)
        rings = [np.column_stack([np.full(24, x), rad * np.cos(th), rad * np.sin(th)]) for x, rad in profile]
        v, f = _ring_grid(rings)
        return _oriented((v, f), lambda p: p * np.array([0.2, 1.0, 1.0]))
    w, t = (0.16 * L, 0.07 * L) if sc.float_shape == "plank" else (0.11 * L, 0.11 * L)
    corners = np.array([[x, y, z] for x in (-L / 2, L / 2) for y in (-w / 2, w / 2) for z in (-t / 2, t / 2)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    f = np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))])
    return _oriented((corners, f), lambda p: p)


def float_half_height_m(sc: PbrScene) -> float:
    """Half the float's thickness (a third of it rides below the surface)."""
    L = sc.float_length_m
    return {"capsule": 0.09, "plank": 0.035}.get(sc.float_shape, 0.055) * L


def json_ready(d: dict) -> dict:
    """Tuples as lists (a JSON dump of the draw)."""
    return {
        k: ([list(x) if isinstance(x, tuple) else x for x in v] if isinstance(v, tuple) else v) for k, v in d.items()
    }
