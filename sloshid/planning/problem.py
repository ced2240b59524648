"""The optimal-control problem of one rest-to-rest segment (seed eq. 8-10), stated in continuous time.

This module says WHAT is optimised, independent of how it is discretised (`transcription.py` turns it into an
NLP, as rockit keeps an `Ocp` apart from its `MultipleShooting`): the state and input, the dynamics
dx/dt = f(x, u, p), the running cost, the path constraints (each with a kind that fixes its bounds), the
box bounds and the rest-to-rest boundary conditions, and the parameter vector p through which everything
that changes between solves enters (liquid, weights, robot limits, robust factors, obstacles).

The liquid model is `sloshid.model.pendulum` (eq. 2 in 1-D, the reconstructed eq. 3 in 3-D); the container
follows the liquid's surface, so its orientation states ARE the pendulum angles. Two formulations:
jerk-limited (jerk is the input, acceleration a state; robot-ready) and the seed's piecewise-constant
acceleration.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import casadi as ca
import numpy as np

from sloshid.model.pendulum import G, SloshParams, angle_accel, pendulum_rhs_3d
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.scenario import Limits, Obstacle, SolverSettings

ROBOT_MARGIN = 0.9
"""Rotational robot limits are imposed at this share, since they are enforced at the nodes only."""
BARRIER_SHARPNESS = 4.0
"""Exponent k of the smooth barrier (1/k) ln(1 + s^-k), which tends to -ln(min{1, s}) of seed eq. 10."""
CYLINDER_POWER = 4
"""Cylinders are kept out with (rho/r)^(2q) + (dz/h)^(2q) >= 2, q this power: a smooth, conservative shell."""


@dataclass(frozen=True)
class Structure:
    """What fixes the shape of the NLP (one cached solver per value)."""

    axis: int | None
    """1-D along this axis (0 = x, 1 = y) with only that axis' states, or None for the full 3-D model."""
    jerk_limited: bool
    N: int
    rk4_steps: int
    clearance_points: int
    n_spheres: int
    n_cylinders: int
    n_robust: int
    vel_norm: bool
    acc_norm: bool
    rot_vel_norm: bool
    max_iter: int = 1000
    tol: float = 1e-8
    warm: bool = False

    @property
    def n_pos(self) -> int:
        """Translational axes in the state."""
        return 1 if self.axis is not None else 3

    @property
    def n_ang(self) -> int:
        """Pendulum angles per copy (1-D angle, or phi and theta)."""
        return 1 if self.axis is not None else 2

    @property
    def nx(self) -> int:
        """State dimension: position, velocity, [acceleration], angles and rates of the nominal and robust copies."""
        return self.n_pos * (3 if self.jerk_limited else 2) + 2 * self.n_ang * (1 + self.n_robust)


class StateLayout:
    """Index bookkeeping of the state vector for one Structure."""

    def __init__(self, s: Structure) -> None:
        n, a = s.n_pos, s.n_ang
        self.pos = slice(0, n)
        self.vel = slice(n, 2 * n)
        off = 2 * n
        self.acc = slice(off, off + n) if s.jerk_limited else None
        off += n if s.jerk_limited else 0
        self.copies = []  # (angle slice, rate slice) of the nominal copy, then the robust copies
        for _ in range(1 + s.n_robust):
            self.copies.append((slice(off, off + a), slice(off + a, off + 2 * a)))
            off += 2 * a


@dataclass
class SegmentProblem:
    """The continuous-time problem: min T + integral of L dt subject to dx/dt = f, path constraints, bounds."""

    s: Structure
    lay: StateLayout
    x: ca.SX
    """State (nx)."""
    u: ca.SX
    """Input (n_pos): jerk or acceleration."""
    p: ca.SX
    """Parameters: l, d/m, kappa_r, kappa_j, kappa_B, kappa_z, robot limits (5), robust factors, obstacles."""
    rhs: ca.Function
    """f(x, u, p): the state's time derivative."""
    running_cost: ca.SX
    """L(x, u, p), integrated over time (regularisers and obstacle barrier)."""
    path: list[tuple[ca.SX, str]]
    """Path constraints g(x, u, p) with their kind (bounds in `constraint_bounds`), imposed at every node."""
    clearance: ca.Function | None
    """Hard obstacle clearance (>= 0 outside) of a position: imposed at the nodes and between them."""

    def position_at(self, tau: ca.SX) -> ca.SX:
        """Exact position tau after a node under the constant input u (the input's polynomial)."""
        x, u, lay = self.x, self.u, self.lay
        acc = x[lay.acc] if lay.acc is not None else u  # acceleration is a state when the jerk is the input
        return x[lay.pos] + x[lay.vel] * tau + acc * tau**2 / 2 + (u * tau**3 / 6 if self.s.jerk_limited else 0)


