"""Track the float through a video: one row per decoded frame with the angle relative to the chosen reference.

`track_video(path, TrackSettings(...))` is the API the CLI, the batch runner and the pipeline call. It
reads frames sequentially with their presentation times, finds and measures the float (float_angle),
measures the container's walls when the reference is the container (container_ref), smooths and
bridges the angle trace with a Kalman/RTS smoother on the real timestamps (smooth), and can write an
overlay video showing what was measured.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from tqdm import tqdm

from sloshid.core.atomic import atomic_path
from sloshid.core.errors import SettingError, UserError
from sloshid.core.tables import to_pandas, write_csv
from sloshid.tracking.container_ref import ContainerMeasurement, ContainerTracker
from sloshid.tracking.float_angle import FloatFinder
from sloshid.tracking.overlay import draw_overlay
from sloshid.tracking.smooth import smooth_angle
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, HsvRange, preset
from sloshid.video.frames import FrameReader, VideoWriter

TRACK_COLUMNS = (
    "frame",
    "t_s",
    "angle_deg",
    "float_angle_deg",
    "container_angle_deg",
    "x_px",
    "y_px",
    "quality",
    "valid",
    "angle_smoothed_deg",
)
"""Output columns of `sloshid track` (the contract with identify/batch/pipeline)."""

VALID_QUALITY = 0.5
"""Frames whose quality is below this are marked valid = 0 (not used by the smoother)."""


@dataclass(frozen=True)
class TrackSettings:
    """How to find the float and what to measure its angle against: the one settings object of the tracker, which
    `sloshid track` options, the pipeline's and batch's [track] table and `sloshid.track(...)` keywords all fill."""

    float_color: str = DEFAULT_FLOAT_COLOR
    """Named float colour preset (red, orange, yellow, green, blue, magenta)."""
    float_hsv_low: tuple[int, int, int] | None = None
    """Lower OpenCV HSV corner (H 0..179, S and V 0..255); overrides float_color, needs float_hsv_high. A hue
    low above the hue high wraps through red."""
    float_hsv_high: tuple[int, int, int] | None = None
    """Upper OpenCV HSV corner."""
    roi: tuple[int, int, int, int] | None = None
    """Region of interest x, y, width, height in pixels; None = whole frame."""
    reference: Literal["image", "container"] = "image"
    """'image': angle against the image horizontal; 'container': against the container's measured walls."""
    smooth: bool = True
    """Compute angle_smoothed_deg (Kalman + RTS); off saves a little time on very long videos."""

    def __post_init__(self) -> None:
        if self.reference not in ("image", "container"):
            raise SettingError("reference", f"{{name}} must be 'image' or 'container', got {self.reference!r}.")
        if (self.float_hsv_low is None) != (self.float_hsv_high is None):
            missing = "float_hsv_high" if self.float_hsv_high is None else "float_hsv_low"
            raise SettingError(missing, "the float's HSV range needs both corners given together; add {name}.")
        if self.roi is not None:
            x, y, w, h = self.roi
            if w <= 0 or h <= 0 or x < 0 or y < 0:
                raise SettingError(
                    "roi", f"{{name}} {x},{y},{w},{h} must have x, y >= 0 and a positive width and height."
                )
        _ = self.hsv  # validates the colour name or the HSV corners now, before any frame is read

    @property
    def hsv(self) -> HsvRange:
        """The OpenCV HSV box searched for the float: the explicit corners, else the named preset's."""
        if self.float_hsv_low is not None:
            return HsvRange(tuple(self.float_hsv_low), tuple(self.float_hsv_high))
        return preset(self.float_color).hsv


