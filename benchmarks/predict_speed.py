"""`sloshid predict`'s liquid simulation on a long 1 kHz log (issue 40: at least 20 times faster than the adaptive
solver it used): the spherical pendulum with its breaking drag, as `predict` runs it, on the compiled fixed-step RK4
(`simulate_liquid`) beside the adaptive DOP853 with a Python right-hand side (`integrate_pendulums`, what it ran
before), in the same process one after the other, on the same pivot acceleration; and the largest difference of the
two wall-relevant angles. The log is a 100 s repetition of a 3-D figure-eight (a lift of 4 m/s^2, a turn about the
vertical) sampled at 1 kHz.

Writes reports/benchmarks/predict_speed.{json,md}. Run from the repository root: python3 benchmarks/predict_speed.py
"""

from __future__ import annotations

import math
import time

import numpy as np
from bench_output import write_results

from sloshid.model.pendulum import TABLE_I
from sloshid.model.simulate import integrate_pendulums, simulate_liquid
from sloshid.model.trajectory import Trajectory

SECONDS, RATE_HZ, DRAG = 100.0, 1000.0, 1.0
TARGET = 20.0


def figure_eight() -> Trajectory:
    """A lemniscate of 0.15 m in x-y with a 40 mm vertical oscillation at twice its rate, repeated, at RATE_HZ."""
    t = np.arange(int(SECONDS * RATE_HZ)) / RATE_HZ
    w = 2 * math.pi / 5.0  # one figure-eight every 5 s
    pos = np.column_stack([0.15 * np.sin(w * t), 0.075 * np.sin(2 * w * t), 0.04 * np.sin(4 * w * t)])
    vel = np.gradient(pos, t, axis=0)
    acc = np.gradient(vel, t, axis=0)
    zeros = np.zeros_like(pos)
    return Trajectory(t, pos, vel, acc, zeros, zeros)


def adaptive(traj: Trajectory, settle_s: float) -> np.ndarray:
    """The surface angles by DOP853 (rtol 1e-9, as predict asks), the acceleration linear between samples."""
    t, acc = traj.t_s, traj.acc_m_s2
    rows, t0, dt, n = acc.tolist(), float(t[0]), traj.dt_s, len(t)

    def moving(time_s: float) -> tuple[float, float, float]:
        s = (time_s - t0) / dt
        i = min(max(int(s), 0), n - 2)
        f = s - i
        a, b = rows[i], rows[i + 1]
        return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])

    t_all = np.concatenate([t, t[-1] + dt * np.arange(1, int(np.ceil(settle_s / dt)) + 1)])
    pieces = [(t0, float(t[-1]), moving), (float(t[-1]), float(t_all[-1]), lambda _t: (0.0, 0.0, 0.0))]
    state = integrate_pendulums(pieces, t_all, TABLE_I, rtol=1e-9, atol=1e-12, max_step=5e-3, spherical=True, drag=DRAG)
    return state[:, :2]


def main() -> None:
    """Time both integrations; write reports/benchmarks/predict_speed.*"""
    traj, settle = figure_eight(), 3.0
    start = time.perf_counter()
    compiled = simulate_liquid(traj, TABLE_I, settle_s=settle, rtol=1e-9, spherical=True, drag=DRAG)
    fast = time.perf_counter() - start
    start = time.perf_counter()
    reference = adaptive(traj, settle)
    slow = time.perf_counter() - start
    diff = float(np.degrees(np.abs(compiled.liquid_rad - reference).max()))
    peak = float(np.degrees(np.abs(reference).max()))
    ratio = slow / fast
    write_results(
        "predict_speed",
        {
            "log_s": SECONDS,
            "rate_hz": RATE_HZ,
            "compiled_rk4_s": fast,
            "adaptive_dop853_s": slow,
            "speedup": ratio,
            "max_angle_difference_deg": diff,
            "peak_angle_deg": peak,
            "target_speedup": TARGET,
            "target_met": ratio >= TARGET,
        },
        "predict's liquid simulation on a 100 s log at 1 kHz",
        ["integrator", "seconds", "speed-up", "largest angle difference, deg (peak angle)"],
        [
            ["adaptive DOP853, Python right-hand side (before)", slow, 1.0, "-"],
            ["compiled RK4 on the 1 kHz grid (now)", fast, ratio, f"{diff:.2g} ({peak:.1f})"],
        ],
        f"The spherical pendulum with breaking drag {DRAG} (Table I's liquid) under a repeated 3-D figure-eight; the "
        f"target is a speed-up of at least {TARGET:g} (issue 40). Both in one process, one after the other.",
    )


if __name__ == "__main__":
    main()
