"""The planning scenario (TOML): the move, its limits, obstacles, container, solver, liquid and robot.

Every table is a typed dataclass validated before use: unknown keys are rejected with a "did you mean",
ranges are checked in `__post_init__`. The `[compare]` table belongs to `sloshid compare` and is kept
unvalidated as a plain dict on the Scenario.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np

from sloshid.core.errors import SettingError, UserError
from sloshid.core.settings import did_you_mean, from_dict, init_fields, load_toml, setting_field
from sloshid.model.pendulum import SloshParams
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.arm_settings import ArmSettings, arm_settings
from sloshid.planning.path import PathGeometry, PathTable, build_geometry

ARM_KEYS = tuple(f.name for f in init_fields(ArmSettings))
"""[robot] keys that describe the arm, the ArmSettings fields (the rest are its Cartesian limits, RobotLimits)."""

Vec3 = tuple[float, float, float]


MAX_WAYPOINTS = 100
"""Most stops a [move] may make: each is an optimal-control segment of its own (a second or so to solve), and 10,000
ran for hours without a word."""


@dataclass(frozen=True)
class Move:
    """[move]: either `start` and `goal`, or `waypoints` (the container stops at each), positions in m."""

    start: Vec3 | None = setting_field(None, unit="m")
    """Start position x, y, z (m)."""
    goal: Vec3 | None = setting_field(None, unit="m")
    """Goal position x, y, z (m)."""
    waypoints: list[Vec3] | None = setting_field(None, unit="m")
    """Positions start ... goal (m), at least two; the container comes to rest at each."""

    def __post_init__(self) -> None:
        if self.waypoints is not None and (self.start is not None or self.goal is not None):
            raise UserError("[move] takes either start and goal, or waypoints, not both.")
        if self.waypoints is None and (self.start is None or self.goal is None):
            raise UserError("[move] needs both start and goal (m), or a waypoints list.")
        if self.waypoints is not None and len(self.waypoints) < 2:
            raise UserError("[move].waypoints needs at least two positions (start and goal).")
        if self.waypoints is not None and len(self.waypoints) > MAX_WAYPOINTS:
            raise UserError(
                f"[move].waypoints holds {len(self.waypoints)} positions; at most {MAX_WAYPOINTS} stops (each is a "
                "segment solved on its own): a path through many points is a [path] table."
            )
        points = self.points()
        for i, (a, b) in enumerate(itertools.pairwise(points)):
            if math.dist(a, b) < 1e-6:
                raise UserError(f"[move] positions {i} and {i + 1} coincide at {a}; there is nothing to plan.")

    def points(self) -> list[Vec3]:
        """Start ... goal as a list."""
        if self.waypoints is not None:
            return list(self.waypoints)
        assert self.start is not None and self.goal is not None  # __post_init__ asks for both
        return [self.start, self.goal]


@dataclass(frozen=True)
class Limits:
    """[limits]: the move's own limits, per axis x, y, z (seed eq. 8d-8f)."""

    acc_max: Vec3 = setting_field((0.5, 0.5, 0.5), unit="m/s^2")
    """Acceleration bound per axis (m/s^2), seed eq. 8d."""
    vel_max: Vec3 = setting_field((1.7, 1.7, 1.7), unit="m/s")
    """Velocity bound per axis (m/s), seed eq. 8f and 8e."""
    jerk_max: Vec3 = setting_field((100.0, 100.0, 100.0), unit="m/s^3")
    """Jerk bound per axis (m/s^3), used by the jerk-limited formulation."""
    z_range: tuple[float, float] = setting_field((0.05, 0.8), unit="m")
    """Allowed height of the container (m), seed eq. 8f."""
    tilt_max_deg: float = setting_field(30.0, unit="deg")
    """Largest roll and pitch of the container (deg)."""
    tilt_rate_max_deg_s: float = setting_field(120.0, unit="deg/s")
    """Largest roll and pitch rate (deg/s)."""
    t_max_s: float = setting_field(20.0, unit="s")
    """Longest allowed duration of one segment (s)."""
    rel_angle_max_deg: float = setting_field(0.5, unit="deg")
    """[path] plans: largest angle between the liquid surface and the container while moving (deg); free moves keep
    the container on the liquid's surface (0 deg)."""
    spill_margin_mm: float | None = setting_field(None, unit="mm")
    """Least distance the liquid may come to the rim, anywhere on the wall, during and after the move (mm); the planner
    keeps the predicted wall height within it (`planning.upright`): upright with tilt_max_deg = 0, else tilting too
    (a straight [move]; along a [path] it sets rel_angle_max_deg)."""
    residual_wall_height_max_mm: float = setting_field(0.5, unit="mm")
    """Largest wall height the liquid may keep swinging to after arrival (mm): calm enough to fill or pour."""

    def __post_init__(self) -> None:
        for name in ("acc_max", "vel_max", "jerk_max"):
            if any(not (v > 0 and math.isfinite(v)) for v in getattr(self, name)):
                raise UserError(f"[limits].{name} must be three positive numbers, got {getattr(self, name)}.")
        if not self.z_range[0] < self.z_range[1]:
            raise UserError(f"[limits].z_range must be [low, high] with low < high (m), got {list(self.z_range)}.")
        if not 0 <= self.tilt_max_deg < 90:
            raise UserError(f"[limits].tilt_max_deg must lie in [0, 90) deg (0: upright), got {self.tilt_max_deg}.")
        if not self.tilt_rate_max_deg_s > 0:
            raise UserError(f"[limits].tilt_rate_max_deg_s must be positive, got {self.tilt_rate_max_deg_s}.")
        if not self.t_max_s > 0:
            raise UserError(f"[limits].t_max_s must be positive, got {self.t_max_s}.")
        if not 0 < self.rel_angle_max_deg <= 10:
            raise UserError(f"[limits].rel_angle_max_deg must lie in (0, 10] deg, got {self.rel_angle_max_deg}.")
        if self.spill_margin_mm is not None and not (math.isfinite(self.spill_margin_mm) and self.spill_margin_mm >= 0):
            raise UserError(f"[limits].spill_margin_mm must be zero or positive (mm), got {self.spill_margin_mm}.")
        if not (math.isfinite(self.residual_wall_height_max_mm) and self.residual_wall_height_max_mm > 0):
            raise UserError(
                f"[limits].residual_wall_height_max_mm must be positive (mm), got {self.residual_wall_height_max_mm}."
            )

    @property
    def upright(self) -> bool:
        """The container may not tilt: an upright move within the spill margin."""
        return self.tilt_max_deg == 0


