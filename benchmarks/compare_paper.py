"""Issue 5 targets, measured in one run: every method on the seed's 1-D case (data/scenarios/paper_1d.toml) and on the
3-D move with obstacles (data/scenarios/paper_3d.toml); writes reports/benchmarks/compare_paper.{json,md} and the two
HTML reports (figures embedded) under reports/benchmarks/compare_paper_{1d,3d}/."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from plan_common import OUT, scenario, write

from sloshid.comparison.compare import compare, from_scenario
from sloshid.comparison.report import save_report

BAND = (0.9, 1.1)
"""Frequency-error band in which the robust variant must stay at or below the residual threshold."""


def run(name: str, **compare_changes) -> tuple[dict, object]:
    """Compare on a bundled scenario (its [liquid]), with [compare] settings changed; (summary, Comparison)."""
    sc = scenario(name)
    sc = dataclasses.replace(sc, compare={**sc.compare, **compare_changes})
    t0 = time.perf_counter()
    comp = compare(from_scenario(sc, sc.liquid), progress=True)
    summary = comp.to_dict()
    summary["wall_s"] = time.perf_counter() - t0
    save_report(comp, OUT / f"compare_paper_{name.split('_')[-1]}")
    return summary, comp


def acc_for_angle(linearity: list[dict], angle_deg: float) -> float | None:
    """Acceleration at which the nonlinear constant-acceleration peak reaches `angle_deg` (interpolated)."""
    acc = np.array([p["acc_m_s2"] for p in linearity])
    peak = np.array([p["peak_nonlinear_deg"] for p in linearity])
    return float(np.interp(angle_deg, peak, acc)) if peak.max() >= angle_deg else None


def rows_of(summary: dict) -> list[list]:
    """Markdown rows: one per method."""
    rows = []
    for m in summary["methods"]:
        if not m["applicable"]:
            rows.append([m["label"], "n/a", "", "", "", "", m["reason"]])
            continue
        band = m["omega_band_residual_ok"]
        band_txt = "none" if band is None else f"{100 * (band[0] - 1):+.0f}..{100 * (band[1] - 1):+.0f} %"
        clear = "" if m["min_clearance_m"] is None else f"clearance {m['min_clearance_m']:.3f} m"
        notes = "; ".join([*m["limits_failed"], clear]).strip("; ")
        rows.append(
            [
                m["label"],
                m["transfer_time_s"],
                m["peak_during_deg"],
                m["residual_deg"],
                m["peak_tilt_deg"],
                band_txt,
                notes or "limits ok",
            ]
        )
    return rows


def targets(summary: dict, comp) -> dict:
    """The issue's 1-D targets from the numbers."""
    by = {m["method"]: m for m in summary["methods"]}
    limit = summary["residual_ok_deg"]
    free = [
        m
        for m in summary["methods"]
        if m["applicable"]
        and m["residual_deg"] <= limit
        and (m["min_clearance_m"] is None or m["min_clearance_m"] >= 0)
    ]
    fastest = min(free, key=lambda m: m["transfer_time_s"])["method"]
    t_plan, t_zvd = by["sloshid"]["transfer_time_s"], by["zvd"]["transfer_time_s"]
    rob = comp.robustness
    inside = (rob.omega_factors >= BAND[0] - 1e-9) & (rob.omega_factors <= BAND[1] + 1e-9)
    robust_res = rob.residual_vs_omega_deg["sloshid robust plan"][inside]
    nominal_res = rob.residual_vs_omega_deg["sloshid plan"][inside]
    return {
        "fastest_slosh_free": fastest,
        "sloshid_T_s": t_plan,
        "zvd_T_s": t_zvd,
        "zvd_over_sloshid_time_ratio": t_zvd / t_plan,
        "time_saved_vs_zvd": 1 - t_plan / t_zvd,
        "constant_acc_peak_deg": by["constant_acc"]["peak_during_deg"],
        "constant_acc_residual_deg": by["constant_acc"]["residual_deg"],
        "acc_for_45_deg_m_s2": acc_for_angle(summary["linearity"], 45.0),
        "band_omega_factors": rob.omega_factors[inside].tolist(),
        "robust_residual_in_band_deg": robust_res.tolist(),
        "nominal_residual_in_band_deg": nominal_res.tolist(),
        "robust_time_cost": by["sloshid_robust"]["transfer_time_s"] / t_plan - 1,
        "robust_solve_time_s": by["sloshid_robust"]["build_time_s"],
        "nominal_solve_time_s": by["sloshid"]["build_time_s"],
    }


