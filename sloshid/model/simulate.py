"""The pendulum integrators and the nonlinear liquid response to a container trajectory, with the slosh figures that
score a move: `simulate_liquids` for sampled trajectories (a fixed-step RK4 compiled with CasADi on the trajectory's
grid, many pendulums per call: every scored move), `integrate_pendulums` for inputs given as functions of time
(adaptive DOP853: plan sampling between the optimiser's nodes, synthetic videos).

The liquid is the pendulum pair of `sloshid.model.pendulum.pendulum_rhs_3d`; what spills liquid is its angle
*relative to the container*, i.e. the liquid surface's (phi, theta) minus the container's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.integrate import solve_ivp

from sloshid.model.conventions import wall_height_mm
from sloshid.model.pendulum import G, SloshParams, angle_accel, pendulum_rhs_3d, spherical_accel
from sloshid.model.trajectory import Trajectory


@dataclass
class LiquidResponse:
    """Liquid surface and relative angles over time; t_s runs past the end of the move by the settle time."""

    t_s: np.ndarray
    """Sample times (N,), the trajectory's grid extended after arrival."""
    liquid_rad: np.ndarray
    """Liquid surface roll phi and pitch theta (N, 2)."""
    rel_rad: np.ndarray
    """Liquid minus container, roll and pitch (N, 2)."""
    t_arrival_s: float
    """End of the move."""

    @property
    def rel_angle_deg(self) -> np.ndarray:
        """Magnitude of the relative tilt between liquid surface and container, degrees (N,)."""
        return np.degrees(np.hypot(self.rel_rad[:, 0], self.rel_rad[:, 1]))

    def wall_height_mm(self, radius_m: float) -> np.ndarray:
        """Highest point of the tilted surface at the wall of a container of `radius_m`, R tan(relative angle), in mm
        (the reading of `pose.PoseResponse.wall_height_mm`) (N,)."""
        return wall_height_mm(radius_m, np.hypot(self.rel_rad[:, 0], self.rel_rad[:, 1]))

    @property
    def peak_during_deg(self) -> float:
        """Largest relative angle while the container moves."""
        return float(self.rel_angle_deg[self.t_s <= self.t_arrival_s].max())

    @property
    def residual_deg(self) -> float:
        """Largest relative angle after arrival: the slosh left behind."""
        after = self.t_s > self.t_arrival_s
        return float(self.rel_angle_deg[after].max()) if after.any() else 0.0


Accel = Callable[[float], Sequence[float]]
"""Container acceleration (ux, uy, uz) in m/s^2 at time t."""


def integrate_pendulums(
    pieces: Sequence[tuple[float, float, Accel]],
    t_eval: np.ndarray,
    params: SloshParams,
    y0: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0, 0.0),
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_step: float = np.inf,
    spherical: bool = False,
    drag: float = 0.0,
) -> np.ndarray:
    """The integrator for inputs given as functions of time: surface state [phi, theta, phi', theta'] (rad, rad/s)
    at the sorted times `t_eval` under the container acceleration given piece by piece, `pieces` = [(t0, t1, accel),
    ...] back to back.

    The nonlinear pair of the reconstructed seed eq. 3 (vertical acceleration changes gravity to g + uz; -phi tilts
    toward +uy, theta toward +ux) is integrated with solve_ivp (DOP853) one piece at a time, restarting at every
    piece boundary so that a jump or kink of the input is never smeared. Samples before the first piece hold y0;
    samples after the last hold nothing (the caller's pieces must cover them). `spherical`: one spherical pendulum in
    the same angles instead of the pair (`pendulum.spherical_accel`: the horizontal directions coupled), with its
    `drag`.
    """
    out = np.zeros((len(t_eval), 4))
    out[t_eval < pieces[0][0]] = y0
    y = np.asarray(y0, dtype=float)
    for k, (t0, t1, accel) in enumerate(pieces):
        last = k == len(pieces) - 1
        idx = np.flatnonzero((t_eval >= t0) & ((t_eval <= t1) if last else (t_eval < t1)))
        if t1 <= t0:
            out[idx] = y
            continue

        def rhs(t: float, q: np.ndarray, accel: Accel = accel) -> list[float]:
            # plain floats: this runs ~10^5 times per second of motion, so it avoids NumPy scalar overhead
            ux, uy, uz = accel(t)
            g_eff = G + uz
            if spherical:
                return [q[2], q[3], *spherical_accel(q[0], q[1], q[2], q[3], ux, uy, g_eff, params, drag)]
            tilt_y_dd = angle_accel(-q[0], -q[2], uy, params, g_eff, math.sin, math.cos)  # -phi tilts toward +uy
            theta_dd = angle_accel(q[1], q[3], ux, params, g_eff, math.sin, math.cos)
            return [q[2], q[3], -tilt_y_dd, theta_dd]

        times = t_eval[idx]
        if not (times.size and times[-1] == t1):
            times = np.append(times, t1)  # the end too: the next piece's start state
        sol = solve_ivp(rhs, (t0, t1), y, method="DOP853", t_eval=times, rtol=rtol, atol=atol, max_step=max_step)
        if not sol.success:  # pragma: no cover - DOP853 on this smooth problem does not fail
            raise RuntimeError(f"liquid simulation failed: {sol.message}")
        out[idx] = sol.y[:, : idx.size].T
        y = sol.y[:, -1]
    return out


