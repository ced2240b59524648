"""The surface target of `track_video`: per-frame surface measurements (surface.py) turned into the track table.

Per frame it keeps what the picture shows; after the last frame it corrects for a camera above the liquid
(the surface ellipse's opening over the inner width is the sine of the elevation, which shortens heights and
flattens slopes by its cosine), takes each wall's height as the surface's rise there about its centre, above that
rise's median over the rest frames, and scales the wall heights to millimetres when the container's inner diameter
is given (the measured walls give px/m).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from sloshid.core.errors import NothingFound, SettingError
from sloshid.tracking.container_ref import (
    GUARD_ROWS,
    STEADY_FLOOR_DEG,
    STEADY_RUN,
    ContainerMeasurement,
    ContainerTracker,
    EdgeLine,
    WallsRecord,
    steady_angle,
)
from sloshid.tracking.overlay import draw_surface_overlay
from sloshid.tracking.repeats import REPEAT_SHARE, Copies, line_regions, repeated_share
from sloshid.tracking.robust import MAD_SIGMA, median, percentile_span, running_median, scatter
from sloshid.tracking.rows import VALID_QUALITY, SurfaceGeometry, TrackRow, step_row
from sloshid.tracking.surface import SurfaceFinder, SurfaceMeasurement, steady_axes
from sloshid.video.colors import HsvRange

CENTRE_SHARE = 0.05
"""A frame whose surface centre (the mid-line's height at the container's axis, above the liquid's bottom) is further
than this share of the inner width from its median over the valid frames is not valid: a planar slosh keeps the centre
there. Rendered clips stay within 2 px (0.01 of the width) up to 40 deg of slosh and 20 deg of camera elevation; a
liquid reaching the rim read 115 px (0.5)."""
SIDES_STILL_DEG = 0.3
"""The liquid's sides whose angle scatters by at most this (robustly, and in a running median) through a clip show a
container that did not turn: their tilt is good to about this much, a sloshing liquid's sides in a tapered glass move
them by as much."""
WALLS_OVER_SIDES = 3.0
"""... where its glass walls' angles scatter more than this many times as much: a turn would move both alike (pbr
decay80: walls 2.8 deg, sides 0.1)."""
GLASS_AGREE_DEG = 10.0
"""The glass's walls turn a frame's measurement onto their axis only when their angle is within this of the liquid's
sides' (the inner walls: a tapered glass, its refraction and a sloshing liquid's sides put them up to 5 deg apart
on the path-traced tumblers); the real frame brightened had one wall on a highlight 40 deg off in half its frames."""
CENTRE_KEPT_SHARE = 0.02
"""... but a frame whose surface centre lies in the picture within this share of the inner width of where the frames
around it put theirs keeps its row (`_bottom_misread`): its level moved with the liquid's bottom as read there, not
with the surface (a thick glass bottom seen from above shows two edges, read in turn 30 px apart on a Blender tumbler,
its surface's centre within 1 px)."""
TILT_NOTE_DEG = 1.0
"""With ``reference` image`, a container that turns by more than this in the picture (its walls as the liquid's sides
give them, 1st to 99th percentile of the valid frames) draws a warning: the angle includes its tilt. A still
container's sides span up to 0.7 deg (their fits move a little at each colour refit)."""


class SurfaceStep:
    """Measures the liquid surface frame by frame and assembles the surface columns at the end."""

    def __init__(self, settings, roi: tuple[int, int, int, int], liquid: HsvRange | None = None) -> None:
        """`liquid`: the dye's HSV box when already chosen (else the settings', else chosen from the first frame)."""
        self.settings, self.roi = settings, roi
        self.finder = SurfaceFinder(liquid or settings.liquid_hsv, roi)
        self.liquid_frames = 0
        self.line_frames = 0  # frames where the walls and a surface line were found, valid or not
        self.previous: np.ndarray | None = None
        self.previous_luma: tuple | None = None  # the last measurement's luma crop, for the repeat check
        self.repeated: list[bool] = []
        self.walls = ContainerTracker(roi) if settings.reference == "container" else None
        self.pending: list[tuple] = []  # (frame in the span, measurement again with a held elevation, walls measured)
        self.walls_record = WallsRecord()  # by frame in the span
        self.held_surfaces: dict[int, SurfaceMeasurement] = {}  # the frames whose walls were held: their surface
        self.measured: list[tuple] = []  # (frame in the span, its axes, its refit in other axes, walls measured)
        self.copies = Copies()
        self.picture_width: int | None = None  # for the perspective correction (`perspective_deg`)
        self.scale = 1  # the video's pixels per measured one (a large picture is measured reduced): for the outputs

    def __call__(self, frame: np.ndarray, draw: bool) -> tuple[tuple, np.ndarray | None]:
        """(row, overlay frame or None): the track row's fields, then the raw surface geometry.

        A frame whose picture around the last measured surface is an exact copy of that frame's is not measured again
        (`Copies`): its row is that measurement's (after `revise`), and it is marked repeated."""
        self.picture_width = frame.shape[1]
        copied = self.copies.source(frame, len(self.repeated))
        if copied is not None:
            m, row = copied
            self.finder.copied()
            if self.walls is not None:
                self.walls_record.copied.append(len(self.repeated))
            self.repeated.append(True)
            self.liquid_frames += 1
            self.line_frames += m.found
            self.previous, self.previous_luma = frame, None  # the next frame is compared with this one
            reference = self.settings.reference
            return row, draw_surface_overlay(
                frame, m, row.angle_deg, bool(row.valid), self.roi, reference
            ) if draw else None
        m = self.finder.measure(frame)
        self.liquid_frames += m.liquid
        self.line_frames += m.found
        # the glass's edges along the liquid's sides, from above the liquid to its bottom, give the container's angle
        # more precisely than the liquid's sides alone
        cm = (
            self.walls.measure(frame, m.x_px, m.y_px, 0.8 * m.width_px, m.still, _glass(m))
            if m.found and self.walls
            else None
        )
        lumas = (m.luma, self.previous_luma)
        repeat = m.found and repeated_share(frame, self.previous, m.band, True, lumas) >= REPEAT_SHARE
        self.previous, self.previous_luma = frame, m.luma
        if m.refit is not None:  # measured before the camera's elevation is held: again at the span's end
            self.pending.append((len(self.repeated), m.refit, cm))
        if m.in_axes is not None:  # measured in this frame's axes: in the span's, if the container stood still
            self.measured.append((len(self.repeated), m.axes, m.in_axes, cm))
        # held walls are interpolated at the span's end, from a copy of what `_row` reads (it changes `m`)
        if cm is not None:
            self.walls_record.add(len(self.repeated), cm)
            if cm.held:
                self.held_surfaces[len(self.repeated)] = replace(m, walls=(), ends=(), luma=None, refit=None)
        self.repeated.append(bool(repeat))
        row = self._row(m, cm)
        self.copies.measured(len(self.repeated) - 1, frame, _regions(m, cm) if m.found else None, (m, row))
        drawn = (
            draw_surface_overlay(frame, m, row.angle_deg, bool(row.valid), self.roi, self.settings.reference)
            if draw
            else None
        )
        return row, drawn

    def _row(self, m: SurfaceMeasurement, cm: ContainerMeasurement | None) -> TrackRow:
        """The track row's fields, then the raw surface geometry, of a measurement (turned onto the container's walls
        `cm` when they were measured and agree with the liquid's sides within GLASS_AGREE_DEG: `m` is changed)."""
        sides = m.container_angle_deg
        if cm is not None and cm.found and abs(m.container_angle_deg - cm.angle_deg) <= GLASS_AGREE_DEG:
            tilt = math.radians(m.container_angle_deg - cm.angle_deg)  # the liquid's sides against the walls
            seen = math.atan(m.rel_slope) + tilt
            # the wall heights were read along the liquid's sides (their tilt is good to some 0.3 deg, the whole
            # walls' to 0.02): on the walls' own axes each wall's height moves by half the width times the tilt
            shift = 0.5 * m.width_px * math.tan(tilt)
            m.left_w, m.right_w = m.left_w - shift, m.right_w + shift
            m.rel_slope, m.container_angle_deg = math.tan(seen), cm.angle_deg
        ok = m.found and m.quality >= VALID_QUALITY
        rel = math.degrees(math.atan(m.rel_slope)) if m.found else math.nan
        cang = m.container_angle_deg if self.settings.reference == "container" else 0.0
        angle = rel if self.settings.reference == "container" else rel + m.container_angle_deg
        raw = SurfaceGeometry(m.rel_slope, m.container_angle_deg, m.left_w, m.right_w, m.width_px, m.opening_px, sides)
        return step_row(angle, rel + m.container_angle_deg, cang, m.x_px, m.y_px, m.quality, int(ok), raw)

    def revise(self, rows: list[TrackRow]) -> None:
        """Measure the span's first frames again, with the camera's elevation and the edge source that were held
        after them (`rows`: this span's, time first, changed in place): their own fits of the elevation scatter, and
        on a yellow liquid with a strong reflection a few tilted the line by a degree and moved a wall by 20 px.
        And turn the frames whose container walls were held onto the container angle interpolated between the
        measurements that began and ended the hold (the held one when the walls were lost at its end, or the span
        ended). A container that stood still through the span is measured in the median of its frames' axes
        (`steady_axes`). Overlay frames show the first measurement. Frames that repeated a measured picture take its
        row."""
        walls = {}
        for i, value in self.walls_record.held_angles().items():
            walls[i] = ContainerMeasurement(True, value)
            rows[i] = self._row(self.held_surfaces[i], walls[i])._replace(t_s=rows[i].t_s)
        held, source = self.finder.settled()
        for i, refit, cm in self.pending if held is not None else ():
            m = refit(held, source)
            if m.found:
                rows[i] = self._row(m, walls.get(i, cm))._replace(t_s=rows[i].t_s)
        axes = steady_axes([g for _, g, _, _ in self.measured])
        for i, _, again, cm in self.measured if axes is not None else ():
            m = again(axes, held, source)
            if m.found:
                rows[i] = self._row(m, walls.get(i, cm))._replace(t_s=rows[i].t_s)
        self.copies.fill(rows)
        self.pending, self.held_surfaces, self.measured = [], {}, []

    def merge(self, later: SurfaceStep) -> None:
        """Take in what the step of a later span of the same video found (for `nothing_found`)."""
        self.liquid_frames += later.liquid_frames
        self.line_frames += later.line_frames
        self.picture_width = self.picture_width or later.picture_width
        self.finder.hsv = self.finder.hsv or later.finder.hsv
        others = [e for e in (self.finder.elsewhere, later.finder.elsewhere) if e is not None]
        self.finder.elsewhere = max(others, default=None)

    def nothing_found(self, n: int, path: Path, hint: str) -> NothingFound:
        """The one-sentence error when no frame was valid: no liquid of that colour, or no container around it."""
        if self.finder.hsv is None:
            return NothingFound(
                "liquid_color",
                f"no dyed liquid of any preset colour found in the {n} frames of {path}; {hint} and give {{name}} "
                "or {liquid_hsv_low}/{liquid_hsv_high}.",
                "overlay",
                "liquid_hsv_low",
                "liquid_hsv_high",
                hint=hint,
            )
        if self.liquid_frames == 0:
            return NothingFound(
                "liquid_color",
                f"no liquid of colour {self.finder.hsv.describe()} found in any of the {n} frames of {path}; "
                f"{hint} and adjust {{name}} or {{liquid_hsv_low}}/{{liquid_hsv_high}}.",
                "overlay",
                "liquid_hsv_low",
                "liquid_hsv_high",
                hint=hint,
            )
        if self.line_frames:
            return NothingFound(
                "roi",
                f"the liquid and the container's walls were found in {self.line_frames} of {n} frames of {path}, but "
                f"the surface's edge in none of them clearly enough to measure (quality under {VALID_QUALITY}: "
                f"edges of other things of the dye's colour, or the surface's front and back edges, crossed it); "
                f"{hint}, and set {{name}} tightly around the liquid's top, or give {{liquid_color}} if another preset "
                "is the dye's.",
                "overlay",
                "liquid_color",
                hint=hint,
            )
        return NothingFound(
            "roi",
            f"the liquid was found in {self.liquid_frames} of {n} frames of {path} but not the container's inner "
            f"walls (straight sides of the liquid inside the picture) in any of them; {hint}, and set {{name}} around "
            "the container: wider when the picture's edge cuts it, narrower when something else of the dye's colour "
            "touches it or the colour range takes in the background.",
            "overlay",
            hint=hint,
        )

    def finish(self, rows: list[TrackRow]) -> tuple[list[TrackRow], dict[str, np.ndarray], list[str]]:
        """Elevation-corrected angles, the wall heights above rest (px, and mm with the diameter) and warnings."""
        t = np.array([r.t_s for r in rows], float)
        valid = np.array([r.valid for r in rows], bool)
        slope, cang, left, right, width, opening, sides = (np.array(c, float) for c in zip(*[r.surface for r in rows]))
        steady = steady_angle(cang, valid, STEADY_FLOOR_DEG) if self.walls is not None else None
        if steady is None and self.walls is not None and _sides_steady(sides, cang, valid):
            steady = median(cang[valid])  # the glass's walls misread in some frames (a holder's edge, the slosh)
        if steady is not None:  # a container that stood still, its walls measured in every frame: their median
            turn = np.radians(cang - steady)
            slope = np.tan(np.arctan(slope) + turn)
            left, right = left - 0.5 * width * np.tan(turn), right + 0.5 * width * np.tan(turn)
            cang = np.full_like(cang, steady)
        # a back edge's ellipse opens upwards (a negative opening): the camera is as far above the liquid either way
        sin_e = float(np.clip(abs(median(opening[valid])) / median(width[valid]), 0, 0.5))
        cos_e = math.sqrt(1 - sin_e * sin_e)
        rel = np.degrees(np.arctan(slope / cos_e))
        x, y = (np.array(c, float) for c in zip(*[(r.x_px, r.y_px) for r in rows]))
        moved_at = _moved_at(valid, x, y, width)
        fov, found_fov = self.settings.fov_deg, None
        if fov is None and self.picture_width:
            fov = found_fov = lens_from_rest(x, y, rel + cang, cang, valid, width, moved_at, self.picture_width, sin_e)
        if fov is not None and self.picture_width:
            rel += np.nan_to_num(perspective_deg(x, self.picture_width, sin_e, fov))
        container = self.settings.reference == "container"
        angle = rel if container else rel + cang
        # the surface's centre in the video's pixels: a measured pixel x covers its x * scale .. x * scale + scale - 1
        seen = [
            (self.scale * r.x_px + 0.5 * (self.scale - 1), self.scale * r.y_px + 0.5 * (self.scale - 1)) for r in rows
        ]
        body = [
            r._replace(angle_deg=a, float_angle_deg=rv + c, x_px=sx, y_px=sy, surface=None)
            if steady is None
            else r._replace(angle_deg=a, float_angle_deg=rv + c, container_angle_deg=c, x_px=sx, y_px=sy, surface=None)
            for r, a, rv, c, (sx, sy) in zip(rows, angle, rel, cang, seen)
        ]
        notes = [] if container else _tilt_notes(cang[valid])
        rest = _rest_window(t, valid, x, y, width, self.settings.rest_frames, moved_at, notes)
        if found_fov is not None and self.picture_width:
            turn = perspective_deg(x[valid], self.picture_width, sin_e, found_fov)
            notes.append(
                "the container stood at rest before its move and after it, where its liquid, level both times, read "
                "angles that differ as the perspective of a camera looking down on it (about "
                f"{math.degrees(math.asin(sin_e)):.0f} deg) through a lens about {found_fov:.0f} deg wide turns them: "
                f"the angles are corrected for it ({np.min(turn):+.2f} to {np.max(turn):+.2f} deg); give `fov_deg` "
                "(the camera's horizontal field of view) to set the lens instead."
            )
        elif self.settings.fov_deg is None and self.picture_width:
            notes += perspective_notes(self.scale * x[valid], self.scale * self.picture_width, sin_e)
        if self.finder.elsewhere is not None:
            ex, ey, ew, eh = (self.scale * v for v in self.finder.elsewhere[1])
            notes.append(
                f"another region of the dye's colour ({ew}x{eh} px at x {ex}-{ex + ew}, y {ey}-{ey + eh}) was left out: "
                "it is not beside the largest one, which was measured as the liquid; if the liquid is elsewhere, or the "
                "measured region is not liquid, set `roi` around the container."
            )
        # each wall's height is the surface's rise there about the mid-line's centre, which a planar slosh keeps where
        # it was (the liquid's volume): read against the liquid's bottom, the centre would add that bottom's misreads
        rise = 0.5 * (right - left)
        rise = np.where(valid, self.scale * (rise - median(rise[rest])) / cos_e, np.nan)
        walls = {"left_wall_px": -rise, "right_wall_px": rise}
        level = 0.5 * (left + right)
        centre = np.where(valid, self.scale * (level - median(level[valid])) / cos_e, np.nan)
        off = valid & (np.abs(centre) > CENTRE_SHARE * self.scale * median(width[valid]))
        off &= ~_bottom_misread(off, valid, x, y, median(width[valid]))
        if off.any():
            valid &= ~off
            body = [b._replace(valid=0) if o else b for b, o in zip(body, off)]
            walls = {name: np.where(valid, w, np.nan) for name, w in walls.items()}
            first = int(np.argmax(off))
            notes.append(
                f"the surface's centre left its level by more than {100 * CENTRE_SHARE:.0f} % of the inner width "
                f"in {int(off.sum())} frame(s), first at {t[first]:.2f} s (up to {np.nanmax(np.abs(centre[off])):.0f} "
                "px), where a slosh keeps it (the liquid's volume): what was measured there is not the surface (the "
                "liquid at the rim or spilling, or another object); those rows have valid = 0."
            )
        spikes = _spikes(np.array([b.angle_deg for b in body], float), valid)
        if spikes.any():
            valid &= ~spikes
            body = [b._replace(valid=0) if k else b for b, k in zip(body, spikes)]
            walls = {name: np.where(valid, w, np.nan) for name, w in walls.items()}
            notes.append(
                f"the surface's angle jumped away from the frames around it and back in {int(spikes.sum())} frame(s), "
                f"first at {t[int(np.argmax(spikes))]:.2f} s, faster than a slosh moves it (the edge read there "
                "strayed, e.g. to the ellipse's back edge): those rows have valid = 0."
            )
        mm_per_px = (
            1000 * self.settings.container_diameter_m / (self.scale * median(width[valid]))
            if self.settings.container_diameter_m
            else math.nan
        )
        for name in ("left_wall", "right_wall"):
            walls[f"{name}_mm"] = walls[f"{name}_px"] * mm_per_px
        return body, walls, notes


def _rest_window(t, valid, x, y, width, n_rest: int | None, moved: int | None, notes: list[str]) -> np.ndarray:
    """The valid frames whose median rise is the wall heights' zero: the first `n_rest` frames, else the first second,
    up to the container's move (frame `moved`) within it, or where it stood after the move when it was moving from its
    first measured frame; every valid frame where none of those was measured. What it took is said in `notes`."""
    check_rest_frames(n_rest, len(t))
    rest = valid & (np.arange(len(t)) < n_rest if n_rest else t < t[0] + 1.0)
    moved = None if n_rest else moved
    all_valid = "above the median of all valid frames, not above rest; give `rest_frames` for frames where "
    if moved is not None and _rest_before(rest, moved):
        rest[moved:] = False
        notes.append(
            f"the container moved at {t[moved]:.2f} s, within the first second, so the wall heights are above the "
            "surface's level in the frames before it; give `rest_frames` for other frames at rest."
        )
    elif moved is not None and moved == np.flatnonzero(valid)[0] and rest.any():
        # measured first while it moved, its liquid off level: the level where it stood after the move instead
        place = _last_place(valid, x, y, width)
        settled = place.size >= LENS_REST_FRAMES
        rest = np.isin(np.arange(len(t)), place) if settled else valid
        where = (
            f"above the surface's level where it stood after its move (from {t[place[0]]:.2f} s); give `rest_frames` "
            if settled
            else all_valid
        )
        notes.append(
            f"the container was moving when its surface was first measured ({t[moved]:.2f} s), so the wall heights "
            f"are {where}for frames where the surface was at rest and measured."
        )
    elif not rest.any():  # heights from the median of every valid frame: said, as they are not above rest
        window = f"the first {n_rest} frames" if n_rest else "the first second"
        notes.append(
            f"the surface was measured in none of {window} (the rest window), so left/right_wall_px and _mm are "
            f"heights {all_valid}the surface was at rest and measured."
        )
        rest = valid
    elif not n_rest and t[-1] < t[0] + 1.0:  # a clip shorter than the default window
        notes.append(
            f"the video lasts {t[-1] - t[0]:.2f} s, less than the rest window (the first second), so "
            f"left/right_wall_px and _mm are heights {all_valid}the surface was at rest."
        )
    return rest


def _bottom_misread(off: np.ndarray, valid: np.ndarray, x: np.ndarray, y: np.ndarray, width: float) -> np.ndarray:
    """The frames of `off` (their level off the median, CENTRE_SHARE) whose surface centre (`x`, `y`) lies within
    CENTRE_KEPT_SHARE of `width` of the line through the nearest valid frames not off before and after them (held
    beyond the first and last): the surface stayed where it was, and the bottom it was measured from moved."""
    kept = np.zeros_like(off)
    good, at = np.flatnonzero(valid & ~off), np.flatnonzero(off)
    if good.size == 0 or at.size == 0:
        return kept
    where = np.hypot(x[at] - np.interp(at, good, x[good]), y[at] - np.interp(at, good, y[good]))
    kept[at[where <= CENTRE_KEPT_SHARE * width]] = True
    return kept


MOVE_SHARE = 0.03
"""The container moved where its surface's centre left its place in the first valid frames by more than this share of
the inner width, in two valid frames in a row: a slosh keeps the centre there (as CENTRE_SHARE). A robot's move that
starts within the first second ends the rest window. A turn alone does not: a container rocked by a degree or two
(the painted tap tests) keeps its liquid at rest, and the frames cut off would only make the rest level noisier."""
MIN_REST_FRAMES = 3
"""A rest window cut short by the container's move keeps at least this many valid frames; fewer: not cut."""


def _rest_before(rest: np.ndarray, moved: int) -> bool:
    """The rest window may end at the container's move (frame `moved`): it goes on past it, and at least
    MIN_REST_FRAMES of its frames come before it."""
    return bool(rest[moved:].any() and np.count_nonzero(rest[:moved]) >= MIN_REST_FRAMES)


def _away(x: np.ndarray, y: np.ndarray, width: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Per frame, whether the surface's centre lies further than MOVE_SHARE of the inner width from where it stood in
    the frames `at` (their medians)."""
    return np.hypot(x - median(x[at]), y - median(y[at])) > MOVE_SHARE * median(width[at])


def _sides_steady(sides: np.ndarray, cang: np.ndarray, valid: np.ndarray) -> bool:
    """The liquid's sides show a container that did not turn while its glass walls scatter: their fresh measurements
    (not held or copied from a frame before) stay within SIDES_STILL_DEG of their median, robustly and in a running
    median over STEADY_RUN of them, or one held value stands for all (the finder found its axes still), and the walls'
    angles scatter more than WALLS_OVER_SIDES times as much (a turn shows in both: the walls misread)."""
    fresh = valid & np.isfinite(sides) & np.r_[True, np.diff(sides) != 0]
    a = sides[fresh]
    if a.size == 0:
        return False
    centre, spread = median(a), scatter(a)
    running = running_median(a, min(STEADY_RUN, a.size))
    if spread > SIDES_STILL_DEG or np.max(np.abs(running - centre)) > SIDES_STILL_DEG:
        return False
    return scatter(cang[valid]) > WALLS_OVER_SIDES * max(spread, STEADY_FLOOR_DEG)


def _moved_at(valid: np.ndarray, x: np.ndarray, y: np.ndarray, width: np.ndarray) -> int | None:
    """The first frame of the container's move (MOVE_SHARE), None when it stayed where it stood; the first valid frame
    where it was already moving there (two of the first MIN_REST_FRAMES away from their median: one is a misread)."""
    frames = np.flatnonzero(valid)
    first = frames[:MIN_REST_FRAMES]
    if len(first) < MIN_REST_FRAMES:
        return None
    away = _away(x, y, width, first)
    if np.count_nonzero(away[first]) >= 2:
        return int(first[0])
    pairs = away[frames[:-1]] & away[frames[1:]]
    return int(frames[np.argmax(pairs)]) if pairs.any() else None


def _last_place(valid: np.ndarray, x: np.ndarray, y: np.ndarray, width: np.ndarray) -> np.ndarray:
    """The valid frames where the container stood at its last place (MOVE_SHARE of where the last MIN_REST_FRAMES
    stood), after the last frame away from it; none where it never left it."""
    frames = np.flatnonzero(valid)
    away = frames[_away(x, y, width, frames[-MIN_REST_FRAMES:])[frames]]
    return frames[frames > away[-1]] if away.size else frames[:0]


LENS_REST_FRAMES = 8
"""The container's rests before and after its move are used for the lens (`lens_from_rest`), and its place after the
move for the wall heights' level (`_rest_window`), over at least this many valid frames each: the liquid may ring
there, and its median level needs a period or so of them."""
LENS_TURN_DEG = 0.5
"""... and only where the container's walls turned by less than this at either rest place (the medians of its first
and second halves), or over the part of it away from the move (`_still_part`): a container still tilting holds its
liquid off level."""
LENS_STILL_FRAMES = 4
"""A rest place whose walls turned is cut to its frames away from the move (`_still_part`), at least this many."""
LENS_TRAVEL_SHARE = 0.15
"""... and only when it moved at least this share of the picture's width between them."""
LENS_FOV_DEG = (10.0, 120.0)
"""The fields of view a lens found so may have; outside, the two rest places differ by more than perspective (the
liquid not yet at rest, a misread edge) or by too little to tell, and nothing is corrected."""


def _turned(w: np.ndarray, cang: np.ndarray) -> bool:
    """Whether the container's walls turned by more than LENS_TURN_DEG across the frames `w` (their halves' medians)."""
    return abs(median(cang[w[: w.size // 2]]) - median(cang[w[w.size // 2 :]])) > LENS_TURN_DEG


def _still_part(w: np.ndarray, cang: np.ndarray, far_first: bool) -> np.ndarray:
    """The rest window `w` (frames), or where its walls turned (`_turned`: a robot starts tilting the container before
    it carries it away and ends after it is back) its part away from the move: the run of frames from its far end
    (`far_first`: the window's start) whose walls stand within half LENS_TURN_DEG of the far LENS_STILL_FRAMES
    frames' median; none where that run is shorter (a container turning there too)."""
    if not _turned(w, cang):
        return w
    ordered = w if far_first else w[::-1]
    apart = np.abs(cang[ordered] - median(cang[ordered[:LENS_STILL_FRAMES]])) > 0.5 * LENS_TURN_DEG
    kept = ordered[: int(np.argmax(apart)) if apart.any() else ordered.size]
    return np.sort(kept) if kept.size >= LENS_STILL_FRAMES else w[:0]


def lens_from_rest(x, y, image_deg, cang, valid, width, moved, picture_width: int, sin_e: float) -> float | None:
    """The horizontal field of view (deg) for which `perspective_deg` reads the liquid level where the container stood
    before its move (from frame `moved`, `_moved_at`'s) and where it stood after it, or None where the clip does not
    show two such rest places: the liquid at rest is level wherever it stands, so what its line differs by between them
    is the camera's (a lens's distortion along the row adds its share, and is taken out with it). `image_deg`: the
    line's angle in the picture per frame, `cang`: the walls'."""
    frames = np.flatnonzero(valid)
    if moved is None or sin_e <= 0:
        return None
    before, after = frames[frames < moved], _last_place(valid, x, y, width)
    if min(before.size, after.size) < LENS_REST_FRAMES:
        return None
    before, after = _still_part(before, cang, far_first=True), _still_part(after, cang, far_first=False)
    if min(before.size, after.size) == 0:
        return None
    dx = median(x[after]) - median(x[before])
    if abs(dx) < LENS_TRAVEL_SHARE * picture_width:
        return None
    inv_focal = -math.radians(median(image_deg[after]) - median(image_deg[before])) / (sin_e * dx)
    fov = 2 * math.degrees(math.atan(0.5 * picture_width * inv_focal)) if inv_focal > 0 else 0.0
    return fov if LENS_FOV_DEG[0] <= fov <= LENS_FOV_DEG[1] else None


GLASS_ABOVE = 1.2
"""The glass's edges are read from this many inner widths above the surface's centre (or the picture's top) down to
the liquid's bottom."""


def perspective_deg(x_px, picture_width: int, sin_elevation: float, fov_deg: float):
    """What a pinhole camera above the liquid turns the surface's line by, in degrees, for a container centred at
    column `x_px`: sin(e) tan(psi), e the camera's elevation (the ellipse's opening over its width), psi the container's
    azimuth off the optical axis (the picture's centre). The tracker's line joins the surface ellipse's ends as seen,
    where the lines of sight graze the wall; the line across the container's plane parallel to the picture lies psi
    round the wall from them, in front of the axis at one end and behind it at the other, so that the camera's elevation
    lowers one end and lifts the other. A sheared ellipse is still a line plus a symmetric chord: the focal length is
    not in the picture."""
    focal = 0.5 * picture_width / math.tan(math.radians(fov_deg) / 2)
    return np.degrees(sin_elevation * (np.asarray(x_px, float) - 0.5 * (picture_width - 1)) / focal)


SPIKE_DEG = 0.5
"""A frame is a spike only when it leaves the cubic through its neighbours (`_spikes`) by at least this much."""
SPIKE_SCATTER = 6.0
"""... and by this many robust scatters of every frame's distance from its neighbours' cubic."""
SPIKE_REACH = 3
"""The four frames a frame is judged against lie within this many frames of it: one invalid frame beside it
leaves a gap of two."""


def _spikes(angle: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Valid frames whose angle leaves the cubic through the two valid frames before and the two after it (within
    SPIKE_REACH frames) by more than SPIKE_DEG and SPIKE_SCATTER robust scatters, and by more than either of those
    next to it does (a spike also moves its neighbours' cubics, by two thirds of it), away from both and back (a tap's
    sudden start is a kink, not a spike): a slosh well below half the frame rate moves the surface smoothly,
    within a few hundredths of its swing of that cubic (3 Hz at 30 fps: 2.5 %), while a fit that strayed to the
    ellipse's back edge in one frame reads degrees off (a path-traced cola clip: 2.6-5.9 deg in 4 of 120 frames,
    one of them beside a frame of too low a quality)."""
    out = np.zeros(angle.size, bool)
    if angle.size < 5:
        return out
    a = np.nan_to_num(angle)
    i = np.arange(angle.size)
    before = np.maximum.accumulate(np.where(valid, i, -1))  # the last valid frame up to each frame
    after = np.minimum.accumulate(np.where(valid, i, angle.size)[::-1])[::-1]  # the first valid frame from each
    p1 = np.r_[-1, before[:-1]]
    n1 = np.r_[after[1:], angle.size]
    p2 = np.where(p1 > 0, np.r_[-1, before[:-1]][np.maximum(p1, 0)], -1)
    n2 = np.where(n1 < angle.size - 1, np.r_[after[1:], angle.size][np.minimum(n1, angle.size - 1)], angle.size)
    judged = valid & (p2 >= 0) & (n2 < angle.size) & (i - p2 <= SPIKE_REACH) & (n2 - i <= SPIKE_REACH)
    if np.count_nonzero(judged) < 10:
        return out
    j = np.flatnonzero(judged)
    nodes = np.vstack([p2[j], p1[j], n1[j], n2[j]]).astype(float) - j  # frame offsets of the four, about the frame
    guess = np.zeros(j.size)
    for k in range(4):  # the cubic through the four (Lagrange) at the frame itself
        others = np.delete(nodes, k, axis=0)
        guess += a[(nodes[k] + j).astype(int)] * np.prod(-others / (nodes[k] - others), axis=0)
    miss = np.zeros(angle.size)
    miss[j] = np.abs(a[j] - guess)
    limit = max(SPIKE_DEG, SPIKE_SCATTER * MAD_SIGMA * median(miss[j]))
    up, down = a[j] - a[p1[j]], a[j] - a[n1[j]]
    away_and_back = (up * down > 0) & (np.minimum(np.abs(up), np.abs(down)) > limit / 2)  # not a tap's kink
    out[j] = (miss[j] > limit) & (miss[j] >= miss[p1[j]]) & (miss[j] >= miss[n1[j]]) & away_and_back
    return out


USUAL_FOV_DEG = 70.0
"""A phone's or a webcam's horizontal field of view: what `perspective_notes` assumes where none was given."""
PERSPECTIVE_NOTE_DEG = 0.1
"""The perspective's turn of the surface's line worth a warning: a third of the angle accuracy aimed at (0.3 deg)."""


def perspective_notes(x_px: np.ndarray, picture_width: int, sin_elevation: float) -> list[str]:
    """The warning that perspective turns the surface's line by PERSPECTIVE_NOTE_DEG or more with a usual lens, where
    no field of view was given (`x_px`: the surface's centre in the valid frames)."""
    if x_px.size == 0:
        return []
    turn = perspective_deg(x_px, picture_width, sin_elevation, USUAL_FOV_DEG)
    if np.max(np.abs(turn)) < PERSPECTIVE_NOTE_DEG:
        return []
    off = np.max(np.abs(x_px - 0.5 * (picture_width - 1)))
    return [
        f"the camera looks down on the surface (about {math.degrees(math.asin(sin_elevation)):.0f} deg) at a "
        f"container up to {off:.0f} px off the picture's centre: perspective turns the surface's line by "
        f"{np.min(turn):+.2f} to {np.max(turn):+.2f} deg with a usual lens ({USUAL_FOV_DEG:g} deg wide), which the "
        "picture cannot show; give `fov_deg` (the camera's horizontal field of view) to correct it, or centre the "
        "container in the picture."
    ]


def _glass(m: SurfaceMeasurement) -> tuple[list[EdgeLine], tuple[int, int], tuple[int, int]]:
    """What `ContainerTracker.measure` needs to find the walls on the glass: the liquid's sides as seed lines (over the
    liquid's rows), the rows from GLASS_ABOVE widths above the surface to the last tenth above the bottom, and the rows
    whose two ends are watched for a move of the container while it stands still: the glass just above the liquid and the liquid's side
    near the bottom (far apart, so that a turn about either end moves the other)."""
    (aL, bL, top, bottom), (aR, bR, _, _) = m.walls
    seeds = [EdgeLine(aL, bL, int(top), int(bottom), 0.0, 0), EdgeLine(aR, bR, int(top), int(bottom), 0.0, 0)]
    low = int(bottom - 0.1 * (bottom - top))
    rows = (max(0, int(m.y_px - GLASS_ABOVE * m.width_px)), low)
    return seeds, rows, (max(rows[0], int(top) - 4 - GUARD_ROWS), low)


def _regions(m: SurfaceMeasurement, cm: ContainerMeasurement | None) -> list[tuple]:
    """Where a surface measurement was read, for `Copies`: the front edge's band, the liquid's sides (the inner walls,
    from the surface to the bottom) and the bottom between them, and the container's whole wall edges when measured."""
    (aL, bL, _, y_bottom), (aR, bR, _, _) = m.walls
    bottom = (
        math.floor(aL * y_bottom + bL) - 4,
        math.floor(y_bottom) - 4,
        math.ceil(aR * y_bottom + bR) + 5,
        math.ceil(y_bottom) + 5,
    )
    regions = [(m.band, True), *line_regions(m.walls), (bottom, True)]
    return regions + line_regions(cm.edges) if cm is not None and cm.edges else regions


def check_rest_frames(n_rest: int | None, frames: int) -> None:
    """Refuse a rest window (``rest_frames``) that covers the whole video of `frames` frames (0: not known yet)."""
    if n_rest and frames and n_rest >= frames:
        raise SettingError(
            "rest_frames",
            f"{{name}} {n_rest} covers the whole video, which has {frames} frames; give the frames before the tap "
            "or move.",
        )


def _tilt_notes(cang: np.ndarray) -> list[str]:
    """The warning that the container turned in the picture (`cang`: its angle in the valid frames, deg), if it did."""
    span = percentile_span(cang)
    if span <= TILT_NOTE_DEG:
        return []
    return [
        f"the container turned by {span:.1f} deg in the picture (1st to 99th percentile of the valid frames): "
        "angle_deg is measured against the image and includes that tilt; `reference` container measures the "
        "liquid against the container."
    ]