def _pendulum_dd(s: Structure, ang, rate, acc, liquid) -> ca.SX:
    """Angular accelerations of one pendulum copy (seed eq. 2, or eq. 3 via model.pendulum_rhs_3d)."""
    if s.axis is not None:
        return angle_accel(ang[0], rate[0], acc[0], liquid, G, ca.sin, ca.cos)
    zero = ca.SX(0)
    o = [zero, zero, zero, ang[0], ang[1], zero, zero, zero, zero, rate[0], rate[1], zero]
    rhs = pendulum_rhs_3d(o, [acc[0], acc[1], acc[2]], liquid, ca.sin, ca.cos)
    return ca.vertcat(rhs[9], rhs[10])


def _rhs(s: Structure, lay: StateLayout, x, u, liquids) -> ca.SX:
    """Time derivative of the full state (translation, nominal pendulum, robust copies)."""
    acc = x[lay.acc] if s.jerk_limited else u
    parts = [x[lay.vel], acc] + ([u] if s.jerk_limited else [])
    for (ang, rate), liquid in zip(lay.copies, liquids):
        parts += [x[rate], _pendulum_dd(s, x[ang], x[rate], acc, liquid)]
    return ca.vertcat(*parts)


def _smooth_barrier(clear_m2) -> ca.SX:
    """-ln(min{1, s}) of seed eq. 10 made smooth: (1/k) ln(1 + s^-k) with s kept positive."""
    s_pos = 0.5 * (clear_m2 + ca.sqrt(clear_m2**2 + 1e-12))
    return ca.log(1 + s_pos ** (-BARRIER_SHARPNESS)) / BARRIER_SHARPNESS


def _obstacle_terms(p, spheres, cylinders) -> tuple[list, list]:
    """Hard clearance expressions (>= 0 outside) and barrier arguments s (m^2) for position p."""
    hard, soft = [], []
    for c in spheres:  # c = [cx, cy, cz, r_inflated]
        d2 = ca.sumsqr(p - c[0:3])
        hard.append(ca.log(d2 / c[3] ** 2))
        soft.append(d2 - c[3] ** 2)
    for c in cylinders:  # c = [cx, cy, z_bottom, z_top, r_inflated] (z extent already inflated)
        rho2 = ((p[0] - c[0]) ** 2 + (p[1] - c[1]) ** 2) / c[4] ** 2
        mid, half = (c[2] + c[3]) / 2, (c[3] - c[2]) / 2
        dz2 = ((p[2] - mid) / half) ** 2
        shell = (rho2**CYLINDER_POWER + dz2**CYLINDER_POWER) / 2
        hard.append(ca.log(shell))
        soft.append(c[4] ** 2 * (shell ** (1 / (2 * CYLINDER_POWER)) - 1) * 2)
    return hard, soft


