"""Identification estimator: signals in, sloshing frequency, damping, pendulum length and damping constant out,
each with an honest 95 % interval and a good/uncertain verdict (scikit-learn style: configure, fit, read `result_`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats
from tqdm import tqdm

from sloshid import __version__
from sloshid.core.errors import SettingError, UserError
from sloshid.core.hashing import file_sha256
from sloshid.core.settings import check_in_metres, setting_field
from sloshid.core.spectrum import MIN_PROMINENCE, Spectrum, welch_spectrum
from sloshid.core.tables import PROGRESS_DELAY_S, distinct_names, to_pandas
from sloshid.identification.between import BetweenSignals, between_signals
from sloshid.identification.crosschecks import CrossCheck, half_power, hilbert_envelope, log_decrement
from sloshid.identification.decay_window import (
    DecayWindow,
    extend_tail,
    find_decay_window,
    moving_zero,
    residual_wander,
    rings_above,
    rough_mode_frequency,
    user_window,
    without_slow_motion,
)
from sloshid.identification.estimates import Estimate, estimate
from sloshid.identification.pt2fit import (
    Z95,
    ZETA_BOUNDS,
    PT2Fit,
    WindowData,
    autocorrelation,
    codec_zeta_share,
    fit_pt2,
    fit_pt2_hold,
    fit_pt2_shrink,
    with_codec_share,
)
from sloshid.identification.second_mode import SecondMode, resolve_second_mode, strong_peaks
from sloshid.identification.signals import Signal, load_signal
from sloshid.identification.verdict import AMPLITUDE_SNR, GROUPS, GroupVerdict, VerdictInput, judge
from sloshid.model.pendulum import (
    XI_CYLINDER_SECOND,
    G,
    SloshParams,
    cylinder_first_mode_omega,
    linear_tf,
    linear_tf_coeffs,
)

MIN_PERIODS_ERROR = 3.0
CORRELATED_NOISE_RATIO = 2.0
"""Noise near the mode at least this many times its broadband level (`Spectrum.noise_near_mode`) is correlated: an
automatic window that found no ring-down is then sought against it. White noise's ratio scatters about 1 (a Welch
median over dozens of bins: a few percent); noise correlated over ten samples (AR(1), 0.9) gives about 3."""
SLOW_KNOT_PERIODS = 2.0
"""Largest knot spacing of a slow zero's spline, in mode periods (`zero_columns` spaces them evenly, 1-2 periods): it
follows a sway well up to about a seventh of the mode's frequency (it leaves 0.4 % of a sway at 0.1 f, 3 % at 0.15 f,
17 % at 0.2 f); the mode, fitted beside it, costs about 2 % of f's standard error to it when there is no sway."""
NO_MODE_SNR = 5.0
"""A window whose PSD shows no clear resonance is still accepted when the fitted decay stands this many standard
errors out and reaches the minimum fit % (short, strongly damped ring-downs give coarse Welch spectra);
otherwise there is no mode, only noise."""


class NotFittedError(RuntimeError):
    """Raised when results are asked of an Identifier before fit() was called."""


MAX_MASS_KG = 1e4
"""Largest liquid mass taken: ten tonnes, a road tanker's compartment; 1e308 kg made the damping constant infinite."""
MAX_MIN_PERIODS = 1000.0
"""Largest `min_periods` taken: a 3 Hz liquid ringing for five minutes; more than any free decay holds, so that every
verdict would be uncertain (1e9 was taken without a word)."""


@dataclass(frozen=True)
class IdentSettings:
    """How to identify (all optional; defaults suit tracker traces and wall-height sensors alike)."""

    mass_kg: float | None = setting_field(None, unit="kg", option="mass", metavar="KG")
    """Liquid mass m; needed for the damping constant d = 2 m omega zeta (seed Table I uses 0.5 kg)."""
    window_s: tuple[float, float] | None = setting_field(None, unit="s", option="window", metavar="T0,T1")
    """Fit window (t0, t1) in the signals' own seconds; not given: the free decay is found automatically."""
    f_range_hz: tuple[float, float] = setting_field((0.5, 30.0), unit="Hz", option="f-range", metavar="LO,HI")
    """Frequency band searched for the sloshing mode."""
    drift: bool = False
    """Also fit a slow linear drift of the signal's zero (e.g. a float creeping across the surface)."""
    min_fit_percent: float = setting_field(15.0, unit="%", option="min-fit", metavar="PERCENT")
    """Below this NRMSE fit % the mode does not dominate the window and the verdict is uncertain. Fit % scores
    the whole waveform: clean tracker angles reach 80-99 %, wall-height sensors with nonlinear crests 35-65 %."""
    min_periods: float = setting_field(4.0, unit="periods", metavar="N")
    """Fewer decay periods than this in a window make the verdict uncertain (fewer than 3 is an error): 3 to 1000."""
    second_mode_ratio: float = setting_field(0.25, metavar="RATIO")
    """A non-harmonic PSD peak above this fraction (above 0, at most 1) of the dominant one counts as a strong second
    mode (-6 dB): it is fitted as a second damped mode, and only when the data cannot separate the two is the verdict
    uncertain."""
    container_radius_m: float | None = setting_field(None, unit="m", metavar="M")
    """Cylinder radius R for the analytic first-mode prior (needs `fill_height_m`)."""
    fill_height_m: float | None = setting_field(None, unit="m", metavar="M")
    """Liquid fill height h for the prior."""

    def __post_init__(self) -> None:
        if self.mass_kg is not None and not (math.isfinite(self.mass_kg) and 0 < self.mass_kg <= MAX_MASS_KG):
            raise SettingError(
                "mass_kg", f"{{name}} must be a positive number of kg up to {MAX_MASS_KG:g}, got {self.mass_kg!r}."
            )
        if self.window_s is not None and not all(map(math.isfinite, self.window_s)):
            raise SettingError("window_s", f"{{name}} must be two numbers of seconds, got {self.window_s!r}.")
        if self.window_s is not None and not self.window_s[0] < self.window_s[1]:
            w0, w1 = self.window_s
            raise SettingError("window_s", f"{{name}} start {w0:g} s must be before its end {w1:g} s.")
        lo, hi = self.f_range_hz
        if not (0 < lo < hi and math.isfinite(hi)):
            raise SettingError(
                "f_range_hz", f"{{name}} must be two increasing finite positive frequencies in Hz, got {lo:g},{hi:g}."
            )
        if not 0 <= self.min_fit_percent < 100:
            raise SettingError("min_fit_percent", f"{{name}} must be in [0, 100), got {self.min_fit_percent:g}.")
        if not MIN_PERIODS_ERROR <= self.min_periods <= MAX_MIN_PERIODS:  # a NaN fails it too
            raise SettingError(
                "min_periods",
                f"{{name}} must be between {MIN_PERIODS_ERROR:g} and {MAX_MIN_PERIODS:g} periods (a window of fewer than "
                f"{MIN_PERIODS_ERROR:g} is an error in any case), got {self.min_periods:g}.",
            )
        if not 0 < self.second_mode_ratio <= 1:
            raise SettingError(
                "second_mode_ratio",
                f"{{name}} is a fraction of the dominant PSD peak, above 0 and at most 1, got {self.second_mode_ratio:g}.",
            )
        if (self.container_radius_m is None) != (self.fill_height_m is None):
            missing = "fill_height_m" if self.fill_height_m is None else "container_radius_m"
            raise SettingError(
                missing, "the geometric prior needs both the container radius and the fill height; give {name} too."
            )
        radius, fill = self.container_radius_m, self.fill_height_m
        if radius is not None and fill is not None and not (radius > 0 and fill > 0):
            bad = "container_radius_m" if not radius > 0 else "fill_height_m"
            raise SettingError(bad, f"{{name}} must be positive (m), got {getattr(self, bad):g}.")
        for key in ("container_radius_m", "fill_height_m"):
            check_in_metres(key, getattr(self, key))  # millimetres typed as metres move the prior a 30-fold


