"""Identification under a slow sway of the signal's zero (a container swaying or tilting in the picture, a camera
that wobbles): 60 seeded tap tests with a sinusoidal sway of 5-30 % of the tap's swing at 3-15 % of the mode's
frequency, each also without the sway, side by side. Reports how many are identified, f and zeta errors, the 95 %
intervals' coverage and width against the same records without sway, and what the same windows give when the zero
is fitted as a constant (the model before the sway was recognised). Run from the repository root:
python3 benchmarks/identify_sway.py (about a minute); writes reports/benchmarks/identify_sway.{json,md}."""

from __future__ import annotations

import math

import numpy as np
from bench_output import write_results
from tqdm import tqdm

from sloshid.core.errors import UserError
from sloshid.identification.estimator import Z95, Identifier
from sloshid.identification.pt2fit import WindowData, fit_pt2
from sloshid.identification.signals import make_signal
from sloshid.synthetic.decays import free_decay

N_TRIALS = 60


N_SHORT = 120
"""Trials of the second family: records that end two decay time constants after the tap, still ringing at 14 %."""


def trial(k: int, time_constants: float | None = None) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    """Trial k's truth and its record with and without the sway (times, values); `time_constants`: end the record that
    many decay time constants after the tap (the short family, seeds from 7000) instead of after the fade."""
    r = np.random.default_rng(5000 + k if time_constants is None else 7000 + k)
    f, z = r.uniform(1.5, 4), r.uniform(0.01, 0.08)
    fps, noise, amp, rho = r.choice([30, 60, 120]), r.uniform(0.02, 0.3), r.uniform(3, 10), r.choice([0.0, 0.5])
    tau = 1 / (z * 2 * math.pi * f)
    # by default the ring-down fades (to 0.25 % of its swing) before the end
    duration = min(30.0, 6 * tau + 2 if time_constants is None else time_constants * tau)
    t, y = free_decay(f, z, fps, duration_s=duration, amplitude=amp, noise_std=noise, rho=rho, seed=k, lead_in_s=1.0)
    sway, sway_f = r.uniform(0.05, 0.3) * amp, r.uniform(0.03, 0.15) * f
    truth = {"f_hz": f, "zeta": z, "fps": int(fps), "noise": noise, "amplitude": amp, "sway": sway, "sway_hz": sway_f}
    return truth, t, y + sway * np.sin(2 * math.pi * sway_f * t + r.uniform(0, 2 * math.pi)), y


def scores(params: dict, truth: dict) -> dict:
    """Errors (%), 95 % half-widths (% of the value) and whether the interval holds the truth, for f and zeta."""
    out = {}
    for key, (value, se) in params.items():
        out[f"{key}_err_pct"] = 100 * (value / truth[key] - 1)
        out[f"{key}_half_pct"] = 100 * Z95 * se / value
        out[f"{key}_covered"] = bool(abs(value - truth[key]) <= Z95 * se)
    return out


def constant_zero(res) -> dict:
    """The same windows fitted with a constant zero: (value, standard error) of f and zeta."""
    parts = [res.window_signal(i) for i in range(len(res.signals))]
    wdata = [WindowData(p.t_s, p.value, w.t0_s) for p, w in zip(parts, res.windows)]
    fit = fit_pt2(wdata, [res.fit.omega_rad_s], res.fit.zeta)
    se_w, se_z = np.sqrt(np.diag(fit.cov))
    return {"f_hz": (fit.omega_rad_s / (2 * math.pi), se_w / (2 * math.pi)), "zeta": (fit.zeta, se_z)}


def short_records() -> dict:
    """The second family: how many identify, are rated good, and are good with f or zeta outside its interval."""
    out = {}
    for label in ("swaying", "still"):
        identified = good = wrong = 0
        for k in range(N_SHORT):
            truth, t, swaying, still = trial(k, time_constants=2.0)
            try:
                res = (
                    Identifier().fit(make_signal(t, swaying if label == "swaying" else still, "a", "deg", label)).result
                )
            except UserError:
                continue
            identified += 1
            if res.quality == "good":
                good += 1
                sc = scores(
                    {key: (res.parameters[key].value, res.parameters[key].stderr) for key in ("f_hz", "zeta")}, truth
                )
                wrong += not (sc["f_hz_covered"] and sc["zeta_covered"])
        out[label] = {"identified": identified, "good": good, "good_outside_interval": wrong}
    return out


