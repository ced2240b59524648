"""Upright moves within a spill margin ([limits] tilt_max_deg = 0): the fastest straight move that keeps every
container's liquid below its rim minus the margin, during and after the move, and calm on arrival.

The container does not tilt, so the liquid's surface angle IS its angle relative to the container; its wall height is
R tan(angle) (`model.conventions.wall_height_mm`). The problem is stated along the straight line from start to goal:
the path coordinate s with its velocity, acceleration and (jerk-limited) jerk, and for every liquid model (each
container's nominal liquid, and in the robust variant its sampled ones) the pendulum angles that the line's direction
drives (`model.pendulum.pendulum_rhs_3d`, the planner's equations). Constraints at the nodes: the wall angle within
the allowed rise (shrunk by cos(omega h / 2), the most a swing can pass between two nodes); at arrival each model's
swing amplitude within the residual limit (a box on angle and rate inside the amplitude's circle). It is transcribed
by the planner's own `MultipleShooting` and solved by IPOPT; the 1 kHz result is verified independently with the
compiled nonlinear integrator (`simulate_liquids`) and re-solved with tighter bounds if a wall passed between nodes.

With tilt allowed (`tilt_max_deg > 0`, a straight [move] with a spill margin) the same problem uses both: the container
tilts too (its roll and pitch for the driven angles, with their rates and angular accelerations; angular jerk is the
input), and the wall reads the liquid's angle RELATIVE to the container, R tan(liquid - container). The container's
tilt does not drive the pendulum (its pivot is the surface's centre, about which the container turns), so the liquid
is the upright problem's; the container is upright and at rest at both ends, within [limits] tilt_max_deg and
tilt_rate_max_deg_s and the robot's angular limits (at ROBOT_MARGIN) on the way. Holding the container on the liquid
(zero relative angle) and the upright move are both feasible here, so the plan is at least as fast as either.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import casadi as ca
import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.parallel import solver_interruptible
from sloshid.model.pendulum import SloshParams, pendulum_rhs_3d
from sloshid.model.trajectory import LimitUsage, Trajectory
from sloshid.planning.feasible import check_feasible
from sloshid.planning.ocp import OK_STATUSES, SegmentResult, bang_bang_time, ipopt_options
from sloshid.planning.problem import ROBOT_MARGIN, constraint_bounds, tilt_rate_limit
from sloshid.planning.result import limit_usages
from sloshid.planning.risk import RiskEstimate, ScenarioGuarantee, draw_models, monte_carlo, spreads, wall_figures
from sloshid.planning.sampling import sample_segments
from sloshid.planning.scenario import Scenario, Vec3
from sloshid.planning.transcription import MultipleShooting, graded_mesh
from sloshid.planning.vessels import Vessel, vessels_of

WALL_TRIES = 4
"""Re-solves with a tighter wall bound when the 1 kHz verification finds a wall passing it between the nodes."""
WALL_SAFETY = 0.998
"""A passed bound is lowered to this share of bound / peak for the next solve."""
ACTIVE_TOL = 0.995
"""A sampled model's constraint counts as active (support) when it uses this share of its bound."""
ROBUST_SEED_OFFSET = 1
"""The robust plan's sampled models use [risk].seed + this (apart from the Monte Carlo's draws)."""
KAPPA_TILT = 1e-7
"""Weight of the container's angular-jerk regulariser (s^5/rad^2) in a tilting move, as for [path] moves."""
TILT_RATE_MARGIN = 0.98
"""A tilting move's tilt and tilt rate are imposed at this share at the nodes (between them the rate, quadratic in
time, can pass a bound it rides)."""


@dataclass(frozen=True)
class UprightStructure:
    """What fixes the shape of the upright NLP (one cached solver per value)."""

    N: int
    n_models: int
    angles: tuple[int, ...]
    """Driven pendulum angles: 0 = phi (by the line's y component), 1 = theta (by its x component)."""
    jerk_limited: bool
    rk4_steps: int
    max_iter: int = 1000
    tol: float = 1e-8
    warm: bool = False
    clearance_points: int = 0
    tilt: bool = False
    """The container tilts too (its angle, rate and angular acceleration per driven angle; angular jerk as input)."""

    @property
    def n_path(self) -> int:
        """Path states: s, s', [s'']."""
        return 3 if self.jerk_limited else 2

    @property
    def tilt_offset(self) -> int:
        """Index of the container's first tilt state (after the path and every model's angles and rates)."""
        return self.n_path + 2 * len(self.angles) * self.n_models