def estimates_table(parameters: dict[str, Estimate]):
    """Estimates as a pandas table: one row each with value, standard error and 95 % interval."""
    return to_pandas(
        {
            "parameter": list(parameters),
            "value": [e.value for e in parameters.values()],
            "stderr": [e.stderr for e in parameters.values()],
            "ci95_lo": [e.ci95[0] for e in parameters.values()],
            "ci95_hi": [e.ci95[1] for e in parameters.values()],
        }
    )


def ljung_box_p(resid: np.ndarray, lags: int) -> float:
    """Ljung-Box portmanteau p-value for whiteness of residuals over `lags` lags (chi^2 with `lags` dof)."""
    n = resid.size
    acf = autocorrelation(resid, lags)[1:]
    q = n * (n + 2) * np.sum(acf**2 / (n - np.arange(1, lags + 1)))
    return float(stats.chi2.sf(q, lags))


@dataclass(kw_only=True)
class IdentResult:
    """Everything `identify` found: parameters with intervals, the windows and spectra behind them, the verdict."""

    signals: list[Signal]
    windows: list[DecayWindow]
    spectra: list[Spectrum]
    fit: PT2Fit
    cross_checks: list[list[CrossCheck]]
    parameters: dict[str, Estimate]
    quality: str
    reasons: list[str]
    notes: list[str]
    mass_kg: float | None
    prior: dict[str, Any] = field(default_factory=dict)
    ljung_box: list[float] = field(default_factory=list)
    lb_lags: list[int] = field(default_factory=list)
    second_mode: SecondMode | None = None
    """The two-mode fit tried for a strong second PSD peak (None when no PSD showed one)."""
    groups: dict[str, GroupVerdict] = field(default_factory=dict)
    """Verdict per parameter group: 'frequency' (f, omega, l) and 'damping' (zeta, d); `quality` is the worst."""
    between: BetweenSignals | None = None
    """Several signals: whether they agree on f and zeta when fitted alone (the intervals are widened when not)."""

    def parameter_verdict(self, name: str) -> GroupVerdict | None:
        """The verdict of the group parameter `name` belongs to (None for given values such as the mass)."""
        group = next((g for g, names in GROUPS.items() if name in names), None)
        return self.groups.get(group) if group else None

    @property
    def frequency_band_hz(self) -> tuple[float, float]:
        """The band of f a move must hold over: the 95 % interval, or, when jointly identified runs disagreed, where
        one more run may land (the between-signal prediction interval, as `IdentifiedFrequency` reads the JSON)."""
        if self.between is not None and self.between.omega.disagree:
            lo, hi = self.between.omega.prediction95
            return lo / (2 * math.pi), hi / (2 * math.pi)
        return self.parameters["f_hz"].ci95

    @property
    def params(self) -> SloshParams:
        """The pendulum model for the planner (mass 1 kg when none was given; the dynamics only need d/m)."""
        return SloshParams.from_modal(self.fit.omega_rad_s, self.fit.zeta, self.mass_kg or 1.0)

    @property
    def tf(self):
        """Seed eq. 5 as a python-control transfer function: surface angle (rad) per container acceleration (m/s^2)."""
        return linear_tf(self.params)

    def fit_percent(self, i: int) -> float:
        """NRMSE fit % of signal i's window."""
        return self.fit.fit_percent(i, self.window_signal(i).value)

    def window_signal(self, i: int) -> Signal:
        """Signal i restricted to its fit window."""
        return self.signals[i].between(self.windows[i].t0_s, self.windows[i].t1_s)

    def to_dict(self) -> dict[str, Any]:
        """The `sloshid identify` JSON (schema: docs/reference/formats.md; read back by SloshParams.from_identify_json). Long, but it
        is the file's schema written out in one place, which is easier to check than pieces."""
        num, den = linear_tf_coeffs(self.params)
        params = {}
        for k, v in self.parameters.items():
            params[k] = v.to_dict()
            group = self.parameter_verdict(k)
            if group is not None:
                params[k].update(quality=group.quality, reasons=list(group.reasons))
        if self.mass_kg is not None:
            params["m_kg"] = {"value": self.mass_kg}
        per_signal = []
        for i, sig in enumerate(self.signals):
            per_signal.append(
                {
                    "source": sig.source,
                    "label": sig.label,
                    "unit": sig.unit,
                    "fit_percent": self.fit_percent(i),
                    "amplitude": self.fit.amplitude(i),
                    "amplitude_stderr": self.fit.amplitude_se(i),
                    "offset": float(self.fit.linear[i][2]),
                    "drift_per_s": float(self.fit.linear[i][3]) if self.fit.drift and not self.fit.slow_s else None,
                    "rms_residual": float(np.sqrt(np.mean(self.fit.residuals[i] ** 2))),
                    "ljung_box_p": self.ljung_box[i],
                    "ljung_box_lags": self.lb_lags[i],
                    "hac_lags": self.fit.hac_lags[i],
                    "n_samples": int(self.fit.residuals[i].size),
                    "sampling": sig.sampling(),
                }
            )
        inflation = math.sqrt(self.fit.cov[0, 0] / self.fit.cov_naive[0, 0]) if self.fit.cov_naive[0, 0] > 0 else None
        if inflation is not None and self.between is not None:  # the residual's correction alone, not the runs' spread
            inflation /= self.between.widened[0]
        return {
            "sloshid_version": __version__,
            "sources": [s.source for s in self.signals],
            # the files' contents too: validate tells a run the model was fitted on wherever the file is found from
            "source_sha256": [file_sha256(s.source) if Path(s.source).is_file() else None for s in self.signals],
            "window_s": [[w.t0_s, w.t1_s] for w in self.windows],
            "window_chosen_by": [w.chosen_by for w in self.windows],
            "quality": self.quality,
            "reasons": list(self.reasons),
            "notes": list(self.notes),
            "parameters": params,
            "transfer_function": {
                "num": num,
                "den": den,
                "input": "container acceleration (m/s^2)",
                "output": "surface angle (rad)",
            },
            "psd": {
                "peak_f_hz": float(np.median([s.peak_f_hz for s in self.spectra])),
                "per_signal": [s.to_dict() for s in self.spectra],
            },
            "cross_checks": {
                "pt2_fit": {"f_hz": self.parameters["f_hz"].value, "zeta": self.parameters["zeta"].value},
                "per_signal": [[c.to_dict() for c in cc] for cc in self.cross_checks],
            },
            "second_mode": self.second_mode.to_dict() if self.second_mode is not None else None,
            "fit": {
                "model": "a exp(-zeta omega t) cos(omega sqrt(1-zeta^2) t + phase) + "
                + (
                    _spline_zero(self.fit.slow_s)
                    if self.fit.slow_s
                    else "offset" + (" + drift t" if self.fit.drift else "")
                )
                + (" + a2 exp(-zeta2 omega2 t) cos(omega2 sqrt(1-zeta2^2) t + phase2)" if self.fit.second else ""),
                "fit_percent": float(np.mean([self.fit_percent(i) for i in range(len(self.signals))])),
                "ljung_box_p": float(min(self.ljung_box)),
                "interval_method": "Newey-West sandwich (VAR(1) prewhitened, Bartlett kernel) on the least-squares "
                "Jacobian; delta method for derived values; normal 95 % quantile"
                + (
                    "; the fitted encoder hold's width is one of the parameters, and the shift from a plain fit is "
                    "added as a systematic standard error; the values are the plain and held fits averaged by the "
                    "hold's Akaike weight, the interval widened to hold the held fit's; zeta's shifts in a refit "
                    "with the codec's shrink of every swing and with that shrink one residual rms larger are "
                    "systematic errors too"
                    if self.fit.hold is not None
                    else ""
                ),
                "encoder_hold": None
                if self.fit.hold is None
                else {
                    "half_width": self.fit.hold.width,
                    "half_width_stderr": self.fit.hold.width_se,
                    "restarts_at_key_frames": self.fit.hold.restarts,
                    "unit": self.signals[0].unit,
                    "shift_from_plain_fit": dict(zip(("omega_rad_s", "zeta"), self.fit.hold.shift.tolist())),
                    "weight": self.fit.hold.weight,
                    "shrink": self.fit.hold.shrink,
                    "zeta_shift_from_shrink": self.fit.hold.shrink_shift,
                    "zeta_hidden_shrink": self.fit.hold.shrink_hidden,
                    "plain_fit_stderr": dict(
                        zip(("omega_rad_s", "zeta"), np.sqrt(np.diag(self.fit.hold.plain_cov)).tolist())
                    ),
                },
                "slow_zero": None
                if self.fit.slow_s is None
                else {
                    "knot_spacing_s": self.fit.slow_s,
                    "moves_by": [w.slow_motion for w in self.windows],
                },
                "stderr_inflation_vs_white": inflation,
                "between_signals": self.between.to_dict() if self.between else None,
                "n_starts": self.fit.n_starts,
                "per_signal": per_signal,
            },
            "prior": dict(self.prior),
        }

    def summary(self) -> str:
        """Readable multi-line summary for stdout."""
        lines = [f"sloshid identify: {len(self.signals)} signal(s)"]
        for sig, w in zip(self.signals, self.windows):
            lines.append(
                f"  {sig.source}: {sig.label} [{sig.unit or 'no unit'}], window {w.t0_s:.2f}-{w.t1_s:.2f} s ({w.chosen_by})"
            )
        units = {"f_hz": "Hz", "omega_rad_s": "rad/s", "zeta": "", "l_m": "m", "d_ns_per_m": "N s/m"}
        for key, est in self.parameters.items():
            lines.append(
                f"  {key:<12} = {est.shown()} ± {est.stderr:.2g} {units.get(key, '')}  (95 % CI {est.interval()})"
            )
        if self.mass_kg is not None:
            lines.append(f"  {'m_kg':<12} = {self.mass_kg:g} kg (given)")
        if self.prior:
            lines.append(
                f"  geometric prior (cylinder): f = {self.prior['f_hz']:.4g} Hz, identified/prior = "
                f"{self.prior['identified_over_prior']:.3f}"
            )
        if self.second_mode is not None:
            lines.append(f"  {self.second_mode.summary()}")
        fits = ", ".join(f"{self.fit_percent(i):.1f}" for i in range(len(self.signals)))
        lines.append(f"  fit % (NRMSE): {fits}")
        if self.between is not None:
            lines.append(f"  {self.between.summary()}")
        if self.fit.slow_s:
            lines.append(f"  zero: moves slowly, fitted as {_spline_zero(self.fit.slow_s)}")
        if self.fit.hold is not None:
            h = self.fit.hold
            shift_f, shift_z = 100 * h.shift / np.array([self.fit.omega_rad_s, self.fit.zeta or 1.0])
            lines.append(
                f"  encoder hold (fitted, video-tracked): half-width {h.width:.3g} ± {h.width_se:.2g} "
                f"{self.signals[0].unit}, restarting at {h.restarts} key frames; f {shift_f:+.3f} %, zeta "
                f"{shift_z:+.2f} % against a plain fit, taken at weight {h.weight:.2f} by the evidence for the hold"
            )
            lines.append(
                f"  codec shrink (refit, widens zeta's interval): {h.shrink:.3g} {self.signals[0].unit} off every "
                f"swing moves zeta {100 * h.shrink_shift / (self.fit.zeta or 1.0):+.2f} %, one residual rms more "
                f"{100 * h.shrink_hidden / (self.fit.zeta or 1.0):+.2f} %"
            )
        lines.append(f"verdict: {self.quality}")
        for group, names in GROUPS.items():
            if group in self.groups:
                g = self.groups[group]
                shown = ", ".join(n.split("_")[0] for n in names if n in self.parameters)
                lines.append(f"  {group} ({shown}): {g.quality}")
                lines += [f"    - {r}" for r in g.reasons]
        return "\n".join(lines)

    def plot(self, ax=None):
        """The fit over the measured window of the first signal (ax=None: a new figure); returns the figure."""
        return self.plot_fit(0, ax).figure

    def report(self, directory: str | Path, links: dict[str, str] | None = None) -> Path:
        """Write the HTML report to directory/index.html (`links`: text -> relative href shown at the top)."""
        from sloshid.identification.report import build_report

        return build_report(self, links).save(directory)

    def to_pandas(self):
        """The parameters as a table: one row each with value, standard error and 95 % interval."""
        return estimates_table(self.parameters)

    # ---- plots (each takes ax=None and returns the axes it drew on) ----

    def plot_signal(self, i: int = 0, ax=None):
        """The whole recording with the fit window shaded and the estimated end of the excitation marked (from the
        signal alone: `find_decay_window`)."""
        ax = _axes(ax)
        sig, w = self.signals[i], self.windows[i]
        ax.plot(*min_max_envelope(sig.t_s, sig.value), lw=0.7, color="0.2", label=sig.label)
        ax.axvspan(w.t0_s, w.t1_s, color="tab:green", alpha=0.15, label=f"fit window ({w.chosen_by})")
        if w.excitation_end_s is not None:
            ax.axvline(w.excitation_end_s, color="tab:red", ls="--", lw=1, label="estimated end of forcing")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(_ylabel(sig))
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title(Path(sig.source).name)
        return ax

    def plot_psd(self, i: int = 0, ax=None):
        """Welch PSD of the window, and the same estimator applied to the fitted PT2 response."""
        ax = _axes(ax)
        sp, win = self.spectra[i], self.window_signal(i)
        model = welch_spectrum(win.t_s, self.fit.fitted[i], nperseg=sp.nperseg)
        ax.semilogy(sp.f_hz, sp.psd, color="0.2", lw=1, label="measured (Welch)")
        what = "two-mode" if self.fit.second else "PT2"
        ax.semilogy(model.f_hz, model.psd, color="tab:orange", lw=1.2, label=f"fitted {what} response (same Welch)")
        if self.fit.second:
            ax.axvline(self.fit.second.omega_rad_s / (2 * math.pi), color="tab:red", ls=":", label="second mode")
        ax.axvline(
            self.parameters["f_hz"].value, color="tab:blue", ls=":", label=f"f = {self.parameters['f_hz'].value:.4g} Hz"
        )
        for p in sp.secondary:
            ax.plot(p.f_hz, p.psd, "v", color="tab:purple" if p.harmonic else "tab:red", ms=6)
        top = sp.peak_psd * 3
        ax.set_ylim(top * 1e-6, top)
        ax.set_xlim(0, min(sp.fs_hz / 2, 4 * self.parameters["f_hz"].value))
        ax.set_xlabel("f (Hz)")
        ax.set_ylabel(f"PSD ({self.signals[i].unit or 'unit'}²/Hz)")
        ax.legend(fontsize=8)
        return ax

    def plot_fit(self, i: int = 0, ax=None):
        """Window data against the fitted free response, with the residual."""
        ax = _axes(ax)
        win = self.window_signal(i)
        ax.plot(win.t_s, win.value, ".", ms=2, color="0.3", label="measured")
        what = "two-mode fit" if self.fit.second else "PT2 fit"
        # the curves are the fit at the samples: broken where samples are missing, not drawn straight across
        t, fitted, residual, zero = _gaps_broken(
            win.t_s, self.fit.fitted[i], self.fit.residuals[i], self.fit.zero_fitted[i] if self.fit.slow_s else win.t_s
        )
        ax.plot(t, fitted, color="tab:orange", lw=1, label=f"{what} ({self.fit_percent(i):.1f} % fit)")
        ax.plot(t, residual, color="tab:red", lw=0.5, alpha=0.6, label="residual")
        if self.fit.slow_s:  # the zero the mode rides on, where a user checks that it is slow and not the mode
            ax.plot(t, zero, "--", color="tab:blue", lw=1, label="fitted slow zero")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(_ylabel(self.signals[i]))
        ax.legend(fontsize=8, loc="upper right")
        return ax

    def plot_residual_acf(self, i: int = 0, ax=None):
        """Residual autocorrelation with the 95 % band of white noise."""
        ax = _axes(ax)
        r = self.fit.residuals[i]
        # out past the interval correction's reach, which is drawn: the correlation it corrects for is seen
        lags = min(r.size - 1, max(3 * self.lb_lags[i], 20, int(1.2 * self.fit.hac_lags[i]) + 1))
        acf = autocorrelation(r, lags)
        dt = 1 / self.signals[i].rate_hz
        ax.vlines(np.arange(lags + 1) * dt, 0, acf, color="tab:blue", lw=1)
        bound = Z95 / math.sqrt(r.size)
        ax.axhspan(-bound, bound, color="0.8", alpha=0.6, label="white-noise 95 % band")
        ax.axvline(self.fit.hac_lags[i] * dt, color="tab:green", ls="--", lw=1, label="interval correction reach")
        ax.set_xlabel("lag (s)")
        ax.set_ylabel("autocorrelation")
        ax.legend(fontsize=8)
        return ax

    def plot_bode(self, axes=None):
        """Bode magnitude and phase of the identified seed eq. 5 (python-control frequency_response)."""
        import control
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
        w0, zeta = self.fit.omega_rad_s, max(self.fit.zeta, 1e-6)
        # dense within a few half-power widths of the resonance: 400 points over three decades drew a lightly damped
        # peak at a fifth of its height (zeta 0.002)
        near = w0 * (1 + 5 * zeta * np.linspace(-1, 1, 201))
        grid = np.union1d(np.logspace(np.log10(w0 / 20), np.log10(w0 * 20), 400), near[near > 0])
        resp = control.frequency_response(self.tf, grid)
        f = resp.omega / (2 * math.pi)
        axes[0].loglog(f, np.abs(resp.magnitude).ravel(), color="tab:blue")
        axes[0].axvline(w0 / (2 * math.pi), color="0.5", ls=":")
        axes[0].set_ylabel("|H| (rad per m/s²)")
        axes[1].semilogx(f, np.degrees(np.asarray(resp.phase).ravel()), color="tab:blue")
        axes[1].set_ylabel("phase (deg)")
        axes[1].set_xlabel("f (Hz)")
        return axes


