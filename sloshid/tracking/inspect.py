"""A first look at a user's own video (`sloshid inspect`): one frame (or a still picture), what each target would track
there, a suggested region of interest and the `sloshid track` command to run next.

Every preset colour is looked for in the frame. Each one found is measured by the tracker's own per-frame step
(`tracker.measure_frame`, the code `track` runs on every frame), as the dyed liquid's surface and as a float, so that
the picture shows what track would do: the liquid region of every matching preset, the liquid's sides (the container's
inner walls) and the surface line, the float candidates (size, elongation, angle) and the float track would take.
Of several colours measured as a surface, the one between the container's walls is taken. When no preset colour gives
a liquid or a float, it says what it saw (how saturated the picture is, its largest coloured regions) and measures the
largest with an HSV range of its own.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, TypeAlias, cast

import cv2
import numpy as np

from sloshid.core.atomic import atomic_path
from sloshid.core.errors import UserError
from sloshid.core.outputs import Outputs
from sloshid.tracking.float_angle import MIN_AREA_PX, hsv_mask, principal_axis
from sloshid.tracking.rows import TrackRow
from sloshid.tracking.surface import (
    MIN_LIQUID_SHARE,
    SATURATED,
    coloured_regions,
    darker_liquid,
    dye_range,
    own_range,
)
from sloshid.tracking.surface_track import SurfaceStep
from sloshid.tracking.tracker import (
    MeasureStep,
    TrackResult,
    TrackSettings,
    float_range,
    measure_frame,
    reduction,
    roi_box,
    shrunk_roi,
    surface_roi,
    track_video,
)
from sloshid.video.colors import PRESETS, HsvRange, format_hsv, preset
from sloshid.video.frames import FrameReader, shrunk

LISTED_SHARE = 1e-4
"""A preset colour is listed as found when its largest region covers at least this share of the searched area (and
MIN_AREA_PX): single noisy pixels of a colour are not a finding."""
MAX_CANDIDATES = 5
"""Float candidates listed per preset colour (the largest)."""
WIDER = 0.05
"""The liquid region is taken to meet something of its own colour (a holder, a table) from the first of three rows, below
its first full row, that reach beyond a side of the liquid by more than this share of its width (plus 3 px)."""
AT_BEFORE_S = 1.0
"""--at: decoding starts at the key frame before this many seconds ahead of the time asked for, so that the frame on
screen then (the last one not after it) is among those read."""
AT_TOLERANCE_S = 5e-4
"""--at: a frame this close after the time asked for is the one meant (a time typed to the millisecond)."""
_HUES = ((8, "red"), (22, "orange"), (35, "yellow"), (85, "green"), (100, "cyan"), (125, "blue"), (170, "magenta"))
"""Upper hue bounds (OpenCV, 0..179) of the colour names used to say what was seen; above the last: red again."""


TRIAL_S = 2.0
"""A video looked at from its first frame: the suggested command is tried on its first this many seconds, beside
track with no colour or ROI of inspect's (its own choices): one frame may show the liquid as no other does (a glow of
the light lifting a faint dye's surface read no colour range in a robot move's first frame, and inspect's colour held
the dye in patches: 12 of 60 frames valid, track's own 40)."""
TRIAL_MARGIN = 0.1
"""... and where the suggestion measures under half the tried frames validly, track's own choices are suggested
instead when they measure at least this share of them more (an ROI around where a robot's container stood in the
first frame lost it once carried away: 10 of 60 frames valid, track's own 57)."""
OWN_CHOICES = ("liquid_color", "liquid_hsv_low", "liquid_hsv_high", "roi")
"""The suggested settings track chooses itself when they are not given (the surface's colour and, for either target,
where to look); the float's colour is always given (`float_color` defaults to red)."""


@dataclass(frozen=True)
class Trial:
    """The suggestion tried on the video's first `seconds` (`TRIAL_S`)."""

    seconds: float
    """The time tried: TRIAL_S, or the whole of a shorter video."""
    frames: int
    valid: int
    """Frames the suggested command measured validly."""
    own: int | None = None
    """Frames track measured validly with its own choices (`OWN_CHOICES`) instead; None: the suggestion is those."""
    own_taken: bool = False
    """The suggestion was replaced by track's own choices (`TRIAL_MARGIN`)."""


Labels: TypeAlias = dict[str, tuple[np.ndarray, list[int]]]
"""Each colour's region labels in the ROI (OpenCV's label image) and the labels of its regions kept, largest first."""
Drawn: TypeAlias = dict[tuple[str, str], np.ndarray]
"""The tracker's overlay of the frame for each (target, colour) measured."""


