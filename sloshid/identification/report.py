"""The HTML report of an identification: what was measured, which part was fitted, how well, and how sure."""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
from tqdm import tqdm

from sloshid.identification.verdict import PARAMETER_LABELS
from sloshid.report.html import Report

if TYPE_CHECKING:  # the result calls this module to draw itself: its class is named for the annotations only
    from sloshid.identification.estimator import IdentResult
    from sloshid.identification.second_mode import SecondMode

GROUP_LABELS = {"frequency": "Frequency (f, omega, l)", "damping": "Damping (zeta, d)"}


def build_report(res: IdentResult, links: dict[str, str] | None = None) -> Report:
    """Assemble every figure and table of one identification into a Report (save it with .save(dir)); `links`
    (text -> relative href) point back to a pipeline's index and to the stage's files."""
    rep = Report("Sloshing mode identification")
    rep.add_links(links or {})
    _verdict_section(rep, res)
    _sampling_section(rep, res)
    for i in tqdm(range(len(res.signals)), desc="report figures", unit="signal", disable=None):
        _signal_section(rep, res, i)
    _parameter_section(rep, res)
    if res.second_mode is not None:
        _second_mode_section(rep, res, res.second_mode)
    _cross_check_section(rep, res)
    _model_section(rep, res)
    return rep


def _verdict_section(rep: Report, res: IdentResult) -> None:
    """The overall verdict, then each parameter group's verdict with its reasons in plain sight."""
    parts = [f'<p>Verdict: <span class="verdict-{res.quality}">{res.quality}</span></p><ul>']
    for group, g in res.groups.items():
        reasons = "".join(f"<li>{html.escape(r)}</li>" for r in g.reasons) or "<li>no reason to doubt the numbers</li>"
        label = html.escape(GROUP_LABELS.get(group, group))
        parts.append(f'<li>{label}: <span class="verdict-{g.quality}">{g.quality}</span><ul>{reasons}</ul></li>')
    rep.add_html("".join(parts) + "</ul>")
    rep.add_text(
        "A free decay of the liquid was found in each signal, its dominant frequency read off a Welch power spectrum, "
        "and a damped second-order (PT2) free response fitted to it by nonlinear least squares. The pendulum length "
        "l = g/omega^2 and damping constant d = 2 m omega zeta follow (seed paper eq. 5-7)."
    )


def _sampling_section(rep: Report, res: IdentResult) -> None:
    """Where each signal came from and how it was sampled, and the notes that inform without doubting."""
    rep.add_heading("Source and sampling")
    rows = []
    for sig in res.signals:
        s = sig.sampling()
        rows.append(
            [
                Path(sig.source).name,
                f"{sig.label} ({sig.unit or '-'})",
                s["n_samples"],
                s["duration_s"],
                s["rate_hz"],
                1000 * s["timestamp_jitter_s"],
                s["n_gaps"],
                s["n_dropped"],
            ]
        )
    rep.add_table(
        ["file", "signal", "samples", "duration (s)", "rate (Hz)", "timestamp jitter (ms)", "gaps", "dropped samples"],
        rows,
        "Gaps are time steps longer than 1.5 nominal steps.",
    )
    for note in res.notes:
        rep.add_text(note, "meta")


def _signal_section(rep: Report, res: IdentResult, i: int) -> None:
    """Signal i: the recording with its window, the PSD, the time-domain fit and the residual autocorrelation."""
    sig = res.signals[i]
    name = Path(sig.source).name
    w, sp = res.windows[i], res.spectra[i]
    rep.add_heading(f"Signal {i + 1}: {name}")
    fig, ax = plt.subplots(figsize=(9, 3))
    res.plot_signal(i, ax)
    how = "given by the user (window_s)"
    if w.chosen_by == "auto":
        how = "found automatically after the last forced motion"
        if w.excitation_end_s is not None:
            how = (
                f"found automatically after the estimated end of forcing, dashed, at {w.excitation_end_s:.2f} s: where "
                "the signal's one-period mean last leaves its resting level; the slow last part of a move can drive "
                "the liquid past it without moving that mean (on the shared measured runs the moves ended 0.2-2.1 s "
                "later), so where the move's end is known, start the window after it (`window_s`)"
            )
    rep.add_figure(fig, f"The whole recording. Shaded: the free-decay window {w.t0_s:.2f}-{w.t1_s:.2f} s ({how}).")
    fig, ax = plt.subplots(figsize=(9, 3.2))
    res.plot_psd(i, ax)
    rep.add_figure(
        fig,
        f"Welch PSD of the window (nperseg {sp.nperseg} = {sp.nperseg / sp.fs_hz:.2f} s, resolution "
        f"{sp.resolution_hz:.3g} Hz, {sp.n_averages} averages; {sp.resample_note}). Dominant peak refined on the "
        f"log PSD: {sp.peak_f_hz:.4g} Hz. Triangles: secondary peaks (purple = harmonics of the mode, red = other "
        "modes). Orange: the fitted PT2 response through the same estimator; it should trace the main peak.",
    )
    fig, ax = plt.subplots(figsize=(9, 3.2))
    res.plot_fit(i, ax)
    rep.add_figure(
        fig,
        f"Time-domain fit: {res.fit_percent(i):.1f} % fit (NRMSE; 100 % = perfect, 0 % = no "
        "better than the mean). The residual (red) should look like noise.",
    )
    fig, ax = plt.subplots(figsize=(9, 2.8))
    res.plot_residual_acf(i, ax)
    rep.add_figure(
        fig,
        f"Residual autocorrelation. Bars outside the grey band mean the residual is not white (Ljung-Box p = "
        f"{res.ljung_box[i]:.2g} over {res.lb_lags[i]} lags); the intervals below account for correlation up "
        f"to the dashed line ({res.fit.hac_lags[i]} lags).",
    )


