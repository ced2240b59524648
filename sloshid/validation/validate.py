"""`sloshid validate`: predict each recorded move, align it with its measurement, score it, and report.

A measured wall height (mm, e.g. the antisloshing .mat files) is the highest point at the wall that the cameras
see, so it is compared with the predicted magnitude R tan(relative angle) after the quiet lead-in's baseline is
subtracted; a measured angle (deg or rad) is compared as a magnitude with the relative angle in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sloshid.core.errors import SettingError, UserError
from sloshid.core.tables import to_pandas
from sloshid.identification.signals import Signal
from sloshid.identification.stage import check_sampling
from sloshid.model.pose import PoseLog
from sloshid.validation.predict import LiquidModel, forecast
from sloshid.validation.scoring import LEAD_IN_S, Alignment, PhaseScore, align, baseline, score

PHASES = ("all", "during", "after")
FIT_RTOL = 1e-7
"""Integrator tolerance for validation: within 1e-4 deg of the 1e-9 default on the shared runs, 3x faster."""


WEAK_ALIGNMENT = 0.5
"""A run whose best-lag Pearson correlation is below this draws a warning: the shared real runs align at 0.9 and more,
white noise against a move at about 0.2."""


def measured_kind(sig: Signal, model: LiquidModel) -> str:
    """'wall_height_mm' for a height in mm (needs the radius), 'rel_angle_deg' for an angle; else one sentence."""
    if sig.unit == "mm":
        if model.radius_m is None:
            raise SettingError(
                "container_radius_m",
                f"{sig.source} is a wall height in mm; give the container radius ({{name}}) to predict it.",
            )
        return "wall_height_mm"
    if sig.unit in ("deg", "rad"):
        return "rel_angle_deg"
    raise UserError(
        f"{sig.source}: the measured '{sig.label}' has no unit this command can compare (a wall height in mm or "
        "an angle in deg/rad; name the column e.g. height_mm or angle_deg)."
    )


def measured_magnitude(sig: Signal, kind: str) -> np.ndarray:
    """Measured values in the compared unit: heights as they are, angles as degree magnitudes about their start."""
    if kind == "wall_height_mm":
        return np.asarray(sig.value, float)
    deg = np.degrees(sig.value) if sig.unit == "rad" else np.asarray(sig.value, float)
    return np.abs(deg - np.median(deg[: max(deg.size // 10, 1)]))


@dataclass
class ValidationRun:
    """One recorded move: the aligned measurement, the prediction on the measurement's samples, the scores."""

    name: str
    kind: str
    alignment: Alignment
    baseline: float
    move_s: tuple[float, float]
    """The move in trajectory time."""
    t_s: np.ndarray
    """Scored samples in trajectory time (measured time minus the lag)."""
    measured: np.ndarray
    predicted: np.ndarray
    scores: dict[str, PhaseScore]
    lo: np.ndarray | None = None
    """The 95 % band's lower edge on the scored samples (None: no band)."""
    hi: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    """What reading the measurement dropped (NaN/inf samples) and the prediction's extrapolation notes."""
    in_sample: bool = False
    """The model was identified from this very measurement: its scores show the fit, not a prediction."""

    @property
    def band_peak(self) -> tuple[float, float]:
        """The band's edges for the peak during the move: the peaks of its lower and upper edges."""
        during = (self.t_s >= self.move_s[0]) & (self.t_s <= self.move_s[1])
        if self.lo is None or self.hi is None or not during.any():
            return (float("nan"), float("nan"))
        return float(self.lo[during].max()), float(self.hi[during].max())

    @property
    def peak_in_band(self) -> bool:
        """The measured peak during the move lies inside the band of the predicted peak."""
        lo, hi = self.band_peak
        return bool(lo <= self.scores["during"].peak_measured <= hi)

    @property
    def unit(self) -> str:
        """Unit of measured and predicted values."""
        return "mm" if self.kind == "wall_height_mm" else "deg"

    def to_dict(self) -> dict[str, Any]:
        """Scores, lag and correlation as plain JSON values."""
        return {
            "name": self.name,
            "measured": self.kind,
            "in_sample": self.in_sample,
            "lag_s": self.alignment.lag_s,
            "correlation": self.alignment.correlation,
            "baseline": self.baseline,
            "move_s": list(self.move_s),
            "scores": {k: v.to_dict() for k, v in self.scores.items()},
            "band_peak": list(self.band_peak),
            "peak_in_band": self.peak_in_band,
            "notes": list(self.notes),
        }

    def plot(self, axes=None):
        """Measured and predicted over the measured clock with the move shaded (top), the residual (bottom)."""
        import matplotlib.pyplot as plt

        if axes is None:
            _, axes = plt.subplots(2, 1, sharex=True, figsize=(9, 4.8), height_ratios=(3, 1.2))
        t = self.t_s + self.alignment.lag_s
        for ax in axes:
            ax.axvspan(*(np.array(self.move_s) + self.alignment.lag_s), color="tab:green", alpha=0.12, lw=0)
        s = self.scores
        axes[0].plot(t, self.measured, color="0.25", lw=0.8, label="measured")
        axes[0].plot(t, self.predicted, color="tab:orange", lw=1.0, label="predicted")
        if self.lo is not None:
            axes[0].fill_between(t, self.lo, self.hi, color="tab:orange", alpha=0.2, lw=0, label="95 % band")
        axes[0].set_ylabel(f"{self.kind.rsplit('_', 1)[0].replace('_', ' ')} ({self.unit})")
        axes[0].set_title(
            f"{self.name}: fit {s['all'].fit_percent:.0f} % (during {s['during'].fit_percent:.0f} %, after "
            f"{s['after'].fit_percent:.0f} %), peak error {s['during'].peak_error_percent:+.1f} %, "
            f"lag {self.alignment.lag_s:.2f} s, r = {self.alignment.correlation:.2f}",
            fontsize=9,
        )
        axes[0].legend(fontsize=8, loc="upper right")
        axes[1].plot(t, self.measured - self.predicted, color="tab:red", lw=0.7)
        axes[1].axhline(0, color="0.5", lw=0.5)
        axes[1].set_ylabel(f"residual ({self.unit})")
        axes[1].set_xlabel("measured time (s); shaded: the move")
        return axes


