"""Predict motion kinds the fit never saw: leave-one-kind-out on the shared antisloshing runs, beside fixed physics.

The nine runs whose command files agree with their slosh fall into seven motion kinds (issue 38's table); each kind is
predicted by the physics-first model fitted on the other six (`fit_io`: priors from the geometry, the wall read in the
two camera planes of the shared setup, 90 deg apart along the tool frame's axes) and, in the same run, by the
fixed-physics reference with nothing fitted (the cylinder's first mode 3.047 Hz, zeta 0.01, the pendulum pair in the
world frame at the pivot 0.078 m up the axis, gravity g + az, wall R tan(angle)). `Tilt_TRD` (its tilt sense flipped
in the command file) is never fitted and is predicted by the model fitted on all nine. The band's model error for a
kind is calibrated on the other kinds' held-out errors only (the RMS of log(measured / predicted peak)), so coverage
is scored as for a new kind. Targets (issue 38): median |peak error| <= 6 %, median fit >= 68 %, >= 90 % of runs
within 20 %, no kind worse than fixed physics by more than 5 points of peak error, band coverage >= 85 %.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np
from bench_output import ROOT, write_results

from sloshid.identification.estimator import IdentSettings
from sloshid.identification.pt2fit import nrmse_fit_percent
from sloshid.identification.signals import load_signal
from sloshid.model.pendulum import SloshParams, cylinder_first_mode_omega
from sloshid.model.pose import load_pose_log
from sloshid.validation.iofit import FITTED, fit_io
from sloshid.validation.predict import MODEL_ERROR_LOG_SD, LiquidModel
from sloshid.validation.validate import validate_run

DATA = ROOT.parent / "shared" / "data" / "antisloshing"
R, H, D = 0.049, 0.078, 0.078
VIEWS_DEG = 0.0
"""The two cameras sit 90 deg apart on the end-effector; taken along the tool frame's x and y axes."""
KINDS = {
    "3-D figure-eight turning 900 deg": ("LE_3D_0m_5s_900deg",),
    "planar circle turning 720 deg": ("RD_2D_0.3m_6.5s_720deg",),
    "circle turning 720 deg with vertical travel": ("RD_3D_0.3m_6.8s_720deg",),
    "tilted circle": ("Tilt_RD_2D_0.3m_7s_30deg",),
    "planar figure-eight turning 900 deg": ("LE_2D_0m_5s_900deg",),
    "translation turning 270 deg": ("TRD_2D_0.3m_2.2s_270deg", "TRD_3D_0.3m_3s_270deg"),
    "tilted figure-eight": ("Tilt_LE_2D_0m_6s_20deg", "Tilt_LE_3D_0m_7s_20deg"),
}
APART = "Tilt_TRD_2D_0.3m_3s_30deg"
ALL = tuple(n for runs in KINDS.values() for n in runs)
PROCESSES = 2
ISSUE_AFTER_S = 5.0
"""Issue 38 scored its unseen runs over the move and this long after it; the report gives that fit beside the
record's."""
FIXED = LiquidModel(
    SloshParams.from_modal(cylinder_first_mode_omega(R, H), 0.01), R, D, spherical=False, model_error=MODEL_ERROR_LOG_SD
)


def load(name: str):
    """(pose log, measured signal) of a shared run."""
    return load_pose_log(DATA / "commands" / f"{name}.csv"), load_signal(DATA / "slosh" / f"{name}.mat")


def fit_kind(kind: str) -> tuple[str, LiquidModel, dict]:
    """The model fitted on every kind but `kind` ('all': on all of them), and the fit's facts."""
    train = [n for k, runs in KINDS.items() if k != kind for n in runs]
    poses, sigs = zip(*(load(n) for n in train))
    t0 = time.perf_counter()
    settings = IdentSettings(container_radius_m=R, fill_height_m=H)
    io = fit_io(list(poses), list(sigs), R, D, settings=settings, names=train, views_deg=VIEWS_DEG)
    facts = {k: io.parameters[k].value for k in FITTED}
    facts.update(seconds=time.perf_counter() - t0, at_bound=io.at_bound, n_simulations=io.n_simulations)
    print(kind, {k: round(v, 4) for k, v in facts.items() if k in FITTED}, f"{facts['seconds']:.0f} s", flush=True)
    return kind, io.model, facts


def row(name: str, kind: str, models: dict[str, LiquidModel]) -> dict:
    """One run scored under each model: fit %, peak error %, the log error of its peak, band and coverage."""
    pose, sig = load(name)
    out = {"run": name, "kind": kind}
    for label, model in models.items():
        v = validate_run(pose, sig, model, name)
        s = v.scores
        window = (v.t_s >= v.move_s[0]) & (v.t_s <= v.move_s[1] + ISSUE_AFTER_S)
        out[label] = {
            "fit_percent": s["all"].fit_percent,
            "fit_move_percent": nrmse_fit_percent(v.measured[window], v.predicted[window]),
            "peak_error_percent": s["during"].peak_error_percent,
            "log_peak_error": math.log(s["during"].peak_measured / s["during"].peak_predicted),
            "band_peak": list(v.band_peak),
            "peak_in_band": v.peak_in_band,
            "notes": list(v.notes),
        }
    return out


def summarise(rows: list[dict], label: str) -> dict:
    """Medians, share within 20 % and band coverage of one model over rows."""
    peaks = [abs(r[label]["peak_error_percent"]) for r in rows]
    return {
        "median_abs_peak_error_percent": float(np.median(peaks)),
        "median_fit_percent": float(np.median([r[label]["fit_percent"] for r in rows])),
        "median_fit_move_percent": float(np.median([r[label]["fit_move_percent"] for r in rows])),
        "share_within_20_percent": float(np.mean([p <= 20 for p in peaks])),
        "band_coverage": float(np.mean([r[label]["peak_in_band"] for r in rows])),
        "n_runs": len(rows),
    }


