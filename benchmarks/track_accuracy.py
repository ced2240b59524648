"""Benchmark: angle accuracy of `sloshid track` on synthetic videos the tests do not use, vs a naive baseline.

Targets (issue 2): RMSE of angle_deg <= 0.2 deg and max error <= 1 deg at 640x480 and 1280x720,
30-120 fps, noise sigma 5-8, blur, H.264 or MPEG-4; with --reference container on a container tilting
+-3 deg while crossing the frame, RMSE <= 0.3 deg. The baseline is what people write first: a binary
HSV mask of the whole frame and its principal axes (and, for the container case, the mean angle of the
near-vertical Hough lines as the wall reference; and, to isolate the float measurement, the naive float
angle against the true container angle). Writes reports/benchmarks/track_accuracy.{json,md}.
Run from the repository root: python3 benchmarks/track_accuracy.py
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bench_output import OUT

from sloshid.core.atomic import atomic_path, write_text
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


def main() -> None:
    """Render every case, track it, compare with truth and the baseline, write JSON, Markdown and a figure."""
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
            ours = stats(res.angle_deg - want)
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
    write_text(OUT / "track_accuracy.json", json.dumps({"cases": rows}, indent=2) + "\n")
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
    write_text(OUT / "track_accuracy.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
