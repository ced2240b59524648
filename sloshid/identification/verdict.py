"""The identification verdict, per parameter group and overall: `good`, `uncertain` or `unreliable`, each with the
reasons behind it. The frequency group (f, omega, l) is what the planner needs most; the damping group (zeta, d)
is set by the envelope's shape and is doubted by anything that bends it (misfit, disagreeing decrement)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from sloshid.core.spectrum import Spectrum
from sloshid.core.tables import distinct_names
from sloshid.identification.crosschecks import CrossCheck
from sloshid.identification.decay_window import DecayWindow
from sloshid.identification.pt2fit import PT2Fit, autocorrelation
from sloshid.identification.second_mode import SecondMode, strong_peaks
from sloshid.identification.signals import Signal

LEVELS = ("good", "uncertain", "unreliable")
"""Verdicts from best to worst; a group takes the worst of its reasons, the overall verdict the worst group's."""
GROUPS = {"frequency": ("f_hz", "omega_rad_s", "l_m"), "damping": ("zeta", "d_ns_per_m")}
"""Which parameters each group's verdict applies to."""
PARAMETER_LABELS = {
    "f_hz": ("natural frequency f", "Hz"),
    "omega_rad_s": ("angular frequency omega", "rad/s"),
    "zeta": ("damping ratio zeta", "-"),
    "l_m": ("pendulum length l", "m"),
    "d_ns_per_m": ("damping constant d", "N s/m"),
    "m_kg": ("liquid mass m", "kg"),
}
"""Human label and unit of each parameter key, for tables."""
AMPLITUDE_SNR = 3.0
"""A fitted amplitude less than this many standard errors above zero is barely distinguishable from noise."""
CROSS_CHECK_MIN_PERIODS = 8.0
"""A cross-check built on fewer (effective) mode periods than this is shown but does not sway the verdict."""
CROSS_CHECK_F_TOL = 0.02
"""Frequencies of independent methods on at least 8 periods agree to a fraction of a Welch bin, far inside 2 %."""
LOG_DECREMENT_FACTOR = 1.5
"""The peak-based decrement reads zeta up to ~25 % low on noisy synthetic decays (noise lifts the late, small
peaks); a factor 1.5 apart, beyond the fit's own 95 % interval, is disagreement, not that bias."""
MISFIT_P = 0.01
"""Significance of the two residual tests: not white (Ljung-Box) and larger where the oscillation is larger."""


@dataclass(frozen=True)
class GroupVerdict:
    """One group's verdict and its reasons (empty when good)."""

    quality: str
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class Verdict:
    """Per-group verdicts, the overall one (the worst group), and notes that inform without doubting."""

    groups: dict[str, GroupVerdict]
    notes: list[str]

    @property
    def quality(self) -> str:
        """The overall verdict: the worst group's."""
        return max((g.quality for g in self.groups.values()), key=LEVELS.index)

    @property
    def reasons(self) -> list[str]:
        """Every group's reasons, each once, frequency first."""
        return list(dict.fromkeys(r for g in self.groups.values() for r in g.reasons))


@dataclass(frozen=True)
class VerdictInput:
    """Everything the verdict weighs, from one identification."""

    signals: list[Signal]
    windows: list[DecayWindow]
    spectra: list[Spectrum]
    fit: PT2Fit
    parameters: dict[str, Any]
    """Name -> Estimate (value, stderr, ci95)."""
    cross_checks: list[list[CrossCheck]]
    ljung_box: list[float]
    fit_percent: list[float]
    min_fit_percent: float
    min_periods: float
    second_mode_ratio: float
    second: SecondMode | None = None
    prior: dict[str, Any] = field(default_factory=dict)
    """The geometric prior (empty without container geometry); its presence settles which peak is the first mode."""
    band_hz: tuple[float, float] | None = None
    """The band searched for the mode (--f-range, narrowed by the prior)."""
    between: Any = None
    """Several signals: their agreement fitted alone (`between.BetweenSignals`), or None."""