def main() -> None:
    """Run the trials and write the report."""
    rows = []
    for k in tqdm(range(N_TRIALS), desc="trials"):
        truth, t, swaying, still = trial(k)
        row = {"trial": k, **truth}
        ref = Identifier().fit(make_signal(t, still, "angle_deg", "deg", "still")).result
        row["still"] = scores(
            {key: (ref.parameters[key].value, ref.parameters[key].stderr) for key in truth if key in ("f_hz", "zeta")},
            truth,
        )
        try:
            res = Identifier().fit(make_signal(t, swaying, "angle_deg", "deg", "swaying")).result
        except UserError as e:
            row["error"] = str(e)
            rows.append(row)
            continue
        row["spline"] = res.fit.slow_s is not None
        row["swaying"] = scores(
            {key: (res.parameters[key].value, res.parameters[key].stderr) for key in ("f_hz", "zeta")}, truth
        )
        row["constant_zero"] = scores(constant_zero(res), truth)
        rows.append(row)
    done = [r for r in rows if "error" not in r]

    def stat(part: str, key: str, what: str) -> float:
        values = np.array([r[part][f"{key}_{what}"] for r in done], float)
        return float(np.mean(values) * 100) if what == "covered" else float(np.median(np.abs(values)))

    table, summary = [], {}
    for part, label in (
        ("swaying", "with the sway, as identified"),
        ("constant_zero", "with the sway, the same windows fitted with a constant zero"),
        ("still", "the same records without the sway"),
    ):
        cells = [label]
        for key in ("f_hz", "zeta"):
            err = np.abs([r[part][f"{key}_err_pct"] for r in done])
            summary[f"{part}_{key}"] = {
                "err_median_pct": float(np.median(err)),
                "err_p95_pct": float(np.percentile(err, 95)),
                "half_width_median_pct": stat(part, key, "half_pct"),
                "coverage_pct": stat(part, key, "covered"),
            }
            s = summary[f"{part}_{key}"]
            cells += [
                f"{s['err_median_pct']:.3g} / {s['err_p95_pct']:.3g}",
                f"{s['half_width_median_pct']:.3g}",
                f"{s['coverage_pct']:.0f} %",
            ]
        table.append(cells)
    n_spline = sum(r.get("spline", False) for r in done)
    short = short_records()
    sw, st = short["swaying"], short["still"]
    notes = (
        f"Identified: {len(done)} of {N_TRIALS} swaying records (the commit before the sway was recognised: 2 of 60, "
        "the others refused as driven to the end or without a ring-down above the noise); the sway was fitted as a "
        f"spline zero in {n_spline}. Trials: f 1.5-4 Hz, zeta 0.01-0.08, 3-10 deg tap at 1 s, 30/60/120 fps, noise "
        "0.02-0.3 deg (white or AR(1) 0.5), each record long enough for the ring-down to fade; sway 5-30 % of the "
        "tap's swing at 3-15 % of the mode's frequency, random phase; seeds 5000-5059. Errors are |%| of the truth; "
        "half-widths are the 95 % intervals' (% of the value).\n\n"
        f"Records that end two decay time constants after the tap, still ringing at 14 % ({N_SHORT} trials, seeds "
        f"7000-{7000 + N_SHORT - 1}, otherwise alike): with the sway {sw['identified']} identify (the commit before: 63, of which 44 good, 2 of those outside), "
        f"{sw['good']} are rated good, and {sw['good_outside_interval']} of those have f or zeta outside its 95 % "
        f"interval; without the sway {st['identified']}, {st['good']} and {st['good_outside_interval']}. Without a quiet "
        "tail a sway cannot be told from forcing; record until the liquid is still."
    )
    write_results(
        "identify_sway",
        {
            "trials": rows,
            "summary": summary,
            "identified": len(done),
            "n_trials": N_TRIALS,
            "spline": n_spline,
            "short_records": short,
        },
        f"identify under a slow sway of the zero: {N_TRIALS} seeded tap tests",
        [
            "records",
            "f error median / 95th pct (%)",
            "f half-width (%)",
            "f coverage",
            "zeta error median / 95th pct (%)",
            "zeta half-width (%)",
            "zeta coverage",
        ],
        table,
        notes,
    )


if __name__ == "__main__":
    main()
