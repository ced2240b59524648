"""Track the float through a video: one row per decoded frame with the angle relative to the chosen reference.

`track_video(path, TrackSettings(...))` is the API the CLI, the batch runner and the pipeline call. It
reads frames sequentially with their presentation times, finds and measures the float (float_angle),
measures the container's walls when the reference is the container (container_ref), smooths and
bridges the angle trace with a Kalman/RTS smoother on the real timestamps (smooth), and can write an
overlay video showing what was measured.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
import multiprocessing
import os
import shlex
import signal
import sys
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Literal, Protocol, TypeAlias, cast

import cv2
import numpy as np
from tqdm import tqdm

from sloshid.core.atomic import atomic_path, temporary_sibling
from sloshid.core.errors import NothingFound, SettingError, UserError, warn
from sloshid.core.outputs import Outputs
from sloshid.core.parallel import forked_helper, signals_held
from sloshid.core.settings import check_in_metres, setting_field
from sloshid.core.tables import to_pandas, write_csv
from sloshid.tracking.container_ref import ContainerMeasurement, ContainerTracker, WallsRecord
from sloshid.tracking.float_angle import ELONGATED, FloatFinder, FloatMeasurement, length_to_width, relaxed_ranges
from sloshid.tracking.overlay import draw_overlay
from sloshid.tracking.repeats import REPEAT_SHARE, Copies, line_regions, repeated_share, stale_repeats
from sloshid.tracking.robust import percentile_span
from sloshid.tracking.rows import VALID_QUALITY, TrackRow, step_row
from sloshid.tracking.smooth import smoothing_worker
from sloshid.tracking.surface import (
    MIN_LIQUID_SHARE,
    SurfaceFinder,
    auto_liquid_preset,
    coloured_regions,
    darker_liquid,
    dye_range,
    own_range,
    preset_regions,
)
from sloshid.tracking.surface_track import SurfaceStep, check_rest_frames
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, HsvRange, preset
from sloshid.video.frames import FrameReader, Picture, VideoInfo, VideoWriter, lost_share, shrunk, shrunk_size
from sloshid.video.keyframes import key_frame_times

if TYPE_CHECKING:
    from multiprocessing.sharedctypes import Synchronized

    from typing_extensions import Self

log = logging.getLogger("sloshid.tracking")
"""Progress of a tracking run (INFO); its doubts are SloshidWarnings and the result's `warnings`."""

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
    "key_frame",
)
"""Output columns of `sloshid track` (the contract with identify/batch/pipeline)."""

SURFACE_COLUMNS = (
    *TRACK_COLUMNS[:3],
    "surface_angle_deg",
    *TRACK_COLUMNS[4:],
    "left_wall_px",
    "right_wall_px",
    "left_wall_mm",
    "right_wall_mm",
)
"""Output columns with `target` surface: the same contract plus the wall heights (surface_angle_deg is the
surface's angle against the image horizontal, where the float target writes float_angle_deg)."""


SURFACE_ONLY = ("liquid_color", "liquid_hsv_low", "liquid_hsv_high", "rest_frames", "fov_deg")
"""Settings only the surface target reads (container_diameter_m too, refused with its own reason)."""
FLOAT_ONLY = ("float_color", "float_hsv_low", "float_hsv_high")
"""Settings only the float target reads."""


@dataclass(frozen=True)
class TrackSettings:
    """What to measure (the float or the dyed liquid's surface), how to find it and what to measure against: the one
    settings object of the tracker, which `sloshid track` options, the pipeline's and batch's [track] table and
    `sloshid.track(...)` keywords all fill."""

    float_color: str | None = setting_field(None, metavar="NAME")
    """Named float colour preset (red, orange, yellow, green, blue, magenta, or dark: any hue too dark to have one);
    not given: red for the float target. Where it measures the float in under half the frames and holds nothing in the
    first, the clip is tracked again with it relaxed (hues and saturation), kept where that measures more, with a
    warning."""
    float_hsv_low: tuple[int, int, int] | None = setting_field(None, metavar="H,S,V")
    """Lower OpenCV HSV corner of the float's colour (H 0..179, S and V 0..255); overrides `float_color`, needs
    `float_hsv_high`. A hue low above the hue high wraps through red."""
    float_hsv_high: tuple[int, int, int] | None = setting_field(None, metavar="H,S,V")
    """Upper OpenCV HSV corner of the float's colour."""
    roi: tuple[int, int, int, int] | None = setting_field(None, unit="px", metavar="X,Y,W,H")
    """Search only this region: left x, top y, width, height; not given: the whole frame. For the surface, an ROI
    drawn so tightly that the first frame shows no surface in it is widened a tenth on each side (with a warning)."""
    reference: Literal["image", "container"] = "image"
    """'image': the angle against the image horizontal; 'container': against the container's side walls (measured in
    every frame while the container moves, in every 6th while it stands still)."""
    smooth: bool = True
    """Compute angle_smoothed_deg (Kalman + RTS smoother); off saves a little time on very long videos (NaN column)."""
    target: Literal["float", "surface"] = setting_field("float", group="surface")
    """'float': a coloured float's angle; 'surface': the dyed liquid's surface angle and its height at each wall."""
    liquid_color: str | None = setting_field(None, metavar="NAME", group="surface")
    """Surface target: named dye colour preset; with neither it nor `liquid_hsv_low`/`liquid_hsv_high`, the preset
    covering most of the first frame is taken, or, where none measures as a liquid between walls there, the largest
    coloured region's own range or a region darker than the rest (the summary names the choice)."""
    liquid_hsv_low: tuple[int, int, int] | None = setting_field(None, metavar="H,S,V", group="surface")
    """Surface target: lower OpenCV HSV corner of the dyed liquid; overrides `liquid_color`, needs
    `liquid_hsv_high`."""
    liquid_hsv_high: tuple[int, int, int] | None = setting_field(None, metavar="H,S,V", group="surface")
    """Surface target: upper OpenCV HSV corner of the dyed liquid."""
    rest_frames: int | None = setting_field(None, unit="frames", metavar="N", group="surface")
    """Surface target: the first this many frames define the rest level of the wall heights; not given: the first
    second, or the frames before the container moves within it."""
    container_diameter_m: float | None = setting_field(None, unit="m", metavar="D", group="surface")
    """Surface target: the container's inner diameter, for the wall heights in millimetres (the walls give px/m)."""
    fov_deg: float | None = setting_field(None, unit="deg", metavar="DEG", group="surface")
    """Surface target: the camera's horizontal field of view (degrees, of the whole picture); given, the angle is
    corrected for the perspective of a camera above the liquid looking at a container off the picture's centre. A
    still picture does not show it; not given, it is found only from a move between two rest places."""

    def __post_init__(self) -> None:
        if self.reference not in ("image", "container"):
            raise SettingError("reference", f"{{name}} must be 'image' or 'container', got {self.reference!r}.")
        if self.target not in ("float", "surface"):
            raise SettingError("target", f"{{name}} must be 'float' or 'surface', got {self.target!r}.")
        for kind in ("float", "liquid"):
            low, high = getattr(self, f"{kind}_hsv_low"), getattr(self, f"{kind}_hsv_high")
            if (low is None) != (high is None):
                missing = f"{kind}_hsv_high" if high is None else f"{kind}_hsv_low"
                raise SettingError(missing, f"the {kind}'s HSV range needs both corners given together; add {{name}}.")
        if self.target == "float" and self.container_diameter_m is not None:
            raise SettingError(
                "container_diameter_m",
                "{name} scales the wall heights, which only {target} surface measures "
                "(the float target finds no walls to scale).",
                "target",
            )
        # an option of the other target would be ignored without a word: refused, as the scale above
        other = SURFACE_ONLY if self.target == "float" else FLOAT_ONLY
        given = [k for k in other if getattr(self, k) is not None]
        if given:
            raise SettingError(
                given[0],
                f"{{name}} applies only to {{target}} {'surface' if self.target == 'float' else 'float'}; "
                f"the {self.target} target does not use it.",
                "target",
            )
        if self.target == "float" and self.float_color is None:  # the default, filled in once nothing can be refused
            object.__setattr__(self, "float_color", DEFAULT_FLOAT_COLOR)
        check_in_metres("container_diameter_m", self.container_diameter_m, "0.1 for 100 mm")
        if self.fov_deg is not None and not 0 < self.fov_deg < 180:
            raise SettingError("fov_deg", f"{{name}} must be between 0 and 180 degrees, got {self.fov_deg}.")
        if self.rest_frames is not None and self.rest_frames < 1:
            raise SettingError("rest_frames", f"{{name}} must be at least 1, got {self.rest_frames}.")
        if self.roi is not None:
            x, y, w, h = self.roi
            if w <= 0 or h <= 0 or x < 0 or y < 0:
                raise SettingError(
                    "roi", f"{{name}} {x},{y},{w},{h} must have x, y >= 0 and a positive width and height."
                )
        for setting, check in (("float_color", lambda: self.hsv), ("liquid_color", lambda: self.liquid_hsv)):
            try:
                check()  # the colour names and HSV corners are valid now, before any frame is read
            except UserError as exc:
                corner = "hsv_high" if "HSV high" in str(exc) else "hsv_low"
                name = setting if "HSV" not in str(exc) else setting.replace("color", corner)
                raise SettingError(name, f"{{name}}: {exc}") from None

    @property
    def liquid_hsv(self) -> HsvRange | None:
        """The HSV box searched for the dyed liquid, or None to choose it from the first frame."""
        if self.liquid_hsv_low is not None:
            return _hsv_box("liquid", self.liquid_hsv_low, self.liquid_hsv_high)
        return preset(self.liquid_color).hsv if self.liquid_color else None

    @property
    def hsv(self) -> HsvRange:
        """The OpenCV HSV box searched for the float: the explicit corners, else the named preset's."""
        if self.float_hsv_low is not None:
            return _hsv_box("float", self.float_hsv_low, self.float_hsv_high)
        return preset(self.float_color or DEFAULT_FLOAT_COLOR).hsv


