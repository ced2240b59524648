"""The robot's Cartesian tracking in series with the linearised liquid (seed eq. 5), as python-control systems.

Every trajectory is pushed through a second-order tracking loop (bandwidth configurable, default 20 Hz) with
`control.forced_response`; the linear liquid angle is H(s) of the executed acceleration. Beside it the
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


def filter_columns(sys: control.TransferFunction, t: np.ndarray, data: np.ndarray) -> np.ndarray:
    """Each column of `data` (N, k) through the SISO system `sys`, starting from its own first value at rest; all
    columns in one forced_response of k uncoupled copies (its time loop runs once, not k times)."""
    one = control.ss(sys)
    k = data.shape[1]
    copies = control.ss(*(np.kron(np.eye(k), np.asarray(m)) for m in (one.A, one.B, one.C, one.D)))
    base = data[0]
    out = control.forced_response(copies, T=t, U=(data - base).T).outputs
    return base + np.asarray(out).reshape(k, -1).T


def executed(traj: Trajectory, robot: control.TransferFunction) -> Trajectory:
    """What a robot with tracking dynamics `robot` actually does when commanded `traj` (all channels filtered)."""
    channels = (traj.pos_m, traj.vel_m_s, traj.acc_m_s2, traj.euler_rad, traj.euler_rate_rad_s)
    done = np.split(filter_columns(robot, traj.t_s, np.hstack(channels)), len(channels), axis=1)
    return Trajectory(traj.t_s, *done, name=traj.name)


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
    """Push each trajectory through robot tracking and liquid, linear (python-control) and nonlinear (all of them in
    one batched `simulate_liquids`)."""
    robot, h = robot_tf(bandwidth_hz), linear_tf(params)
    runs = [executed(hold_after(traj, settle_s), robot) for traj in trajs]
    nonlinear = simulate_liquids(runs, params, settle_s=0.0)
    out = []
    for traj, run, nl in zip(trajs, runs, nonlinear):
        t = run.t_s
        theta = control.forced_response(h, T=t, U=run.acc_m_s2[:, 0]).outputs  # pitch tilts toward +ux
        phi = -control.forced_response(h, T=t, U=run.acc_m_s2[:, 1]).outputs  # roll tilts away from +uy
        linear = np.column_stack([phi, theta]) - run.euler_rad[:, :2]
        out.append(ClosedLoopResponse(t, linear, nl.rel_rad[: len(t)], float(traj.t_s[-1])))
    return out


def closed_loop_response(
    traj: Trajectory, params: SloshParams, bandwidth_hz: float = 20.0, settle_s: float = 2.0
) -> ClosedLoopResponse:
    """`closed_loop_responses` of one trajectory."""
    return closed_loop_responses([traj], params, bandwidth_hz, settle_s)[0]
