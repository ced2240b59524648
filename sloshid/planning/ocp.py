"""The time-optimal slosh-free optimal-control problem of one rest-to-rest segment (seed eq. 8-10) in CasADi.

Direct multiple shooting with RK4 on a time-scaled grid (T is a decision variable), solved by IPOPT.
The liquid model is `sloshid.model.pendulum` (eq. 2 in 1-D, the reconstructed eq. 3 in 3-D); the container
follows the liquid's surface, so its orientation states ARE the pendulum angles. Two formulations:
jerk-limited (jerk is the input, acceleration a state; robot-ready) and the seed's piecewise-constant
acceleration. Solvers are built once per problem structure and cached; everything that changes between
solves (start, goal, limits, liquid, obstacles, weights) enters as bounds or parameters.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace

import casadi as ca
import numpy as np

from sloshid.model.pendulum import G, SloshParams, angle_accel, pendulum_rhs_3d
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.scenario import Limits, Obstacle, SolverSettings

OK_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
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


@dataclass
class SegmentResult:
    """The optimum of one rest-to-rest segment: node states and inputs on the shooting grid."""

    index: int
    start: tuple[float, float, float]
    goal: tuple[float, float, float]
    axis: int | None
    jerk_limited: bool
    T_s: float
    status: str
    iterations: int
    solve_time_s: float
    x_nodes: np.ndarray
    """States at the N+1 nodes, (N+1, nx), layout of `Structure`."""
    u: np.ndarray
    """Inputs on the N intervals (N, n_pos): jerk (m/s^3) or acceleration (m/s^2)."""
    warm: dict = field(default_factory=dict, repr=False)
    """x, lam_x, lam_g of the optimum, to warm-start a re-solve of the same structure."""

    @property
    def success(self) -> bool:
        """True when IPOPT reported a solution."""
        return self.status in OK_STATUSES

    @property
    def formulation(self) -> str:
        """'jerk' or 'acceleration'."""
        return "jerk" if self.jerk_limited else "acceleration"

    def _nominal(self, which: int) -> np.ndarray:
        """Nominal pendulum angles (which=0) or rates (which=1) at the nodes, by the Structure's state layout."""
        n_pos = 1 if self.axis is not None else 3
        n_ang = 1 if self.axis is not None else 2
        off = n_pos * (3 if self.jerk_limited else 2) + which * n_ang
        return self.x_nodes[:, off : off + n_ang]

    @property
    def angles(self) -> np.ndarray:
        """Container tilt at the nodes (rad): the 1-D angle, or phi and theta."""
        return self._nominal(0)

    @property
    def rates(self) -> np.ndarray:
        """Container tilt rates at the nodes (rad/s)."""
        return self._nominal(1)


def bang_bang_time(distance_m: float, acc_max: float, vel_max: float) -> float:
    """Minimum rest-to-rest time of a double integrator under |a| <= acc_max, |v| <= vel_max (no sloshing)."""
    if distance_m <= 0:
        return 0.0
    if distance_m <= vel_max**2 / acc_max:
        return 2.0 * math.sqrt(distance_m / acc_max)
    return distance_m / vel_max + vel_max / acc_max


def segment_axis(start: Sequence[float], goal: Sequence[float], n_obstacles: int) -> int | None:
    """The horizontal axis of a 1-D move (only x or only y changes, no obstacles), else None (3-D model)."""
    moving = [i for i in range(3) if abs(goal[i] - start[i]) > 1e-12]
    if n_obstacles == 0 and len(moving) == 1 and moving[0] in (0, 1):
        return moving[0]
    return None


def time_lower_bound(start: Sequence[float], goal: Sequence[float], limits: Limits, kappa_T: float) -> float:
    """Largest of the per-axis bang-bang times and seed eq. 8e (kappa_T * distance / |vel_max|)."""
    delta = np.abs(np.subtract(goal, start))
    per_axis = max(bang_bang_time(d, a, v) for d, a, v in zip(delta, limits.acc_max, limits.vel_max))
    return max(per_axis, kappa_T * float(np.linalg.norm(delta)) / float(np.linalg.norm(limits.vel_max)))


class _Layout:
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


