"""Benchmark: accuracy of `sloshid track` on synthetic videos the tests do not use: angles, wall heights, dynamics.

Targets (issue 2): RMSE of angle_deg <= 0.2 deg and max error <= 1 deg at 640x480 and 1280x720,
30-120 fps, noise sigma 5-8, blur, H.264 or MPEG-4; with --reference container on a container tilting
+-3 deg while crossing the frame, RMSE <= 0.3 deg (and on a container at rest before and after a robot move, whose
walls are held between measurements while they stand still). The baseline is what people write first: a binary
HSV mask of the whole frame and its principal axes (and, for the container case, the mean angle of the
near-vertical Hough lines as the wall reference; and, to isolate the float measurement, the naive float
angle against the true container angle).

Dynamics (issue 12): two seeded sets of 20 short rendered tap tests (the second held out), float and dyed-liquid
surface targets, 30-120 fps, 640x480 and 800x600, H.264 CRF 16-20 and MPEG-4 qscale 2-3, noise, blur, and a
different look per clip (colours, camera elevation, meniscus, highlight stripes, wall reflection, second mode,
container tilt, camera roll; most floats rounded, bent, with a specular spot, partly under the tinted liquid and
motion-blurred). Each clip's tracked trace and its exact truth trace are identified alike; reported per clip:
angle RMSE, wall-height RMSE, the f and zeta errors of the tracked trace against the truth trace's, and whether the
tracked 95 % intervals cover the truth trace's values, before and after identify's encoder-hold fit; and for each
float clip the same errors of its lossless control (the clip as H.264 CRF 0), which separate the tracker's part of
the error from the codec's.
Targets: f within 0.1 %, zeta within 3 %, coverage near 95 %, surface angle RMSE
<= 0.3 deg, wall RMSE <= 1 px, float angle RMSE <= 0.2 deg.
Camera elevation: the dyed-liquid surface of every dye preset seen from 0, 8 and 16 deg above (and from 16 deg with a
dark meniscus and more noise), 640x480: angle and wall-height RMSE against the same targets, and whether the
"container turned" warning came without a turn.
Writes reports/benchmarks/track_accuracy.{json,md}. Run from the repository root: python3 benchmarks/track_accuracy.py
(--only angles, dynamics or elevation runs one part; the other parts' previous results are kept).
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
from bench_output import OUT
from scipy.stats import binom

from sloshid.core.atomic import atomic_path, write_text
from sloshid.identification.estimator import Z95, Identifier
from sloshid.identification.signals import Signal, signal_from_track
from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.tracking.float_angle import hsv_mask
from sloshid.tracking.tracker import TrackSettings, track_video
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, preset
from sloshid.video.frames import FrameReader

CASES = [
    (
        "640x480 30fps h264 noise5 blur1.0 roll1",
        "image",
        SynthSettings(
            width=640, height=480, fps=30, duration_s=5, noise_sigma=5, blur_px=1.0, camera_roll_deg=1.0, seed=101
        ),
    ),
    (
        "640x480 120fps mpeg4 noise8 blur1.5 flicker",
        "image",
        SynthSettings(
            width=640,
            height=480,
            fps=120,
            duration_s=4,
            noise_sigma=8,
            blur_px=1.5,
            flicker=0.05,
            codec="mpeg4",
            quality=5,
            f_hz=2.5,
            zeta=0.03,
            amplitude_deg=10,
            seed=102,
        ),
    ),
    (
        "1280x720 60fps h264 crf26 noise6 blur2.0 move",
        "image",
        SynthSettings(
            width=1280,
            height=720,
            fps=60,
            duration_s=4,
            noise_sigma=6,
            blur_px=2.0,
            codec="h264",
            quality=26,
            motion="move",
            accel_m_s2=3.0,
            move_duration_s=1.2,
            px_per_m=500,
            seed=103,
        ),
    ),
    (
        "1280x720 30fps mpeg4 noise7 blur1.2 VFR",
        "image",
        SynthSettings(
            width=1280,
            height=720,
            fps=30,
            duration_s=5,
            noise_sigma=7,
            blur_px=1.2,
            codec="mpeg4",
            vfr_jitter=0.3,
            amplitude_deg=12,
            seed=104,
        ),
    ),
    (
        "640x480 60fps h264 noise6 container tilt+-3 crossing",
        "container",
        SynthSettings(
            width=640,
            height=480,
            fps=60,
            duration_s=5,
            noise_sigma=6,
            blur_px=1.2,
            container_tilt_deg=3,
            container_tilt_hz=0.3,
            travel_px=300,
            camera_roll_deg=1.0,
            seed=105,
        ),
    ),
    (
        "1280x720 30fps mpeg4 noise8 container tilt+-3 crossing",
        "container",
        SynthSettings(
            width=1280,
            height=720,
            fps=30,
            duration_s=5,
            noise_sigma=8,
            blur_px=1.5,
            codec="mpeg4",
            container_tilt_deg=3,
            container_tilt_hz=0.25,
            travel_px=600,
            seed=106,
        ),
    ),
    (
        "640x480 60fps h264 noise5 container at rest, robot move",
        "container",
        SynthSettings(
            width=640,
            height=480,
            fps=60,
            duration_s=4,
            noise_sigma=5,
            blur_px=1.0,
            camera_roll_deg=1.0,
            motion="move",
            accel_m_s2=3.0,
            move_duration_s=1.2,
            px_per_m=400,
            seed=107,
        ),
    ),
]


def principal_axis_deg(mask: np.ndarray) -> float:
    """Naive float angle: principal axis of a binary mask, CCW as seen."""
    m = cv2.moments(mask, binaryImage=True)
    return -0.5 * math.degrees(math.atan2(2 * m["mu11"], m["mu20"] - m["mu02"]))


def hough_vertical_deg(frame: np.ndarray) -> float:
    """Naive container angle: mean tilt of the strongest near-vertical Hough lines, CCW as seen."""
    edges = cv2.Canny(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY), 30, 90)
    lines = cv2.HoughLines(edges, 1, np.pi / 720, frame.shape[0] // 5)
    if lines is None:
        return math.nan
    th = lines[:8, 0, 1]
    th = np.where(th > np.pi / 2, th - np.pi, th)
    th = th[np.abs(th) < math.radians(20)]
    return float(np.degrees(np.mean(th))) if len(th) else math.nan


def baseline(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Naive per-frame float angles and Hough wall angles for the whole video."""
    hsv = preset(DEFAULT_FLOAT_COLOR).hsv
    floats, walls = [], []
    for _, _, frame in FrameReader(path):
        floats.append(principal_axis_deg(hsv_mask(frame, hsv)))
        walls.append(hough_vertical_deg(frame))
    return np.array(floats), np.array(walls)


