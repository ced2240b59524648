"""Welch power spectral density of a (possibly unevenly sampled) window, with its dominant mode refined beyond a bin."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sp_fft
from scipy import signal as sps

from sloshid.core.tables import GAP_STEP_FACTOR

MIN_PROMINENCE = 10.0
"""Dominant peak / median PSD below this (10 dB) means no oscillatory mode stands out of the noise.
For white noise a Welch PSD with 3 averages exceeds 10x its median with probability ~1e-10 per bin."""

MAX_PADDED_NFFT = 1 << 20
"""Zero-padding stops growing at this FFT length (16 MB per segment): a segment this long already resolves a
bin finer than any mode's width, and padding a million-sample record 16-fold would take gigabytes."""

NEAR_MODE_OCTAVES = 2.0
"""`Spectrum.noise_near_mode` reads the noise floor this many octaves either side of the mode (its peak left out:
a quarter of its frequency, or two resolution bins, each side, whichever is wider)."""

SECONDARY_MIN_RATIO = 0.02
"""Secondary peaks weaker than this fraction of the dominant peak (-17 dB) are not listed."""


@dataclass(frozen=True)
class Uniform:
    """A signal on a uniform time grid, with a sentence on how it got there."""

    t_s: np.ndarray
    value: np.ndarray
    fs_hz: float
    note: str


def to_uniform(t: np.ndarray, y: np.ndarray) -> Uniform:
    """Put samples on a uniform grid at the median rate; linear interpolation when timestamps jitter or gaps exist."""
    dt = np.diff(t)
    step = float(np.median(dt, overwrite_input=True))  # reorders dt, which only order-free sums read below
    jitter = max(float(dt.max()) - step, step - float(dt.min())) / step  # max |dt - step|, without a temporary
    if jitter < 1e-3:
        return Uniform(t, y, 1.0 / step, "samples already uniform, used as they are")
    n = int(np.floor((t[-1] - t[0]) / step)) + 1
    tu = t[0] + step * np.arange(n)
    gaps = int(np.count_nonzero(dt > GAP_STEP_FACTOR * step))
    note = (
        f"timestamps uneven (max step deviation {100 * jitter:.0f} % of {1000 * step:.2f} ms, {gaps} gaps): "
        f"linearly interpolated onto a uniform {1 / step:.2f} Hz grid"
    )
    return Uniform(tu, np.interp(tu, t, y), 1.0 / step, note)


@dataclass(frozen=True)
class SpectralPeak:
    """A local maximum of the PSD: frequency, density, power relative to the dominant peak, harmonic order (0 = none)."""

    f_hz: float
    psd: float
    relative: float
    harmonic: int


@dataclass(frozen=True)
class Spectrum:
    """Welch PSD of one window and what was read off it."""

    f_hz: np.ndarray
    psd: np.ndarray
    fs_hz: float
    nperseg: int
    nfft: int
    n_averages: int
    resolution_hz: float
    resample_note: str
    peak_f_hz: float
    """Dominant frequency refined by a parabola on the log PSD over the main lobe (Gaussian interpolation)."""
    peak_bin_f_hz: float
    peak_psd: float
    prominence: float
    """Dominant peak density / median density (noise floor)."""
    noise_std: float
    """Broadband noise standard deviation implied by the median density (white-noise assumption)."""
    secondary: tuple[SpectralPeak, ...]
    resonant: bool
    """The dominant peak is a true resonance: inside the search band the PSD falls below half of it on both
    sides (red noise or drift only rises toward the band's lower edge)."""

    def noise_near_mode(self) -> float:
        """Noise standard deviation implied by the median density within NEAR_MODE_OCTAVES of the dominant peak, its
        main lobe left out (white-noise scaling, as `noise_std`): for noise correlated from sample to sample (red),
        whose density rises toward the mode and below it, the broadband median reads several times too low."""
        f0 = self.peak_f_hz
        span = 2.0**NEAR_MODE_OCTAVES
        lobe = max(0.25 * f0, 2 * self.resolution_hz)  # a short record's main lobe is wider than a quarter of f
        near = (self.f_hz > f0 / span) & (self.f_hz < f0 * span) & (np.abs(self.f_hz - f0) > lobe)
        if not near.any():
            return self.noise_std
        return float(np.sqrt(np.median(self.psd[near]) * self.fs_hz / 2))

    def period_mean_noise(self, f_hz: float) -> float:
        """Standard deviation that noise leaves in a running mean over one period of `f_hz`, from the median density
        below half that frequency (the mean passes a band of f_hz / 2): white noise's noise_std / sqrt(samples per
        period), several times more for noise correlated over many samples."""
        slow = (self.f_hz > 0) & (self.f_hz < f_hz / 2)
        if not slow.any():
            return self.noise_std * float(np.sqrt(f_hz / self.fs_hz))
        return float(np.sqrt(np.median(self.psd[slow]) * f_hz / 2))

    def to_dict(self) -> dict:
        """The summary numbers (not the arrays) with unit-named keys."""
        return {
            "method": "scipy.signal.welch, Hann window, 50 % overlap, density scaling",
            "fs_hz": self.fs_hz,
            "nperseg": self.nperseg,
            "nfft": self.nfft,
            "n_averages": self.n_averages,
            "resolution_hz": self.resolution_hz,
            "resampling": self.resample_note,
            "peak_f_hz": self.peak_f_hz,
            "peak_bin_f_hz": self.peak_bin_f_hz,
            "prominence_db": float(10 * np.log10(self.prominence)),
            "resonant": self.resonant,
            "secondary_peaks": [
                {"f_hz": p.f_hz, "relative_power": p.relative, "harmonic": p.harmonic} for p in self.secondary
            ],
        }