def _symbols(s: Structure) -> SimpleNamespace:
    """The parameter symbols and the liquids of the nominal and robust pendulum copies."""
    n = SimpleNamespace()
    n.l, n.c, n.k_r, n.k_j, n.k_b, n.k_z = (ca.SX.sym(k) for k in ("l", "c", "kr", "kj", "kb", "kz"))
    n.factors = ca.SX.sym("f", s.n_robust)
    sph, cyl = ca.SX.sym("sph", 4 * s.n_spheres), ca.SX.sym("cyl", 5 * s.n_cylinders)
    n.spheres = [sph[4 * i : 4 * i + 4] for i in range(s.n_spheres)]
    n.cylinders = [cyl[5 * i : 5 * i + 5] for i in range(s.n_cylinders)]
    # vel, acc, tilt rate (the move's or the robot's), rot_acc, rot_jerk, tilt_max: normalise the norm
    # constraints to O(1)
    n.robot = ca.SX.sym("robot", 6)
    n.p = ca.vertcat(n.l, n.c, n.k_r, n.k_j, n.k_b, n.k_z, n.robot, n.factors, sph, cyl)
    # a robust copy with omega*f and the same zeta has l/f^2 and damping rate c*f
    n.liquids = [SimpleNamespace(l_m=n.l, damping_rate_1_s=n.c)]
    n.liquids += [
        SimpleNamespace(l_m=n.l / n.factors[i] ** 2, damping_rate_1_s=n.c * n.factors[i]) for i in range(s.n_robust)
    ]
    return n


def _running_cost(s: Structure, lay: StateLayout, x, u, sym) -> ca.SX:
    """Seed eq. 8a's regularisers (acceleration, jerk, vertical acceleration) and the obstacle barrier (eq. 9-10)."""
    acc = x[lay.acc] if s.jerk_limited else u
    run = sym.k_r / 2 * ca.sumsqr(acc) + (sym.k_j / 2 * ca.sumsqr(u) if s.jerk_limited else 0)
    if s.axis is None:  # vertical acceleration changes gravity: without a price it is used to steer the liquid
        run += sym.k_z / 2 * acc[2] ** 2
    if sym.spheres or sym.cylinders:
        _hard, soft = _obstacle_terms(x[lay.pos], sym.spheres, sym.cylinders)
        run += sym.k_b * sum(_smooth_barrier(v) for v in soft)
    return run


def _path_constraints(s: Structure, lay: StateLayout, x, u, f: ca.Function, sym) -> list[tuple[ca.SX, str]]:
    """Node constraints: obstacle clearance, the robot's norm limits, angular acceleration and jerk, robust copies."""
    out: list[tuple[ca.SX, str]] = []
    acc = x[lay.acc] if s.jerk_limited else u
    rl = sym.robot

    def add_norm(vec, limit):
        """|vec| <= limit as a scaled constraint: linear in 1-D, squared norm in 3-D."""
        out.append((vec / limit, "unit") if vec.numel() == 1 else (ca.sumsqr(vec) / limit**2, "norm"))

    ang_n, rate_n = lay.copies[0]
    if sym.spheres or sym.cylinders:
        out.append((ca.vertcat(*_obstacle_terms(x[lay.pos], sym.spheres, sym.cylinders)[0]), "clear"))
    if s.vel_norm:
        add_norm(x[lay.vel], rl[0])
    if s.acc_norm:
        add_norm(acc, rl[1])
    if s.rot_vel_norm:
        add_norm(x[rate_n], rl[2])
    if s.axis is None:  # the tilt from upright, acos(cos(phi) cos(theta)), is at most the norm of the two angles
        add_norm(x[ang_n], rl[5])
    if s.jerk_limited:
        xdot = f(x, u, sym.p)
        alpha = xdot[rate_n]  # depends on the state only here, so its time derivative is exact
        add_norm(alpha, rl[3])
        add_norm(ca.jtimes(alpha, x, xdot), rl[4])
    for ang_r, _ in lay.copies[1:]:
        out.append((x[ang_r] - x[ang_n], "robust"))
    return out


def build_problem(s: Structure) -> SegmentProblem:
    """The segment's optimal-control problem in CasADi SX symbols."""
    lay = StateLayout(s)
    sym = _symbols(s)
    x, u = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.n_pos)
    f = ca.Function("f", [x, u, sym.p], [_rhs(s, lay, x, u, sym.liquids)])
    clearance = None
    if sym.spheres or sym.cylinders:
        q = ca.SX.sym("q", 3)
        clearance = ca.Function("clear", [q, sym.p], [ca.vertcat(*_obstacle_terms(q, sym.spheres, sym.cylinders)[0])])
    return SegmentProblem(
        s, lay, x, u, sym.p, f, _running_cost(s, lay, x, u, sym), _path_constraints(s, lay, x, u, f, sym), clearance
    )