@dataclass(frozen=True)
class Obstacle:
    """[[obstacles]]: a sphere (center x, y, z) or a vertical cylinder (center x, y and z_range), radius in m."""

    center: tuple[float, ...] = setting_field(unit="m")
    """Sphere: [x, y, z] (m); cylinder: [x, y] of its vertical axis (m)."""
    radius: float = setting_field(unit="m")
    """Radius (m), before inflation by the container radius."""
    kind: Literal["sphere", "cylinder"] = "sphere"
    """Shape."""
    z_range: tuple[float, float] | None = setting_field(None, unit="m")
    """Cylinder only: bottom and top height (m)."""

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise UserError(f"obstacle radius must be positive (m), got {self.radius}.")
        if self.kind == "sphere" and (len(self.center) != 3 or self.z_range is not None):
            raise UserError("a sphere obstacle needs center = [x, y, z] (m) and no z_range.")
        if self.kind == "cylinder" and (
            len(self.center) != 2 or self.z_range is None or not self.z_range[0] < self.z_range[1]
        ):
            raise UserError("a cylinder obstacle needs center = [x, y] (m) and z_range = [bottom, top] (m).")

    def clearance(self, p: Any, inflate_m: float) -> Any:
        """Exact signed clearance (m) of point(s) p (..., 3) from the obstacle inflated by `inflate_m`; < 0 inside."""
        p = np.asarray(p, dtype=float)
        r = self.radius + inflate_m
        if self.kind == "sphere":
            return np.linalg.norm(p - np.asarray(self.center), axis=-1) - r
        radial = np.hypot(p[..., 0] - self.center[0], p[..., 1] - self.center[1]) - r
        assert self.z_range is not None  # a cylinder's, checked in __post_init__
        lo, hi = self.z_range[0] - inflate_m, self.z_range[1] + inflate_m
        vertical = np.maximum(lo - p[..., 2], p[..., 2] - hi)
        return np.maximum(radial, vertical)

    def describe(self, inflate_m: float) -> str:
        """One phrase naming the obstacle for error messages."""
        where = ", ".join(f"{c:g}" for c in self.center)
        extra = f", z {self.z_range[0]:g}..{self.z_range[1]:g} m" if self.z_range else ""
        return f"{self.kind} at ({where}) m{extra} with radius {self.radius:g} m inflated by {inflate_m:g} m"