MAX_SETTLE_S = 600.0
"""Longest time the liquid is followed after a move ends (s): ten minutes at the trajectory's 1 kHz is 600 000
samples; a liquid rings down in seconds, and 1e9 s asked for terabytes."""

CHUNK_STEPS = 1000
"""Grid steps per call of the compiled RK4 (one second at 1 kHz): one CasADi function serves every length."""


class _Symbols:
    """The two constants the pendulum equations read from a SloshParams, as CasADi symbols (one function for every
    liquid)."""

    def __init__(self, l_m, damping_rate_1_s) -> None:
        self.l_m, self.damping_rate_1_s = l_m, damping_rate_1_s


@lru_cache(maxsize=16)
def _rk4_chunk(substeps: int, members: int, spherical: bool = False):
    """CasADi function: `members` pendulum pairs (or, `spherical`, spherical pendulums), each over CHUNK_STEPS grid
    steps of `substeps` RK4 steps.

    Inputs per member: the state [phi, theta, phi', theta'] (4, 1), the acceleration at each step's start and end
    (3, CHUNK_STEPS) each, linear in between, and (l_m, d/m, dt, drag) per step (4, CHUNK_STEPS); output the state at
    each step's end. The right-hand side is `pendulum_rhs_3d`, the equations the planner uses, or `spherical_accel`."""
    import casadi as ca

    q, ua, ub, c = ca.SX.sym("q", 4), ca.SX.sym("ua", 3), ca.SX.sym("ub", 3), ca.SX.sym("c", 4)
    liquid = _Symbols(c[0], c[1])

    def rates(y, u):
        if spherical:
            dd = spherical_accel(y[0], y[1], y[2], y[3], u[0], u[1], G + u[2], liquid, c[3], ca.sin, ca.cos, ca.sqrt)
            return ca.vertcat(y[2], y[3], *dd)
        o = ca.vertcat(0, 0, 0, y[0], y[1], 0, 0, 0, 0, y[2], y[3], 0)
        d = pendulum_rhs_3d(o, [u[0], u[1], u[2]], liquid, ca.sin, ca.cos)
        return ca.vertcat(d[3], d[4], d[9], d[10])

    h, y = c[2] / substeps, q
    for j in range(substeps):
        u0, u1 = ua + (ub - ua) * (j / substeps), ua + (ub - ua) * ((j + 1) / substeps)
        um = (u0 + u1) / 2
        k1 = rates(y, u0)
        k2 = rates(y + h / 2 * k1, um)
        k3 = rates(y + h / 2 * k2, um)
        k4 = rates(y + h * k3, u1)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    step = ca.Function("rk4_step", [q, ua, ub, c], [y], {"cse": True})
    chunk = step.mapaccum("rk4_chunk", CHUNK_STEPS)
    return chunk.map(members) if members > 1 else chunk


def _evaluate(fn, *args: np.ndarray) -> np.ndarray:
    """`fn`'s one output for dense NumPy inputs, as `np.asarray(fn(*args))` gives it (the same evaluation, bit for bit),
    through CasADi's FunctionBuffer: passing the arrays through DM matrices took about half of a Monte Carlo's time."""
    buffer, evaluate = fn.buffer()
    # CasADi reads and writes the nonzeros column-major: Fortran-ordered arrays, bound as flat views of themselves
    ins = [np.asfortranarray(a, dtype=float).reshape(-1, order="F") for a in args]
    rows, cols = fn.size_out(0)
    flat = np.empty(rows * cols)
    for i, a in enumerate(ins):
        if a.size != fn.nnz_in(i):  # the buffer would be read short or past its end
            raise ValueError(f"input {i} of {fn.name()} has {a.size} values, not {fn.nnz_in(i)}")
        buffer.set_arg(i, a.data)
    buffer.set_res(0, flat.data)
    evaluate()
    if buffer.ret() != 0:  # pragma: no cover - the RK4 has no failing operation
        raise RuntimeError(f"CasADi function {fn.name()} failed (return code {buffer.ret()})")
    return flat.reshape((rows, cols), order="F")


def rk4_substeps(omega_rad_s: float, dt_s: float, rtol: float) -> int:
    """RK4 steps per grid interval: enough that the phase error per radian of slosh, (omega h)^4 / 120, is at most
    `rtol` (1e-9: two steps per millisecond at 3.4 Hz)."""
    return max(1, math.ceil(omega_rad_s * dt_s / (120.0 * rtol) ** 0.25))