def tilt_rate_limit(limits: Limits, robot: RobotLimits) -> float:
    """The container's largest angular speed (rad/s): the move's tilt rate or the robot's rotation speed (at
    ROBOT_MARGIN), whichever is lower; a bound on the norm of the roll and pitch rates, as the 1 kHz check reads it."""
    return min(math.radians(limits.tilt_rate_max_deg_s), robot.rot_vel_rad_s * ROBOT_MARGIN)


def parameter_values(
    limits: Limits,
    robot: RobotLimits,
    solver: SolverSettings,
    liquid: SloshParams,
    robust: Sequence[float],
    obstacles: Sequence[Obstacle],
    inflate_m: float,
) -> list[float]:
    """Numeric p: liquid, weights, robot and tilt limits, robust factors, inflated obstacles (order of `_symbols`)."""
    robot_p = [
        robot.vel_m_s,
        robot.acc_m_s2,
        tilt_rate_limit(limits, robot),
        robot.rot_acc_rad_s2 * ROBOT_MARGIN,
        robot.rot_jerk_rad_s3 * ROBOT_MARGIN,
        math.radians(limits.tilt_max_deg),
    ]
    params = [
        liquid.l_m,
        liquid.damping_rate_1_s,
        solver.kappa_r,
        solver.kappa_j,
        solver.kappa_B,
        solver.kappa_z,
        *robot_p,
        *robust,
    ]
    for o in obstacles:
        if o.kind == "sphere":
            params += [*o.center, o.radius + inflate_m]
    for o in obstacles:
        if o.kind == "cylinder" and o.z_range is not None:  # a cylinder always has one (Obstacle checks)
            params += [*o.center[:2], o.z_range[0] - inflate_m, o.z_range[1] + inflate_m, o.radius + inflate_m]
    return params


def box_bounds(
    s: Structure, start, goal, limits: Limits, robot: RobotLimits
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State bounds (lo, hi) at every node, rest at start and goal (first and last row), and the input bound."""
    lay = StateLayout(s)
    ax = [s.axis] if s.axis is not None else [0, 1, 2]
    lo, hi = np.full((3, s.nx), -np.inf), np.full((3, s.nx), np.inf)  # rows: start, path, goal
    vmax = [min(limits.vel_max[i], robot.vel_m_s) for i in ax]
    amax = [min(limits.acc_max[i], robot.acc_m_s2) for i in ax]
    jmax = [min(limits.jerk_max[i], robot.jerk_m_s3) for i in ax]
    lo[:, lay.vel], hi[:, lay.vel] = -np.array(vmax), vmax
    if s.axis is None:
        lo[:, 2], hi[:, 2] = limits.z_range
    if s.jerk_limited:
        lo[:, lay.acc], hi[:, lay.acc] = -np.array(amax), amax
    tilt, rate = math.radians(limits.tilt_max_deg), tilt_rate_limit(limits, robot)
    ang_n, rate_n = lay.copies[0]
    lo[:, ang_n], hi[:, ang_n] = -tilt, tilt
    lo[:, rate_n], hi[:, rate_n] = -rate, rate
    for row, point in ((0, start), (2, goal)):  # at rest: position given, every other state zero
        rest = np.zeros(s.nx)
        rest[lay.pos] = [point[i] for i in ax]
        lo[row], hi[row] = rest, rest
    return lo, hi, np.array(jmax if s.jerk_limited else amax)


def constraint_bounds(kinds: np.ndarray, solver: SolverSettings) -> tuple[np.ndarray, np.ndarray]:
    """(lbg, ubg) for constraints of the given kinds."""
    inf, rob = np.inf, math.radians(solver.robust_max_rel_deg)
    lower = {"eq": 0.0, "clear": 0.0, "unit": -1.0, "norm": -inf, "robust": -rob}
    upper = {"eq": 0.0, "clear": inf, "unit": 1.0, "norm": 1.0, "robust": rob}
    return np.array([lower[k] for k in kinds]), np.array([upper[k] for k in kinds])