@dataclass(frozen=True)
class Container:
    """[container]: geometry of the container that the obstacles are inflated by."""

    radius_m: float = setting_field(0.04, unit="m")
    """Container radius (m); every obstacle grows by it."""
    depth_m: float = setting_field(0.0, unit="m")
    """How far the container's body reaches below the liquid surface's centre (the point the plan moves) along its
    axis (m): it must clear the obstacles too, tilted as the plan tilts it (`body_clearance`); 0: the sphere only."""
    rim_above_surface_m: float | None = setting_field(None, unit="m")
    """Height of the rim above the liquid surface at rest (m): the spill margin is measured down from it."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.radius_m) and 0 <= self.radius_m <= MAX_RIM_M):
            raise UserError(
                f"[container].radius_m must lie in [0, {MAX_RIM_M:g}] m (metres, not millimetres), got {self.radius_m}."
            )
        if self.rim_above_surface_m is not None:
            try:
                check_rim(self.rim_above_surface_m, "rim_above_surface_m")
            except SettingError as exc:
                raise UserError(str(exc.named("[container].rim_above_surface_m"))) from None
        if not 0 <= self.depth_m <= MAX_DEPTH_M:
            raise UserError(
                f"[container].depth_m must lie in [0, {MAX_DEPTH_M:g}] m (metres, not millimetres), got {self.depth_m}."
            )


MAX_RIM_M = 1.0
"""The highest rim above the liquid a container takes (m): a rim in millimetres would read as metres."""


def check_rim(rim_m: float | None, where: str) -> None:
    """Refuse a rim height that is not a positive number of metres (None: not given); `where` names the setting."""
    if rim_m is not None and not (math.isfinite(rim_m) and 0 < rim_m <= MAX_RIM_M):
        raise SettingError(where, f"{{name}} must lie in (0, {MAX_RIM_M:g}] m (metres, not millimetres), got {rim_m}.")


@dataclass(frozen=True)
class TrayContainer:
    """[[containers]]: one container on the tool's tray, with its own geometry and liquid."""

    radius_m: float = setting_field(unit="m")
    """Inner radius (m): the wall height is radius x tan(the surface's tilt)."""
    rim_above_surface_m: float = setting_field(unit="m")
    """Height of its rim above its liquid's surface at rest (m)."""
    position_m: tuple[float, float] = setting_field((0.0, 0.0), unit="m")
    """Centre on the tray (m), in the tool's x and y from the point the plan moves."""
    name: str = ""
    """Name in reports (default: container 1, 2, ...)."""
    spill_margin_mm: float | None = setting_field(None, unit="mm")
    """Its own spill margin (mm); default [limits].spill_margin_mm."""
    m_kg: float | None = setting_field(None, unit="kg")
    """Liquid as a pendulum (seed Table I units): m_kg, l_m and d_ns_per_m together; this is its mass."""
    l_m: float | None = setting_field(None, unit="m")
    """The pendulum's length (with m_kg and d_ns_per_m)."""
    d_ns_per_m: float | None = setting_field(None, unit="N s/m")
    """The pendulum's damping constant (with m_kg and l_m)."""
    params: str | None = None
    """Or an identify JSON (path relative to the scenario) for this container's liquid."""
    fill_m: float | None = setting_field(None, unit="m")
    """Or the fill height (m) with `zeta`: the cylinder's first mode omega^2 = (g xi / R) tanh(xi h / R)."""
    zeta: float | None = None
    """Damping ratio that goes with `fill_m`."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.radius_m) and 0 < self.radius_m <= MAX_RIM_M):
            raise SettingError("radius_m", f"{{name}} must lie in (0, {MAX_RIM_M:g}] m, got {self.radius_m}.")
        check_rim(self.rim_above_surface_m, "rim_above_surface_m")
        if self.fill_m is not None and not (math.isfinite(self.fill_m) and self.fill_m > 0):
            raise SettingError("fill_m", f"{{name}} must be a positive height (m), got {self.fill_m}.")
        if self.zeta is not None and not 0 <= self.zeta < 1:
            raise SettingError("zeta", f"{{name}} must lie in [0, 1), got {self.zeta}.")
        if self.spill_margin_mm is not None and not (math.isfinite(self.spill_margin_mm) and self.spill_margin_mm >= 0):
            raise SettingError(
                "spill_margin_mm", f"{{name}} must be zero or positive (mm), got {self.spill_margin_mm}."
            )
        check_pendulum(self.m_kg, self.l_m, self.d_ns_per_m)


def check_pendulum(m_kg: float | None, l_m: float | None, d_ns_per_m: float | None) -> None:
    """Refuse pendulum keys (None: not given) that are not positive (d_ns_per_m: zero or positive) finite numbers."""
    for name, value in (("m_kg", m_kg), ("l_m", l_m)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise SettingError(name, f"{{name}} must be positive, got {value}.")
    if d_ns_per_m is not None and not (math.isfinite(d_ns_per_m) and d_ns_per_m >= 0):
        raise SettingError("d_ns_per_m", f"{{name}} must be zero or positive, got {d_ns_per_m}.")


@dataclass(frozen=True)
class Tray:
    """[tray]: the tool plate the containers stand on, centred on the point the plan moves."""

    size_m: tuple[float, float] = setting_field(unit="m")
    """Its extent along the tool's x and y (m)."""

    def __post_init__(self) -> None:
        if not all(math.isfinite(v) and v > 0 for v in self.size_m):
            raise UserError(f"[tray].size_m must be two positive lengths (m), got {list(self.size_m)}.")


