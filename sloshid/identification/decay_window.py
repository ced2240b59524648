"""Find the free-decay part of a recording: after the last excitation, where the mode rings down on its own."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy import signal as sps

from sloshid.core.errors import SettingError, UserError
from sloshid.core.spectrum import to_uniform, welch_spectrum
from sloshid.identification.signals import Signal

SEGMENT_S = 4.0
"""Length of the segments scanned for the rough mode frequency (several periods of any lab sloshing mode)."""

ACTIVE_FLOOR = 0.01
"""A segment counts as active only above this fraction of the strongest segment's spread (-40 dB): below it lie
quantisation steps and tracker hold-levels, not a mode a fit could use (a ring-down is fitted to 3 noise sd)."""

FORCED_RATIO = 0.5
"""A one-period mean that moves by more than this fraction of the oscillation amplitude means forced motion."""

START_SEARCH_PERIODS = 2
"""After the detected end of forced motion the window starts at the largest swing within this many periods:
the fading tail of the forcing still drives the liquid, and a damped liquid loses signal with every period."""

ONSET_FRACTION = 0.3
"""Without forcing, the window starts at the first sample swinging past this fraction of the largest swing."""

END_NOISE_FACTOR = 3.0
"""The window ends where the oscillation amplitude falls below this many noise standard deviations (pure noise
shows about 1.7 on the half-range measure used) ..."""

QUIET_PERIODS = 2
"""... and stays there for this many periods, so one quiet dip in a beating decay does not end it."""

TAIL_TIME_CONSTANTS = 2.0
"""When two modes beat (the first quiet stretch may be a beat's null), the window is extended this many decay time
constants 1/(zeta omega) past it: for a ring-down starting at 20 noise sd about 30 % of the Fisher information on
the decay rate lies beyond the 3-noise-sd fade, and two time constants further on only about 2 % remains."""

RISE_FACTOR = 2.0
"""The tail extension stops where the swing climbs above this multiple of the fade level (END_NOISE_FACTOR noise sd):
a new disturbance, not the ring-down's own low tail that hovers around the fade level."""


@dataclass(frozen=True)
class DecayWindow:
    """The time span fitted, and how it was chosen."""

    t0_s: float
    t1_s: float
    chosen_by: str
    """'auto' or 'user'."""
    excitation_end_s: float | None
    """Last time the record was driven (quasi-static offset larger than the ringing), None when never."""
    f_guess_hz: float

    @property
    def duration_s(self) -> float:
        """Window length in seconds."""
        return self.t1_s - self.t0_s


def rough_mode_frequency(sig: Signal, f_range_hz: tuple[float, float]) -> float:
    """Dominant frequency of the last active segments (the ring-down comes after any forced motion).

    Peaks are picked on f * PSD (power per octave) so that a slow drift of the resting level does not win."""
    u = to_uniform(sig.t_s, sig.value)
    if np.ptp(u.value) == 0:
        raise UserError(f"{sig.source}: '{sig.label}' is constant, so there is no oscillation to identify.")
    n_seg = min(u.value.size, round(SEGMENT_S * u.fs_hz))
    step = max(1, round(u.fs_hz))
    starts = list(range(0, u.value.size - n_seg + 1, step)) or [0]
    stds = np.array([np.std(sps.detrend(u.value[s : s + n_seg])) for s in starts])
    # active: 3x the quietest segment (noise), and at least ACTIVE_FLOOR of the strongest (a tracker holding its
    # value in a quiet tail leaves steps of a thousandth of the swing that beat a near-zero noise floor)
    active = np.flatnonzero(stds >= max(3 * stds.min(), ACTIVE_FLOOR * stds.max()))
    if active.size == 0:
        active = np.arange(len(starts))
    peaks = []  # (frequency, is a resonance) of each active segment, last first
    for k in active[::-1]:
        if f_range_hz[0] < u.fs_hz / 2:  # the band has frequencies below Nyquist
            part = slice(starts[k], starts[k] + n_seg)
            spec = welch_spectrum(u.t_s[part], u.value[part], f_range_hz, nperseg=n_seg, per_octave=True)
            peaks.append((spec.peak_f_hz, spec.resonant))
    # the last segments whose peak is a resonance; without any (pure noise), the last ones as they are
    freqs = [f for f, resonant in peaks if resonant][:3] or [f for f, _ in peaks[:3]]
    if not freqs:
        raise UserError(f"{sig.source}: no frequency in the search range {f_range_hz[0]:g}-{f_range_hz[1]:g} Hz.")
    return float(np.median(freqs))


def period_mean(t: np.ndarray, y: np.ndarray, period_s: float) -> np.ndarray:
    """Running mean over exactly one period (fractional ends from the interpolated running integral), which
    cancels the mode and all its harmonics even with few samples per period; ends are held at the edge value."""
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])
    lo = np.clip(t - period_s / 2, t[0], t[-1] - period_s)
    return (np.interp(lo + period_s, t, integral) - np.interp(lo, t, integral)) / period_s


