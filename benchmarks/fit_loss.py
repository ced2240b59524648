"""Where the leave-one-kind-out fit % is lost (issue 38's target 68 %): by stretch of the record, by frequency, and as
amplitude, timing or level.

Each run is predicted by its kind's leave-one-kind-out model (read from `reports/benchmarks/validate_real.json`, as
`after_move_wave.py` reads it) and scored as `validate` scores it. Nothing is fitted here. Per run:

- the residual's energy over the record's variance in five stretches (before the move, its first and second half, the
  2 s after it, the rest), so that fit % = 100 (1 - sqrt(their sum));
- the move's residual split at 2 Hz (the quasi-static shape) and 2.5-3.6 Hz (the first mode's band);
- the fit % the record would score with one thing set right: the move's prediction scaled by its best factor
  (amplitude), shifted by its best lag within +-0.15 s (timing), the after-move prediction set to the measured
  after-move mean (level), the move's residual below 2 Hz removed (shape), the move or the after-move part exact.
"""

from __future__ import annotations

import math

import numpy as np
from after_move_wave import fold_models
from bench_output import write_results
from scipy.optimize import minimize_scalar
from scipy.signal import butter, sosfiltfilt
from validate_real import KINDS, load

from sloshid.identification.pt2fit import nrmse_fit_percent
from sloshid.validation.predict import forecast
from sloshid.validation.validate import FIT_RTOL, validate_run

LOW_HZ, BAND_HZ = 2.0, (2.5, 3.6)
MAX_LAG_S = 0.15
STRETCHES = ("before", "the move's first half", "its second half", "2 s after", "later")


def run_row(name: str, kind: str, model) -> dict:
    """One run's figures (see the module docstring)."""
    pose, sig = load(name)
    v = validate_run(pose, sig, model, name)
    t, y, p = v.t_s, v.measured, v.predicted
    start, end = v.move_s
    mid = (start + end) / 2
    during, after = (t >= start) & (t <= end), t > end
    masks = [t < start, during & (t < mid), during & (t >= mid), after & (t <= end + 2), t > end + 2]
    res, var = y - p, float(np.sum((y - y.mean()) ** 2))
    fs = 1.0 / float(np.median(np.diff(t)))
    low = sosfiltfilt(butter(4, LOW_HZ, "lowpass", fs=fs, output="sos"), res)
    band = sosfiltfilt(butter(4, BAND_HZ, "bandpass", fs=fs, output="sos"), res)

    def fit_with(mask: np.ndarray, values: np.ndarray) -> float:
        q = p.copy()
        q[mask] = values
        return nrmse_fit_percent(y, q)

    scale = float(np.sum(y[during] * p[during]) / np.sum(p[during] ** 2))
    resp = forecast(pose, model, settle_s=float(t[-1] - end) + 1.0, rtol=FIT_RTOL, band=False).resp
    reading = model.reading(resp, v.kind)

    def shifted(lag: float) -> np.ndarray:
        return np.interp(t[during] - lag, resp.t_s, reading)

    best = minimize_scalar(
        lambda lag: float(np.sum((y[during] - shifted(lag)) ** 2)), bounds=(-MAX_LAG_S, MAX_LAG_S), method="bounded"
    )
    level = float(np.mean(y[after]))
    return {
        "run": name,
        "kind": kind,
        "fit_percent": nrmse_fit_percent(y, p),
        "residual_share": {s: float(np.sum(res[m] ** 2) / var) for s, m in zip(STRETCHES, masks)},
        "move_residual_below_2_hz": float(np.sum(low[during] ** 2) / var),
        "move_residual_first_mode_band": float(np.sum(band[during] ** 2) / var),
        "best_scale": scale,
        "fit_scaled": fit_with(during, scale * p[during]),
        "best_lag_s": float(best.x),
        "fit_relagged": fit_with(during, shifted(float(best.x))),
        "after_mean_mm": level,
        "fit_after_level": fit_with(after, np.full(int(after.sum()), level)),
        "fit_shape": fit_with(during, p[during] + low[during]),
        "fit_move_exact": fit_with(during, y[during]),
        "fit_after_exact": fit_with(after, y[after]),
    }


def main() -> None:
    """Every held-out run and the medians."""
    models = fold_models()
    rows = [run_row(n, k, models[k]) for k, runs in KINDS.items() for n in runs]
    keys = (
        "fit_percent",
        "fit_scaled",
        "fit_relagged",
        "fit_after_level",
        "fit_shape",
        "fit_move_exact",
        "fit_after_exact",
    )
    medians = {k: float(np.median([r[k] for r in rows])) for k in keys}
    table = []
    for r in rows:
        shares = " / ".join(f"{r['residual_share'][s]:.3f}" for s in STRETCHES)
        table.append(
            [
                r["run"],
                f"{r['fit_percent']:.1f}",
                shares,
                f"{r['move_residual_below_2_hz']:.3f} / {r['move_residual_first_mode_band']:.3f}",
                f"x {r['best_scale']:.2f}: {r['fit_scaled']:.1f}",
                f"{1000 * r['best_lag_s']:+.0f} ms: {r['fit_relagged']:.1f}",
                f"{r['after_mean_mm']:+.2f} mm: {r['fit_after_level']:.1f}",
                f"{r['fit_shape']:.1f}",
                f"{r['fit_move_exact']:.1f} / {r['fit_after_exact']:.1f}",
            ]
        )
    table.append(
        [
            "median",
            f"{medians['fit_percent']:.1f}",
            "",
            "",
            f"{medians['fit_scaled']:.1f}",
            f"{medians['fit_relagged']:.1f}",
            f"{medians['fit_after_level']:.1f}",
            f"{medians['fit_shape']:.1f}",
            f"{medians['fit_move_exact']:.1f} / {medians['fit_after_exact']:.1f}",
        ]
    )
    notes = (
        "Each run predicted by its kind's leave-one-kind-out model, scored as `validate` scores it; nothing fitted. "
        "Columns: fit % over the record; the residual's energy over the record's variance "
        f"({', '.join(STRETCHES)}: fit % = 100 (1 - sqrt(their sum))); the move's residual below {LOW_HZ:g} Hz / in "
        f"{BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz (the same scale); the fit % with one thing set right: the move's "
        "prediction times its best factor (amplitude), shifted by its best lag (timing), the after-move prediction "
        f"set to the measured after-move mean (level), the move's residual below {LOW_HZ:g} Hz removed (shape), the "
        "move / the after-move part exact. Over all runs, a fit of 68 % needs the residual energy at most "
        f"{(1 - 0.68) ** 2:.4f} of the variance."
    )
    assert math.isfinite(medians["fit_percent"])
    write_results(
        "fit_loss",
        {"rows": rows, "medians": medians},
        "Where the leave-one-kind-out fit is lost",
        [
            "run",
            "fit %",
            "residual: before / move 1st half / 2nd half / 2 s after / later",
            "move's residual < 2 Hz / 2.5-3.6 Hz",
            "amplitude",
            "timing",
            "after-move level",
            "shape",
            "move / after exact",
        ],
        table,
        notes,
    )


if __name__ == "__main__":
    main()