@dataclass(frozen=True)
class RiskSettings:
    """[risk]: how sure the plan is, from the liquid's uncertainty (`planning.risk`)."""

    draws: int = 1000
    """Monte-Carlo draws of the liquid models that estimate the probability of breaking the margin."""
    seed: int = 1
    """Seed of the Monte-Carlo draws (the robust plan's scenarios use seed + 1)."""
    scenarios: int = 0
    """Sampled models the robust plan holds the margin for (scenario approach); 0: the nominal plan only."""
    omega_ci95_rel: float | None = None
    """A band the user gives: the natural frequency's 95 % interval as a share of it (0.05: +-5 %), for liquids that
    come without standard errors (a [liquid] table, fill_m); an identify JSON's own standard errors take precedence."""
    zeta_ci95_rel: float | None = None
    """The damping ratio's 95 % interval as a share of it."""
    beta: float = 1e-3
    """Confidence parameter of the scenario guarantee: the bound on the violation probability holds with 1 - beta."""

    def __post_init__(self) -> None:
        if not 100 <= self.draws <= 1_000_000:
            raise UserError(f"[risk].draws must lie in 100..1000000, got {self.draws}.")
        if not 0 <= self.scenarios <= MAX_RISK_SCENARIOS:
            raise UserError(
                f"[risk].scenarios must lie in 0..{MAX_RISK_SCENARIOS} (each adds the liquids to the plan's problem), "
                f"got {self.scenarios}."
            )
        for name in ("omega_ci95_rel", "zeta_ci95_rel"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and 0 <= v < 1):
                raise UserError(f"[risk].{name} must lie in [0, 1) (a share, not per cent), got {v}.")
        if not 0 < self.beta < 1:
            raise UserError(f"[risk].beta must lie in (0, 1), got {self.beta}.")


MAX_RISK_SCENARIOS = 200
"""Most sampled models a robust upright plan holds: each adds a pendulum per container to the problem."""


