"""`identify` on the ten measured antisloshing runs (physical first mode 3.047 Hz): per-parameter verdicts, frequency
and its error, per run and jointly, with the container geometry given (R = 49 mm, h = 78 mm: the prior picks the
first mode) and without it. Target (issue 10): at least 85 % of the runs get a `good` frequency, and every `good`
frequency lies within 2 % of the first mode.
Also looks into the runs that were hard: the mode's envelope over each window (does it decay at all?) and, for the
run with a second mode, how the two-mode separation depends on where the window ends; draws all ten windows.
And how far the end of forcing that identify estimates from the signal alone lies from the move's end on the measured
clock (the command file's move end plus the lag validate fits with the physical first mode)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from bench_output import OUT, ROOT, write_results
from scipy import signal as sps

from sloshid.core.atomic import atomic_path
from sloshid.core.spectrum import to_uniform
from sloshid.identification.estimator import Identifier
from sloshid.identification.signals import load_signal
from sloshid.model.pendulum import SloshParams
from sloshid.model.pose import load_pose_log
from sloshid.validation.predict import LiquidModel
from sloshid.validation.validate import validate_run

F_PHYS = 3.047
GEOMETRY = {"container_radius_m": 0.049, "fill_height_m": 0.078}
"""The shared setup's cylinder (data README)."""
TARGET_GOOD_SHARE = 0.85
DATA = ROOT.parent / "shared" / "data" / "antisloshing" / "slosh"
SECOND_MODE_RUN = "Tilt_TRD_2D_0.3m_3s_30deg"
WINDOW_ENDS_S = (18.86, 20.0, 21.0, 22.0, 23.0, 24.6)
GROWING_RUN = "TRD_2D_0.3m_2.2s_270deg"
GROWING_WINDOWS_S = ((13.74, 20.0), (15.0, 23.8), (18.0, 23.8), (20.0, 23.8))
"""Sub-windows tried for the run whose wall amplitude grows after the motion (auto window 13.74-23.8 s)."""
"""Window ends tried for the second-mode run (18.86 s: where the first quiet stretch ends it; 24.6 s: the data end)."""
PHYSICAL = LiquidModel(SloshParams.from_modal(2 * math.pi * F_PHYS, 0.01, 1.0), radius_m=0.049, axis_offset_m=0.078)
"""The model each run's command file is aligned with its measurement by: the first mode, zeta 0.01, the pivot 78 mm
up the axis (data README)."""


def move_end_s(sig) -> float:
    """The end of the run's move on the measured clock: its command file's move end plus the lag validate fits."""
    run = validate_run(load_pose_log(DATA.parent / "commands" / f"{Path(sig.source).stem}.csv"), sig, PHYSICAL)
    return run.move_s[1] + run.alignment.lag_s


