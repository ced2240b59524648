"""Nonlinear liquid response to a container trajectory (solve_ivp), and the slosh figures that score a move.

The liquid is the pendulum pair of `sloshid.model.pendulum.pendulum_rhs_3d`; what spills liquid is its angle
*relative to the container*, i.e. the liquid surface's (phi, theta) minus the container's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from sloshid.model.pendulum import G, SloshParams, angle_accel
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


def simulate_liquid(
    traj: Trajectory, params: SloshParams, settle_s: float = 3.0, rtol: float = 1e-9, atol: float = 1e-12
) -> LiquidResponse:
    """Integrate the nonlinear pendulums under the trajectory's accelerations, liquid at rest at t0.

    The acceleration is linear between samples and zero after arrival; the container holds its last pose.
    """
    t = traj.t_s
    dt = traj.dt_s
    acc = traj.acc_m_s2
    n_after = int(np.ceil(settle_s / dt))
    t_all = np.concatenate([t, t[-1] + dt * np.arange(1, n_after + 1)])

    t0, t_end, n = float(t[0]), float(t[-1]), len(t)
    rows = acc.tolist()

    def rhs(time: float, y: np.ndarray) -> list[float]:
        # acceleration linear between samples, zero after arrival (as np.interp(..., right=0)), in plain
        # floats: this function runs ~10^5 times per second of motion, so it avoids NumPy scalar overhead
        if time > t_end:
            ux = uy = uz = 0.0
        else:
            s = (time - t0) / dt
            i = min(max(int(s), 0), n - 2)
            f = s - i
            a, b = rows[i], rows[i + 1]
            ux, uy, uz = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]))
        g_eff = G + uz
        tilt_y_dd = angle_accel(-y[0], -y[2], uy, params, g_eff, math.sin, math.cos)  # -phi tilts toward +uy
        theta_dd = angle_accel(y[1], y[3], ux, params, g_eff, math.sin, math.cos)
        return [y[2], y[3], -tilt_y_dd, theta_dd]

    # max_step only keeps the integrator from stepping over a move that starts after an idle lead-in;
    # accuracy comes from rtol/atol (5 ms steps agree with 2 ms steps to 1e-6 deg on the bundled moves)
    sol = solve_ivp(
        rhs,
        (t_all[0], t_all[-1]),
        np.zeros(4),
        method="DOP853",
        t_eval=t_all,
        rtol=rtol,
        atol=atol,
        max_step=max(2 * dt, MAX_STEP_S),
    )
    if not sol.success:  # pragma: no cover - DOP853 on this smooth problem does not fail
        raise RuntimeError(f"liquid simulation failed: {sol.message}")
    liquid = sol.y[:2].T
    container = np.vstack([traj.euler_rad[:, :2], np.repeat(traj.euler_rad[-1:, :2], n_after, axis=0)])
    return LiquidResponse(t_all, liquid, liquid - container, float(t[-1]))
