"""Plan a time-optimal slosh-free move for a scenario: check feasibility, solve each segment, export, verify.

Waypoints split the move into rest-to-rest segments, independent problems that are solved (in worker
processes when there are several) and concatenated into one 1 kHz Trajectory. The result is checked
against the robot limits and, independently of the optimiser, by simulating the liquid (simulate.py).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.parallel import parallel_map
from sloshid.model.conventions import steady_tilt
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import (
    Trajectory,
)
from sloshid.planning.feasible import check_feasible  # kept importable here
from sloshid.planning.ocp import (
    OK_STATUSES,
    SegmentResult,
    Structure,
    get_solver,
    segment_axis,
    time_lower_bound,
)
from sloshid.planning.result import (  # the result lives in its own module; kept importable here
    VERIFY_AFTER_DEG,
    VERIFY_DURING_DEG,
    PlanResult,
    limit_usages,
    segment_of_samples,
)
from sloshid.planning.sampling import sample_segments
from sloshid.planning.scenario import (
    Obstacle,
    Scenario,
    SolverSettings,
    Vec3,
    body_clearance,
    check_robust_factors,
)
from sloshid.planning.transcription import equidistributed_mesh, graded_mesh, regrid

if TYPE_CHECKING:  # plan() returns it for an upright scenario; imported where it is planned
    from sloshid.planning.upright import UprightPlan

GUESS_MARGIN_M = 0.02
"""Initial-guess points inside an inflated obstacle are pushed this far outside it."""
CLEARANCE_RETRIES = 3
"""Re-solves with a grown obstacle margin when a 1 kHz sample dips into an obstacle between constraint points."""
MAX_OMEGA_H = 0.9
"""The graded grid's longest interval (estimated from the segment's time bound) stays below this many radians of
the liquid's oscillation: RK4 with two steps stays accurate there; coarser grids get less or no grading."""
NEAR_M = 0.1
"""A segment's problem includes the obstacles that come this close to its straight line (all, if the check fails)."""


def near_obstacles(scenario: Scenario, start: Sequence[float], goal: Sequence[float]) -> list[Obstacle]:
    """Obstacles within NEAR_M of the straight segment (the others cannot matter unless the path bulges far)."""
    line = np.linspace(start, goal, 64)
    return [o for o in scenario.obstacles if scenario.container_clearance(line, obstacles=[o]).min() < NEAR_M]


def _structure(
    scenario: Scenario,
    start: Sequence[float],
    goal: Sequence[float],
    obstacles: Sequence[Obstacle],
    n_robust: int,
    warm: bool,
) -> Structure:
    """The NLP shape for one segment; norm constraints only where the per-axis bounds do not imply them."""
    lim, robot, sv = scenario.limits, scenario.robot, scenario.solver
    axis = segment_axis(start, goal, len(obstacles))
    three = axis is None
    return Structure(
        axis=axis,
        jerk_limited=sv.jerk_limited,
        N=sv.N,
        rk4_steps=sv.rk4_steps,
        clearance_points=sv.clearance_points if obstacles else 0,
        n_spheres=sum(o.kind == "sphere" for o in obstacles),
        n_cylinders=sum(o.kind == "cylinder" for o in obstacles),
        n_robust=n_robust,
        vel_norm=three and float(np.linalg.norm(lim.vel_max)) > robot.vel_m_s,
        acc_norm=three and float(np.linalg.norm(lim.acc_max)) > robot.acc_m_s2,
        rot_vel_norm=three,  # the tilt rate is a bound on the angular speed, not on each angle's rate
        max_iter=sv.max_iter,
        tol=sv.tol,
        warm=warm,
    )


