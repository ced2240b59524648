"""Independent estimates of frequency and damping to hold against the PT2 fit: half-power bandwidth,
logarithmic decrement of the peaks, and the Hilbert envelope."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import signal as sps

from sloshid.core.spectrum import to_uniform

PEAK_SNR = 5.0
"""Peaks and envelope samples are used only when they stand this many noise standard deviations above zero."""


@dataclass(frozen=True)
class CrossCheck:
    """One method's frequency (Hz) and damping ratio, or NaN with a note saying why it could not tell."""

    method: str
    f_hz: float
    zeta: float
    n_periods: float
    """How many mode periods of data the method could use (its weight in the verdict)."""
    note: str = ""

    def to_dict(self) -> dict:
        """Plain dict; NaN becomes null."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}


def _modal(sigma: float, omega_d: float) -> tuple[float, float]:
    """(f_n in Hz, zeta) from decay rate sigma and damped angular frequency omega_d."""
    omega_n = math.hypot(omega_d, sigma)
    return omega_n / (2 * math.pi), sigma / omega_n


def half_power(t: np.ndarray, y: np.ndarray, f0_hz: float) -> CrossCheck:
    """-3 dB width of the window's periodogram (boxcar: a ring-down is its own taper): zeta = width / (2 f)."""
    u = to_uniform(t, y)
    x = u.value - u.value.mean()
    nfft = 1 << int(np.ceil(np.log2(64 * x.size)))
    f, p = sps.periodogram(x, fs=u.fs_hz, window="boxcar", nfft=nfft, detrend="linear")
    near = np.abs(f - f0_hz) < 0.5 * f0_hz
    k = int(np.flatnonzero(near)[np.argmax(p[near])])
    periods = float((t[-1] - t[0]) * f0_hz)
    half = p[k] / 2
    lo = k
    while lo > 0 and p[lo] > half:
        lo -= 1
    hi = k
    while hi < f.size - 1 and p[hi] > half:
        hi += 1
    if lo == 0 or hi == f.size - 1:
        return CrossCheck("half-power bandwidth", float(f[k]), float("nan"), periods, "peak edges not found")
    f_lo = np.interp(half, [p[lo], p[lo + 1]], [f[lo], f[lo + 1]])
    f_hi = np.interp(half, [p[hi], p[hi - 1]], [f[hi], f[hi - 1]])
    width = f_hi - f_lo
    duration = t[-1] - t[0]
    note = ""
    zeta = width / (2 * f[k])
    if width * duration < 1.0:  # the ring-down did not fade within the window: its edges, not damping, set the width
        note = f"bandwidth {width:.3g} Hz is limited by the {duration:.1f} s window; zeta not resolved"
        zeta = float("nan")
    return CrossCheck("half-power bandwidth", float(f[k]), float(zeta), periods, note)


def log_decrement(t: np.ndarray, y: np.ndarray, f0_hz: float, noise_std: float) -> CrossCheck:
    """Straight line through log(peak) vs time for the maxima (one per period) of the offset-free signal that
    stand well above the noise; only maxima, because nonlinear crests make maxima and minima differ."""
    u = to_uniform(t, y)
    x = u.value
    idx, _ = sps.find_peaks(x, distance=max(1, int(0.7 * u.fs_hz / f0_hz)), height=PEAK_SNR * noise_std)
    idx = idx[(idx > 0) & (idx < x.size - 1)]
    if idx.size < 4:
        return CrossCheck(
            "logarithmic decrement", float("nan"), float("nan"), float(idx.size), "fewer than 4 peaks above noise"
        )
    a, b, c = x[idx - 1], x[idx], x[idx + 1]  # parabolic refinement of each maximum
    den = np.where(a - 2 * b + c != 0, a - 2 * b + c, -1.0)
    shift = 0.5 * (a - c) / den
    tt = u.t_s[idx] + shift / u.fs_hz
    hh = b - 0.25 * (a - c) * shift
    slope = np.polyfit(tt, np.log(hh), 1, w=hh)[0]  # weights hh: log-peak noise ~ noise / peak (as in the envelope)
    cycles = np.round((tt - tt[0]) * f0_hz)  # a maximum lost in noise must not shorten the period
    period = np.polyfit(cycles, tt, 1)[0]
    f, zeta = _modal(-slope, 2 * math.pi / period)
    return CrossCheck(
        "logarithmic decrement", f, zeta, float(cycles[-1]), f"{tt.size} maxima above {PEAK_SNR:g} noise sd"
    )


def hilbert_envelope(t: np.ndarray, y: np.ndarray, f0_hz: float, noise_std: float) -> CrossCheck:
    """Band-pass around the mode, analytic signal (scipy.signal.hilbert): log envelope slope and phase slope."""
    u = to_uniform(t, y)
    nyq = u.fs_hz / 2
    band = [f0_hz / 1.5 / nyq, min(1.5 * f0_hz / nyq, 0.95)]  # centred on f0 in log: the pass-band tilts no line
    sos = sps.butter(4, band, btype="bandpass", output="sos")
    x = sps.sosfiltfilt(sos, u.value - u.value.mean(), padlen=min(3 * (2 * len(sos) + 1), u.value.size - 1))
    z = sps.hilbert(x)
    env, phase = np.abs(z), np.unwrap(np.angle(z))
    edge = round(u.fs_hz / f0_hz)
    keep = np.zeros(x.size, bool)
    keep[edge : x.size - edge] = True
    keep &= env > PEAK_SNR * noise_std
    if keep.sum() < 2 * edge:
        return CrossCheck("Hilbert envelope", float("nan"), float("nan"), 0.0, "envelope too short above noise")
    # polyfit's weights multiply the residuals, so w = envelope weighs each sample by envelope^2: the inverse variance
    # of both the log envelope and the phase under additive noise. Without it the faint tail, where the phase is
    # mostly noise or round-off, outvotes the ring-down (a noise-free decay read 2.2 Hz against 3.45 Hz).
    w = env[keep]
    slope = np.polyfit(u.t_s[keep], np.log(w), 1, w=w)[0]
    omega_d = np.polyfit(u.t_s[keep], phase[keep], 1, w=w)[0]
    f, zeta = _modal(-slope, abs(omega_d))
    effective = float(np.sum(w**2) ** 2 / np.sum(w**4))  # Kish effective sample count of the envelope^2 weights
    return CrossCheck(
        "Hilbert envelope",
        f,
        zeta,
        effective / u.fs_hz * f0_hz,
        "band-pass f0/1.5-1.5 f0, one period cut at each end, samples weighted by envelope^2",
    )