@dataclass
class ColourMatch:
    """Where one colour is in the frame: a preset's, or (when no preset's is there) the range made for the largest
    coloured region."""

    name: str
    """The preset's name, or the colour's name and HSV range."""
    hsv: HsvRange
    share: float
    """Share of the searched area (the ROI, or the whole picture) in the HSV range."""
    regions: list[tuple[int, int, int, int, int]]
    """Its connected regions (x, y, width, height, area in px), largest first, each at least MIN_AREA_PX."""

    @property
    def preset(self) -> bool:
        """A named preset (`liquid_color` NAME), not an HSV range of inspect's making."""
        return self.name in PRESETS

    def settings(self, kind: str) -> dict:
        """The TrackSettings fields that name this colour for `kind` 'liquid' or 'float'."""
        if self.preset:
            return {f"{kind}_color": self.name}
        return {f"{kind}_hsv_low": self.hsv.low, f"{kind}_hsv_high": self.hsv.high}

    def outline(self) -> tuple[int, int, int]:
        """A BGR colour that stands out on this one (its complement), for drawing its regions."""
        if self.preset:
            bgr = PRESETS[self.name].bgr
        else:
            lo, hi = self.hsv.low[0], self.hsv.high[0]
            hue = ((lo + hi + (180 if lo > hi else 0)) // 2) % 180
            bgr = cv2.cvtColor(np.array([[[hue, 220, 220]]], np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
        b, g, r = bgr
        return 255 - int(b), 255 - int(g), 255 - int(r)


@dataclass
class SurfaceLook:
    """One preset colour measured as the dyed liquid by the surface target."""

    dye: str
    liquid: bool
    """Liquid of this colour was found (a region large enough)."""
    measured: bool
    """The surface was measured there (valid, as track would mark the frame)."""
    angle_deg: float = math.nan
    """The surface against the image horizontal, CCW positive as seen."""
    container_angle_deg: float = math.nan
    """The container's tilt from vertical: its whole wall edges when found, else the liquid's sides."""
    walls: bool = False
    """The container's wall edges were found (what --reference container measures against)."""
    quality: float = 0.0
    roi: tuple[int, int, int, int] | None = None
    """The ROI this measurement was made in (None: the whole picture)."""


@dataclass
class FloatCandidate:
    """A region of a preset colour that could be a float (binary moments of its mask)."""

    color: str
    box: tuple[int, int, int, int]
    """x, y, width, height in px."""
    area_px: int
    elongation: float
    """1 - minor/major variance: 0 for a disc or a square, near 1 for a thin bar (track wants at least 0.5)."""
    angle_deg: float
    """Long axis against the image horizontal, CCW positive as seen."""


@dataclass
class FloatLook:
    """One preset colour measured as the float by the float target (it takes the largest region)."""

    color: str
    found: bool
    measured: bool = False
    angle_deg: float = math.nan
    quality: float = 0.0
    walls: bool = False
    """The container's side walls were found beside it (what --reference container measures against)."""
    container_angle_deg: float = math.nan
    """Their tilt from vertical, CCW positive as seen (NaN when they were not found)."""
    liquid_like: bool = False
    """What the float target would take is a liquid body between straight walls: dyed liquid, not a float."""
    relaxed: str = ""
    """What of the named preset's range was relaxed to find it, as track relaxes it (`float_range`); empty: none."""


@dataclass(kw_only=True)
class InspectResult:
    """What `sloshid inspect` found in one frame and the tracking settings it suggests."""

    video: Path
    t_s: float
    size: tuple[int, int]
    """(width, height) of the frame, px."""
    still: bool = False
    """`video` is a still picture (PNG, JPEG): the commands are for the video it is a frame of (VIDEO)."""
    roi: tuple[int, int, int, int]
    """The area searched (x, y, width, height): the given ROI or the whole picture."""
    colours: list[ColourMatch]
    """The colours found, each largest share first: the presets, then the range made for a colour no preset takes."""
    surfaces: list[SurfaceLook]
    floats: list[FloatLook]
    candidates: list[FloatCandidate]
    suggested_roi: tuple[int, int, int, int] | None
    """Around the container (the liquid found) or the float: where track should look; drawn on the picture."""
    target: str | None
    """'surface' or 'float': what the suggested command tracks (None: nothing found)."""
    liquid: SurfaceLook | None = None
    """The liquid the text and the picture's left panel show: the measured surface (one whose container's walls were
    found first), else the largest liquid region found (its measurement in the suggested ROI when that one was)."""
    float_look: FloatLook | None = None
    """The float the right panel shows: the named colour's (`float_color`), else the best measured, not liquid, not of
    the measured liquid's colour."""
    float_color: str | None = None
    """The float's colour preset as the user named it: looked at as track looks for it, and tracked when found."""
    float_miss: str = ""
    """Why the named colour, relaxed, gave no float (empty: it was not relaxed, or gave one)."""
    track_settings: dict[str, Any] = field(default_factory=dict)
    """The keywords of `sloshid.track` (TrackSettings fields) that track this video, empty when nothing was found."""
    alternative: dict[str, Any] = field(default_factory=dict)
    """The keywords that track a float measured on the dyed liquid instead (empty: none)."""
    notes: list[str] = field(default_factory=list)
    """Sentences on what was found, in the order `summary` prints them."""
    seen: str = ""
    """When no preset colour gave a liquid or a float: what the frame shows (how coloured, its largest coloured
    regions) and the HSV range made for the largest."""
    saw: str = ""
    """What was seen, as a clause for the one-sentence error when nothing was found."""
    picture: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3), np.uint8), repr=False)
    """The annotated picture (BGR): surface target on the left, float target on the right."""
    trial: Trial | None = None
    """The suggested command tried on the video's first seconds (None: a still picture, a frame after the first, or
    nothing to suggest)."""

    @property
    def measured(self) -> bool:
        """The suggested command's target was measured in this frame (track would mark it valid)."""
        look = self.liquid if self.target == "surface" else self.float_look if self.target == "float" else None
        return look is not None and look.measured

    @property
    def works(self) -> bool:
        """The suggested command measured at least half the frames it was tried on (`trial`), or, not tried, this
        frame (`measured`): what the command line's exit code says."""
        tried = self.trial
        if tried is None:
            return self.measured
        return 2 * (tried.own if tried.own_taken and tried.own is not None else tried.valid) >= tried.frames > 0

    def suggestion(self, settings: dict[str, Any]) -> str:
        """Tracking settings as the Python call that uses them (the default way `summary` shows them)."""
        keywords = "".join(f", {k}={v!r}" for k, v in settings.items())
        return f"sloshid.track({'VIDEO' if self.still else repr(str(self.video))}{keywords})"

    def summary(self, suggest: Callable[[dict[str, Any]], str] | None = None) -> str:
        """What was found per target and what to run next; `suggest` shows a settings dict as its front-end does (the
        command line gives a `sloshid track` command; default: the Python call)."""
        suggest = suggest or self.suggestion
        w, h = self.size
        lines = [
            f"{self.video}: {'a still picture' if self.still else f'frame at {self.t_s:.3f} s'}, {w}x{h} px",
            *([self.seen] if self.seen else []),
            *self.notes,
        ]
        if self.alternative:
            color = self.alternative.get("float_color", "a")
            lines.append(f"a {color} float is measured too; to track it instead: {suggest(self.alternative)}")
        if self.track_settings:
            lines.append("next: " + suggest(self.track_settings))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-safe form (the picture is `save_picture`)."""

        def num(v: float) -> float | None:
            return float(v) if math.isfinite(v) else None

        return {
            "video": str(self.video),
            "still": self.still,
            "t_s": self.t_s,
            "size_px": list(self.size),
            "roi": list(self.roi),
            "colours": [
                {
                    "name": p.name,
                    "hsv_low": list(p.hsv.low),
                    "hsv_high": list(p.hsv.high),
                    "share": p.share,
                    "regions": [list(r) for r in p.regions],
                }
                for p in self.colours
            ],
            "surfaces": [
                {**s.__dict__, "angle_deg": num(s.angle_deg), "container_angle_deg": num(s.container_angle_deg)}
                for s in self.surfaces
            ],
            "floats": [
                {**f.__dict__, "angle_deg": num(f.angle_deg), "container_angle_deg": num(f.container_angle_deg)}
                for f in self.floats
            ],
            "float_candidates": [c.__dict__ for c in self.candidates],
            "suggested_roi": list(self.suggested_roi) if self.suggested_roi else None,
            "target": self.target,
            "liquid": self.liquid.dye if self.liquid else None,
            "float": self.float_look.color if self.float_look else None,
            "float_color": self.float_color,
            "track_settings": {k: list(v) if isinstance(v, tuple) else v for k, v in self.track_settings.items()},
            "notes": list(self.notes),
            "seen": self.seen or None,
            "trial": None if self.trial is None else asdict(self.trial),
        }

    def save_picture(self, path: str | Path) -> Path:
        """Write the annotated picture as PNG, atomically (never over the inspected video)."""
        out = Outputs([self.video]).file(path, "the picture", (".png",))
        with atomic_path(out) as tmp:
            if not cv2.imwrite(str(tmp), self.picture, [cv2.IMWRITE_PNG_COMPRESSION, 6]):
                raise UserError(f"could not write the picture {out}.")
        return out

    def plot(self, ax=None):
        """The annotated picture in a matplotlib axes; returns the figure."""
        import matplotlib.pyplot as plt

        if ax is None:
            h, w = self.picture.shape[:2]
            _, ax = plt.subplots(figsize=(10, 10 * h / max(w, 1)))
        ax.imshow(self.picture[:, :, ::-1])
        ax.set_axis_off()
        ax.set_title(f"sloshid inspect: {self.video.name} at {self.t_s:.3f} s", fontsize=9)
        return ax.figure

    def report(self, directory: str | Path) -> Path:
        """Write a one-page HTML report (the text and the picture) to directory/index.html."""
        from sloshid.report.html import Report

        page = Report(f"sloshid inspect: {self.video.name}")
        for line in self.summary().splitlines():
            page.add_text(line)
        page.add_figure(self.plot(), "Left: the surface target; right: the float target; white: the suggested ROI.")
        return page.save(directory)


def read_frame(path: str | Path, at: float | None) -> tuple[np.ndarray, float, bool]:
    """The BGR frame on screen at `at` seconds (the last whose presentation time is not after it; None: the first),
    its time and whether `path` is a still picture (PNG, JPEG: read by OpenCV, at 0 s); a negative time, one after
    the last frame's time on screen and a video of one frame are refused."""
    if at is not None and not (math.isfinite(at) and at >= 0):
        what = "a time of 0 s or more into the video" if math.isfinite(at) else "a finite number of seconds"
        raise UserError(f"`at` must be {what}, got {at:g}.")
    path = Path(path)
    frames = iter(FrameReader(path, False))
    try:
        first, second = next(frames), next(frames, None)
    finally:
        frames.close()
    if second is None:  # a picture opens as a video of one frame: OpenCV reads it as a viewer shows it (EXIF turn)
        picture = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if picture is None:
            raise UserError(f"{path} holds a single frame: inspect looks at a picture (PNG, JPEG) or a video.")
        if at:
            raise UserError(f"{path} is a still picture, its one frame at 0 s: leave out `at` (got {at:g} s).")
        return picture, 0.0, True
    if not at:
        return cast(np.ndarray, first[2]), float(first[1]), False  # a BGR array: the reader makes no `Picture`s
    reader = FrameReader(Path(path), False, start_s=max(0.0, at - AT_BEFORE_S))
    frames, shown, after = iter(reader), None, False
    try:
        for _, t, frame in frames:
            if t > at + AT_TOLERANCE_S:
                after = True
                break
            shown = (cast(np.ndarray, frame), float(t))  # a BGR array: the reader makes no `Picture`s
    finally:
        frames.close()
    if shown is None:  # every frame lies more than AT_BEFORE_S before the time asked for
        lasts = f", which lasts {reader.info.duration_s:.3f} s" if reader.info.duration_s else ""
        raise UserError(f"`at` {at:g} s is beyond the end of {path}{lasts}; give a time within the video.")
    end = shown[1] + 1 / (reader.info.fps or 30.0)  # the last frame stays on screen for a frame's time
    if not after and at >= end:
        raise UserError(
            f"`at` {at:g} s is beyond the end of {path}, whose last frame is shown from {shown[1]:.3f} s to "
            f"{end:.3f} s; give a time within the video."
        )
    return *shown, False