MAX_DEPTH_M = 2.0
"""The deepest container body [container].depth_m takes (m): a depth in millimetres would read as metres."""


def body_clearance(obstacles, pos_m, radius_m: float, depth_m: float = 0.0, z_axis=None):
    """Smallest signed clearance (m) of the container from any of `obstacles` at each position `pos_m` (..., 3) of
    the liquid surface's centre; < 0 inside one, inf without obstacles. The container is the sphere of `radius_m`
    around that point and, with a `depth_m`, its body down to `depth_m` below it along its axis `z_axis` (..., 3; None:
    upright): spheres along the axis at most half a radius apart, each grown to cover the cylinder between them
    (radius hypot(R, spacing / 2): at most 3.1 % more while R is over a 32nd of the depth), so a body that clears
    them clears the obstacle."""
    pos = np.asarray(pos_m, dtype=float)
    if not obstacles:
        return np.full(pos.shape[:-1], np.inf)
    if depth_m <= 0:
        return np.min([o.clearance(pos, radius_m) for o in obstacles], axis=0)
    n = math.ceil(2 * depth_m / max(radius_m, depth_m / 32)) + 1
    step = depth_m / (n - 1)
    axis = np.array([0.0, 0.0, 1.0]) if z_axis is None else np.asarray(z_axis, dtype=float)
    points = pos[..., None, :] - np.linspace(0.0, depth_m, n)[:, None] * axis[..., None, :]
    grown = math.hypot(radius_m, step / 2)
    return np.min([o.clearance(points, grown).min(axis=-1) for o in obstacles], axis=0)


MAX_ROBUST_FACTORS = 9
"""Most frequency factors a robust plan holds: each adds a copy of the liquid to the optimal control problem (nine
cover a band at 2.5 % steps), and 101 made one plan run for hours."""


def check_robust_factors(factors: Sequence[float], where: str) -> None:
    """Refuse robust frequency factors that are not positive finite numbers, or more than MAX_ROBUST_FACTORS."""
    if any(not (isinstance(f, (int, float)) and math.isfinite(f) and f > 0) for f in factors):
        raise UserError(f"{where} must be positive numbers, got {list(factors)}.")
    if len(factors) > MAX_ROBUST_FACTORS:
        raise UserError(
            f"{where} holds {len(factors)} factors; at most {MAX_ROBUST_FACTORS}: each adds a copy of the liquid to "
            "the plan's problem."
        )