@dataclass
class UprightProblem:
    """The continuous-time problem in the interface `MultipleShooting` transcribes (as `problem.SegmentProblem`)."""

    s: UprightStructure
    x: ca.SX
    u: ca.SX
    p: ca.SX
    """direction (3), kappa_r, kappa_j, then per model: l, d/m, allowed wall angle; tilting: tilt, rate and angular
    acceleration limits (rad, rad/s, rad/s^2)."""
    rhs: ca.Function
    running_cost: ca.SX
    path: list[tuple[ca.SX, str]]
    clearance: None = None

    @property
    def n_path(self) -> int:
        """Path states: s, s', [s'']."""
        return 3 if self.s.jerk_limited else 2


def build_upright_problem(s: UprightStructure) -> UprightProblem:
    """The upright (or tilting) problem in CasADi SX symbols."""
    n_path, na = s.n_path, len(s.angles)
    n_tilt = 3 * na if s.tilt else 0
    x, u = ca.SX.sym("x", n_path + 2 * na * s.n_models + n_tilt), ca.SX.sym("u", 1 + (na if s.tilt else 0))
    direction, weights = ca.SX.sym("e", 3), ca.SX.sym("w", 2)
    models = ca.SX.sym("m", 3 * s.n_models)
    tilt_lim = ca.SX.sym("tl", 3 if s.tilt else 0)
    p = ca.vertcat(direction, weights, models, tilt_lim)
    acc = x[2] if s.jerk_limited else u[0]
    acc3 = acc * direction
    parts = [x[1], acc] + ([u[0]] if s.jerk_limited else [])
    path: list[tuple[ca.SX, str]] = []
    zero = ca.SX(0)
    con = x[s.tilt_offset : s.tilt_offset + na] if s.tilt else None

    def bounded(vec, limit) -> tuple[ca.SX, str]:
        """|vec| <= limit: per angle with one driven angle, on the norm of the two with both."""
        return (vec / limit, "unit") if na == 1 else (ca.sumsqr(vec) / limit**2, "norm")

    for k in range(s.n_models):
        off = n_path + 2 * na * k
        ang, rate = x[off : off + na], x[off + na : off + 2 * na]
        liquid = SimpleNamespace(l_m=models[3 * k], damping_rate_1_s=models[3 * k + 1])
        o = [zero] * 12
        for i, a in enumerate(s.angles):
            o[3 + a], o[9 + a] = ang[i], rate[i]
        rhs = pendulum_rhs_3d(o, [acc3[0], acc3[1], acc3[2]], liquid, ca.sin, ca.cos)
        parts += [rate, ca.vertcat(*(rhs[9 + a] for a in s.angles))]
        # the wall reads the surface relative to the container (upright: the surface's own angle)
        path.append(bounded(ang - con if con is not None else ang, models[3 * k + 2]))
    cost = weights[0] / 2 * acc**2 + (weights[1] / 2 * u[0] ** 2 if s.jerk_limited else 0)
    if s.tilt:
        t0 = s.tilt_offset
        con_rate, con_acc = x[t0 + na : t0 + 2 * na], x[t0 + 2 * na : t0 + 3 * na]
        parts += [con_rate, con_acc, u[1:]]
        path += [bounded(con, tilt_lim[0]), bounded(con_rate, tilt_lim[1]), bounded(con_acc, tilt_lim[2])]
        cost += KAPPA_TILT / 2 * ca.sumsqr(u[1:])
    f = ca.Function("f", [x, u, p], [ca.vertcat(*parts)])
    return UprightProblem(s, x, u, p, f, cost, path)


_CACHE: dict[UprightStructure, tuple[UprightProblem, MultipleShooting, ca.Function]] = {}


def _solver(s: UprightStructure) -> tuple[UprightProblem, MultipleShooting, ca.Function]:
    """The cached problem, transcription and IPOPT solver of a structure."""
    if s not in _CACHE:
        prob = build_upright_problem(s)
        ms = MultipleShooting(prob)
        # expanded to SX: many pendulum copies make the MX graph's iterations several times slower
        _CACHE[s] = (prob, ms, ca.nlpsol("upright", "ipopt", ms.nlp, {**ipopt_options(s), "expand": True}))
    return _CACHE[s]


@dataclass(frozen=True)
class LineLimits:
    """The scenario's limits along the move's line (the tightest axis decides), and its length."""

    length_m: float
    direction: np.ndarray
    vel: float
    acc: float
    jerk: float

    @property
    def t_no_liquid_s(self) -> float:
        """The fastest rest-to-rest move these acceleration and velocity limits allow, with no liquid (bang-bang)."""
        return bang_bang_time(self.length_m, self.acc, self.vel)