def _colour_matches(
    frame: np.ndarray, roi: tuple[int, int, int, int], colours: dict[str, HsvRange]
) -> tuple[list[ColourMatch], Labels]:
    """Every one of `colours` found in the ROI (largest share first) and each one's region labels (for drawing)."""
    x, y, w, h = roi
    crop = frame[y : y + h, x : x + w]
    least = max(MIN_AREA_PX, LISTED_SHARE * w * h)
    found: list[ColourMatch] = []
    labels: Labels = {}
    for name, hsv in colours.items():
        mask = hsv_mask(crop, hsv)
        n, lab, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        keep = [k for k in range(1, n) if stats[k, cv2.CC_STAT_AREA] >= least]
        if not keep:
            continue
        keep.sort(key=lambda k: -stats[k, cv2.CC_STAT_AREA])
        regions = [
            (x + int(stats[k, 0]), y + int(stats[k, 1]), int(stats[k, 2]), int(stats[k, 3]), int(stats[k, 4]))
            for k in keep
        ]
        found.append(ColourMatch(name, hsv, cv2.countNonZero(mask) / (w * h), regions))
        labels[name] = (lab, keep)
    found.sort(key=lambda m: -m.share)
    return found, labels


def _candidates(name: str, labels: np.ndarray, keep: list[int], roi: tuple) -> list[FloatCandidate]:
    """The largest regions of one preset colour as float candidates: box, area, elongation, long-axis angle."""
    out = []
    for k in keep[:MAX_CANDIDATES]:
        blob = (labels == k).astype(np.uint8)
        bx, by, bw, bh = cv2.boundingRect(blob)
        mo = cv2.moments(blob[by : by + bh, bx : bx + bw], binaryImage=True)
        angle, elongation, _ = principal_axis(mo)
        box = (roi[0] + bx, roi[1] + by, bw, bh)
        out.append(FloatCandidate(name, box, int(mo["m00"]), round(elongation, 3), round(angle, 2)))
    return out


def _measure(
    frame: np.ndarray, t_s: float, settings: TrackSettings, roi: tuple
) -> tuple[TrackRow, np.ndarray, MeasureStep]:
    """The tracker's own measurement of one frame (the one call into it: `measure_frame`, what track runs per frame)."""
    return measure_frame(frame, t_s, settings, roi, None)


