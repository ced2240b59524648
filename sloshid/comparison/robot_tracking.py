"""The robot's Cartesian tracking in series with the linearised liquid (seed eq. 5), as python-control systems.

Every trajectory is pushed through a second-order tracking loop (bandwidth configurable, default 20 Hz) by
`forced_columns` (control.forced_response's discretisation, all columns at once); the linear liquid angle is H(s)
of the executed acceleration. Beside it the
nonlinear pendulum (`simulate_liquids`) runs on the same executed motion, which shows where the
linearisation holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np

from sloshid.model.pendulum import SloshParams, linear_tf
from sloshid.model.simulate import simulate_liquids
from sloshid.model.trajectory import Trajectory


def robot_tf(bandwidth_hz: float = 20.0, zeta: float = 1 / math.sqrt(2)) -> control.TransferFunction:
    """Cartesian tracking as wn^2 / (s^2 + 2 zeta wn s + wn^2); with zeta = 1/sqrt(2) its -3 dB bandwidth is wn."""
    wn = 2 * math.pi * bandwidth_hz
    return control.tf([wn * wn], [1.0, 2 * zeta * wn, wn * wn])


def hold_after(traj: Trajectory, settle_s: float) -> Trajectory:
    """The trajectory extended by `settle_s` at rest in its last pose (what the robot commands after arrival)."""
    n = round(settle_s / traj.dt_s)
    t = np.concatenate([traj.t_s, traj.t_s[-1] + traj.dt_s * np.arange(1, n + 1)])
    hold = lambda a, keep: np.vstack([a, np.repeat(a[-1:] if keep else 0 * a[-1:], n, axis=0)])  # noqa: E731
    return Trajectory(
        t,
        hold(traj.pos_m, True),
        hold(traj.vel_m_s, False),
        hold(traj.acc_m_s2, False),
        hold(traj.euler_rad, True),
        hold(traj.euler_rate_rad_s, False),
        name=traj.name,
    )


def forced_columns(sys: control.TransferFunction, blocks: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
    """Each column of each block (t (N,), u (N, k)) through the SISO system `sys` from zero state: the discretisation
    control.forced_response uses (exact for inputs linear between samples), with every column of every block in one
    vectorised recursion instead of one Python time loop per column. The blocks share their sample period."""
    import scipy.linalg

    if not blocks:
        return []
    one = control.ss(sys)
    a, b, c, d = (np.asarray(m, dtype=float) for m in (one.A, one.B, one.C, one.D))
    periods = {(t[-1] - t[0]) / (len(t) - 1) for t, _ in blocks}  # forced_response's own dt
    if max(periods) - min(periods) > 1e-12:
        raise ValueError(f"blocks sampled at different periods: {sorted(periods)}")
    dt, n = periods.pop(), a.shape[0]
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n], m[n, n + 1] = a * dt, b[:, 0] * dt, 1.0
    e = scipy.linalg.expm(m)
    ad, bd1 = e[:n, :n], e[:n, n + 1]
    bd0 = e[:n, n] - bd1
    steps = max(len(t) for t, _ in blocks)
    u = np.hstack([np.vstack([x, np.repeat(x[-1:], steps - len(x), axis=0)]) for _, x in blocks])  # held to the end
    state = np.zeros((steps, u.shape[1], n))
    for i in range(1, steps):
        state[i] = state[i - 1] @ ad.T + np.outer(u[i - 1], bd0) + np.outer(u[i], bd1)
    y = state @ c[0] + d[0, 0] * u
    cuts = np.cumsum([x.shape[1] for _, x in blocks])[:-1]
    return [part[: len(t)] for part, (t, _) in zip(np.split(y, cuts, axis=1), blocks)]


def filter_columns(sys: control.TransferFunction, t: np.ndarray, data: np.ndarray) -> np.ndarray:
    """Each column of `data` (N, k) through the SISO system `sys`, starting from its own first value at rest."""
    return data[0] + forced_columns(sys, [(t, data - data[0])])[0]


def executed_moves(trajs: list[Trajectory], robot: control.TransferFunction) -> list[Trajectory]:
    """What a robot with tracking dynamics `robot` actually does when commanded each trajectory (all channels
    filtered, every trajectory in one recursion)."""
    channels = [np.hstack([tr.pos_m, tr.vel_m_s, tr.acc_m_s2, tr.euler_rad, tr.euler_rate_rad_s]) for tr in trajs]
    done = forced_columns(robot, [(tr.t_s, ch - ch[0]) for tr, ch in zip(trajs, channels)])
    moves = []
    for tr, ch, f in zip(trajs, channels, done):
        pos, vel, acc, euler, rate = np.split(ch[0] + f, 5, axis=1)
        moves.append(Trajectory(tr.t_s, pos, vel, acc, euler, rate, name=tr.name))
    return moves


@dataclass
class ClosedLoopResponse:
    """Relative liquid angle (roll, pitch) under the executed motion, linear model beside nonlinear pendulum."""

    t_s: np.ndarray
    rel_linear_rad: np.ndarray
    """python-control: H(s) of the executed acceleration minus the executed container tilt (N, 2)."""
    rel_nonlinear_rad: np.ndarray
    """The nonlinear pendulums under the same executed motion (N, 2)."""
    t_arrival_s: float
    """End of the commanded move."""

    @property
    def rel_linear_deg(self) -> np.ndarray:
        """Magnitude of the linear relative angle, degrees."""
        return np.degrees(np.hypot(*self.rel_linear_rad.T))

    @property
    def rel_nonlinear_deg(self) -> np.ndarray:
        """Magnitude of the nonlinear relative angle, degrees."""
        return np.degrees(np.hypot(*self.rel_nonlinear_rad.T))

    @property
    def max_gap_deg(self) -> float:
        """Largest difference between the linear and nonlinear relative angles (either axis)."""
        return float(np.degrees(np.abs(self.rel_linear_rad - self.rel_nonlinear_rad).max()))

    @property
    def residual_linear_deg(self) -> float:
        """Largest linear relative angle after arrival."""
        return float(self.rel_linear_deg[self.t_s > self.t_arrival_s].max())


def closed_loop_responses(
    trajs: list[Trajectory], params: SloshParams, bandwidth_hz: float = 20.0, settle_s: float = 2.0
) -> list[ClosedLoopResponse]:
    """Push each trajectory through robot tracking and liquid, linear (seed eq. 5) and nonlinear, all of them at
    once."""
    runs = executed_moves([hold_after(traj, settle_s) for traj in trajs], robot_tf(bandwidth_hz))
    nonlinear = simulate_liquids(runs, params, settle_s=0.0)
    # pitch theta tilts toward +ux, roll phi away from +uy
    linear = forced_columns(linear_tf(params), [(run.t_s, run.acc_m_s2[:, :2]) for run in runs])
    return [
        ClosedLoopResponse(
            run.t_s,
            np.column_stack([-lin[:, 1], lin[:, 0]]) - run.euler_rad[:, :2],
            nl.rel_rad[: len(run.t_s)],
            float(traj.t_s[-1]),
        )
        for traj, run, nl, lin in zip(trajs, runs, nonlinear, linear)
    ]


def closed_loop_response(
    traj: Trajectory, params: SloshParams, bandwidth_hz: float = 20.0, settle_s: float = 2.0
) -> ClosedLoopResponse:
    """`closed_loop_responses` of one trajectory."""
    return closed_loop_responses([traj], params, bandwidth_hz, settle_s)[0]