def stats(err: np.ndarray) -> dict[str, float]:
    """RMSE and max absolute error over the finite entries."""
    err = err[np.isfinite(err)]
    return {"rmse_deg": float(np.sqrt(np.mean(err**2))), "max_deg": float(np.max(np.abs(err)))}


def plot_errors(traces: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]], path: Path) -> None:
    """One panel per case: error of sloshid and of the naive baseline over time (what a reader looks at)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(traces), 1, figsize=(9, 1.9 * len(traces)), sharex=False)
    for ax, (name, t, ours, naive) in zip(axes, traces):
        ax.plot(t, naive, color="0.6", lw=0.8, label="naive mask + principal axes")
        ax.plot(t, ours, color="C3", lw=0.9, label="sloshid track")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylim(-1.0, 1.0)
        ax.set_ylabel("error, deg")
        ax.set_title(name, fontsize=9, loc="left")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t, s")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)


def dynamics_cases(n: int = 20, seed: int = 1212) -> list[tuple[str, str, SynthSettings]]:
    """The seeded dynamics set: alternating targets, each clip with its own frame rate, codec and look."""
    rng = np.random.default_rng(seed)
    colours = ["red", "orange", "yellow", "green", "blue", "magenta"]
    cases = []
    for k in range(n):
        target = "surface" if k % 2 else "float"
        w, h = [(640, 480), (800, 600)][int(rng.integers(2))]
        fps = float(rng.choice([30, 60, 120]))
        codec = "h264" if rng.random() < 0.7 else "mpeg4"
        quality = float(rng.choice([16, 18, 20])) if codec == "h264" else float(rng.choice([2, 3]))
        common = dict(
            width=w,
            height=h,
            fps=fps,
            duration_s=5.0,
            tap_s=0.5,
            f_hz=float(rng.uniform(1.5, 3.5)),
            zeta=float(rng.uniform(0.02, 0.06)),
            amplitude_deg=float(rng.uniform(5, 10)),
            noise_sigma=float(rng.uniform(3, 7)),
            blur_px=float(rng.uniform(0.6, 1.5)),
            codec=codec,
            quality=quality,
            seed=1000 + k,
        )
        if target == "surface":
            look = dict(
                scene="surface",
                liquid_color=str(rng.choice(colours)),
                elevation_deg=float(rng.choice([0.0, 3.0, 6.0])),
                meniscus_px=float(rng.uniform(0, 2)),
                meniscus_dark=bool(rng.random() < 0.3),
                specular=float(rng.uniform(0, 0.5)),
                reflection=float(rng.uniform(0, 0.5)),
                second_mode=float(rng.uniform(0, 0.2)),
                container_tilt_deg=float(rng.uniform(0, 2)),
            )
        else:
            real = rng.random() < 0.6  # most floats look real: rounded, bent, a specular spot, partly submerged
            look = dict(
                float_color=str(rng.choice(colours[:1] + colours[2:])),  # orange is too close to the pale liquid's
                float_length_frac=float(rng.uniform(0.15, 0.25)),
                camera_roll_deg=float(rng.uniform(-2, 2)),
                float_rounded=real,
                float_bend_px=float(rng.uniform(0, 3)) if real else 0.0,
                float_specular=float(rng.uniform(0, 0.6)) if real else 0.0,
                float_submerged=float(rng.uniform(0, 0.4)) if real else 0.0,
                motion_blur=float(rng.uniform(0, 0.5)) if real else 0.0,
            )
        s = SynthSettings(**common, **look)
        name = f"{k:02d} {target} {w}x{h} {fps:.0f}fps {codec} q{quality:g} noise{s.noise_sigma:.0f}"
        cases.append((name, target, s))
    return cases


def _identified(signal: Signal) -> dict:
    """f and zeta with 95 % intervals of one trace, identified with the default settings; for a tracked trace also
    what the plain fit (no encoder hold) gave, with its HAC interval, and the fitted hold's half-width."""
    res = Identifier().fit(signal).result
    p, fit = res.parameters, res.fit
    out = {k: (p[k].value, p[k].ci95) for k in ("f_hz", "zeta")}
    if fit.hold is not None:
        se = np.sqrt(np.clip(np.diag(fit.hold.plain_cov), 0, None))
        scale = np.array([2 * math.pi, 1.0])
        before = (np.array([fit.omega_rad_s, fit.zeta]) - fit.hold.weight * fit.hold.shift) / scale
        for key, v, s_e in zip(("f_hz", "zeta"), before, se / scale):
            out[f"{key}_uncorrected"] = (float(v), (float(v - Z95 * s_e), float(v + Z95 * s_e)))
        out["hold_half_width_deg"] = (fit.hold.width, fit.hold.width_se)
    return out


