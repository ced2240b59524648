"""Plan the time-optimal slosh-free motion along a prescribed path: check, solve, sample at 1 kHz, verify.

The problem is `path_problem.py`, transcribed by the same multiple shooting (graded grid) as free segments and
solved by IPOPT. The 1 kHz trajectory is exact for the optimum: sigma(t) and the container's tilt are the
polynomials of their piecewise-constant jerks, the position is p(sigma(t)) on the planning curve, velocity
p' sigma', acceleration p'' sigma'^2 + p' sigma''. `max_path_deviation_m` is the distance of every 1 kHz
sample from the user's curve.
"""

from __future__ import annotations

import hashlib
import math
import time
from typing import cast

import casadi as ca
import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.parallel import solver_interruptible
from sloshid.model.conventions import G, steady_tilt
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import EXPORT_RATE_HZ, Trajectory
from sloshid.planning.ocp import OK_STATUSES, SegmentResult, bang_bang_time, ipopt_options
from sloshid.planning.path import PathGeometry
from sloshid.planning.path_problem import (
    CON,
    CON_ACC,
    CON_RATE,
    LIQ,
    NX,
    SD,
    SDD,
    SIG,
    PathProblem,
    PathStructure,
    build_path_problem,
    path_box_bounds,
    path_parameters,
)
from sloshid.planning.problem import constraint_bounds
from sloshid.planning.result import PlanResult, limit_usages
from sloshid.planning.scenario import Scenario, Vec3
from sloshid.planning.transcription import MultipleShooting, graded_mesh

VERIFY_AFTER_DEG = 0.05
"""Largest relative angle allowed after arrival (as for free moves)."""
PATH_N_PER_S = 45
"""Shooting intervals per second of the estimated move when [solver].N is smaller (the path's curvature
changes the acceleration along it, which a coarse grid cannot follow)."""

_CACHE: dict[PathStructure, tuple[ca.Function, MultipleShooting, PathProblem]] = {}


def _curve(scenario: Scenario) -> PathGeometry:
    """The planning curve of a [path] scenario (a ValueError for a scenario without one: there is no path to keep to)."""
    if scenario.path is None:
        raise ValueError("a [path] scenario is needed: this scenario has no path (Scenario.path is None).")
    return scenario.path


def _solver(s: PathStructure, geo: PathGeometry) -> tuple[ca.Function, MultipleShooting, PathProblem]:
    """(nlpsol, transcription, problem) for a structure and its curve, built once."""
    if s not in _CACHE:
        prob = build_path_problem(s, geo)
        ms = MultipleShooting(prob)
        opts = ipopt_options(s)
        _CACHE[s] = (ca.nlpsol("path", "ipopt", ms.nlp, opts), ms, prob)
    return _CACHE[s]


def check_path(scenario: Scenario) -> None:
    """Reject a path that leaves the z range or runs through an inflated obstacle (one sentence, UserError)."""
    geo, lim = _curve(scenario), scenario.limits
    sigma = np.linspace(0.0, geo.length_m, max(200, math.ceil(geo.length_m / 0.002)))
    pts = geo.evaluate(sigma)
    z = pts[:, 2]
    if z.min() < lim.z_range[0] or z.max() > lim.z_range[1]:
        i = int(np.argmin(z)) if z.min() < lim.z_range[0] else int(np.argmax(z))
        raise UserError(
            f"the path leaves [limits].z_range [{lim.z_range[0]:g}, {lim.z_range[1]:g}] m at "
            f"{np.round(pts[i], 4).tolist()} ({sigma[i]:.3f} m along it)."
        )
    R, depth = scenario.container_radius_m, scenario.container_depth_m
    body = f", and the upright body {depth:g} m below the surface's centre" if depth else ""
    for j, o in enumerate(scenario.obstacles):
        clear = scenario.container_clearance(pts, obstacles=[o])
        if clear.min() < 0:
            i = int(np.argmin(clear))
            raise UserError(
                f"the path runs through obstacle {j + 1} ({o.describe(R)}: container radius{body}) at "
                f"{np.round(pts[i], 4).tolist()}, {sigma[i]:.3f} m along it; sloshid keeps to the given path, "
                "so move the path or the obstacle."
            )


def _structure(scenario: Scenario, T_est: float) -> PathStructure:
    sv = scenario.solver
    N = max(sv.N, math.ceil(PATH_N_PER_S * T_est))
    geo = _curve(scenario)
    key = hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in (geo.poly, geo.knots, geo.jumps)))
    return PathStructure(N, key.hexdigest()[:16], sv.rk4_steps, sv.max_iter, sv.tol)