class _Doubts:
    """Collects (level, reason) per group."""

    def __init__(self) -> None:
        self.items: dict[str, list[tuple[str, str]]] = {g: [] for g in GROUPS}

    def add(self, groups: tuple[str, ...], level: str, reason: str) -> None:
        """Count one reason, at one level, against each of the named groups."""
        for g in groups:
            self.items[g].append((level, reason))

    def verdict(self, notes: list[str]) -> Verdict:
        """Each group takes the worst level among its reasons (good without any)."""
        out = {}
        for g, found in self.items.items():
            worst = max((lvl for lvl, _ in found), key=LEVELS.index, default="good")
            out[g] = GroupVerdict(worst, tuple(dict.fromkeys(r for _, r in found)))
        return Verdict(out, notes)


BOTH = ("frequency", "damping")
LOST_SHARE_MAX = 0.4
"""A larger share of lost or invalid samples makes both groups uncertain: the intervals held on seeded traces with 5-30 %
lost at random or in bursts, and a video that loses more usually loses them for the angle (a 3 Hz float tracked in a
colour range it half left kept 43 % of its frames and fitted 1.95 Hz, 'good', with an interval that missed 3 Hz)."""


def residual_grows_p(resid: np.ndarray, lags: int) -> float:
    """One-sided F-test p-value that the residual variance in the window's first third exceeds that in its last
    third (degrees of freedom shrunk by the residual's correlation over `lags`, Bartlett weights). Measurement noise
    is stationary; a residual that fades with the ring-down is the mode misfitted (nonlinear crests, a frequency
    that drifts with amplitude), which bends the envelope and so the damping."""
    k = resid.size // 3
    if k < 8:
        return 1.0
    ratio = float(np.mean(resid[:k] ** 2) / max(np.mean(resid[-k:] ** 2), 1e-300))
    acf = autocorrelation(resid, lags)[1:]
    weights = 1 - np.arange(1, lags + 1) / (lags + 1)
    dof = k / max(1.0, 1 + 2 * float(np.sum(weights * acf)))
    return float(stats.f.sf(ratio, dof, dof))


def judge(inp: VerdictInput) -> Verdict:
    """The verdict: a group is `good` unless a reason doubts its numbers beyond their intervals (a merely wide interval
    is honest and only noted); `unreliable` when the number is probably not what it claims to be."""
    doubts, notes = _Doubts(), []
    fit, f = inp.fit, inp.parameters["f_hz"].value
    f2 = fit.second.omega_rad_s / (2 * math.pi) if fit.second else None
    if inp.second is not None and inp.second.separated and fit.second is not None:  # a separated mode was fitted
        notes.append(
            f"a second mode at {f2:.4g} Hz (zeta {fit.second.zeta:.2g}) was fitted beside the main one; "
            f"the main mode's numbers account for it."
        )
    names = distinct_names([sig.source for sig in inp.signals])
    for i in range(len(inp.signals)):
        _judge_signal(inp, i, names[i], f, f2, doubts, notes)
    _judge_bounds(inp, doubts, notes)
    _judge_mode_choice(inp, f, f2, doubts)
    _judge_between(inp, f, doubts)
    return doubts.verdict(notes)


RUN_SPREAD = 0.05
"""Jointly identified runs whose 95 % prediction interval of f reaches more than this share of f either side make the
frequency uncertain: a move planned for one f then meets liquids outside compare's default 5 % margin."""


def _judge_between(inp: VerdictInput, f: float, doubts: _Doubts) -> None:
    """Runs that ring at different frequencies when fitted alone: one joint damping fits none of them, and one joint
    frequency is no liquid's when they spread widely."""
    b = inp.between
    if b is None or not b.omega.disagree:
        return
    lo, hi = (v / (2 * math.pi) for v in b.omega.prediction95)
    f_lo, f_hi = (v / (2 * math.pi) for v in (min(b.omega.values), max(b.omega.values)))
    doubts.add(
        ("damping",),
        "uncertain",
        f"the signals ring at different frequencies when fitted alone ({f_lo:.4g}-{f_hi:.4g} Hz, beyond their own "
        "intervals): one joint damping, fitted across them, fits none of them; identify them apart.",
    )
    if max(f - lo, hi - f) > RUN_SPREAD * f:
        doubts.add(
            ("frequency",),
            "uncertain",
            f"the signals ring at {f_lo:.4g}-{f_hi:.4g} Hz when fitted alone, and one more run may land in "
            f"{lo:.4g}-{hi:.4g} Hz, more than {100 * RUN_SPREAD:g} % from the joint {f:.4g} Hz: different liquids or "
            "fills? Identify them apart.",
        )


