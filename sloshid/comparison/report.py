"""The comparison as one HTML page: verdict, Fig. 7 equivalent, score table, closed loop, robustness, camera rate."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from sloshid.comparison.recommend import slowed_label
from sloshid.report.html import Report

if TYPE_CHECKING:  # the comparison draws itself through this module: its class is named for the annotations only
    from sloshid.comparison.compare import Comparison
    from sloshid.comparison.recommend import Recommendation

SCORE_HEADER = (
    "method",
    "transfer time (s)",
    "peak relative angle during move (deg)",
    "residual after arrival (deg)",
    "peak tilt (deg)",
    "peak tilt rate (deg/s)",
    "robot limits",
    "move limits",
    "min obstacle clearance (m)",
    "build time (s)",
    "notes",
)


def score_rows(comp: Comparison) -> list[list[object]]:
    """One table row per method; a method that could not be built says 'not applicable' and why; the move sent, when
    it is the recommended method's slowed for the arm, under that method's row (`Comparison.slowed_row`)."""
    slowed = comp.slowed_row()
    rows: list[list[object]] = []
    for r in comp.results:
        if not r.applicable:
            rows.append([r.label, "not applicable", *[""] * 8, r.reason])
            continue
        s = r.require_score()
        clearance = "-" if s.min_clearance_m is None else s.min_clearance_m
        notes = "; ".join(
            s.limits_failed
            + (["collides with an obstacle"] if s.min_clearance_m is not None and s.min_clearance_m < 0 else [])
        )
        rows.append(
            [
                r.label,
                s.transfer_time_s,
                s.peak_during_deg,
                s.residual_deg,
                s.peak_tilt_deg,
                s.peak_tilt_rate_deg_s,
                "ok" if s.robot_limits_ok else "FAIL",
                "ok" if s.move_limits_ok else "FAIL",
                clearance,
                r.build_time_s,
                notes,
            ]
        )
        if slowed is not None and slowed.method == r.key:
            sent = (
                "the move sent: re-planned slower for the Panda of [robot]; peak and residual at the identified "
                "frequency, from the band check above; the other columns not scored"
            )
            seconds, peak, residual = slowed.transfer_time_s, slowed.peak_during_deg, slowed.residual_deg
            rows.append([slowed.label, seconds, peak, residual, *[None] * 6, sent])
    return rows


def fig7(comp: Comparison):
    """Seed Fig. 7 equivalent: relative angle over time for all methods, linear and log scale; dots mark arrival."""
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for r in comp.results:
        if not r.applicable:
            continue
        resp = r.require_response()
        for ax in axes:
            (line,) = ax.plot(resp.t_s, resp.rel_angle_deg, lw=1.2, label=r.label)
            i = int(np.searchsorted(resp.t_s, resp.t_arrival_s))
            ax.plot(resp.t_s[i], max(resp.rel_angle_deg[i], 1e-4), "o", color=line.get_color(), ms=5)
    axes[0].set_ylabel("relative angle liquid - container (deg)")
    axes[1].set_yscale("log")
    axes[1].set_ylim(1e-4, None)
    axes[1].axhline(comp.settings.residual_ok_deg, color="k", ls="--", lw=0.8)
    axes[1].set_ylabel("same, log scale (deg)")
    axes[1].set_xlabel("time from start of move (s)")
    axes[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    return fig


def closed_loop_figure(comp: Comparison):
    """Per method: relative angle through robot tracking, linear (python-control) vs nonlinear pendulum."""
    keys = list(comp.closed_loop)
    labels = {r.key: r.label for r in comp.results}
    cols = 3
    rows = max(1, int(np.ceil(len(keys) / cols)))
    fig, axes = plt.subplots(rows, cols, figsize=(12, 2.8 * rows), squeeze=False)
    for ax, key in zip(axes.flat, keys):
        cl = comp.closed_loop[key]
        ax.plot(cl.t_s, cl.rel_linear_deg, lw=1.5, label="linear (python-control)")
        ax.plot(cl.t_s, cl.rel_nonlinear_deg, lw=1, ls="--", label="nonlinear (RK4)")
        ax.axvline(cl.t_arrival_s, color="grey", lw=0.7)
        ax.set_title(f"{labels[key]}: gap {cl.max_gap_deg:.2g} deg", fontsize=9)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("deg")
    for ax in list(axes.flat)[len(keys) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def linearity_figure(comp: Comparison):
    """Peak relative angle of the constant-acceleration move vs its acceleration: linear and nonlinear."""
    fig, ax = plt.subplots(figsize=(6, 4))
    acc = [p.acc_m_s2 for p in comp.linearity]
    ax.plot(acc, [p.peak_linear_deg for p in comp.linearity], "o-", label="linear (python-control)")
    ax.plot(acc, [p.peak_nonlinear_deg for p in comp.linearity], "s--", label="nonlinear pendulum")
    ax.axhline(45, color="r", lw=0.8, ls=":", label="seed Fig. 8: ~45 deg observed")
    ax.set_xlabel("acceleration of the constant-acceleration move (m/s^2)")
    ax.set_ylabel("peak relative angle (deg)")
    gap = ax.twinx()
    gap.plot(acc, [p.max_gap_deg for p in comp.linearity], "^:", color="grey", label="largest gap (right axis)")
    gap.set_ylabel("largest linear - nonlinear gap over time (deg)", color="grey")
    ax.legend(handles=ax.get_lines() + gap.get_lines(), fontsize=8, loc="upper left", bbox_to_anchor=(1.15, 1))
    return fig


def robustness_figure(comp: Comparison):
    """Residual slosh vs true/identified frequency and damping ratios, one curve per method (log scale)."""
    rob = comp.robustness
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for label, res in rob.residual_vs_omega_deg.items():
        axes[0].plot(100 * (rob.omega_factors - 1), np.maximum(res, 1e-4), "o-", ms=3, label=label)
        axes[1].plot(rob.zeta_factors, np.maximum(rob.residual_vs_zeta_deg[label], 1e-4), "o-", ms=3, label=label)
    for ax in axes:
        ax.axhline(comp.settings.residual_ok_deg, color="k", ls="--", lw=0.8)
        ax.set_yscale("log")
    axes[1].set_xscale("log")
    axes[0].set_xlabel("true natural frequency error (%)")
    axes[1].set_xlabel("true damping ratio / identified")
    axes[0].set_ylabel("residual relative angle after arrival (deg)")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    return fig


def camera_figure(comp: Comparison):
    """Left: feedback residual against camera rate (dashed: without feedback). Right: the peak a camera sees."""
    fig, (ax, seen) = plt.subplots(1, 2, figsize=(12, 4))
    for base, ref in comp.no_feedback_at_camera_error.items():
        pts = [c for c in comp.camera if c.base == base]
        fps = [c.camera_fps for c in pts]
        (line,) = ax.plot(fps, [c.residual_deg for c in pts], "o-", label=f"{base} + feedback")
        ax.axhline(ref, color=line.get_color(), ls="--", lw=0.8, label=f"{base}, no feedback")
        seen.plot(fps, [c.seen_peak_deg for c in pts], "o-", color=line.get_color(), label=f"{base}: seen by camera")
        seen.axhline(pts[0].true_peak_deg, color=line.get_color(), ls="--", lw=0.8, label=f"{base}: true peak")
    fps_ticks = sorted({c.camera_fps for c in comp.camera})
    for a in (ax, seen):
        a.set_xscale("log")
        a.set_xticks(fps_ticks, [f"{f:g}" for f in fps_ticks])  # plain frame rates, not powers of ten
        a.minorticks_off()
        a.set_xlabel("camera frame rate (fps)")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.18))
    seen.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    ax.set_yscale("log")
    ax.set_ylabel("residual relative angle (deg)")
    seen.set_ylabel("peak relative angle during the move (deg)")
    return fig


def _recommendation_table(rep: Report, comp: Comparison, rec: Recommendation) -> None:
    """The band check behind the recommendation (`rec`, the comparison's): each method tried, fastest first, at the
    band's ends and middle."""
    labels = {r.key: r.label for r in comp.results}
    if rec.method is not None and rec.arm is not None and rec.arm.slowed:  # its check is of the move slowed
        labels[rec.method] = slowed_label(labels[rec.method])
    rows = []
    for key, c in rec.checks.items():
        cells = [f"{p:.2g} / {r:.2g}" for p, r in zip(c.peak_during_deg, c.residual_deg)]
        rows.append([labels[key], *cells, c.loses_because or "slosh-free over the band"])
    f = next(iter(rec.checks.values())).f_hz if rec.checks else (rec.band_hz[0], comp.params.f_hz, rec.band_hz[1])
    rep.add_table(
        ["method", *(f"at {x:.3g} Hz: peak / residual (deg)" for x in f), "outcome"],
        rows,
        f"Band {rec.band_hz[0]:.3g}-{rec.band_hz[1]:.3g} Hz: {rec.band_source}. Methods that break a limit or collide "
        "are not simulated over the band; slower methods than the recommended one are not tried.",
    )


def build_report(
    comp: Comparison, title: str = "sloshid compare", links: dict[str, str] | None = None, progress: bool = False
) -> Report:
    """Assemble the page; every figure says what to look at; `links` (text -> relative href) point back to a
    pipeline's index and to the stage's files; `progress` counts the figures on a tqdm bar."""
    s = comp.settings
    p = comp.params
    rep = Report(title, progress=progress)
    rep.add_links(links or {})
    rec = comp.recommendation
    rep.add_text(comp.verdict, f"verdict-{rec.risk if rec else 'uncertain'}")
    if rec is not None:
        _recommendation_table(rep, comp, rec)
    rep.add_text(
        f"Liquid: f = {p.f_hz:.3g} Hz, zeta = {p.zeta:.3g} (l = {p.l_m:.4g} m, d = {p.d_ns_per_m:.3g} Ns/m). "
        "Every method is scored by the same nonlinear pendulum simulation (RK4 on the 1 kHz grid): the relative angle "
        "between liquid surface and container is what spills liquid."
    )
    rep.add_heading("Relative slosh angle over time (the seed's Fig. 7, all methods)")
    rep.add_figure(
        fig7(comp),
        "Relative angle liquid minus container; dots mark each method's arrival. Lower panel: "
        f"log scale, dashed line = {s.residual_ok_deg:g} deg (slosh-free threshold).",
    )
    rep.add_heading("Scores")
    rep.add_table(
        SCORE_HEADER,
        score_rows(comp),
        "Robot limits: Franka Panda Cartesian limits (or [robot]); "
        "move limits: the scenario's acc_max, vel_max, tilt_max_deg, tilt_rate_max_deg_s.",
    )
    _closed_loop_section(rep, comp)
    _robustness_section(rep, comp)
    if comp.camera:
        _camera_section(rep, comp)
    return rep


def _closed_loop_section(rep: Report, comp: Comparison) -> None:
    """Each trajectory through the robot's tracking and the linearised liquid, and where linearisation holds."""
    s = comp.settings
    rep.add_heading("Closed loop: robot tracking and liquid in python-control")
    rep.add_figure(
        closed_loop_figure(comp),
        f"Each trajectory through a {s.robot_bandwidth_hz:g} Hz second-order "
        "tracking loop in series with the linearised liquid (seed eq. 5, python-control forced_response), "
        "beside the nonlinear pendulum under the same executed motion; grey line = arrival.",
    )
    if len(comp.linearity) >= 3:  # two points make no curve: the table below says it all
        rep.add_figure(
            linearity_figure(comp),
            "Where linearisation holds: the constant-acceleration move at growing "
            "accelerations; the curves part where the small-angle model stops being valid.",
        )
    rep.add_table(
        ("acceleration (m/s^2)", "peak linear (deg)", "peak nonlinear (deg)", "largest gap (deg)"),
        [[q.acc_m_s2, q.peak_linear_deg, q.peak_nonlinear_deg, q.max_gap_deg] for q in comp.linearity],
    )


def _robustness_section(rep: Report, comp: Comparison) -> None:
    """Residual slosh against frequency and damping error, and each method's tolerated frequency error."""
    s = comp.settings
    rep.add_heading("Robustness to model error")
    rep.add_figure(
        robustness_figure(comp),
        "Every method keeps its nominal plan while the true liquid differs "
        "(feedback methods re-run their loop). Below the dashed line the move is slosh-free.",
    )
    bands = []
    for r in comp.results:
        if r.applicable:
            bands.append([r.label, comp.robustness.describe_band(r.label, s.residual_ok_deg)])
    rep.add_table(("method", f"frequency error with residual <= {s.residual_ok_deg:g} deg"), bands)


def _camera_section(rep: Report, comp: Comparison) -> None:
    """Feedback residual against camera rate, and what a slow camera misses (seed Remark 1)."""
    s = comp.settings
    f = s.feedback
    rep.add_heading("Feedback and camera rate (seed Remark 1)")
    rep.add_figure(
        camera_figure(comp),
        f"Kalman filter + LQR on a camera measurement of the float angle "
        f"(noise {f.noise_deg:g} deg, latency {1000 * f.latency_s:g} ms) with the true frequency "
        f"{100 * (s.camera_omega_factor - 1):+.0f} % off the model; dashed = the same feedforward "
        "without feedback. Right: the feedforward's peak relative angle (nominal liquid, no feedback) "
        "as frames at that rate sample it, against the true peak: a slow camera misses fast peaks "
        "(the seed's Remark 1).",
    )
    rep.add_table(
        (
            "feedforward",
            "camera (fps)",
            "transfer time (s)",
            "peak during (deg)",
            "residual (deg)",
            "peak seen by camera (deg)",
            "true peak (deg)",
        ),
        [
            [
                c.base,
                c.camera_fps,
                c.transfer_time_s,
                c.peak_during_deg,
                c.residual_deg,
                c.seen_peak_deg,
                c.true_peak_deg,
            ]
            for c in comp.camera
        ],
    )


def save_report(
    comp: Comparison, directory: str | Path, links: dict[str, str] | None = None, progress: bool = False
) -> Path:
    """Write the comparison report to `directory/index.html`."""
    return build_report(comp, links=links, progress=progress).save(directory)