def simulate_liquids(
    trajs: Sequence[Trajectory],
    params: SloshParams | Sequence[SloshParams],
    settle_s: float = 3.0,
    rtol: float = 1e-9,
    spherical: bool = False,
    drag: float = 0.0,
) -> list[LiquidResponse]:
    """The nonlinear pendulums under many trajectories at once, each with its own liquid (or one for all), liquid at
    rest at each start: one compiled integration of the batched state (see `simulate_liquid`)."""
    liquids = [params] * len(trajs) if isinstance(params, SloshParams) else list(params)
    if len(liquids) != len(trajs):
        raise ValueError(f"{len(trajs)} trajectories but {len(liquids)} liquids")
    out: list[LiquidResponse | None] = [None] * len(trajs)
    by_dt: dict[float, list[int]] = {}
    for i, traj in enumerate(trajs):
        by_dt.setdefault(traj.dt_s, []).append(i)
    for dt, members in by_dt.items():
        batch = [trajs[i] for i in members], [liquids[i] for i in members]
        states = _integrate_grid(*batch, dt, settle_s, rtol, spherical, drag)
        for i, state in zip(members, states):
            out[i] = _response(trajs[i], state, dt)
    return out  # type: ignore[return-value]


def _integrate_grid(
    trajs: list[Trajectory],
    liquids: list[SloshParams],
    dt: float,
    settle_s: float,
    rtol: float,
    spherical: bool = False,
    drag: float = 0.0,
) -> list[np.ndarray]:
    """States [phi, theta, phi', theta'] on each trajectory's grid extended by `settle_s` (one array per member):
    the acceleration is linear between samples and zero after arrival."""
    n_after = int(np.ceil(settle_s / dt))
    steps = [len(t.t_s) - 1 + n_after for t in trajs]
    n_chunks = max(1, math.ceil(max(steps) / CHUNK_STEPS))
    total = n_chunks * CHUNK_STEPS
    members = len(trajs)
    acc = np.zeros((members, total + 1, 3))
    for b, traj in enumerate(trajs):
        acc[b, : len(traj.t_s)] = traj.acc_m_s2
    ua, ub = acc[:, :-1].copy(), acc[:, 1:].copy()
    for b, traj in enumerate(trajs):  # the step leaving the last sample already sees the container at rest
        ua[b, len(traj.t_s) - 1 :] = 0.0
        ub[b, len(traj.t_s) - 1 :] = 0.0
    consts = np.array([[p.l_m, p.damping_rate_1_s, dt, drag] for p in liquids])  # (members, 4)
    substeps = rk4_substeps(max(p.omega_rad_s for p in liquids), dt, rtol)
    fn = _rk4_chunk(substeps, members, spherical)
    c = np.repeat(consts.T[:, :, None], CHUNK_STEPS, axis=2).reshape(4, -1)
    # per chunk, member after member along the columns: what map(mapaccum) takes
    ua, ub = (
        a.reshape(members, n_chunks, CHUNK_STEPS, 3).transpose(1, 3, 0, 2).reshape(n_chunks, 3, -1) for a in (ua, ub)
    )
    state = np.zeros((members, total + 1, 4))
    q = np.zeros((4, members))
    for k in range(n_chunks):
        got = _evaluate(fn, q, ua[k], ub[k], c).reshape(4, members, CHUNK_STEPS)
        state[:, k * CHUNK_STEPS + 1 : (k + 1) * CHUNK_STEPS + 1] = got.transpose(1, 2, 0)
        q = got[:, :, -1]
    return [state[b, : n + 1] for b, n in enumerate(steps)]


def _response(traj: Trajectory, state: np.ndarray, dt: float) -> LiquidResponse:
    """The LiquidResponse of one member: its grid extended after arrival, the container holding its last pose."""
    t = traj.t_s
    n_after = len(state) - len(t)
    t_all = np.concatenate([t, t[-1] + dt * np.arange(1, n_after + 1)])
    liquid = state[:, :2]
    container = np.vstack([traj.euler_rad[:, :2], np.repeat(traj.euler_rad[-1:, :2], n_after, axis=0)])
    return LiquidResponse(t_all, liquid, liquid - container, float(t[-1]))


def simulate_liquid(
    traj: Trajectory,
    params: SloshParams,
    settle_s: float = 3.0,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    spherical: bool = False,
    drag: float = 0.0,
) -> LiquidResponse:
    """Integrate the nonlinear pendulums (or, `spherical`, one spherical pendulum with its `drag`) under the
    trajectory's accelerations, liquid at rest at t0.

    The acceleration is linear between samples and zero after arrival; the container holds its last pose. The inputs
    change only at the samples, so a fixed-step RK4 on the trajectory's grid (`rk4_substeps` per interval, from
    `rtol`) is as exact as an adaptive solver there: it agrees with DOP853 at rtol 1e-12 to 1e-5 deg (tests). `atol`
    is what callers of the adaptive solver this replaced still pass; a fixed step has no absolute tolerance.
    """
    del atol
    return simulate_liquids([traj], params, settle_s, rtol, spherical, drag)[0]