def line_limits(scenario: Scenario, index: int = 0) -> LineLimits:
    """Per-axis [limits] and the robot's norm limits turned into limits along the line from waypoint `index` to the
    next (start -> goal for a move without waypoints)."""
    start, goal = (np.asarray(p, dtype=float) for p in scenario.waypoints[index : index + 2])
    delta = goal - start
    length = float(np.linalg.norm(delta))
    e = delta / length
    lim, robot = scenario.limits, scenario.robot

    def along(box, norm) -> float:
        return min([norm] + [b / abs(c) for b, c in zip(box, e) if abs(c) > 1e-12])

    return LineLimits(
        length,
        e,
        along(lim.vel_max, robot.vel_m_s),
        along(lim.acc_max, robot.acc_m_s2),
        along(lim.jerk_max, robot.jerk_m_s3),
    )


@dataclass
class VesselCheck:
    """One container's wall in the independent nonlinear simulation of the planned move (mm)."""

    name: str
    peak_mm: float
    """Highest wall height during and after the move."""
    allowed_mm: float
    """Rim minus margin above the surface at rest."""
    residual_mm: float
    """Highest wall height after arrival."""
    residual_max_mm: float

    @property
    def ok(self) -> bool:
        """Within its margin and calm enough on arrival."""
        return self.peak_mm <= self.allowed_mm and self.residual_mm <= self.residual_max_mm

    @property
    def use(self) -> float:
        """The larger share of its two allowances it uses (1: at a bound)."""
        return max(self.peak_mm / self.allowed_mm, self.residual_mm / self.residual_max_mm)