def validate_run(pose: PoseLog, sig: Signal, model: LiquidModel, name: str = "") -> ValidationRun:
    """Predict the move, align by cross-correlation over it, subtract the lead-in baseline, score per phase."""
    if np.ptp(sig.value) == 0:  # no correlation to align by, scores of 0 / 0
        raise UserError(
            f"{sig.source}: '{sig.label}' is constant, so there is no slosh to compare the prediction with."
        )
    check_sampling(sig.source, sig.rate_hz, (model.params.f_hz, model.params.f_hz))
    kind = measured_kind(sig, model)
    y_all = measured_magnitude(sig, kind)
    fc = forecast(pose, model, settle_s=float(sig.t_s[-1] - sig.t_s[0]) + 1.0, rtol=FIT_RTOL)
    resp = fc.resp
    pred = model.reading(resp, kind)
    band = fc.band(lambda r, m: m.reading(r, kind))
    move = resp.move_span_s
    al = align(sig.t_s, y_all, resp.t_s, pred, move, sig.source)
    base = baseline(sig.t_s, y_all, move[0] + al.lag_s)
    tm = sig.t_s - al.lag_s
    keep = (tm >= move[0] - LEAD_IN_S) & (tm <= resp.t_s[-1])
    t, y = tm[keep], y_all[keep] - base
    yhat = np.interp(t, resp.t_s, pred, left=pred[0])
    during, after = (t >= move[0]) & (t <= move[1]), t > move[1]
    scores = {"all": score(y, yhat), "during": score(y[during], yhat[during]), "after": score(y[after], yhat[after])}
    lo, hi = (np.interp(t, resp.t_s, edge, left=edge[0]) for edge in band)
    return ValidationRun(
        name or Path(sig.source).stem, kind, al, base, move, t, y, yhat, scores, lo, hi, (*sig.warnings, *fc.notes)
    )


def medians(runs: list[ValidationRun]) -> dict[str, Any]:
    """Median of each phase's fit % and |peak error| % over the runs the model was not fitted on (over all of them
    when it was fitted on every one)."""
    runs = [r for r in runs if not r.in_sample] or runs
    out: dict[str, Any] = {}
    for phase in PHASES:
        fits = [r.scores[phase].fit_percent for r in runs]
        peaks = [abs(r.scores[phase].peak_error_percent) for r in runs]
        out[phase] = {"fit_percent": _nanmedian(fits), "abs_peak_error_percent": _nanmedian(peaks)}
    out["band_coverage"] = float(np.mean([r.peak_in_band for r in runs])) if runs else float("nan")
    return out