@dataclass(frozen=True)
class SolverSettings:
    """[solver]: discretisation and weights of the optimal-control problem (seed eq. 8-10)."""

    N: int = 100
    """Shooting intervals per segment."""
    jerk_limited: bool = True
    """True: jerk is the decision variable, acceleration a state (robot-ready); False: the seed's piecewise-constant acceleration."""
    kappa_r: float = setting_field(1e-3, unit="s^3/m^2")
    """Weight of the acceleration regulariser kappa_r/2 |u|^2 (seed eq. 8a), s^3/m^2."""
    kappa_j: float = setting_field(1e-7, unit="s^5/m^2")
    """Weight of the jerk regulariser kappa_j/2 |j|^2 (jerk-limited formulation only), s^5/m^2."""
    kappa_z: float = setting_field(5.0, unit="s^3/m^2")
    """Extra weight on vertical acceleration kappa_z/2 uz^2 (s^3/m^2): vertical acceleration changes the effective
    gravity of the liquid, and without a price the optimiser uses it to steer the liquid (bouncing in z)."""
    kappa_T: float = 1.0
    """Factor of the lower bound on T from distance / |vel_max| (seed eq. 8e), >= 1."""
    kappa_B: float = 1e-3
    """Weight of the obstacle barrier (seed eq. 9-10)."""
    rk4_steps: int = 2
    """RK4 steps per shooting interval."""
    grid: Literal["graded", "uniform", "refined"] = "graded"
    """Shooting grid: 'graded' shortens the intervals smoothly toward both rest ends, where the acceleration has to
    ramp within milliseconds (one solve, within 0.1 % of the converged T at N = 100); 'uniform' is the plain grid
    (0.8 % slower at N = 100); 'refined' solves on the graded grid, then once more on a grid that equidistributes
    the input's magnitude (converged T, about twice the solve time)."""
    grid_grading: float = 0.8
    """Grading a of the 'graded' grid: interval length proportional to 1 - a cos(2 pi t/T), in [0, 1)."""
    clearance_points: int = 1
    """Extra points per interval at which the hard obstacle clearance is also imposed."""
    clearance_margin_m: float = setting_field(0.002, unit="m")
    """Safety margin added to every inflated obstacle by the hard clearance constraint (m)."""
    robust_omega_factors: list[float] = field(default_factory=list)
    """Natural-frequency factors of extra pendulum copies that must also end at rest (robust variant), e.g. [0.9, 1.1]."""
    robust_max_rel_deg: float = setting_field(1.0, unit="deg")
    """Largest angle between a robust copy and the container during the move (deg)."""
    max_iter: int = 1000
    """IPOPT iteration limit."""
    tol: float = 1e-6
    """IPOPT convergence tolerance."""
    parallel: bool = False
    """Solve independent waypoint segments in two worker processes (pays off only on an idle machine)."""

    def __post_init__(self) -> None:
        if not 10 <= self.N <= 5000:
            raise UserError(f"[solver].N must lie between 10 and 5000, got {self.N}.")
        if self.kappa_T < 1:
            raise UserError(f"[solver].kappa_T must be at least 1 (seed eq. 8e), got {self.kappa_T}.")
        for name in ("kappa_r", "kappa_j", "kappa_z", "kappa_B"):
            if not getattr(self, name) >= 0:
                raise UserError(f"[solver].{name} must be zero or positive, got {getattr(self, name)}.")
        if self.grid not in ("graded", "uniform", "refined"):
            raise UserError(f"[solver].grid must be 'graded', 'uniform' or 'refined', got {self.grid!r}.")
        if not 0 <= self.grid_grading < 1:
            raise UserError(f"[solver].grid_grading must lie in [0, 1), got {self.grid_grading}.")
        if not 1 <= self.rk4_steps <= 20 or not 0 <= self.clearance_points <= 20:
            raise UserError("[solver].rk4_steps must lie in 1..20 and clearance_points in 0..20.")
        check_robust_factors(self.robust_omega_factors, "[solver].robust_omega_factors")
        if not self.clearance_margin_m >= 0:
            raise UserError(f"[solver].clearance_margin_m must be zero or positive, got {self.clearance_margin_m}.")
        for name in ("robust_max_rel_deg", "tol", "max_iter"):
            if not getattr(self, name) > 0:
                raise UserError(f"[solver].{name} must be positive, got {getattr(self, name)!r}.")


@dataclass(frozen=True)
class LiquidTable:
    """[liquid]: the pendulum parameters (seed Table I units); `--params` from `sloshid identify` overrides it."""

    m_kg: float = setting_field(unit="kg")
    """The liquid mass m of the pendulum model (seed Table I)."""
    l_m: float = setting_field(unit="m")
    """The pendulum's length, which sets the natural frequency (omega^2 = g / l)."""
    d_ns_per_m: float = setting_field(unit="N s/m")
    """The pendulum's damping constant d = 2 m omega zeta."""

    def __post_init__(self) -> None:
        check_pendulum(self.m_kg, self.l_m, self.d_ns_per_m)