def main() -> None:
    s1, c1 = run("paper_1d", linearity_acc_m_s2=[0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 6.0])
    t = targets(s1, c1)
    s3, c3 = run(
        "paper_3d", omega_factors=[0.8, 0.9, 1.0, 1.1, 1.2], camera_fps_sweep=[30.0, 60.0], linearity_acc_m_s2=[0.5]
    )
    t3 = targets(s3, c3)
    header = [
        "method",
        "T (s)",
        "peak during (deg)",
        "residual (deg)",
        "peak tilt (deg)",
        "freq. error with residual <= 0.5 deg",
        "limits / notes",
    ]
    rows = [
        ["**1-D seed case**", "", "", "", "", "", ""],
        *rows_of(s1),
        ["**3-D, 6 waypoints, 2 obstacles**", "", "", "", "", "", ""],
        *rows_of(s3),
    ]
    ok = lambda b: "met" if b else "NOT met"  # noqa: E731
    band_max = max(t["robust_residual_in_band_deg"])
    notes = [
        f"Target 1 (fastest slosh-free): {t['fastest_slosh_free']} is fastest with residual <= 0.5 deg: "
        f"{ok(t['fastest_slosh_free'] == 'sloshid')}.",
        f"Target 2 (>= 10 % faster than ZVD): ZVD takes {100 * (t['zvd_over_sloshid_time_ratio'] - 1):.1f} % longer "
        f"({t['zvd_T_s']:.3f} s vs {t['sloshid_T_s']:.3f} s): {ok(t['zvd_over_sloshid_time_ratio'] >= 1.1)} as a speed "
        f"ratio; sloshid saves {100 * t['time_saved_vs_zvd']:.1f} % of ZVD's time: "
        f"{ok(t['time_saved_vs_zvd'] >= 0.1)} if read as a time reduction.",
        f"Target 3 (constant acceleration): the model predicts a peak relative angle of {t['constant_acc_peak_deg']:.2f} deg "
        f"and {t['constant_acc_residual_deg']:.2f} deg residual at 0.5 m/s^2; the seed saw about 45 deg on its robot, which "
        f"this liquid model reaches only at about {t['acc_for_45_deg_m_s2']:.2g} m/s^2 (so the seed's classical move was far "
        "more aggressive than 0.5 m/s^2, or its float overshot; acc_max is an assumption, the seed gives none).",
        f"Target 4 (robust variant over +-10 % frequency error): residual <= {band_max:.3f} deg at omega x "
        f"{t['band_omega_factors']} ({ok(band_max <= 0.5)}); the nominal plan leaves up to "
        f"{max(t['nominal_residual_in_band_deg']):.2f} deg there. Time cost: +{100 * t['robust_time_cost']:.1f} % transfer "
        f"time; planner solve {t['robust_solve_time_s']:.2f} s vs {t['nominal_solve_time_s']:.2f} s.",
        f"3-D: fastest slosh-free collision-free method {t3['fastest_slosh_free']} ({t3['sloshid_T_s']:.3f} s); ZVD "
        f"(straight lines, collides) takes {100 * (t3['zvd_over_sloshid_time_ratio'] - 1):.1f} % longer; robust "
        f"variant residual <= {max(t3['robust_residual_in_band_deg']):.3f} deg at omega x {t3['band_omega_factors']}, "
        f"+{100 * t3['robust_time_cost']:.1f} % time (solve {t3['robust_solve_time_s']:.2f} s vs "
        f"{t3['nominal_solve_time_s']:.2f} s).",
        f"Verdict (1-D): {s1['verdict']}",
        f"Verdict (3-D): {s3['verdict']}",
        "Scoring: nonlinear pendulum (solve_ivp) on every method; residual = largest relative angle after arrival. "
        "Feedback: 30 fps camera, 50 ms latency, 0.3 deg noise, Kalman filter + LQR; its T includes settling back "
        "onto the goal. ZV/ZVD/ruckig/constant acceleration go straight between waypoints (clearance < 0: collides).",
        f"Wall time: 1-D {s1['wall_s']:.0f} s, 3-D {s3['wall_s']:.0f} s on a shared 2-core machine (whole comparison "
        "with all studies). HTML reports: compare_paper_1d/index.html, compare_paper_3d/index.html.",
    ]
    write("compare_paper", {"targets_1d": t, "targets_3d": t3, "paper_1d": s1, "paper_3d": s3}, header, rows, notes)


if __name__ == "__main__":
    main()
