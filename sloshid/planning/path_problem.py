"""The optimal-control problem along a prescribed path ([path]), stated in continuous time.

The container's reference point moves along the planning curve p(sigma) of `path.py`; the path parameter's
timing and the container's tilt are free. State (13): sigma, sigma', sigma'' (m, m/s, m/s^2); the liquid's
surface roll and pitch and their rates (the reconstructed seed eq. 3, driven by the container's acceleration
a = p''(sigma) sigma'^2 + p'(sigma) sigma''); the container's roll and pitch with their rates and angular
accelerations. Input (3): sigma''' and the container's two angular jerks (robot-ready: every commanded
quantity is continuous up to acceleration).

min T + integral of the regularisers, subject to the dynamics, the per-axis and norm limits on the Cartesian
velocity, acceleration and jerk, the container's tilt, angular rate, acceleration and jerk, sigma' >= 0,
|liquid - container| <= [limits].rel_angle_max_deg (times PATH_REL_MARGIN, imposed at the nodes) while moving,
and everything at rest, upright and settled at both ends (so the relative angle vanishes at the end).
The transcription is the same `MultipleShooting` as for free segments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import casadi as ca
import numpy as np

from sloshid.model.pendulum import SloshParams, pendulum_rhs_3d
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.path import PathGeometry
from sloshid.planning.problem import ROBOT_MARGIN, tilt_rate_limit
from sloshid.planning.scenario import Limits, SolverSettings

BETWEEN_POINTS = 3
"""Points inside every interval where the per-axis velocity and acceleration limits also hold (the curve bends
the acceleration between the nodes; nodes alone let it overshoot by about 2 %)."""
PATH_LIMIT_MARGIN = 0.985
"""Per-axis velocity and acceleration are imposed at this share: crossing a knot of the curve puts a kink in the
acceleration that can fall between the constraint points (measured overshoot 1.2 % without the margin)."""
PATH_REL_MARGIN = 0.8

"""The relative-angle bound is imposed at this share of [limits].rel_angle_max_deg (nodes only; 1 kHz is checked)."""
KAPPA_TILT = 1e-7
"""Weight of the container's angular-jerk regulariser (s^5/rad^2), as kappa_j for the path jerk."""
KAPPA_REL = 1e-3
"""Weight of (relative angle / bound)^2 (1/s): keeps the liquid with the container where time does not need it."""

# state layout
SIG, SD, SDD = 0, 1, 2
LIQ = slice(3, 5)
LIQ_RATE = slice(5, 7)
CON = slice(7, 9)
CON_RATE = slice(9, 11)
CON_ACC = slice(11, 13)
NX, NU = 13, 3


@dataclass(frozen=True)
class PathStructure:
    """What fixes the shape of a path NLP (one cached solver per value)."""

    N: int
    geometry_key: str
    """Content hash of the planning curve, which enters the problem as constants (as parameters, its ~100 values
    would ride along in every derivative of every interval and make IPOPT's iterations ~20x slower)."""
    rk4_steps: int
    max_iter: int = 1000
    tol: float = 1e-6
    warm: bool = False


@dataclass
class PathProblem:
    """Same interface as `problem.SegmentProblem` for the transcription (no obstacle terms: the path is checked)."""

    s: PathStructure
    x: ca.SX
    u: ca.SX
    p: ca.SX
    rhs: ca.Function
    running_cost: ca.SX
    path: list[tuple[ca.SX, str]]
    clearance: None = None
    geometry: ca.Function | None = None
    """sigma -> p(sigma) and its first three derivatives (the symbolic curve, for tests)."""
    lim: ca.SX | None = None
    """The limit parameters (vel box, acc box, ...), for the constraints inside the intervals."""

    def between(self, h: ca.SX) -> tuple[ca.SX, list[str]]:
        """Per-axis velocity and acceleration at BETWEEN_POINTS inside each interval (sigma exact under sigma''')."""
        x, u, out, kinds = self.x, self.u, [], []
        assert self.geometry is not None and self.lim is not None  # set by build_path_problem
        for i in range(1, BETWEEN_POINTS + 1):
            tau = h * i / (BETWEEN_POINTS + 1)
            sd = x[SD] + x[SDD] * tau + u[0] * tau**2 / 2
            sdd = x[SDD] + u[0] * tau
            sigma = x[SIG] + x[SD] * tau + x[SDD] * tau**2 / 2 + u[0] * tau**3 / 6
            _p0, p1, p2, _p3 = self.geometry(sigma)
            out += [p1 * sd / self.lim[0:3], (p2 * sd**2 + p1 * sdd) / self.lim[3:6]]
            kinds += ["unit"] * 6
        return ca.vertcat(*out), kinds


def _curve(sigma, poly, knots, jumps) -> tuple:
    """p, p', p'', p''' of the truncated-power cubic spline at sigma (3-vectors)."""
    d = ca.fmax(sigma - knots, 0)
    a0, a1, a2, a3 = (poly[3 * i : 3 * i + 3] for i in range(4))
    jt = jumps.T  # (3, K)
    step = ca.if_else(sigma > knots, 1, 0)
    p0 = a0 + a1 * sigma + a2 * sigma**2 + a3 * sigma**3 + ca.mtimes(jt, d**3)
    p1 = a1 + 2 * a2 * sigma + 3 * a3 * sigma**2 + 3 * ca.mtimes(jt, d**2)
    p2 = 2 * a2 + 6 * a3 * sigma + 6 * ca.mtimes(jt, d)
    p3 = 6 * a3 + 6 * ca.mtimes(jt, step)
    return p0, p1, p2, p3