def find_decay_window(sig: Signal, f_guess_hz: float, noise_std: float, drift: bool = False) -> DecayWindow:
    """Automatic window: from the largest swing just after the last forced motion (or in the record) to where it fades.

    Forced motion shows as a one-period running mean (which cancels the mode and its harmonics) that departs from
    the final resting level by more than half the ringing amplitude and by more than the noise.
    """
    u = to_uniform(sig.t_s, sig.value)
    n = max(3, round(u.fs_hz / f_guess_hz))
    slow = period_mean(u.t_s, u.value, 1.0 / f_guess_hz)
    amp = _swing(u.value, n)
    if drift:  # a zero that creeps steadily is not forcing: measure departures from its straight line
        slow = slow - np.polyval(np.polyfit(u.t_s, slow, 1), u.t_s)
    rest = float(np.median(slow[-max(n, slow.size // 5) :]))
    dev = np.abs(slow - rest)
    # an offset counts as forcing only if it is large against the noise, the record's biggest swing and its offsets
    floor = max(0.2 * float(dev.max()), 0.1 * float(amp.max()), 5 * noise_std / np.sqrt(n))
    forced = np.flatnonzero(dev > np.maximum(FORCED_RATIO * amp, floor))
    forced = forced[(forced >= n) & (forced < dev.size - n)]  # running means are padded at the edges: no evidence
    if forced.size:
        i_end = int(forced[-1])
        excitation_end = float(u.t_s[i_end])
        lo = min(u.value.size - 1, i_end + n)
        i0 = lo + int(np.argmax(amp[lo : i_end + START_SEARCH_PERIODS * n + 1]))
    else:
        excitation_end = None
        peak = int(np.argmax(amp[: max(1, amp.size - 3 * n)]))
        lo = max(0, peak - n)  # the running measures lag the onset; step back to the first large sample
        swing = np.abs(u.value[lo : peak + 1] - rest)
        i0 = lo + int(np.argmax(swing > ONSET_FRACTION * swing.max()))
    quiet = (amp[i0:] <= END_NOISE_FACTOR * noise_std).astype(int)
    run = np.convolve(quiet, np.ones(QUIET_PERIODS * n, int), mode="valid")  # quiet samples in each stretch
    fades = np.flatnonzero(run == QUIET_PERIODS * n)
    i1 = min(i0 + int(fades[0]) + n // 2, u.value.size - 1) if fades.size else u.value.size - 1
    return DecayWindow(float(u.t_s[i0]), float(u.t_s[i1]), "auto", excitation_end, f_guess_hz)


def _swing(y: np.ndarray, n: int) -> np.ndarray:
    """Oscillation amplitude per sample: half the max-min range over one period (n samples), smoothed over one more."""
    span = ndimage.maximum_filter1d(y, n, mode="nearest") - ndimage.minimum_filter1d(y, n, mode="nearest")
    return ndimage.uniform_filter1d(span, n, mode="nearest") / 2


def extend_tail(sig: Signal, win: DecayWindow, f_hz: float, decay_rate_1_s: float, noise_std: float) -> DecayWindow:
    """The automatic window carried TAIL_TIME_CONSTANTS decay time constants past its fade, stopping early before the
    signal swings well above the fade level again (a later disturbance) and at the end of the data."""
    u = to_uniform(sig.t_s, sig.value)
    n = max(3, round(u.fs_hz / f_hz))
    amp = _swing(u.value, n)
    i1 = int(np.searchsorted(u.t_s, win.t1_s))
    rise = np.flatnonzero(amp[i1:] > RISE_FACTOR * END_NOISE_FACTOR * noise_std)
    stop = u.t_s[min(i1 + int(rise[0]) - n, u.t_s.size - 1)] if rise.size else u.t_s[-1]
    t1 = min(win.t1_s + TAIL_TIME_CONSTANTS / max(decay_rate_1_s, 1e-9), float(stop))
    return DecayWindow(win.t0_s, max(win.t1_s, t1), win.chosen_by, win.excitation_end_s, win.f_guess_hz)


def user_window(sig: Signal, t0: float, t1: float, f_guess_hz: float) -> DecayWindow:
    """A window given by the user, checked to lie inside the data."""
    lo, hi = float(sig.t_s[0]), float(sig.t_s[-1])
    if not t0 < t1:
        raise SettingError("window_s", f"{{name}} start {t0:g} s must be before its end {t1:g} s.")
    if t0 < lo - 1e-9 or t1 > hi + 1e-9:
        raise SettingError(
            "window_s", f"{{name}} {t0:g},{t1:g} s lies outside the data of {sig.source} ({lo:g} to {hi:g} s)."
        )
    return DecayWindow(float(t0), float(t1), "user", None, f_guess_hz)
