"""The one pendulum integrator (solve_ivp) used by simulation, plan sampling and synthetic videos, the nonlinear
liquid response to a container trajectory, and the slosh figures that score a move.

The liquid is the pendulum pair of `sloshid.model.pendulum.pendulum_rhs_3d`; what spills liquid is its angle
*relative to the container*, i.e. the liquid surface's (phi, theta) minus the container's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from sloshid.model.pendulum import G, SloshParams, angle_accel, spherical_accel
from sloshid.model.trajectory import Trajectory

MAX_STEP_S = 5e-3
"""Largest integrator step: far below any move's duration, so no acceleration phase can be stepped over."""


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
    y0: Sequence[float] = (0.0, 0.0, 0.0, 0.0),
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_step: float = np.inf,
    spherical: bool = False,
    drag: float = 0.0,
) -> np.ndarray:
    """The one pendulum integrator: surface state [phi, theta, phi', theta'] (rad, rad/s) at the sorted times
    `t_eval` under the container acceleration given piece by piece, `pieces` = [(t0, t1, accel), ...] back to back.

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

    The acceleration is linear between samples and zero after arrival; the container holds its last pose.
    """
    t = traj.t_s
    dt = traj.dt_s
    n_after = int(np.ceil(settle_s / dt))
    t_all = np.concatenate([t, t[-1] + dt * np.arange(1, n_after + 1)])
    t0, t_end, n = float(t[0]), float(t[-1]), len(t)
    rows = traj.acc_m_s2.tolist()

    def moving(time: float) -> tuple[float, float, float]:
        # linear between samples (as np.interp), in plain floats for speed
        s = (time - t0) / dt
        i = min(max(int(s), 0), n - 2)
        f = s - i
        a, b = rows[i], rows[i + 1]
        return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])

    # max_step only keeps the integrator from stepping over a move that starts after an idle lead-in;
    # accuracy comes from rtol/atol (5 ms steps agree with 2 ms steps to 1e-6 deg on the bundled moves)
    pieces = [(t0, t_end, moving), (t_end, float(t_all[-1]), lambda _t: (0.0, 0.0, 0.0))]
    state = integrate_pendulums(
        pieces, t_all, params, rtol=rtol, atol=atol, max_step=max(2 * dt, MAX_STEP_S), spherical=spherical, drag=drag
    )
    liquid = state[:, :2]
    container = np.vstack([traj.euler_rad[:, :2], np.repeat(traj.euler_rad[-1:, :2], n_after, axis=0)])
    return LiquidResponse(t_all, liquid, liquid - container, float(t[-1]))
