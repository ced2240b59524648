"""What sets the physics-first model's scores on the shared runs: the parts of a predicted peak, the parts of the
record's residual, and the scores under other parameters and readings (issue 38's structure questions).

No fit: every variant is the model at fixed values, scored on the nine runs of `validate_real.py` as `validate` scores
them (the prediction aligned by cross-correlation, fit % over the record, peak error % during the move). In-sample by
construction (nothing is fitted, but the variants were looked at on these runs), so the figures say what moves the
scores, not how well a variant extrapolates; `validate_real.py` is the score.

- Parts of the peak: at the predicted peak, the wall's quasi-static surface (R |a| / g in the camera planes, the
  surface at rest under the pivot's acceleration) and the first mode's wave (wave_share x its excess over it).
- Parts of the residual: the residual's energy before, during and after the move over the record's variance, and the
  fit % the record would score with the after-move part predicted exactly (100 (1 - sqrt(before + during))).
- Variants: the physics priors; the leave-one-kind-out fits' values; the crest, damping, drag, frequency and pivot
  height changed one at a time; the wall read as R sin(angle) instead of R tan(angle); every reading scaled by 0.9; the
  commanded pose low-passed (a critically damped 40 ms filter, as a robot's tracking would); the wall read where the
  liquid meets the glass, less the meniscus an advancing contact line loses (1 and 2 mm: a meniscus rises
  l_c sqrt(2 (1 - sin theta)) up the glass, l_c = 2.7 mm for water; from a static contact angle of about 30 deg to an
  advancing one of 55-70 deg it falls by 1-2 mm), never below the rest level.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from bench_output import write_results
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation
from validate_real import ALL, VIEWS_DEG, D, H, R, load

from sloshid.model.pendulum import XI_CYLINDER, SloshParams, cylinder_first_mode_omega
from sloshid.model.pose import PoseLog
from sloshid.validation.predict import LiquidModel, forecast, wall_parts
from sloshid.validation.scoring import LEAD_IN_S, align, baseline, score
from sloshid.validation.validate import FIT_RTOL

F_GEOMETRY = cylinder_first_mode_omega(R, H) / (2 * math.pi)
PRIORS = {"f": F_GEOMETRY, "zeta": 0.01, "drag": 1.0, "share": 2 / (XI_CYLINDER**2 - 1), "crest": 0.58}
FITTED = {"f": 3.0, "zeta": 0.0022, "drag": 0.5, "share": 0.87, "crest": -0.5}
"""About what every leave-one-kind-out fold of validate_real fits (reports/benchmarks/validate_real.md)."""
LOWPASS_S = 0.04


def model(f: float, zeta: float, drag: float, share: float, crest: float, offset: float = D) -> LiquidModel:
    """The physics-first model at these values, the wall read in the shared runs' two camera planes."""
    params = SloshParams.from_modal(2 * math.pi * f, zeta)
    return LiquidModel(params, R, offset, wave_share=share, drag=drag, crest_coeff=crest, views_deg=VIEWS_DEG)


def tan_reading(resp, m: LiquidModel) -> np.ndarray:
    """The model's own wall reading (mm): R x the slope."""
    return m.reading(resp, "wall_height_mm")


def sin_reading(resp, m: LiquidModel) -> np.ndarray:
    """R sin(atan(slope)) in each camera plane instead of R x the slope (a reading that saturates with the angle)."""
    static, wave = wall_parts(resp)
    total = static + m.wave_share * wave
    a = math.radians(VIEWS_DEG)
    sx, sy = (np.abs(total @ v) for v in ([math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]))
    slope = np.maximum(sx / np.hypot(1, sx), sy / np.hypot(1, sy))
    return 1000 * R * slope * (1 + m.crest_coeff * np.linalg.norm(m.wave_share * wave, axis=1))


def scaled_reading(resp, m: LiquidModel) -> np.ndarray:
    """Every reading times 0.9 (a camera scale)."""
    return 0.9 * tan_reading(resp, m)


def meniscus_reading(mm: float):
    """The wall read where the liquid meets the glass: the model's reading less the meniscus an advancing contact line
    loses (mm), never below the rest level: max(R x the slope - mm, 0)."""

    def reading(resp, m: LiquidModel) -> np.ndarray:
        return np.maximum(tan_reading(resp, m) - mm, 0.0)

    return reading


def lowpass(pose: PoseLog, tau_s: float) -> PoseLog:
    """The pose through a critically damped second-order low-pass of time constant tau_s (positions and quaternion
    components, renormalised)."""
    pose = pose.uniform()
    dt = float(pose.t_s[1] - pose.t_s[0])
    a = dt / (tau_s + dt)

    def filt(x: np.ndarray) -> np.ndarray:
        for _ in range(2):
            x = lfilter([a], [1, a - 1], x - x[0], axis=0) + x[0]
        return x

    q = filt(pose.rot.as_quat())
    return replace(pose, pos_m=filt(pose.pos_m), rot=Rotation.from_quat(q / np.linalg.norm(q, axis=1, keepdims=True)))