@dataclass
class TrackResult:
    """Per-frame measurements (arrays of equal length) plus what went wrong along the way."""

    video: Path
    frame: np.ndarray
    t_s: np.ndarray
    angle_deg: np.ndarray
    float_angle_deg: np.ndarray
    container_angle_deg: np.ndarray
    x_px: np.ndarray
    y_px: np.ndarray
    quality: np.ndarray
    valid: np.ndarray
    angle_smoothed_deg: np.ndarray
    lost_share: float = 0.0
    """Share of the frames the container declares that did not decode (truncated file)."""
    warnings: list[str] = field(default_factory=list)

    @property
    def invalid_share(self) -> float:
        """Share of the decoded frames in which the float was not measured (valid = 0)."""
        return float(1 - np.mean(self.valid)) if len(self.valid) else 1.0

    def columns(self) -> dict[str, np.ndarray]:
        """The output table, keyed by TRACK_COLUMNS."""
        return {name: getattr(self, name) for name in TRACK_COLUMNS}

    def to_csv(self, path: str | Path) -> None:
        """Write the table atomically as CSV."""
        write_csv(path, self.columns())

    def summary(self) -> str:
        """One line: frames, valid frames, duration (what `sloshid track` prints)."""
        duration = self.t_s[-1] - self.t_s[0] if len(self.t_s) else 0.0
        return f"{self.video}: {len(self.t_s)} frames, {int(self.valid.sum())} valid, {duration:.2f} s"

    def to_dict(self) -> dict:
        """JSON-safe summary of the run (the per-frame table is `to_csv`/`to_pandas`)."""
        return {
            "video": str(self.video),
            "frames": len(self.t_s),
            "valid_frames": int(self.valid.sum()),
            "invalid_share": self.invalid_share,
            "lost_share": self.lost_share,
            "duration_s": float(self.t_s[-1] - self.t_s[0]) if len(self.t_s) else 0.0,
            "warnings": list(self.warnings),
        }

    def to_pandas(self):
        """The per-frame table as a pandas DataFrame (columns as in the CSV)."""
        return to_pandas(self.columns())

    def plot(self, ax=None):
        """Measured angle of the valid frames (dots) and the smoothed trace over time; returns the figure."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(9, 3.2))
        ok = self.valid == 1
        ax.plot(self.t_s[ok], self.angle_deg[ok], ".", ms=2, color="0.4", label="measured (valid frames)")
        ax.plot(self.t_s, self.angle_smoothed_deg, lw=1, color="tab:blue", label="Kalman/RTS smoothed")
        ax.set(xlabel="time t (s)", ylabel="float angle (deg)", title=f"tracked float angle: {self.video.name}")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
        return ax.figure

    def report(self, directory: str | Path) -> Path:
        """Write a one-page HTML report (the angle plot and the run's figures) to directory/index.html."""
        from sloshid.report.html import Report

        page = Report(f"sloshid track: {self.video.name}")
        page.add_table(["quantity", "value"], [[k, v] for k, v in self.to_dict().items() if k != "warnings"])
        for warning in self.warnings:
            page.add_text(f"warning: {warning}")
        page.add_figure(self.plot(), "Measured angle of every valid frame and the smoothed trace that bridges gaps.")
        return page.save(directory)


def _roi_box(settings: TrackSettings, width: int, height: int) -> tuple[int, int, int, int]:
    """The ROI checked against the frame, or the whole frame."""
    if settings.roi is None:
        return 0, 0, width, height
    x, y, w, h = settings.roi
    if x + w > width or y + h > height:
        raise UserError(f"ROI {x},{y},{w},{h} lies outside the {width}x{height} frame.")
    return x, y, w, h


def _unwrap(angle: float, previous: float) -> float:
    """Choose angle + k*180 closest to the previous angle (the float is a line: no head or tail)."""
    if not math.isfinite(previous):
        return angle
    return angle - 180.0 * round((angle - previous) / 180.0)


def track_video(
    path: str | Path,
    settings: TrackSettings | None = None,
    overlay: str | Path | None = None,
    progress: bool = False,
    multithreaded: bool = True,
) -> TrackResult:
    """Track the float in every decoded frame of `path`; optionally write an overlay video.

    Raises UserError for unreadable videos, a bad ROI, and a float (or, with the container reference,
    container walls) found in no frame; the overlay, if requested, is still written then: it shows what
    was searched. Truncation and partial loss are reported in `warnings`, `lost_share`, `invalid_share`.
    multithreaded=False decodes on one core in this thread (for batches that run many videos side by side).
    """
    settings = settings or TrackSettings()
    reader = FrameReader(Path(path), multithreaded)
    width, height = reader.frame_size
    roi = _roi_box(settings, width, height)
    finder = FloatFinder(settings.hsv, roi)
    walls = ContainerTracker(roi) if settings.reference == "container" else None
    rows: list[tuple] = []
    last_angle = math.nan
    floats_found = 0
    with contextlib.ExitStack() as stack:
        writer = None
        if overlay is not None:
            tmp = stack.enter_context(atomic_path(overlay))
            writer = stack.enter_context(VideoWriter(tmp, width, height, reader.info.fps or 30.0, "h264", 20))
        frames = tqdm(
            reader,
            total=reader.info.frame_count or None,
            desc="track",
            unit="frame",
            disable=None if progress else True,
            leave=False,
        )
        for index, t, frame in frames:
            fm = finder.measure(frame)
            floats_found += fm.found
            cm = ContainerMeasurement(True, 0.0)
            if walls is not None:
                cm = walls.measure(frame, fm.x_px, fm.y_px, fm.length_px) if fm.found else ContainerMeasurement(False)
            float_angle = _unwrap(fm.angle_deg, last_angle) if fm.found else math.nan
            ok = fm.found and cm.found and fm.quality >= VALID_QUALITY
            if ok:
                last_angle = float_angle
            rows.append(
                (
                    index,
                    t,
                    float_angle - cm.angle_deg,
                    float_angle,
                    cm.angle_deg,
                    fm.x_px,
                    fm.y_px,
                    fm.quality if cm.found else 0.0,
                    int(ok),
                )
            )
            if writer is not None:
                writer.write(draw_overlay(frame, fm, cm, float_angle - cm.angle_deg, ok, roi), t)
    # raised after the overlay is finished: when nothing is found, the overlay is the user's diagnosis
    if not any(r[-1] for r in rows):
        hint = (
            f"see the overlay {overlay}" if overlay else "write an overlay video ({overlay}) to see what was searched"
        )
        if walls is not None and floats_found:
            raise SettingError(
                "reference",
                f"the float was found in {floats_found} of {len(rows)} frames of {path} but the container's "
                f"side walls in none of them; {hint}, or use {{name}} image.",
                "overlay",
            )
        raise SettingError(
            "float_color",
            f"no float found in any of the {len(rows)} frames of {path} with HSV range "
            f"{settings.hsv.describe()}; {hint} and adjust {{float_hsv_low}}/{{float_hsv_high}} or {{name}}.",
            "overlay",
            "float_hsv_low",
            "float_hsv_high",
        )
    return _result(Path(path), rows, reader.lost_share, reader.info.frame_count, settings.smooth)


def _result(video: Path, rows: list[tuple], lost_share: float, declared: int, smooth: bool) -> TrackResult:
    """Assemble the TrackResult, smooth the angle and collect warnings."""
    cols = list(zip(*rows))
    arr = [np.asarray(c) for c in cols]
    frame, t, angle, fang, cang, x, y, q, valid = arr
    frame, valid = frame.astype(int), valid.astype(int)
    smoothed = smooth_angle(t, angle, valid.astype(bool), q) if smooth else np.full(len(t), np.nan)
    res = TrackResult(
        video,
        frame,
        t.astype(float),
        angle.astype(float),
        fang.astype(float),
        cang.astype(float),
        x.astype(float),
        y.astype(float),
        q.astype(float),
        valid,
        smoothed,
        lost_share,
    )
    if lost_share > 0.005:
        res.warnings.append(
            f"{video} looks truncated: only {len(rows)} of {declared} frames decoded "
            f"({100 * lost_share:.1f} % lost); tracked what decoded."
        )
    if res.invalid_share > 0:
        res.warnings.append(
            f"float not measured in {int(np.sum(valid == 0))} of {len(valid)} frames "
            f"({100 * res.invalid_share:.1f} %); those rows have valid = 0 and are bridged "
            "in angle_smoothed_deg."
        )
    return res