CLIP_RUN = 3
"""Samples in a row at the window's extreme value that make a peak flat: a clipped one, at two peaks or more, when a
smooth peak's top would not hold one value that long (QUANTUM_RUNS)."""
QUANTUM_RUNS = 2.0
"""A quantised record (a logger's whole millimetres) holds a smooth peak's top value for as long as the swing stays
within one step of it: 2 sqrt(2 q / A) / omega. A flat top counts as clipped only beyond this many times that (a
review: a 1 Hz decay of 20 whole mm at 100 Hz, zeta 0.002, held its top for some 10 samples at two peaks and was
called clipped)."""


def clipped_at(values: np.ndarray, f_hz: float, rate_hz: float) -> tuple[float, int] | None:
    """(level, peaks) when at least two peaks of `values` (a mode at `f_hz` sampled at `rate_hz`) stop flat at its
    maximum or its minimum for longer than a smooth, quantised peak would (CLIP_RUN, QUANTUM_RUNS), else None."""
    if values.size < 2:
        return None
    steps = np.diff(np.unique(values))
    quantum, swing = float(steps.min()) if steps.size else 0.0, 0.5 * float(values.max() - values.min())
    if swing <= 0:
        return None
    top = 2 * math.sqrt(2 * quantum / swing) / (2 * math.pi * f_hz) * rate_hz  # samples a smooth top holds a value
    for level in (float(values.max()), float(values.min())):
        at = np.abs(values - level) <= 1e-9 * max(1.0, abs(level))
        edges = np.diff(np.concatenate([[0], at.astype(np.int8), [0]]))
        runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
        peaks = int(np.count_nonzero(runs >= max(CLIP_RUN, QUANTUM_RUNS * top)))
        if peaks >= 2:
            return level, peaks
    return None


