"""Accuracy and interval coverage of `identify` on 100 seeded synthetic free decays (issue 3 targets):
10 s, 30-120 fps, 0.3 deg tracker-like noise; frequency error <= 0.3 %, zeta error <= 5 %, 95 % coverage 90-98 %.
Side by side: the Welch peak alone (frequency) and white-noise intervals (coverage) as the naive alternatives, and
the Cramer-Rao bound of each trial (its true noise covariance known) as the best any unbiased estimator could do."""

from __future__ import annotations

import math

import numpy as np
from bench_output import write_results
from scipy import linalg
from tqdm import tqdm

from sloshid.identification.estimator import Z95, Identifier
from sloshid.synthetic.decays import NOISE_WHITE_SHARE, free_decay_signal

N_TRIALS = 100
NOISE_STD = 0.3


def zeta_crb(sig, f0: float, z0: float, amp: float, rho: float) -> float:
    """Cramer-Rao standard deviation of zeta for this trial's samples: Fisher information J' S^-1 J of the noise-free
    decay's parameters (omega, zeta, amplitude, phase, offset; J by central differences) under the generator's own
    noise covariance S (white share plus AR(1) share with correlation rho per sample)."""
    t = sig.t_s - sig.t_s[0]

    def decay(p):
        w, z, a, ph, c = p
        return a * np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z * z) * t + ph) + c

    p0 = np.array([2 * math.pi * f0, z0, amp, 0.3, 0.0])  # phase 0.3 rad: the bound hardly depends on it (<2 %)
    steps = np.array([1e-6, 1e-7, 1e-6, 1e-6, 1e-6])
    jac = np.column_stack([(decay(p0 + h * e) - decay(p0 - h * e)) / (2 * h) for h, e in zip(steps, np.eye(5))])
    lag = np.arange(t.size)
    cov = NOISE_STD**2 * linalg.toeplitz(NOISE_WHITE_SHARE * (lag == 0) + (1 - NOISE_WHITE_SHARE) * rho**lag)
    fisher = jac.T @ np.linalg.solve(cov, jac)
    return float(np.sqrt(np.linalg.inv(fisher)[1, 1]))


def crb_p95(rel_sd: np.ndarray, seed: int = 0, draws: int = 4000) -> tuple[float, float, float]:
    """Median and 10-90 % range of the 95th-percentile |error| (%) over N_TRIALS trials for an estimator that reaches
    each trial's Cramer-Rao bound exactly (normal errors, simulated)."""
    errs = np.abs(np.random.default_rng(seed).normal(size=(draws, rel_sd.size)) * rel_sd)
    p95 = 100 * np.percentile(errs, 95, axis=1)
    return float(np.median(p95)), float(np.percentile(p95, 10)), float(np.percentile(p95, 90))