def scored(pose: PoseLog, sig, m: LiquidModel, reading=tan_reading) -> dict:
    """`validate_run`'s scores with a given reading, and the parts of the peak and of the residual."""
    y_all = np.asarray(sig.value, float)
    resp = forecast(pose, m, settle_s=float(sig.t_s[-1] - sig.t_s[0]) + 1.0, rtol=FIT_RTOL, band=False).resp
    pred = reading(resp, m)
    move = resp.move_span_s
    al = align(sig.t_s, y_all, resp.t_s, pred, move)
    tm = sig.t_s - al.lag_s
    keep = (tm >= move[0] - LEAD_IN_S) & (tm <= resp.t_s[-1])
    t, y = tm[keep], y_all[keep] - baseline(sig.t_s, y_all, move[0] + al.lag_s)
    yhat = np.interp(t, resp.t_s, pred, left=pred[0])
    during, after = (t >= move[0]) & (t <= move[1]), t > move[1]
    res, var = (y - yhat) ** 2, float(np.sum((y - y.mean()) ** 2))
    static, wave = wall_parts(resp)
    k = int(np.argmax(pred))
    a = math.radians(VIEWS_DEG)
    in_views = [math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]
    return {
        "fit_percent": score(y, yhat).fit_percent,
        "peak_error_percent": score(y[during], yhat[during]).peak_error_percent,
        "peak_mm": float(pred[k]),
        "static_at_peak_mm": 1000 * R * max(abs(float(static[k] @ v)) for v in in_views),
        "wave_at_peak_mm": 1000 * R * m.wave_share * float(np.linalg.norm(wave[k])),
        "residual_before": float(np.sum(res[t < move[0]])) / var,
        "residual_during": float(np.sum(res[during])) / var,
        "residual_after": float(np.sum(res[after])) / var,
    }


def main() -> None:
    """Score every variant on the nine runs; write reports/benchmarks/validate_structure.{json,md}."""
    runs = {name: load(name) for name in ALL}
    variants = {
        "physics priors (nothing fitted)": (PRIORS, {}),
        "the folds' fitted values": (FITTED, {}),
        "priors, crest 0": ({**PRIORS, "crest": 0.0}, {}),
        "priors, zeta 0.0044 (Miles), crest 0": ({**PRIORS, "zeta": 0.0044, "crest": 0.0}, {}),
        "priors, drag 0.5": ({**PRIORS, "drag": 0.5}, {}),
        "priors, drag 2": ({**PRIORS, "drag": 2.0}, {}),
        "priors, f 3.0 Hz": ({**PRIORS, "f": 3.0}, {}),
        "priors, pivot at the tool point (0 m)": ({**PRIORS, "offset": 0.0}, {}),
        "priors, pivot 0.04 m up": ({**PRIORS, "offset": 0.04}, {}),
        "priors, pivot 0.12 m up": ({**PRIORS, "offset": 0.12}, {}),
        "priors, wall R sin(angle), crest 0": ({**PRIORS, "crest": 0.0}, {"reading": sin_reading}),
        "priors, every reading x 0.9, crest 0": ({**PRIORS, "crest": 0.0}, {"reading": scaled_reading}),
        f"priors, pose low-passed {1000 * LOWPASS_S:.0f} ms": (PRIORS, {"tau_s": LOWPASS_S}),
        "priors, less a contact line's meniscus of 1 mm": (PRIORS, {"reading": meniscus_reading(1.0)}),
        "priors, less a contact line's meniscus of 2 mm": (PRIORS, {"reading": meniscus_reading(2.0)}),
    }
    results = {}
    for label, (values, how) in variants.items():
        m = model(**values)
        out = {}
        for name, (pose, sig) in runs.items():
            if "tau_s" in how:
                pose = lowpass(pose, how["tau_s"])
            out[name] = scored(pose, sig, m, how.get("reading", tan_reading))
        results[label] = out
        print(label, flush=True)
    table = []
    for label, out in results.items():
        peaks = [out[n]["peak_error_percent"] for n in ALL]
        table.append(
            [
                label,
                *(f"{p:+.0f}" for p in peaks),
                f"{np.median(np.abs(peaks)):.1f}",
                f"{np.median([out[n]['fit_percent'] for n in ALL]):.1f}",
            ]
        )
    base = results["physics priors (nothing fitted)"]
    parts = {
        n: {k: base[n][k] for k in ("peak_mm", "static_at_peak_mm", "wave_at_peak_mm")}
        | {"residual": {ph: base[n][f"residual_{ph}"] for ph in ("before", "during", "after")}}
        for n in ALL
    }
    ceilings = [100 * (1 - math.sqrt(p["residual"]["before"] + p["residual"]["during"])) for p in parts.values()]
    notes = (
        "Cells: peak error % during the move per run (in-sample, nothing fitted), then the median |peak error| % and "
        "the median fit % over the record. Parts of the predicted peak under the priors (mm: the peak, of it the "
        "quasi-static surface in the camera planes, the first mode): "
        + "; ".join(
            f"{n} {p['peak_mm']:.1f}: {p['static_at_peak_mm']:.1f}, {p['wave_at_peak_mm']:.1f}"
            for n, p in parts.items()
        )
        + ". Residual energy over the record's variance, before / during / after the move: "
        + "; ".join(
            f"{n} {p['residual']['before']:.2f} / {p['residual']['during']:.2f} / {p['residual']['after']:.2f}"
            for n, p in parts.items()
        )
        + f". With the after-move part predicted exactly the fits would be at most {min(ceilings):.0f}-"
        f"{max(ceilings):.0f} % (median {np.median(ceilings):.0f} %)."
    )
    write_results(
        "validate_structure",
        {"variants": results, "peak_and_residual_parts": parts, "fit_ceiling_percent": dict(zip(ALL, ceilings))},
        "What sets the physics-first model's scores on the shared runs (in-sample, nothing fitted)",
        ["variant", *(n.split("_0")[0] for n in ALL), "median abs peak %", "median fit %"],
        table,
        notes,
    )


if __name__ == "__main__":
    main()