def _parameter_section(rep: Report, res: IdentResult) -> None:
    """The parameter table with intervals and each parameter's verdict."""
    rep.add_heading("Parameters")
    rows = []
    for k, e in res.parameters.items():
        label, unit = PARAMETER_LABELS[k]
        group = res.parameter_verdict(k)
        shown = [e.shown(), e.stderr, *e.interval_ends()]  # digits down to the error's
        rows.append([label, unit, *shown, group.quality if group else ""])
    if res.mass_kg is not None:
        rows.append(["liquid mass m", "kg", res.mass_kg, "given", "", "", ""])
    rep.add_table(
        ["parameter", "unit", "value", "sigma", "95 % low", "95 % high", "verdict"],
        rows,
        "Standard errors from a Newey-West sandwich covariance that allows correlated residuals; derived "
        "values by the delta method.",
    )
    if res.mass_kg is None:
        rep.add_text(
            "No liquid mass given (mass_kg), so the damping constant d is not reported (it scales with the mass)."
        )


def _second_mode_section(rep: Report, res: IdentResult, sm: SecondMode) -> None:
    """The two-mode fit tried for a strong second PSD peak, and whether it separated the modes."""
    m = sm.to_dict()
    rep.add_heading("Second mode")
    rows = [
        ["second mode f2 (Hz)", m["f_hz"]["value"], m["f_hz"]["stderr"]],
        ["second mode zeta2", m["zeta"]["value"], m["zeta"]["stderr"]],
        ["main mode f without the second mode (Hz)", m["single_mode_f_hz"], ""],
    ]
    rows += [
        [f"amplitude share A2/(A1+A2), {Path(res.signals[i].source).name}", share, ""]
        for i, share in enumerate(m["amplitude_share"])
    ]
    rep.add_table(
        ["", "value", "sigma"],
        rows,
        f"The PSD of {Path(res.signals[sm.signal].source).name} showed a non-harmonic peak at "
        f"{sm.peak.f_hz:.4g} Hz ({100 * sm.peak.relative:.0f} % of the main peak), so two damped modes "
        "were fitted together.",
    )
    rep.add_text(
        "The modes count as separated, and the main mode's numbers above come from the two-mode fit, when both "
        "modes stay off their search bounds, lie at least two Welch resolution bins apart, the second mode's "
        "amplitude stands three standard errors out, the two frequency intervals do not overlap and the main "
        "mode's intervals widen no more than two-fold. "
        + (
            "Here they are separated."
            if sm.separated
            else "Here they are not (" + "; ".join(sm.problems) + "), so the numbers above come from the single-mode "
            "fit and the verdict is uncertain."
        )
    )


def _cross_check_section(rep: Report, res: IdentResult) -> None:
    """Independent estimates held against the fit."""
    rep.add_heading("Cross-checks")
    rows = [["PT2 least squares (all signals)", res.parameters["f_hz"].value, res.parameters["zeta"].value, "", ""]]
    for i, checks in enumerate(res.cross_checks):
        for c in checks:
            rows.append([f"{c.method} ({Path(res.signals[i].source).name})", c.f_hz, c.zeta, c.n_periods, c.note])
    rep.add_table(
        ["method", "f (Hz)", "zeta", "periods used", "note"],
        rows,
        "Independent estimates; - means the method could not tell (see note). The frequencies should agree "
        "within about 2 %; a method that could use fewer than 8 periods is too coarse to overrule the fit.",
    )


def _model_section(rep: Report, res: IdentResult) -> None:
    """The identified transfer function's Bode plot and the geometric prior."""
    rep.add_heading("Identified model (seed eq. 5)")
    axes = res.plot_bode()
    rep.add_figure(
        axes[0].figure,
        "Bode plot of H(s) = (1/g) / ((l/g) s^2 + (d l/(g m)) s + 1): surface angle (rad) "
        "per container acceleration (m/s^2), from python-control.",
    )
    if res.prior:
        p = res.prior
        rep.add_heading("Geometric prior")
        rep.add_table(
            ["", "f (Hz)", "l (m)"],
            [
                [
                    "cylinder, R = {:g} m, h = {:g} m".format(p["container_radius_m"], p["fill_height_m"]),
                    p["f_hz"],
                    p["l_m"],
                ],
                ["identified", res.parameters["f_hz"].value, res.parameters["l_m"].value],
            ],
            f"Analytic first mode omega^2 = (g xi/R) tanh(xi h/R), xi = 1.8412; identified/prior = "
            f"{p['identified_over_prior']:.3f}. The mode was searched only in {p['band_hz'][0]:.3g}-"
            f"{p['band_hz'][1]:.3g} Hz, where the first mode is nearer than the second azimuthal one (xi = 3.054, "
            f"{p['second_azimuthal_f_hz']:.3g} Hz).",
        )
    if not math.isfinite(res.parameters["f_hz"].stderr):
        rep.add_text("The frequency's standard error is not finite: the fit is degenerate.")
