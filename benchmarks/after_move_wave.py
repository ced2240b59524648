"""What could excite the free wave the shared runs ring with after each move (issue 38): measured on the commands.

Per run, beside the measured 2.5-3.6 Hz band after the move (aligned with its leave-one-kind-out model, read from
`reports/benchmarks/validate_real.json`): the free wave a linear liquid is left with by the commanded move at any f in
that band (|integral of a e^(-i 2 pi f t)| 2 pi f / g, both horizontal axes, times R and the fold's wave share); the
gain a second-order servo between command and tool has at 3 Hz (natural frequency 5-20 Hz, damping 0.3-1: a linear
filter scales that free wave by it, no more); the model's own wave after the move (its ellipse and whether its plane
turns: a swirl); how the move ends (acceleration and jerk in its last second), how long it lasts and how far the
container turns about its own axis. Nothing is fitted here.
"""

from __future__ import annotations

import json
import math

import numpy as np
from bench_output import ROOT, write_results
from scipy.signal import butter, hilbert, sosfiltfilt
from scipy.stats import spearmanr
from validate_real import ALL, KINDS, D, H, R, load

from sloshid.model.conventions import G
from sloshid.model.pendulum import SloshParams
from sloshid.model.pose import excitation
from sloshid.validation.predict import LiquidModel, forecast
from sloshid.validation.validate import validate_run

BAND_HZ = (2.5, 3.6)
SERVO_HZ, SERVO_ZETA = (5.0, 10.0, 20.0), (0.3, 0.7, 1.0)
"""The servo's prior: a large industrial arm's joint loops."""


def fold_models() -> dict[str, LiquidModel]:
    """Each kind's model as the leave-one-kind-out benchmark fitted it (on the other kinds)."""
    fits = json.loads((ROOT / "reports" / "benchmarks" / "validate_real.json").read_text())["fits"]
    keys = ("wave_share", "drag", "crest_coeff", "rest_tilt_x_deg", "rest_tilt_y_deg", "view_arc_deg")
    return {
        kind: LiquidModel(
            SloshParams.from_modal(2 * math.pi * v["f_hz"], v["zeta"]),
            R,
            D,
            views_deg=0.0,
            fill_height_m=H,
            **{k: v[k] for k in keys},
        )
        for kind, v in fits.items()
    }


def servo_gain(f_hz: float, fn_hz: float, zeta: float) -> float:
    """|H| at f_hz of a unit-gain second-order servo wn^2 / (s^2 + 2 zeta wn s + wn^2)."""
    r = f_hz / fn_hz
    return 1.0 / math.hypot(1 - r * r, 2 * zeta * r)