@dataclass
class UprightPlan:
    """A solved upright move: the 1 kHz trajectory, each container's wall, the limiting one, and the risk."""

    trajectory: Trajectory
    T_s: float
    status: str
    solve_time_s: float
    iterations: int
    vessels: list[Vessel]
    checks: list[VesselCheck]
    t_no_liquid_s: float
    """The fastest move the same acceleration and velocity limits allow with no liquid at all."""
    limits: list[LimitUsage]
    move_limits: list[LimitUsage]
    scenario: Scenario | None = None
    risk: RiskEstimate | None = None
    guarantee: ScenarioGuarantee | None = None
    """The robust variant's sampled models and bound (None: the nominal plan)."""
    wall_bound_share: list[float] = field(default_factory=list)
    """Share of each container's allowed wall angle the solver was given (below 1 after a wall passed between nodes)."""
    joints: None = None
    path_ok: bool = True

    @property
    def tilting(self) -> bool:
        """The container tilts (tilt_max_deg > 0): the margin is held relative to it."""
        return self.scenario is not None and not self.scenario.limits.upright

    @property
    def max_tilt_deg(self) -> float:
        """Largest tilt of the container from upright on the 1 kHz trajectory (0 for an upright move)."""
        return float(np.degrees(np.arccos(np.clip(self.trajectory.z_axis[:, 2], -1.0, 1.0))).max())

    @property
    def kind(self) -> str:
        """'upright', or 'tilt_margin' for a tilting move within the spill margin."""
        return "tilt_margin" if self.tilting else "upright"

    @property
    def limits_ok(self) -> bool:
        """Robot and [limits] held on the 1 kHz trajectory."""
        return all(u.ok for u in self.limits + self.move_limits)

    @property
    def verification_ok(self) -> bool:
        """Every container within its margin and residual in the independent simulation."""
        return all(c.ok for c in self.checks)

    @property
    def limiting(self) -> VesselCheck:
        """The container closest to one of its allowances: the one that sets the move's duration."""
        return max(self.checks, key=lambda c: c.use)

    def summary(self) -> str:
        """What `sloshid plan` prints for an upright move (or a tilting one within the spill margin)."""
        walls = "; ".join(
            f"{c.name}: wall {c.peak_mm:.2f} of {c.allowed_mm:.2f} mm, {c.residual_mm:.2f} mm after "
            f"(<= {c.residual_max_mm:.2f})"
            for c in self.checks
        )
        tilt = f"max tilt {self.max_tilt_deg:.2f} deg; " if self.tilting else ""
        lines = [
            f"planned {self._what}: T = {self.T_s:.4f} s ({self.T_s / self.t_no_liquid_s:.3f} x the "
            f"{self.t_no_liquid_s:.4f} s of a move with no liquid), solved in {self.solve_time_s:.2f} s "
            f"({self.status}); {tilt}{walls}; limiting: {self.limiting.name}; margins "
            f"{'held' if self.verification_ok else 'BROKEN'}; limits {'ok' if self.limits_ok else 'EXCEEDED'}"
        ]
        if self.guarantee is not None:
            lines.append(self.guarantee.summary())
        lines.append(self.risk.summary() if self.risk is not None else "risk: not estimated (no parameter band)")
        return "\n".join(lines)

    @property
    def _what(self) -> str:
        """'an upright move' or 'a tilting move within the spill margin'."""
        return "a tilting move within the spill margin" if self.tilting else "an upright move"

    def to_dict(self) -> dict:
        """The `--json` content."""
        return {
            "kind": self.kind,
            "T_s": self.T_s,
            "max_tilt_deg": self.max_tilt_deg,
            "t_no_liquid_s": self.t_no_liquid_s,
            "time_ratio": self.T_s / self.t_no_liquid_s,
            "status": self.status,
            "solve_time_s": self.solve_time_s,
            "iterations": self.iterations,
            "containers": [
                {
                    "name": c.name,
                    "peak_wall_mm": c.peak_mm,
                    "allowed_wall_mm": c.allowed_mm,
                    "residual_wall_mm": c.residual_mm,
                    "residual_max_mm": c.residual_max_mm,
                    "f_hz": v.liquid.f_hz,
                    "zeta": v.liquid.zeta,
                    "ok": c.ok,
                }
                for c, v in zip(self.checks, self.vessels)
            ],
            "limiting_container": self.limiting.name,
            "verification_ok": self.verification_ok,
            "limits_ok": self.limits_ok,
            "limits": [vars(u) for u in self.limits],
            "move_limits": [vars(u) for u in self.move_limits],
            "wall_bound_share": list(self.wall_bound_share),
            "robust": self.guarantee.to_dict() if self.guarantee is not None else None,
            "risk": self.risk.to_dict() if self.risk is not None else None,
            "samples": len(self.trajectory.t_s),
        }

    def to_csv(self, path: str | Path) -> None:
        """Write the 1 kHz trajectory CSV, never over the scenario it was planned from."""
        self.trajectory.to_csv(path, (self.scenario.source,) if self.scenario and self.scenario.source else ())

    def plot(self, ax=None):
        """Each container's wall height in the nonlinear simulation with its allowance; returns the figure."""
        import matplotlib.pyplot as plt

        own = ax is None
        if own:
            _, ax = plt.subplots(figsize=(9, 3.4))
        from sloshid.model.simulate import simulate_liquids

        responses = simulate_liquids([self.trajectory] * len(self.vessels), [v.liquid for v in self.vessels], 1.5)
        for v, r, c in zip(self.vessels, responses, self.checks):
            (line,) = ax.plot(r.t_s, r.wall_height_mm(v.radius_m), lw=1, label=f"{v.name} ({v.liquid.f_hz:.2f} Hz)")
            ax.axhline(c.allowed_mm, color=line.get_color(), ls="--", lw=0.8)
        ax.axvline(self.T_s, color="0.5", ls=":", lw=0.8)
        ax.set(
            xlabel="time t (s)", ylabel="wall height (mm)", title=f"{self._what.split(' ', 1)[1]}, T = {self.T_s:.3f} s"
        )
        ax.legend(fontsize=8)
        if own:
            ax.figure.tight_layout()
        return ax.figure

    def report_page(self, links: dict[str, str] | None = None, liquid_source: str = ""):
        """The upright plan's report (summary, wall heights, containers), drawn but not written."""
        from sloshid.report.html import Report

        rep = Report("sloshid tilting plan within the spill margin" if self.tilting else "sloshid upright plan")
        if links:
            rep.add_links(links)
        rep.add_text(self.summary())
        if liquid_source:
            rep.add_text(f"liquid: {liquid_source}")
        rep.add_figure(self.plot(), "wall height of each container in the independent nonlinear simulation")
        rows = [[c.name, c.peak_mm, c.allowed_mm, c.residual_mm, c.residual_max_mm, c.ok] for c in self.checks]
        rep.add_table(["container", "peak (mm)", "allowed (mm)", "after (mm)", "after max (mm)", "ok"], rows)
        return rep

    def report(self, directory: str | Path, links: dict[str, str] | None = None, liquid_source: str = "") -> Path:
        """Write the report to directory/index.html."""
        return self.report_page(links, liquid_source).save(directory)


def _check_request(scenario: Scenario) -> None:
    """Refuse what the upright (or tilting, within a margin) planner does not take (one sentence each)."""
    src = scenario.source or "the scenario"
    what = "an upright move (tilt_max_deg = 0)" if scenario.limits.upright else "a tilting move within a spill margin"
    if scenario.path is not None:
        raise UserError(f"{src}: {what} follows a straight [move], not a [path].")
    if len(scenario.waypoints) != 2 and not scenario.limits.upright:
        raise UserError(f"{src}: {what} takes one start and goal, not waypoints.")
    if scenario.obstacles:
        raise UserError(f"{src}: {what} is a straight line and takes no [[obstacles]].")


def _driven_angles(e: np.ndarray) -> tuple[int, ...]:
    """The pendulum angles a move along e drives: phi by its y component, theta by its x component."""
    angles = tuple(a for a, axis in ((0, 1), (1, 0)) if abs(e[axis]) > 1e-12)
    return angles or (1,)