def _fewer(periods: float) -> str:
    """A count of periods short of a minimum, rounded down: 2.98 read "only 3.0 periods ...; at least 3 are needed"."""
    return f"{math.floor(periods * 100) / 100:.2f}"


GAP_FACTOR = 3.0
"""Plotted curves break where samples are further apart than this many typical steps (a lost stretch; a single
repeated frame does not break them)."""


def _gaps_broken(t: np.ndarray, *curves: np.ndarray) -> tuple[np.ndarray, ...]:
    """`t` and the curves with a NaN between samples more than GAP_FACTOR typical steps apart, so that a line plot
    leaves the gap empty."""
    dt = np.diff(t)
    at = np.flatnonzero(dt > GAP_FACTOR * np.median(dt)) + 1 if dt.size else np.array([], int)
    return tuple(np.insert(np.asarray(c, float), at, np.nan) for c in (t, *curves))


def _axes(ax):
    """Use the given axes or make a new figure's."""
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(8, 3.2))
    return ax


PLOT_COLUMNS = 4000
"""A long recording is drawn as the minimum and maximum of this many stretches (more than a report figure's pixel
columns): the same picture as every sample, without handing matplotlib ten million points."""


def min_max_envelope(t: np.ndarray, y: np.ndarray, columns: int = PLOT_COLUMNS) -> tuple[np.ndarray, np.ndarray]:
    """The samples that are a minimum or maximum of each of `columns` equal stretches, in time order; a short record
    as it is."""
    if y.size <= 4 * columns:
        return t, y
    k = y.size // columns
    full = y.size // k * k
    rows = y[:full].reshape(-1, k)  # a view: no copy of the samples
    starts = np.arange(rows.shape[0]) * k
    idx = [starts + rows.argmin(axis=1), starts + rows.argmax(axis=1)]
    if full < y.size:  # the last samples, fewer than a stretch
        idx.append(full + np.array([int(y[full:].argmin()), int(y[full:].argmax())]))
    keep = np.unique(np.concatenate(idx))
    return t[keep], y[keep]


