"""Find the free-decay part of a recording: after the last excitation, where the mode rings down on its own."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage
from scipy import signal as sps

from sloshid.core.errors import SettingError, UserError
from sloshid.core.spectrum import to_uniform, welch_spectrum
from sloshid.core.tables import GAP_STEP_FACTOR
from sloshid.identification.signals import Signal

SEGMENT_S = 4.0
"""Length of the segments scanned for the rough mode frequency (several periods of any lab sloshing mode)."""

ACTIVE_FLOOR = 0.01
"""A segment counts as active only above this fraction of the strongest segment's spread (-40 dB): below it lie
quantisation steps and tracker hold-levels, not a mode a fit could use (a ring-down is fitted to 3 noise sd)."""

ROUGH_PROMINENCE = 30.0
"""A segment's peak counts first for the rough mode frequency when it stands this many times above the median of the
segment's spectrum: in a single 4-s periodogram noise alone reaches 10-13 times (its 100-250 bins), so a record
whose quiet segments are active only through a slow sway does not hand the guess to a noise peak."""

FORCED_RATIO = 0.5
"""A one-period mean that moves by more than this fraction of the oscillation amplitude means forced motion."""

SLOW_ZERO_NOISE = 3.0
"""A signal's zero counts as moving slowly when, after the ringing has faded, its one-period mean moves by more than
this many noise standard deviations (white noise moves it by some 3 sd / sqrt(samples per period), tracker noise
correlated from frame to frame up to twice that: 2 sd triggered on one of 60 clean random records, at 30 fps)
and by more than ACTIVE_FLOOR of the largest swing (a tracker's hold levels, thousandths of a degree, do not count):
the oscillation is then measured without that slow part, and the fit follows the zero with a spline."""

SLOW_CUTOFF = 0.5
"""The swing about a moving zero is measured on the signal minus its part below this fraction of the mode's
frequency (`_slow_part`): that keeps a sway and its harmonics up to 0.35 f (98.6 %; 94 % at 0.4 f: a cutoff of 0.3 f
let a tilting container's harmonics pass for ringing) and passes 0.02 % of the mode and 0.6 % of a second mode at
0.77 f (a tilted container's), where a running mean over one period would take in half of one."""

SPLINE_CUTOFF = 0.2
"""A constant-zero fit's residual shows a moving zero when its part below this fraction of the mode's frequency moves:
what the spline zero can follow (it leaves 3 % of a sway at 0.15 f, 17 % at 0.2 f); faster leftovers (a swirl, the
nonlinear crests of wall heights) are not a zero a spline could fit."""

SWAY_FACTOR = 2.0
"""... and by more than this multiple of how far it moves once the ringing has faded: a slow motion that goes on
after the ring-down (a container swaying on its stand, a camera that wobbles, a container tilting in the picture)
is not what excited the mode, and it reaches as far during the ring-down as after it (twice its reach from the
final level, which may sit at one end of the sway)."""

START_SEARCH_PERIODS = 2
"""After the detected end of forced motion the window starts at the largest swing within this many periods:
the fading tail of the forcing still drives the liquid, and a damped liquid loses signal with every period."""

ONSET_FRACTION = 0.3
"""Without forcing, the window starts at the first sample swinging past this fraction of the largest swing."""

MOVING_ONSET_FRACTION = 0.7
"""... or, about a zero that moves slowly, this fraction: its low-pass part reaches a few periods ahead into the
ring-down, so before the onset the signal strays from it by up to half the first swing. On 60 seeded swaying tap
tests no window started before the tap, the median 0.03 s after it (the largest swing alone: 0.13 s, one crest later,
and zeta's coverage 86 % instead of 93 %)."""

END_NOISE_FACTOR = 3.0
"""The window ends where the oscillation amplitude falls below this many noise standard deviations (pure noise
shows about 1.7 on the half-range measure used) ..."""

QUIET_PERIODS = 2
"""... and stays there for this many periods, so one quiet dip in a beating decay does not end it."""

TAIL_TIME_CONSTANTS = 2.0
"""When two modes beat (the first quiet stretch may be a beat's null), the window is extended this many decay time
constants 1/(zeta omega) past it: for a ring-down starting at 20 noise sd about 30 % of the Fisher information on
the decay rate lies beyond the 3-noise-sd fade, and two time constants further on only about 2 % remains."""

GAP_PERIODS = 0.25
"""A gap in the samples (lost frames) longer than this many mode periods is no evidence of forcing or of a fade:
the uniform grid's straight line across it moves the running period mean and has no swing. On a tracked 2.5 Hz decay
a 0.3 s gap at 4 s started the window after it (4.63 instead of 0.90 s, f's interval ten times wider)."""

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
    slow_motion: float = 0.0
    """How far the signal's zero (its one-period mean, the mode averaged out) moves, when that counts as moving
    (SLOW_ZERO_NOISE): from its final level once the ringing has faded, or in the residual of a constant-zero fit of
    the window (`residual_wander`); 0 when it stays within noise."""
    near_mode_noise: float = 0.0
    """The noise level (standard deviation) near the mode the window was chosen against, when the broadband level
    found no ring-down in noise correlated from sample to sample (`Spectrum.noise_near_mode`); 0 otherwise."""

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
    peaks = []  # (frequency, is a resonance, prominence) of each active segment, last first
    for k in active[::-1]:
        if f_range_hz[0] < u.fs_hz / 2:  # the band has frequencies below Nyquist
            part = slice(starts[k], starts[k] + n_seg)
            spec = welch_spectrum(u.t_s[part], u.value[part], f_range_hz, nperseg=n_seg, per_octave=True)
            peaks.append((spec.peak_f_hz, spec.resonant, spec.prominence))
    # the last segments whose peak is a resonance well above noise, else any resonance; without any (pure noise), the
    # last ones as they are
    strong = [f for f, resonant, p in peaks if resonant and p >= ROUGH_PROMINENCE][:3]
    freqs = strong or [f for f, resonant, _ in peaks if resonant][:3] or [f for f, _, _ in peaks[:3]]
    if not freqs:
        raise UserError(f"{sig.source}: no frequency in the search range {f_range_hz[0]:g}-{f_range_hz[1]:g} Hz.")
    return float(np.median(freqs))


def period_mean(t: np.ndarray, y: np.ndarray, period_s: float) -> np.ndarray:
    """Running mean over exactly one period (fractional ends from the interpolated running integral), which
    cancels the mode and all its harmonics even with few samples per period; ends are held at the edge value."""
    # the arithmetic of (interp(lo + T) - interp(lo)) / T on the running sum of 0.5 (y[1:] + y[:-1]) dt, a block at a
    # time (the sum carried from block to block, in order): a long record holds two arrays of its length here
    integral = np.empty(t.size)
    integral[0] = 0.0
    for a in range(0, t.size - 1, SWING_BLOCK):
        b = min(a + SWING_BLOCK, t.size - 1)
        area = y[a + 1 : b + 1] + y[a:b]
        area *= 0.5
        area *= np.diff(t[a : b + 1])
        if a:
            area[0] += integral[a]
        np.cumsum(area, out=integral[a + 1 : b + 1])
    mean = np.empty(t.size)
    for a in range(0, t.size, SWING_BLOCK):
        b = min(a + SWING_BLOCK, t.size)
        lo = t[a:b] - period_s / 2
        np.clip(lo, t[0], t[-1] - period_s, out=lo)
        part = np.interp(lo + period_s, t, integral)
        part -= np.interp(lo, t, integral)
        part /= period_s
        mean[a:b] = part
    return mean


def _forcing(sig: Signal, f_guess_hz: float, noise_std: float, drift: bool, mean_noise: float | None):
    """The record's levels and where it was driven: (uniform signal, samples per period, amplitude (without a swaying
    zero), resting level, slow zero, its reach, whether it moves, samples in gaps, indices of forced samples)."""
    u, n, amp, rest, dev = _levels(sig, f_guess_hz, drift)
    mean_noise = noise_std / np.sqrt(n) if mean_noise is None else mean_noise
    slow, free, reach, moving = _zero_motion(u, n, amp, dev, f_guess_hz, noise_std)
    # an offset counts as forcing only if it is large against the noise, the record's biggest swing and its offsets,
    # and against the slow motion that goes on after the ring-down
    floor = max(0.2 * float(dev.max()), 0.1 * float(amp.max()), 5 * mean_noise, SWAY_FACTOR * reach * moving)
    if moving:  # the zero sways: the oscillation is judged without it
        amp = free
    else:  # neither is read again: a long record's arrays go now
        slow = None
    del free
    gap = _in_gaps(sig.t_s, u.t_s, 1.0 / f_guess_hz)
    limit = FORCED_RATIO * amp
    np.maximum(limit, floor, out=limit)
    forced = np.flatnonzero(dev > limit)
    del limit
    forced = forced[(forced >= n) & (forced < dev.size - n)]  # running means are padded at the edges: no evidence
    # nor are they across a gap (lost frames), where the grid holds a straight line: its mean strays, its swing is 0
    forced = forced[~_near(gap, n)[forced]]
    return u, n, amp, rest, slow, reach, moving, gap, forced


def find_decay_window(
    sig: Signal, f_guess_hz: float, noise_std: float, drift: bool = False, mean_noise: float | None = None
) -> DecayWindow:
    """Automatic window: from the largest swing just after the last forced motion (or in the record) to where it fades.

    Forced motion shows as a one-period running mean (which cancels the mode and its harmonics) that departs from
    the final resting level by more than half the ringing amplitude and by more than the noise: 5 times `mean_noise`,
    the spread noise leaves in that mean (white noise's by default, noise_std / sqrt(samples per period)).
    """
    u, n, amp, rest, slow, reach, moving, gap, forced = _forcing(sig, f_guess_hz, noise_std, drift, mean_noise)
    if forced.size:
        i_end = int(forced[-1])
        excitation_end = float(u.t_s[i_end])
        lo = min(u.value.size - 1, i_end + n)
        i0 = lo + int(np.argmax(amp[lo : i_end + START_SEARCH_PERIODS * n + 1]))
    else:
        excitation_end = None
        peak = int(np.argmax(amp[: max(1, amp.size - 3 * n)]))
        lo = max(0, peak - n)  # the running measures lag the onset; step back to the first large sample
        if moving:  # about the swaying zero, whose low-pass reaches ahead into the ring-down: the samples before the
            # onset stray from it too, if less than the first crests do
            about = np.abs(u.value - slow)[lo : peak + 1]
            i0 = lo + int(np.argmax(about >= MOVING_ONSET_FRACTION * about.max()))
        else:
            swing = np.abs(u.value[lo : peak + 1] - rest)
            i0 = lo + int(np.argmax(swing > ONSET_FRACTION * swing.max()))
    quiet = amp <= END_NOISE_FACTOR * noise_std
    quiet = (quiet & ~_near(gap & ~_quiet_around(gap, quiet), n))[i0:]
    # quiet samples in each stretch of QUIET_PERIODS periods, as differences of their running count (whole numbers:
    # the same as a convolution with ones, in two arrays of 4-byte counts instead of three of 8-byte ones)
    count = np.zeros(quiet.size + 1, np.int32 if quiet.size < 2**31 else np.int64)
    np.cumsum(quiet, out=count[1:])
    stretch = QUIET_PERIODS * n
    run = count[stretch:] - count[:-stretch] if quiet.size >= stretch else count[:0]
    fades = np.flatnonzero(run == stretch)
    i1 = min(i0 + int(fades[0]) + n // 2, u.value.size - 1) if fades.size else u.value.size - 1
    return DecayWindow(float(u.t_s[i0]), float(u.t_s[i1]), "auto", excitation_end, f_guess_hz, reach * moving)


def _in_gaps(t: np.ndarray, grid: np.ndarray, period_s: float) -> np.ndarray:
    """Which points of the uniform `grid` lie inside a gap of the samples `t` (lost frames: a step over 1.5 times the
    median and over GAP_PERIODS of the mode's period), where `to_uniform` interpolated a straight line. A frame or
    two dropped here and there (an encoder's repeated pictures) leave steps too short to bend the running measures."""
    limit = max(GAP_STEP_FACTOR * float(np.median(np.diff(t), overwrite_input=True)), GAP_PERIODS * period_s)
    if not np.diff(t).max(initial=0.0) > limit:  # no gap: spare the per-point look-ups (arrays as long as the record)
        return np.zeros(grid.shape, bool)
    dt = np.diff(t)
    k = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, dt.size - 1)
    long = dt[k] > limit
    return long & (grid > t[k]) & (grid < t[k] + dt[k])


def _quiet_around(gap: np.ndarray, quiet: np.ndarray) -> np.ndarray:
    """The gap points whose gap is quiet on both sides (the grid points just before and after it): a still float the
    encoder repeats, whose frames are invalid; a gap in a ringing signal (a float hidden for a while) is not a fade."""
    edges = np.flatnonzero(np.diff(gap.astype(np.int8)))  # the last point before a change
    out = np.zeros_like(gap)
    starts = edges[gap[edges + 1]] + 1 if edges.size else edges
    for a in starts:
        b = a + int(np.argmin(gap[a:])) if not gap[a:].all() else gap.size
        out[a:b] = quiet[max(a - 1, 0)] and quiet[min(b, gap.size - 1)]
    return out


def _near(mask: np.ndarray, n: int) -> np.ndarray:
    """The mask widened by n samples each way: the running measures over one period (n samples) see that far."""
    if not mask.any():  # nothing to widen (a record without gaps): no filter buffering the whole line in doubles
        return np.zeros(mask.shape, bool)
    return ndimage.maximum_filter1d(mask.astype(np.uint8), 2 * n + 1, mode="constant").astype(bool)


def _levels(sig: Signal, f_guess_hz: float, drift: bool):
    """The signal on a uniform grid, samples per period n, the oscillation's swing per sample, the final resting level
    of its one-period mean (which cancels the mode) and that mean's distance from it (from its straight line with
    `drift`)."""
    u = to_uniform(sig.t_s, sig.value)
    n = _period_samples(u.fs_hz, f_guess_hz)
    slow = period_mean(u.t_s, u.value, 1.0 / f_guess_hz)
    if drift:  # a zero that creeps steadily is not forcing: measure departures from its straight line
        slow = slow - np.polyval(np.polyfit(u.t_s, slow, 1), u.t_s)
    rest = float(np.median(slow[-max(n, slow.size // 5) :]))
    return u, n, _swing(u.value, n), rest, np.abs(slow - rest)


def _zero_motion(u, n: int, amp: np.ndarray, dev: np.ndarray, f_guess_hz: float, noise_std: float):
    """The signal's slow part (`_slow_part`), the swing about it, how far the zero moves once the ringing has faded,
    and whether that counts as moving (SLOW_ZERO_NOISE), from `_levels`' grid, period, swing and distances. Below
    that count nothing changes: a reach the noise could explain is no evidence of a sway (a window chosen with it
    then, about a final level the sway has shifted, started before the tap or in the tail, rated good)."""
    slow = _slow_part(u.value, u.fs_hz, SLOW_CUTOFF * f_guess_hz)
    free = _swing(u.value, n, minus=slow)
    reach = _reach_after_fade(dev, free, n, noise_std)
    return slow, free, reach, reach > _moving_floor(noise_std, float(amp.max()))


def _moving_floor(noise_std: float, swing: float) -> float:
    """How far a zero must move to count as moving (SLOW_ZERO_NOISE)."""
    return max(SLOW_ZERO_NOISE * noise_std, ACTIVE_FLOOR * swing)


def moving_zero(win: DecayWindow) -> bool:
    """The signal's zero moves slowly (a sway after the ring-down), beyond noise and hold levels (SLOW_ZERO_NOISE)."""
    return win.slow_motion > 0


def residual_wander(t_s: np.ndarray, resid: np.ndarray, f_hz: float, noise_std: float, swing: float) -> float:
    """How far the slow part (`_slow_part`, two periods from either end, where the filter settles) of a constant-zero
    fit's residual strays from its median, when that counts as a moving zero (SLOW_ZERO_NOISE; `swing`: the mode's
    fitted amplitude), else 0: a window without a quiet tail, or one the user gave, can still hold a moving zero (a
    sway; on wall heights, the mean level that large, nonlinear swings lift and that sinks as they decay). A second
    mode left in the residual does not count: it lies far above the slow part's band."""
    u = to_uniform(t_s, resid)
    n = _period_samples(u.fs_hz, f_hz)
    slow = _slow_part(u.value, u.fs_hz, SPLINE_CUTOFF * f_hz)[2 * n : -2 * n]
    wander = float(np.abs(slow - np.median(slow)).max()) if slow.size else 0.0
    return wander if wander > _moving_floor(noise_std, swing) else 0.0


def without_slow_motion(sig: Signal, f_hz: float) -> Signal:
    """`sig` minus its slow part (`_slow_part`): a slow motion of its zero taken out, for spectra and starting values
    (computed on a uniform grid and read back at the signal's own times)."""
    u = to_uniform(sig.t_s, sig.value)
    return replace(sig, value=sig.value - np.interp(sig.t_s, u.t_s, _slow_part(u.value, u.fs_hz, SLOW_CUTOFF * f_hz)))


def _slow_part(y: np.ndarray, fs_hz: float, cutoff_hz: float) -> np.ndarray:
    """The part of uniformly sampled `y` below `cutoff_hz`: a zero-phase 6th-order Butterworth low-pass (SciPy's
    sosfiltfilt), padded by three cutoff periods of odd reflection so that its ends settle."""
    sos = sps.butter(6, min(cutoff_hz, 0.45 * fs_hz), fs=fs_hz, output="sos")
    if y.size <= 3 * (2 * len(sos) + 1):  # too short for sosfiltfilt's edge padding: its mean
        return np.full(y.shape, float(np.mean(y)))
    padlen = min(y.size - 1, round(3 * fs_hz / cutoff_hz))
    if y.size <= SWING_BLOCK or padlen < 1:
        return sps.sosfiltfilt(sos, y, padlen=padlen)
    return _sosfiltfilt_blocks(sos, y, padlen)


def _sosfiltfilt_blocks(sos: np.ndarray, y: np.ndarray, padlen: int) -> np.ndarray:
    """SciPy's sosfiltfilt (odd padding of `padlen`) run a block at a time, the filter's state carried from block to
    block: the same numbers, holding one output array instead of the padded signal and three filtered copies."""
    zi = sps.sosfilt_zi(sos)
    pieces = [2 * y[0] - y[padlen:0:-1]]  # SciPy's odd extension at either end
    pieces += [y[a : a + SWING_BLOCK] for a in range(0, y.size, SWING_BLOCK)]
    pieces.append(2 * y[-1] - y[-2 : -(padlen + 2) : -1])
    out = np.empty(y.size + 2 * padlen)
    state, at = zi * pieces[0][0], 0
    for piece in pieces:  # forward
        out[at : at + piece.size], state = sps.sosfilt(sos, piece, zi=state)
        at += piece.size
    state = zi * out[-1]
    for b in range(out.size, 0, -SWING_BLOCK):  # backward, in place, from the end
        a = max(b - SWING_BLOCK, 0)
        back, state = sps.sosfilt(sos, out[a:b][::-1], zi=state)
        out[a:b] = back[::-1]
    return out[padlen:-padlen]


def _reach_after_fade(dev: np.ndarray, free: np.ndarray, n: int, noise_std: float) -> float:
    """How far the one-period mean (`dev`: its distance from the final level) moves after the oscillation (`free`:
    its swing without the slow motion) last stood well above the fade level (RISE_FACTOR times it: noise correlated
    from frame to frame crosses the fade level itself now and then) and above ACTIVE_FLOOR of its largest swing (a
    noise-free trace has no noise level to fade to); 0 without such a tail of QUIET_PERIODS periods (the record ends
    ringing, or never rings)."""
    level = max(RISE_FACTOR * END_NOISE_FACTOR * noise_std, ACTIVE_FLOOR * float(free.max()))
    loud = np.flatnonzero(free[: dev.size - 2 * n] > level)  # the twiced mean and the swing reach 2 periods
    if loud.size == 0:
        return 0.0
    tail = dev[int(loud[-1]) + n : dev.size - n]  # running means are padded at the edges: no evidence
    return float(tail.max()) if tail.size >= QUIET_PERIODS * n else 0.0


def _period_samples(fs_hz: float, f_hz: float) -> int:
    """Samples in one mode period (at least 3): the length of every running measure here."""
    return max(3, round(fs_hz / f_hz))


SWING_BLOCK = 1 << 18
"""Samples of a long record whose running max and min `_swing` takes at a time (SciPy's filters buffer a whole line)."""


def _swing(y: np.ndarray, n: int, minus: np.ndarray | None = None) -> np.ndarray:
    """Oscillation amplitude per sample: half the max-min range over one period (n samples), smoothed over one more;
    of y - minus when that is given (without a copy of the difference)."""

    def span(lo: int, hi: int) -> np.ndarray:
        """The max-min range at samples lo..hi-1: a running max or min is local, so a block with a period's margin
        each side gives the same numbers as the whole line."""
        a, b = max(lo - n, 0), min(hi + n, y.size)
        x = y[a:b] if minus is None else y[a:b] - minus[a:b]
        ext = ndimage.maximum_filter1d(x, n, mode="nearest")
        ext -= ndimage.minimum_filter1d(x, n, mode="nearest")
        return ext[lo - a : hi - a]

    if y.size <= SWING_BLOCK:
        swing = ndimage.uniform_filter1d(span(0, y.size), n, mode="nearest")
    else:  # the range is made block by block as the running mean reaches it, never as a whole array
        swing = _running_mean(span, y.size, n)
    swing /= 2
    return swing


def _running_mean(values: Callable[[int, int], np.ndarray], size: int, n: int) -> np.ndarray:
    """SciPy's uniform_filter1d(x, n, mode="nearest") of the `size` samples that values(lo, hi) gives as x[lo:hi], a
    block at a time: its running sum (each step adds the entering sample's difference from the leaving one, in order)
    carried from block to block, divided by n at the end: the same numbers, without the two line buffers of the
    record's length that SciPy allocates."""
    left, right, last = n // 2, n - n // 2 - 1, size - 1
    out = np.empty(size)
    head = values(0, min(right + 1, size))
    carry = float(np.cumsum(head[np.clip(np.arange(-left, right + 1), 0, last)])[-1])  # the first window, in order
    out[0] = carry
    for a in range(1, size, SWING_BLOCK):
        b = min(a + SWING_BLOCK, size)
        at = np.arange(a, b)
        lo, hi = max(a - left - 1, 0), min(b - 1 + right, last) + 1
        x = values(lo, hi)
        step = x[np.clip(at + right, 0, last) - lo] - x[np.clip(at - left - 1, 0, last) - lo]
        step[0] += carry
        np.cumsum(step, out=out[a:b])
        carry = float(out[b - 1])
    out /= n
    return out


def extend_tail(sig: Signal, win: DecayWindow, f_hz: float, decay_rate_1_s: float, noise_std: float) -> DecayWindow:
    """The automatic window carried TAIL_TIME_CONSTANTS decay time constants past its fade, stopping early before the
    signal swings well above the fade level again (a later disturbance) and at the end of the data."""
    u = to_uniform(sig.t_s, sig.value)
    n = _period_samples(u.fs_hz, f_hz)
    amp = _swing(u.value, n)
    i1 = int(np.searchsorted(u.t_s, win.t1_s))
    rise = np.flatnonzero(amp[i1:] > RISE_FACTOR * END_NOISE_FACTOR * noise_std)
    stop = u.t_s[min(i1 + int(rise[0]) - n, u.t_s.size - 1)] if rise.size else u.t_s[-1]
    t1 = min(win.t1_s + TAIL_TIME_CONSTANTS / max(decay_rate_1_s, 1e-9), float(stop))
    return replace(win, t1_s=max(win.t1_s, t1))


def rings_above(sig: Signal, win: DecayWindow, f_hz: float, noise_std: float) -> bool:
    """The window's ring-down starts above the fade level: its largest swing in the window's first two periods exceeds
    END_NOISE_FACTOR times `noise_std` (pure noise shows about 1.7 on this measure)."""
    u = to_uniform(sig.t_s, sig.value)
    n = _period_samples(u.fs_hz, f_hz)
    i0 = int(np.searchsorted(u.t_s, win.t0_s))
    first = _swing(u.value, n)[i0 : i0 + 2 * n]
    return bool(first.size) and float(first.max()) > END_NOISE_FACTOR * noise_std


def user_window(
    sig: Signal,
    t0: float,
    t1: float,
    f_guess_hz: float,
    noise_std: float,
    drift: bool,
    mean_noise: float | None = None,
) -> DecayWindow:
    """A window given by the user, checked to lie inside the data, with the record's slow motion as for the automatic
    window, and as `excitation_end_s` the last forced sample inside the window (None when it holds none: a window
    that holds forcing is judged uncertain; a forcing before or after it, such as a second tap, does not count)."""
    lo, hi = float(sig.t_s[0]), float(sig.t_s[-1])
    if not t0 < t1:
        raise SettingError("window_s", f"{{name}} start {t0:g} s must be before its end {t1:g} s.")
    # a window that ends within a sample of the data ends with it: the one identify prints, rounded to 0.01 s, does
    dt = float(np.median(np.diff(sig.t_s)))
    t0, t1 = (lo if lo - dt <= t0 < lo else t0), (hi if hi < t1 <= hi + dt else t1)
    if t0 < lo - 1e-9 or t1 > hi + 1e-9:
        raise SettingError(
            "window_s", f"{{name}} {t0:g},{t1:g} s reaches beyond the data of {sig.source} ({lo:g} to {hi:g} s)."
        )
    u, _, _, _, _, reach, moving, _, forced = _forcing(sig, f_guess_hz, noise_std, drift, mean_noise)
    inside = u.t_s[forced][(u.t_s[forced] >= t0) & (u.t_s[forced] <= t1)]
    end = float(inside.max()) if inside.size else None
    return DecayWindow(float(t0), float(t1), "user", end, f_guess_hz, reach * moving)