def build_path_problem(s: PathStructure, geo: PathGeometry) -> PathProblem:
    """The path problem in CasADi SX symbols, the curve as constants; numbers enter through `path_parameters`."""
    x, u = ca.SX.sym("x", NX), ca.SX.sym("u", NU)
    liquid = ca.SX.sym("liquid", 2)  # l, d/m
    weights = ca.SX.sym("w", 2)  # kappa_r (path acceleration), kappa_j (path jerk)
    # vel box 3, acc box 3, jerk box 3, robot vel, acc, tilt rate, rot acc, rel max, tilt max
    lim = ca.SX.sym("lim", 15)
    poly, knots, jumps = ca.DM(geo.poly.ravel()), ca.DM(geo.knots), ca.DM(geo.jumps)
    p = ca.vertcat(liquid, weights, lim)
    sigma, sd, sdd = x[SIG], x[SD], x[SDD]
    _p0, p1, p2, p3 = _curve(sigma, poly, knots, jumps)
    acc = p2 * sd**2 + p1 * sdd
    jerk = p3 * sd**3 + 3 * p2 * sd * sdd + p1 * u[0]
    # the pendulum's two parameters as symbols, where SloshParams holds numbers
    fluid = cast(SloshParams, type("Liquid", (), {"l_m": liquid[0], "damping_rate_1_s": liquid[1]}))
    zero = ca.SX(0)
    o = [zero, zero, zero, x[3], x[4], zero, zero, zero, zero, x[5], x[6], zero]
    dd = pendulum_rhs_3d(o, [acc[0], acc[1], acc[2]], fluid, ca.sin, ca.cos)
    xdot = ca.vertcat(sd, sdd, u[0], x[LIQ_RATE], dd[9], dd[10], x[CON_RATE], x[CON_ACC], u[1], u[2])
    f = ca.Function("f", [x, u, p], [xdot])
    rel = x[LIQ] - x[CON]
    cost = weights[0] / 2 * sdd**2 + weights[1] / 2 * (u[0] ** 2) + KAPPA_TILT / 2 * ca.sumsqr(u[1:])
    cost += KAPPA_REL * ca.sumsqr(rel) / lim[13] ** 2
    path = [
        (p1 * sd / lim[0:3], "unit"),
        (acc / lim[3:6], "unit"),
        (jerk / lim[6:9], "unit"),
        (ca.sumsqr(p1 * sd) / lim[9] ** 2, "norm"),
        (ca.sumsqr(acc) / lim[10] ** 2, "norm"),
        (ca.sumsqr(x[CON_RATE]) / lim[11] ** 2, "norm"),
        (ca.sumsqr(x[CON_ACC]) / lim[12] ** 2, "norm"),
        (ca.sumsqr(rel) / lim[13] ** 2, "norm"),
        (ca.sumsqr(x[CON]) / lim[14] ** 2, "norm"),  # the tilt from upright (a bound on it), not each angle
    ]
    sig = ca.SX.sym("sigma")
    geometry = ca.Function("curve", [sig], list(_curve(sig, poly, knots, jumps)))
    return PathProblem(s, x, u, p, f, cost, path, None, geometry, lim)


def path_parameters(limits: Limits, robot: RobotLimits, solver: SolverSettings, liquid: SloshParams) -> np.ndarray:
    """Numeric p for `build_path_problem` (order of its symbols)."""
    vel = [min(v, robot.vel_m_s) * PATH_LIMIT_MARGIN for v in limits.vel_max]
    acc = [min(a, robot.acc_m_s2) * PATH_LIMIT_MARGIN for a in limits.acc_max]

    jerk = [min(j, robot.jerk_m_s3) for j in limits.jerk_max]
    rate = tilt_rate_limit(limits, robot)
    lim = [*vel, *acc, *jerk, robot.vel_m_s, robot.acc_m_s2, rate, robot.rot_acc_rad_s2 * ROBOT_MARGIN]
    lim += [math.radians(limits.rel_angle_max_deg) * PATH_REL_MARGIN, math.radians(limits.tilt_max_deg)]
    return np.array([liquid.l_m, liquid.damping_rate_1_s, solver.kappa_r, solver.kappa_j, *lim])


def path_box_bounds(geo: PathGeometry, limits: Limits, robot: RobotLimits) -> tuple[np.ndarray, ...]:
    """State bounds at start, along the path and at the end (3 rows each of lo, hi), and the input bound."""
    lo, hi = np.full((3, NX), -np.inf), np.full((3, NX), np.inf)
    lo[1, SIG], hi[1, SIG] = 0.0, geo.length_m
    lo[1, SD] = 0.0
    tilt = math.radians(limits.tilt_max_deg)
    lo[1, CON], hi[1, CON] = -tilt, tilt
    lo[1, LIQ], hi[1, LIQ] = -tilt - 0.2, tilt + 0.2
    for row, sigma in ((0, 0.0), (2, geo.length_m)):  # at rest, upright, liquid settled
        lo[row], hi[row] = 0.0, 0.0
        lo[row, SIG] = hi[row, SIG] = sigma
    rot_jerk = robot.rot_jerk_rad_s3 * ROBOT_MARGIN / math.sqrt(2)
    ulim = np.array([float(np.linalg.norm([min(j, robot.jerk_m_s3) for j in limits.jerk_max])), rot_jerk, rot_jerk])
    return lo, hi, ulim