def _time_estimate(scenario: Scenario) -> tuple[float, float]:
    """(lower bound, initial guess) of T: bang-bang along the path's length under the norm of the box limits."""
    lim, L = scenario.limits, _curve(scenario).length_m
    acc = min(float(np.linalg.norm(lim.acc_max)), scenario.robot.acc_m_s2)
    vel = min(float(np.linalg.norm(lim.vel_max)), scenario.robot.vel_m_s)
    lower = bang_bang_time(L, acc, vel)
    # a min-jerk profile at the smallest axis limit, or at the acceleration whose quasi-static tilt is tilt_max_deg
    # (a guess that leans past the tilt limit kept IPOPT from converging on a 5 deg diagonal)
    usable = min(*lim.acc_max, G * math.tan(math.radians(lim.tilt_max_deg)))
    guess = max(lower * 1.2, math.sqrt(5.77 * L / usable))
    return lower, guess


def _guess(scenario: Scenario, ms: MultipleShooting, mesh: np.ndarray, T0: float) -> np.ndarray:
    """Minimum-jerk timing along the path, liquid and container at the quasi-static tilt of its acceleration."""
    geo, N = _curve(scenario), ms.N
    tau = np.concatenate([[0.0], np.cumsum(mesh)]) / N
    L = geo.length_m
    sig = L * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
    sd = L * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / T0
    sdd = L * (60 * tau - 180 * tau**2 + 120 * tau**3) / T0**2
    sddd = L * (60 - 360 * tau + 360 * tau**2) / T0**3
    acc = geo.evaluate(sig, 2) * sd[:, None] ** 2 + geo.evaluate(sig, 1) * sdd[:, None]
    tilt = np.column_stack(steady_tilt(acc[:, 0], acc[:, 1], acc[:, 2]))
    X = np.zeros((N + 1, NX))
    X[:, SIG], X[:, SD], X[:, SDD] = sig, sd, sdd
    X[:, LIQ] = X[:, CON] = tilt
    t = tau * T0
    X[:, CON_RATE] = np.gradient(tilt, t, axis=0)
    X[:, CON_ACC] = np.gradient(X[:, CON_RATE], t, axis=0)
    U = np.zeros((N, 3))
    U[:, 0] = (sddd[:-1] + sddd[1:]) / 2
    return ms.join(T0, X, U)


