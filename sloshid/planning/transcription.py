"""Direct multiple shooting of a `SegmentProblem` on a time-scaled, possibly non-uniform grid.

How the continuous problem of `problem.py` becomes an NLP: N shooting intervals with a constant input each,
RK4 (a fixed number of steps per interval) for the dynamics, the running cost integrated with the same
interval length, path constraints at every node and the hard obstacle clearance also between the nodes.

The grid: interval k lasts h_k = m_k * T / N, where the mesh m (mean 1) is an NLP parameter, so a refined
grid (short intervals where the input switches) reuses the same solver. The mean interval T / N is carried
as an extra, constant state: every interval then depends on its own node only, which keeps the exact
Hessian block-diagonal (cheap to colour and evaluate).
"""

from __future__ import annotations

from typing import Protocol

import casadi as ca
import numpy as np

from sloshid.planning.problem import SegmentProblem


class ShootingStructure(Protocol):
    """What the transcription reads of a problem's structure (`problem.Structure`, `path_problem.PathStructure`,
    `upright.UprightStructure`)."""

    @property
    def N(self) -> int: ...

    @property
    def rk4_steps(self) -> int: ...


class ShootingProblem(Protocol):
    """The continuous-time problem `MultipleShooting` transcribes (`problem.SegmentProblem`,
    `path_problem.PathProblem`, `upright.UprightProblem`); only a `SegmentProblem` has a hard obstacle clearance, and
    a problem may add constraints inside the intervals with a `between(h)` method."""

    @property
    def s(self) -> ShootingStructure: ...

    @property
    def x(self) -> ca.SX: ...

    @property
    def u(self) -> ca.SX: ...

    @property
    def p(self) -> ca.SX: ...

    @property
    def rhs(self) -> ca.Function: ...

    @property
    def running_cost(self) -> ca.SX: ...

    @property
    def path(self) -> list[tuple[ca.SX, str]]: ...


def rk4(f: ca.Function, x, u, p, h, steps: int):
    """`steps` classical Runge-Kutta steps of length h / steps under a constant input."""
    hs = h / steps
    for _ in range(steps):
        k1 = f(x, u, p)
        k2 = f(x + hs / 2 * k1, u, p)
        k3 = f(x + hs / 2 * k2, u, p)
        k4 = f(x + hs * k3, u, p)
        x = x + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def interval_function(prob: ShootingProblem) -> tuple[ca.Function, list[str]]:
    """interval(x, u, h, p) -> (state at the end, cost over the interval, clearance between the nodes), kinds."""
    x, u, p = prob.x, prob.u, prob.p
    h = ca.SX.sym("h")
    sub: list[ca.SX] = []
    kinds: list[str] = []
    if isinstance(prob, SegmentProblem) and prob.clearance is not None:  # the others have no clearance (None)
        s = prob.s
        for i in range(1, s.clearance_points + 1):  # exact positions between the nodes
            sub.append(prob.clearance(prob.position_at(h * i / (s.clearance_points + 1)), p))
            kinds += ["clear"] * (s.n_spheres + s.n_cylinders)
    between = getattr(prob, "between", None)
    if between is not None:  # further constraints inside the interval (exact states under the constant input)
        expr, more = between(h)
        sub.append(expr)
        kinds += more
    x_end = rk4(prob.rhs, x, u, p, h, prob.s.rk4_steps)

    return ca.Function("interval", [x, u, h, p], [x_end, h * prob.running_cost, ca.vertcat(*sub)]), kinds