def _ylabel(sig: Signal) -> str:
    """Axis label with unit."""
    return f"{sig.label} ({sig.unit})" if sig.unit else sig.label


class Identifier:
    """Configure with IdentSettings, call fit(signals), read result_ (an IdentResult) and params_ (SloshParams)."""

    def __init__(self, settings: IdentSettings | None = None, **overrides: Any):
        self.settings = settings if settings is not None else IdentSettings(**overrides)

    def fit(self, signals: Signal | str | Path | Sequence[Signal | str | Path], progress: bool = False) -> Identifier:
        """Find windows and spectra, fit the PT2 response jointly, derive parameters, judge quality.

        Accepts Signal objects or file paths (read with load_signal's defaults); `progress` shows a bar per signal
        while the decay windows are searched, the slow part of a long record."""
        items = [signals] if isinstance(signals, (Signal, str, Path)) else list(signals)
        sigs = [s if isinstance(s, Signal) else load_signal(s) for s in items]
        if not sigs:
            raise UserError("no signal given to identify.")
        st = self.settings
        prior = geometric_prior(st)
        f_range = search_band(st, prior)
        bar = tqdm(
            sigs,
            desc="decay windows",
            unit="signal",
            leave=False,
            delay=PROGRESS_DELAY_S,
            disable=None if progress else True,
        )
        windows, spectra, fullspec = map(list, zip(*(self._window(sig, f_range) for sig in bar)))
        parts = [s.between(w.t0_s, w.t1_s) for s, w in zip(sigs, windows)]
        moving = [moving_zero(w) for w in windows]
        # a zero that moves slowly in any signal is fitted as a spline in all of them (it costs a little precision)
        slow_s = SLOW_KNOT_PERIODS / float(np.median([w.f_guess_hz for w in windows])) if any(moving) else None
        hp0 = [
            half_power(p.t_s, (without_slow_motion(p, sp.peak_f_hz) if m else p).value, sp.peak_f_hz)
            for p, sp, m in zip(parts, spectra, moving)
        ]
        omega_starts = [2 * math.pi * float(np.median([sp.peak_f_hz for sp in spectra]))]
        omega_starts += [2 * math.pi * h.f_hz for h in hp0]
        zeta_hints = [h.zeta for h in hp0 if math.isfinite(h.zeta)]
        wdata = [WindowData(p.t_s, p.value, w.t0_s, p.hold_restarts()) for p, w in zip(parts, windows)]
        fit = fit_pt2(
            wdata,
            omega_starts,
            float(np.median(zeta_hints)) if zeta_hints else None,
            st.drift,
            slow_s,
        )
        fit, windows, slow_s = _moving_zero_refit(fit, parts, windows, wdata, fullspec, omega_starts, st.drift, slow_s)
        spectra = [_window_spectrum(p, w, f_range) for p, w in zip(parts, windows)]
        for i, (sig, spec, part) in enumerate(zip(sigs, spectra, parts)):
            snr = fit.amplitude(i) / fit.amplitude_se(i)
            explained = fit.fit_percent(i, part.value)
            if (spec.prominence < MIN_PROMINENCE or not spec.resonant) and (
                not snr >= NO_MODE_SNR or explained < st.min_fit_percent
            ):
                weak = (
                    [f"a fitted decay's amplitude is only {snr:.1f} standard errors"] if not snr >= NO_MODE_SNR else []
                )
                if explained < st.min_fit_percent:
                    weak.append(f"it explains only {explained:.0f} % of the signal")
                raise UserError(
                    f"{sig.source}: no oscillatory mode found; the PSD shows no resonance standing 10 dB above the "
                    f"noise in {f_range[0]:g}-{f_range[1]:g} Hz, and {' and '.join(weak)}."
                )
        f_fit = fit.omega_rad_s / (2 * math.pi)
        if st.window_s is None and any(strong_peaks(sp, st.second_mode_ratio, f_fit) for sp in spectra):
            # two modes beat, so the first quiet stretch may be a beat's null rather than the fade: now that the decay
            # rate is known, let the automatic windows take in the ring-down's tail (a single mode's envelope only
            # falls, so there the first quiet stretch is the fade and the window stays)
            rate = fit.zeta * fit.omega_rad_s
            longer = [extend_tail(s, w, f_fit, rate, fs.noise_std) for s, w, fs in zip(sigs, windows, fullspec)]
            if any(a.t1_s > b.t1_s + 1 / f_fit for a, b in zip(longer, windows)):  # at least a period more
                windows = longer
                parts = [s.between(w.t0_s, w.t1_s) for s, w in zip(sigs, windows)]
                spectra = [_window_spectrum(p, w, f_range) for p, w in zip(parts, windows)]
                wdata = [WindowData(p.t_s, p.value, w.t0_s, p.hold_restarts()) for p, w in zip(parts, windows)]
                fit = fit_pt2(wdata, [fit.omega_rad_s, *omega_starts[1:]], fit.zeta or None, st.drift, slow_s)
                fit, windows, slow_s = _moving_zero_refit(
                    fit, parts, windows, wdata, fullspec, omega_starts, st.drift, slow_s
                )
                spectra = [_window_spectrum(p, w, f_range) for p, w in zip(parts, windows)]
        second = resolve_second_mode(wdata, fit, spectra, st.second_mode_ratio, AMPLITUDE_SNR)
        if second is not None and second.separated:
            fit = second.fit
        if any(s.tracked for s in sigs):  # a video encoder's hold distorts every tracked target alike
            fit = fit_pt2_hold(wdata, fit)
        fit, between = between_signals(wdata, fit, [2 * math.pi * sp.peak_f_hz for sp in spectra])
        if fit.hold is not None:
            fit = with_codec_share(fit_pt2_shrink(wdata, fit), codec_zeta_share([s.tracked for s in sigs]))
        self.result_ = self._assemble(
            sigs, windows, parts, spectra, [s.noise_std for s in fullspec], fit, second, prior, between
        )
        self.params_ = self.result_.params
        return self

    def _window(self, sig: Signal, f_range: tuple[float, float]) -> tuple[DecayWindow, Spectrum, Spectrum]:
        """The free-decay window of one signal, its Welch spectrum and that of the whole record; refuses a signal
        without a ring-down of MIN_PERIODS_ERROR periods. When the noise near the mode is CORRELATED_NOISE_RATIO
        times its broadband level, an automatic window that holds no ring-down, or one after forcing whose start does
        not ring above that noise, is sought again against it (and the period mean's own noise): correlated (red)
        noise's slow wander otherwise passes for forcing, which refused clear ring-downs or left the record's noisy
        tail to fit. The first window stays when the second search finds none."""
        st = self.settings
        f_guess = rough_mode_frequency(sig, f_range)
        whole = welch_spectrum(sig.t_s, sig.value, f_range)
        near, period_noise = whole.noise_near_mode(), whole.period_mean_noise(f_guess)
        # only these numbers and the record's noise level are read from here on: its arrays (half a million bins per
        # million samples) are not held through the window search and the fit
        whole = replace(whole, f_hz=np.empty(0), psd=np.empty(0))
        if st.window_s is not None:
            # forcing is judged as the automatic search judges it, against the noise near the mode when that is
            # correlated (red noise's slow wander otherwise passes for forcing)
            red = near > CORRELATED_NOISE_RATIO * whole.noise_std
            noise, mean = (near, period_noise) if red else (whole.noise_std, None)
            win = user_window(sig, *st.window_s, f_guess, noise, st.drift, mean)
        else:
            win = find_decay_window(sig, f_guess, whole.noise_std, st.drift)
            if near > CORRELATED_NOISE_RATIO * whole.noise_std and not _ring_down(sig, win, f_guess, near):
                again = find_decay_window(sig, f_guess, near, st.drift, period_noise)
                if _ring_down(sig, again, f_guess, near):
                    win, whole = replace(again, near_mode_noise=near), replace(whole, noise_std=near)
            elif not _ring_down(sig, win, f_guess):
                # slow noise alone (a thin float's tracked angle wandering by tenths of a degree over seconds) moved the
                # period mean past the white-noise level and passed for forcing: sought again against its measured level
                again = find_decay_window(sig, f_guess, whole.noise_std, st.drift, period_noise)
                if _ring_down(sig, again, f_guess):
                    win = again
        part = sig.between(win.t0_s, win.t1_s)
        whole_periods = (sig.t_s[-1] - sig.t_s[0]) * f_guess
        if whole_periods < MIN_PERIODS_ERROR:
            raise UserError(
                f"{sig.source}: the signal lasts only {_fewer(whole_periods)} periods of the {f_guess:.3g} Hz mode; "
                f"at least {MIN_PERIODS_ERROR:g} are needed."
            )
        if win.chosen_by == "auto" and not _ring_down(sig, win, f_guess):
            driven = win.excitation_end_s
            # driven to the end, unless the record shows no resonance at all (a liquid at rest: its wander is no move)
            if driven is not None and (sig.t_s[-1] - driven) * f_guess < MIN_PERIODS_ERROR and whole.resonant:
                # driven to the end: a slow motion larger than the swing (a container moving in the picture)
                raise SettingError(
                    "window_s",
                    f"{sig.source}: no free ring-down of {MIN_PERIODS_ERROR:g} periods ({f_guess:.3g} Hz): the signal "
                    f"is driven (its mean over a period moves by more than half its swing) until {driven:.2f} s of "
                    f"{sig.t_s[-1]:.2f} s; give {{name}} (start and end, s) where it rings down freely, or track a "
                    'container that moves in the picture against the container (tracking with `reference` = "container", '
                    'or reference = "container" in a pipeline\'s [track]).',
                )
            raise UserError(
                f"{sig.source}: no oscillatory mode found; nowhere does a ring-down of {MIN_PERIODS_ERROR:g} "
                f"periods ({f_guess:.3g} Hz) stand above the noise."
            )
        if part.t_s.size < 16:
            raise UserError(f"{sig.source}: the window {win.t0_s:g}-{win.t1_s:g} s holds only {part.t_s.size} samples.")
        spec = _window_spectrum(part, win, f_range)
        periods = win.duration_s * spec.peak_f_hz
        if spec.prominence >= MIN_PROMINENCE and periods < MIN_PERIODS_ERROR:
            raise UserError(
                f"{sig.source}: the window {win.t0_s:.2f}-{win.t1_s:.2f} s holds only {_fewer(periods)} periods of "
                f"the {spec.peak_f_hz:.3g} Hz mode; at least {MIN_PERIODS_ERROR:g} are needed."
            )
        return win, spec, whole

    def _assemble(
        self,
        sigs,
        windows,
        parts,
        spectra,
        noise_std,
        fit: PT2Fit,
        second: SecondMode | None,
        prior: dict,
        between: BetweenSignals | None = None,
    ) -> IdentResult:
        """Derived parameters with delta-method errors, cross-checks and the verdict."""
        st = self.settings
        omega, zeta = fit.omega_rad_s, fit.zeta
        se_w, se_z = np.sqrt(np.clip(np.diag(fit.cov), 0, None))
        params = {
            "f_hz": estimate(omega / (2 * math.pi), se_w / (2 * math.pi)),
            "omega_rad_s": estimate(omega, se_w),
            "zeta": estimate(zeta, se_z, ZETA_BOUNDS),
            "l_m": estimate(G / omega**2, 2 * G / omega**3 * se_w),
        }
        if st.mass_kg is not None:
            grad = np.array([2 * st.mass_kg * zeta, 2 * st.mass_kg * omega])
            d_se = math.sqrt(grad @ fit.cov @ grad)
            params["d_ns_per_m"] = estimate(2 * st.mass_kg * omega * zeta, d_se, (0.0, math.inf))
        checks, lb, lb_lags = _cross_checks(sigs, windows, parts, noise_std, fit)
        fits = [fit.fit_percent(i, p.value) for i, p in enumerate(parts)]
        if prior:
            prior["identified_over_prior"] = omega / prior["omega_rad_s"]
        verdict = judge(
            VerdictInput(
                sigs,
                windows,
                spectra,
                fit,
                params,
                checks,
                lb,
                fits,
                st.min_fit_percent,
                st.min_periods,
                st.second_mode_ratio,
                second,
                prior,
                search_band(st, prior),
                between,
            )
        )
        notes = verdict.notes + [w for s in sigs for w in s.warnings]
        if fit.slow_s:
            moved = ", ".join(f"{w.slow_motion:.3g} {s.unit}".strip() for s, w in zip(sigs, windows) if w.slow_motion)
            notes.append(
                f"the signal's zero moves slowly (its mean over a period moves by up to {moved}: a sway, or a mean level "
                f"that large swings lift): it was fitted beside the mode as {_spline_zero(fit.slow_s)}, so it is "
                "neither taken for forcing nor left in the residual."
            )
        if fit.hold is not None:
            notes.append(
                "tracked from video: the mode was fitted as seen through the encoder's hold of slowly moving edges, "
                "its half-width fitted with it; tracking noise alone also fits a small hold, so the values lie "
                "between the plain and the held fit's by the evidence for the hold. A codec also takes about the same angle off every swing, so it "
                "shrinks the smallest swings most for their size and the decay looks faster; no model of that held "
                "on all rendered clips, so zeta's interval holds how far zeta moves in a refit with such a shrink and "
                "with a shrink one residual rms larger, and a share of zeta (2.5 % for a float, 1 % for a surface). "
                "At H.264 CRF 23 (60-120 fps) rendered floats' zeta came out up to 13 % high, inside intervals of +-7 "
                "to +-25 %, and at CRF 16-23 and 30 fps 4-17 % high; film at a high bit rate (the documentation's "
                "design note: identifying from compressed video)."
            )
        for note in (
            between.note(distinct_names([s.source for s in sigs])) if between else None,
            mass_against_geometry(st),
        ):
            if note:
                notes.append(note)
        return IdentResult(
            signals=sigs,
            windows=windows,
            spectra=spectra,
            fit=fit,
            cross_checks=checks,
            parameters=params,
            quality=verdict.quality,
            reasons=verdict.reasons,
            notes=notes,
            mass_kg=st.mass_kg,
            prior=prior,
            ljung_box=lb,
            lb_lags=lb_lags,
            second_mode=second,
            groups=verdict.groups,
            between=between,
        )

    @property
    def result(self) -> IdentResult:
        """The fitted result; raises NotFittedError before fit()."""
        if not hasattr(self, "result_"):
            raise NotFittedError("this Identifier is not fitted yet; call fit(signals) first.")
        return self.result_