def _pendulum_dd(s: Structure, ang, rate, acc, liquid) -> ca.SX:
    """Angular accelerations of one pendulum copy (seed eq. 2, or eq. 3 via model.pendulum_rhs_3d)."""
    if s.axis is not None:
        return angle_accel(ang[0], rate[0], acc[0], liquid, G, ca.sin, ca.cos)
    zero = ca.SX(0)
    o = [zero, zero, zero, ang[0], ang[1], zero, zero, zero, zero, rate[0], rate[1], zero]
    rhs = pendulum_rhs_3d(o, [acc[0], acc[1], acc[2]], liquid, ca.sin, ca.cos)
    return ca.vertcat(rhs[9], rhs[10])


def _rhs(s: Structure, lay: _Layout, x, u, liquids) -> ca.SX:
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


class SegmentSolver:
    """One CasADi/IPOPT solver for a Structure; `solve` fills bounds and parameters and runs it."""

    def __init__(self, s: Structure) -> None:
        self.s = s
        self.lay = lay = _Layout(s)
        nx, nu, N = s.nx, s.n_pos, s.N
        # parameters: l, d/m, kappa_r, kappa_j, kappa_B, kappa_z, robot limits, robust factors, obstacles
        l_p, c_p, k_r, k_j, k_b, k_z = (ca.SX.sym(n) for n in ("l", "c", "kr", "kj", "kb", "kz"))
        factors = ca.SX.sym("f", s.n_robust)
        sph = ca.SX.sym("sph", 4 * s.n_spheres)
        cyl = ca.SX.sym("cyl", 5 * s.n_cylinders)
        spheres = [sph[4 * i : 4 * i + 4] for i in range(s.n_spheres)]
        cylinders = [cyl[5 * i : 5 * i + 5] for i in range(s.n_cylinders)]
        # robot limits (vel, acc, rot_vel, rot_acc, rot_jerk) normalise the norm constraints to O(1)
        rl = ca.SX.sym("robot", 5)
        P = ca.vertcat(l_p, c_p, k_r, k_j, k_b, k_z, rl, factors, sph, cyl)
        # a robust copy with omega*f and the same zeta has l/f^2 and damping rate c*f
        liquids = [SimpleNamespace(l_m=l_p, damping_rate_1_s=c_p)]
        liquids += [
            SimpleNamespace(l_m=l_p / factors[i] ** 2, damping_rate_1_s=c_p * factors[i]) for i in range(s.n_robust)
        ]

        # one shooting interval, built once in SX and mapped over the grid (fast construction and evaluation)
        x, u, h = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("h")
        f = ca.Function("f", [x, u, P], [_rhs(s, lay, x, u, liquids)])
        self.rhs = f
        """The model's right-hand side f(x, u, p) exactly as the NLP uses it (for tests and inspection)."""
        hs = h / s.rk4_steps
        xe = x
        for _ in range(s.rk4_steps):
            k1 = f(xe, u, P)
            k2 = f(xe + hs / 2 * k1, u, P)
            k3 = f(xe + hs / 2 * k2, u, P)
            k4 = f(xe + hs * k3, u, P)
            xe = xe + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        acc = x[lay.acc] if s.jerk_limited else u
        run = k_r / 2 * ca.sumsqr(acc) + (k_j / 2 * ca.sumsqr(u) if s.jerk_limited else 0)
        if s.axis is None:  # vertical acceleration changes gravity: without a price it is used to steer the liquid
            run += k_z / 2 * acc[2] ** 2
        sub, sub_kinds = [], []
        if spheres or cylinders:
            _hard, soft = _obstacle_terms(x[lay.pos], spheres, cylinders)
            run += k_b * sum(_smooth_barrier(v) for v in soft)
            for i in range(1, s.clearance_points + 1):  # exact positions between the nodes
                tau = h * i / (s.clearance_points + 1)
                pt = x[lay.pos] + x[lay.vel] * tau + acc * tau**2 / 2 + (u * tau**3 / 6 if s.jerk_limited else 0)
                sub += _obstacle_terms(pt, spheres, cylinders)[0]
                sub_kinds += ["clear"] * (s.n_spheres + s.n_cylinders)
        interval = ca.Function("interval", [x, u, h, P], [xe, h * run, ca.vertcat(*sub)])

        node, node_kinds = [], []

        def add(expr, kind):
            node.append(expr)
            node_kinds.extend([kind] * expr.numel())

        def add_norm(vec, limit):
            """|vec| <= limit as a scaled constraint: linear in 1-D, squared norm in 3-D."""
            if vec.numel() == 1:
                add(vec / limit, "unit")
            else:
                add(ca.sumsqr(vec) / limit**2, "norm")

        ang_n, rate_n = lay.copies[0]
        if spheres or cylinders:
            add(ca.vertcat(*_obstacle_terms(x[lay.pos], spheres, cylinders)[0]), "clear")
        if s.vel_norm:
            add_norm(x[lay.vel], rl[0])
        if s.acc_norm:
            add_norm(acc, rl[1])
        if s.rot_vel_norm:
            add_norm(x[rate_n], rl[2])
        if s.jerk_limited:
            xdot = f(x, u, P)
            alpha = xdot[rate_n]  # depends on the state only here, so its time derivative is exact
            add_norm(alpha, rl[3])
            add_norm(ca.jtimes(alpha, x, xdot), rl[4])
        for ang_r, _ in lay.copies[1:]:
            add(x[ang_r] - x[ang_n], "robust")
        node_fn = ca.Function("node", [x, u, P], [ca.vertcat(*node)])

        # the interval length h is carried as an extra, constant state: every interval then depends on its own
        # node only, which keeps the exact Hessian block-diagonal (cheap to colour and evaluate)
        X = ca.MX.sym("X", nx + 1, N + 1)
        U = ca.MX.sym("U", nu, N)
        Pm = ca.MX.sym("P", P.numel())
        x_next, cost_k, sub_g = interval.map(N)(X[:nx, :N], U, X[nx, :N], Pm)
        g = [ca.vec(x_next - X[:nx, 1:]), ca.vec(X[nx, 1:] - X[nx, :N])]
        kinds = ["eq"] * (nx * N + N)
        if node:
            g.append(ca.vec(node_fn.map(N + 1)(X[:nx, :], ca.horzcat(U, U[:, N - 1]), Pm)))
            kinds += node_kinds * (N + 1)
        if sub:
            g.append(ca.vec(sub_g))
            kinds += sub_kinds * N
        w = ca.vertcat(ca.vec(X), ca.vec(U))
        opts = {
            "ipopt.print_level": 0,
            "print_time": False,
            "ipopt.sb": "yes",
            "ipopt.max_iter": s.max_iter,
            "ipopt.tol": s.tol,
            "ipopt.mu_strategy": "monotone",
            "ipopt.mu_init": 1e-3,
        }
        if s.warm:  # re-solves: expand to SX (slower to build once, about twice as fast per iteration)
            opts.update(
                {
                    "expand": True,
                    "ipopt.warm_start_init_point": "yes",
                    "ipopt.mu_init": 1e-5,
                    "ipopt.mu_strategy": "adaptive",
                    "ipopt.warm_start_bound_push": 1e-6,
                    "ipopt.warm_start_mult_bound_push": 1e-6,
                }
            )
        nlp = {"x": w, "f": N * X[nx, 0] + ca.sum2(cost_k), "g": ca.vertcat(*g), "p": Pm}
        self.nlp = ca.nlpsol("segment", "ipopt", nlp, opts)
        self.kinds = np.array(kinds)

    def split(self, w: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Decision vector -> (T, X (N+1, nx), U (N, nu))."""
        s = self.s
        nX = (s.nx + 1) * (s.N + 1)
        X = w[:nX].reshape(s.N + 1, s.nx + 1)
        U = w[nX:].reshape(s.N, s.n_pos)
        return float(X[0, -1] * s.N), X[:, :-1], U

    def join(self, T: float, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """(T, X, U) -> decision vector (CasADi vec is column-major, i.e. node after node, h last)."""
        Xa = np.column_stack([X, np.full(len(X), T / self.s.N)])
        return np.concatenate([Xa.ravel(), U.ravel()])

    @staticmethod
    def parameters(
        robot: RobotLimits,
        solver: SolverSettings,
        liquid: SloshParams,
        robust: Sequence[float],
        obstacles: Sequence[Obstacle],
        inflate_m: float,
    ) -> list[float]:
        """The NLP parameter vector p: liquid, weights, robot limits, robust factors, inflated obstacles."""
        robot_p = [
            robot.vel_m_s,
            robot.acc_m_s2,
            robot.rot_vel_rad_s * ROBOT_MARGIN,
            robot.rot_acc_rad_s2 * ROBOT_MARGIN,
            robot.rot_jerk_rad_s3 * ROBOT_MARGIN,
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
            if o.kind == "cylinder":
                params += [*o.center[:2], o.z_range[0] - inflate_m, o.z_range[1] + inflate_m, o.radius + inflate_m]
        return params

    def solve(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        limits: Limits,
        robot: RobotLimits,
        solver: SolverSettings,
        liquid: SloshParams,
        robust: Sequence[float],
        obstacles: Sequence[Obstacle],
        inflate_m: float,
        T_bounds: tuple[float, float],
        guess: np.ndarray,
        warm: dict | None = None,
    ) -> tuple[str, int, float, np.ndarray, dict]:
        """Run IPOPT; returns (status, iterations, wall time, optimal w, warm-start data)."""
        s, lay = self.s, self.lay
        ax = [s.axis] if s.axis is not None else [0, 1, 2]
        inf = np.inf
        lo = np.full((s.N + 1, s.nx), -inf)
        hi = np.full((s.N + 1, s.nx), inf)
        vmax = [min(limits.vel_max[i], robot.vel_m_s) for i in ax]
        amax = [min(limits.acc_max[i], robot.acc_m_s2) for i in ax]
        jmax = [min(limits.jerk_max[i], robot.jerk_m_s3) for i in ax]
        lo[:, lay.vel], hi[:, lay.vel] = -np.array(vmax), vmax
        if s.axis is None:
            lo[:, 2], hi[:, 2] = limits.z_range
        if s.jerk_limited:
            lo[:, lay.acc], hi[:, lay.acc] = -np.array(amax), amax
        tilt = math.radians(limits.tilt_max_deg)
        rate = min(math.radians(limits.tilt_rate_max_deg_s), robot.rot_vel_rad_s * ROBOT_MARGIN)
        ang_n, rate_n = lay.copies[0]
        lo[:, ang_n], hi[:, ang_n] = -tilt, tilt
        lo[:, rate_n], hi[:, rate_n] = -rate, rate
        rest = np.zeros(s.nx)
        for point, node in ((start, 0), (goal, s.N)):
            rest[lay.pos] = [point[i] for i in ax]
            lo[node], hi[node] = rest, rest
        ulim = np.array(jmax if s.jerk_limited else amax)
        lbx = self.join(T_bounds[0], lo, np.tile(-ulim, (s.N, 1)))
        ubx = self.join(T_bounds[1], hi, np.tile(ulim, (s.N, 1)))
        ubg_of = {"eq": 0.0, "clear": inf, "unit": 1.0, "norm": 1.0, "robust": math.radians(solver.robust_max_rel_deg)}
        lbg_of = {
            "eq": 0.0,
            "clear": 0.0,
            "unit": -1.0,
            "norm": -inf,
            "robust": -math.radians(solver.robust_max_rel_deg),
        }
        ubg = np.array([ubg_of[k] for k in self.kinds])
        lbg = np.array([lbg_of[k] for k in self.kinds])
        params = self.parameters(robot, solver, liquid, robust, obstacles, inflate_m)
        args = dict(x0=guess, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=np.array(params, dtype=float))
        if warm:
            args.update(lam_x0=warm["lam_x"], lam_g0=warm["lam_g"])
        t0 = time.perf_counter()
        sol = self.nlp(**args)
        elapsed = time.perf_counter() - t0
        stats = self.nlp.stats()
        w = np.asarray(sol["x"]).ravel()
        warm_out = {"x": w, "lam_x": np.asarray(sol["lam_x"]).ravel(), "lam_g": np.asarray(sol["lam_g"]).ravel()}
        return str(stats.get("return_status", "unknown")), int(stats.get("iter_count", 0)), elapsed, w, warm_out


_CACHE: dict[Structure, SegmentSolver] = {}


def get_solver(s: Structure) -> SegmentSolver:
    """The cached solver for a structure (built on first use: CasADi graph plus IPOPT interface)."""
    if s not in _CACHE:
        _CACHE[s] = SegmentSolver(s)
    return _CACHE[s]