def _judge_signal(inp: VerdictInput, i: int, name: str, f: float, f2: float | None, doubts: _Doubts, notes) -> None:
    """The doubts one signal's window raises."""
    fit = inp.fit
    if inp.fit_percent[i] < inp.min_fit_percent:
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: fit {inp.fit_percent[i]:.1f} % is below {inp.min_fit_percent:g} %: noise, or a trace that is "
            "not the liquid's angle alone; check the tracked angle in the report (another colour range if frames "
            "were lost or jump), or fit its clean decay (`window_s`).",
        )
    periods = inp.windows[i].duration_s * f
    if periods < inp.min_periods:
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: only {periods:.1f} periods in the window (fewer than {inp.min_periods:g}); record a longer "
            "decay (a stronger tap rings longer) or give a longer window (`window_s`).",
        )
    # a peak the fitted second mode accounts for (within one bin) is no longer a doubt; any other one is
    strong = [
        p
        for p in strong_peaks(inp.spectra[i], inp.second_mode_ratio, f)
        if f2 is None or abs(p.f_hz - f2) > inp.spectra[i].resolution_hz
    ]
    if strong:
        p, second = strong[0], inp.second
        why = "; ".join(second.problems) if second is not None and not second.separated else ""
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: strong second mode at {p.f_hz:.3g} Hz ({100 * p.relative:.0f} % of the main peak's PSD)"
            + (f" that a two-mode fit could not separate ({why})" if why else "")
            + "; give `f_range_hz` around the mode you want, or the container geometry to pick the first mode.",
        )
    if inp.windows[i].near_mode_noise:
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: the noise is correlated from sample to sample ({inp.windows[i].near_mode_noise:.3g} standard "
            "deviation near the mode, several times its broadband level): the window was chosen against that level, "
            "and the fit, which assumes little correlation, can be off by more than its intervals; check the window "
            "in the report or give it yourself (`window_s`).",
        )
    w = inp.windows[i]
    sig = inp.signals[i]
    clipped = clipped_at(sig.value[(sig.t_s >= w.t0_s) & (sig.t_s <= w.t1_s)], f, sig.rate_hz)
    if clipped is not None:
        level, peaks = clipped
        doubts.add(
            ("damping",),
            "unreliable",
            f"{name}: {peaks} peaks stop flat at {level:.6g} {sig.unit}".rstrip()
            + ": the signal is clipped (a saturated sensor, a float or surface at the end of its range), and a cut "
            "swing decays more slowly than the mode does; fit a window after the clipping ends (`window_s`).",
        )
    if w.chosen_by == "user" and w.excitation_end_s is not None and w.t0_s < w.excitation_end_s:
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: the given window starts at {w.t0_s:g} s, before the forced motion in it ends (at about "
            f"{w.excitation_end_s:.2f} s): the fit reads a driven response as a free decay; start it after that "
            "(`window_s`).",
        )
    if sig.n_dropped:
        lost = sig.n_dropped / (sig.n_dropped + sig.t_s.size)
        notes.append(
            f"{name}: {sig.n_dropped} samples ({100 * lost:.0f} %) were lost or invalid and are left out; the fit and "
            "its intervals use the measured ones alone (on seeded traces with 5-30 % lost at random or in bursts the "
            "95 % intervals held), unless they were lost for a reason tied to the angle (a float leaving its colour "
            "range when tilted most): then look at the tracked angle, or track with another colour range."
        )
        if lost > LOST_SHARE_MAX:
            doubts.add(
                BOTH,
                "uncertain",
                f"{name}: {100 * lost:.0f} % of the samples were lost or invalid, past the 30 % on which the intervals "
                "were checked; so many are seldom lost at random (a float leaves its colour range at some angles, and "
                "the kept ones then misread the swing): track with another colour range until most frames are valid.",
            )
    snr = fit.amplitude(i) / fit.amplitude_se(i)
    if snr < AMPLITUDE_SNR:
        doubts.add(
            BOTH,
            "uncertain",
            f"{name}: the fitted amplitude is only {snr:.1f} standard errors above zero; tap harder, or film closer "
            "or at a higher frame rate, so that the swing stands out of the noise.",
        )
    _judge_residual(inp, i, name, doubts, notes)
    _judge_cross_checks(inp, i, name, f, doubts)


def _judge_residual(inp: VerdictInput, i: int, name: str, doubts: _Doubts, notes: list[str]) -> None:
    """Correlated residuals widen the intervals (handled); residuals that fade with the mode are misfit (a doubt)."""
    lb, lags = inp.ljung_box[i], inp.fit.hac_lags[i]
    if not lb < MISFIT_P:
        return
    p_grow = residual_grows_p(inp.fit.residuals[i], lags)
    if p_grow < MISFIT_P:
        doubts.add(
            ("damping",),
            "uncertain",
            f"{name}: the residual is not white (Ljung-Box p = {lb:.2g}) and fades with the oscillation (p = "
            f"{p_grow:.2g}): the model misfits the mode, which bends the envelope the damping is read from; fit a later "
            "window with smaller swings (`window_s`), or tap more gently so that the slosh stays linear.",
        )
    else:
        notes.append(
            f"{name}: residuals are not white (Ljung-Box p = {lb:.2g}) but stationary like measurement noise; the "
            f"intervals are corrected for correlation over {lags} lags."
        )