def main() -> None:
    """Run the trials and write reports/benchmarks/identify_accuracy.{json,md}."""
    rng = np.random.default_rng(20261122)
    rows = []
    for k in tqdm(range(N_TRIALS), desc="trials"):
        f0, z0 = rng.uniform(2.5, 4.5), rng.uniform(0.02, 0.08)
        fps, amp, rho = rng.uniform(30, 120), rng.uniform(5, 15), rng.uniform(0, 0.6)
        sig = free_decay_signal(f0, z0, fps, amplitude=amp, rho=rho, seed=k)
        res = Identifier().fit(sig).result
        full = Identifier(window_s=(float(sig.t_s[0]), float(sig.t_s[-1]))).fit(sig).result.parameters["zeta"]
        f, z = res.parameters["f_hz"], res.parameters["zeta"]
        se_naive = np.sqrt(np.diag(res.fit.cov_naive))
        rows.append(
            {
                "f_true": f0,
                "zeta_true": z0,
                "fps": fps,
                "amplitude_deg": amp,
                "rho": rho,
                "f_err_pct": 100 * abs(f.value / f0 - 1),
                "zeta_err_pct": 100 * abs(z.value / z0 - 1),
                "welch_f_err_pct": 100 * abs(res.spectra[0].peak_f_hz / f0 - 1),
                "f_covered": bool(f.ci95[0] <= f0 <= f.ci95[1]),
                "zeta_covered": bool(z.ci95[0] <= z0 <= z.ci95[1]),
                "f_covered_white": bool(abs(res.fit.omega_rad_s - 2 * math.pi * f0) <= Z95 * se_naive[0]),
                "zeta_covered_white": bool(abs(res.fit.zeta - z0) <= Z95 * se_naive[1]),
                "quality": res.quality,
                "zeta_err_full_record_pct": 100 * abs(full.value / z0 - 1),
                "zeta_covered_full_record": bool(full.ci95[0] <= z0 <= full.ci95[1]),
                "zeta_signed_err_pct": 100 * (z.value / z0 - 1),
                "zeta_crb_rel_pct": 100 * zeta_crb(sig, f0, z0, amp, rho) / z0,
            }
        )
    col = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    summary = {
        "f_err_pct": {
            "median": float(np.median(col["f_err_pct"])),
            "p95": float(np.percentile(col["f_err_pct"], 95)),
            "max": float(col["f_err_pct"].max()),
        },
        "zeta_err_pct": {
            "median": float(np.median(col["zeta_err_pct"])),
            "p95": float(np.percentile(col["zeta_err_pct"], 95)),
            "max": float(col["zeta_err_pct"].max()),
        },
        "welch_only_f_err_pct": {
            "median": float(np.median(col["welch_f_err_pct"])),
            "p95": float(np.percentile(col["welch_f_err_pct"], 95)),
        },
        "coverage_f": float(col["f_covered"].mean()),
        "coverage_zeta": float(col["zeta_covered"].mean()),
        "coverage_f_white_noise_intervals": float(col["f_covered_white"].mean()),
        "coverage_zeta_white_noise_intervals": float(col["zeta_covered_white"].mean()),
        "good_verdicts": int(np.sum(col["quality"] == "good")),
        "zeta_mean_signed_err_pct": float(np.mean(col["zeta_signed_err_pct"])),
        "zeta_err_full_record_pct": {
            "median": float(np.median(col["zeta_err_full_record_pct"])),
            "p95": float(np.percentile(col["zeta_err_full_record_pct"], 95)),
        },
        "coverage_zeta_full_record": float(col["zeta_covered_full_record"].mean()),
        "zeta_crb_p95_pct_median_p10_p90": crb_p95(col["zeta_crb_rel_pct"] / 100),
    }
    s = summary
    table = [
        [
            "frequency error, median / 95th pct / max (%)",
            f"{s['f_err_pct']['median']:.3f} / {s['f_err_pct']['p95']:.3f} / {s['f_err_pct']['max']:.3f}",
            "<= 0.3",
            f"Welch peak alone: {s['welch_only_f_err_pct']['median']:.2f} / {s['welch_only_f_err_pct']['p95']:.2f}",
        ],
        [
            "zeta error, median / 95th pct / max (%)",
            f"{s['zeta_err_pct']['median']:.2f} / {s['zeta_err_pct']['p95']:.2f} / {s['zeta_err_pct']['max']:.2f}",
            "<= 5",
            "Cramer-Rao bound: 95th pct {:.2f} (10-90 % of draws {:.2f}-{:.2f})".format(
                *s["zeta_crb_p95_pct_median_p10_p90"]
            ),
        ],
        ["zeta mean signed error (%)", f"{s['zeta_mean_signed_err_pct']:+.2f}", "", ""],
        [
            "zeta error and coverage when fitting the whole 10 s record instead of the found window",
            f"{s['zeta_err_full_record_pct']['median']:.2f} / {s['zeta_err_full_record_pct']['p95']:.2f} %, coverage {100 * s['coverage_zeta_full_record']:.0f} %",
            "",
            "(not used: no better)",
        ],
        [
            "95 % interval coverage, f",
            f"{100 * s['coverage_f']:.0f} %",
            "90-98 %",
            f"white-noise intervals: {100 * s['coverage_f_white_noise_intervals']:.0f} %",
        ],
        [
            "95 % interval coverage, zeta",
            f"{100 * s['coverage_zeta']:.0f} %",
            "90-98 %",
            f"white-noise intervals: {100 * s['coverage_zeta_white_noise_intervals']:.0f} %",
        ],
        ["verdict good", f"{s['good_verdicts']} / {N_TRIALS}", "", ""],
    ]
    write_results(
        "identify_accuracy",
        {"n_trials": N_TRIALS, "summary": summary, "trials": rows},
        "identify: accuracy and coverage on 100 synthetic free decays",
        ["measure", "sloshid identify", "target", "naive alternative"],
        table,
        "Trials: f 2.5-4.5 Hz, zeta 0.02-0.08, amplitude 5-15 deg, 30-120 fps, 10 s, noise 0.3 deg total "
        "(half white, half AR(1) with per-frame correlation 0-0.6), seeded (numpy default_rng 20261122, trial seeds 0-99).\n\n"
        "How close the zeta target is to what the data allow: an unbiased estimator that reached each trial's Cramer-Rao "
        "bound exactly (its noise covariance known) would show a 95th percentile of {:.2f} % over these 100 trials "
        "(10-90 % of simulated draws {:.2f}-{:.2f} %); the least-squares fit shows {:.2f} % with a mean signed error of "
        "{:+.2f} %, so the tail is noise in the weakest trials (5-6 deg amplitude, zeta near 0.08, few frames per period), "
        "not bias. Fitting the whole record instead of the found window (more samples of the low tail) gives "
        "{:.2f} % and {:.0f} % zeta coverage: no better, so the window is kept.".format(
            *s["zeta_crb_p95_pct_median_p10_p90"],
            s["zeta_err_pct"]["p95"],
            s["zeta_mean_signed_err_pct"],
            s["zeta_err_full_record_pct"]["p95"],
            100 * s["coverage_zeta_full_record"],
        ),
    )


if __name__ == "__main__":
    main()