def _polynomial_samples(x0: np.ndarray, jerk: np.ndarray, t_nodes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Value, rate, acceleration of a chain of integrators under piecewise-constant jerk, at times t: (n, 3, m)."""
    n = len(jerk)
    hk = np.diff(t_nodes)
    nodes = np.zeros((n + 1, 3, x0.shape[-1]))
    nodes[0] = x0
    for i in range(n):  # exact propagation node to node
        p, v, a = nodes[i]
        h, j = hk[i], jerk[i]
        nodes[i + 1] = [p + v * h + a * h**2 / 2 + j * h**3 / 6, v + a * h + j * h**2 / 2, a + j * h]
    k = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, n - 1)
    tau = np.clip(t - t_nodes[k], 0.0, hk[k])[:, None]
    p, v, a = nodes[k, 0], nodes[k, 1], nodes[k, 2]
    j = jerk[k]
    out = np.stack([p + v * tau + a * tau**2 / 2 + j * tau**3 / 6, v + a * tau + j * tau**2 / 2, a + j * tau], axis=1)
    out[t >= t_nodes[-1]] = nodes[-1]
    return out


def sample_path(scenario: Scenario, T: float, X: np.ndarray, U: np.ndarray, mesh: np.ndarray) -> Trajectory:
    """The 1 kHz trajectory of an optimum (exact polynomials of its inputs, positions on the planning curve)."""
    geo, N = _curve(scenario), len(U)
    t_nodes = np.concatenate([[0.0], np.cumsum(mesh)]) * T / N
    dt = 1.0 / EXPORT_RATE_HZ
    t = np.arange(math.ceil(T / dt - 1e-9) + 1) * dt
    path = _polynomial_samples(np.zeros((3, 1)), U[:, :1], t_nodes, t)[:, :, 0]
    sig, sd, sdd = np.clip(path[:, 0], 0.0, geo.length_m), np.maximum(path[:, 1], 0.0), path[:, 2]
    p1, p2 = geo.evaluate(sig, 1), geo.evaluate(sig, 2)
    tilt = _polynomial_samples(np.zeros((3, 2)), U[:, 1:], t_nodes, t)
    euler = np.column_stack([tilt[:, 0], np.zeros(len(t))])
    rates = np.column_stack([tilt[:, 1], np.zeros(len(t))])
    acc = p2 * sd[:, None] ** 2 + p1 * sdd[:, None]
    return Trajectory(t, geo.evaluate(sig), p1 * sd[:, None], acc, euler, rates, name="sloshid plan (path)")


def _as_segment(
    scenario: Scenario,
    traj: Trajectory,
    T: float,
    status: str,
    iters: int,
    elapsed: float,
    mesh: np.ndarray,
    X: np.ndarray,
    U: np.ndarray,
) -> SegmentResult:
    """The optimum in the free planner's node layout (position, velocity, acceleration, tilt, tilt rate)."""
    idx = np.minimum(
        np.round(np.concatenate([[0.0], np.cumsum(mesh)]) * T / len(U) * EXPORT_RATE_HZ).astype(int), len(traj.t_s) - 1
    )
    nodes = np.column_stack([traj.pos_m[idx], traj.vel_m_s[idx], traj.acc_m_s2[idx], X[:, CON], X[:, CON_RATE]])
    jerk = np.diff(traj.acc_m_s2[idx], axis=0) / np.maximum(np.diff(traj.t_s[idx])[:, None], 1e-9)
    start, goal = (cast(Vec3, tuple(map(float, p))) for p in scenario.waypoints)
    return SegmentResult(0, start, goal, None, True, T, status, iters, elapsed, nodes, jerk, {}, mesh)


def plan_path(scenario: Scenario, params: SloshParams, *, progress: bool = False) -> PlanResult:
    """Solve the [path] scenario for liquid `params` (PlanResult); raises UserError for bad paths and failures."""
    t_wall = time.perf_counter()
    check_path(scenario)
    lower, T0 = _time_estimate(scenario)
    s = _structure(scenario, T0)
    nlp, ms, _prob = _solver(s, _curve(scenario))
    sv, lim = scenario.solver, scenario.limits
    grading = min(sv.grid_grading, max(0.0, 0.9 * s.N / (params.omega_rad_s * lower) - 1.0))
    mesh = np.ones(s.N) if sv.grid == "uniform" else graded_mesh(s.N, grading)
    lo, hi, ulim = path_box_bounds(_curve(scenario), lim, scenario.robot)
    rows = np.r_[0, np.ones(s.N - 1, dtype=int), 2]
    lbx = ms.join(lower, lo[rows], np.tile(-ulim, (s.N, 1)))
    ubx = ms.join(lim.t_max_s, hi[rows], np.tile(ulim, (s.N, 1)))
    lbg, ubg = constraint_bounds(ms.kinds, sv)
    p = np.concatenate([path_parameters(lim, scenario.robot, sv, params), mesh])
    t0 = time.perf_counter()
    with solver_interruptible():
        sol = nlp(x0=_guess(scenario, ms, mesh, T0), lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p)
    elapsed = time.perf_counter() - t0
    stats = nlp.stats()
    status, iters = str(stats.get("return_status", "unknown")), int(stats.get("iter_count", 0))
    if status not in OK_STATUSES:
        raise UserError(
            f"the solver did not converge along the path: IPOPT status {status} after {iters} iterations; relax "
            "[limits] (acc_max, jerk_max, tilt_max_deg, tilt_rate_max_deg_s, rel_angle_max_deg, t_max_s) or [solver].tol."
        )
    T, X, U = ms.split(np.asarray(sol["x"]).ravel())
    traj = sample_path(scenario, T, X, U, mesh)
    usages, move = limit_usages(traj, scenario)
    verification = simulate_liquid(traj, params)
    deviation = float(_curve(scenario).deviation(traj.pos_m).max())
    seg = _as_segment(scenario, traj, T, status, iters, elapsed, mesh, X, U)
    clearance = _clearance(scenario, traj)
    if clearance is not None and clearance < 0:  # the path was checked upright: the planned tilt swung the body in
        depth = scenario.container_depth_m
        what = f"tilted as the plan tilts it along the path (its body {depth:g} m deep)" if depth else "on the plan"
        raise UserError(
            f"the container, {what}, enters an obstacle by {-clearance * 1e3:.1f} mm; sloshid keeps to the given "
            "path (within [path].path_tolerance_m), so move the path or the obstacle"
            + (", or lower [limits].tilt_max_deg." if depth else ".")
        )
    table = scenario.path_table
    if table is None:
        raise ValueError(
            "a [path] scenario is needed: this scenario has no [path] table (Scenario.path_table is None)."
        )
    return PlanResult(
        trajectory=traj,
        T_s=T,
        status=status,
        solve_time_s=elapsed,
        iterations=iters,
        segments=[seg],
        limits=usages,
        limits_ok=all(u.ok for u in usages + move),
        verification=verification,
        params=params,
        min_clearance_m=clearance,
        wall_time_s=time.perf_counter() - t_wall,
        verify_during_deg=lim.rel_angle_max_deg,
        max_path_deviation_m=deviation,
        path_tolerance_m=table.path_tolerance_m,
        scenario=scenario,
        move_limits=move,
    )


def _clearance(scenario: Scenario, traj: Trajectory) -> float | None:
    """Smallest distance of a 1 kHz sample to an inflated obstacle (None without obstacles)."""
    if not scenario.obstacles:
        return None
    return float(scenario.container_clearance(traj.pos_m, traj.z_axis).min())


__all__ = ["check_path", "plan_path", "sample_path"]