def _moving_zero_refit(fit: PT2Fit, parts, windows, wdata, fullspec, omega_starts, drift: bool, slow_s):
    """A fit with a constant zero whose residual shows the zero moving (`residual_wander`): fitted again with a spline
    zero, the windows marked with how far it moves; otherwise (or when it has the spline already) all as they were.
    Returns (fit, windows, knot spacing or None)."""
    if slow_s is not None:
        return fit, windows, slow_s
    f_fit = fit.omega_rad_s / (2 * math.pi)
    wander = [
        residual_wander(p.t_s, fit.residuals[i], f_fit, fs.noise_std, fit.amplitude(i))
        for i, (p, fs) in enumerate(zip(parts, fullspec))
    ]
    if not any(wander):
        return fit, windows, None
    slow_s = SLOW_KNOT_PERIODS / f_fit
    refit = fit_pt2(wdata, [fit.omega_rad_s, *omega_starts[1:]], fit.zeta or None, drift, slow_s)
    return refit, [replace(w, slow_motion=v) for w, v in zip(windows, wander)], slow_s


def _spline_zero(knot_spacing_s: float) -> str:
    """How the report names a slow zero's model."""
    return f"a cubic spline (knots at most {knot_spacing_s:.3g} s, {SLOW_KNOT_PERIODS:g} mode periods, apart)"


