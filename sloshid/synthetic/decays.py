"""Synthetic free-decay traces with known truth, for the identification tests and benchmarks (no video needed)."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from sloshid.identification.signals import Signal, make_signal

NOISE_WHITE_SHARE = 0.5
"""Default variance fraction of the white part of tracker-like noise (the rest is AR(1))."""


def tracker_noise(
    rng: np.random.Generator, n: int, std: float, rho: float, share: float = 1 - NOISE_WHITE_SHARE
) -> np.ndarray:
    """Tracker-like measurement noise of total standard deviation `std`: white per-frame error plus an AR(1) part
    (per-frame correlation `rho`, variance fraction `share`) as compression and blur leave it."""
    white = rng.normal(size=n)
    ar = sps.lfilter([np.sqrt(1 - rho**2)], [1, -rho], rng.normal(size=n))
    return std * (np.sqrt(1 - share) * white + np.sqrt(share) * ar)


def free_decay(
    f_hz: float,
    zeta: float,
    fps: float,
    duration_s: float = 10.0,
    amplitude: float = 10.0,
    noise_std: float = 0.3,
    rho: float = 0.0,
    seed: int = 0,
    jitter: float = 0.0,
    drop_fraction: float = 0.0,
    lead_in_s: float = 0.0,
    phase: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(t_s, value) of amplitude * exp(-zeta w t) cos(w_d t + phase) + noise, starting after `lead_in_s` of rest.

    `jitter` is the timestamp jitter as a fraction of the frame period (variable-frame-rate cameras);
    `drop_fraction` of frames are removed at random (lost frames)."""
    rng = np.random.default_rng(seed)
    n = round((lead_in_s + duration_s) * fps)
    t = np.arange(n) / fps + rng.uniform(-jitter, jitter, n) / fps
    t = np.sort(t)
    omega = 2 * np.pi * f_hz
    ph = rng.uniform(0, 2 * np.pi) if phase is None else phase
    tr = np.clip(t - lead_in_s, 0, None)
    y = np.where(
        t >= lead_in_s, amplitude * np.exp(-zeta * omega * tr) * np.cos(omega * np.sqrt(1 - zeta**2) * tr + ph), 0.0
    )
    y = y + tracker_noise(rng, n, noise_std, rho)
    keep = rng.uniform(size=n) >= drop_fraction
    return t[keep], y[keep]


def free_decay_signal(f_hz: float, zeta: float, fps: float, **kw) -> Signal:
    """free_decay() wrapped as a Signal in degrees."""
    t, y = free_decay(f_hz, zeta, fps, **kw)
    return make_signal(t, y, "angle_deg", "deg", f"synthetic f={f_hz:g} Hz zeta={zeta:g} {fps:g} fps")