def _bounds(
    s: UprightStructure,
    line: LineLimits,
    models,
    residual_angles,
    T_bounds,
    ms: MultipleShooting,
    rot_jerk: float = 0.0,
    liquid0: np.ndarray | None = None,
):
    """(lbx, ubx): rest at the start (the liquids at `liquid0`, their angles and rates in the state's order, when
    given), the line's limits on the way, each model's swing within its residual box at the goal (a tilting container
    upright and at rest there, its angular jerk within `rot_jerk`), T within T_bounds."""
    n_path, na = s.n_path, len(s.angles)
    nx = s.tilt_offset + (3 * na if s.tilt else 0)
    lo, hi = np.full((3, nx), -np.inf), np.full((3, nx), np.inf)  # rows: start, path, goal
    lo[:, 1], hi[:, 1] = -line.vel, line.vel
    if s.jerk_limited:
        lo[:, 2], hi[:, 2] = -line.acc, line.acc
    lo[0], hi[0] = 0.0, 0.0
    if liquid0 is not None:  # a later segment: the liquids swing on from where the last one left them
        lo[0, n_path : s.tilt_offset] = hi[0, n_path : s.tilt_offset] = liquid0
    lo[2, :n_path], hi[2, :n_path] = 0.0, 0.0
    lo[2, 0] = hi[2, 0] = line.length_m
    for k, (m, a_res) in enumerate(zip(models, residual_angles)):
        # inside the amplitude circle: angle and (rate + zeta omega angle) / omega_d each within a_res / sqrt(2 na)
        box = a_res / math.sqrt(2 * na) / (1 + m.zeta)
        off = n_path + 2 * na * k
        lo[2, off : off + na], hi[2, off : off + na] = -box, box
        w = m.omega_rad_s * math.sqrt(1 - m.zeta**2)
        lo[2, off + na : off + 2 * na], hi[2, off + na : off + 2 * na] = -box * w, box * w
    lo[2, s.tilt_offset :], hi[2, s.tilt_offset :] = 0.0, 0.0  # a tilting container ends upright and at rest
    ulim = np.array([line.jerk if s.jerk_limited else line.acc] + [rot_jerk / math.sqrt(na)] * (na if s.tilt else 0))
    rows = np.r_[0, np.ones(s.N - 1, dtype=int), 2]
    lbx = ms.join(T_bounds[0], lo[rows], np.tile(-ulim, (s.N, 1)))
    ubx = ms.join(T_bounds[1], hi[rows], np.tile(ulim, (s.N, 1)))
    return lbx, ubx