@dataclass
class Scenario:
    """A validated planning scenario: waypoints start ... goal and everything the planner needs."""

    waypoints: list[Vec3]
    limits: Limits
    obstacles: list[Obstacle]
    container_radius_m: float
    solver: SolverSettings
    liquid: SloshParams | None
    robot: RobotLimits
    compare: dict = field(default_factory=dict)
    source: str = ""
    """File the scenario came from (for messages)."""
    path: PathGeometry | None = None
    """[path] scenarios: the prescribed curve (then `waypoints` are its two ends)."""
    path_table: PathTable | None = None
    """[path] as written (tolerances)."""
    arm: Any = None
    """[robot] model = "panda" ...: the arm for joint-space checks (sloshid.planning.arm.ArmSettings), else None."""
    container_depth_m: float = 0.0
    """[container].depth_m: the container's body below the liquid surface's centre that clears the obstacles too."""
    rim_above_surface_m: float | None = None
    """[container].rim_above_surface_m: the rim's height above the liquid at rest (m)."""
    containers: list[TrayContainer] = field(default_factory=list)
    """[[containers]]: a tray of containers on the tool (then [container] is not used for the margin)."""
    tray: Tray | None = None
    """[tray]: the tool plate's size, which every container must stand on."""
    risk: RiskSettings | None = None
    """[risk]: Monte-Carlo draws and the robust plan's sampled models."""

    def container_clearance(self, pos_m, z_axis=None, obstacles=None):
        """`body_clearance` of this scenario's container (its radius and depth) at positions `pos_m` of the surface's
        centre, from `obstacles` (default: all of the scenario's); `z_axis` None: upright."""
        obstacles = self.obstacles if obstacles is None else obstacles
        return body_clearance(obstacles, pos_m, self.container_radius_m, self.container_depth_m, z_axis)

    @property
    def within_margin(self) -> bool:
        """Planned within the spill margin (`planning.upright`) rather than slosh-free: an upright move, or a tilting
        straight [move] (one start and goal, no obstacles) with [limits].spill_margin_mm, which uses tilt and margin
        both. A tilting move with waypoints or obstacles keeps the liquid level with the container instead."""
        if self.limits.upright:
            return True
        return (
            self.limits.spill_margin_mm is not None
            and self.path is None
            and len(self.waypoints) == 2
            and not self.obstacles
        )

    @property
    def move_jerk_max(self) -> Vec3 | None:
        """[limits].jerk_max as a limit of the move (planned or compared), with the jerk-limited formulation (the
        default); None with the seed's piecewise-constant acceleration, whose steps have no jerk bound."""
        return self.limits.jerk_max if self.solver.jerk_limited else None


_TABLES = (
    "move",
    "path",
    "limits",
    "obstacles",
    "container",
    "containers",
    "tray",
    "risk",
    "solver",
    "liquid",
    "robot",
    "compare",
)
_ARRAYS = ("obstacles", "containers")
"""Tables given as arrays of tables [[name]]."""


def scenario_from_dict(data: dict[str, Any], source: str = "") -> Scenario:
    """Validate a parsed scenario table-by-table (UserError with key and reason) and build the Scenario."""
    for key in data:
        if key not in _TABLES:
            raise UserError(f"unknown table '[{key}]'{did_you_mean(key, _TABLES)} in {source or 'the scenario'}.")
        if key not in _ARRAYS and not isinstance(data[key], dict):
            raise UserError(f"'{key}' must be a table [{key}], got {data[key]!r}.")
    misplaced = [k for k in data.get("solver", {}) if k in Limits.__dataclass_fields__]
    if misplaced:
        raise UserError(f"'[solver].{misplaced[0]}' belongs in the [limits] table.")
    if "move" in data and "path" in data:
        raise UserError(f"{source or 'the scenario'} has both [move] and [path]; give one of them.")
    if "move" not in data and "path" not in data:
        raise UserError(f"{source or 'the scenario'} has no [move] table (start and goal, or waypoints) nor [path].")
    path_table = geometry = None
    if "path" in data:
        path_table = from_dict(PathTable, data["path"], "[path]")
        geometry = build_geometry(path_table, Path(source).parent if source else None)
        points = [cast(Vec3, tuple(map(float, p))) for p in (geometry.start, geometry.end)]
    else:
        points = from_dict(Move, data["move"], "[move]").points()
    obstacles_raw = data.get("obstacles", [])
    if not isinstance(obstacles_raw, list):
        raise UserError("obstacles must be an array of tables [[obstacles]].")
    obstacles = [from_dict(Obstacle, o, f"[[obstacles]] #{i + 1}") for i, o in enumerate(obstacles_raw)]
    liquid = None
    if "liquid" in data:
        t = from_dict(LiquidTable, data["liquid"], "[liquid]")
        liquid = SloshParams(t.m_kg, t.l_m, t.d_ns_per_m)
    robot_raw = dict(data.get("robot", {}))
    arm_raw = {k: robot_raw.pop(k) for k in list(robot_raw) if k in ARM_KEYS}
    arm = None
    if arm_raw:
        arm = arm_settings(arm_raw)
    container = from_dict(Container, data.get("container", {}), "[container]")
    limits = from_dict(Limits, data.get("limits", {}), "[limits]")
    containers_raw = data.get("containers", [])
    if not isinstance(containers_raw, list):
        raise UserError("containers must be an array of tables [[containers]].")
    containers = [from_dict(TrayContainer, c, f"[[containers]] #{i + 1}") for i, c in enumerate(containers_raw)]
    if geometry is not None:
        limits = _path_margin(limits, container, "rel_angle_max_deg" in data.get("limits", {}))
    if containers and not limits.upright:
        raise UserError(
            f"{source or 'the scenario'} carries a tray of [[containers]], which is planned upright: set [limits] "
            "tilt_max_deg = 0."
        )
    tray = from_dict(Tray, data["tray"], "[tray]") if "tray" in data else None
    risk = from_dict(RiskSettings, data["risk"], "[risk]") if "risk" in data else None
    scenario = Scenario(
        waypoints=points,
        limits=limits,
        obstacles=obstacles,
        container_radius_m=container.radius_m,
        container_depth_m=container.depth_m,
        solver=from_dict(SolverSettings, data.get("solver", {}), "[solver]"),
        liquid=liquid,
        robot=from_dict(RobotLimits, robot_raw, "[robot]"),
        compare=dict(data.get("compare", {})),
        source=source,
        path=geometry,
        path_table=path_table,
        arm=arm,
        rim_above_surface_m=container.rim_above_surface_m,
        containers=containers,
        tray=tray,
        risk=risk,
    )
    _check_margin_radius(scenario)
    return scenario