def _judge_cross_checks(inp: VerdictInput, i: int, name: str, f: float, doubts: _Doubts) -> None:
    """Independent methods that disagree beyond their own accuracy."""
    z = inp.parameters["zeta"]
    for c in inp.cross_checks[i]:
        if c.n_periods < CROSS_CHECK_MIN_PERIODS:
            continue
        if math.isfinite(c.f_hz) and abs(c.f_hz - f) > CROSS_CHECK_F_TOL * f:
            doubts.add(
                ("frequency",),
                "uncertain",
                f"{name}: {c.method} gives f = {c.f_hz:.4g} Hz, more than 2 % from the fit's {f:.4g} Hz; check the "
                "window and the tracked trace in the report (lost or mis-tracked frames), or give the window (`window_s`).",
            )
        if c.method == "logarithmic decrement" and math.isfinite(c.zeta):
            outside = not z.ci95[0] <= c.zeta <= z.ci95[1]
            far = not z.value / LOG_DECREMENT_FACTOR <= c.zeta <= z.value * LOG_DECREMENT_FACTOR
            if outside and far:
                doubts.add(
                    ("damping",),
                    "uncertain",
                    f"{name}: the logarithmic decrement gives zeta = {c.zeta:.2g}, outside the fit's 95 % interval "
                    f"{z.ci95[0]:.2g}-{z.ci95[1]:.2g} and more than a factor {LOG_DECREMENT_FACTOR:g} from {z.value:.2g}; "
                    "give the window yourself where the decay is clean (`window_s`), or record a longer decay.",
                )


def _judge_bounds(inp: VerdictInput, doubts: _Doubts, notes: list[str]) -> None:
    """Parameters that ended on their search bounds, and a damping that cannot be told from zero."""
    fit = inp.fit
    for name in fit.at_bound:
        if name == "zeta" and fit.zeta < 0.5:  # the lower bound: no decay, or a growing amplitude, in the window
            doubts.add(
                ("damping",),
                "unreliable",
                "zeta ended on its search bound 0: the oscillation does not decay in the window (no free decay); "
                "fit a window after the excitation ends (`window_s`).",
            )
        elif name == "omega":
            doubts.add(("frequency",), "unreliable", "omega ended on its search bound; widen the band (`f_range_hz`).")
        else:
            doubts.add(
                BOTH,
                "uncertain",
                f"{name} ended on its search bound; check that the window holds one free decay (`window_s`).",
            )
    z = inp.parameters["zeta"]
    if "zeta" not in fit.at_bound and z.ci95[0] <= 0:  # a wide but valid interval: reported, not a doubt
        notes.append(
            f"zeta = {z.value:.2g} ± {z.stderr:.2g} cannot be told from zero: the amplitude barely decays in the window."
        )


def _judge_mode_choice(inp: VerdictInput, f: float, f2: float | None, doubts: _Doubts) -> None:
    """Is the identified mode the first one, and the one searched for? With geometry the prior's band decides;
    without it, a fit whose interval lies outside the searched band followed another mode, and a strong mode below
    the reported one competes (the first sloshing mode is the lowest)."""
    ci = inp.parameters["f_hz"].ci95  # a mode at the band's edge may be fitted a hair beyond it
    if not inp.prior and inp.band_hz is not None and (ci[1] < inp.band_hz[0] or ci[0] > inp.band_hz[1]):
        lo, hi = inp.band_hz
        doubts.add(
            ("frequency",),
            "unreliable",
            f"f = {f:.4g} Hz lies outside the searched band {lo:g}-{hi:g} Hz (`f_range_hz`): the fit found a mode outside "
            "it, not one inside (to fit a mode beside a stronger one, give `window_s` where it rings alone).",
        )
    if inp.prior:
        lo, hi = inp.prior["band_hz"]
        if not lo <= f <= hi:
            doubts.add(
                ("frequency",),
                "unreliable",
                f"f = {f:.4g} Hz lies outside {lo:.3g}-{hi:.3g} Hz, the band where the container's first mode "
                f"({inp.prior['f_hz']:.3g} Hz) is nearer than its second azimuthal mode: not the first mode; check "
                "the container's radius and fill, or fit where the first mode rings (`window_s`, `f_range_hz`).",
            )
        return
    lower = [f2] if f2 is not None and f2 < f else []
    for sp in inp.spectra:
        lower += [p.f_hz for p in strong_peaks(sp, inp.second_mode_ratio, f) if p.f_hz < f]
    if lower:
        doubts.add(
            ("frequency",),
            "uncertain",
            f"a strong mode at {min(lower):.3g} Hz lies below the reported {f:.4g} Hz: the first sloshing mode is the "
            "lowest, so the reported one may be a higher mode; give the container geometry to pick the first.",
        )