def _hsv_box(kind: str, low: tuple[int, int, int], high: tuple[int, int, int] | None) -> HsvRange:
    """The HSV box between two corners given (a TOML array as well as a tuple)."""
    if high is None:  # refused when the settings were made (`TrackSettings.__post_init__`)
        raise SettingError(
            f"{kind}_hsv_high", f"the {kind}'s HSV range needs both corners given together; add {{name}}."
        )
    # tuple() keeps a declared triple a triple (and makes a TOML array's list one); mypy only knows tuple[int, ...]
    return HsvRange(cast("tuple[int, int, int]", tuple(low)), cast("tuple[int, int, int]", tuple(high)))


@dataclass(kw_only=True)
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
    still: bool = False
    """Nothing moved the angle: over ten valid frames or more it spans less than STILL_SPAN_DEG (a warning says so),
    so `identify` finds no mode in it."""
    warnings: list[str] = field(default_factory=list)
    target: str = "float"
    """What was measured; with 'surface', float_angle_deg holds the surface's angle against the image."""
    walls: dict[str, np.ndarray] = field(default_factory=dict)
    """Surface target: left_wall_px, right_wall_px, left_wall_mm, right_wall_mm (NaN without a scale)."""
    repeated: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    """Frames whose picture of the float/surface the encoder copied from the previous frame while it moved
    (valid = 0: an old picture is not a new measurement)."""
    dye: str = ""
    """Surface target: the dye colour measured (its preset, said when it was chosen automatically, or its HSV range)."""
    key_frame: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """1 on the video's key frames (coded afresh, without earlier pictures): there the encoder's hold of slowly moving
    edges restarts, which identify models (pt2fit.encoder_hold)."""

    @property
    def invalid_share(self) -> float:
        """Share of the decoded frames in which the float was not measured (valid = 0)."""
        return float(1 - np.mean(self.valid)) if len(self.valid) else 1.0

    def columns(self) -> dict[str, np.ndarray]:
        """The output table, keyed by TRACK_COLUMNS (SURFACE_COLUMNS for the surface target)."""
        if self.target != "surface":
            return {name: getattr(self, name) for name in TRACK_COLUMNS}
        named = {"surface_angle_deg": self.float_angle_deg, **self.walls}
        return {name: named[name] if name in named else getattr(self, name) for name in SURFACE_COLUMNS}

    def to_csv(self, path: str | Path) -> None:
        """Write the table atomically as CSV (a .csv file, never over the tracked video)."""
        write_csv(Outputs([self.video]).file(path, "the track table", (".csv",)), self.columns())

    def summary(self) -> str:
        """One line: frames, valid frames, duration (what `sloshid track` prints)."""
        duration = self.t_s[-1] - self.t_s[0] if len(self.t_s) else 0.0
        repeated = f" ({int(self.repeated.sum())} repeated)" if self.repeated.any() else ""
        dye = f", dye {self.dye}" if self.dye else ""
        return f"{self.video}: {len(self.t_s)} frames, {int(self.valid.sum())} valid{repeated}, {duration:.2f} s{dye}"

    def to_dict(self) -> dict:
        """JSON-safe summary of the run (the per-frame table is `to_csv`/`to_pandas`)."""
        return {
            "video": str(self.video),
            "frames": len(self.t_s),
            "target": self.target,
            "valid_frames": int(self.valid.sum()),
            "repeated_frames": int(self.repeated.sum()),
            "invalid_share": self.invalid_share,
            "lost_share": self.lost_share,
            "dye": self.dye or None,
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
        what = "surface" if self.target == "surface" else "float"
        ax.plot(self.t_s[ok], self.angle_deg[ok], ".", ms=2, color="0.4", label="measured (valid frames)")
        ax.plot(self.t_s, self.angle_smoothed_deg, lw=1, color="tab:blue", label="Kalman/RTS smoothed")
        ax.set(xlabel="time t (s)", ylabel=f"{what} angle (deg)", title=f"tracked {what} angle: {self.video.name}")
        ax.legend(loc="upper right", fontsize=8)  # inside the axes: a plain savefig keeps it
        return ax.figure

    def report(self, directory: str | Path) -> Path:
        """Write a one-page HTML report (the angle plot and the run's figures) to directory/index.html."""
        from sloshid.report.html import Report

        page = Report(f"sloshid track: {self.video.name}")
        d, n = self.to_dict(), max(len(self.t_s), 1)
        rows = [
            ["video", d["video"]],
            ["target", "dyed liquid's surface" if self.target == "surface" else "float"],
            ["frames", f"{d['frames']} over {d['duration_s']:.2f} s"],
            ["valid frames (measured, quality >= 0.5)", f"{d['valid_frames']} ({100 * d['valid_frames'] / n:.1f} %)"],
            [
                "frames the encoder repeated (not valid)",
                f"{d['repeated_frames']} ({100 * d['repeated_frames'] / n:.1f} %)",
            ],
            ["declared frames that did not decode", f"{100 * d['lost_share']:.1f} %"],
        ]
        page.add_table(["quantity", "value"], rows)
        for warning in self.warnings:
            page.add_text(f"warning: {warning}")
        page.add_figure(self.plot(), "Measured angle of every valid frame and the smoothed trace that bridges gaps.")
        return page.save(directory)


WORK_WIDTH_PX = 960
"""A surface search area (the ROI, or the whole picture) whose first frame does not measure the surface validly is
measured reduced by the whole factor nearest its width over this, when the reduced one does (`surface_size`). The
surface's thresholds in pixels (an edge's steps, the rows a crossing holds, the margins of its boxes) were set on
pictures of 400-960 px: a 1920 px picture of a cola, with a 960 px render's speckle on every 2x2 pixels, broke the liquid
into a core and ragged sides. A large picture the tracker does measure is kept whole: rendered at 1920 px, 20 glasses
were read more closely there than reduced (image p95 0.15 against 0.23 deg)."""


def reduction(roi: tuple[int, int, int, int]) -> int:
    """How many times each way a surface search area `roi` is reduced when it is (`WORK_WIDTH_PX`; 1: never)."""
    return max(1, round(roi[2] / WORK_WIDTH_PX))


def shrunk_roi(roi: tuple[int, int, int, int], factor: int, size: tuple[int, int]) -> tuple[int, int, int, int]:
    """`roi` (x, y, w, h) in a picture of `size` (width, height) reduced `factor` times: the reduced pixels it
    touches."""
    h, w = shrunk_size(size[::-1], factor)
    x0, y0 = min(roi[0] // factor, w - 1), min(roi[1] // factor, h - 1)
    return x0, y0, min(w, -(-(roi[0] + roi[2]) // factor)) - x0, min(h, -(-(roi[1] + roi[3]) // factor)) - y0


def roi_box(settings: TrackSettings, width: int, height: int) -> tuple[int, int, int, int]:
    """The ROI checked against the frame, or the whole frame (track and inspect)."""
    if settings.roi is None:
        return 0, 0, width, height
    x, y, w, h = settings.roi
    if x + w > width or y + h > height:
        raise SettingError("roi", f"{{name}} {x},{y},{w},{h} reaches beyond the {width}x{height} frame.")
    return x, y, w, h


def _box(fm: FloatMeasurement) -> tuple[int, int, int, int]:
    """The box (x0, y0, x1, y1) around a float found."""
    if fm.bbox is None:
        raise ValueError("a float measured as found has no box")
    return fm.bbox


def _unwrap(angle: float, previous: float) -> float:
    """Choose angle + k*180 closest to the previous angle (the float is a line: no head or tail)."""
    if not math.isfinite(previous):
        return angle
    return angle - 180.0 * round((angle - previous) / 180.0)


class _FloatStep:
    """Per-frame float measurement (float_angle) against the image or the container walls (container_ref)."""

    def __init__(self, settings: TrackSettings, roi: tuple[int, int, int, int], hsv: HsvRange | None = None) -> None:
        self.settings, self.roi, self.hsv = settings, roi, hsv or settings.hsv
        self.finder = FloatFinder(self.hsv, roi)
        self.walls = ContainerTracker(roi) if settings.reference == "container" else None
        self.last_angle = math.nan
        self.found = 0
        self.cut = 0  # frames where the float reached the ROI's edge
        self.round = 0  # frames whose blob was not valid and rounder than a float (`_count`)
        self.roundest = 0.0  # the largest elongation of those blobs
        self.previous: np.ndarray | None = None
        self.repeated: list[bool] = []
        self.walls_record = WallsRecord()  # by frame in the span
        self.liquid_width: float | None = None  # `_liquid_width` of the first frame the float was found in
        self.copies = Copies()

    def __call__(self, frame: np.ndarray, draw: bool) -> tuple[TrackRow, np.ndarray | None]:
        """(row, overlay frame or None) of one frame; a frame whose picture around the last measured float is an exact
        copy of that frame's is not measured again (`Copies`: its row is that measurement's, after `revise`)."""
        copied = self.copies.source(frame, len(self.repeated))
        if copied is not None:
            fm, cm, row = copied
            self.finder.copied()
            self._count(fm)
            if self.walls is not None:
                self.walls_record.copied.append(len(self.repeated))
            self.repeated.append(True)
            self.previous = frame
            return row, draw_overlay(frame, fm, cm, row.angle_deg, bool(row.valid), self.roi) if draw else None
        fm = self.finder.measure(frame)
        self._count(fm)
        if fm.found and self.liquid_width is None:
            self.liquid_width = _liquid_width(frame, self.hsv, self.roi)
        repeat = fm.found and repeated_share(frame, self.previous, _box(fm), dy_only=False) >= REPEAT_SHARE
        self.previous = frame
        cm = ContainerMeasurement(True, 0.0)
        if self.walls is not None:  # nothing here tells whether the container moved: its walls' ends judge
            cm = ContainerMeasurement(False)
            if fm.found:
                cm = self.walls.measure(frame, fm.x_px, fm.y_px, fm.length_px, still=True)
            self.walls_record.add(len(self.repeated), cm)
        self.repeated.append(bool(repeat))
        float_angle = _unwrap(fm.angle_deg, self.last_angle) if fm.found else math.nan
        ok = fm.found and cm.found and fm.quality >= VALID_QUALITY
        if ok:
            self.last_angle = float_angle
        angle = float_angle - cm.angle_deg
        row = step_row(angle, float_angle, cm.angle_deg, fm.x_px, fm.y_px, fm.quality if cm.found else 0.0, int(ok))
        # the float's outline, and the container's wall edges when they are measured
        regions = [(fm.bbox, False), *line_regions(cm.edges if self.walls is not None else ())] if fm.found else None
        self.copies.measured(len(self.repeated) - 1, frame, regions, (fm, cm, row))
        return row, draw_overlay(frame, fm, cm, angle, ok, self.roi) if draw else None

    def _count(self, fm: FloatMeasurement) -> None:
        """Count a frame's blob for `nothing_found`: found, cut by the ROI, or round: not valid (quality under
        VALID_QUALITY) and less elongated than a float (under ELONGATED, where its shape lowered that quality)."""
        self.found += fm.found
        self.cut += fm.cut
        if fm.found and not fm.cut and fm.quality < VALID_QUALITY and fm.elongation < ELONGATED:
            self.round += 1
            self.roundest = max(self.roundest, fm.elongation)

    def revise(self, rows: list[TrackRow]) -> None:
        """Turn the frames whose container walls were held onto the container angle interpolated between the
        measurements around them (`held_angles`; `rows`: this span's, time first, changed in place); then give the
        copied frames their measured frame's row."""
        for i, value in self.walls_record.held_angles().items():
            rows[i] = rows[i]._replace(angle_deg=rows[i].float_angle_deg - value, container_angle_deg=value)
        self.copies.fill(rows)

    def merge(self, later: _FloatStep) -> None:
        """Take in what the step of a later span of the same video found (for `nothing_found` and `finish`)."""
        self.found += later.found
        self.cut += later.cut
        self.round += later.round
        self.roundest = max(self.roundest, later.roundest)
        if self.liquid_width is None:
            self.liquid_width = later.liquid_width

    def finish(self, rows: list[TrackRow]) -> tuple[list[TrackRow], dict[str, np.ndarray], list[str]]:
        """The table's rows as measured, no wall columns, and the warnings: a float cut by the ROI, a 'float' that is
        dyed liquid."""
        notes = []
        if self.cut:
            notes.append(
                f"the float reached the edge of the searched region (`roi`, or the picture) in {self.cut} of "
                f"{len(rows)} frames: part of it was outside, so those frames have valid = 0; widen `roi`."
            )
        if self.liquid_width:
            notes.append(
                f"what was tracked as the float looks like dyed liquid in its container (a body {self.liquid_width:.0f}"
                " px wide between straight side walls, with a surface across them): angle_deg is then that body's "
                "principal axis, not the surface's angle; for a dyed liquid use `target` surface."
            )
        return list(rows), {}, notes

    def nothing_found(self, n: int, path: Path, hint: str) -> NothingFound:
        """The one-sentence error when no frame was valid."""
        if self.cut and self.cut == self.found:
            return NothingFound(
                "roi",
                f"the float was found in {self.found} of {n} frames of {path} but always at the edge of the searched "
                f"region, partly outside it; {hint} and widen {{name}}.",
                "overlay",
                hint=hint,
            )
        if self.round and self.round + self.cut == self.found:
            return NothingFound(
                "float_color",
                f"a blob of the float's colour ({self.hsv.describe()}) was found in {self.found} of {n} frames "
                f"of {path}, but round, not elongated (at most {length_to_width(self.roundest):.2f} times as long as "
                f"wide): a float needs a length at least {length_to_width(ELONGATED):.2f} times its width for its "
                f"angle to be measured; {hint}, and film a float longer than wide, or adjust {{name}} or "
                "{float_hsv_low}/{float_hsv_high}, or {roi}, if that blob is not the float.",
                "overlay",
                "float_hsv_low",
                "float_hsv_high",
                "roi",
                hint=hint,
            )
        if self.walls is not None and self.found:
            return NothingFound(
                "reference",
                f"the float was found in {self.found} of {n} frames of {path} but the container's "
                f"side walls in none of them; {hint}, or use {{name}} image.",
                "overlay",
                hint=hint,
            )
        return NothingFound(
            "float_color",
            f"no float found in any of the {n} frames of {path} with HSV range "
            f"{self.hsv.describe()}; {hint} and adjust {{float_hsv_low}}/{{float_hsv_high}} or {{name}}.",
            "overlay",
            "float_hsv_low",
            "float_hsv_high",
            hint=hint,
        )


def track_video(
    path: str | Path,
    settings: TrackSettings | None = None,
    overlay: str | Path | None = None,
    progress: bool = False,
    multithreaded: bool = True,
    until_s: float | None = None,
) -> TrackResult:
    """Track the float (or the liquid surface) in every decoded frame of `path`; optionally write an overlay video.

    Raises UserError for unreadable videos, a bad ROI, and a float or liquid (or the container walls they need)
    found in no frame; the overlay, if requested, is still written then: it shows what was searched.
    Truncation and partial loss are reported in `warnings`, `lost_share`, `invalid_share`.
    A long video is tracked in spans (`SPAN_S`), side by side in processes when `multithreaded` and no overlay is
    written; multithreaded=False tracks them one after the other on one core in this thread (for batches that run
    many videos side by side). The table is the same either way. `until_s`: only the frames shown before this time
    (a trial of settings, as `inspect` runs one; no truncation is reported then). A named float colour that measures
    the float in under RELAX_BELOW of the frames is tried again relaxed (`_relaxed_run`).
    """
    settings = settings or TrackSettings()
    run = (path, settings, overlay, progress, multithreaded, until_s)
    res: TrackResult | None = None
    try:
        res = _track_once(*run)
    except NothingFound as exc:
        if not _may_relax(settings):
            raise
        res = _relaxed_run(run, None)
        if res is None:
            raise exc from None
    else:
        if _may_relax(settings) and float(np.mean(res.valid)) < RELAX_BELOW:
            res = _relaxed_run(run, res) or res
    for warning in res.warnings:
        warn(warning)
    log.info("tracked %s: %d frames, %.1f %% valid", path, len(res.t_s), 100 * float(np.mean(res.valid)))
    return res


RELAX_BELOW = 0.5
"""A named float colour whose run measures the float validly in under this share of the frames, and whose range holds
nothing in the first frame, is tried again with the range relaxed (`float_range`)."""


def _may_relax(settings: TrackSettings) -> bool:
    """The float target with a named colour (a range given as HSV corners is the user's, used as given)."""
    return settings.target == "float" and settings.float_hsv_low is None


def _relaxed_run(run: tuple, first: TrackResult | None) -> TrackResult | None:
    """The clip tracked again with its float colour relaxed (`float_range`), with a warning first that says so, where
    that run tracked the preset's float (`_same_float`; `first`: the preset's run, None where it measured none); else
    None. Its overlay replaces the first run's only then."""
    path, settings, overlay, progress, multithreaded, until_s = run
    reader = FrameReader(Path(path), False, pictures=True)
    try:
        picture = np.asarray(reader.first_picture())
    finally:
        reader.close()
    name = settings.float_color or DEFAULT_FLOAT_COLOR
    relaxed = float_range(picture, roi_box(settings, picture.shape[1], picture.shape[0]), name)
    if relaxed is None:
        return None
    wider, changes, length = relaxed
    trial = None if overlay is None else temporary_sibling(Path(overlay), ".part.mp4")  # removed unless kept
    res: TrackResult | None = None
    try:
        try:
            res = _track_once(path, settings, trial, progress, multithreaded, until_s, wider)
        except NothingFound:
            res = None
        if res is not None and not _same_float(res, first, length):
            res = None
        if res is not None and trial is not None and trial.exists():
            os.replace(trial, Path(overlay))
    finally:
        if trial is not None and trial.exists():
            trial.unlink()
    if res is None:
        return None
    hsv, share = preset(name).hsv, 0.0 if first is None else float(np.mean(first.valid))
    res.warnings.insert(
        0,
        f"the {name} preset's range ({hsv.describe()}) measured the float in {100 * share:.0f} % of the frames and "
        f"found nothing of its colour in the first, so the clip was tracked again with it relaxed ({changes}: "
        f"{wider.describe()}), as a float's colour pales in the light and mixes with the liquid's under it; if what "
        f"was tracked is not the float, give `float_hsv_low` {','.join(map(str, hsv.low))} and `float_hsv_high` "
        f"{','.join(map(str, hsv.high))} (the preset's own range) or a range of your own.",
    )
    return res


def _same_float(res: TrackResult, first: TrackResult | None, length: float) -> bool:
    """The relaxed run `res` tracked the preset's float (`first`, its run; None where it measured none): it measures
    more frames validly, and, where the preset measured any, the median distance from each run's valid positions to
    the nearest of the other's is at most half the float's `length` (px): a few stray pixels of the preset's colour in a
    long clip lie about the float; a label of a near colour, tracked before the float came in, lies elsewhere."""
    if first is None:
        return True
    if int(np.sum(res.valid)) <= int(np.sum(first.valid)):
        return False
    if not first.valid.any():
        return True
    from scipy.spatial import cKDTree  # only here: a run's start does not wait for SciPy

    ours = np.column_stack([res.x_px, res.y_px])[res.valid.astype(bool)]
    theirs = np.column_stack([first.x_px, first.y_px])[first.valid.astype(bool)]
    apart = [float(np.median(cKDTree(b).query(a)[0])) for a, b in ((ours, theirs), (theirs, ours))]
    return max(apart) <= 0.5 * length


def _track_once(
    path: str | Path,
    settings: TrackSettings,
    overlay: str | Path | None,
    progress: bool,
    multithreaded: bool,
    until_s: float | None,
    colour: HsvRange | None = None,
) -> TrackResult:
    """`track_video`'s run with one colour (`colour`: the float's range to search instead of the settings'), its
    warnings in the result, not yet given."""
    with contextlib.ExitStack() as workers:
        # the smoother's imports load beside opening and decoding, on the other core, instead of after them; forked
        # before the reader opens, so no decoding thread exists at the fork
        smoother = smoothing_worker(fork=multithreaded) if settings.smooth and Path(path).is_file() else None
        if smoother is not None:
            workers.callback(smoother.close)
        reader = FrameReader(Path(path), multithreaded, pictures=True)
        check_rest_frames(settings.rest_frames, reader.info.frame_count)  # as declared; the frames read: at the end
        width, height = reader.frame_size
        roi = roi_box(settings, width, height)
        key_times = key_frame_times(path)
        spans = _spans(reader.info, key_times)
        if until_s is not None:
            spans = [(s, until_s if e is None else min(e, until_s)) for s, e in spans if s is None or s < until_s]
        log.info("tracking %s (%s target) in %d span(s)", path, settings.target, len(spans))
        reader.end_s = spans[0][1]
        dye, liquid, rival, larger = "", colour if settings.target == "float" else settings.liquid_hsv, None, False
        drawn_roi, widened = roi, None
        shrink = 1
        if settings.target == "surface":  # one dye colour and one size for every span: the first frame's
            shrink, roi, widened, (dye, liquid, rival, larger) = surface_size(reader.first_picture(), roi, settings)
            if shrink > 1:  # measured (and the overlay drawn) reduced; its pixels are reported in the video's
                reader.shrink = shrink
                height, width = shrunk_size((height, width), shrink)
        parallel = multithreaded and overlay is None and len(spans) > 1 and _can_fork()
        desc = "track" if colour is None else "track again, float colour relaxed"  # a second bar says why
        # a run that finds nothing writes its overlay as the diagnosis, but does not replace one already there
        kept = overlay if overlay is not None and Path(overlay).exists() else None
        with contextlib.ExitStack() as stack:
            writer = None
            if overlay is not None:
                tmp = stack.enter_context(atomic_path(overlay))
                writer = stack.enter_context(VideoWriter(tmp, width, height, reader.info.fps or 30.0, "h264", 20))
            jobs = [(Path(path), settings, roi, liquid, span, shrink) for span in spans]
            if parallel:
                reader.close()
                parts = _parallel_spans(jobs, reader.info.frame_count, reader.info.duration_s, progress, desc)
            else:
                bar = stack.enter_context(_progress_bar(reader.info.frame_count, progress, desc))
                parts = [_track_frames(reader, _step(settings, roi, liquid), bar.update, writer)]
                for job in jobs[1:]:
                    start, end = job[4]
                    span_reader = FrameReader(job[0], multithreaded, True, start, end, shrink)
                    parts.append(_track_frames(span_reader, _step(settings, roi, liquid), bar.update, writer))
            step = parts[0].step
            for part in parts[1:]:
                step.merge(part.step)
            rows = [row._replace(frame=index) for index, row in enumerate(row for part in parts for row in part.rows)]
            if len(rows) < 2:  # an image (PNG, JPEG) opens as a video of one frame
                raise UserError(
                    f"{path} holds a single picture, not a video: track measures the frames of a tap test or a move; "
                    f"`{shlex.join(['sloshid', 'inspect', str(path)])}` shows what each target would find in it."
                )
            found = any(r.valid for r in rows)
            if kept is not None and not found:  # raised here, the new overlay is not put in place
                hint = f"{kept} was kept; write the overlay to a new path ({{overlay}}) to see what was searched"
                raise step.nothing_found(len(rows), Path(path), hint)
        # raised after the overlay is finished: when nothing is found, the overlay is the user's diagnosis
        if not found:
            hint = (
                f"see the overlay {overlay}"
                if overlay
                else "look at a frame with `sloshid inspect` (it draws what each target finds and suggests a command), "
                "or write an overlay video ({overlay}) to see what was searched"
            )
            raise step.nothing_found(len(rows), Path(path), hint)
        if isinstance(step, SurfaceStep):
            step.scale = shrink
        body, walls, notes = step.finish(rows)
        flags = [flag for part in parts for flag in part.repeated]
        repeated = stale_repeats(np.array([r.angle_deg for r in body]), np.array([r.valid for r in body], bool), flags)
        body = [r._replace(valid=int(r.valid and not rep)) for r, rep in zip(body, repeated)]
        smooth = smoother.smooth if smoother is not None else None
        lost = lost_share(reader.info.frame_count, len(rows)) if until_s is None else 0.0
        res = _result(Path(path), body, lost, reader.info, smooth, repeated, settings.target)
    res.target, res.walls, res.repeated, res.dye = settings.target, walls, repeated, dye
    res.warnings.extend(notes)
    if widened is not None:  # the widened ROI in the video's pixels (a reduced picture's times its reduction)
        x, y, w, h = (shrink * v for v in roi)
        widened = f"{x},{y},{min(w, reader.info.width - x)},{min(h, reader.info.height - y)}"
        res.warnings.append(
            f"the first frame's surface was measured better with `roi` {','.join(map(str, drawn_roi))} widened to "
            f"{widened}, which was "
            "tracked: the container's walls lie at its edge; draw it a little wider."
        )
    if rival is not None:
        res.warnings.append(
            f"the dye's colour was chosen from the first frame as {dye.removesuffix(' (chosen from the first frame)')}, "
            + (
                f"the largest region of its colour measured there as a liquid between a container's walls; "
                f"{rival} covers a larger region, which was not measured as a liquid, or only as what this one stands on"
                if larger
                else f"the largest region of a preset colour; {rival} covers a region at least a quarter as large"
            )
            + f": if that is the liquid, give `liquid_color` {rival}."
        )
    res.key_frame = _at_key_frames(np.array([r.t_s for r in body], float), key_times)  # the file's own times
    return res


def _float_in(frame: np.ndarray, hsv: HsvRange, roi: tuple[int, int, int, int]) -> FloatMeasurement | None:
    """The float measured validly in `frame` by the range `hsv` (not cut by the ROI, and no liquid body), or None."""
    m = FloatFinder(hsv, roi).measure(frame)
    ok = m.found and not m.cut and m.quality >= VALID_QUALITY and not _liquid_width(frame, hsv, roi)
    return m if ok else None


def float_range(frame: np.ndarray, roi: tuple[int, int, int, int], name: str) -> tuple[HsvRange, str, float] | None:
    """The nearest relaxation of the float colour `name`'s preset (`relaxed_ranges`: a float's colour pales in the light
    and mixes with the liquid's under it) that measures the float validly in `frame` (a video's first frame), where the
    preset finds no blob of its colour there (an orange float in a yellow dye that the orange range holds too is not
    relaxed): (its range, what was relaxed, the float's length there in px); None where none does."""
    hsv = preset(name).hsv
    relaxations = relaxed_ranges(hsv)
    if not relaxations or FloatFinder(hsv, roi).measure(frame).found:
        return None
    if not FloatFinder(relaxations[-1][2], roi).measure(frame).found:  # the widest finds nothing: none will
        return None
    for dh, ds, wider in relaxations:
        m = _float_in(frame, wider, roi)
        if m is not None:
            changes = [f"its hues widened by {dh}" if dh else "", f"its saturation floor lowered by {ds}" if ds else ""]
            return wider, " and ".join(c for c in changes if c), m.length_px
    return None


def _liquid_width(frame: np.ndarray, hsv: HsvRange, roi: tuple[int, int, int, int]) -> float:
    """Width (px) of a liquid body of the float's colour with the container's walls, a bottom and a surface, as the
    surface tracker finds it in `frame`, or 0.0: a float has no straight side walls and is never found so (checked on
    rendered floats of every look and size), while a dyed liquid's body is, however ragged its surface (a float
    breaking the surface of a tinted liquid that the range also covers left the fit 2.7 px off a line)."""
    m = SurfaceFinder(hsv, roi).measure(frame)
    return m.width_px if m.found else 0.0


def _at_key_frames(t_s: np.ndarray, key_times: np.ndarray) -> np.ndarray:
    """1 where a frame's time is one of the (sorted) key frames' times, else 0; np.isin would import numpy.ma (tens of
    milliseconds at the end of every run)."""
    if key_times.size == 0:
        return np.zeros(t_s.size, int)
    at = np.minimum(np.searchsorted(key_times, t_s), key_times.size - 1)
    return (key_times[at] == t_s).astype(int)


STILL_SPAN_DEG = 0.2
"""A tracked angle that spans less than this (1st to 99th percentile of the valid frames) draws a warning that nothing
moved: a float on still liquid spanned 0.08 deg, a static label of the float's colour tracked as the float 0.02 deg,
a tapped float 12.6 deg."""

LOST_NOTE = 0.005
"""A video that decodes fewer frames than it declares by more than this share is called truncated: a warning, and
exit code 1 from `track` and `batch` (what decoded is still tracked and written)."""

SPAN_S = 10.0
"""A video is tracked in spans that start at key frames at least this far apart (none within this of the end).
Decoding a span needs nothing from before its key frame, and the trackers' state (where the float or the liquid
is, its colour model, the camera's elevation) settles within a fraction of a second, so spans can run side by side;
every mode tracks the same spans, so the table does not depend on how many ran at once."""


@dataclass
class _Span:
    """One span's table rows (time first, no frame index), repeat flags, and its tracker step (what it found)."""

    rows: list[TrackRow]
    repeated: list[bool]
    step: _Step


class _Step(Protocol):
    """What a span's step (`_FloatStep`, `SurfaceStep`) tells `track_video` once its frames are measured."""

    def merge(self, later: Self) -> None: ...

    def nothing_found(self, n: int, path: Path, hint: str) -> NothingFound: ...

    def finish(self, rows: list[TrackRow]) -> tuple[list[TrackRow], dict[str, np.ndarray], list[str]]: ...


def _spans(info: VideoInfo, key_times: np.ndarray) -> list[tuple[float | None, float | None]]:
    """(start, end) presentation times of the spans (None: the video's start or end), from its key frames."""
    if not info.timed or not info.fps:
        return [(None, None)]
    end = info.duration_s
    starts: list[float] = []
    for k in key_times:
        if k - (starts[-1] if starts else 0.0) >= SPAN_S and end - k >= SPAN_S:
            starts.append(float(k))
    bounds = [None, *starts, None]
    return list(itertools.pairwise(bounds))


MeasureStep: TypeAlias = "_FloatStep | SurfaceStep"
"""A per-frame measurement step of the float or the surface target (`measure_frame`)."""


def _auto_dye(first: Picture | np.ndarray, roi: tuple[int, int, int, int], settings: TrackSettings):
    """The dye's colour from the first frame: the preset whose colour covers the largest region when a surface is
    measured in it there (of any quality; `dark` only validly, and not under a coloured liquid measured validly that
    stands on it: shadows and black objects, an underexposed picture's, a holder's, outgrew a blue dye); else another
    preset measured validly as the liquid between a container's walls, with its hues fitted to the dye as track then
    fits them (`dye_range`: a dye between two presets' hues lies in neither), the one with the largest region; else the
    largest coloured region's own range (`own_range`: a faint dye below every preset's saturation, a dusky red juice
    whose liquid the red preset holds in patches) when it is measured so; else a region darker than the rest in a
    picture with no coloured one large enough (`darker_liquid`: a near-black liquid greyed by the light) when it is
    measured so; else, where no preset's colour has a region at all, the largest coloured region's own range measured
    or not (a first frame the tracker reads poorly, as a surface's glow may make it, says nothing of the rest);
    else the largest preset. Returns (its name or None, its HSV range or None, a rival to name or None,
    whether the rival's region is the larger)."""
    x, y, w, h = roi  # the ROI's pixels only (a Picture converts just them), as auto_liquid_preset reads them
    crop = first[y : y + h, x : x + w]
    name, rival = auto_liquid_preset(crop, (0, 0, w, h))
    frame = np.asarray(first)  # measured as a picture is drawn: converted whole
    if (
        name not in ("dark", None)
        and measure_frame(frame, 0.0, settings, roi, dye_range(frame, roi, preset(name).hsv))[0].quality > 0
    ):
        return name, preset(name).hsv, rival, False
    # a cola in its glass measures validly as `dark`, and a coloured box behind it may measure too: dark is kept
    # unless the coloured liquid stands on its surface (a holder and the shadows under the liquid measured as one)
    dark = measure_frame(frame, 0.0, settings, roi, preset("dark").hsv)[0] if name == "dark" else None
    for other, _, _ in preset_regions(crop, (0, 0, w, h)):
        if other not in ("dark", name):
            row, _, step = measure_frame(frame, 0.0, settings, roi, dye_range(frame, roi, preset(other).hsv))
            body = step.finder.box if isinstance(step, SurfaceStep) else None
            if row.valid and (dark is None or not dark.valid or _stands_on(body, dark)):
                return other, preset(other).hsv, name, name is not None
    if dark is not None and dark.valid:
        return "dark", preset("dark").hsv, rival, False
    hsv, labels, stats, order = coloured_regions(frame, roi)
    own = None
    if order and stats[order[0], cv2.CC_STAT_AREA] > MIN_LIQUID_SHARE * w * h:
        own = own_range(hsv[labels == order[0]])
        if measure_frame(frame, 0.0, settings, roi, own)[0].valid:
            return f"{own.describe()}, no preset's", own, name, name is not None
    darker = darker_liquid(hsv, stats, order)
    if darker is not None and measure_frame(frame, 0.0, settings, roi, darker[1])[0].valid:
        return f"{darker[1].describe()}, darker than the rest", darker[1], name, name is not None
    if name is None and own is not None:  # no preset's region at all: the largest coloured one, measured or not here
        return f"{own.describe()}, no preset's", own, None, False
    return name, preset(name).hsv if name else None, rival, False


def _stands_on(body: tuple[int, int, int, int] | None, surface: TrackRow) -> bool:
    """A liquid's body (x0, y0, x1, y1) stands on the surface measured at `surface`'s centre: the centre lies within
    its columns, below its top and at most a tenth of its width below its bottom. A surface has air above it, so that
    surface is what holds the liquid (a holder, the shadows under it: the real frame's turned magenta measured as
    `dark` at its holder's top, under the liquid's body)."""
    if body is None:
        return False
    x0, y0, x1, y1 = body
    return x0 <= surface.x_px <= x1 and y0 < surface.y_px <= y1 + 0.1 * (x1 - x0)


ROI_REACH = 0.1
"""A surface ROI in whose first frame the surface is not measured, or not validly, is tried again this share of its
width (and of its height) wider on each side (at least ROI_REACH_PX), and the wider one is kept when it measures the
surface there, or validly: drawn tightly around a container, an ROI cuts the glass's walls or the edges beside them,
which the tracker reads (30 glasses on a table with the ROI on their outline: 27 tracked before, 29 now; with it 3 %
of their width inside it: 22 before, 29 now, as many as with no ROI)."""
ROI_REACH_PX = 8


def surface_roi(
    first: Picture | np.ndarray, roi: tuple[int, int, int, int], settings: TrackSettings
) -> tuple[tuple[int, int, int, int], str | None, tuple]:
    """The ROI the surface is tracked in: the user's (`settings.roi`), or it widened by ROI_REACH when the first frame's
    surface is measured better in the wider one (`_first_level`); the widened ROI as text for the warning (else None);
    and the dye chosen in the ROI kept (`_surface_dye`). `sloshid inspect` widens an ROI as well."""
    drawn = _surface_dye(first, roi, settings)
    if settings.roi is None:
        return roi, None, drawn
    height, width = first.shape[:2]
    x, y, w, h = roi
    dx, dy = max(ROI_REACH_PX, round(ROI_REACH * w)), max(ROI_REACH_PX, round(ROI_REACH * h))
    x0, y0 = max(0, x - dx), max(0, y - dy)
    wide = (x0, y0, min(width, x + w + dx) - x0, min(height, y + h + dy) - y0)
    if wide == roi:
        return roi, None, drawn
    level = _first_level(first, roi, settings, drawn[1])
    if level == 2:
        return roi, None, drawn
    wider = _surface_dye(first, wide, settings)
    if _first_level(first, wide, settings, wider[1]) <= level:
        return roi, None, drawn
    return wide, ",".join(map(str, wide)), wider


def surface_size(first: Picture | np.ndarray, roi: tuple[int, int, int, int], settings: TrackSettings) -> tuple:
    """(shrink, ROI, widened ROI's text or None, dye) for the surface: `surface_roi`'s in the first frame, or, when its
    surface is not measured validly there and is measured better in the picture reduced `reduction` times, in that
    (shrink > 1; the ROI then in the reduced picture's pixels)."""
    whole = surface_roi(first, roi, settings)
    factor = reduction(whole[0])
    level = 2 if factor == 1 else _first_level(first, whole[0], settings, whole[2][1])
    if level == 2:
        return 1, *whole
    small = shrunk(first, factor)
    reduced = surface_roi(small, shrunk_roi(roi, factor, (first.shape[1], first.shape[0])), settings)
    if _first_level(small, reduced[0], settings, reduced[2][1]) <= level:
        return 1, *whole
    return factor, *reduced


def _surface_dye(first: Picture | np.ndarray, roi: tuple[int, int, int, int], settings: TrackSettings) -> tuple:
    """The dye the surface is tracked by in `roi`: (its description for the summary, its HSV range fitted to the first
    frame or None, a rival colour to name or None, whether the rival's region is the larger), chosen in the first frame
    (`_auto_dye`) unless one is given."""
    if settings.liquid_hsv is None:
        name, liquid, rival, larger = _auto_dye(first, roi, settings)
        dye = f"{name} (chosen from the first frame)" if name else ""
    else:
        liquid, rival, larger = settings.liquid_hsv, None, False
        dye = settings.liquid_color or liquid.describe()
    return dye, None if liquid is None else _dye_range(first, roi, settings, liquid), rival, larger


def _first_level(
    first: Picture | np.ndarray, roi: tuple[int, int, int, int], settings: TrackSettings, liquid: HsvRange | None
) -> int:
    """How well the first frame's surface is measured inside `roi` by the dye `liquid` (`_surface_dye`'s): 0 not at
    all, 1 under the valid quality (as a first frame may be until the camera's elevation is held), 2 validly."""
    if liquid is None:
        return 0
    row = measure_frame(np.asarray(first), 0.0, settings, roi, liquid)[0]
    return 2 if row.valid else int(row.quality > 0)


def _dye_range(frame: Picture | np.ndarray, roi: tuple, settings: TrackSettings, liquid: HsvRange) -> HsvRange:
    """A preset's range (named, or chosen from the first frame) fitted to the dye in `frame` (`dye_range`); a range
    the user gave as HSV, as given."""
    return liquid if settings.liquid_hsv_low is not None else dye_range(np.asarray(frame), roi, liquid)


def _step(settings: TrackSettings, roi: tuple[int, int, int, int], colour: HsvRange | None):
    """A fresh per-frame measurement step of the target, searching `colour` (the float's or the liquid's; None: the
    settings' float colour, or the liquid's chosen in the first frame)."""
    return _FloatStep(settings, roi, colour) if settings.target == "float" else SurfaceStep(settings, roi, colour)


def measure_frame(
    frame: np.ndarray, t_s: float, settings: TrackSettings, roi: tuple[int, int, int, int], liquid: HsvRange | None
) -> tuple[TrackRow, np.ndarray, MeasureStep]:
    """One frame measured as `track_video` measures the first frame of a span and draws it in ``overlay`` (the target's
    step, then, for a valid frame, its finish): the table row (frame, t_s, angle_deg, ..., valid), the overlay picture,
    and the step, which holds what it found (`walls_record`, `liquid_frames`, ...). `sloshid inspect` calls it, so that
    its picture shows what track would do."""
    if settings.target == "surface" and liquid is None and settings.liquid_hsv is not None:
        liquid = _dye_range(frame, roi, settings, settings.liquid_hsv)
    settings = replace(settings, rest_frames=None)  # one frame has no rest window to check
    step = _step(settings, roi, liquid)
    row, drawn = step(frame, True)
    row = row._replace(t_s=t_s)
    step.previous = None
    if row.valid:  # finish corrects a valid surface for the camera's elevation; it needs a valid frame
        return step.finish([row])[0][0], drawn, step
    return row._replace(surface=None), drawn, step


def _track_frames(reader: FrameReader, step, tick: Callable[[int], object], writer: VideoWriter | None = None) -> _Span:
    """Measure every frame the reader yields with `step` (drawing the overlay into `writer`); tick(1) per frame."""
    rows: list[TrackRow] = []
    for _, t, frame in reader:
        if writer is not None and isinstance(frame, Picture):  # the overlay is drawn on the whole picture
            frame.convert_all()
        row, drawn = step(frame, writer is not None)
        rows.append(row._replace(t_s=t))
        if writer is not None:
            writer.write(drawn, t)
        tick(1)
    step.previous = None  # the last picture: not needed any more, and it holds the decoder's buffers
    step.revise(rows)
    return _Span(rows, step.repeated, step)


def _progress_bar(total: int, progress: bool, desc: str = "track") -> tqdm:
    """The frames' progress bar (shown only when asked and stderr is a terminal), named `desc`."""
    return tqdm(total=total or None, desc=desc, unit="frame", disable=None if progress else True, leave=False)


def _can_fork() -> bool:
    """Spans can run in forked processes: on Linux, and not from a daemonic process (which may have no children)."""
    return sys.platform.startswith("linux") and not multiprocessing.current_process().daemon


_done: Synchronized[int] | None = None
"""In a span worker: the shared count of frames tracked, which the parent's progress bar shows."""


def _parallel_spans(jobs: list[tuple], total: int, duration: float, progress: bool, desc: str) -> list[_Span]:
    """Track the spans in forked processes, one per core, in order; the progress bar (`desc`) counts their frames."""
    ctx = multiprocessing.get_context("fork")
    done = ctx.Value("q", 0)
    # the longest spans first (the last one runs on to the end): no core waits long for another's last span
    order = sorted(range(len(jobs)), key=lambda k: -_length(jobs[k][4], duration))
    with contextlib.ExitStack() as stack:
        # a stop while the pool starts would raise before anything could stop the pool, whose workers (started again
        # by its own thread) then outlive the command: it is raised once the pool is up, here, where it is stopped
        with signals_held():
            pool = stack.enter_context(
                ctx.Pool(min(len(jobs), os.cpu_count() or 1), _start_worker, (done, os.getpid()))
            )
        pending = pool.map_async(_span_job, [jobs[k] for k in order], chunksize=1)
        with _progress_bar(total, progress, desc) as bar:  # after the fork: its monitor thread stays here
            while not pending.ready():
                pending.wait(0.1)
                bar.update(done.value - bar.n)
            bar.update(done.value - bar.n)
        parts = pending.get()
    return [parts[order.index(k)] for k in range(len(jobs))]


def _length(span: tuple[float | None, float | None], duration: float) -> float:
    """Seconds of video in a span."""
    start, end = span
    return (duration if end is None else end) - (start or 0.0)


def _start_worker(done: Synchronized[int], parent_pid: int) -> None:
    """A span worker: SIGTERM (the pool's terminate) ends it at once, and so does the end of the parent (or of the
    pool's thread that started it); Ctrl-C is the parent's to handle."""
    global _done
    _done = done
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    forked_helper(parent_pid)


def _span_job(job: tuple) -> _Span:
    """Track one span in a worker (decoding in this process's one thread)."""
    path, settings, roi, liquid, (start, end), shrink = job
    if _done is None:
        raise RuntimeError("a span job runs in a worker process started by `_start_worker`")
    done = _done
    counted = [0]

    def tick(n: int) -> None:
        counted[0] += n
        if counted[0] >= 30:  # the shared counter's lock costs more than a frame's bookkeeping
            with done.get_lock():
                done.value += counted[0]
            counted[0] = 0

    part = _track_frames(FrameReader(path, False, True, start, end, shrink), _step(settings, roi, liquid), tick)
    tick(30)
    return part


def _increasing_times(t: np.ndarray, fps: float) -> tuple[np.ndarray, int]:
    """The frames' times, and how many did not increase: when any did not (a file's repeated or reordered
    timestamps), every frame is timed by its number at the declared rate, since a smoother and an identification
    need increasing times and a timestamp that repeats says nothing of when the frame was taken."""
    bad = int(np.sum(np.diff(t) <= 0))
    if not bad:
        return t, 0
    return t[0] + np.arange(t.size) / (fps or 30.0), bad


def _result(
    video: Path,
    rows: list[TrackRow],
    lost_share: float,
    info: VideoInfo,
    smooth: Callable[..., np.ndarray] | None,
    repeated: np.ndarray,
    target: str,
) -> TrackResult:
    """Assemble the TrackResult, smooth the angle (with `smooth`, a SmoothingWorker's; None: not) and collect
    warnings."""
    frame, t, angle, fang, cang, x, y, q, valid = (np.asarray(c) for c in list(zip(*rows))[:9])
    frame, valid = frame.astype(int), valid.astype(int)
    declared = info.frame_count
    t, retimed = _increasing_times(t.astype(float), info.fps)
    # the smoother may lean on repeated pictures: they are late by a frame or two, not wrong, and without them
    # it would bridge whole stretches (a float at rest until a tap) along an oscillator of coarse frequency
    measured = valid.astype(bool) | repeated
    smoothed = smooth(t, angle, measured, q) if smooth is not None else np.full(len(t), np.nan)
    res = TrackResult(
        video=video,
        frame=frame,
        t_s=t.astype(float),
        angle_deg=angle.astype(float),
        float_angle_deg=fang.astype(float),
        container_angle_deg=cang.astype(float),
        x_px=x.astype(float),
        y_px=y.astype(float),
        quality=q.astype(float),
        valid=valid,
        angle_smoothed_deg=smoothed,
        lost_share=lost_share,
    )
    if retimed:
        res.warnings.append(
            f"{retimed} of {len(t)} frames of {video} have a timestamp that does not increase (repeated or out of "
            f"order); every frame is timed by its number at the declared {info.fps:.3f} fps instead: check that rate, "
            "or re-mux the file with fresh timestamps (ffmpeg -fflags +genpts)."
        )
    if lost_share > LOST_NOTE:
        res.warnings.append(
            f"{video} looks truncated: only {len(rows)} of {declared} frames decoded "
            f"({100 * lost_share:.1f} % lost); tracked what decoded."
        )
    if valid.sum() >= 10:
        span = percentile_span(angle[valid.astype(bool)].astype(float))
        res.still = span < STILL_SPAN_DEG
        if res.still:
            other = "something of the float's colour that is not the float" if target == "float" else "not its surface"
            res.warnings.append(
                f"the {target}'s angle spans only {span:.3f} deg over the valid frames (1st to 99th percentile): "
                f"nothing moved it. A liquid at rest, or what was measured is {other}: check with `overlay`, or "
                "narrow `roi`."
            )
    lost, repeats = int(np.sum((valid == 0) & ~repeated)), int(repeated.sum())
    if lost > 0:
        res.warnings.append(
            f"{target} not measured in {lost} of {len(valid)} frames "
            f"({100 * lost / len(valid):.1f} %); those rows have valid = 0 and are bridged "
            "in angle_smoothed_deg."
        )
    if repeats > 0:
        res.warnings.append(
            f"the encoder repeated the moving {target}'s previous picture in {repeats} of {len(valid)} "
            f"frames ({100 * repeats / len(valid):.1f} %; unchanged copies, common at low bit rates and high frame "
            "rates): those rows have valid = 0, so old pictures do not pass for new measurements."
        )
    return res