def _check_margin_radius(scenario: Scenario) -> None:
    """Refuse a [container] of no radius whose spill margin is planned for: its wall height is radius x tan(tilt)."""
    measured = scenario.within_margin or (
        scenario.path is not None
        and scenario.limits.spill_margin_mm is not None
        and scenario.rim_above_surface_m is not None
    )
    if measured and not scenario.containers and scenario.container_radius_m <= 0:
        raise UserError(
            f"[container].radius_m must lie in (0, {MAX_RIM_M:g}] m for a move within a spill margin (the liquid "
            f"rises radius x tan(tilt) at the wall), got {scenario.container_radius_m:g}."
        )


def _path_margin(limits: Limits, container: Container, rel_given: bool) -> Limits:
    """A tilting [path] move with a spill margin uses both: the liquid may leave the container's axis by the angle at
    which its wall height R tan(angle) reaches rim - margin (at most 10 deg, and at most rel_angle_max_deg when that is
    given too)."""
    if limits.spill_margin_mm is None or container.rim_above_surface_m is None or limits.upright:
        return limits
    rise = container.rim_above_surface_m - limits.spill_margin_mm / 1000
    if rise <= 0:
        raise UserError(
            f"[container]: the spill margin of {limits.spill_margin_mm:g} mm is not below the rim's "
            f"{1000 * container.rim_above_surface_m:g} mm above the liquid, so the liquid would break it at rest."
        )
    angle = min(10.0, math.degrees(math.atan(rise / max(container.radius_m, 1e-9))))
    return replace(limits, rel_angle_max_deg=min(angle, limits.rel_angle_max_deg) if rel_given else angle)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file; any problem is a UserError naming the key and the reason."""
    return scenario_from_dict(load_toml(path), str(path))


def resolve_liquid(scenario: Scenario, params_path: str | Path | None) -> SloshParams:
    """The liquid to plan for: `--params` (identify JSON) if given, else the scenario's [liquid] table."""
    if params_path is not None:
        return SloshParams.from_identify_json(params_path)
    if scenario.liquid is None:
        raise SettingError(
            "params",
            f"{scenario.source or 'the scenario'} has no [liquid] table (m_kg, l_m, d_ns_per_m); "
            "add one or pass {name} PARAMS.json from `sloshid identify`.",
        )
    return scenario.liquid