def _look_at_surface(frame, t_s, colour: ColourMatch, roi: tuple) -> tuple[SurfaceLook, np.ndarray]:
    """Measure `colour` as the dyed liquid (against the container's walls, to learn whether they are found); a large
    picture whose surface is not measured validly, reduced as track reduces it (`surface_size`) when that is."""
    settings = TrackSettings(target="surface", reference="container", roi=roi, **colour.settings("liquid"))
    row, drawn, step = _measure(frame, t_s, settings, roi)
    shrink = reduction(roi)
    if not row.valid and shrink > 1:
        small = shrunk_roi(roi, shrink, (frame.shape[1], frame.shape[0]))
        small_frame = cast(np.ndarray, shrunk(frame, shrink))  # an array stays one
        reduced = _measure(small_frame, t_s, replace(settings, roi=small), small)
        if reduced[0].valid:
            row, small_drawn, step = reduced
            h, w = (shrink * n for n in small_drawn.shape[:2])
            drawn = frame.copy()  # drawn on the whole picture again
            drawn[:h, :w] = cv2.resize(small_drawn, (w, h), interpolation=cv2.INTER_LINEAR)
    if not isinstance(step, SurfaceStep):
        raise TypeError(f"the surface target was measured by a {type(step).__name__}")
    walls = bool(step.walls_record.measured)
    look = SurfaceLook(
        colour.name, step.liquid_frames > 0, bool(row.valid), walls=walls, quality=float(row.quality), roi=roi
    )
    if look.measured:
        look.angle_deg, look.container_angle_deg = float(row.float_angle_deg), float(row.container_angle_deg)
    return look, drawn


def _look_at_float(frame, t_s, colour: ColourMatch, roi: tuple, relaxed: str = "") -> tuple[FloatLook, np.ndarray]:
    """Measure `colour` as the float, against the image (is it measured?) and the container (are walls there?);
    `relaxed`: what of its preset's range was relaxed (measured by its own range, not the preset's)."""
    named = (
        {"float_hsv_low": colour.hsv.low, "float_hsv_high": colour.hsv.high} if relaxed else colour.settings("float")
    )
    row, drawn, step = _measure(frame, t_s, TrackSettings(roi=roi, **named), roi)
    if isinstance(step, SurfaceStep):
        raise TypeError("the float target was measured by a SurfaceStep")
    look = FloatLook(colour.name, step.found > 0, bool(row.valid), float(row.float_angle_deg), float(row.quality))
    look.relaxed = relaxed
    look.liquid_like = bool(step.liquid_width)
    if look.found:
        row, _, walled = _measure(frame, t_s, TrackSettings(reference="container", roi=roi, **named), roi)
        look.walls = bool(walled.walls_record.measured)
        look.container_angle_deg = float(row.container_angle_deg) if look.walls else math.nan
    return look, drawn