def band_envelope(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Hilbert envelope of the 2.5-3.6 Hz band (fourth-order Butterworth, run both ways)."""
    sos = butter(4, BAND_HZ, "bandpass", fs=1.0 / float(np.median(np.diff(t))), output="sos")
    return np.abs(hilbert(sosfiltfilt(sos, y)))


def command_wave_mm(t: np.ndarray, acc: np.ndarray, f_hz: float, share: float) -> float:
    """The first mode's free wave (mm at the wall) a linear liquid at f_hz is left with by the horizontal `acc`."""
    w = 2 * math.pi * f_hz
    phasor = np.trapezoid(acc[:, :2] * np.exp(-1j * w * t)[:, None], t, axis=0)
    return 1000 * R * share * float(np.linalg.norm(np.abs(phasor))) * w / G


def model_wave_shape(resp, end_s: float) -> tuple[float, float, float]:
    """The model's world-frame wave after the move: minor/major axis ratio over the first second, its amplitude (mm
    at the wall) and how far its major axis turns (deg) between the first second and the seventh."""
    axes = []
    for start in (0.0, 6.0):
        k = (resp.t_s >= end_s + start) & (resp.t_s < end_s + start + 1)
        w = np.tan(resp.liquid_rad[k]) - np.tan(resp.liquid_rad[k]).mean(0)
        ev, vec = np.linalg.eigh(w.T @ w)
        axes.append((math.sqrt(ev[0] / ev[1]), 1000 * R * math.sqrt(2 * ev[1] / k.sum()), vec[:, 1]))
    turn = math.degrees(math.acos(min(1.0, abs(float(axes[0][2] @ axes[1][2])))))
    return axes[0][0], axes[0][1], turn


def run_row(name: str, kind: str, model: LiquidModel) -> dict:
    """The measurements of one run (see the module docstring)."""
    pose, sig = load(name)
    v = validate_run(pose, sig, model, name)
    s, e = v.move_s
    env_m, env_p = band_envelope(v.t_s, v.measured), band_envelope(v.t_s, v.predicted)
    after = (v.t_s > e) & (v.t_s < e + 2)
    seconds = [(v.t_s >= e + a) & (v.t_s < e + a + 1) for a in range(10)]
    per_second = [float(np.median(env_m[k])) if k.any() else None for k in seconds]
    exc = excitation(pose, D)
    t, acc = exc.t_s, exc.acc_m_s2
    fs = np.arange(BAND_HZ[0], BAND_HZ[1] + 1e-9, 0.05)
    waves = [command_wave_mm(t, acc, f, model.wave_share) for f in fs]
    last = (t >= e - 1) & (t <= e)
    jerk = np.linalg.norm(np.gradient(acc[:, :2], t[1] - t[0], axis=0), axis=1)
    uni = pose.uniform()
    spin = float(np.degrees(np.abs((uni.rot[:-1].inv() * uni.rot[1:]).as_rotvec()[:, 2]).sum()))
    resp = forecast(pose, model, settle_s=8.0, rtol=1e-7, band=False).resp
    ratio, amp, turn = model_wave_shape(resp, resp.move_span_s[1])
    return {
        "run": name,
        "kind": kind,
        "measured_after_2s_mm": float(np.median(env_m[after])),
        "predicted_after_2s_mm": float(np.median(env_p[after])),
        "measured_envelope_per_second_mm": per_second,
        "command_wave_band_mm": [float(min(waves)), float(max(waves))],
        "command_wave_at_f_mm": command_wave_mm(t, acc, model.params.f_hz, model.wave_share),
        "model_wave_mm": amp,
        "model_wave_axis_ratio": ratio,
        "model_wave_turn_deg": turn,
        "last_second_accel_g": float(np.max(np.linalg.norm(acc[last, :2], axis=1)) / G),
        "last_second_jerk_m_s3": float(np.max(jerk[last])),
        "peak_accel_g": float(np.max(np.linalg.norm(acc[(t >= s) & (t <= e), :2], axis=1)) / G),
        "duration_s": e - s,
        "spin_deg": spin,
    }


def main() -> None:
    """Measure every run, the servo's gains and the rank correlations; write the report."""
    models = fold_models()
    rows = [run_row(n, k, models[k]) for k, runs in KINDS.items() for n in runs]
    assert [r["run"] for r in rows] == list(ALL)
    gains = {f"{fn:g} Hz, zeta {z:g}": servo_gain(3.0, fn, z) for fn in SERVO_HZ for z in SERVO_ZETA}
    wave = [r["measured_after_2s_mm"] for r in rows]
    corr = {
        key: float(spearmanr(wave, [r[key] for r in rows]).statistic)
        for key in ("peak_accel_g", "last_second_accel_g", "last_second_jerk_m_s3", "duration_s", "spin_deg")
    }
    table = [
        [
            r["run"],
            f"{r['measured_after_2s_mm']:.2f} / {r['predicted_after_2s_mm']:.2f}",
            " ".join("-" if x is None else f"{x:.1f}" for x in r["measured_envelope_per_second_mm"]),
            f"{r['command_wave_band_mm'][0]:.2f}-{r['command_wave_band_mm'][1]:.2f} / {r['command_wave_at_f_mm']:.2f}",
            f"{r['model_wave_mm']:.2f} / {r['model_wave_axis_ratio']:.2f} / {r['model_wave_turn_deg']:.0f}",
            f"{r['last_second_accel_g']:.2f} / {r['last_second_jerk_m_s3']:.1f}",
            f"{r['duration_s']:.1f}",
            f"{r['spin_deg']:.0f}",
        ]
        for r in rows
    ]
    notes = (
        "Columns: the 2.5-3.6 Hz band's median envelope in the 2 s after the move, measured / predicted by the "
        "kind's leave-one-kind-out model (mm); the measured envelope per second after the move (mm; - past the "
        "record's end); the free wave the commanded move leaves a linear liquid at any f in 2.5-3.6 Hz / at "
        "the fold's f (mm, the fold's wave share); the model's world-frame wave after the move: amplitude (mm) / minor-to-major axis ratio "
        "/ how far its plane turns over 6 s (deg); the move's last second: its largest horizontal acceleration (g) / "
        "jerk (m/s3); the move's duration (s); the container's turning about its own axis (deg). A second-order "
        "servo at 3 Hz scales a free wave by " + ", ".join(f"{k}: {g:.2f}" for k, g in gains.items()) + ". Rank "
        "correlation of the measured wave after the move with "
        + ", ".join(f"{k} {c:+.2f}" for k, c in corr.items())
        + "."
    )
    write_results(
        "after_move_wave",
        {"rows": rows, "servo_gain_at_3hz": gains, "rank_correlation_with_after_wave": corr},
        "The free wave after the move: measured, predicted, and what the commands could excite",
        [
            "run",
            "2 s after: measured / predicted",
            "measured, per second after",
            "command's free wave: 2.5-3.6 Hz / at f",
            "model's wave: mm / axes / turn",
            "last second: g / jerk",
            "move (s)",
            "turn (deg)",
        ],
        table,
        notes,
    )


if __name__ == "__main__":
    main()