def score_job(job: tuple[str, str, LiquidModel, LiquidModel]) -> dict:
    """Score one held-out run under the fitted model and fixed physics (each with the fold's model error)."""
    name, kind, fitted, fixed = job
    return row(name, kind, {"physics_first": fitted, "fixed_physics": fixed})


def main() -> None:
    """Fit per held-out kind (and on all), calibrate each fold's model error on the others, score, write reports."""
    with ProcessPoolExecutor(PROCESSES) as pool:
        fits = {k: (m, f) for k, m, f in pool.map(fit_kind, [*KINDS, "all"])}
        # first pass: the held-out log errors of every kind, with the model error of the code
        first = list(pool.map(score_job, [(n, k, fits[k][0], FIXED) for k, runs in KINDS.items() for n in runs]))
        sds = {}
        for kind in KINDS:
            others = [r for r in first if r["kind"] != kind]
            sds[kind] = {
                lab: float(np.sqrt(np.mean([r[lab]["log_peak_error"] ** 2 for r in others])))
                for lab in ("physics_first", "fixed_physics")
            }
        sds["all"] = {
            lab: float(np.sqrt(np.mean([r[lab]["log_peak_error"] ** 2 for r in first])))
            for lab in ("physics_first", "fixed_physics")
        }
        jobs = [
            (
                n,
                k,
                replace(fits[k][0], model_error=sds[k]["physics_first"]),
                replace(FIXED, model_error=sds[k]["fixed_physics"]),
            )
            for k, runs in [*KINDS.items(), ("all", (APART,))]
            for n in runs
        ]
        rows = list(pool.map(score_job, jobs))
    held, apart = [r for r in rows if r["run"] != APART], [r for r in rows if r["run"] == APART]
    labels = ("physics_first", "fixed_physics")
    summary = {lab: summarise(held, lab) for lab in labels}
    per_kind = {}
    for kind in KINDS:
        rs = [r for r in held if r["kind"] == kind]
        per_kind[kind] = {lab: summarise(rs, lab) for lab in labels}
    worst = max(
        per_kind[k]["physics_first"]["median_abs_peak_error_percent"]
        - per_kind[k]["fixed_physics"]["median_abs_peak_error_percent"]
        for k in KINDS
    )
    data = {
        "rows": held,
        "tilt_trd_apart": apart,
        "summary": summary,
        "per_kind": per_kind,
        "worst_kind_vs_fixed_points": worst,
        "model_error_log_sd": sds,
        "fits": {k: f for k, (_, f) in fits.items()},
    }
    table = []
    for kind in KINDS:
        for r in (r for r in held if r["kind"] == kind):
            table.append([kind, r["run"], *(cell(r[lab]) for lab in labels)])
    for r in apart:
        table.append(["(apart, fitted on all)", r["run"], *(cell(r[lab]) for lab in labels)])
    table.append(["median", "", *(median_cell(summary[lab]) for lab in labels)])
    s, f = summary["physics_first"], summary["fixed_physics"]
    notes = (
        "Cells: fit % over the record / peak error % during the move / the 95 % band of the peak (! measured outside). "
        f"Physics-first, leave-one-kind-out: median |peak error| {s['median_abs_peak_error_percent']:.1f} % (target "
        f"<= 6; fixed physics {f['median_abs_peak_error_percent']:.1f}), median fit {s['median_fit_percent']:.1f} % "
        f"(target >= 68; fixed {f['median_fit_percent']:.1f}); over the move and {ISSUE_AFTER_S:g} s after it, as the "
        f"issue scored its unseen runs, {s['median_fit_move_percent']:.1f} % (fixed {f['median_fit_move_percent']:.1f}); "
        "within 20 %: "
        f"{100 * s['share_within_20_percent']:.0f} % of runs (target >= 90; fixed "
        f"{100 * f['share_within_20_percent']:.0f}), worst kind against fixed physics {worst:+.1f} points of peak error "
        f"(target <= +5), band coverage {100 * s['band_coverage']:.0f} % (target >= 85; fixed physics with its own "
        f"calibrated error {100 * f['band_coverage']:.0f} %). Fits: "
        + "; ".join(
            f"without {k}: " + ", ".join(f"{p} {v[p]:.3g}" for p in FITTED) + f" ({v['seconds']:.0f} s)"
            for k, (_, v) in fits.items()
        )
        + "."
    )
    write_results(
        "validate_real",
        data,
        "Predicting unseen motion kinds of the shared runs: physics-first model vs fixed physics",
        ["kind held out", "run", "physics-first (fitted on the other kinds)", "fixed physics"],
        table,
        notes,
    )


def cell(s: dict) -> str:
    """'fit / peak error / band'."""
    lo, hi = s["band_peak"]
    return f"{s['fit_percent']:.1f} / {s['peak_error_percent']:+.1f} / {lo:.3g}-{hi:.3g}{'' if s['peak_in_band'] else ' !'}"


def median_cell(s: dict) -> str:
    """Median fit / median |peak error| / coverage."""
    return (
        f"{s['median_fit_percent']:.1f} / {s['median_abs_peak_error_percent']:.1f} / "
        f"{100 * s['band_coverage']:.0f} % in band"
    )


if __name__ == "__main__":
    main()