class MultipleShooting:
    """The NLP {x: w, f: T + sum of interval costs, g: continuity and path constraints, p: [p; mesh]}."""

    def __init__(self, prob: ShootingProblem) -> None:
        self.nx, self.nu, self.N = prob.x.numel(), prob.u.numel(), prob.s.N
        nx, N = self.nx, self.N
        interval, sub_kinds = interval_function(prob)
        node_expr = ca.vertcat(*(e for e, _ in prob.path))
        node_kinds = [k for e, k in prob.path for _ in range(e.numel())]
        node_fn = ca.Function("node", [prob.x, prob.u, prob.p], [node_expr])

        X = ca.MX.sym("X", nx + 1, N + 1)  # states and the mean interval length T/N at each node
        U = ca.MX.sym("U", self.nu, N)
        Pm = ca.MX.sym("P", prob.p.numel() + N)  # problem parameters, then the mesh m (N, mean 1)
        P, mesh = Pm[: prob.p.numel()], Pm[prob.p.numel() :].T
        x_next, cost_k, sub_g = interval.map(N)(X[:nx, :N], U, X[nx, :N] * mesh, P)
        g = [ca.vec(x_next - X[:nx, 1:]), ca.vec(X[nx, 1:] - X[nx, :N])]
        kinds = ["eq"] * (nx * N + N)
        if node_kinds:
            g.append(ca.vec(node_fn.map(N + 1)(X[:nx, :], ca.horzcat(U, U[:, N - 1]), P)))
            kinds += node_kinds * (N + 1)
        if sub_kinds:
            g.append(ca.vec(sub_g))
            kinds += sub_kinds * N
        self.nlp = {
            "x": ca.vertcat(ca.vec(X), ca.vec(U)),
            "f": N * X[nx, 0] + ca.sum2(cost_k),
            "g": ca.vertcat(*g),
            "p": Pm,
        }
        self.kinds = np.array(kinds)

    def split(self, w: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Decision vector -> (T, X (N+1, nx), U (N, nu))."""
        nX = (self.nx + 1) * (self.N + 1)
        X = w[:nX].reshape(self.N + 1, self.nx + 1)
        U = w[nX:].reshape(self.N, self.nu)
        return float(X[0, -1] * self.N), X[:, :-1], U

    def join(self, T: float, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """(T, X, U) -> decision vector (CasADi vec is column-major, i.e. node after node, T/N last)."""
        Xa = np.column_stack([X, np.full(len(X), T / self.N)])
        return np.concatenate([Xa.ravel(), U.ravel()])


GRADED_WIDTH = 0.08
"""Share of the intervals, at each end, over which the graded grid shrinks them."""


def graded_mesh(N: int, grading: float, width: float = GRADED_WIDTH) -> np.ndarray:
    """Interval lengths (mean 1) shrunk toward both rest ends: 1 - a (exp(-(x/w)^2) + exp(-((1-x)/w)^2)).

    A rest-to-rest move starts and ends with the acceleration ramping at the jerk limit for a few milliseconds;
    on a uniform grid of 20 ms intervals that ramp is smeared over a whole interval and costs about 0.8 % of T.
    Only the first and last intervals shrink (to 1 - a of the mean); the rest grow by a few per cent, so the
    constraints imposed at the nodes are as close together mid-move as on the uniform grid."""
    x = (np.arange(N) + 0.5) / N
    shape = 1.0 - grading * (np.exp(-((x / width) ** 2)) + np.exp(-(((1.0 - x) / width) ** 2)))
    return shape * N / shape.sum()


def equidistributed_mesh(t_nodes: np.ndarray, u: np.ndarray, weight: float = 10.0, shortest: float = 0.1) -> np.ndarray:
    """Interval lengths (mean 1) that equidistribute 1 + weight |u| / max |u| of a solution (same N).

    Short intervals go where the input is large (the ramps and switches of a near bang-bang optimum); no interval
    is shorter than `shortest` times the mean."""
    N = len(u)
    mag = np.linalg.norm(np.atleast_2d(u.T).T, axis=1)
    density = 1.0 + weight * mag / max(float(mag.max()), 1e-12)
    cum = np.concatenate([[0.0], np.cumsum(density * np.diff(t_nodes))])
    nodes = np.interp(np.linspace(0.0, cum[-1], N + 1), cum, t_nodes)
    mesh = np.maximum(np.diff(nodes) / (t_nodes[-1] / N), shortest)
    return mesh * N / mesh.sum()


def regrid(t_old: np.ndarray, X: np.ndarray, U: np.ndarray, t_new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A solution moved onto other node times: states interpolated linearly, inputs piecewise constant."""
    Xn = np.column_stack([np.interp(t_new, t_old, X[:, j]) for j in range(X.shape[1])])
    mid = (t_new[:-1] + t_new[1:]) / 2
    k = np.clip(np.searchsorted(t_old, mid, side="right") - 1, 0, len(U) - 1)
    return Xn, U[k]