def band_envelope(sig, f_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(t, envelope) of the signal band-passed to 0.85-1.15 f (4th-order Butterworth, zero phase) via scipy's Hilbert."""
    u = to_uniform(sig.t_s, sig.value)
    sos = sps.butter(4, [0.85 * f_hz / (u.fs_hz / 2), 1.15 * f_hz / (u.fs_hz / 2)], btype="bandpass", output="sos")
    return u.t_s, np.abs(sps.hilbert(sps.sosfiltfilt(sos, u.value - u.value.mean())))


def envelope_growth(sig, f_hz: float, t0: float, t1: float) -> float:
    """Mean mode envelope in the window's last 2 s over that in its first 2 s (one period cut at each end against
    filter edge effects): below 1 the mode decays, at or above 1 it does not."""
    t, env = band_envelope(sig, f_hz)
    cut = 1 / f_hz
    first = env[(t >= t0 + cut) & (t <= t0 + 2)]
    last = env[(t >= t1 - 2) & (t <= t1 - cut)]
    return float(last.mean() / first.mean())


def draw(sigs, results) -> None:
    """One panel per run: the signal after the lead-in, the fit window, and the first mode's band envelope."""
    fig, axes = plt.subplots(4, 2, figsize=(13, 11))
    for ax, sig, res in zip(axes.ravel(), sigs, results):
        w, f = res.windows[0], res.parameters["f_hz"].value
        t, env = band_envelope(sig, f)
        keep = sig.t_s > w.t0_s - 4
        ax.plot(sig.t_s[keep], sig.value[keep], lw=0.5, color="0.3")
        ax.plot(t[t > w.t0_s - 4], env[t > w.t0_s - 4], color="tab:blue", lw=1.2, label=f"envelope near {f:.2f} Hz")
        ax.axvspan(w.t0_s, w.t1_s, color="tab:green", alpha=0.15, label="fit window")
        ax.set_ylim(-6, 8)
        ax.set_title(f"{Path(sig.source).stem}: frequency {res.groups['frequency'].quality}", fontsize=9)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("height (mm)")
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    with atomic_path(OUT / "identify_real.png") as tmp:
        fig.savefig(tmp, dpi=80)
    plt.close(fig)


def main() -> None:
    """Identify each run and all runs jointly; write reports/benchmarks/identify_real.{json,md,png}."""
    sigs = [load_signal(p) for p in sorted(DATA.glob("*.mat"))]
    runs, rows, results = [], [], []
    for sig in sigs:
        res = Identifier(**GEOMETRY).fit(sig).result
        bare = Identifier().fit(sig).result
        results.append(res)
        f, z, w = res.parameters["f_hz"], res.parameters["zeta"], res.windows[0]
        err = 100 * (f.value / F_PHYS - 1)
        growth = envelope_growth(sig, f.value, w.t0_s, w.t1_s)
        move_end = move_end_s(sig)
        forcing_end = math.nan if w.excitation_end_s is None else w.excitation_end_s
        sm = res.second_mode
        second = "-"
        if sm is not None:
            m = sm.to_dict()
            second = (
                f"{m['f_hz']['value']:.3f} Hz, zeta {m['zeta']['value']:.4f}, share "
                f"{100 * m['amplitude_share'][0]:.0f} %, {'separated' if sm.separated else 'not separated'}"
            )
        runs.append(
            {
                "run": Path(sig.source).stem,
                "quality": res.quality,
                "frequency_quality": res.groups["frequency"].quality,
                "damping_quality": res.groups["damping"].quality,
                "reasons": res.reasons,
                "without_geometry": {
                    "f_hz": bare.parameters["f_hz"].value,
                    "frequency_quality": bare.groups["frequency"].quality,
                    "damping_quality": bare.groups["damping"].quality,
                    "reasons": bare.reasons,
                },
                "f_hz": f.value,
                "f_stderr": f.stderr,
                "f_err_pct": err,
                "zeta": z.value,
                "zeta_stderr": z.stderr,
                "fit_percent": res.fit_percent(0),
                "window_s": [w.t0_s, w.t1_s],
                "envelope_growth": growth,
                "move_end_s": move_end,
                "estimated_forcing_end_s": w.excitation_end_s,
                "second_mode": sm.to_dict() if sm is not None else None,
            }
        )
        rows.append(
            [
                Path(sig.source).stem,
                f"{res.groups['frequency'].quality} / {res.groups['damping'].quality}",
                f"{bare.groups['frequency'].quality}, {bare.parameters['f_hz'].value:.4f}",
                f"{f.value:.4f} ± {f.stderr:.4f}",
                f"{err:+.2f}",
                f"{z.value:.4f} ± {z.stderr:.4f}",
                f"{res.fit_percent(0):.1f}",
                f"{w.t0_s:.1f}-{w.t1_s:.1f}",
                f"{growth:.2f}",
                f"{move_end:.2f}: {forcing_end - move_end:+.2f}, {w.t0_s - move_end:+.2f}",
                second,
                "; ".join(res.reasons) or "-",
            ]
        )
    joint = Identifier(**GEOMETRY).fit(sigs).result
    jf = joint.parameters["f_hz"]
    rows.append(
        [
            "joint (all 8)",
            f"{joint.groups['frequency'].quality} / {joint.groups['damping'].quality}",
            "",
            f"{jf.value:.4f} ± {jf.stderr:.4f}",
            f"{100 * (jf.value / F_PHYS - 1):+.2f}",
            f"{joint.parameters['zeta'].value:.4f} ± {joint.parameters['zeta'].stderr:.4f}",
            "",
            "",
            "",
            "",
            "",
            "; ".join(joint.reasons) or "-",
        ]
    )
    draw(sigs, results)

    tilt = next(s for s in sigs if Path(s.source).stem == SECOND_MODE_RUN)
    t0 = next(r for r in runs if r["run"] == SECOND_MODE_RUN)["window_s"][0]
    sweep = []
    for t1 in WINDOW_ENDS_S:
        res = Identifier(window_s=(t0, min(t1, float(tilt.t_s[-1])))).fit(tilt).result
        sm = res.second_mode
        two = sm.fit
        sweep.append(
            {
                "t1_s": t1,
                "single_f_hz": sm.single.omega_rad_s / (2 * math.pi),
                "two_mode_f1_hz": two.omega_rad_s / (2 * math.pi),
                "f2_hz": two.second.omega_rad_s / (2 * math.pi),
                "zeta2": two.second.zeta,
                "second_amplitude_snr": two.amplitude(0, 1) / two.amplitude_se(0, 1),
                "separated": sm.separated,
                "problems": list(sm.problems),
            }
        )
    sweep_lines = [
        "",
        f"Window-end sweep for {SECOND_MODE_RUN} (start {t0:.2f} s):",
        "",
        "| window end (s) | single-mode f (Hz) | two-mode f1 (Hz) | f2 (Hz) | zeta2 | second amplitude / se | separated |",
        "|---|---|---|---|---|---|---|",
    ]
    sweep_lines += [
        f"| {s['t1_s']:.2f} | {s['single_f_hz']:.4f} | {s['two_mode_f1_hz']:.4f} | {s['f2_hz']:.3f} | "
        f"{s['zeta2']:.4f} | {s['second_amplitude_snr']:.1f} | {'yes' if s['separated'] else 'no: ' + '; '.join(s['problems'])} |"
        for s in sweep
    ]

    grow_sig = next(s for s in sigs if Path(s.source).stem == GROWING_RUN)
    grow_lines = [
        "",
        f"Sub-windows of {GROWING_RUN} (does any part of the record decay?):",
        "",
        "| window (s) | f (Hz) | zeta | verdict |",
        "|---|---|---|---|",
    ]
    grow_sweep = []
    for w in GROWING_WINDOWS_S:
        res = Identifier(window_s=w).fit(grow_sig).result
        grow_sweep.append(
            {
                "window_s": list(w),
                "f_hz": res.parameters["f_hz"].value,
                "zeta": res.parameters["zeta"].value,
                "quality": res.quality,
                "reasons": res.reasons,
            }
        )
        grow_lines.append(
            f"| {w[0]:.2f}-{w[1]:.2f} | {res.parameters['f_hz'].value:.4f} | {res.parameters['zeta'].value:.4f} | "
            f"{res.quality} |"
        )
    good = [r for r in runs if r["frequency_quality"] == "good"]
    early = [r["move_end_s"] - r["estimated_forcing_end_s"] for r in runs if r["estimated_forcing_end_s"] is not None]
    good_bare = [r for r in runs if r["without_geometry"]["frequency_quality"] == "good"]
    summary = {
        "n_runs": len(runs),
        "n_good_frequency": len(good),
        "good_frequency_share": len(good) / len(runs),
        "good_within_2pct": all(abs(r["f_err_pct"]) <= 2 for r in good),
        "all_within_2pct": all(abs(r["f_err_pct"]) <= 2 for r in runs),
        "n_good_frequency_without_geometry": len(good_bare),
        "good_within_2pct_without_geometry": all(
            abs(r["without_geometry"]["f_hz"] / F_PHYS - 1) <= 0.02 for r in good_bare
        ),
        "n_good_damping": sum(r["damping_quality"] == "good" for r in runs),
        "target_met": len(good) >= TARGET_GOOD_SHARE * len(runs) and all(abs(r["f_err_pct"]) <= 2 for r in good),
        "joint_f_hz": jf.value,
        "forcing_end_early_s": [min(early), max(early)],
        "n_windows_before_move_end": sum(r["window_s"][0] < r["move_end_s"] for r in runs),
    }
    notes = "\n".join(
        [
            f"With the geometry: {len(good)} of {len(runs)} runs get a good frequency (target >= "
            f"{100 * TARGET_GOOD_SHARE:.0f} %); every good frequency within ±2 % of 3.047 Hz: "
            f"{summary['good_within_2pct']}; all runs within ±2 %: {summary['all_within_2pct']}. Without the geometry: "
            f"{len(good_bare)} of {len(runs)} good, all within ±2 %: {summary['good_within_2pct_without_geometry']}. "
            f"Damping good in {summary['n_good_damping']} of {len(runs)}: on these nonlinear wall-height records the "
            "log decrement and the fit disagree on zeta by more than a factor 1.5, or the residual fades with the mode.",
            "",
            "Envelope growth: mean envelope of the first mode (band 0.85-1.15 f, Hilbert) in the window's last 2 s over its "
            "first 2 s; a free decay gives clearly less than 1. Figure: identify_real.png (each run's window and envelope).",
            "",
            "End of forcing: identify estimates it from the signal alone, as the last time the signal's one-period mean "
            "leaves its resting level by more than half the swing. The move's end on the measured clock is the command "
            "file's (its last change over 10 µm) plus the lag validate fits with the physical first mode. The estimate "
            f"lies {min(early):.2f}-{max(early):.2f} s before the move's end in {len(early)} of {len(runs)} runs, and "
            f"{summary['n_windows_before_move_end']} windows start before the move ends: the slow last part of a move "
            "barely moves the one-period mean, so identify marks that end as an estimate.",
            *sweep_lines,
            *grow_lines,
            "",
            "Reading the hard runs. TRD_2D_0.3m_2.2s_270deg: the window already runs to the end of the recording and the "
            "first mode's envelope grows over it (growth {:.2f}, see the figure): after the 270 deg yaw the wall amplitude "
            "keeps rising until the video stops, so the record holds no free decay to identify (energy passing between the "
            "two degenerate horizontal modes, or a swirl, too slow to resolve as a second peak in 10 s). zeta lands on its "
            "bound 0 and the run stays uncertain; no sub-window of the record decays either (zeta 0 in each, above). {}: the 3.97 Hz second mode of the "
            "data README beats with the first, and the first quiet stretch of the ring-down (18.86 s) was a beat's null; "
            "with two modes in the PSD the window is carried to the end of the ring-down, where the two-mode fit separates "
            "them (second amplitude {:.1f} standard errors there, see the sweep). Its main-mode frequency hardly "
            "depends on the second mode (single- and two-mode fits agree within {:.4f} Hz at every window end) but falls "
            "as the window grows ({:.3f} to {:.3f} Hz): the large, nonlinear early swings ring faster than the small late "
            "ones.".format(
                next(r for r in runs if r["run"] == "TRD_2D_0.3m_2.2s_270deg")["envelope_growth"],
                SECOND_MODE_RUN,
                sweep[-1]["second_amplitude_snr"],
                max(abs(w["single_f_hz"] - w["two_mode_f1_hz"]) for w in sweep),
                sweep[0]["single_f_hz"],
                sweep[-1]["single_f_hz"],
            ),
        ]
    )
    write_results(
        "identify_real",
        {
            "f_phys_hz": F_PHYS,
            "summary": summary,
            "runs": runs,
            "window_end_sweep": sweep,
            "growing_run_windows": grow_sweep,
        },
        "identify: ten measured antisloshing runs",
        [
            "run",
            "verdict frequency / damping (geometry given)",
            "without geometry: frequency verdict, f (Hz)",
            "f (Hz) ± sigma",
            "error vs 3.047 Hz (%)",
            "zeta ± sigma",
            "fit %",
            "window (s)",
            "envelope growth",
            "move end (s): estimated end of forcing, window start (s from it)",
            "second mode",
            "reasons",
        ],
        rows,
        notes,
    )


if __name__ == "__main__":
    main()