def welch_spectrum(
    t: np.ndarray,
    y: np.ndarray,
    f_range_hz: tuple[float, float] = (0.0, np.inf),
    nperseg: int | None = None,
    per_octave: bool = False,
) -> Spectrum:
    """Welch PSD of a window (three 50 %-overlapping Hann segments by default) and its dominant peak in f_range_hz:
    the one dominant-frequency estimate of the package. `per_octave` picks the peak on f * PSD (power per octave),
    so that a slow drift of the resting level cannot win over the mode."""
    u = to_uniform(t, y)
    n = u.value.size
    seg = int(nperseg) if nperseg else max(16, n // 2)
    seg = min(seg, n)
    nfft = max(_pow2(seg), min(_pow2(16 * seg), MAX_PADDED_NFFT))
    if seg >= LEAN_WELCH_SAMPLES:
        f, p = _lean_welch(u.value, u.fs_hz, seg, nfft)
    else:
        x = u.value - np.mean(u.value)
        f, p = sps.welch(x, fs=u.fs_hz, window="hann", nperseg=seg, noverlap=seg // 2, nfft=nfft, detrend="linear")
    n_avg = 1 + (n - seg) // (seg - seg // 2)
    resolution = u.fs_hz / seg
    band = (f >= max(f_range_hz[0], 1.5 * resolution)) & (f <= f_range_hz[1])
    if not band.any():
        band = f > 0
    weighted = f * p if per_octave else p
    k = int(np.flatnonzero(band)[np.argmax(weighted[band])])
    peak_f = _refine_peak(f, p, k, resolution)
    floor = float(np.median(p[f > 0]))
    prominence = float(p[k] / floor) if floor > 0 else np.inf
    noise_std = float(np.sqrt(floor * u.fs_hz / 2))
    low, high = band & (f < f[k]), band & (f > f[k])
    # a resonance falls below half of itself on both sides inside the band; a drift (or the staircase a tracker
    # leaves holding its value in a quiet tail) only rises toward the band's edge
    peak = weighted[k]
    resonant = bool(low.any() and high.any() and weighted[low].min() < 0.5 * peak and weighted[high].min() < 0.5 * peak)
    return Spectrum(
        f,
        p,
        u.fs_hz,
        seg,
        nfft,
        n_avg,
        resolution,
        u.note,
        peak_f,
        float(f[k]),
        float(p[k]),
        prominence,
        noise_std,
        _secondary_peaks(f, p, k, peak_f, resolution),
        resonant,
    )


LEAN_WELCH_SAMPLES = 1 << 18
"""Segments this long (a record of over half a million samples) are transformed one at a time by `_lean_welch`:
SciPy's welch holds every segment detrended, windowed, padded and transformed at once, some 60 bytes per sample."""

BLOCK = 1 << 18
"""Samples detrended and windowed at a time by `_lean_welch`."""


def _lean_welch(y: np.ndarray, fs_hz: float, seg: int, nfft: int) -> tuple[np.ndarray, np.ndarray]:
    """SciPy's welch (Hann window, 50 % overlap, linear detrend per segment, density scaling, one-sided) computed one
    segment at a time and the segment in blocks, so that it holds one padded segment and its transform, not all of
    them; equal to SciPy's up to rounding (the detrending line from closed-form sums, not a least-squares solver)."""
    step = seg - seg // 2
    n_seg = 1 + (y.size - seg) // step
    i = np.arange(1, seg + 1, dtype=float) / seg  # SciPy's detrend regresses on (1..N)/N
    i_mean = float(np.mean(i))
    i_var = float(np.dot(i - i_mean, i - i_mean))
    del i
    win_sq = 0.0
    psd = np.zeros(nfft // 2 + 1)
    for k in range(n_seg):
        x = y[k * step : k * step + seg]
        x_mean = float(np.mean(x))
        cov = 0.0
        for a in range(0, seg, BLOCK):
            b = min(a + BLOCK, seg)
            cov += float(np.dot(np.arange(a + 1, b + 1, dtype=float) / seg - i_mean, x[a:b] - x_mean))
        slope = cov / i_var
        buf = np.zeros(nfft)  # the zero-padded segment, freed once transformed
        for a in range(0, seg, BLOCK):
            b = min(a + BLOCK, seg)
            win = _hann(seg, a, b)
            if k == 0:
                win_sq += float(np.dot(win, win))
            line = x_mean + slope * (np.arange(a + 1, b + 1, dtype=float) / seg - i_mean)
            buf[a:b] = win * (x[a:b] - line)
        spec = sp_fft.rfft(buf)
        del buf
        for a in range(0, spec.size, BLOCK):
            part = spec[a : a + BLOCK]
            psd[a : a + BLOCK] += part.real**2 + part.imag**2
        del spec
    psd *= 1.0 / (fs_hz * win_sq) / n_seg
    psd[1 : -1 if nfft % 2 == 0 else None] *= 2
    return sp_fft.rfftfreq(nfft, 1 / fs_hz), psd


def _hann(n: int, a: int, b: int) -> np.ndarray:
    """Samples a..b-1 of the periodic Hann window of length n (SciPy's get_window("hann", n))."""
    return 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(a, b, dtype=float) / n)


def _pow2(n: int) -> int:
    """The smallest power of two >= n."""
    return 1 << int(np.ceil(np.log2(n)))


def _refine_peak(f: np.ndarray, p: np.ndarray, k: int, resolution: float) -> float:
    """Vertex of a parabola fitted to log PSD over the peak's top (within half a resolution of the maximum bin)."""
    near = np.flatnonzero((np.abs(f - f[k]) <= 0.5 * resolution) & (p > 0))
    if near.size < 3:
        return float(f[k])
    c2, c1, _ = np.polyfit(f[near] - f[k], np.log(p[near]), 2)
    if c2 >= 0:
        return float(f[k])
    shift = -c1 / (2 * c2)
    return float(f[k] + np.clip(shift, -0.5 * resolution, 0.5 * resolution))


def _secondary_peaks(f: np.ndarray, p: np.ndarray, k: int, f0: float, resolution: float) -> tuple[SpectralPeak, ...]:
    """Other local maxima at least 2 resolutions from the dominant one, strongest first, marked when harmonic."""
    # peaks too weak to be listed are left out before the distance rule, which only ever drops the weaker of two
    # neighbours: the same list, without millions of noise peaks in a long record's spectrum
    idx, _ = sps.find_peaks(p, height=SECONDARY_MIN_RATIO * p[k], distance=max(1, round(resolution / (f[1] - f[0]))))
    # a long record's noise floor may lie above that fraction of a short ring-down's peak: its candidates are
    # ranked as arrays and only the six listed become objects
    idx = idx[~((np.abs(f[idx] - f[k]) < 2 * resolution) | (f[idx] < 1.5 * resolution))]
    idx = idx[np.argsort(-p[idx], kind="stable")[:6]]  # strongest first, ties in frequency order
    out = []
    for i in idx:
        order = round(f[i] / f0)
        harmonic = order if order >= 2 and abs(f[i] - order * f0) <= resolution else 0
        out.append(SpectralPeak(float(f[i]), float(p[i]), float(p[i] / p[k]), harmonic))
    return tuple(out)
