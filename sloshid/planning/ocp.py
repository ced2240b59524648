"""Solving one rest-to-rest segment: the problem (`problem.py`), its transcription (`transcription.py`), IPOPT.

`SegmentSolver` is built once per problem structure and cached; everything that changes between solves
(start, goal, limits, liquid, obstacles, weights, the grid's mesh) enters as bounds or parameters. This
module also holds the segment's result and the bounds on its duration that need no solver.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import casadi as ca
import numpy as np

from sloshid.core.parallel import solver_interruptible
from sloshid.model.pendulum import SloshParams
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.problem import (
    ROBOT_MARGIN,
    SegmentProblem,
    Structure,
    box_bounds,
    build_problem,
    constraint_bounds,
    parameter_values,
)
from sloshid.planning.scenario import Limits, Obstacle, SolverSettings
from sloshid.planning.transcription import MultipleShooting

OK_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


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
    mesh: np.ndarray | None = None
    """Relative interval lengths m_k (N, mean 1): interval k lasts m_k T / N; None is the uniform grid."""
    coarse_T_s: float | None = None
    """T of the uniform-grid solve that the refined grid was designed from (None: not refined)."""

    @property
    def t_nodes(self) -> np.ndarray:
        """Times of the N+1 nodes from the segment's start (s)."""
        n = len(self.u)
        m = np.ones(n) if self.mesh is None else np.asarray(self.mesh)
        return np.concatenate([[0.0], np.cumsum(m)]) * self.T_s / n

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


class SegmentSolver:
    """One IPOPT solver for a Structure: the problem, transcribed once; `solve` fills bounds and parameters."""

    def __init__(self, s: Structure) -> None:
        self.s = s
        self.problem: SegmentProblem = build_problem(s)
        self.lay = self.problem.lay
        self.rhs = self.problem.rhs
        """The model's right-hand side f(x, u, p) exactly as the NLP uses it (for tests and inspection)."""
        self.transcription = MultipleShooting(self.problem)
        self.kinds = self.transcription.kinds
        self.nlp = ca.nlpsol("segment", "ipopt", self.transcription.nlp, ipopt_options(s))

    def split(self, w: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Decision vector -> (T, X (N+1, nx), U (N, nu))."""
        return self.transcription.split(w)

    def join(self, T: float, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """(T, X, U) -> decision vector."""
        return self.transcription.join(T, X, U)

    parameters = staticmethod(parameter_values)

    def bounds(self, start, goal, limits: Limits, robot: RobotLimits, T_bounds: tuple[float, float]):
        """(lbx, ubx): box bounds on every node and input, rest at start and goal, T within T_bounds."""
        s = self.s
        lo3, hi3, ulim = box_bounds(s, start, goal, limits, robot)
        rows = np.r_[0, np.ones(s.N - 1, dtype=int), 2]
        lbx = self.join(T_bounds[0], lo3[rows], np.tile(-ulim, (s.N, 1)))
        ubx = self.join(T_bounds[1], hi3[rows], np.tile(ulim, (s.N, 1)))
        return lbx, ubx

    def fits(self, warm: dict, solver: SolverSettings) -> bool:
        """A warm start (`solve`'s warm-start data) has this problem's numbers of variables and constraints."""
        n_g = len(constraint_bounds(self.kinds, solver)[0])
        return len(warm["x"]) == len(warm["lam_x"]) == self.nlp.size1_in("x0") and len(warm["lam_g"]) == n_g

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
        mesh: np.ndarray | None = None,
    ) -> tuple[str, int, float, np.ndarray, dict]:
        """Run IPOPT; returns (status, iterations, wall time, optimal w, warm-start data)."""
        lbx, ubx = self.bounds(start, goal, limits, robot, T_bounds)
        lbg, ubg = constraint_bounds(self.kinds, solver)
        params = parameter_values(limits, robot, solver, liquid, robust, obstacles, inflate_m)
        mesh = np.ones(self.s.N) if mesh is None else np.asarray(mesh, dtype=float)
        args = dict(x0=guess, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=np.concatenate([params, mesh]))
        if warm:
            args.update(lam_x0=warm["lam_x"], lam_g0=warm["lam_g"])
        t0 = time.perf_counter()
        with solver_interruptible():
            sol = self.nlp(**args)
        elapsed = time.perf_counter() - t0
        stats = self.nlp.stats()
        w = np.asarray(sol["x"]).ravel()
        warm_out = {"x": w, "lam_x": np.asarray(sol["lam_x"]).ravel(), "lam_g": np.asarray(sol["lam_g"]).ravel()}
        return str(stats.get("return_status", "unknown")), int(stats.get("iter_count", 0)), elapsed, w, warm_out


class SolverStructure(Protocol):
    """What `ipopt_options` reads of a problem's structure (free segments, [path] moves and upright moves)."""

    @property
    def max_iter(self) -> int: ...

    @property
    def tol(self) -> float: ...

    @property
    def warm(self) -> bool: ...


def ipopt_options(s: SolverStructure) -> dict[str, str | int | float | bool]:
    """IPOPT settings: monotone barrier from a cold start; warm solvers are expanded to SX and start near mu = 0."""
    opts: dict[str, str | int | float | bool] = {
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
    return opts


_CACHE: dict[Structure, SegmentSolver] = {}


def get_solver(s: Structure) -> SegmentSolver:
    """The cached solver for a structure (built on first use: CasADi graph plus IPOPT interface)."""
    if s not in _CACHE:
        _CACHE[s] = SegmentSolver(s)
    return _CACHE[s]


__all__ = [
    "OK_STATUSES",
    "ROBOT_MARGIN",
    "SegmentResult",
    "SegmentSolver",
    "Structure",
    "bang_bang_time",
    "get_solver",
    "segment_axis",
    "time_lower_bound",
]
