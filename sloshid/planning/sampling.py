"""Robot-ready sampling of an optimal plan: integrate the optimal input exactly onto a 1 kHz grid.

Translation is the closed-form polynomial of the piecewise-constant input (cubic per interval for jerk,
quadratic for acceleration); the container orientation is the liquid surface, obtained by integrating
the nonlinear pendulum (model.simulate.integrate_pendulums) interval by interval under that same input,
never by interpolating the optimiser's nodes. Segments are concatenated with the pendulum state carried on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import integrate_pendulums
from sloshid.model.trajectory import EXPORT_RATE_HZ, Trajectory
from sloshid.planning.ocp import SegmentResult


def _input_3d(seg: SegmentResult) -> np.ndarray:
    """The segment's piecewise-constant input as (N, 3) world-axis values (jerk or acceleration)."""
    u = np.zeros((len(seg.u), 3))
    if seg.axis is None:
        u[:] = seg.u
    else:
        u[:, seg.axis] = seg.u[:, 0]
    return u


def _node_states(seg: SegmentResult, u3: np.ndarray, hk: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity, acceleration at each node, propagated exactly from the start (N+1, 3) each."""
    n = len(u3)
    p, v, a = np.zeros((n + 1, 3)), np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    p[0] = seg.start
    for k in range(n):
        h = hk[k]
        acc0 = a[k] if seg.jerk_limited else u3[k]
        jerk = u3[k] if seg.jerk_limited else 0.0
        p[k + 1] = p[k] + v[k] * h + acc0 * h**2 / 2 + jerk * h**3 / 6
        v[k + 1] = v[k] + acc0 * h + jerk * h**2 / 2
        a[k + 1] = acc0 + jerk * h if seg.jerk_limited else 0.0
    return p, v, a


def sample_segment(
    seg: SegmentResult, params: SloshParams, y0: np.ndarray, dt: float = 1.0 / EXPORT_RATE_HZ
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Samples of one segment on t = 0, dt, ... ceil(T/dt) dt (holding the goal after T), and the final pendulum state."""
    u3 = _input_3d(seg)
    n = len(u3)
    tn = seg.t_nodes  # node times (the grid may be refined, i.e. non-uniform)
    hk = np.diff(tn)
    p, v, a = _node_states(seg, u3, hk)
    K = math.ceil(seg.T_s / dt - 1e-9)
    t = np.arange(K + 1) * dt
    k = np.clip(np.searchsorted(tn, t, side="right") - 1, 0, n - 1)
    tau = np.clip(t - tn[k], 0.0, hk[k])[:, None]
    after = t >= seg.T_s
    if seg.jerk_limited:
        jerk = u3[k]
        acc = a[k] + jerk * tau
        vel = v[k] + a[k] * tau + jerk * tau**2 / 2
        pos = p[k] + v[k] * tau + a[k] * tau**2 / 2 + jerk * tau**3 / 6
    else:
        acc = u3[k].copy()
        vel = v[k] + acc * tau
        pos = p[k] + v[k] * tau + acc * tau**2 / 2
    acc[after], vel[after], pos[after] = 0.0, 0.0, p[-1]

    def acc_in(kk: int):
        """Acceleration as a function of absolute time inside interval kk (exact polynomial)."""
        t0 = tn[kk]
        if seg.jerk_limited:
            return lambda tt: (a[kk] + u3[kk] * (tt - t0)).tolist()
        return lambda tt: u3[kk].tolist()

    pieces = [(tn[kk], tn[kk + 1] if kk < n - 1 else seg.T_s, acc_in(kk)) for kk in range(n)]
    pieces.append((seg.T_s, max(seg.T_s, float(t[-1])), lambda tt: (0.0, 0.0, 0.0)))
    ang = integrate_pendulums(pieces, t, params, y0, rtol=1e-11, atol=1e-13)
    y = ang[-1]  # the state at the last sample, where the next segment starts
    samples = {"t": t, "pos": pos, "vel": vel, "acc": acc, "ang": ang}
    return samples, y


def sample_segments(segments: Sequence[SegmentResult], params: SloshParams, name: str = "sloshid plan") -> Trajectory:
    """Concatenate the segments into one 1 kHz Trajectory starting at t = 0 (junction samples not repeated)."""
    dt = 1.0 / EXPORT_RATE_HZ
    y = np.zeros(4)
    parts: list[dict[str, np.ndarray]] = []
    for i, seg in enumerate(segments):
        samples, y = sample_segment(seg, params, y, dt)
        if i > 0:  # the first sample repeats the previous segment's last one (rest at the waypoint)
            samples = {key: val[1:] for key, val in samples.items()}
        parts.append(samples)
    cat = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    n = len(cat["pos"])
    ang = cat["ang"]
    euler = np.column_stack([ang[:, 0], ang[:, 1], np.zeros(n)])
    rates = np.column_stack([ang[:, 2], ang[:, 3], np.zeros(n)])
    return Trajectory(np.arange(n) * dt, cat["pos"], cat["vel"], cat["acc"], euler, rates, name=name)