def _guess(
    s: Structure,
    scenario: Scenario,
    obstacles: Sequence[Obstacle],
    start: Sequence[float],
    goal: Sequence[float],
    T0: float,
    inflate_m: float,
    mesh: np.ndarray | None,
) -> np.ndarray:
    """Initial guess: a minimum-jerk straight line pushed out of obstacles, liquid at its quasi-static tilt."""
    N = s.N
    m = np.ones(N) if mesh is None else mesh
    tau = (np.concatenate([[0.0], np.cumsum(m)]) / N)[:, None]
    delta = np.subtract(goal, start)[None, :]
    pos = np.asarray(start)[None, :] + (10 * tau**3 - 15 * tau**4 + 6 * tau**5) * delta
    vel = (30 * tau**2 - 60 * tau**3 + 30 * tau**4) * delta / T0
    acc = (60 * tau - 180 * tau**2 + 120 * tau**3) * delta / T0**2
    jerk = (60 - 360 * tau + 360 * tau**2) * delta / T0**3
    for o in obstacles:  # bend the line around each obstacle it enters: a smooth sideways bump
        clear = o.clearance(pos, inflate_m + GUESS_MARGIN_M)
        if clear.min() >= 0:
            continue
        k = int(np.argmin(clear))
        center = np.array([*o.center[:2], o.center[2] if o.kind == "sphere" else pos[k, 2]])
        unit = delta[0] / np.linalg.norm(delta[0])
        side = pos[k] - center
        side -= side.dot(unit) * unit  # perpendicular to the move
        if o.kind == "cylinder":
            side[2] = 0.0
        if np.linalg.norm(side) < 1e-6:  # straight through the centre: go around horizontally
            side = np.cross(unit, [0.0, 0.0, 1.0])
            side = side if np.linalg.norm(side) > 1e-9 else np.array([1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        need = o.radius + inflate_m + GUESS_MARGIN_M - (pos[k] - center).dot(side)
        bump = np.sin(np.pi * tau[:, 0]) ** 2
        pos += np.outer(bump / max(bump[k], 0.3), side) * need
    ax = [s.axis] if s.axis is not None else [0, 1, 2]
    tilt = math.radians(scenario.limits.tilt_max_deg) * 0.9
    # the guess tilts at the steady angle of the horizontal acceleration (1-D: the angle that tilts toward +u)
    if s.axis is not None:
        ang = np.clip(steady_tilt(acc[:, ax], 0.0)[1], -tilt, tilt)
    else:  # scaled into the bound on the norm of the two angles (the tilt from upright), not clipped per angle
        ang = np.column_stack(steady_tilt(acc[:, 0], acc[:, 1]))
        ang *= np.minimum(1.0, tilt / np.maximum(np.linalg.norm(ang, axis=1), 1e-12))[:, None]
    cols = [pos[:, ax], vel[:, ax]] + ([acc[:, ax]] if s.jerk_limited else [])
    cols += [ang, np.zeros_like(ang)] * (1 + s.n_robust)
    mid = (jerk[:-1] + jerk[1:]) / 2 if s.jerk_limited else (acc[:-1] + acc[1:]) / 2
    return get_solver(s).join(T0, np.column_stack(cols), mid[:, ax])


def _grading(sv: SolverSettings, params: SloshParams, robust: Sequence[float], t_lb: float) -> float:
    """[solver].grid_grading, reduced so that no interval grows beyond MAX_OMEGA_H / omega (RK4's accuracy)."""
    omega = params.omega_rad_s * max([1.0, *robust])
    return float(np.clip(MAX_OMEGA_H * sv.N / (omega * t_lb) - 1.0, 0.0, sv.grid_grading))


def solve_segment(
    scenario: Scenario,
    params: SloshParams,
    index: int,
    robust: Sequence[float] = (),
    extra_margin_m: float = 0.0,
    warm: SegmentResult | None = None,
    all_obstacles: bool = False,
) -> SegmentResult:
    """Solve the rest-to-rest segment from waypoint `index` to `index + 1` (cached solver, optional warm start).

    Only obstacles near the straight segment enter the problem unless `all_obstacles`."""
    start, goal = scenario.waypoints[index], scenario.waypoints[index + 1]
    obstacles = scenario.obstacles if all_obstacles else near_obstacles(scenario, start, goal)
    inflate = scenario.container_radius_m + scenario.solver.clearance_margin_m + extra_margin_m
    prev = warm if warm is not None and warm.warm else None  # the solve warm-started from (None: cold)
    s = _structure(scenario, start, goal, obstacles, len(robust), prev is not None)
    solver = get_solver(s)
    # a start from a problem of another shape (grid, or obstacle set: a clearance retry takes in every obstacle) is
    # no start: its variables or multipliers do not fit this one's
    if prev is not None and not solver.fits(prev.warm, scenario.solver):
        prev, s = None, _structure(scenario, start, goal, obstacles, len(robust), False)
        solver = get_solver(s)
    t_lb = time_lower_bound(start, goal, scenario.limits, scenario.solver.kappa_T)
    T_bounds = (t_lb, scenario.limits.t_max_s)
    sv = scenario.solver
    if prev is not None:
        mesh = prev.mesh
    else:
        mesh = None if sv.grid == "uniform" else graded_mesh(s.N, _grading(sv, params, robust, t_lb))
    guess = (
        prev.warm["x"]
        if prev is not None
        else _guess(s, scenario, obstacles, start, goal, min(1.15 * t_lb, T_bounds[1]), inflate, mesh)
    )
    fixed = (np.asarray(start), np.asarray(goal), scenario.limits, scenario.robot, sv, params, robust, obstacles)
    status, iters, elapsed, w, warm_out = solver.solve(
        *fixed, inflate, T_bounds, guess, prev.warm if prev is not None else None, mesh
    )
    T, X, U = solver.split(w)
    ends = (cast(Vec3, tuple(start)), cast(Vec3, tuple(goal)))
    seg = SegmentResult(index, *ends, s.axis, s.jerk_limited, T, status, iters, elapsed, X, U, warm_out, mesh)
    if sv.grid == "refined" and prev is None and seg.success:  # once more on a grid fitted to this optimum
        seg = _refine(seg, solver, (*fixed, inflate, T_bounds))
    return seg


def _refine(seg: SegmentResult, solver, fixed: tuple) -> SegmentResult:
    """Re-solve on a grid that equidistributes the first optimum's input, started from it moved onto that grid."""
    N = len(seg.u)
    fine = equidistributed_mesh(seg.t_nodes, seg.u)
    X, U = regrid(seg.t_nodes, seg.x_nodes, seg.u, np.concatenate([[0.0], np.cumsum(fine)]) * seg.T_s / N)
    status, iters, elapsed, w, warm = solver.solve(*fixed, solver.join(seg.T_s, X, U), None, fine)
    if status not in OK_STATUSES:
        return seg
    T, X, U = solver.split(w)
    return dataclasses.replace(
        seg,
        T_s=T,
        status=status,
        iterations=seg.iterations + iters,
        solve_time_s=seg.solve_time_s + elapsed,
        x_nodes=X,
        u=U,
        warm=warm,
        mesh=fine,
        coarse_T_s=seg.T_s,
    )


def _advice(status: str) -> str:
    """What to relax for an IPOPT failure status."""
    if "Infeasible" in status:
        return (
            "relax [limits] (acc_max, jerk_max, tilt_max_deg, tilt_rate_max_deg_s, t_max_s, z_range), "
            "the [robot] limits, or move waypoints away from obstacles"
        )
    if "Maximum_Iterations" in status or "CPUtime" in status:
        return "raise [solver].max_iter, lower [solver].N or loosen [solver].tol"
    return "relax [limits] or loosen [solver].tol, or lower [solver].kappa_B"


def _solve_all(
    scenario: Scenario,
    params: SloshParams,
    robust: tuple[float, ...],
    margins: list[float],
    which: list[int],
    warm: list[SegmentResult] | None,
    progress: bool,
    full: set[int],
) -> dict[int, SegmentResult]:
    """Solve the listed segments, in two worker processes when there are at least three and parallel is on."""
    jobs = [(scenario, params, i, robust, margins[i], warm[i] if warm else None, i in full) for i in which]
    workers = 2 if scenario.solver.parallel and len(jobs) >= 3 else 1
    solved = parallel_map(solve_segment, jobs, workers, progress=progress, desc="segments")
    return {seg.index: seg for seg in solved}


def plan(
    scenario: Scenario,
    params: SloshParams,
    *,
    robust_omega_factors: Sequence[float] | None = None,
    progress: bool = False,
    warm_from: PlanResult | None = None,
) -> PlanResult | UprightPlan:
    """Solve the scenario's move for liquid `params`; raises UserError for infeasible requests and solver failures.

    robust_omega_factors: natural-frequency factors of extra pendulum copies (same zeta, same acceleration)
    that must also end at rest and stay within [solver].robust_max_rel_deg of the container (robust variant);
    None takes [solver].robust_omega_factors. warm_from: a previous result of the same scenario shape to
    warm-start IPOPT from.

    The solver holds the limits at its grid points; between them a move riding a bound passes it (a 1 deg tilt
    limit by 8 %). A free move that does is solved again with the passed limits lowered by LIMIT_SAFETY * limit /
    peak (at most LIMIT_TRIES times, only for overshoots up to LIMIT_GRID_OVERSHOOT, and kept only while the peak falls
    and every limit the last plan held still holds; a lowered limit that cannot be solved keeps the last plan), and
    always checked against the scenario's own limits
    (`PlanResult.tightened` says what the solver was given).
    """
    if scenario.limits.upright:  # no tilt: the fastest move within the spill margin (an UprightPlan)
        from sloshid.planning.upright import plan_upright

        return plan_upright(scenario, params)
    if scenario.path is not None:
        from sloshid.planning.path_planner import plan_path

        return plan_path(scenario, params, progress=progress)
    result = _plan_free(scenario, params, robust_omega_factors, progress, warm_from)
    solver_scenario, worst = scenario, _worst_overshoot(result)
    for _ in range(LIMIT_TRIES):
        if not 1.0 < worst <= LIMIT_GRID_OVERSHOOT:
            break
        solver_scenario = _tightened(solver_scenario, result)
        try:
            again = _plan_free(solver_scenario, params, robust_omega_factors, progress, result)
        except UserError:  # the lowered limits are infeasible (t_max_s) or do not solve: the last plan stands
            break
        usages, move = limit_usages(again.trajectory, scenario)  # judged by the user's limits, not the lowered ones
        again = dataclasses.replace(
            again,
            limits=usages,
            move_limits=move,
            limits_ok=all(u.ok for u in usages + move),
            scenario=scenario,
            tightened=_ratios(solver_scenario, scenario),
            solve_time_s=again.solve_time_s + result.solve_time_s,
            wall_time_s=again.wall_time_s + result.wall_time_s,
        )
        held = {u.quantity for u in result.limits + result.move_limits if u.ok}
        newly = [u for u in again.limits + again.move_limits if u.quantity in held and not u.ok]
        # the peak must fall, and no limit the last plan held may give (lowering vel_max pushed rot_acc past the robot's)
        if newly or _worst_overshoot(again) >= worst:
            break
        result, worst = again, _worst_overshoot(again)
    return result


LIMIT_TRIES = 3
"""Re-plans with lowered limits when the 1 kHz trajectory passes a limit between the solver's grid points."""
LIMIT_GRID_OVERSHOOT = 1.5
"""A limit passed by more than this share is not one the solver holds (the seed's piecewise-constant acceleration jumps,
so its angular jerk is unbounded): no re-plan."""
LIMIT_SAFETY = 0.995
"""Share of limit / peak a passed limit is lowered to for the next solve."""


def _worst_overshoot(result: PlanResult) -> float:
    """Largest peak / limit of the limits the trajectory passes (1.0 when it passes none)."""
    return max([u.peak / u.limit for u in result.limits + result.move_limits if not u.ok], default=1.0)


def _tightened(scenario: Scenario, result: PlanResult) -> Scenario:
    """The scenario with every limit the result passed lowered to LIMIT_SAFETY * limit / peak of its current value
    (robot limits by their field, [limits] per key: every axis of a per-axis one)."""
    robot = {
        u.quantity: getattr(scenario.robot, u.quantity) * LIMIT_SAFETY * u.limit / u.peak
        for u in result.limits
        if not u.ok
    }
    limits: dict[str, Any] = {}  # [limits] values of several types (per-axis tuples, numbers)
    for u in result.move_limits:
        if not u.ok:
            value, factor = getattr(scenario.limits, u.quantity), LIMIT_SAFETY * u.limit / u.peak
            limits[u.quantity] = tuple(v * factor for v in value) if isinstance(value, tuple) else value * factor
    return dataclasses.replace(
        scenario,
        robot=dataclasses.replace(scenario.robot, **robot),
        limits=dataclasses.replace(scenario.limits, **limits),
    )


def _ratios(solver: Scenario, user: Scenario) -> dict[str, float]:
    """The limits the solver was given as shares of the user's, for those that differ (`[limits].key` or `robot.key`)."""
    out = {}
    for table, a, b in (("[limits]", solver.limits, user.limits), ("robot", solver.robot, user.robot)):
        for f in dataclasses.fields(b):
            mine, theirs = np.atleast_1d(getattr(a, f.name)), np.atleast_1d(getattr(b, f.name))
            if not np.array_equal(mine, theirs):
                out[f"{table}.{f.name}"] = float(np.min(mine / theirs))
    return out


def _plan_free(
    scenario: Scenario,
    params: SloshParams,
    robust_omega_factors: Sequence[float] | None,
    progress: bool,
    warm_from: PlanResult | None,
) -> PlanResult:
    """One solve of a free move (waypoints, obstacles) at the scenario's limits, with the clearance retries."""
    t_wall = time.perf_counter()
    check_feasible(scenario)
    factors = scenario.solver.robust_omega_factors if robust_omega_factors is None else robust_omega_factors
    check_robust_factors(factors, "robust_omega_factors")  # a NaN was dropped by the filter below: a nominal plan
    robust = tuple(float(f) for f in factors if abs(f - 1.0) > 1e-9)
    n_seg = len(scenario.waypoints) - 1
    margins = [0.0] * n_seg
    warm = warm_from.segments if warm_from is not None and len(warm_from.segments) == n_seg else None
    full: set[int] = set()  # segments solved with every obstacle, not only the near ones
    segs = _solve_all(scenario, params, robust, margins, list(range(n_seg)), warm, progress, full)
    for attempt in range(CLEARANCE_RETRIES + 1):
        bad = [s for s in segs.values() if not s.success]
        if bad:
            s = bad[0]
            raise UserError(
                f"the solver did not converge on segment {s.index + 1} ({list(s.start)} -> {list(s.goal)}): "
                f"IPOPT status {s.status} after {s.iterations} iterations; {_advice(s.status)}."
            )
        ordered = [segs[i] for i in range(n_seg)]
        traj = sample_segments(ordered, params)
        clearance, seg_of_sample = _clearance(scenario, ordered, traj)
        dipped = sorted({int(seg_of_sample[i]) for i in np.nonzero(clearance < 0)[0]})
        if not dipped:
            break
        if attempt == CLEARANCE_RETRIES:
            if scenario.container_depth_m:  # the body is kept clear by these retries alone, not by constraints
                raise UserError(
                    f"segment {dipped[0] + 1}: the container's body ([container].depth_m) still enters an obstacle by "
                    f"{-clearance.min() * 1e3:.2f} mm after {CLEARANCE_RETRIES} solves with it grown; add a waypoint "
                    "that leads around it, or raise the path."
                )
            raise UserError(
                f"segment {dipped[0] + 1} still enters an inflated obstacle by {-clearance.min() * 1e3:.2f} mm between "
                "constraint points; raise [solver].clearance_points or [solver].N."
            )
        for i in dipped:
            if i in full or scenario.container_depth_m:
                margins[i] = _grown_margin(scenario, traj, clearance, seg_of_sample == i, margins[i])
            full.add(i)
        segs.update(_solve_all(scenario, params, robust, margins, dipped, None, progress, full))
    return _assemble(scenario, params, ordered, traj, clearance, robust, t_wall)


def _grown_margin(
    scenario: Scenario, traj: Trajectory, clearance: np.ndarray, mine: np.ndarray, margin: float
) -> float:
    """A segment's obstacle margin for its next solve, from its samples' clearance (`mine`: its samples): the deepest
    dip and a millimetre more. A container's body ([container].depth_m) dips where its surface's centre, which the
    constraints keep clear, may still have room: the margin then also takes in that room, else it would grow without
    the constraint ever pushing the centre (a sphere 10 cm below a move, 3 cm into the body, was never left)."""
    worst = int(np.flatnonzero(mine)[np.argmin(clearance[mine])])
    grown = margin - float(clearance[worst]) + 1e-3
    if not scenario.container_depth_m:
        return grown
    centre = body_clearance(scenario.obstacles, traj.pos_m[worst], scenario.container_radius_m)
    room = float(centre) - scenario.solver.clearance_margin_m - margin  # beyond what the constraint keeps
    return grown + max(0.0, room)


def _assemble(scenario, params, ordered, traj, clearance, robust, t_wall: float) -> PlanResult:
    """The PlanResult of solved segments: limits checked and the liquid verified on the 1 kHz trajectory."""
    usages, move = limit_usages(traj, scenario)
    verification = simulate_liquid(traj, params)
    return PlanResult(
        trajectory=traj,
        T_s=float(sum(s.T_s for s in ordered)),
        status=ordered[0].status if len({s.status for s in ordered}) == 1 else "; ".join(s.status for s in ordered),
        solve_time_s=float(sum(s.solve_time_s for s in ordered)),
        iterations=int(sum(s.iterations for s in ordered)),
        segments=ordered,
        limits=usages,
        limits_ok=all(u.ok for u in usages + move),
        verification=verification,
        params=params,
        robust_omega_factors=robust,
        min_clearance_m=float(clearance.min()) if scenario.obstacles else None,
        wall_time_s=time.perf_counter() - t_wall,
        scenario=scenario,
        move_limits=move,
    )


def _clearance(scenario: Scenario, segments: list[SegmentResult], traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Smallest clearance (m) of each 1 kHz sample to any inflated obstacle, and the segment of each sample."""
    seg_of = segment_of_samples(segments, len(traj.t_s))
    return scenario.container_clearance(traj.pos_m, traj.z_axis), seg_of


__all__ = [
    "VERIFY_AFTER_DEG",
    "VERIFY_DURING_DEG",
    "PlanResult",
    "check_feasible",
    "limit_usages",
    "plan",
    "segment_of_samples",
    "solve_segment",
]
