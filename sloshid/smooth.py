"""Kalman filter + RTS smoother (filterpy) of an angle trace on its real, uneven timestamps, bridging gaps.

Model: constant angular velocity driven by white-noise angular acceleration (per step F and Q from the
step's own dt). Frames with valid = 0 get a prediction only, so the smoother interpolates them from
both sides. The acceleration noise level is estimated from the valid data itself (second differences
minus what measurement noise explains), so no tuning is needed for slow or fast sloshing.
"""

from __future__ import annotations

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

MEASUREMENT_SIGMA_DEG = 0.05
"""Standard deviation of a quality-1 angle measurement, degrees (tracker accuracy on synthetic video)."""


def _accel_variance(t: np.ndarray, z: np.ndarray, valid: np.ndarray, r: float) -> float:
    """Mean square angular acceleration (deg/s^2)^2 seen in consecutive valid samples, noise removed."""
    idx = np.flatnonzero(valid)
    if len(idx) < 4:
        return 1e4
    tv, zv = t[idx], z[idx]
    dt1, dt2 = np.diff(tv)[:-1], np.diff(tv)[1:]
    acc = 2 * ((zv[2:] - zv[1:-1]) / dt2 - (zv[1:-1] - zv[:-2]) / dt1) / (dt1 + dt2)
    noise = 6 * r / np.mean(0.5 * (dt1 + dt2)) ** 4  # second difference of white noise of variance r
    return float(max(np.mean(acc**2) - noise, np.median(acc**2), 1.0))


def smooth_angle(t_s: np.ndarray, angle_deg: np.ndarray, valid: np.ndarray, quality: np.ndarray) -> np.ndarray:
    """RTS-smoothed angle (degrees) at every timestamp; invalid samples are bridged, not used."""
    t = np.asarray(t_s, float)
    z = np.asarray(angle_deg, float)
    ok = np.asarray(valid, bool) & np.isfinite(z)
    n = len(t)
    if not ok.any():
        return np.full(n, np.nan)
    r_base = MEASUREMENT_SIGMA_DEG**2
    q_var = _accel_variance(t, z, ok, r_base)
    kf = KalmanFilter(dim_x=2, dim_z=1)
    first = int(np.argmax(ok))
    kf.x = np.array([[z[first]], [0.0]])
    kf.P = np.diag([1.0, 100.0 * max(q_var, 1.0) ** 0.5])
    kf.H = np.array([[1.0, 0.0]])
    dts = np.diff(t, prepend=t[0])
    dts = np.where(dts > 0, dts, 1e-6)
    Fs = np.array([[[1.0, dt], [0.0, 1.0]] for dt in dts])
    Qs = np.array([Q_discrete_white_noise(2, dt, q_var) for dt in dts])
    q = np.clip(np.asarray(quality, float), 0.05, 1.0)
    Rs = [np.array([[r_base / qi**2]]) for qi in q]
    zs = [np.array([[zi]]) if oki else None for zi, oki in zip(z, ok)]
    mu, cov, _, _ = kf.batch_filter(zs, Fs=Fs, Qs=Qs, Rs=Rs)
    xs, _, _, _ = kf.rts_smoother(mu, cov, Fs=Fs, Qs=Qs)
    return xs[:, 0, 0] if xs.ndim == 3 else xs[:, 0]