def liquid_roi(
    box_mask: np.ndarray, origin: tuple[int, int], bounds: tuple[int, int, int, int]
) -> tuple[tuple[int, int, int, int], bool]:
    """A ROI around the container a liquid region (`box_mask`: its pixels in its bounding box at `origin`) stands in,
    and whether the region meets something of its own colour below (it widens: a holder or a table).

    The liquid's sides are straight lines fitted to the region's ends in its full rows (those of the upper half at
    least nine tenths as wide as the widest there: below a sloped surface, above a holder); the ROI holds them, plus a
    margin for the glass, from half the width above the region's top (a slosh, the rim) down to the first of three
    rows that reach beyond a side (or a little below the region's bottom); inside `bounds` (x, y, w, h)."""
    rows = np.flatnonzero(box_mask.any(axis=1))
    left = np.argmax(box_mask[rows], axis=1).astype(float)
    right = box_mask.shape[1] - 1 - np.argmax(box_mask[rows, ::-1], axis=1).astype(float)
    upper = slice(0, max(3, len(rows) // 2))
    width = right - left + 1
    full = np.flatnonzero(width[upper] >= 0.9 * width[upper].max())
    if len(full) < 3:  # a sliver: its box
        left_line = right_line = None
        lo, hi, wide = left.min(), right.max(), np.zeros(len(rows), bool)
    else:
        left_line, right_line = (np.polyfit(rows[full], v[full], 1) for v in (left, right))
        tol = WIDER * float(np.median(width[full])) + 3
        wide = (left < np.polyval(left_line, rows) - tol) | (right > np.polyval(right_line, rows) + tol)
        wide[: full[0]] = False
    run = np.convolve(wide, np.ones(3), "valid") >= 3  # three rows in a row
    meets = bool(run.any())
    size = float(np.median(width[full])) if len(full) >= 3 else float(width.max())
    bottom = rows[int(np.argmax(run))] if meets else rows[-1] + 1 + int(0.05 * size)
    if left_line is not None and right_line is not None:  # the sides' extent from top to bottom (a tilted container)
        ends = np.array([rows[0], bottom])
        lo, hi = np.polyval(left_line, ends).min(), np.polyval(right_line, ends).max()
    pad = int(0.08 * size) + 4
    x0, x1 = origin[0] + int(lo) - pad, origin[0] + int(hi) + 1 + pad
    y0, y1 = origin[1] + int(rows[0] - 0.5 * size), origin[1] + int(bottom)
    return _clipped(x0, y0, x1, y1, bounds), meets


def _float_roi(c: FloatCandidate, bounds: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    """A ROI around a float: 1.5 of its length each way, where track looks for the container's walls beside it;
    inside `bounds` (x, y, w, h: the area searched)."""
    x, y, w, h = c.box
    length, cx, cy = max(w, h), x + 0.5 * w, y + 0.5 * h
    return _clipped(
        int(cx - 1.5 * length), int(cy - 1.5 * length), int(cx + 1.5 * length), int(cy + 1.5 * length), bounds
    )


def _clipped(x0: int, y0: int, x1: int, y1: int, bounds: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    """(x, y, w, h) of a box cut to `bounds` (x, y, w, h), which it overlaps (it holds a region found there)."""
    bx, by, bw, bh = bounds
    x0, y0 = max(bx, x0), max(by, y0)
    x1, y1 = min(bx + bw, x1), min(by + bh, y1)
    return x0, y0, x1 - x0, y1 - y0


def _inside(box: tuple, roi: tuple) -> bool:
    """Box (x, y, w, h) lies within roi (x, y, w, h)."""
    return (
        box[0] >= roi[0]
        and box[1] >= roi[1]
        and box[0] + box[2] <= roi[0] + roi[2]
        and box[1] + box[3] <= roi[1] + roi[3]
    )


def _hue_name(h: float) -> str:
    """A colour's name for an OpenCV hue (0..179)."""
    return next((name for bound, name in _HUES if h < bound), "red")


def what_it_saw(frame: np.ndarray, roi: tuple[int, int, int, int]) -> tuple[str, str, dict[str, HsvRange]]:
    """What the frame shows when no preset colour was found: how coloured it is and its largest coloured regions, in
    words, the same in a clause, and HSV ranges (by name) to measure with: one that takes the largest in, and one for a
    region darker than the rest where no coloured region is large enough for a liquid (`darker_liquid`); none in a
    grey picture without one."""
    x, y, w, h = roi
    hsv, lab, stats, order = coloured_regions(frame, roi)
    s_med, v_med = int(np.median(hsv[..., 1])), int(np.median(hsv[..., 2]))
    greys = f"median saturation {s_med} and brightness {v_med} of 255"
    big = [k for k in order if stats[k, cv2.CC_STAT_AREA] >= max(MIN_AREA_PX, LISTED_SHARE * w * h)][:3]
    dark = darker_liquid(hsv, stats, order)
    darker, also = {}, ""
    if dark is not None:
        (bx, by, bw, bh), r = dark
        where = f"{bw}x{bh} px at x {x + bx}-{x + bx + bw}, y {y + by}-{y + by + bh}"
        darker = {f"darker ({r.describe()})": r}
        also = (
            f"; a region darker than the rest, {where} (a near-black liquid greyed by the light, or a grey one), is "
            f"looked at with `liquid_hsv_low` {format_hsv(r.low)} `liquid_hsv_high` {format_hsv(r.high)}"
        )
    if not big:
        none = f"no preset colour here, and no coloured region (saturation {SATURATED[0]} or more) of {MIN_AREA_PX} px"
        if dark is not None:
            return f"{none} or more, {greys}{also}.", f"a grey picture, with a darker region {where}", darker
        return (
            (
                f"{none} or more, {greys}: a grey picture. Track needs a float or a dye of a clear colour (red, orange, "
                "yellow, green, blue, magenta); check the file, the lighting, or the time given (`at`)."
            ),
            f"a grey picture (no coloured region, median saturation {s_med} of 255)",
            {},
        )
    parts = []
    for k in big:
        hue = float(np.median(hsv[lab == k][:, 0]))
        bx, by, bw, bh, area = (int(v) for v in stats[k])
        parts.append(
            f"{_hue_name(hue)} (hue {hue:.0f}) {bw}x{bh} px at x {x + bx}-{x + bx + bw}, y {y + by}-{y + by + bh}, "
            f"{100 * area / (w * h):.2f} %"
        )
    px = hsv[lab == big[0]]
    hue = float(np.median(px[:, 0]))
    r = own_range(px)
    return (
        (
            f"no preset colour measured here ({greys}); the largest coloured regions: {'; '.join(parts)}; the "
            f"largest is looked at below with `liquid_hsv_low` {format_hsv(r.low)} `liquid_hsv_high` "
            f"{format_hsv(r.high)} (`float_hsv_low` and `float_hsv_high` for a float){also}."
        ),
        f"its largest coloured region, {parts[0]}, in no preset's range",
        {f"{_hue_name(hue)} ({r.describe()})": r, **darker},
    )


def default_picture_path(video: Path) -> Path:
    """Where `inspect`'s picture of `video` goes when no path is given (and where `track` draws one when it can
    track nothing): VIDEO_inspect.png beside the video."""
    return video.with_name(f"{video.stem}_inspect.png")


def inspect_video(
    path: str | Path,
    at: float | None = None,
    roi: tuple[int, int, int, int] | None = None,
    float_color: str | None = None,
) -> InspectResult:
    """Look at one frame of `path` (the first, or the one at `at` seconds; or a still picture) as each target would
    track it; `float_color`: the float's colour preset, looked at as track looks for it and tracked when found.

    Raises UserError for a file that is neither a video nor a picture, a time outside the video, a ROI outside the
    frame and an unknown colour. Finding nothing is not an error here: the result says what was seen (`seen`) and has
    no `target`."""
    if float_color is not None:
        preset(float_color)  # an unknown name is refused before the video is read
    video = Path(path)
    frame, t_s, still = read_frame(video, at)
    size = (frame.shape[1], frame.shape[0])
    # tuple() keeps the ROI's four numbers four (and makes a list a tuple); mypy only knows tuple[int, ...]
    box = roi_box(TrackSettings(roi=None if roi is None else cast("tuple[int, int, int, int]", tuple(roi))), *size)
    widened = None
    if roi is not None:  # an ROI drawn so tightly that it cuts the walls: looked at as track widens it
        wide, widened, _ = surface_roi(frame, box, TrackSettings(target="surface", roi=box))
        drawn_roi, box = box, wide
    res = InspectResult(
        video=video,
        t_s=t_s,
        size=size,
        still=still,
        roi=box,
        colours=[],
        surfaces=[],
        floats=[],
        candidates=[],
        suggested_roi=None,
        target=None,
        float_color=float_color,
    )
    if widened is not None:
        res.notes.append(
            f"the ROI {_fmt_roi(drawn_roi)} cuts the container's walls (the surface is measured only with it "
            f"wider): looked at {widened}, as track widens it"
        )
    labels: Labels = {}
    drawn: Drawn = {}
    # each preset's hues fitted to the dye as track fits them (`dye_range`): a dye between two presets' hues is
    # otherwise seen only where its edges reach one of them
    _look_at_colours(res, frame, {name: dye_range(frame, box, p.hsv) for name, p in PRESETS.items()}, labels, drawn)
    if not any(s.liquid for s in res.surfaces) and not any(f.found for f in res.floats):
        # a colour no preset takes (or too little of one): the largest coloured region's own range is looked at
        res.seen, res.saw, largest = what_it_saw(frame, box)
        _look_at_colours(res, frame, largest, labels, drawn)
    elif not any(s.measured for s in res.surfaces):
        # no preset measured as the liquid (a faint dye below every preset's saturation): its own range, as track
        # takes it then, when that is measured
        seen, saw, largest = what_it_saw(frame, box)
        if largest:
            own = replace(res, colours=[], surfaces=[], floats=[], candidates=[])
            more: Labels = {}
            _look_at_colours(own, frame, largest, more, drawn)
            if any(s.measured for s in own.surfaces):
                res.seen, res.saw = seen, saw
                labels.update(more)
                for name in ("colours", "surfaces", "floats", "candidates"):
                    getattr(res, name).extend(getattr(own, name))
    _look_at_named(res, frame, labels, drawn)
    _decide(res, frame, labels, drawn)
    if not still and (at is None or at <= 0) and res.track_settings:
        _try(res, roi)
    if res.track_settings and not res.works:
        res.notes.append(
            "track would not measure this frame with those settings today; run it to see its message, with "
            "`overlay` OUT.mp4 to see what it found"
            if res.trial is None
            else "the command below measured under half the frames tried; run it with `overlay` OUT.mp4 to see what "
            "it found, or look at a later frame (`at`)"
        )
    if still and res.track_settings:
        res.notes.append(
            "track measures a video, not a still: run the command below on the video this picture is a frame of "
            "(VIDEO; the ROI is in this picture's pixels)"
        )
    res.picture = _picture(res, frame, labels, drawn)
    return res


def _try(res: InspectResult, given: tuple[int, int, int, int] | None) -> None:
    """Track the video's first TRIAL_S seconds with the suggested settings and, where they name a colour or an ROI of
    inspect's (`OWN_CHOICES`), with track's own choices (the ROI `given` kept); take those where the suggestion measured
    under half the frames and they measure more (`TRIAL_MARGIN`): a suggestion that works is kept (track's own colour
    may be a label's, which inspect's liquid between walls was chosen over). Notes how many frames each measured."""
    own = {k: v for k, v in res.track_settings.items() if k not in OWN_CHOICES}
    if given is not None:
        own["roi"] = tuple(int(v) for v in given)
    runs = [_tried(res.video, res.track_settings)]
    if own != res.track_settings:
        runs.append(_tried(res.video, own))
    tried = [r for r in runs if r is not None]
    if not tried:
        res.trial = Trial(TRIAL_S, 0, 0)
        res.notes.append(f"tried on the first {TRIAL_S:g} s: track measured none of their frames")
        return
    frames = max(len(r.valid) for r in tried)
    times = tried[0].t_s
    seconds = min(TRIAL_S, float(times[-1] + (times[-1] - times[0]) / max(len(times) - 1, 1)))
    valid = [0 if r is None else int(np.count_nonzero(r.valid)) for r in runs]
    taken = len(runs) == 2 and 2 * valid[0] < frames and valid[1] >= valid[0] + TRIAL_MARGIN * frames
    res.trial = Trial(seconds, frames, valid[0], valid[1] if len(runs) == 2 else None, taken)
    which = "colour" if given is not None or "roi" not in res.track_settings else "colour and region"
    if taken:
        res.notes = [n.split(", used below: ")[0] if n.startswith("suggested ROI:") else n for n in res.notes]
        res.notes.append(
            f"tried on the first {seconds:.3g} s ({frames} frames): the settings this frame suggests measured "
            f"{valid[0]} validly, track with its own choice of {which} {valid[1]}: the command below leaves the "
            f"{which} to it"
        )
        res.track_settings = own
    else:
        res.notes.append(
            f"tried on the first {seconds:.3g} s: the command below measured {valid[0]} of {frames} frames validly"
            + (f" (track with its own choice of {which}: {valid[1]})" if len(runs) == 2 else "")
        )


def _tried(video: Path, settings: dict[str, Any]) -> TrackResult | None:
    """`settings` tracked over the video's first TRIAL_S seconds, quietly (None: track found nothing there)."""
    try:
        with warnings.catch_warnings():  # a trial's warnings are not the user's run's
            warnings.simplefilter("ignore")
            return track_video(video, TrackSettings(**settings, smooth=False), multithreaded=False, until_s=TRIAL_S)
    except UserError:
        return None


def _look_at_colours(res: InspectResult, frame: np.ndarray, colours: dict, labels: Labels, drawn: Drawn) -> None:
    """Find `colours` (name: HSV range) in the frame and measure each one found as the liquid and as a float; the
    region labels and the tracker's overlays go into `labels` and `drawn`."""
    found, more = _colour_matches(frame, res.roi, colours)
    labels.update(more)
    for p in found:
        surface, drawn[("surface", p.name)] = _look_at_surface(frame, res.t_s, p, res.roi)
        res.surfaces.append(surface)
        res.candidates += _candidates(p.name, *labels[p.name], res.roi)
        floating, drawn[("float", p.name)] = _look_at_float(frame, res.t_s, p, res.roi)
        res.floats.append(floating)
    res.colours += found


FLOAT_ALONG_DEG = 10.0
"""A float found only with its named colour relaxed is taken where its long axis lies within this of the measured
liquid surface's angle (a float follows the surface it lies on); relaxed, a range also finds a liquid's rim (27.8 deg
across a level surface) and specks."""


def _look_at_named(res: InspectResult, frame: np.ndarray, labels: Labels, drawn: Drawn) -> None:
    """The float colour the user named, where its preset measures no float in the first frame: relaxed as track relaxes
    it (`float_range`: a thin float's colour mixes with the liquid's under it, or pales in the light), in place of
    what the preset's range fitted to the picture found, where what it finds lies along the measured surface and is
    no other colour's float (`_along_surface`). Only a named colour: relaxed, every preset finds something."""
    name = res.float_color
    if name is None or any(f.color == name and f.measured and not f.liquid_like for f in res.floats):
        return
    if res.t_s > 0 and not res.still:  # track relaxes on the first frame's evidence only
        res.float_miss = "track relaxes its range only on the video's first frame: look at that one"
        return
    found = float_range(frame, res.roi, name)
    matches, more = _colour_matches(frame, res.roi, {name: found[0]}) if found is not None else ([], {})
    if found is None or not matches:
        return
    look, picture = _look_at_float(frame, res.t_s, matches[0], res.roi, found[1])
    cands = _candidates(name, *more[name], res.roi)
    res.float_miss = _along_surface(res, look, cands[0].box)
    if res.float_miss:
        return
    res.colours = [m for m in res.colours if m.name != name] + matches
    res.floats = [f for f in res.floats if f.color != name] + [look]
    res.candidates = [c for c in res.candidates if c.color != name] + cands
    labels.update(more)
    drawn[("float", name)] = picture


def _along_surface(res: InspectResult, look: FloatLook, box: tuple[int, int, int, int]) -> str:
    """Why a float found with its colour relaxed is not taken ("" where it is): not measured, lying across the measured
    surface (FLOAT_ALONG_DEG), or its centre inside another colour's measured float (not the liquid's colour's)."""
    if not look.measured:
        return f"its range relaxed ({look.relaxed}) finds a region track would not measure"
    surface = _measured_surface(res)
    if surface is not None and abs(look.angle_deg - surface.angle_deg) > FLOAT_ALONG_DEG:
        return (
            f"its range relaxed ({look.relaxed}) finds a region at {look.angle_deg:+.1f} deg, across the liquid's "
            f"surface at {surface.angle_deg:+.1f} deg: not a float lying on it"
        )
    cx, cy = box[0] + 0.5 * box[2], box[1] + 0.5 * box[3]
    for f in res.floats:  # a "float" of the measured liquid's colour is that liquid's body
        other = next((c.box for c in res.candidates if c.color == f.color), None)
        on = other is not None and other[0] <= cx <= other[0] + other[2] and other[1] <= cy <= other[1] + other[3]
        if f.measured and not f.liquid_like and on and (surface is None or f.color != surface.dye):
            return f"its range relaxed ({look.relaxed}) finds a part of the {f.color} float"
    return ""


def _decide(res: InspectResult, frame: np.ndarray, labels: Labels, drawn: Drawn) -> None:
    """Choose the target (a measured surface, else a measured float, else liquid found, else a float found), the
    preset and the ROI, and write the notes and the command."""
    size, box = res.size, res.roi
    given = box if box != (0, 0, *size) else None  # the user's ROI
    if res.colours:
        where = "ROI" if given else "picture"
        shares = ", ".join(f"{p.name} {100 * p.share:.2f} %" for p in res.colours)
        res.notes.append(f"colours found (share of the {where}): {shares}")
    # a liquid stands in a container: one whose walls were found first, then the largest
    measured = _measured_surface(res)
    liquid = measured or next((s for s in res.surfaces if s.liquid), None)
    dye = None if measured is None else measured.dye
    # the user's float, when found (not the measured liquid's colour), is what the command tracks
    named = _best_float(res, dye, res.float_color) if res.float_color is not None else None
    named = named if named is not None and named.measured else None
    flt = res.float_look = named or _best_float(res, dye)
    surface = None if named is not None else measured or (liquid if flt is None or not flt.measured else None)
    if res.float_color is not None and named is None:
        why = (
            "it is the liquid's colour here"
            if res.float_color == dye
            else res.float_miss or "track relaxes its range only where the preset finds nothing of its colour"
        )
        res.notes.append(
            f"no {res.float_color} float was measured in this frame ({why}); the command below is as unnamed"
        )
    res.liquid = liquid
    if liquid is not None:
        res.notes.append(_surface_note(liquid, _match(res, liquid.dye)))
        rivals = [s.dye for s in res.surfaces if s.measured and s is not measured]
        if measured is not None and rivals:
            res.notes.append(
                f"  measured as a surface too: {', '.join(rivals)}; "
                + ("it has no container's walls beside it" if measured.walls else "the largest was taken")
                + "; if that is the liquid, give its colour instead"
            )
    else:
        res.notes.append(
            f"surface: no dyed liquid (no preset colour's region of {100 * MIN_LIQUID_SHARE:.1f} % of the area)"
        )
    why = ""  # why the command needs the suggested ROI ("": it does not)
    if surface is not None:
        surface, why = _around_liquid(res, surface, frame, labels, drawn)
    res.notes += [_float_note(f, [c for c in res.candidates if c.color == f.color]) for f in res.floats]
    if surface is None and flt is not None:
        cands = [c for c in res.candidates if c.color == flt.color]
        res.suggested_roi = _float_roi(cands[0], box)
        others = [c for c in cands[1:] if not _inside(c.box, res.suggested_roi)]
        if others and not given:
            why = f"{len(others)} other {flt.color} region(s) lie outside it and could be taken for the float"
    use_roi = bool(why)
    if res.suggested_roi is not None:
        around = "the container the liquid stands in" if surface is not None else "the float and the walls beside it"
        used = f", used below: {why}" if use_roi else ""
        res.notes.append(
            f"suggested ROI: `roi` {_fmt_roi(res.suggested_roi)} (around {around}; white on the picture){used}"
        )
    if surface is not None:
        res.target = "surface"
        colour = {"target": "surface", **_match(res, surface.dye).settings("liquid")}
        res.track_settings = _track_settings(colour, res.suggested_roi if use_roi else given, surface.walls)
        if flt is not None and flt.measured:  # a float on the dyed liquid: its settings too
            res.alternative = _track_settings(_match(res, flt.color).settings("float"), given, flt.walls)
    elif flt is not None:
        res.target = "float"
        colour = _match(res, flt.color).settings("float")
        res.track_settings = _track_settings(colour, res.suggested_roi if use_roi else given, flt.walls)
    elif res.colours:
        names = ", ".join(c.name for c in res.colours)
        res.saw = (res.saw + "; " if res.saw else "") + f"{names} found, but neither as a liquid nor as a float"
        res.notes.append(
            "nothing here is a dyed liquid or a float: the colours found cover too little of the area, or are not "
            "elongated; try `roi` around the liquid or float, or a frame where they show (`at`)"
        )


def _around_liquid(
    res: InspectResult, surface: SurfaceLook, frame: np.ndarray, labels: Labels, drawn: Drawn
) -> tuple[SurfaceLook, str]:
    """Suggest the ROI around the liquid `surface` shows; measure it there when it was not measured in the whole area.
    Returns the surface to track (that measurement when it succeeded) and why the command needs the ROI ("": not)."""
    box, given = res.roi, res.roi != (0, 0, *res.size)
    p = _match(res, surface.dye)
    lab, keep = labels[surface.dye]
    x0, y0, w0, h0, _ = p.regions[0]
    region = lab[y0 - box[1] : y0 - box[1] + h0, x0 - box[0] : x0 - box[0] + w0] == keep[0]
    res.suggested_roi, meets = liquid_roi(region, (x0, y0), box)
    others = [r for r in p.regions[1:] if not _inside(r[:4], res.suggested_roi) and r[4] >= 0.1 * p.regions[0][4]]
    if not surface.measured and res.suggested_roi != box:
        retry, drawn[("surface", "roi")] = _look_at_surface(frame, res.t_s, p, res.suggested_roi)
        res.surfaces.append(retry)
        found = "measured, " + _surface_numbers(retry) if retry.measured else "not measured either"
        res.notes.append(f"  with `roi` {_fmt_roi(res.suggested_roi)}: {found}")
        if retry.measured:
            surface = res.liquid = retry
        return surface, f"the liquid was not measured in the {'ROI given' if given else 'whole picture'}"
    if given or not (meets or others):
        return surface, ""
    # measured in the whole picture: the ROI is suggested only where it keeps the surface measured (a dye's region
    # in patches, with its holder, had put the ROI inside the liquid's sides)
    if surface.measured and not _look_at_surface(frame, res.t_s, p, res.suggested_roi)[0].measured:
        res.notes.append(f"  with `roi` {_fmt_roi(res.suggested_roi)} the surface is not measured: not used below")
        return surface, ""
    if meets:
        return surface, f"the {surface.dye} region runs on into something of its own colour below the liquid"
    return surface, f"{len(others)} other {surface.dye} region(s) lie outside it"


def _track_settings(colour: dict[str, Any], roi: tuple | None, walls: bool) -> dict[str, Any]:
    """The target and colour settings, then the ROI (when one is needed) and the container reference (walls found)."""
    settings = dict(colour)
    if roi is not None:
        settings["roi"] = tuple(int(v) for v in roi)
    if walls:
        settings["reference"] = "container"
    return settings


def _fmt_roi(roi: tuple) -> str:
    return ",".join(str(int(v)) for v in roi)


def _surface_numbers(s: SurfaceLook) -> str:
    """The measured surface's numbers in words."""
    walls = (
        f"the container's wall edges found at {s.container_angle_deg:+.2f} deg from vertical (`reference` container)"
        if s.walls
        else f"the liquid's sides at {s.container_angle_deg:+.2f} deg from vertical; the container's wall edges not found"
    )
    return f"surface at {s.angle_deg:+.2f} deg against the image, quality {s.quality:.2f}, {walls}"


def _surface_note(s: SurfaceLook, p: ColourMatch) -> str:
    """One line on the surface target."""
    x, y, w, h, _ = p.regions[0]
    where = f"{s.dye} liquid {w}x{h} px at x {x}-{x + w}, y {y}-{y + h}"
    if s.measured:
        return f"surface: {where}: measured, {_surface_numbers(s)}"
    return (
        f"surface: the largest {s.dye} region, {w}x{h} px at x {x}-{x + w}, y {y}-{y + h}: not measured as a liquid, "
        "the container's inner walls (straight sides of the region, its bottom) were not found"
    )


def _float_note(f: FloatLook, cands: list[FloatCandidate]) -> str:
    """One line on the float target for one preset colour."""
    listed = "; ".join(
        f"{c.box[2]}x{c.box[3]} px at x {c.box[0]}, y {c.box[1]}, {c.area_px} px, elongation {c.elongation:.2f}, "
        f"{c.angle_deg:+.1f} deg"
        for c in cands[:3]
    )
    more = f" (+{len(cands) - 3} more)" if len(cands) > 3 else ""
    if f.liquid_like:
        verdict = "the largest is a liquid body between walls, not a float"
    elif f.measured:
        walls = (
            f"walls found beside it, {f.container_angle_deg:+.2f} deg from vertical"
            if f.walls
            else "no walls beside it (`reference` image only)"
        )
        verdict = f"track takes the largest: {f.angle_deg:+.2f} deg, quality {f.quality:.2f}, {walls}"
    elif f.found:
        verdict = f"track takes the largest but with quality {f.quality:.2f} (below 0.5: not a float's shape or colour)"
    else:
        verdict = "too small for track to take"
    relaxed = f" (the preset's range relaxed, {f.relaxed}, as track relaxes it)" if f.relaxed else ""
    return f"float, {f.color}{relaxed}: {len(cands)} candidate(s): {listed}{more}: {verdict}"


def _picture(res: InspectResult, frame: np.ndarray, labels: Labels, drawn: Drawn) -> np.ndarray:
    """Two panels: the surface target (the tracker's overlay, every preset's regions) and the float target (its
    overlay, the candidates); the suggested ROI in white on both; a title bar over each."""
    chosen = res.liquid
    key = ("surface", "roi" if chosen is not None and chosen.roi != res.roi else chosen.dye if chosen else "")
    left = drawn.get(key, np.array(frame)).copy()
    scale = max(0.45, frame.shape[0] / 800)
    thick = max(1, round(frame.shape[0] / 360))
    for p in res.colours:
        lab, keep = labels[p.name]
        outline = p.outline()
        mask = np.isin(lab, keep).astype(np.uint8)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(left, contours, -1, outline, thick, offset=res.roi[:2])
        x, y = p.regions[0][:2]
        _text(left, f"{p.name} {100 * p.share:.1f} %", (x + 4, y + int(22 * scale) + 4), scale, outline)
    flt = res.float_look
    right = drawn[("float", flt.color)].copy() if flt else np.array(frame)
    for c in res.candidates:
        outline = _match(res, c.color).outline()
        x, y, w, h = c.box
        cv2.rectangle(right, (x - 2, y - 2), (x + w + 1, y + h + 1), outline, thick)
        _text(right, f"{c.color} e{c.elongation:.2f} {c.angle_deg:+.1f}", (x, max(y - 6, 12)), 0.8 * scale, outline)
    for panel in (left, right):
        if res.suggested_roi is not None:
            x, y, w, h = res.suggested_roi
            cv2.rectangle(panel, (x, y), (x + w - 1, y + h - 1), (255, 255, 255), thick)
    titles = (_title(res, "surface"), _title(res, "float"))
    bar = int(34 * scale) + 8
    panels = []
    for panel, title in zip((left, right), titles):
        head = np.full((bar, panel.shape[1], 3), 32, np.uint8)
        cv2.putText(head, title, (8, bar - 10), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
        panels.append(np.vstack([head, panel]))
    gap = np.full((panels[0].shape[0], 8, 3), 255, np.uint8)
    return np.hstack([panels[0], gap, panels[1]])


def _title(res: InspectResult, target: str) -> str:
    """A panel's title: the target and what it found."""
    if target == "surface":
        s = res.liquid
        if s is not None and s.measured:
            return f"surface: {s.dye} liquid, {s.angle_deg:+.2f} deg"
        return "surface: liquid found, walls not" if res.target == "surface" else "surface: nothing measured"
    f = res.float_look
    if f is not None and f.measured:
        return f"float: {f.color}, {f.angle_deg:+.2f} deg, quality {f.quality:.2f}"
    return f"float: {len(res.candidates)} candidate(s), none measured"


def _measured_surface(res: InspectResult) -> SurfaceLook | None:
    """The measured liquid surface track would take: one whose container's walls were found first, then the largest."""
    return max((s for s in res.surfaces if s.measured), key=lambda s: s.walls, default=None)


def _best_float(res: InspectResult, liquid: str | None = None, colour: str | None = None) -> FloatLook | None:
    """The float track would measure best (measured, not liquid, highest quality), or the first found; not of the
    colour `liquid` (a measured liquid's); of the colour `colour` only, when given."""
    found = [
        f
        for f in res.floats
        if f.found and not f.liquid_like and f.color != liquid and (colour is None or f.color == colour)
    ]
    return max(found, key=lambda f: (f.measured, f.quality), default=None)


def _text(img: np.ndarray, text: str, org: tuple[int, int], scale: float, colour: tuple) -> None:
    """Text with a dark outline, readable on any background."""
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def _match(res: InspectResult, name: str) -> ColourMatch:
    """The colour called `name` among those found."""
    return next(m for m in res.colours if m.name == name)