def _guess(s: UprightStructure, line: LineLimits, n_models: int, T0: float, mesh: np.ndarray, ms) -> np.ndarray:
    """A minimum-jerk profile along the line over T0, liquids at rest."""
    tau = (np.concatenate([[0.0], np.cumsum(mesh)]) / s.N)[:, None]
    L = line.length_m
    cols = [L * (10 * tau**3 - 15 * tau**4 + 6 * tau**5), L * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / T0]
    if s.jerk_limited:
        cols.append(L * (60 * tau - 180 * tau**2 + 120 * tau**3) / T0**2)
    n_tilt = 3 * len(s.angles) if s.tilt else 0
    X = np.hstack([*cols, np.zeros((s.N + 1, 2 * len(s.angles) * n_models + n_tilt))])
    mid = (tau[:-1] + tau[1:]) / 2
    U = L * (60 - 360 * mid + 360 * mid**2) / T0**3 if s.jerk_limited else L * (60 * mid - 180 * mid**2) / T0**2
    return ms.join(T0, X, np.hstack([U, np.zeros((s.N, n_tilt // 3))]))


@dataclass
class _Solved:
    """One IPOPT solve of the upright problem."""

    T_s: float
    status: str
    iterations: int
    solve_time_s: float
    X: np.ndarray
    U: np.ndarray
    mesh: np.ndarray
    w: np.ndarray
    wall_node: list[float]
    """The wall bound each model was held to at the nodes (rad)."""
    structure: UprightStructure


def _solve(
    scenario: Scenario,
    line: LineLimits,
    models: Sequence[SloshParams],
    wall_angles: Sequence[float],
    residual_angles: Sequence[float],
    warm: _Solved | None,
    angles: tuple[int, ...] | None = None,
    liquid0: np.ndarray | None = None,
) -> _Solved:
    """Solve the upright problem of one segment for these liquid models and wall bounds (rad); `angles` the pendulum
    angles it carries (default: those its line drives), `liquid0` their state at its start (default: at rest)."""
    sv, tilt = scenario.solver, not scenario.limits.upright
    angles = angles if angles is not None else _driven_angles(line.direction)
    s = UprightStructure(sv.N, len(models), angles, sv.jerk_limited, sv.rk4_steps, sv.max_iter, sv.tol, tilt=tilt)
    _prob, ms, nlp = _solver(s)
    t_lb = line.t_no_liquid_s
    mesh = graded_mesh(s.N, sv.grid_grading) if sv.grid != "uniform" else np.ones(s.N)
    h_max = float(mesh.max()) * 1.3 * t_lb / s.N
    # the most a swing passes its node values between two nodes: 1 / cos(omega h / 2)
    node = [bound * math.cos(min(m.omega_rad_s * h_max / 2, 1.0)) for m, bound in zip(models, wall_angles)]
    params = [*line.direction, sv.kappa_r, sv.kappa_j]
    for m, bound in zip(models, node):
        params += [m.l_m, m.damping_rate_1_s, bound]
    lim, robot = scenario.limits, scenario.robot
    if tilt:
        params += [math.radians(lim.tilt_max_deg) * TILT_RATE_MARGIN, tilt_rate_limit(lim, robot) * TILT_RATE_MARGIN,
                   robot.rot_acc_rad_s2 * ROBOT_MARGIN]  # fmt: skip
    rot_jerk = robot.rot_jerk_rad_s3 * ROBOT_MARGIN
    lbx, ubx = _bounds(s, line, models, residual_angles, (t_lb, lim.t_max_s), ms, rot_jerk, liquid0)
    lbg, ubg = constraint_bounds(ms.kinds, sv)
    x0 = warm.w if warm is not None else _guess(s, line, len(models), 1.1 * t_lb, mesh, ms)
    t0 = time.perf_counter()
    with solver_interruptible():
        sol = nlp(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=np.concatenate([params, mesh]))
    elapsed = time.perf_counter() - t0
    stats = nlp.stats()
    w = np.asarray(sol["x"]).ravel()
    T, X, U = ms.split(w)
    return _Solved(T, str(stats.get("return_status")), int(stats.get("iter_count", 0)), elapsed, X, U, mesh, w, node, s)


def _trajectory(
    scenario: Scenario, lines: Sequence[LineLimits], sols: Sequence[_Solved], liquid: SloshParams
) -> Trajectory:
    """The exact 1 kHz samples of the solutions' piecewise-constant inputs along their lines, segment after segment
    (at rest at each waypoint); the container upright, or (tilting) at the exact polynomials of its piecewise-constant
    angular jerks."""
    from sloshid.planning.path_planner import _polynomial_samples

    segs = []
    for i, (line, sol) in enumerate(zip(lines, sols)):
        start, goal = (cast(Vec3, tuple(p)) for p in scenario.waypoints[i : i + 2])
        segs.append(SegmentResult(
            i, start, goal, None, scenario.solver.jerk_limited, sol.T_s, sol.status, sol.iterations,
            sol.solve_time_s, sol.X, sol.U[:, :1] * line.direction[None, :], mesh=sol.mesh,
        ))  # fmt: skip
    moved = sample_segments(segs, liquid, name="sloshid upright plan")
    euler, rates = np.zeros_like(moved.euler_rad), np.zeros_like(moved.euler_rad)
    if sols[0].structure.tilt:  # the container's tilt: angle and rate of each angle, segment after segment
        dt, first = float(moved.t_s[1] - moved.t_s[0]), 0
        for i, (seg, sol) in enumerate(zip(segs, sols)):
            t = np.arange(math.ceil(seg.T_s / dt - 1e-9) + 1) * dt  # as sample_segments samples a segment
            angles = sol.structure.angles
            tilt = _polynomial_samples(np.zeros((3, len(angles))), sol.U[:, 1:], seg.t_nodes, t)[1 if i else 0 :]
            for j, a in enumerate(angles):
                euler[first : first + len(tilt), a], rates[first : first + len(tilt), a] = tilt[:, 0, j], tilt[:, 1, j]
            first += len(tilt)
        name = "sloshid tilting plan within the spill margin"
    else:
        name = moved.name
    return Trajectory(moved.t_s, moved.pos_m, moved.vel_m_s, moved.acc_m_s2, euler, rates, name=name)


def _checks(traj: Trajectory, vessels: Sequence[Vessel]) -> list[VesselCheck]:
    """Each container's wall under the move in the independent nonlinear simulation."""
    fig = wall_figures(traj, vessels, [[v.liquid for v in vessels]])
    return [
        VesselCheck(v.name, float(fig.peak_mm[0, j]), 1000 * v.rise_allowed_m, float(fig.residual_mm[0, j]),
                    1000 * min(v.residual_max_m, v.rise_allowed_m))
        for j, v in enumerate(vessels)
    ]  # fmt: skip


def _support(sols: Sequence[_Solved], models: Sequence[SloshParams], residual: Sequence[float], first: int) -> int:
    """Sampled models (from index `first`) whose wall bound or arrival box is active at the optimum of some segment."""
    active = set()
    for sol in sols:
        s = sol.structure
        na = len(s.angles)
        con = sol.X[:, s.tilt_offset : s.tilt_offset + na] if s.tilt else 0.0
        for k in range(first, len(models)):
            off = s.n_path + 2 * na * k
            ang, rate = sol.X[:, off : off + na], sol.X[-1, off + na : off + 2 * na]
            box = residual[k] / math.sqrt(2 * na) / (1 + models[k].zeta)
            w = models[k].omega_rad_s * math.sqrt(1 - models[k].zeta ** 2)
            wall_use = float(np.sqrt(((ang - con) ** 2).sum(axis=1)).max()) / sol.wall_node[k]
            end_use = max(float(np.abs(ang[-1]).max()) / box, float(np.abs(rate).max()) / (box * w))
            if wall_use >= ACTIVE_TOL or end_use >= ACTIVE_TOL:
                active.add(k)
    return len(active)


def plan_upright(
    scenario: Scenario,
    liquid: SloshParams | None,
    *,
    params_path: str | Path | None = None,
    robust_samples: int | None = None,
    risk_draws: int | None = None,
) -> UprightPlan:
    """Plan the scenario's upright move for its containers; `robust_samples` (default [risk].scenarios) sampled models
    per container are held too; the risk is estimated over `risk_draws` (default [risk].draws) Monte-Carlo draws
    when every container's uncertainty is known. UserError for requests it cannot plan or solve."""
    _check_request(scenario)
    check_feasible(scenario)
    vessels = vessels_of(scenario, liquid, params_path)
    n_seg = len(scenario.waypoints) - 1
    lines = [line_limits(scenario, i) for i in range(n_seg)]
    # with waypoints every segment carries both angles: a swing left by one segment goes on in the next, whatever
    # direction that one drives
    angles = None if n_seg == 1 else (0, 1)
    settings = scenario.risk
    spread = spreads(vessels, settings)
    n_samples = robust_samples if robust_samples is not None else (settings.scenarios if settings else 0)
    if n_samples and spread is None:
        raise UserError(
            "a robust upright plan samples the liquids from their uncertainty: give [risk] omega_ci95_rel, or `params` "
            "as an identify JSON that holds standard errors."
        )
    seed = settings.seed if settings else 1
    models = [v.liquid for v in vessels]
    of_vessel = list(range(len(vessels)))
    if n_samples and spread is not None:  # (without a spread, n_samples raised above)
        for draw in draw_models(vessels, spread, n_samples, seed + ROBUST_SEED_OFFSET):
            models += draw
            of_vessel += list(range(len(vessels)))
    share = [1.0] * len(vessels)
    residual = [vessels[j].residual_angle_rad for j in of_vessel]
    sols: list[_Solved] = []
    total_time, total_iter = 0.0, 0
    for attempt in range(WALL_TRIES + 1):
        wall = [vessels[j].angle_allowed_rad * share[j] for j in of_vessel]
        warm, sols, liquid0 = sols, [], None
        for i, line in enumerate(lines):  # one after the other: each starts where the liquids were left
            sol = _solve(scenario, line, models, wall, residual, warm[i] if warm else None, angles, liquid0)
            total_time, total_iter = total_time + sol.solve_time_s, total_iter + sol.iterations
            if sol.status not in OK_STATUSES:
                where = f" (segment {i + 1} of {n_seg})" if n_seg > 1 else ""
                raise UserError(
                    f"the {'tilting' if not scenario.limits.upright else 'upright'} move within the spill margin did "
                    f"not solve{where}: IPOPT status {sol.status} after {sol.iterations} iterations; raise "
                    "[limits].t_max_s, lower the spill margin, or loosen [solver].tol."
                )
            sols.append(sol)
            liquid0 = sol.X[-1, sol.structure.n_path : sol.structure.tilt_offset]
        traj = _trajectory(scenario, lines, sols, vessels[0].liquid)
        checks = _checks(traj, vessels)
        passed = [c.peak_mm / c.allowed_mm for c in checks]
        if all(c.ok for c in checks) or attempt == WALL_TRIES:
            break
        share = [sh * WALL_SAFETY / r if r > 1 else sh for sh, r in zip(share, passed)]
    usages, move = limit_usages(traj, scenario)
    guarantee = None
    if n_samples:  # a sample is support when its constraints are active in some segment
        k = _support(sols, models, residual, len(vessels))
        guarantee = ScenarioGuarantee(n_samples, k, settings.beta if settings else 1e-3, seed + ROBUST_SEED_OFFSET)
    risk = None
    if spread is not None:
        draws = risk_draws if risk_draws is not None else (settings.draws if settings else 1000)
        risk = monte_carlo(traj, vessels, spread, draws, seed)
    return UprightPlan(
        trajectory=traj,
        T_s=float(sum(x.T_s for x in sols)),
        status=sols[0].status if len({x.status for x in sols}) == 1 else "; ".join(x.status for x in sols),
        solve_time_s=total_time,
        iterations=total_iter,
        vessels=vessels,
        checks=checks,
        t_no_liquid_s=float(sum(line.t_no_liquid_s for line in lines)),
        limits=usages,
        move_limits=move,
        scenario=scenario,
        risk=risk,
        guarantee=guarantee,
        wall_bound_share=share,
    )


@dataclass
class MarginSweep:
    """Transfer time and risk of upright plans over a range of spill margins: the trade-off a user picks from."""

    margins_mm: list[float]
    T_s: list[float | None]
    """Each margin's transfer time (None: no move meets it)."""
    risk: list[RiskEstimate | None]
    ok: list[bool]
    t_no_liquid_s: float

    def summary(self) -> str:
        """One line per margin, joined."""
        parts = []
        for m, T, r in zip(self.margins_mm, self.T_s, self.risk):
            risk = f", risk {100 * r.p:.2f} +- {100 * r.stderr:.2f} %" if r is not None else ""
            parts.append(f"{m:g} mm: " + (f"T = {T:.3f} s{risk}" if T is not None else "no move meets it"))
        return "margin sweep: " + "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "margins_mm": self.margins_mm,
            "T_s": self.T_s,
            "risk": [r.to_dict() if r is not None else None for r in self.risk],
            "verification_ok": self.ok,
            "t_no_liquid_s": self.t_no_liquid_s,
        }

    def plot(self, ax=None):
        """Transfer time (left axis) and risk with its sampling error (right axis) against the margin."""
        import matplotlib.pyplot as plt

        own = ax is None
        if own:
            _, ax = plt.subplots(figsize=(7, 3.6))
        got = [(m, T) for m, T in zip(self.margins_mm, self.T_s) if T is not None]
        ax.plot([m for m, _ in got], [T for _, T in got], "o-", color="#36c", label="transfer time")
        ax.axhline(self.t_no_liquid_s, color="#36c", ls=":", lw=0.8, label="no liquid")
        ax.set(xlabel="spill margin (mm)", ylabel="transfer time T (s)", title="upright move: time and risk vs margin")
        risks = [(m, r) for m, r in zip(self.margins_mm, self.risk) if r is not None]
        if risks:
            right = ax.twinx()
            right.errorbar(
                [m for m, _ in risks],
                [100 * r.p for _, r in risks],
                yerr=[100 * 1.96 * r.stderr for _, r in risks],
                fmt="s--",
                color="tab:red",
                capsize=3,
                label="risk (95 % sampling error)",
            )
            right.set_ylabel("P(margin broken) (%)", color="tab:red")
        ax.figure.legend(loc="upper center", fontsize=8, ncols=3)
        if own:
            ax.figure.tight_layout(rect=(0, 0, 1, 0.9))
        return ax.figure

    def save_figure(self, path: str | Path) -> None:
        """Draw and write the figure atomically."""
        import matplotlib.pyplot as plt

        from sloshid.core.atomic import atomic_path
        from sloshid.core.outputs import FIGURE_METADATA

        fig = self.plot()
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=150, format="png", metadata=FIGURE_METADATA)  # marked: sloshid replaces only its own
        plt.close(fig)


def sweep_margin(
    scenario: Scenario,
    liquid: SloshParams | None,
    margins_mm: Sequence[float],
    params_path: str | Path | None = None,
    robust_samples: int | None = None,
) -> MarginSweep:
    """Plan the upright move at every spill margin (every container's margin set to it); a margin no move meets is a
    gap in the sweep, not an error."""
    import dataclasses

    T: list[float | None] = []
    risk: list[RiskEstimate | None] = []
    ok: list[bool] = []
    t_free = sum(line_limits(scenario, i).t_no_liquid_s for i in range(len(scenario.waypoints) - 1))
    for m in margins_mm:
        trial = dataclasses.replace(
            scenario,
            limits=dataclasses.replace(scenario.limits, spill_margin_mm=float(m)),
            containers=[dataclasses.replace(c, spill_margin_mm=None) for c in scenario.containers],
        )
        try:
            got = plan_upright(trial, liquid, params_path=params_path, robust_samples=robust_samples)
        except UserError:
            T.append(None)
            risk.append(None)
            ok.append(False)
            continue
        T.append(got.T_s)
        risk.append(got.risk)
        ok.append(got.verification_ok)
    return MarginSweep([float(m) for m in margins_mm], T, risk, ok, t_free)