def _nanmedian(values: list[float]) -> float:
    """Median of the finite values (nan when none is)."""
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else float("nan")


def table_text(runs: list[ValidationRun]) -> str:
    """Aligned plain-text table of the runs, with the median row when there are several."""
    head = (
        f"{'run':34s} {'lag_s':>7s} {'r':>5s} {'fit_%':>6s} {'fit_move_%':>10s} {'fit_after_%':>11s} {'peak_err_%':>10s} "
        f"{'peak_after_err_%':>16s} {'band_peak':>15s}"
    )
    lines = [head]
    for r in runs:
        s = r.scores
        name = f"{r.name[:32]} *" if r.in_sample else r.name[:34]
        lines.append(
            f"{name:34s} {r.alignment.lag_s:7.2f} {r.alignment.correlation:5.2f} {s['all'].fit_percent:6.1f} "
            f"{s['during'].fit_percent:10.1f} {s['after'].fit_percent:11.1f} {s['during'].peak_error_percent:+10.1f} "
            f"{s['after'].peak_error_percent:+16.1f} {_band_cell(r):>15s}"
        )
    if len(runs) > 1:
        m = medians(runs)
        lines.append(
            f"{'median (|peak error|)':34s} {'':7s} {'':5s} {m['all']['fit_percent']:6.1f} "
            f"{m['during']['fit_percent']:10.1f} {m['after']['fit_percent']:11.1f} "
            f"{m['during']['abs_peak_error_percent']:10.1f} {m['after']['abs_peak_error_percent']:16.1f} "
            f"{100 * m['band_coverage']:8.0f} % in"
        )
    if any(r.in_sample for r in runs):
        where = "" if all(r.in_sample for r in runs) else "; the median leaves them out"
        lines.append(f"* the model was identified from this measurement: a fit, not a prediction{where}")
    return "\n".join(lines)


def _band_cell(run: ValidationRun) -> str:
    """The band of the predicted peak, starred when the measured peak lies outside it."""
    lo, hi = run.band_peak
    return f"{lo:.3g}-{hi:.3g}{'' if run.peak_in_band else ' !'}"


def build_report(runs: list[ValidationRun], model: LiquidModel, title: str = "sloshid validate"):
    """HTML report: the model, the score table (with medians), and per run the overlay and the residual."""
    from sloshid.report.html import Report

    rep = Report(title)
    p = model.params
    rep.add_text(
        f"Model: a spherical pendulum at the surface, f = {p.f_hz:.4g} Hz, zeta = {p.zeta:.3g}; the wall reads the "
        f"static surface plus {model.wave_share:.3g} of the wave, crest coefficient {model.crest_coeff:.3g}, against a "
        f"level tilted {model.rest_tilt_x_deg:.2g} deg along x and {model.rest_tilt_y_deg:.2g} along y at rest"
        + (
            ""
            if model.views_deg is None
            else f", on the wall within {model.view_arc_deg:.2g} deg of the views' edge-on points"
        )
        + "; radius "
        f"{'-' if model.radius_m is None else f'{1000 * model.radius_m:.1f} mm'}, axis offset "
        f"{1000 * model.axis_offset_m:.0f} mm, acceleration smoothing {1000 * model.smooth_s:.0f} ms (Savitzky-Golay)."
    )
    rep.add_heading("Scores")
    rep.add_html(f"<pre>{table_text(runs)}</pre>")
    rep.add_text(
        "fit % = 100 (1 - |y - yhat| / |y - mean y|) over the whole scored record (from 1 s before the move), during "
        "the move and after it; peak error % = predicted peak over measured peak during the move, minus 1 (after it: "
        "peak_after_err_%, where a model that leaves the liquid at rest reads -100 %); lag: "
        "measured time minus trajectory time, from the cross-correlation over the move (r); band_peak: the 95 % band of the "
        "predicted peak (parameters' errors and the model error calibrated on held-out kinds), ! where the measured peak "
        "lies outside it; the median row gives the share of runs inside."
    )
    rep.add_heading("Measured and predicted")
    for r in runs:
        axes = r.plot()
        rep.add_figure(axes[0].figure, f"{r.name}: measured and predicted (move shaded), residual below.")
    return rep