def _ring_down(sig: Signal, win: DecayWindow, f_guess_hz: float, noise_std: float | None = None) -> bool:
    """An automatic window holds a ring-down to fit: at least 16 samples and MIN_PERIODS_ERROR periods, and, with
    `noise_std`, a window after forcing starts ringing above its fade level (`rings_above`): correlated noise's wander
    can pass for forcing until the record's noisy tail."""
    if sig.between(win.t0_s, win.t1_s).t_s.size < 16 or win.duration_s * f_guess_hz < MIN_PERIODS_ERROR:
        return False
    return noise_std is None or win.excitation_end_s is None or rings_above(sig, win, f_guess_hz, noise_std)


def _window_spectrum(part: Signal, win: DecayWindow, f_range: tuple[float, float]) -> Spectrum:
    """Welch spectrum of a window; of the window without its slow motion when its zero moves (a sway's leakage below
    the band would otherwise outweigh the mode)."""
    if moving_zero(win):
        part = without_slow_motion(part, win.f_guess_hz)
    return welch_spectrum(part.t_s, part.value, f_range)


def _cross_checks(sigs, windows, parts, noise_std, fit: PT2Fit) -> tuple[list, list[float], list[int]]:
    """Per signal: the independent estimates (on the window minus its fitted zero and any fitted second mode) and
    the Ljung-Box whiteness test of the residual with its lag count."""
    omega = fit.omega_rad_s
    checks, lb, lb_lags = [], [], []
    for i, p in enumerate(parts):
        base = fit.zero_fitted[i]
        if fit.second:  # the cross-checks judge the main mode, so the fitted second mode is taken out first
            base = base + fit.second_fitted[i]
        clean = p.value - base
        noise = noise_std[i]
        f_fit = omega / (2 * math.pi)
        checks.append(
            [
                half_power(p.t_s, clean, f_fit),
                log_decrement(p.t_s, clean, f_fit, noise),
                hilbert_envelope(p.t_s, clean, f_fit, noise),
            ]
        )
        h = int(min(max(10, round(sigs[i].rate_hz / f_fit)), fit.residuals[i].size // 5))
        lb_lags.append(h)
        lb.append(ljung_box_p(fit.residuals[i], h))
    return checks, lb, lb_lags


def search_band(st: IdentSettings, prior: dict[str, Any]) -> tuple[float, float]:
    """The band searched for the mode: --f-range, narrowed by the geometric prior to where the first mode is nearer
    than the second azimuthal one (the prior picks the first mode)."""
    if not prior:
        return st.f_range_hz
    lo, hi = max(st.f_range_hz[0], prior["band_hz"][0]), min(st.f_range_hz[1], prior["band_hz"][1])
    if not lo < hi:
        raise UserError(
            f"the frequency range {st.f_range_hz[0]:g}-{st.f_range_hz[1]:g} Hz misses the container's first "
            f"mode band {prior['band_hz'][0]:.3g}-{prior['band_hz'][1]:.3g} Hz."
        )
    return lo, hi


WATER_KG_M3 = 1000.0
"""Density the mass is checked against: sloshing liquids lie within a factor of 3 of water's (oils 0.9, syrups 1.4)."""


def mass_against_geometry(st: IdentSettings) -> str | None:
    """The note when the given mass is more than 3 times off the water a cylinder of the given radius and fill height
    holds (a mass in grams read as kg is a thousand times), or None."""
    if st.mass_kg is None or st.container_radius_m is None or st.fill_height_m is None:
        return None
    water = WATER_KG_M3 * math.pi * st.container_radius_m**2 * st.fill_height_m
    ratio = st.mass_kg / water
    if 1 / 3 <= ratio <= 3:
        return None
    times = f"{ratio:.0f}" if ratio >= 10 else f"{ratio:.2g}"
    return (
        f"the mass {st.mass_kg:g} kg is {times} times the {water:.3g} kg of water that a cylinder of radius "
        f"{st.container_radius_m:g} m filled to {st.fill_height_m:g} m holds: the mass is in kg (grams read as kg are "
        "a thousand times too much), and d scales with it."
    )


def geometric_prior(st: IdentSettings) -> dict[str, Any]:
    """The cylinder's analytic first mode and the band where it, not the second azimuthal mode, is the nearer one
    (split at their geometric mean), or {} without geometry."""
    if st.container_radius_m is None or st.fill_height_m is None:  # given together (checked on construction)
        return {}
    w1 = cylinder_first_mode_omega(st.container_radius_m, st.fill_height_m)
    w2 = cylinder_first_mode_omega(st.container_radius_m, st.fill_height_m, XI_CYLINDER_SECOND)
    half = math.sqrt(w2 / w1)
    return {
        "container_radius_m": st.container_radius_m,
        "fill_height_m": st.fill_height_m,
        "omega_rad_s": w1,
        "f_hz": w1 / (2 * math.pi),
        "l_m": G / w1**2,
        "second_azimuthal_f_hz": w2 / (2 * math.pi),
        "band_hz": [w1 / half / (2 * math.pi), w1 * half / (2 * math.pi)],
    }