LOSSLESS_KEYS = ("angle_rmse_deg", "f_hz_err_pct", "zeta_err_pct", "f_hz_covered", "zeta_covered")
"""What a float clip's lossless control (the same clip as H.264 CRF 0: the same look, noise and frame rate, no codec
loss) reports beside it, as `<key>_lossless`."""


def dynamics_case(name: str, target: str, s: SynthSettings, path: Path) -> dict:
    """Render, track and identify one clip and its truth; the errors the user would get. A float clip is also rendered
    losslessly (its LOSSLESS_KEYS): what the tracker alone leaves of the dynamics."""
    row = _tracked_case(name, target, s, path)
    if target == "float":
        control = _tracked_case(name, target, replace(s, codec="h264", quality=0.0), path.with_name("control.mp4"))
        row |= {f"{k}_lossless": control[k] for k in LOSSLESS_KEYS}
    return row


def _tracked_case(name: str, target: str, s: SynthSettings, path: Path) -> dict:
    """One clip rendered, tracked and identified, with its truth trace identified alike."""
    truth = render_video(path, s)
    reference = "container" if target == "surface" else "image"
    t0 = time.perf_counter()
    if target == "surface":  # the dye colour is left to the automatic choice
        settings = TrackSettings(target=target, reference=reference, container_diameter_m=0.1)
    else:
        settings = TrackSettings(float_color=s.float_color, reference=reference)
    res = track_video(path, settings)
    elapsed = time.perf_counter() - t0
    want = truth["rel_angle_deg"] if reference == "container" else truth["float_angle_deg"]
    ok = res.valid.astype(bool)
    row = {"case": name, "target": target, "frames": len(res.t_s), "valid_share": float(ok.mean())}
    row["repeated_share"] = float(res.repeated.mean())
    row["angle_rmse_deg"] = float(np.sqrt(np.mean((res.angle_deg - want)[ok] ** 2)))
    if target == "surface":
        cols = res.columns()
        err = [cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"] for side in ("left", "right")]
        row["wall_rmse_px"] = float(np.sqrt(np.mean(np.concatenate([e[ok] for e in err]) ** 2)))
    exact = _identified(Signal(truth["t_s"], want, "angle", "deg", "truth"))
    tracked = _identified(signal_from_track(res))
    for key in ("f_hz", "zeta"):
        row[f"{key}_truth_trace"] = exact[key][0]
        for suffix, (value, (lo, hi)) in (("", tracked[key]), ("_uncorrected", tracked[f"{key}_uncorrected"])):
            row[f"{key}_tracked{suffix}"] = value
            row[f"{key}_err_pct{suffix}"] = 100 * (value / exact[key][0] - 1)
            row[f"{key}_covered{suffix}"] = bool(lo <= exact[key][0] <= hi)
            row[f"{key}_ci_halfwidth_pct{suffix}"] = 50 * (hi - lo) / value
    row["hold_half_width_deg"], row["hold_half_width_stderr_deg"] = tracked["hold_half_width_deg"]
    row["track_fps"] = len(res.t_s) / elapsed
    return row


def _yes(flag: bool) -> str:
    """yes/no for a table cell."""
    return "yes" if flag else "no"


DYNAMICS_SETS = (
    ("calibration set (seed 1212): the clips the encoder-hold model was developed on", 1212),
    ("held-out set (seed 1213): drawn alike, used for no choice", 1213),
)
"""The seeded dynamics sets: the first shaped the encoder-hold fit, the second checks it (a third draw, seed 1214,
decided between variants: see README)."""


def _summary_table(rows: list[dict]) -> list[str]:
    """Before/after counts, coverage and median interval half-widths of one set, as Markdown lines."""
    cells = {}
    for label, suffix in (("before", "_uncorrected"), ("after", "")):
        f_ok, z_ok = _within_targets(rows, suffix)
        covered = [r[f"{k}_covered{suffix}"] for r in rows for k in ("f_hz", "zeta")]
        widths = [np.median([r[f"{k}_ci_halfwidth_pct{suffix}"] for r in rows]) for k in ("f_hz", "zeta")]
        # how often intervals of a true 95 % rate would cover this few or fewer (independent intervals)
        tail = float(binom.cdf(sum(covered), len(covered), 0.95))
        cells[label] = (f_ok, z_ok, 100 * np.mean(covered), tail, *widths)
    (fb, zb, cb, pb, wfb, wzb), (fa, za, ca, pa, wfa, wza) = cells["before"], cells["after"]
    n = len(rows)
    return [
        "| measure | before | after | target |",
        "|---|---|---|---|",
        f"| f within 0.1 % | {fb} of {n} | {fa} of {n} | all |",
        f"| zeta within 3 % | {zb} of {n} | {za} of {n} | all |",
        f"| 95 % intervals covering the truth trace's value ({2 * n}) | {cb:.0f} % | {ca:.0f} % | about 95 % |",
        f"| chance that intervals with a true 95 % rate cover this few or fewer | {pb:.2g} | {pa:.2g} | |",
        f"| median 95 % half-width, f | {wfb:.3f} % | {wfa:.3f} % |  |",
        f"| median 95 % half-width, zeta | {wzb:.2f} % | {wza:.2f} % |  |",
    ]


def _within_targets(rows: list[dict], suffix: str) -> tuple[int, int]:
    """How many rows have f within F_TARGET_PCT and zeta within ZETA_TARGET_PCT of the truth trace's (`suffix`: which
    result, "" for identify's, "_uncorrected" or "_lossless")."""
    f_ok = sum(abs(r[f"f_hz_err_pct{suffix}"]) <= F_TARGET_PCT for r in rows)
    return f_ok, sum(abs(r[f"zeta_err_pct{suffix}"]) <= ZETA_TARGET_PCT for r in rows)


F_TARGET_PCT, ZETA_TARGET_PCT = 0.1, 3.0
"""Issue 12's dynamics targets: f within 0.1 % and zeta within 3 % of the truth trace's."""


def _control_table(rows: list[dict]) -> list[str]:
    """A set's float clips as coded against their lossless controls (identify's result, after), as Markdown lines:
    what the codec takes from the dynamics and what the tracker does. Empty when the rows have no controls."""
    floats = [r for r in rows if "f_hz_err_pct_lossless" in r]
    if not floats:
        return []
    n, cells = len(floats), {}
    for label, suffix in (("coded", ""), ("lossless", "_lossless")):
        f_ok, z_ok = _within_targets(floats, suffix)
        worst = [max(abs(r[f"{k}_err_pct{suffix}"]) for r in floats) for k in ("f_hz", "zeta")]
        covered = sum(r[f"{k}_covered{suffix}"] for r in floats for k in ("f_hz", "zeta"))
        cells[label] = (f_ok, worst[0], z_ok, worst[1], covered)
    (fc, wfc, zc, wzc, cc), (fl, wfl, zl, wzl, cl) = cells["coded"], cells["lossless"]
    return [
        f"| the {n} float clips | as coded | lossless control (H.264 CRF 0) | target |",
        "|---|---|---|---|",
        f"| f within 0.1 % (largest error) | {fc} of {n} ({wfc:.3f} %) | {fl} of {n} ({wfl:.3f} %) | all |",
        f"| zeta within 3 % (largest error) | {zc} of {n} ({wzc:.2f} %) | {zl} of {n} ({wzl:.2f} %) | all |",
        f"| 95 % intervals covering the truth trace's value | {cc} of {2 * n} | {cl} of {2 * n} | about 95 % |",
    ]


def _clip_table(rows: list[dict]) -> list[str]:
    """One Markdown row per clip: validity, RMSEs, f and zeta errors and coverage before / after."""
    lines = [
        "| clip | valid | repeated | angle RMSE deg | wall RMSE px | hold half-width deg | f err % before / after | "
        "zeta err % before / after | f covered | zeta covered | lossless control: angle RMSE deg, f / zeta err % | "
        "track fps |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        wall = f"{r['wall_rmse_px']:.2f}" if "wall_rmse_px" in r else "-"
        lines.append(
            f"| {r['case']} | {r['valid_share']:.2f} | {r['repeated_share']:.2f} | {r['angle_rmse_deg']:.3f} | {wall} | "
            f"{r['hold_half_width_deg']:.3f} ± {r['hold_half_width_stderr_deg']:.3f} | "
            f"{r['f_hz_err_pct_uncorrected']:+.3f} / {r['f_hz_err_pct']:+.3f} | "
            f"{r['zeta_err_pct_uncorrected']:+.2f} / {r['zeta_err_pct']:+.2f} | "
            f"{_yes(r['f_hz_covered_uncorrected'])} / {_yes(r['f_hz_covered'])} | "
            f"{_yes(r['zeta_covered_uncorrected'])} / {_yes(r['zeta_covered'])} | {_control_cell(r)} | "
            f"{r['track_fps']:.0f} |"
        )
    return lines


def _control_cell(r: dict) -> str:
    """A clip's lossless control as a table cell ("-" for a surface clip, which has none)."""
    if "f_hz_err_pct_lossless" not in r:
        return "-"
    return f"{r['angle_rmse_deg_lossless']:.3f}, {r['f_hz_err_pct_lossless']:+.3f} / {r['zeta_err_pct_lossless']:+.2f}"


def run_dynamics() -> list[dict]:
    """Both dynamics sets: per-clip rows (with their set's seed)."""
    everything = []
    with tempfile.TemporaryDirectory() as tmp:
        for _, seed in DYNAMICS_SETS:
            for name, target, s in dynamics_cases(seed=seed):
                row = {"set_seed": seed, **dynamics_case(name, target, s, Path(tmp) / "d.mp4")}
                everything.append(row)
                print(
                    f"{seed} {name}: rmse {row['angle_rmse_deg']:.3f} f {row['f_hz_err_pct']:+.3f} % zeta "
                    f"{row['zeta_err_pct']:+.2f} % covered {row['f_hz_covered']}/{row['zeta_covered']}",
                    flush=True,
                )
    return everything


def _dynamics_markdown(rows: list[dict]) -> list[str]:
    """The dynamics section: per set, the summary and the per-clip table."""
    lines = [
        "",
        "## Dynamics: identified f and zeta of the tracked trace against its truth trace",
        "",
        "Seeded 5 s clips, tap at 0.5 s. Before = the plain PT2 fit with its HAC interval; after = what identify "
        "reports for a tracked video trace: the mode fitted as seen through an encoder hold whose half-width is fitted "
        "with it (float and surface alike), averaged with the plain fit by the hold's Akaike weight, the interval from "
        "the joint covariance widened to hold the held fit's. Each float clip is also "
        "rendered losslessly (the same clip as H.264 CRF 0: same look, noise and frame rate) and identified after "
        "tracking alike: its errors are the tracker's own, the difference to the coded clip's is the codec's.",
    ]
    for title, seed in DYNAMICS_SETS:
        mine = [r for r in rows if r["set_seed"] == seed]
        control = _control_table(mine)
        lines += ["", f"### {title[0].upper()}{title[1:]}", "", *_summary_table(mine), ""]
        lines += [*control, "", *_clip_table(mine)] if control else _clip_table(mine)
    return lines


ELEVATIONS_DEG = (0.0, 8.0, 16.0)
"""Camera elevations of the elevation sweep; the dynamics sets draw 0-6 deg."""


def elevation_cases() -> list[tuple[str, SynthSettings]]:
    """Every dye preset at each of ELEVATIONS_DEG (bright meniscus), and at the highest with a dark one and more
    noise: 640x480, 30 fps, H.264, a 5 s tap test with highlight stripes."""
    cases = []
    for k, dye in enumerate(["red", "orange", "yellow", "green", "blue", "magenta"]):
        for elevation, dark in [*((e, False) for e in ELEVATIONS_DEG), (ELEVATIONS_DEG[-1], True)]:
            s = SynthSettings(
                scene="surface",
                width=640,
                height=480,
                fps=30,
                duration_s=5.0,
                liquid_color=dye,
                elevation_deg=elevation,
                meniscus_px=2.0 if dark else 1.0,
                meniscus_dark=dark,
                specular=0.2,
                noise_sigma=6.0 if dark else 5.0,
                seed=300 + 10 * k + int(elevation) + dark,
            )
            cases.append((f"{dye} {elevation:g} deg" + (" dark meniscus" if dark else ""), s))
    return cases


def run_elevation() -> list[dict]:
    """Track every elevation case against the image: one row per case."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, s in elevation_cases():
            path = Path(tmp) / "e.mp4"
            truth = render_video(path, s)
            res = track_video(path, TrackSettings(target="surface"))
            ok, cols = res.valid.astype(bool), res.columns()
            walls = [(cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok] for side in ("left", "right")]
            row = {
                "case": name,
                "valid_share": float(ok.mean()),
                "angle_rmse_deg": float(np.sqrt(np.mean((res.angle_deg - truth["surface_angle_deg"])[ok] ** 2))),
                "wall_rmse_px": float(np.sqrt(np.mean(np.concatenate(walls) ** 2))),
                "false_turn_warning": any("container turned" in w for w in res.warnings),
            }
            row["meets_target"] = row["angle_rmse_deg"] <= 0.3 and row["wall_rmse_px"] <= 1.0
            rows.append(row)
            print(f"{name}: angle {row['angle_rmse_deg']:.3f} deg, walls {row['wall_rmse_px']:.2f} px", flush=True)
    return rows


def _elevation_markdown(rows: list[dict]) -> list[str]:
    """The elevation section's table."""
    lines = [
        "",
        "## Camera elevation: the surface seen from above",
        "",
        "Every dye preset, 640x480, 30 fps, H.264, 5 s tap test, highlight stripes, noise 5 (dark meniscus: noise 6), "
        '`--reference image`. The container stands still, so a "container turned" warning is false.',
        "",
        "| case | valid | angle RMSE deg | wall RMSE px | false turn warning | target | met |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['valid_share']:.2f} | {r['angle_rmse_deg']:.3f} | {r['wall_rmse_px']:.2f} | "
            f"{_yes(r['false_turn_warning'])} | angle <= 0.3 deg, walls <= 1 px | {'yes' if r['meets_target'] else 'NO'} |"
        )
    return lines


def main() -> None:
    """Run the angle cases, the dynamics sets and the elevation sweep (or one of them); write JSON and Markdown (and
    the angle error figure)."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", choices=("angles", "dynamics", "elevation"))
    parser.add_argument("--tables-only", action="store_true", help="rebuild the Markdown from the JSON, run nothing")
    args = parser.parse_args()
    only = args.only
    previous = json.loads((OUT / "track_accuracy.json").read_text()) if (OUT / "track_accuracy.json").exists() else {}
    if args.tables_only:
        rows, lines = previous.get("cases", []), previous.get("angle_markdown", [])
        dyn, elev = previous.get("dynamics", []), previous.get("elevation", [])
    else:
        rows, lines = run_angles() if only in (None, "angles") else (previous["cases"], previous["angle_markdown"])
        dyn = run_dynamics() if only in (None, "dynamics") else previous.get("dynamics", [])
        elev = run_elevation() if only in (None, "elevation") else previous.get("elevation", [])
    dyn_lines = _dynamics_markdown(dyn)
    OUT.mkdir(parents=True, exist_ok=True)
    if not args.tables_only:
        doc = {"cases": rows, "angle_markdown": lines, "dynamics": dyn, "dynamics_markdown": dyn_lines}
        write_text(OUT / "track_accuracy.json", json.dumps({**doc, "elevation": elev}, indent=2) + "\n")
    write_text(OUT / "track_accuracy.md", "\n".join(lines + dyn_lines + _elevation_markdown(elev)) + "\n")


def run_angles() -> tuple[list[dict], list[str]]:
    """Render every angle case, track it, compare with truth and the baseline; rows, Markdown and a figure."""
    rows = []
    traces = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, reference, s in CASES:
            path = Path(tmp) / "v.mp4"
            truth = render_video(path, s)
            t0 = time.perf_counter()
            res = track_video(path, TrackSettings(reference=reference))
            elapsed = time.perf_counter() - t0
            want = truth["rel_angle_deg"] if reference == "container" else truth["float_angle_deg"]
            ours = stats(np.where(res.valid == 1, res.angle_deg - want, np.nan))  # frames the encoder updated
            smooth = stats(res.angle_smoothed_deg - want)
            naive_float, naive_wall = baseline(path)
            if reference == "container":
                base = stats(naive_float - naive_wall - want)
                base_float = stats(naive_float - truth["container_angle_deg"] - want)
            else:
                base = base_float = stats(naive_float - want)
            naive_err = (naive_float - truth["container_angle_deg"] if reference == "container" else naive_float) - want
            traces.append(
                (
                    f"{name} (naive with the true reference)" if reference == "container" else name,
                    res.t_s,
                    res.angle_deg - want,
                    naive_err,
                )
            )
            target_rmse = 0.3 if reference == "container" else 0.2
            ok = ours["rmse_deg"] <= target_rmse and (reference == "container" or ours["max_deg"] <= 1.0)
            rows.append(
                {
                    "case": name,
                    "reference": reference,
                    "frames": len(res.t_s),
                    "valid_share": float(res.valid.mean()),
                    "sloshid": ours,
                    "sloshid_smoothed": smooth,
                    "naive_baseline": base,
                    "naive_float_true_reference": base_float,
                    "target": {"rmse_deg": target_rmse, "max_deg": None if reference == "container" else 1.0},
                    "meets_target": bool(ok),
                    "track_fps": len(res.t_s) / elapsed,
                }
            )
            print(
                f"{name}: rmse {ours['rmse_deg']:.3f} max {ours['max_deg']:.3f} | smoothed {smooth['rmse_deg']:.3f} "
                f"| naive {base['rmse_deg']:.3f}/{base['max_deg']:.3f} | {'OK' if ok else 'MISSED'}",
                flush=True,
            )
    OUT.mkdir(parents=True, exist_ok=True)
    lines = [
        "# track accuracy (synthetic videos, truth from sloshid synth)",
        "",
        "Angle error of `angle_deg` against the rendered truth; naive = binary HSV mask + principal axes "
        "(+ mean Hough wall angle for the container reference).",
        "",
        "| case | reference | frames | RMSE deg | max deg | smoothed RMSE | naive RMSE | naive max | "
        "naive float, true reference: RMSE | target | met |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        tgt = f"RMSE<={r['target']['rmse_deg']}" + (
            f", max<={r['target']['max_deg']}" if r["target"]["max_deg"] else ""
        )
        lines.append(
            f"| {r['case']} | {r['reference']} | {r['frames']} | {r['sloshid']['rmse_deg']:.3f} | "
            f"{r['sloshid']['max_deg']:.3f} | {r['sloshid_smoothed']['rmse_deg']:.3f} | "
            f"{r['naive_baseline']['rmse_deg']:.3f} | {r['naive_baseline']['max_deg']:.3f} | "
            f"{r['naive_float_true_reference']['rmse_deg']:.3f} | {tgt} | "
            f"{'yes' if r['meets_target'] else 'NO'} |"
        )
    plot_errors(traces, OUT / "track_accuracy.png")
    lines += [
        "",
        "![error over time per case](track_accuracy.png)",
        "",
        "Error of `angle_deg` over time per case, sloshid (red) and the naive baseline (grey). The largest "
        "remaining errors come with strong compression (H.264 CRF 26 at 1280x720) and fast motion. For the "
        "container cases the grey curve uses the true container angle, because the naive Hough wall "
        "reference alone is off by several degrees.",
    ]
    return rows, lines


if __name__ == "__main__":
    main()