def _score_rows(runs: list[ValidationRun]) -> dict[str, list]:
    """One row per run and phase (all, during, after) with its scores: the table of `to_pandas`."""
    rows = [(r, phase, sc) for r in runs for phase, sc in r.scores.items()]
    return {
        "run": [r.name for r, _, _ in rows],
        "phase": [phase for _, phase, _ in rows],
        "lag_s": [r.alignment.lag_s for r, _, _ in rows],
        "correlation": [r.alignment.correlation for r, _, _ in rows],
        "fit_percent": [sc.fit_percent for _, _, sc in rows],
        "peak_error_percent": [sc.peak_error_percent for _, _, sc in rows],
    }


@dataclass(kw_only=True)
class Validation:
    """Several recorded moves validated against one model: the result of `sloshid validate`, which behaves like
    every stage result (summary, to_dict, plot, report, to_pandas)."""

    runs: list[ValidationRun]
    model: LiquidModel

    def summary(self) -> str:
        """The score table with the median row (what `sloshid validate` prints)."""
        return table_text(self.runs)

    @property
    def warnings(self) -> list[str]:
        """Each run's notes (samples dropped on reading, extrapolation), then runs whose prediction correlates weakly
        with the measurement at the best lag (WEAK_ALIGNMENT: the lag and every score may be wrong) or was fitted on it."""
        return (
            [n for r in self.runs for n in r.notes]
            + [
                f"run {r.name}: the prediction correlates weakly with the measurement (r = {r.alignment.correlation:.2f} "
                f"at a lag of {r.alignment.lag_s:.2f} s), so the alignment and the scores may be wrong; check that the "
                "measurement records this move."
                for r in self.runs
                if r.alignment.correlation < WEAK_ALIGNMENT
            ]
            + [
                f"run {r.name}: the model was identified from this measurement, so its scores show how well it was fitted, "
                "not how well it predicts"
                + (
                    "; the medians leave it out."
                    if not all(q.in_sample for q in self.runs)
                    else "; validate it on a recorded move it was not fitted to."
                )
                for r in self.runs
                if r.in_sample
            ]
        )

    def to_dict(self) -> dict[str, Any]:
        """The `--json` content: every run's scores, the medians and the warnings."""
        return {"runs": [r.to_dict() for r in self.runs], "medians": medians(self.runs), "warnings": self.warnings}

    def plot(self, ax=None):
        """Measured and predicted of the first run (with its residual when no axes are given); returns the figure."""
        axes = self.runs[0].plot(None if ax is None else [ax, ax.twinx()])
        return axes[0].figure

    def report(self, directory: str | Path, links: dict[str, str] | None = None) -> Path:
        """Write the HTML report to directory/index.html (`links`: text -> relative href shown at the top)."""
        rep = build_report(self.runs, self.model)
        rep.add_links(links or {})
        return rep.save(directory)

    def to_pandas(self):
        """One row per run and phase with lag, correlation, fit % and peak error %."""
        return to_pandas(_score_rows(self.runs))


def validate(poses: list[PoseLog], signals: list[Signal], model: LiquidModel) -> Validation:
    """The validate stage in one call: every recorded move (pose log and measurement, in the same order) scored."""
    if len(poses) != len(signals):
        raise SettingError(
            "trajectory",
            f"give one {{name}} per measurement, in the same order: {len(poses)} trajectories, "
            f"{len(signals)} measurements.",
        )
    pairs = [(str(Path(p.source).resolve()), str(Path(s.source).resolve())) for p, s in zip(poses, signals)]
    twice = next((pair for pair in pairs if pairs.count(pair) > 1), None)
    if twice is not None:  # it was scored twice, and its run counted twice in the medians
        raise UserError(f"the run {twice[1]} with {twice[0]} is given more than once; each run is scored once.")
    names = [Path(s.source).stem for s in signals]
    # one measured file against several trajectories (or files of one name): each run named by both
    names = [n if names.count(n) == 1 else f"{n} ({Path(p.source).stem})" for n, p in zip(names, poses)]
    runs = [validate_run(p, s, model, n) for p, s, n in zip(poses, signals, names)]
    for run, sig in zip(runs, signals):
        run.in_sample = model.fitted_to(sig.source)
    return Validation(runs=runs, model=model)
