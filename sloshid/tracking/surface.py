"""Find dyed liquid in a container and measure its surface: angle across the inner width and height at each wall.

The liquid body is detected with an HSV range (a preset, the user's range, or the preset whose colour covers
the largest region of the first frame) and measured with the same linear colour model as the float, a soft
body membership of every pixel. The body's sides are the container's inner walls (one sub-pixel crossing per
row, on the luma where every row has the contrast, robust straight lines) and its lower boundary is the inner
bottom: together they fix the container's axes in every frame, so a container that moves and tilts in the picture
is measured in its own coordinates.
Per column, the body's upper boundary is the front edge of the surface, refined on the full-resolution luma (or left
on the colour, for a dye whose luma edge is noisy: chosen in the first frames with the elevation below). A
camera slightly above the liquid sees the round surface as a thin ellipse: its front edge lies R sin(elevation)
sqrt(1 - s^2) below the mid-line (s = -1..1 across the inner width), so the front edges are fitted with the
mid-line (an antisymmetric cubic: first and second mode) minus that term. The fit is robust (a running median,
then 3-MAD trimming): highlight stripes, a meniscus band and a reflection of the surface on the wall disturb runs
of columns and drop out, and the columns next to the walls, where the meniscus curls up, are not used. The
mid-line's best-fit line across the whole inner width is the angle; its values at the walls are the heights.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import cast

import cv2
import numpy as np

from sloshid.tracking.container_ref import EdgeLine, glass_walls, steady_angle, wall_lines
from sloshid.tracking.float_angle import fit_colour_model, hsv_mask, membership_map
from sloshid.tracking.robust import MAD_SIGMA, median, normal_solve, robust_lines, scatter, straight_part
from sloshid.tracking.rows import VALID_QUALITY
from sloshid.video.colors import PRESETS, HsvRange
from sloshid.video.frames import Picture

MIN_LIQUID_SHARE = 0.005
"""A liquid region must cover at least this share of the searched area."""
WALL_MARGIN = 0.06
"""Columns this close to a wall (share of the inner width, at least 4 px) are not used: the meniscus curls up."""
REFIT_EVERY = 48
"""The liquid's colour model is refitted every this many frames (the float's: every 8): the front edge is placed on
the luma, so a model that lags a lighting change by a second or two moves no edge; a refit reads the whole body."""
EXPOSURE_SHARE = 0.1
"""The colour model is fitted again, in the frame itself, when the liquid's mean grey level (`_liquid_level`) has moved
by this share from its level at the last fit (a camera's exposure step)."""
EXPOSURE_EVERY = 4
"""Frames after a colour refit in which the exposure is not watched: under a light flickering by 30 % the model was
refitted in every frame (1.8 times the CPU time) and measured no better."""
HOLD_ELEVATION_AFTER = 15
"""The camera's elevation is fitted in this many frames, then held at their median."""
HOLD_AXES_FRAMES = REFIT_EVERY
"""The container's axes are held while the container stands still (its last two fits agreed within STILL_PX, and its
sides, bottom and ANCHOR_PX strip have not moved since), until the next colour refit; a moving one is measured every frame."""
STILL_PX = 0.1
"""Largest shift of the bottom centre or of a wall between two measurements of a container that stands still."""
ANCHOR_PX = 0.5
"""Largest change of the liquid's centre or width across the body just above the bottom, or of its depth or centroid
across the bottom, since the axes were measured, for which a band frame keeps them (a lift, a slide, a tilt)."""
ANCHOR_ROWS = 8
"""Rows across the body (just above the bottom's nine) in which the liquid's centre and width are watched."""
MAX_COLUMNS = 128
"""The front edge is measured in at most this many evenly spaced columns: neighbouring columns share the compressed
chroma and the blur, so more add little precision but cost time (a 640x480 view of a container: every second)."""
HEADROOM = 0.1
"""The surface is followed this far (share of the body's width, plus 6 px) above the liquid's top in the last frame;
a surface that rises faster is found again by a colour search."""
FIT_HEADROOM = 0.3
"""The colour model is fitted on the pixels up to this far above the liquid's top: the air above the surface is much
of its background, and with less of it the fitted edges move (by 3 px at the walls of a test clip)."""
BAND_BELOW = 12
"""While the container stands still, the liquid is mapped only down to this many pixels (or a twentieth of its width)
plus twice the last frame's sinking below the last frame's lowest front-edge point, and in the ANCHOR_PX strip:
the rest of the body is not read then."""
EDGE_SOURCES = ("luma", "colour", "luma low", "colour low", "luma high", "colour high")
"""Where the front edge is read: the liquid's membership crossing 0.5 refined on the luma, or on the colour alone, and
the same crossing LOW_LEVEL (the low sources) or PLATEAU_LEVEL (the high ones)."""
OTHER_SOURCE = {
    s: s.replace("luma", "colour") if s.startswith("luma") else s.replace("colour", "luma") for s in EDGE_SOURCES
}
"""The front edge's other source at the same level, which a frame the held one does not measure validly is read on."""
LOW_LEVEL = 0.3
"""The 'low' sources cross the liquid's membership at this level instead of 0.5: the lit top face of an opaque juice
seen from above holds at 0.4-0.9, dimmer on the side away from the light, so that 0.5 crosses its back edge on one
side and the middle of the face on the other, while this crosses the back edge all along it."""
LOW_SCATTER_SHARE = 0.8
"""The low sources are held when in a span's first frames their edge scatters about its fit by less than this share
of the 0.5 crossings' (median rms, the same source): one clean ellipse edge where 0.5 mixes two."""
LOW_BASE_SCATTER_PX = 1.0
"""... and the 0.5 crossings' own scatter is at most this (px): an edge mixed with another, not the speckle of a noisy
picture, in which the low level finds the speckle too."""
LOW_CLEAN_PX = 0.5
"""Where both sources' 0.5 crossings scatter by more than LOW_BASE_SCATTER_PX, the low crossing that scatters less is
held when its scatter is at most this (px) and it fits validly and better than the 0.5 crossings: one clean edge,
where the 0.5 crossings run onto a glow on the surface over a third of the width (a faint dye lit from behind: 1.7-1.8
px against 0.1); a noisy picture's speckle, which the low level finds too, scatters it as much."""
LOW_MIN_FRAMES = 5
"""... chosen on the medians of at least this many first frames: on two, a juice's low crossing scattered less by chance
(a pbr juice seen 14 deg from above: 0.48 deg off, where the 0.5 crossings read 0.18)."""
LOW_QUALITY_MARGIN = 0.25
"""... and the low source's fits are valid and at most this much below the 0.5 crossings' in quality (medians): a low
crossing that leaves columns out reads a part of the edge (a pbr still's, 0.50 against 0.76, read 0.1 deg worse)."""
HIGH_BASE_QUALITY = 0.6
"""The 'high' sources cross the membership at PLATEAU_LEVEL. They are held when the 0.5 crossings fit poorly in a span's
first frames (median quality under this; scatter at most LOW_BASE_SCATTER_PX): an opaque juice's lit top face that
holds at 0.5-0.8 of the dye, under a paler highlight at its back, puts the 0.5 crossings at the highlight's edge in some
columns and at the face's front in others, while the face's front edge is a clean step to the body's 1 (a Blender
glass of orange juice leaning 4.3 deg seen 12 deg from above: 4.2 deg off, refused)."""
HIGH_QUALITY_GAIN = 0.2
"""... and the high source's fits are valid, better than the 0.5 crossings' by at least this much in quality, and its
edge scatters less (medians over at least LOW_MIN_FRAMES first frames)."""
LUMA_EDGE_SCATTER = 0.3
"""The front edge stays on the colour, not refined on the luma, when in a span's first frames the luma edge scatters
about its fit by more than this (px, median rms) and the colour edge by less (a dye whose luma is close to the background's)."""
GREY_WEIGHT = 0.25
"""Neutral greys join the colour model's background with this share of its pixels' weight when the dye's HSV range holds
no grey (every preset's), so that the container's dark walls are not taken for liquid."""
RIVAL_SHARE = 0.25
"""A second preset colour whose largest region in the first frame is at least this share of the chosen one's is
named in a warning when the dye is chosen automatically (a trial's red label beside blue water was measured as the
liquid, with no word of the blue)."""
PIECE_GAP = 0.1
"""Largest gap between pieces of one liquid body, as a share of the largest piece's width (`_beside`): highlight
stripes are a few pixels wide."""
FOLLOW_DOWN = 3
"""How many times a body box is reached further down, by half its width each, when the liquid goes on below it."""
WIDER_REACH = 3
"""How many times FOLLOW_SIDE a body box is reached out at most, with the colour model fitted again there (`_wider`)."""
FOLLOW_SIDE = 0.25
"""Share of its width a body box is reached further out on each side, once, when its liquid gave no surface or walls
outside its window: a dark preset's range holds a rendered cola's darker core only (its sides up to a tenth of its
width beyond that box)."""
OUTWARD_PX = 3.0
"""Both sides of the liquid's run stepping outward from the walls' lines by more than this (or OUTWARD_SHARE of the
inner width) in three successive rows end the container's column: a holder or table of the dye's colour below it."""
OUTWARD_SHARE = 0.03
STEP_PX = 4.0
"""Front edges of neighbouring columns further apart than this (and STEP_SLOPE per pixel between them) are on two
sides of something in front of the surface (`_continuous`)."""
STEP_SLOPE = 1.0
"""A surface's largest slope in the picture, px per px (45 deg: a slosh beyond that breaks up)."""
STEP_FIT = 10
"""Columns at the end of the surface taken so far whose line is carried across a step (`_continuous`)."""
STEP_RUNS = 8
"""More steps than this are a ragged edge, not something in front of the glass: `_continuous` leaves them."""
STEP_KEEP = 0.5
"""Share of the columns the surface's runs must keep (`_continuous`), else nothing is measured; a label over more than
half of the surface is taken for it."""
STEP_SPREAD = 0.1
"""How far that line may miss a run beyond the step, per pixel of gap (the surface's curvature, px per px)."""
SUSTAIN_ROWS = 3
"""A column's front edge is its first crossing of 0.5 into at least this many rows of liquid (`_sustained`)."""
BOTTOM_ROWS = 6
"""The liquid's bottom is where it ends for at least this many rows: a beaker's graduation marks, a few pixels high,
cross it above (at 640x480, two to three rows)."""
LINE_SLOPE_OF_CUBIC = 0.6
"""Least-squares line slope of s^3 over s in [-1, 1]: the cubic's contribution to the best-fit line."""
SECOND_MODE_PRIOR_PX = 0.5
"""The cubic's (second mode's) prior: zero mean, this standard deviation (px at the walls), against the edge's own
scatter. A free cubic read the odd structure a lit meniscus or the glass leaves near the walls of a surface at rest as
a second mode of several pixels, and its share of the line turned the angle by tenths of a degree (physically based
stills: median error 0.23 -> 0.17 deg with the prior; without any cubic 0.14, but a painted second mode's wall
heights then lost 0.16 px); a second mode the edge shows along its whole width still outweighs it."""
EDGE_SIGMA_PX = 0.3
"""Floor of the front edge's scatter (px) in the cubic's prior: a sub-pixel edge on a clean picture."""
CENTRE_PRIOR_PX = 2.0
"""The walls' midpoint lies within about this of the container's axis (a wall read on a reflection or a refracted edge
a few pixels off): the prior of the surface ellipse's fitted centre."""
CENTRE_MIN_K_PX = 2.0
"""The ellipse's centre is fitted only when its front edge sags at least this far below the mid-line: flatter, it
tells nothing about the centre."""
PLATEAU_LEVEL = 0.75
"""Where the 0.5 crossings fit no front edge, those of this membership are tried (the high edge sources cross it too):
the surface ellipse seen from above can hold at about 0.5 over an opaque liquid (the sheen of the wall reflected on
orange juice), so its back edge and the rows of it hide the front edge's 0.5 crossing; the body under the front edge
is at 1."""
QUALITY_HALF_PX = 80.0
"""The front edge's scatter about its fit counts against a frame's quality in pixels of a surface this many pixels
half-wide, and in proportion on a wider one: a clip scaled up three times (edges three pixels wide) scattered 0.7-1.1
px where its original did 0.36-0.49, and every frame fell under the valid quality."""
MAX_ELEVATION_SIN = 0.3
"""Largest camera elevation's sine looked for (17 deg): the surface ellipse seen from above is at most this share of
the inner width tall, so a column's front edge is searched that far below its first crossing (`_front_below`)."""
ELEVATION_GAP = 0.05
"""The first frames' elevations (k / R, of one sign), sorted, split into two readings where neighbours lie further apart
than this (3 deg): on a juice's lit top face some frames fitted its front edge and others a line above it (0.09, 0.28)."""
ELEVATION_GAIN = 0.05
"""... and the reading whose elevation fits all the first frames better by this much in median quality is held, though
fewer frames read it (a Blender tumbler of orange juice: 5 frames at 0.60-0.75, 10 at 0.50-0.55; 1.5 deg off)."""


@dataclass
class SurfaceMeasurement:
    """One frame's surface measurement in container coordinates (u along the width, w up the walls), pixels as seen."""

    found: bool
    liquid: bool = False
    """The liquid colour was found (False with found=False means: no liquid; True: no container)."""
    rel_slope: float = math.nan
    """Best-fit line slope dw/du of the surface's mid-line across the inner width."""
    container_angle_deg: float = math.nan
    """Mean tilt of the two inner walls from the image vertical, CCW positive as seen."""
    left_w: float = math.nan
    right_w: float = math.nan
    """Surface height at the left/right inner wall above the inner bottom, along the walls."""
    width_px: float = math.nan
    opening_px: float = math.nan
    """Front-to-back distance of the surface ellipse at the centre (0 when the camera is level)."""
    x_px: float = math.nan
    y_px: float = math.nan
    quality: float = 0.0
    walls: tuple = ()
    """(a, b, y0, y1) of the inner walls x = a y + b, for the overlay."""
    ends: tuple = ()
    """Image points of the fitted line at the walls and of the wall heights, for the overlay."""
    band: tuple[int, int, int, int] = (0, 0, 0, 0)
    """Box (x0, y0, x1, y1) around the measured front edge: where a repeated picture shows."""
    low: float = math.nan
    """Lowest image row of the fitted front edge across the measured columns."""
    still: bool = False
    """Measured in a band: the liquid's sides and bottom are where they were in the last whole-body frame (within
    ANCHOR_PX), so the container did not move, but for a tilt of a few tenths of a degree."""
    luma: tuple | None = None
    """(8-bit luma of the measured crop, frame (x, y) of its corner): the repeated-picture check reads it."""
    refit: Callable[[tuple[float, float], str], SurfaceMeasurement] | None = None
    """Before the camera's elevation is held: this frame's measurement again with a given elevation (k / R) and
    ellipse centre (`centre_shift`), and edge source (one of EDGE_SOURCES), so that the first frames can be measured
    as the later ones once they are held."""
    axes: tuple | None = None
    """The container's axes it was measured in (as `_container_axes` returns them, in frame coordinates)."""
    in_axes: Callable[[tuple, tuple[float, float] | None, str], SurfaceMeasurement] | None = None
    """This frame's front edge measured again in other axes (frame coordinates) with a given elevation and ellipse
    centre, and edge source: a container that stood still is measured in the median of its frames' axes (`steady_axes`)."""
    centre_shift: float = 0.0
    """The surface ellipse's centre from the walls' midpoint, in half widths (fitted when it is seen from above)."""


def preset_regions(frame: np.ndarray, roi: tuple[int, int, int, int]) -> list[tuple[str, int, np.ndarray]]:
    """Every preset's largest connected region in the ROI as (name, area in pixels, box x, y, w, h), largest first
    (presets with no pixel there left out)."""
    x, y, w, h = roi
    crop = frame[y : y + h, x : x + w]
    regions = []
    for name, p in PRESETS.items():
        n, _, stats, _ = cv2.connectedComponentsWithStats(hsv_mask(crop, p.hsv), connectivity=8)
        if n > 1:
            k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
            regions.append((name, int(stats[k, cv2.CC_STAT_AREA]), stats[k, :4]))
    return sorted(regions, key=lambda r: r[1], reverse=True)


def auto_liquid_preset(frame: np.ndarray, roi: tuple[int, int, int, int]) -> tuple[str | None, str | None]:
    """The name of the preset whose colour covers the largest connected region of the ROI (None when none covers
    enough), and of the next one when its largest region is at least RIVAL_SHARE of that (the liquid may be it)."""
    regions = preset_regions(frame, roi)
    if not regions or regions[0][1] <= MIN_LIQUID_SHARE * roi[2] * roi[3]:
        return None, None
    (best, area, best_box), rival = regions[0], regions[1] if len(regions) > 1 else None
    # a hue between two presets' ranges is one region in both: no rival
    if rival is None or _overlap(best_box, rival[2]) >= 0.5 or rival[1] < RIVAL_SHARE * area:
        return best, None
    return best, rival[0]


def _overlap(a: np.ndarray, b: np.ndarray) -> float:
    """Share of the smaller of two boxes (x, y, w, h) that the other covers."""
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(w, 0) * max(h, 0) / max(min(a[2] * a[3], b[2] * b[3]), 1)


def auto_liquid_range(frame: np.ndarray, roi: tuple[int, int, int, int]) -> HsvRange | None:
    """The HSV box of `auto_liquid_preset`'s choice, or None."""
    name = auto_liquid_preset(frame, roi)[0]
    return PRESETS[name].hsv if name else None


DYE_HUE_REACH = 10
"""How far (OpenCV hue units, 2 deg each) a preset's hue bounds may move out to the dye's as seen (`dye_range`)."""
DYE_HUE_SHARE = 0.25
"""A hue just beyond a bound joins the range while the dye's region holds at least this share of the median count of
the range's own hues there (and at least one pixel): a dye's hue spreads on without a gap, another object's starts
after one. A narrow hue (most of the range's hues empty) sets no floor beyond the one pixel."""


def dye_range(frame: np.ndarray, roi: tuple[int, int, int, int], hsv: HsvRange) -> HsvRange:
    """A preset's range with its hue bounds moved out (by at most DYE_HUE_REACH) over the hues that continue the
    dye's own in the region of the preset's saturation and value holding its largest region: a dye's hue shifts with
    its depth and the light (the real frame's blue water brightened reads 97-101 at its top, below the blue preset's
    100), and a range that cuts it leaves the liquid's top out. The `dark` preset's value ceiling moves up instead."""
    if hsv.wraps:
        return hsv
    x, y, w, h = roi
    crop = frame[y : y + h, x : x + w]
    core = hsv_mask(crop, hsv)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(core, connectivity=8)
    if n <= 1:
        return hsv
    largest = labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    im = cv2.cvtColor(crop, cv2.COLOR_BGR2HSV)
    if hsv.low[0] == 0 and hsv.high[0] == 179:  # no hue: a near-black liquid lit or seen through bright glass greys
        flipped = 255 - hsv.high[2]  # its value's ceiling as a floor of 255 - value
        ceiling = 255 - _paler_bound(255 - im[..., 2], largest, np.ones(largest.shape, bool), flipped, 0)
        return HsvRange(hsv.low, (*hsv.high[:2], ceiling))
    sv = cv2.inRange(im, (0, hsv.low[1], hsv.low[2]), (179, hsv.high[1], hsv.high[2]))
    _, around = cv2.connectedComponents(sv, connectivity=8)
    counts = np.bincount(im[..., 0][around == np.bincount(around[largest]).argmax()], minlength=180)
    floor = DYE_HUE_SHARE * float(np.median(counts[hsv.low[0] : hsv.high[0] + 1]))
    low, high = hsv.low[0], hsv.high[0]
    while low > max(0, hsv.low[0] - DYE_HUE_REACH) and counts[low - 1] >= max(floor, 1):
        low -= 1
    while high < min(179, hsv.high[0] + DYE_HUE_REACH) and counts[high + 1] >= max(floor, 1):
        high += 1
    # over the preset's own hues: widened, they reach a neighbouring colour's liquid (a red juice for orange)
    hue = cv2.inRange(im, (hsv.low[0], 0, hsv.low[2]), (hsv.high[0], 255, hsv.high[2])) > 0
    pale = _paler_bound(im[..., 1], largest, hue, hsv.low[1], SATURATED[0])
    return HsvRange((low, pale, hsv.low[2]), (high, *hsv.high[1:]))


DYE_SAT_REACH = 60
"""How far (OpenCV saturation or value) a preset's saturation floor may move down to the dye's paler part, or the
`dark` preset's value ceiling up (`dye_range`): a light dye lit from one side pales towards the highlight (a
Cycles-rendered blue dye reads saturation 90-160 across its glass, the blue preset starts at 140), a near-black one
greys behind a bright glass (a Cycles cola reads value 40-100, the dark preset ends at 60), and a range that cuts it
takes a chord of the surface for its line."""
DYE_SAT_STEP = 10
"""The bound is moved in steps of this (OpenCV saturation or value): a dye's region is searched at most six times."""
DYE_SAT_SHARE = 2.0
"""The bound moves only when the dye's region at the farthest bound is at least this many times the preset's pixels
in it (all of them: highlight stripes cut a painted liquid into pieces that the moved bound joins): a preset that
holds most of the dye leaves out its fringes, its highlights and the surface's pale reflection seen from above, which
are not the liquid's body."""
DYE_SAT_APART = 0.01
"""... and only when the pixels of the moved range more than 15 px away from the liquid number less than this share
of the pale pixels it adds to the liquid: Cycles' blue dyes on a white wall and a beige table had 0-0.004, orange and
yellow dyes on a noisy beige table 0.04-2."""


def _paler_bound(q: np.ndarray, core: np.ndarray, within: np.ndarray, bound: int, lowest: int) -> int:
    """A lower bound on `q` (a crop's saturation, or 255 - value) for the dye: the palest pixels (2nd percentile) of
    the region of `within` (the preset's other bounds) joined to its core (`core`, the crop's largest region in the
    preset's range) at the lowest floor, down from `bound` by DYE_SAT_REACH (never below `lowest`) in steps of
    DYE_SAT_STEP, whose region reaches no side of the crop the core does not (a table or wall of the dye's hue runs out
    of the picture); `bound` when that region is under DYE_SAT_SHARE times the preset's pixels in it or the pale colour
    is found away from it too (DYE_SAT_APART)."""

    def sides(region: np.ndarray) -> np.ndarray:
        return np.array([region[0].any(), region[-1].any(), region[:, 0].any(), region[:, -1].any()])

    reached, joined = sides(core), core
    for level in range(bound - DYE_SAT_STEP, max(lowest, bound - DYE_SAT_REACH) - 1, -DYE_SAT_STEP):
        _, labels = cv2.connectedComponents((within & (q >= level)).astype(np.uint8), connectivity=8)
        region = labels == np.bincount(labels[core]).argmax()
        if (sides(region) & ~reached).any():
            break
        joined = region
    held = np.count_nonzero(joined & within & (q >= bound))  # the preset's pixels in it, its every piece
    if np.count_nonzero(joined) < DYE_SAT_SHARE * held:  # the preset holds most of the dye
        return bound
    floor = min(bound, int(np.percentile(q[joined], 2)))  # the joined region's own palest pixels
    # pixels of that pale colour away from the liquid (a beige table's, of an orange dye's hue): its pale part cannot be
    # told from the background's
    apart = within & (q >= floor) & (cv2.dilate(joined.astype(np.uint8), np.ones((31, 31), np.uint8)) == 0)
    if np.count_nonzero(apart) > DYE_SAT_APART * np.count_nonzero(joined & (q < bound)):
        return bound
    return floor


SATURATED = (60, 40)
"""Least saturation and value (OpenCV HSV) of a pixel called coloured where no preset's range takes the dye."""
OWN_HUE_REACH = 8
"""The HSV range made for a colour no preset takes reaches this far (OpenCV hue, 0..179) either side of its median
hue: the presets' ranges are 14-35 wide."""


def coloured_regions(frame: np.ndarray, roi: tuple[int, int, int, int]):
    """The ROI's coloured pixels (SATURATED) as connected regions: the crop in HSV, the region labels, their stats
    (OpenCV's x, y, w, h, area rows) and their labels largest first."""
    x, y, w, h = roi
    hsv = cv2.cvtColor(frame[y : y + h, x : x + w], cv2.COLOR_BGR2HSV)
    coloured = ((hsv[..., 1] >= SATURATED[0]) & (hsv[..., 2] >= SATURATED[1])).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(coloured, connectivity=8)
    return hsv, labels, stats, sorted(range(1, n), key=lambda k: -stats[k, cv2.CC_STAT_AREA])


def darker_liquid(
    hsv: np.ndarray, stats: np.ndarray, order: list[int]
) -> tuple[tuple[int, int, int, int], HsvRange] | None:
    """Where no coloured region of a crop (`coloured_regions`: its HSV, region stats, order) covers MIN_LIQUID_SHARE of
    it, the largest region darker than the rest (Otsu's split of the value: a near-black liquid greyed by the light, or
    a grey one) that reaches neither side nor the top (a liquid stands in its container; a dark table or wall runs out
    of the picture), of at least that share: its box (x, y, w, h) and a range up to its brightest pixels (98th
    percentile). None when there is none, or a coloured region is large enough to be the liquid."""
    value = np.ascontiguousarray(hsv[..., 2])
    h, w = value.shape
    if order and stats[order[0], cv2.CC_STAT_AREA] >= MIN_LIQUID_SHARE * w * h:
        return None
    split, dark = cv2.threshold(value, 0, 255, cv2.THRESH_BINARY_INV + cv2.THRESH_OTSU)
    n, labels, regions, _ = cv2.connectedComponentsWithStats(dark, connectivity=8)
    inside = [
        k
        for k in range(1, n)
        if regions[k, cv2.CC_STAT_LEFT] > 0
        and regions[k, cv2.CC_STAT_TOP] > 0
        and regions[k, cv2.CC_STAT_LEFT] + regions[k, cv2.CC_STAT_WIDTH] < w
        and regions[k, cv2.CC_STAT_AREA] >= MIN_LIQUID_SHARE * w * h
    ]
    if not inside:
        return None
    k = max(inside, key=lambda j: regions[j, cv2.CC_STAT_AREA])
    ceiling = min(int(split), int(np.percentile(value[labels == k], 98)))
    box = cast("tuple[int, int, int, int]", tuple(int(v) for v in regions[k, :4]))
    return box, HsvRange((0, 0, 0), (179, 255, ceiling))


OWN_VALLEY_SHARE = 0.25
"""Two hue groups of a region are two colours only where the fewest pixels of a hue between their medians (a running
sum over 3 hues) number under this share of the smaller group's most (a dye's and a box's hues, 111 and 128: 40 of
5,300); a dye's hue spread over 20 units has no such valley and keeps its median."""


def _main_hue(hues: np.ndarray) -> float:
    """A region's hue (OpenCV, 0..179) as a circle's median: its median turned so that the widest run of hues it lacks
    lies at 0/179 (a red's 175-179 and 0-5 are one colour); or, where Otsu's split of its hues gives two groups whose
    medians lie further apart than OWN_HUE_REACH with a valley between them (`OWN_VALLEY_SHARE`), the larger group's:
    one range holds no two such colours, and a region of both is two objects joined (a faint blue dye and a violet box
    behind its glass)."""
    counts = np.bincount(hues.astype(int) % 180, minlength=180)
    runs = np.concatenate([counts, counts]) == 0
    shift, best, length = 0, 0, 0
    for k, gap in enumerate(runs):  # the end of the widest gap, going round the circle once more
        length = length + 1 if gap else 0
        if best < length <= 180:
            shift, best = (k + 1) % 180, length
    turned = (hues.astype(float) - shift) % 180
    centre = float(np.median(turned))
    if turned.size > 1:
        split, _ = cv2.threshold(np.ascontiguousarray(turned.astype(np.uint8)).reshape(-1, 1), 0, 179, cv2.THRESH_OTSU)
        low, high = turned[turned <= split], turned[turned > split]
        if low.size and high.size and float(np.median(high)) - float(np.median(low)) > OWN_HUE_REACH:
            histogram = np.convolve(np.roll(counts, -shift), np.ones(3), "same")
            a, b = int(np.median(low)), int(np.median(high))
            smaller = low if low.size < high.size else high
            peak = histogram[int(smaller.min()) : int(smaller.max()) + 1].max()
            if histogram[a : b + 1].min() < OWN_VALLEY_SHARE * peak:
                centre = float(np.median(low if low.size >= high.size else high))
    return (centre + shift) % 180


def own_range(pixels: np.ndarray) -> HsvRange:
    """The HSV box of one region's pixels (n x 3, OpenCV HSV): its hue (`_main_hue`) +- OWN_HUE_REACH, and from 10 below
    its 5th-percentile saturation and value (paler and darker pixels of the dye too), for a dye no preset's range takes (a
    faint dye below every preset's saturation). Its value starts above the `dark` preset's (shadows of the dye's hue,
    a holder's dark parts, are dark: they had joined a faint blue liquid to its holder and the picture's side)."""
    hue = _main_hue(pixels[:, 0])
    s_floor, v_floor = (int(np.percentile(pixels[:, c], 5)) - 10 for c in (1, 2))
    low = (int(hue - OWN_HUE_REACH) % 180, max(20, s_floor), max(PRESETS["dark"].hsv.high[2] + 1, v_floor))
    return HsvRange(low, (int(hue + OWN_HUE_REACH) % 180, 255, 255))


def _crossings_first(m: np.ndarray, above: np.ndarray, axis: int, level: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel position of the first `level` crossing of m along `axis` (from index 0), and whether there is one;
    `above` is the same view of m >= level (as `_inside` gives it for 0.5)."""
    j = np.argmax(above, axis=axis)  # 0 where there is no crossing
    other = np.arange(m.shape[1 - axis])
    jm = np.maximum(j - 1, 0)
    if axis == 0:
        ok, a, b = (above[j, other] > 0) & (j > 0), m[jm, other], m[j, other]
    else:
        ok, a, b = (above[other, j] > 0) & (j > 0), m[other, jm], m[other, j]
    frac = np.where(b > a, (level - a) / np.where(b > a, b - a, 1), 0.5)
    return jm + frac, ok


def refine_on_luma(
    gray: np.ndarray, pos: np.ndarray, ok: np.ndarray, reach: int = 6, cols: np.ndarray | None = None
) -> np.ndarray:
    """Move each column's edge estimate `pos` (rows of `gray`, sub-pixel) to the luma profile's mid-level crossing.

    Compression keeps colour at half resolution and in coarse blocks, but luma (`gray`, 8 bit) at full resolution:
    the edge is where the column's luma passes halfway between its levels `reach` pixels before and after the
    estimate (the crossing closest to the estimate). Columns without that contrast keep their estimate.
    `cols`: the column of `gray` each estimate is in (default: one estimate per column; a column may come twice).
    """
    refined, good = _luma_crossings(gray, pos, ok, reach, cols)
    return np.where(good, refined, pos)


def _luma_crossings(
    gray: np.ndarray, pos: np.ndarray, ok: np.ndarray, reach: int = 6, cols: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """`refine_on_luma`'s crossings and where they hold (the column has the contrast, its window fits the picture)."""
    n = gray.shape[0]
    if n <= 2 * reach:  # no column has the levels' rows on both sides
        return pos.copy(), np.zeros(pos.shape, bool)
    base = np.rint(pos).astype(np.intp)
    # a column whose window leaves the picture keeps its estimate: its window is moved inside, whatever it reads
    inner = (base >= reach) & (base < n - reach)
    offs = np.arange(-reach, reach + 1)
    rows = np.minimum(np.maximum(base, reach), n - 1 - reach) + offs[:, None]
    cols = np.arange(gray.shape[1]) if cols is None else cols
    prof = gray[rows, cols].astype(np.float32)
    n_lvl = max(1, reach // 2)  # the outer samples give the two levels
    lo, hi = prof[:n_lvl].sum(axis=0) / n_lvl, prof[-n_lvl:].sum(axis=0) / n_lvl
    mid = 0.5 * (lo + hi)
    d = prof - mid
    cross = (d[:-1] * d[1:] <= 0) & (d[:-1] != d[1:])
    dist = np.where(cross, np.abs(offs[:-1, None] + 0.5 - (pos - base)[None, :]), np.inf)
    i = np.argmin(dist, axis=0)
    at = np.arange(pos.size)
    d0, d1 = d[i, at], d[i + 1, at]
    frac = np.where(d0 != d1, d0 / np.where(d0 != d1, d0 - d1, 1), 0.5)
    refined = base + offs[i] + frac
    good = ok & inner & np.isfinite(dist[i, at]) & (np.abs(hi - lo) >= 12)
    return refined, good


class SurfaceFinder:
    """Stateful per-video surface measurement: follows the liquid body from frame to frame."""

    def __init__(self, hsv: HsvRange | None, roi: tuple[int, int, int, int]) -> None:
        self.hsv = hsv
        self.roi = roi
        self._box: tuple[int, int, int, int] | None = None  # last liquid body box (x0, y0, x1, y1)
        self._model: tuple[np.ndarray, float] | None = None
        self._since_fit = 0
        self._k: list[float] = []  # k / R = sin(elevation) from the first frames
        self._e: list[float] = []  # the ellipse's centre from the walls' midpoint (half widths) from the first frames
        self._q: list[float] = []  # those frames' qualities
        self._refits: list[Callable] = []  # those frames' measurements again with a given elevation
        self._held: tuple[float, float] | None = None  # the medians of both, once there are enough
        self._scatter: list[tuple] = []  # the first frames' edge scatter (rms px), then fit quality, per EDGE_SOURCES
        self._levelled: list[tuple] = []  # the first frames' (k / R, centre) on the low and high sources
        self._edges: str | None = None  # the front edge's source (one of EDGE_SOURCES), held with the elevation
        # (body sides and bottom, axes in frame coordinates, frames they were used in, frames they may be used in)
        self._axes: tuple | None = None
        self._last: SurfaceMeasurement | None = None  # the last frame's, when found
        self._anchor: tuple | None = None  # (strip where the container's sides and bottom are, its centre, values)
        self._sink = 0.0  # how far the front edge's lowest point sank from the frame before to the last one
        self.elsewhere: tuple | None = None  # (area, (x, y, w, h)) of the largest region of the dye's colour left out
        self._fit_level: float | None = None  # the liquid's mean grey level when the colour model was fitted

    @property
    def box(self) -> tuple[int, int, int, int] | None:
        """The liquid body's box (x0, y0, x1, y1) in the last frame measured, None when it was not found."""
        return self._box

    def copied(self) -> None:
        """A frame that copied the last measured picture (`Copies`) was not measured: it counts toward the colour
        model's refit as one that was (REFIT_EVERY frames of video, whatever the encoder repeated)."""
        self._since_fit += 1

    def measure(self, frame: np.ndarray) -> SurfaceMeasurement:
        """Measure the surface in one BGR frame."""
        if self.hsv is None:
            self.hsv = auto_liquid_range(frame, self.roi)
            if self.hsv is None:
                return SurfaceMeasurement(False)
        self._since_fit += 1
        # the camera's exposure moved: fitted again now (not again within EXPOSURE_EVERY frames: a flickering light)
        if self._fit_level is not None and self._box is not None and self._since_fit > EXPOSURE_EVERY:
            level = _liquid_level(frame, self._box)
            if abs(level - self._fit_level) > EXPOSURE_SHARE * self._fit_level:
                self._since_fit = REFIT_EVERY
        m = self._measure_band(frame) if self._band_ready() else None
        if m is None and self._box is not None:
            m = self._follow(frame, self._box)
        if m is None:  # lost, or the body left the box it had: search around it (or the whole ROI)
            box = self._find_body(frame)
            m = None if box is None else self._follow(frame, box)
            if m is None:  # the box as found (a whole-body measurement returns a measurement, found or not)
                m = (None if box is None else self._measure_body(frame, box, follow=False)) or SurfaceMeasurement(False)
                if box is not None and (not m.found or _walls_beyond(m, self._window(box, frame.shape))):
                    m = self._wider(frame, box) or m
        if not m.found:
            self._box = None
        self._sink = max(0.0, m.low - self._last.low) if m.found and self._last is not None else 0.0
        if m.found and self._held is None:
            self._k.append(m.opening_px / m.width_px)  # k / R, while the elevation is still being fitted
            self._e.append(m.centre_shift)
            self._q.append(m.quality)
            if m.refit is not None:
                self._refits.append(m.refit)
        self._last = m if m.found else None
        return m

    def _follow(self, frame: np.ndarray, box: tuple[int, int, int, int]) -> SurfaceMeasurement | None:
        """The body read off the membership map around `box`, and again with the box reaching half its width further
        down (up to FOLLOW_DOWN times) while the liquid goes on below it (a box from the preset's colour range, which
        loses a dark dye's lower part, had grown by a tenth a frame); None when the body is not there."""
        x0, y0, x1, y1 = box
        m = self._measure_body(frame, box, follow=True)
        for down in range(1, FOLLOW_DOWN + 1):
            if m is not None or y1 + (down - 1) * (x1 - x0) // 2 >= self.roi[1] + self.roi[3]:
                break
            m = self._measure_body(frame, (x0, y0, x1, y1 + down * (x1 - x0) // 2), follow=True)
        return m

    def _wider(self, frame: np.ndarray, box: tuple[int, int, int, int]) -> SurfaceMeasurement | None:
        """`_follow` with `box` reached FOLLOW_SIDE of its width further out on each side, or None: a dark preset's
        range holds a rendered cola's darker core only, and its box cut the liquid's sides (and bottom). When that
        finds no surface, the box is reached further (up to WIDER_REACH times as far) with the colour model fitted
        again there, on a copy adopted only when it finds one: a model fitted in a box that cut the sides leaves
        them out too (a cola's core at twice the resolution)."""
        x0, y0, x1, y1 = box
        rx, rw = self.roi[0], self.roi[2]
        m = None
        for reach in range(WIDER_REACH + 1):
            pad = int(max(reach, 1) * FOLLOW_SIDE * (x1 - x0))
            wide = (max(rx, x0 - pad), y0, min(rx + rw, x1 + pad), y1)
            if wide == box:
                return m
            trial = self if reach == 0 else copy.deepcopy(self)
            if reach:
                trial._since_fit = REFIT_EVERY
            got = trial._follow(frame, wide)
            if got is not None and got.found:
                self.__dict__.update(trial.__dict__)
                return got
            if reach == 0:
                m = got
        return m

    def settled(self) -> tuple[tuple[float, float] | None, str]:
        """The camera's elevation (k / R = its sine) with the surface ellipse's centre (`centre_shift`), and the front
        edge's source, as held after the first frames, or as the frames so far give them when fewer than
        HOLD_ELEVATION_AFTER were measured (None before any)."""
        if self._held is not None:
            return self._held, self._edges or self._edge_source()
        if not self._k:
            return None, self._edge_source()
        source = self._edge_source()
        return self._elevation(source), source

    def _elevation(self, source: str) -> tuple[float, float]:
        """The medians of the first frames' elevation (k / R) and ellipse centre, over those measured validly when
        any was: on a faint dye most frames' own fits, by their noise alone, read the ellipse less than half as open
        and under the valid quality (0.26 against 0.58), and outnumbered the frames that read it right. A low or high
        source (`source`) has them from its own fits."""
        if source.endswith((" low", " high")):
            i = EDGE_SOURCES.index(source)  # its quality follows the sources' scatters; its fits, the low and high ones
            q = np.array([v[len(EDGE_SOURCES) + i] for v in self._scatter])
            k, e = np.array([v[i - 2] for v in self._levelled]).T
            sure = q >= VALID_QUALITY
            return median(k[sure]), median(e[sure])
        q = np.array(self._q)
        sure = q >= VALID_QUALITY if (q >= VALID_QUALITY).any() else np.ones(q.size, bool)
        # np.median would import numpy.ma (40 ms) in every span worker
        k, e = np.array(self._k), np.array(self._e)
        return _best_reading((median(k[sure]), median(e[sure])), k, e, sure, self._refits, source)

    def _find_body(self, frame: np.ndarray) -> tuple[int, int, int, int] | None:
        """Box of the largest liquid-coloured region near the last one (or in the whole ROI after a loss)."""
        if self.hsv is None:  # `measure` chooses the colour first
            return None
        hsv = self.hsv
        rx, ry, rw, rh = self.roi
        X0, Y0, X1, Y1 = rx, ry, rx + rw, ry + rh
        if self._box is not None:
            x0, y0, x1, y1 = self._box
            mx, my = 8 + 0.1 * (x1 - x0), 8 + 0.1 * (y1 - y0)
            X0, Y0 = max(X0, int(x0 - mx)), max(Y0, int(y0 - my))
            X1, Y1 = min(X1, int(x1 + mx) + 1), min(Y1, int(y1 + my) + 1)
        # the box only bounds the search: half resolution finds it four times faster, to within 2 px
        small = cv2.resize(frame[Y0:Y1, X0:X1], None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
        mask = cv2.morphologyEx(hsv_mask(small, hsv), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if n <= 1:
            return None
        areas = 4 * stats[1:, cv2.CC_STAT_AREA]  # full-resolution pixels
        if areas.max() < MIN_LIQUID_SHARE * rw * rh and self._box is None:
            return None
        # highlight stripes cut the body into side-by-side pieces: the box holds every sizeable piece beside the largest
        sizeable = 1 + np.flatnonzero(areas >= 0.1 * areas.max())
        pieces = stats[sizeable]
        one = _beside(pieces)
        for x, y, w, h, area in pieces[~one]:  # another object of the dye's colour: the largest is named in a warning
            if self.elsewhere is None or 4 * area > self.elsewhere[0]:
                self.elsewhere = (4 * int(area), (X0 + 2 * int(x), Y0 + 2 * int(y), 2 * int(w), 2 * int(h)))
        # the container's part of them: a holder or table of the dye's colour below it is left out
        column = _column_box(np.isin(labels, sizeable[one]), (0, 0), bottom_open=True)
        if column is None:  # the liquid reaches the picture's side: the caller finds no walls in the pieces' box
            big = pieces[one]
            column = big[:, 0].min(), big[:, 1].min(), (big[:, 0] + big[:, 2]).max(), (big[:, 1] + big[:, 3]).max()
        bx0, by0, bx1, by1 = (2 * int(v) for v in column)
        return X0 + bx0, Y0 + by0, X0 + bx1, Y0 + by1

    def _window(
        self, box: tuple[int, int, int, int], shape: tuple, headroom: float = HEADROOM
    ) -> tuple[int, int, int, int]:
        """Frame box (X0, Y0, X1, Y1) mapped around a liquid body box: its sides and bottom with a margin, and
        `headroom` (share of its width) above its top; inside the ROI (the whole picture by default)."""
        x0, y0, x1, y1 = box
        rx, ry, rw, rh = self.roi
        pad, up = 6 + int(0.03 * (x1 - x0)), 6 + int(headroom * (x1 - x0))
        X0, Y0 = max(0, rx, x0 - pad), max(0, ry, y0 - up)
        return X0, Y0, min(shape[1], rx + rw, x1 + pad), min(shape[0], ry + rh, y1 + pad)

    def _band_ready(self) -> bool:
        """The next frame can be measured in a band: the container's axes are held (it stood still), the last frame
        was measured and no colour refit is due (a refit reads the whole body)."""
        held = self._axes
        return (
            self._last is not None
            and held is not None
            and held[2] < held[3]
            and self._anchor is not None
            and self._since_fit < REFIT_EVERY
        )

    def _measure_band(self, frame: np.ndarray) -> SurfaceMeasurement | None:
        """The surface of a container that stands still, from the rows around it: the body's membership is mapped
        down to BAND_BELOW below the last frame's front edge, and a thin strip across the bottom confirms that the
        walls and the bottom stayed where they were. None when that cannot be trusted: the strip changed by
        ANCHOR_PX, the liquid rose to the top of the band or its fitted front edge came within half the margin of
        the band's bottom; the whole body is measured then."""
        axes, anchor, model, last, box = self._axes, self._anchor, self._model, self._last, self._box
        if axes is None or anchor is None or model is None or last is None or box is None:  # `_band_ready` says not
            return None
        key, geom, used, may = axes
        (sx0, sy0, sx1, sy1), centre, reference = anchor
        # the strip before the band (which stays the picture's converted box), with a row beyond it each way: mapped
        # as in the whole body's map, where its pixels' neighbours are real
        now = _anchor_values(membership_map(frame[sy0 - 1 : sy1 + 1, sx0:sx1], model[0])[1:-1], centre)
        if now is None or np.abs(now - reference).max() > ANCHOR_PX:
            self._axes = None  # the container moved: its axes are measured again
            return None
        x0, _y0, x1, y1 = box
        X0, Y0, X1, Y1 = self._window(box, frame.shape)
        margin = max(BAND_BELOW, 0.05 * (x1 - x0)) + 2 * self._sink
        crop = frame[Y0 : min(Y1, math.ceil(last.low + margin)), X0:X1]
        body = membership_map(crop, model[0])
        inside = _inside(body)
        top = int(_liquid_rows(inside)[1][0])  # the body's top, as `_body_box` finds it
        if top == 0:
            return None
        gray = cv2.cvtColor(crop, cv2.COLOR_BGR2GRAY)
        m = self._surface(gray, body, inside, (X0, Y0), _shifted(geom, (-X0, -Y0)))
        if not m.found or m.low > Y0 + crop.shape[0] - margin / 2:
            return None
        self._box = (x0, Y0 + top, x1, y1)
        self._axes = (key, geom, used + 1, may)
        m.still = True
        return m

    def _measure_body(
        self, frame: np.ndarray, box: tuple[int, int, int, int], follow: bool
    ) -> SurfaceMeasurement | None:
        """Walls, bottom and surface of the liquid body in `box`; the box it was found in is kept for the next frame.

        `follow`: `box` is the last frame's; the body's box is read off this frame's membership map around it
        (a tenth of the cost of a colour search), or None is returned when the body reaches the map's edge."""
        rx, _ry, rw, _rh = self.roi
        # the liquid reaches the side of the picture: no walls to measure (when following, its column's box is asked:
        # a holder or table of the dye's colour may run out of the picture below a liquid standing inside it)
        if not follow and (box[0] <= rx or box[2] >= rx + rw):
            return SurfaceMeasurement(False, liquid=True)
        X0, Y0, X1, Y1 = self._window(box, frame.shape)
        refit = self._model is None or self._since_fit >= REFIT_EVERY
        if refit:
            # FIT_HEADROOM above the liquid (converted first: the crop below is then a view of it), every second
            # pixel each way: thousands of body and background pixels still fix the four coefficients
            fy0 = self._window(box, frame.shape, FIT_HEADROOM)[1]
            half = frame[fy0:Y1, X0:X1][::2, ::2]
            if self.hsv is None:  # `measure` chooses the colour first
                return SurfaceMeasurement(False)
            greys = GREY_WEIGHT if self.hsv.low[1] > 0 else 0.0  # a range that holds greys makes them liquid
            self._model, self._since_fit = fit_colour_model(half, hsv_mask(half, self.hsv), greys), 0
            self._fit_level = _liquid_level(frame, box)
        crop = frame[Y0:Y1, X0:X1]
        if self._model is None:
            return SurfaceMeasurement(False, liquid=True)
        body = membership_map(crop, self._model[0])
        inside = _inside(body)
        if follow:
            column = _column_box(inside, (X0, Y0))
            if column is None:
                return None
            box = column
            if box[0] <= rx or box[2] >= rx + rw:
                return SurfaceMeasurement(False, liquid=True)
        self._box = box
        gray = cv2.cvtColor(crop, cv2.COLOR_BGR2GRAY)
        key = (box[0], box[2], box[3])  # the body's sides and bottom: where the container is
        held = self._axes
        if held is not None and held[0] == key and held[2] < held[3] and not refit:
            frame_geom = _shifted(held[1], (-X0, -Y0))
            self._axes = (key, held[1], held[2] + 1, held[3])
        else:
            frame_geom = _container_axes(body, inside, gray, frame, (X0, Y0), box)
            if frame_geom is None:
                self._axes = None
                return SurfaceMeasurement(False, liquid=True)
            geom = _shifted(frame_geom, (X0, Y0))
            still = held is not None and not refit and _moved_px(held[1], geom) < STILL_PX
            self._axes = (key, geom, 1, HOLD_AXES_FRAMES if still else 0)
        # the strip a band frame watches, when one may follow (the axes are held)
        self._anchor = _anchor(body, frame_geom, (X0, Y0)) if self._axes[2] < self._axes[3] else None
        return self._surface(gray, body, inside, (X0, Y0), frame_geom)

    def _surface(self, gray, body, inside, origin, geom) -> SurfaceMeasurement:
        """Front edge per column in container coordinates, robust fit of mid-line and ellipse, line and wall heights."""
        X0, Y0 = origin
        walls, o, e_u, e_w = geom
        (aL, bL), (aR, bR) = walls
        # the axes as plain numbers: the few points below cost a microsecond each this way, ten as arrays
        (ox, oy), (eux, euy), (ewx, ewy) = (map(float, v) for v in (o, e_u, e_w))
        first = int(np.argmax(inside.ravel())) // body.shape[1]  # the liquid's top row: its first pixel's
        if first == 0 and max(self.roi[1], 0) == Y0:  # the ROI's (or the picture's) top cuts the liquid off
            return SurfaceMeasurement(False, liquid=True)
        ytop = float(first)
        uL = (aL * ytop + bL - ox) * eux + (ytop - oy) * euy
        uR = (aR * ytop + bR - ox) * eux + (ytop - oy) * euy
        half, uc = 0.5 * (uR - uL), 0.5 * (uR + uL)
        margin = max(4.0, WALL_MARGIN * 2 * half)
        # the columns between the walls at the liquid's top, in the map: a container tilted in the picture has one
        # wall's top beyond the liquid there (its columns hold no surface); `inner` keeps the margin along the walls
        lo_col = max(0, math.ceil(aL * ytop + bL + margin))
        hi_col = min(body.shape[1], int(aR * ytop + bR - margin))
        cols = np.arange(lo_col, hi_col, max(1, -(-(hi_col - lo_col) // MAX_COLUMNS)))
        if half < 10 or len(cols) < 12:
            return SurfaceMeasurement(False, liquid=True)
        inner = 1 - margin / half
        span = slice(cols[0], cols[-1] + 1, cols[1] - cols[0])  # views, not copies: the columns are evenly spaced
        start = max(0, first - 1)  # no row above the top one crosses; one row of it keeps a crossing there found
        # how far below its first crossing a column's front edge is looked for: the held ellipse's height (its size:
        # read on the back edge, k is negative), or the largest looked for before it is held
        reach = 2 * half * (MAX_ELEVATION_SIN if self._held is None else abs(self._held[0])) + 3
        # the elevation and the edge source are chosen in the first frames and then held (a static camera, one dye)
        if self._held is None and len(self._k) >= HOLD_ELEVATION_AFTER:
            self._edges = self._edge_source()
            self._held = self._elevation(self._edges)
        du, n = cols - ox, max(10, len(cols) // 3)

        def edge_points(level: float, sources: tuple[str, ...]) -> dict:
            """Per edge source in `sources`: (s, w, usable columns, dw, the edge rows, sure share) of the first
            crossings of `level` and of those below them."""
            # a level under 0.5 crosses above the liquid's top row: its own top row then
            top = start if level >= 0.5 else max(0, int(np.argmax((body[:, span] >= level).any(axis=1))) - 1)
            crop = body[top:, span]
            liquid = crop >= level if level != 0.5 else inside[top:, span]
            held_rows = _sustained(liquid)
            colour, found = _crossings_first(crop, held_rows, axis=0, level=level)
            below, gap = _front_below(crop, liquid, held_rows, colour, found, reach, level)
            colour += top
            below += top
            points = {}
            for source in sources:
                edges = []
                for rows, sure in ((colour, found), (below, gap)) if gap.any() else ((colour, found),):
                    front = refine_on_luma(gray[:, span], rows, found) if source.startswith("luma") else rows
                    dw = front - oy
                    wv = du * ewx + dw * ewy
                    sv = (du * eux + dw * euy - uc) / half
                    usable = _continuous(wv, found & (np.abs(sv) <= inner), cols)
                    usable &= _locally_consistent(wv, usable)
                    share = np.count_nonzero(sure & usable) / max(int(np.count_nonzero(usable)), 1)
                    edges.append((sv, wv, usable, dw, front, share))
                points[source] = tuple(edges)
            return points

        def sourced_points(sources: tuple[str, ...]) -> dict:
            """`edge_points` of each source at its own level (`_source_level`), each level's crossings found once."""
            points: dict = {}
            for level in dict.fromkeys(_source_level(x) for x in sources):
                points |= edge_points(level, tuple(x for x in sources if _source_level(x) == level))
            return points

        held_sources = EDGE_SOURCES if self._edges is None else (self._edges,)
        points = sourced_points(held_sources)
        if self._edges is None:  # how much each source's first crossings scatter about a free fit of them
            fits = [_fit_front(p[0][0][p[0][2]], p[0][1][p[0][2]], n) for p in (points[x] for x in EDGE_SOURCES)]
            if fits[0] and fits[1]:
                best = [_best_front(points[x], n, half, None) for x in EDGE_SOURCES]
                self._scatter.append(
                    tuple(math.inf if f is None else f[2] for f in fits)
                    + tuple(0.0 if b is None else b[0] for b in best)
                )
                # the low and high sources' own elevation and centre, held with them when they are chosen
                self._levelled.append(
                    tuple((math.nan, 0.0) if b is None else (b[1][0][3] / half, b[1][0][4]) for b in best[2:])
                )
        # the measurement from these edge points with a given elevation and centre (None: fitted with them) and edge
        # source; a partial of a plain function, not a closure, so a span worker's step can be sent to the parent
        fitted = partial(_fitted, points, n, geom, (X0, Y0), (ytop, uL, uR, du))
        source = self._edges or "luma"
        m = fitted(self._held, source)
        if not m.found:  # the surface ellipse seen from above reads as half liquid (a pale sheen over a juice)
            points = edge_points(PLATEAU_LEVEL, held_sources)
            fitted = partial(_fitted, points, n, geom, (X0, Y0), (ytop, uL, uR, du))
            m = fitted(self._held, source)
        if self._edges is not None and m.quality < VALID_QUALITY:
            # a frame the held source misses is read on the other (a moving juice's luma edge blurred), a held low
            # one's also at 0.5 (a glow that ran onto the 0.5 crossings moves off), its points under the held source's
            # name: the span's later refits in other axes ask for that one
            alts = (OTHER_SOURCE[source], "luma", "colour") if source.endswith(" low") else (OTHER_SOURCE[source],)
            found_alts = sourced_points(alts)  # each level's crossings found once
            for alt in alts:
                other = {source: found_alts[alt]}
                again = partial(_fitted, other, n, geom, (X0, Y0), (ytop, uL, uR, du))
                m_other = again(self._held, source)
                if m_other.quality > m.quality:
                    points, fitted, m = other, again, m_other
        if m.found:
            fronts = np.concatenate([front[ok] for _, _, ok, _, front, _ in points[source]])
            m.band, m.luma = _band(fronts, cols, (X0, Y0)), (gray, (X0, Y0))
            m.refit = fitted if self._held is None else None
            m.axes = _shifted(geom, (X0, Y0))
            m.in_axes = partial(_in_axes, points, n, (X0, Y0), ytop, cols)
        return m

    def _edge_source(self) -> str:
        """'colour' when the first frames' luma-refined front edges scattered about their fits by more than
        LUMA_EDGE_SCATTER and more than those on the colour alone (median rms), else 'luma'. Over at least
        LOW_MIN_FRAMES first frames: its high source instead where that fitted validly and clearly better than a poor
        fit of the 0.5 crossings, and scattered less (HIGH_BASE_QUALITY, HIGH_QUALITY_GAIN); else its low source where
        that scattered less (LOW_SCATTER_SHARE, LOW_BASE_SCATTER_PX) and fitted validly and nearly as well
        (LOW_QUALITY_MARGIN; median quality); else the cleaner low source where both 0.5 crossings scattered and it
        fitted better (LOW_CLEAN_PX)."""
        if not self._scatter:
            return "luma"
        rms, quality = np.split(np.array([median(np.array(v)) for v in zip(*self._scatter)]), 2)
        i = 1 if rms[0] > max(LUMA_EDGE_SCATTER, rms[1]) else 0  # the colour, or the luma
        if len(self._scatter) < LOW_MIN_FRAMES:
            return EDGE_SOURCES[i]
        poor = rms[i] <= LOW_BASE_SCATTER_PX and quality[i] < HIGH_BASE_QUALITY
        if poor and quality[i + 4] >= max(VALID_QUALITY, quality[i] + HIGH_QUALITY_GAIN) and rms[i + 4] < rms[i]:
            return EDGE_SOURCES[i + 4]
        mixed = rms[i] <= LOW_BASE_SCATTER_PX and rms[i + 2] < LOW_SCATTER_SHARE * rms[i]
        if mixed and quality[i + 2] >= max(VALID_QUALITY, quality[i] - LOW_QUALITY_MARGIN):
            return EDGE_SOURCES[i + 2]
        j = 2 + int(np.argmin(rms[2:4]))  # the cleaner low crossing, where both 0.5 crossings run onto another edge
        clean = min(rms[:2]) > LOW_BASE_SCATTER_PX and rms[j] <= LOW_CLEAN_PX
        clean &= quality[j] >= VALID_QUALITY and quality[j] > quality[i]
        return EDGE_SOURCES[j] if clean else EDGE_SOURCES[i]


def _best_reading(held, k, e, sure, refits, source: str) -> tuple[float, float]:
    """`held` (the first frames' median elevation and centre) or, where those of its sign split by over ELEVATION_GAP,
    the group's that fits every first frame best (`refits`) by ELEVATION_GAIN; a front and a back edge (k's sign) are
    not compared: a cola's two front-edge frames fitted better than its back edge and read 0.11 deg worse."""
    same = np.flatnonzero(sure & (np.sign(k) == np.sign(held[0])))
    order = same[np.argsort(k[same])]
    groups = np.split(order, np.flatnonzero(np.diff(k[order]) > ELEVATION_GAP) + 1)
    if len(groups) < 2 or len(refits) != k.size:
        return held

    def fit(c: tuple[float, float]) -> float:
        return median(np.array([m.quality if m.found else 0.0 for m in (r(c, source) for r in refits)]))

    score, best = max((fit(c), c) for c in ((median(k[g]), median(e[g])) for g in groups))
    return best if score > fit(held) + ELEVATION_GAIN else held


def _source_level(source: str) -> float:
    """The membership level an edge source (one of EDGE_SOURCES) crosses: LOW_LEVEL, PLATEAU_LEVEL or 0.5."""
    return LOW_LEVEL if source.endswith(" low") else PLATEAU_LEVEL if source.endswith(" high") else 0.5


def _fitted(points, min_points, geom, origin, where, held, source) -> SurfaceMeasurement:
    """Robust fit of the front edge points (`_surface`'s, from `source`) with the elevation and the ellipse's centre
    `held` ((k / R, centre_shift); None: fitted with them), and the line, wall heights and overlay points from it."""
    X0, Y0 = origin
    walls, o, e_u, e_w = geom
    (aL, _), (aR, _) = walls
    (ox, oy), (eux, euy), (ewx, ewy) = (map(float, v) for v in (o, e_u, e_w))
    ytop, uL, uR, du = where
    half, uc = 0.5 * (uR - uL), 0.5 * (uR + uL)
    best = _best_front(points[source], min_points, half, held)
    if best is None:
        return SurfaceMeasurement(False, liquid=True)
    # the ellipse ends where the surface's line meets the walls: a tapered glass turned in the picture, or a surface
    # tilted against a tapered glass's axis, has its walls nearer the axis at one end than the row `ytop` reads
    ends = _walls_on_line(geom, uc, best[1][0][0], (best[1][0][1] + LINE_SLOPE_OF_CUBIC * best[1][0][2]) / half)
    if ends is not None and max(abs(ends[0] - uL), abs(ends[1] - uR)) > WALL_END_PX:
        (uL, uR), old = ends, (half, uc)
        half, uc = 0.5 * (uR - uL), 0.5 * (uR + uL)
        moved = [((s * old[0] + old[1] - uc) / half, *rest) for s, *rest in points[source]]
        best = _best_front(moved, min_points, half, held) or best
    quality, ((c0, c1, c3, k, e), _, _), ok, dw = best
    left, right = c0 - c1 - c3, c0 + c1 + c3
    to_img = lambda uu, ww: (X0 + ox + uu * eux + ww * ewx, Y0 + oy + uu * euy + ww * ewy)  # noqa: E731
    line = c1 + LINE_SLOPE_OF_CUBIC * c3
    # the fitted front edge in every column (also where none was found), at the found edges' typical height
    u_all = du * eux + median(dw[ok]) * euy
    s_all = (u_all - uc) / half
    s2 = s_all * s_all
    fitted = c0 + (c1 + c3 * s2) * s_all - k * np.sqrt(np.maximum(1 - s2, 0))
    low = Y0 + oy + float(np.max(u_all * euy + fitted * ewy))
    pl, pr, pc = to_img(uL, left), to_img(uR, right), to_img(uc, c0)
    line_l, line_r = to_img(uL, c0 - line), to_img(uR, c0 + line)
    y_lo, y_hi = Y0 + ytop, Y0 + oy
    wall_lines = tuple((a, b + X0 - a * Y0, y_lo, y_hi) for a, b in walls)
    return SurfaceMeasurement(
        True,
        True,
        (c1 + LINE_SLOPE_OF_CUBIC * c3) / half,
        math.degrees(float(_axis_angle(aL, aR))),
        float(left),
        float(right),
        float(2 * half),
        float(2 * k),
        float(pc[0]),
        float(pc[1]),
        float(quality),
        wall_lines,
        (line_l, line_r, pl, pr),
        low=low,
        centre_shift=float(e),
    )


def _best_front(edges, min_points: int, half: float, held):
    """(quality, fit, usable, dw) of the best of `edges`: the first crossings, or those below them where the first ones
    fit under the valid quality and those better (a thin rim of the dye along the surface ellipse's back edge holds
    the first crossings of a low camera's picture; a label's straight top below a faint dye's surface fits well too, so
    a valid fit of the first crossings is kept), or None."""
    best = None
    for s, wv, ok, dw, _, sure in edges:
        fit = _fit_front(s[ok], wv[ok], min_points, half, None if held is None else (held[0] * half, held[1]))
        if fit is not None:
            # below the first crossings, a column without a gap may still show the back edge: it counts as unsure
            rms = fit[2] * min(1.0, QUALITY_HALF_PX / half)  # a larger picture's edge spreads over more pixels
            score = (0.5 + 0.5 * sure) * np.count_nonzero(fit[1]) / ok.size * min(1.0, max(0.0, 1.5 - rms))
            if best is None or (best[0] < VALID_QUALITY and score > best[0]):
                best = (score, fit, ok, dw)
    return best


def _walls_beyond(m: SurfaceMeasurement, window: tuple[int, int, int, int]) -> bool:
    """Whether a wall `m` measured lies outside the window its liquid was mapped in (at the window's middle row): the
    liquid's sides were not in it, and the walls came from the glass beyond them (`_glass_sides`)."""
    X0, Y0, X1, Y1 = window
    y = 0.5 * (Y0 + Y1)
    (aL, bL, *_), (aR, bR, *_) = m.walls
    return aL * y + bL < X0 or aR * y + bR > X1


def _spread_deg(lines: np.ndarray) -> float:
    """How far apart two walls x = a y + b (the rows of `lines`) lean, degrees."""
    return float(abs(np.degrees(np.arctan(lines[0, 0]) - np.arctan(lines[1, 0]))))


def _axis_angle(aL, aR):
    """The container's axis (rad, CCW as seen from the image vertical) from its walls' slopes x = a y + b: their angles'
    mean. Their slopes' mean turns a tapered glass's axis toward its more leaning wall (0.07 deg at a 7 deg turn)."""
    return 0.5 * (np.arctan(aL) + np.arctan(aR))


def _walls_on_line(geom: tuple, uc: float, wc: float, slope: float) -> tuple[float, float] | None:
    """Where the line w = wc + slope (u - uc) (container axes) meets each wall: (uL, uR) along e_u, or None."""
    walls, o, e_u, e_w = geom
    (ox, oy), (eux, euy), (ewx, ewy) = (map(float, v) for v in (o, e_u, e_w))
    ends = []
    for a, b in walls:  # the wall's point in row y: u = au y + bu, w = aw y + bw
        au, bu = a * eux + euy, (b - ox) * eux - oy * euy
        aw, bw = a * ewx + ewy, (b - ox) * ewx - oy * ewy
        if abs(aw - slope * au) < 1e-9:
            return None
        y = (wc + slope * (bu - uc) - bw) / (aw - slope * au)
        ends.append(au * y + bu)
    return ends[0], ends[1]


def _in_axes(points, min_points, origin, ytop, cols, axes, held, source) -> SurfaceMeasurement:
    """The front edge points (`_surface`'s, found in the crop at `origin`) fitted again in other axes (`axes`, frame
    coordinates): the same image points, their (s, w) and the walls at the liquid's top anew."""
    X0, Y0 = origin
    geom = _shifted(axes, (-X0, -Y0))
    ((aL, bL), (aR, bR)), o, e_u, e_w = geom
    (ox, oy), (eux, euy), (ewx, ewy) = (map(float, v) for v in (o, e_u, e_w))
    uL = (aL * ytop + bL - ox) * eux + (ytop - oy) * euy
    uR = (aR * ytop + bR - ox) * eux + (ytop - oy) * euy
    half, uc = 0.5 * (uR - uL), 0.5 * (uR + uL)
    if half < 10:
        return SurfaceMeasurement(False, liquid=True)
    inner = 1 - max(4.0, WALL_MARGIN * 2 * half) / half
    du = cols - ox
    moved = {}
    for name, edges in points.items():
        again = []
        for _, _, usable, _, front, share in edges:
            dw = front - oy
            sv = (du * eux + dw * euy - uc) / half
            again.append((sv, du * ewx + dw * ewy, usable & (np.abs(sv) <= inner), dw, front, share))
        moved[name] = tuple(again)
    m = _fitted(moved, min_points, geom, origin, (ytop, uL, uR, du), held, source)
    if m.found:
        m.axes = axes
    return m


def steady_axes(axes: list[tuple]) -> tuple | None:
    """The median of the axes of a container that stood still (frame coordinates), or None when they show a move.

    A sloshing liquid's sides, from which the axes are read, turn the walls by up to degrees from frame to frame
    (a meniscus, the light below the surface, a label cutting them), and each frame's surface was fitted in its own:
    its line and wall heights follow the sides. A container that stands still has one pair of walls: the median of
    its frames' (each wall's slope and its place at the bottom, the bottom's centre) when the walls' mean slope and
    the bottom's centre scatter about their medians by no more than their frame-to-frame noise (`steady_angle`), the
    centre also when by no more than STILL_PX. Axes held from an earlier frame count once."""
    axes = [
        g for n, g in enumerate(axes) if n == 0 or not np.array_equal(g[1], axes[n - 1][1]) or g[0] != axes[n - 1][0]
    ]
    if len(axes) < 20:
        return None
    aL, bL, aR, bR = (np.array([g[0][i][j] for g in axes]) for i in (0, 1) for j in (0, 1))
    ox, oy = (np.array([g[1][i] for g in axes]) for i in (0, 1))
    ok = np.ones(len(axes), bool)
    angle = np.degrees(_axis_angle(aL, aR))
    if steady_angle(angle, ok) is None or any(steady_angle(v, ok) is None and scatter(v) > STILL_PX for v in (ox, oy)):
        return None
    yb = median(oy)
    a_l, a_r = median(aL), median(aR)
    x_l, x_r = median(aL * yb + bL), median(aR * yb + bR)
    a = 0.5 * (a_l + a_r)
    norm = math.hypot(1, a)
    e_w, e_u = np.array([-a, -1.0]) / norm, np.array([1.0, -a]) / norm
    return ((a_l, x_l - a_l * yb), (a_r, x_r - a_r * yb)), np.array([median(ox), yb]), e_u, e_w


def _anchor(body: np.ndarray, geom: tuple, origin: tuple[int, int]) -> tuple | None:
    """What `SurfaceFinder._measure_band` watches: a strip across the body (frame box) of ANCHOR_ROWS rows above the
    bottom and the nine rows around the bottom's centre, the columns of the bottom's middle three fifths in it, and
    the strip's values in this body map (`geom`: the container's axes in it); None when there is no liquid in it or
    the map has no row beyond it."""
    X0, Y0 = origin
    (aL, bL), (aR, bR) = geom[0]
    o = geom[1]
    half = 0.3 * ((aR - aL) * o[1] + bR - bL)
    r0, r1 = int(o[1]) - 4 - ANCHOR_ROWS, int(o[1]) + 5
    centre = (int(o[0] - half), int(o[0] + half) + 1)
    if r0 < 1 or r1 >= body.shape[0] or centre[0] < 0 or centre[1] > body.shape[1]:
        return None
    values = _anchor_values(body[r0:r1], centre)
    return None if values is None else ((X0, Y0 + r0, X0 + body.shape[1], Y0 + r1), centre, values)


def _anchor_values(strip: np.ndarray, centre: tuple[int, int]) -> np.ndarray | None:
    """Where the container is, from the membership map of the `_anchor` strip (pixels, each moving with the container
    by about as much as it does): the liquid's centre and width in its upper rows, across the body; and in its lower
    nine rows, over the bottom's middle (`centre` columns), how far the liquid reaches down and its centroid, which a
    tilt moves (the depth changes across them). None when either part holds no liquid."""
    s, b = cv2.moments(strip[:ANCHOR_ROWS]), cv2.moments(strip[ANCHOR_ROWS:, centre[0] : centre[1]])
    if s["m00"] <= 0 or b["m00"] <= 0:
        return None
    return np.array(
        [s["m10"] / s["m00"], s["m00"] / ANCHOR_ROWS, b["m00"] / (centre[1] - centre[0]), b["m10"] / b["m00"]]
    )


def _liquid_level(frame: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """Mean grey level of the liquid in its body box (x0, y0, x1, y1): its lower half's middle three fifths, which a
    slosh keeps under the surface, every other pixel; from the decoded luma of a `Picture`, converting nothing."""
    x0, y0, x1, y1 = box
    rows, cols = slice((y0 + y1) // 2, y1, 2), slice(x0 + (x1 - x0) // 5, x1 - (x1 - x0) // 5, 2)
    if isinstance(frame, Picture):
        grey = frame.luma[rows, cols]
    else:
        grey = cv2.cvtColor(np.ascontiguousarray(frame[rows, cols]), cv2.COLOR_BGR2GRAY)
    return float(grey.mean()) if grey.size else 0.0


def _beside(pieces: np.ndarray) -> np.ndarray:
    """Which pieces (connected components' stats rows: x, y, w, h, area) are one liquid body cut by highlight stripes
    or by a line across the glass: the largest, and those beside it (in the rows taken, half their height at least) or
    above or below it (in the columns taken, half their width at least, and no wider than them), within PIECE_GAP of
    the width taken so far. Another object of the dye's colour elsewhere (a label, a mat under the container, a cap) had
    joined the body's box, whose sides were then no walls: no frame was measured."""
    one = np.zeros(len(pieces), bool)
    one[int(np.argmax(pieces[:, 4]))] = True
    changed = True
    while changed:  # pieces may join through one another (a stripe, then the piece beyond the next stripe)
        changed = False
        t = pieces[one]
        left, top = t[:, 0].min(), t[:, 1].min()
        right, bottom = (t[:, 0] + t[:, 2]).max(), (t[:, 1] + t[:, 3]).max()
        gap = PIECE_GAP * (right - left) + 2
        for k in np.flatnonzero(~one):
            x, y, w, h, _ = pieces[k]
            rows = min(bottom, y + h) - max(top, y) >= 0.5 * h and x <= right + gap and x + w >= left - gap
            cols = min(right, x + w) - max(left, x) >= 0.5 * w and w <= right - left + 2 * gap
            if rows or (cols and y <= bottom + gap and y + h >= top - gap):
                one[k] = changed = True
    return one


def _inside(body: np.ndarray) -> np.ndarray:
    """True where the membership map is at least 0.5: the crossings and the body's box read it (NumPy's argmax finds
    the first liquid pixel of each row or column of a bool map several times faster than of a 0/255 one)."""
    return body >= 0.5


def _sustained(inside: np.ndarray, rows: int = SUSTAIN_ROWS) -> np.ndarray:
    """Where a mask (`inside` as `_inside` gives it, or its complement) holds in this row and the `rows` - 1 rows
    below: the body below the surface's front edge is solid, while the surface ellipse seen from above (a pale band
    over a yellow dye) can hover about 0.5 and cross it in some columns only, a back edge 2k above."""
    held = inside.copy()
    for k in range(1, rows):
        held[:-k] &= inside[k:]
        held[-k:] = False
    return held


def _column_box(
    inside: np.ndarray, origin: tuple[int, int], bottom_open: bool = False
) -> tuple[int, int, int, int] | None:
    """Frame box (x0, y0, x1, y1) of the liquid column in a membership map (`inside`, as `_inside` gives it): the
    longest stretch of liquid through its centre (`_centre_run`), down to where the liquid ends, or to where something of its colour wider than the
    container begins (a holder, a table, a thick glass bottom: `_column_end`; with `bottom_open`, also where it runs
    out to the map's side below the walls' rows). None when there is no body, when the column touches the map's sides
    above its end, or (unless `bottom_open`) reaches the map's bottom: the body left the map."""
    per_row, r = _liquid_rows(inside)
    if per_row.max() < 10:
        return None
    top = int(r[0])
    # highlight stripes cut rows into pieces: closed across a tenth of the body's width for the runs below
    gap = 2 * int(PIECE_GAP * median(per_row[r].astype(float))) + 3
    # on the map padded with no liquid: at its edge a closing reads the outside as liquid, or erodes the body near it
    kernel = np.ones((1, gap), np.uint8)
    padded = cv2.copyMakeBorder(inside[top:].view(np.uint8), 0, 0, gap, gap, cv2.BORDER_CONSTANT, value=0)
    closed = np.ascontiguousarray(cv2.morphologyEx(padded, cv2.MORPH_CLOSE, kernel)[:, gap:-gap])
    seg = closed.view(bool)
    # the centre: middle of the columns the upper half of the body fills (a wider holder below does not move it)
    upper = cv2.reduce(seg[: max(1, (int(r[-1]) - top) // 2)].view(np.uint8), 0, cv2.REDUCE_SUM, dtype=cv2.CV_32S)
    filled = np.flatnonzero(upper.ravel() >= 0.1 * upper.max())
    c = (int(filled[0]) + int(filled[-1])) // 2
    # per row, the run of liquid through the centre: its first and its last-plus-one column
    dl, dr = np.argmax(~seg[:, c::-1], axis=1), np.argmax(~seg[:, c:], axis=1)
    # the run through the centre stops short of both of the map's sides (another thing of the dye's colour may touch
    # a side in the same rows: a dark camera body beside a cola)
    walled = seg[:, c] & (~seg[:, :c]).any(axis=1) & (~seg[:, c + 1 :]).any(axis=1)
    left, right = (c + 1 - dl).astype(float), (c + dr).astype(float)
    start, stop = _centre_run(seg[:, c])
    n = start + _column_end(seg[start:stop, c], left[start:stop], right[start:stop])
    if bottom_open:
        # below the rows the walls are fitted on, a run that reaches the map's side is what the container stands in (a
        # holder's base running out of the picture on one side only, which `_column_end` does not see): the column
        # ends there. (A followed body's map is a window about its last box, whose sides it may touch: found anew.)
        lower = start + int(0.6 * (stop - start))
        beyond = np.flatnonzero(seg[lower:n, c] & ~walled[lower:n])
        n = lower + int(beyond[0]) if beyond.size else n
    if n - start < 12 or np.any(seg[start:n, c] & ~walled[start:n]):  # the column reaches the map's side
        return None
    if n == seg.shape[0] and not bottom_open:
        return None
    X0, Y0 = origin
    rows = seg[start:n, c]
    x0, x1 = int(left[start:n][rows].min()), int(right[start:n][rows].max())
    # from the liquid's top in its own columns (a pale surface band seen from above too; not another thing's top)
    first = int(np.argmax(inside[top : top + n, x0:x1].any(axis=1)))
    return X0 + x0, Y0 + top + first, X0 + x1, Y0 + top + n


def _centre_run(centre: np.ndarray) -> tuple[int, int]:
    """The longest stretch of rows (start, stop) in which the column's centre holds liquid, across gaps of up to three
    rows: the body, not a pale band above it (the surface seen from above, a meniscus) nor a holder beyond a gap."""
    rows = np.flatnonzero(centre)
    if rows.size == 0:
        return 0, 0
    breaks = np.flatnonzero(np.diff(rows) > 4)
    starts, stops = np.r_[rows[:1], rows[breaks + 1]], np.r_[rows[breaks], rows[-1:]] + 1
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k])


def _column_end(centre: np.ndarray, left: np.ndarray, right: np.ndarray) -> int:
    """Rows of the liquid column (from its top, the `_centre_run`): all of them, or up to where both sides of the run
    step outward from the walls' lines by more than OUTWARD_PX (or OUTWARD_SHARE of the width) in three successive rows.
    The walls' lines are fitted on the middle of the column (its 30-60 % rows): below the slosh's reach, above what may
    stand below the container."""
    length = centre.size
    lo, hi = int(0.3 * length), int(0.6 * length)
    if hi - lo < 10:
        return length
    rows = np.arange(length, dtype=float)
    mid = np.zeros((2, length), bool)
    mid[:, lo:hi] = centre[lo:hi]
    lines, _ = robust_lines(rows, np.vstack([left[:length], right[:length]]), mid, 0.5, min_points=5)
    if np.isnan(lines).any():
        return length
    width = float(np.median(right[lo:hi] - left[lo:hi]))
    tol = max(OUTWARD_PX, OUTWARD_SHARE * width)
    out = (lines[0, 0] * rows + lines[0, 1] - left[:length] > tol) & (
        right[:length] - lines[1, 0] * rows - lines[1, 1] > tol
    )
    out[:hi] = False
    steps = np.flatnonzero(out[:-2] & out[1:-1] & out[2:])
    return int(steps[0]) if steps.size else length


def _front_below(
    body: np.ndarray,
    inside: np.ndarray,
    held: np.ndarray,
    first: np.ndarray,
    found: np.ndarray,
    reach: float,
    level: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Each column's last crossing into sustained liquid (`held`, as `_sustained` gives it) within `reach` rows below
    its first one (`first`, sub-pixel; that one where there is none), and where there is one. The surface ellipse seen from above can read as
    liquid in parts (a dark dye reflecting its own colour), so the first crossing is its back edge in some columns
    and its front edge in others; below the last gap of two rows without liquid, the body is solid."""
    rows = body.shape[0]
    base = np.minimum(np.floor(np.where(found, first, 0)).astype(np.intp), rows - 1)
    depth = int(min(math.ceil(reach), rows - 2))
    if depth < 2:
        return first.copy(), np.zeros(first.shape, bool)
    r = base[None, :] + np.arange(depth)[:, None]
    cols = np.arange(body.shape[1])[None, :]
    within = r + 2 < rows
    rc = np.minimum(r, rows - 3)
    # a gap: two rows without liquid, followed by sustained liquid from the next row on
    gap = ~inside[rc, cols] & ~inside[rc + 1, cols] & held[rc + 2, cols] & within
    last = depth - 1 - np.argmax(gap[::-1], axis=0)
    has = gap.any(axis=0) & found
    q = np.minimum(base + last + 2, rows - 1)
    a, b = body[q - 1, cols[0]], body[q, cols[0]]
    frac = np.where(b > a, (level - a) / np.where(b > a, b - a, 1), 0.5)
    return np.where(has, q - 1 + np.clip(frac, 0, 1), first), has


def _liquid_rows(inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Liquid pixels per row of a membership map (`inside`, as `_inside` gives it), and the rows holding a twentieth
    of the fullest row's (a sloped surface thins out at its top): the body's rows for its box and a band's top."""
    per_row = cv2.reduce(inside.view(np.uint8), 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel()  # OpenCV sums bytes
    return per_row, np.flatnonzero(per_row >= 0.05 * per_row.max())


def _band(front: np.ndarray, cols: np.ndarray, origin: tuple[int, int]) -> tuple[int, int, int, int]:
    """Frame box around the front edge points, 3 px beyond them vertically."""
    X0, Y0 = origin
    return X0 + int(cols[0]), Y0 + int(front.min()) - 3, X0 + int(cols[-1]) + 1, Y0 + int(front.max()) + 4


def _continuous(w: np.ndarray, ok: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The columns (of `ok`) on the surface where something in front of the glass (a label, a finger, a clamp) hides or
    takes the place of the liquid's top in a run of them: a surface is continuous, so neighbouring front edges (`w`,
    at map columns `cols`) further apart than STEP_PX plus STEP_SLOPE per pixel between them bound such runs. The
    surface is the largest set of runs that continue one another's line (`_joined`: the last STEP_FIT columns taken,
    carried across the gap, within STEP_PX plus STEP_SPREAD per pixel of gap); the other runs are dropped (a 50 px
    label across a 240 px surface moved the fitted angle by 12 deg, the walls staying put). When that set keeps less
    than STEP_KEEP of the columns, none is kept (the frame is not measured); a surface without steps, or with more than
    STEP_RUNS (a ragged edge), keeps every column."""
    at = np.flatnonzero(ok)
    if at.size < 12:
        return ok
    v, x = w[at], cols[at].astype(float)
    steps = np.flatnonzero(np.abs(np.diff(v)) > STEP_PX + STEP_SLOPE * np.diff(x)) + 1
    if steps.size == 0 or steps.size > STEP_RUNS:  # no step, or a ragged edge: the robust fit's to judge
        return ok
    runs = np.split(np.arange(at.size), steps)
    # each run in turn taken for the surface, with the runs that continue its line: the largest such set is kept
    taken = max((_joined(runs, r, v, x) for r in range(len(runs))), key=lambda t: sum(q.size for q in t))
    keep = np.zeros_like(ok)
    kept = np.concatenate(taken)
    if kept.size >= STEP_KEEP * at.size:  # else the surface may be the part left out: nothing is measured
        keep[at[kept]] = True
    return keep


def _joined(runs: list[np.ndarray], first: int, v: np.ndarray, x: np.ndarray) -> list[np.ndarray]:
    """Run `first` and the runs beyond it on either side that continue its line across their steps (`_continuous`)."""
    taken = [runs[first]]
    for order in (range(first + 1, len(runs)), range(first - 1, -1, -1)):
        side = list(runs[first])
        for r in order:
            near = side[-STEP_FIT:] if r > first else side[:STEP_FIT]
            end = near[-1] if r > first else near[0]
            slope = np.polyfit(x[near], v[near], 1)[0] if len(near) >= 3 else 0.0
            start = runs[r][0] if r > first else runs[r][-1]
            gap = abs(x[start] - x[end])
            if abs(v[start] - (v[end] + slope * (x[start] - x[end]))) <= STEP_PX + STEP_SPREAD * gap:
                taken.append(runs[r])
                side = side + list(runs[r]) if r > first else list(runs[r]) + side
    return taken


def _locally_consistent(w: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Columns within 3 MAD (at least 0.7 px) of a running median over a sixth of the width: stripes and
    reflections move runs of neighbouring columns together, which would drag a first least-squares fit."""
    keep = np.zeros_like(ok)
    if ok.sum() < 12:
        return keep
    size = max(7, (int(ok.sum()) // 6) | 1)  # odd: the running median is the middle of each window
    v, h = w[ok], size // 2
    padded = np.concatenate([np.full(h, v[0]), v, np.full(h, v[-1])])  # edge padding, as np.pad's "edge"
    step = padded.strides[0]  # overlapping windows as one strided view (sliding_window_view's checks cost more)
    windows = np.ndarray((v.size, size), padded.dtype, padded, strides=(step, step))
    r = v - np.partition(windows, size // 2, axis=1)[:, size // 2]
    dev = np.abs(r - median(r))
    keep[ok] = dev < max(3 * MAD_SIGMA * median(dev), 0.7)
    return keep


def _fit_front(
    s: np.ndarray, w: np.ndarray, min_points: int, half: float | None = None, held: tuple[float, float] | None = None
):
    """Robust least squares of the front edge: w = c0 + c1 s + c3 s^3 - k sqrt(1 - (s - e)^2).

    The mid-line of the surface ellipse is the antisymmetric cubic (first and second mode); its front edge lies
    k = R sin(elevation) below it at the centre and meets it at the walls. The ellipse is centred on the container's
    axis whatever the surface's tilt: its offset e from the walls' midpoint (half widths) is fitted when the half
    width `half` (px) is given and the edge sags by CENTRE_MIN_K_PX, held toward 0 by CENTRE_PRIOR_PX (seen from
    above, an edge curved by k had turned the line by about k e / half when the walls were read e off). `held`: k (px)
    and e given, not fitted. Returns ((c0, c1, c3, k, e), inliers, rms) or None. Each pass drops points more than
    3 MAD (at least 0.5 px) off.
    """
    chord = np.sqrt(np.maximum(1 - s * s, 0))
    basis = np.empty((s.size, 4))
    basis[:, 0], basis[:, 1], basis[:, 2] = 1.0, s, s**3
    # the centre's offset, linearised about the walls' midpoint (d/de of -k sqrt(1 - (s - e)^2) at e = 0)
    lean = -s / np.maximum(chord, 0.2)
    if held is not None:
        k, e = held
        fit = _fit_front_basis(basis[:, :3], w + k * chord - k * e * lean, min_points)
        return None if fit is None else ((*fit[0], k, e), *fit[1:])
    basis[:, 3] = -chord
    fit = _fit_front_basis(basis, w, min_points)
    if fit is None or half is None or fit[0][3] < CENTRE_MIN_K_PX:
        return None if fit is None else ((*fit[0], 0.0), *fit[1:])
    k = float(fit[0][3])
    basis[:, 3] = k * lean
    again = _fit_front_basis(basis, w + k * chord, min_points, (half / CENTRE_PRIOR_PX) ** 2)
    return ((*fit[0], 0.0), *fit[1:]) if again is None else ((*again[0][:3], k, again[0][3]), *again[1:])


def _fit_front_basis(basis: np.ndarray, w: np.ndarray, min_points: int, centre_ridge: float = 0.0):
    """Iteratively trimmed linear least squares of w on the basis columns, the cubic's (third) coefficient held
    toward zero by its prior (SECOND_MODE_PRIOR_PX, against the edge's scatter) and a fourth column's, when
    `centre_ridge` is given, by that (its prior's inverse variance per unit edge variance): (coefficients, inliers,
    rms) or None."""
    keep = np.ones(len(w), bool)
    ridge, sigma = np.zeros(basis.shape[1]), EDGE_SIGMA_PX
    for passes in range(5):
        if np.count_nonzero(keep) < min_points:
            return None
        # normal equations: at most four well-separated columns on [-1, 1], hundreds of rows
        ridge[2] = (sigma / SECOND_MODE_PRIOR_PX) ** 2
        if centre_ridge:
            ridge[3] = sigma**2 * centre_ridge
        coef = normal_solve(basis, w, keep, ridge)
        if coef is None:
            return None
        res = np.abs(w - basis @ coef)
        sigma = max(EDGE_SIGMA_PX, MAD_SIGMA * median(res[keep]))
        if passes == 4:
            break
        new = res < max(3 * MAD_SIGMA * median(res[keep]), 0.5)
        if np.array_equal(new, keep):  # converged: further passes would repeat this fit
            break
        keep = new
    kept = res[keep]
    return coef, keep, math.sqrt(kept @ kept / kept.size)


def _shifted(geom: tuple, shift: tuple[int, int]) -> tuple:
    """Container axes (as `_container_axes` returns them) in coordinates whose origin moved by -shift."""
    ((aL, bL), (aR, bR)), o, e_u, e_w = geom
    dx, dy = shift
    return ((aL, bL + dx - aL * dy), (aR, bR + dx - aR * dy)), o + np.array([dx, dy]), e_u, e_w


def _moved_px(a: tuple, b: tuple) -> float:
    """Largest shift between two container axes (frame coordinates): of the bottom centre, and of each wall at it."""
    (wa, oa, _, _), (wb, ob, _, _) = a, b
    y = ob[1]
    walls = [abs((p[0] - q[0]) * y + p[1] - q[1]) for p, q in zip(wa, wb)]
    return max(float(np.hypot(*(oa - ob))), *walls)


WALL_END_PX = 0.2
"""The ellipse's ends are refitted when the walls where its line meets them lie this far from those in its top row:
a tenth of a pixel at the ends moves a 0.2 deg line by a thousandth of a degree."""

WALL_STEP_PX = 3.0
"""A wall's colour crossings wander by up to 1.3 px from the line through its lower half (compression blocks: a 6 deg
slosh in H.264 at 120 fps); a sloped surface in the wall's rows moves away by more than a pixel per row."""


def _line_through(rows: np.ndarray, x: np.ndarray, size: int) -> np.ndarray:
    """The least-squares line through the crossings `x` at `rows`, at every row up to `size` (np.polyfit, written out,
    costs four times as much per frame)."""
    dr, dx = rows - rows.mean(), x - x.mean()
    return x.mean() + (dr @ dx) / (dr @ dr) * (np.arange(size) - rows.mean())


def _on_wall(x: np.ndarray, ok: np.ndarray, inward: float) -> np.ndarray:
    """The rows whose side crossing `x` lies on the wall, not on the surface: a steep slosh brings the surface down a
    wall into the upper rows read for it (29 deg at a 640x480 container: 50 of a wall's 110 rows), where the first
    liquid pixel is on the sloped surface, inside the wall (`inward`: +1 for the left wall, -1 for the right), and a
    fit through them turned the wall by tens of degrees. The wall's line is fitted on the lower half of the rows
    (below the surface's reach; the lower half of the usable rows, which a tilted container's bottom corner may end
    early), or on the usable rows' straight part when a tenth of those lie WALL_STEP_PX off it; rows more than
    WALL_STEP_PX inside the line are dropped when they are a tenth of the rows or more (the surface's run); a few such
    rows are left to the robust fit, as before."""
    usable = np.flatnonzero(ok)
    if usable.size < 10:
        return ok
    rows = usable[usable.size // 2 :]
    line = _line_through(rows, x[rows], x.size)
    if np.count_nonzero(np.abs(x[rows] - line[rows]) >= WALL_STEP_PX) > 0.1 * rows.size:
        # the lower rows are not on one line: a reflection or the bottom's corner seen through the glass moves the
        # lowest rows' crossings inward, which had turned the line by degrees and dropped the wall's upper rows
        straight = np.flatnonzero(straight_part(np.arange(x.size), x[None], ok[None], WALL_TOL_PX, WALL_MAX_SLOPE)[0])
        if straight.size >= 10:
            line = _line_through(straight, x[straight], x.size)
    on = inward * (x - line) < WALL_STEP_PX
    return on if np.count_nonzero(ok & ~on) >= 0.1 * x.size else ok


LABEL_SHARE = 0.1
"""A label in front of the liquid (`_in_front`) takes at least this share of a side's rows, and the liquid above and
below it as many each."""
LABEL_SPLITS = 96
"""A label's ends are looked for at this many evenly spaced places along a side's rows (every split of a side's few
hundred rows cost 16 ms per frame); the rows between them are told apart by their distance from the liquid's line."""
LABEL_LIFT_PX = 4.5
"""A label's rows lie at least this far outside the liquid's (on average): the glass's thickness and the label's; a
lens's barrel distortion bows a wall's middle rows out by up to 3.5 px (640x480, k1 = 0.05)."""


def _in_front(rows: np.ndarray, x: np.ndarray, ok: np.ndarray, top: int) -> np.ndarray:
    """Per side (row 0 left, 1 right), the rows of a band of the liquid's colour round the glass: a label or print,
    outside the liquid's sides on both, at the same rows, with the liquid inside it above and below on one line (a
    liquid is never outside its container, and a surface running down a wall lies above it only; one wall bowed out
    by the glass is one side). Its edge, straighter than the liquid's seen through the glass, had been taken for the
    wall, or a line between the two. `top`: the liquid's top row, as `rows` count."""
    front, spans = np.zeros_like(ok), []
    half = 0.5 * (median(x[1, ok[1]]) - median(x[0, ok[0]])) if ok.any(axis=1).all() else 0.0
    for side, inward in enumerate((1.0, -1.0)):
        at = np.flatnonzero(ok[side])
        least = max(5, int(LABEL_SHARE * rows.size))
        if at.size < 3 * least:
            continue
        r = rows[at].astype(float)
        out = -inward * x[side, at]  # outward
        # rows far inside every line (a dark band where no liquid was seen) held at the liquid's depth
        ((a, b),), _ = robust_lines(r[None], out[None], np.ones((1, at.size), bool), WALL_TOL_PX)
        out = a * r + b + np.maximum(out - a * r - b, -2 * WALL_STEP_PX)
        # splits into rows above, a run, rows below (at LABEL_SPLITS places): the line through the rows above and
        # below, and how far the run lies outside it (sums over prefixes: the run's from i to j, the others' the rest)
        cum = np.vstack([np.zeros(5), np.cumsum(np.column_stack([np.ones_like(r), r, out, r * r, r * out]), axis=0)])
        cut = np.unique(np.linspace(0, at.size, LABEL_SPLITS + 1).astype(int))
        i, j = (cut[k] for k in np.triu_indices(cut.size, 1))
        i, j = i[j - i >= least], j[j - i >= least]
        run = cum[j] - cum[i]
        n, sr, so, srr, sro = (cum[-1] - run).T
        det = n * srr - sr * sr
        fine = (i >= least) & (j <= at.size - least) & (det > 0)
        slope = (n * sro - sr * so) / np.where(fine, det, 1.0)
        icpt = (so - slope * sr) / np.maximum(n, 1.0)
        lift = np.where(fine, (run[:, 2] - slope * run[:, 1] - icpt * run[:, 0]) / run[:, 0], -np.inf)
        best = int(np.argmax(lift))
        if lift[best] < LABEL_LIFT_PX:
            continue
        res = out - slope[best] * r - icpt[best]
        rest = np.r_[0 : i[best], j[best] : at.size]
        if MAD_SIGMA * median(np.abs(res[rest])) > WALL_STEP_PX:  # the rows above and below are not on one line
            continue
        # a band that begins within the surface ellipse's reach below the liquid's top (the camera at most
        # MAX_ELEVATION_SIN above it) has the ellipse's back above it, not the liquid's side: it is the liquid's own top
        # band, seen wider than its body through a thick glass, not a label in front of it
        if r[i[best]] - top <= MAX_ELEVATION_SIN * half:
            continue
        mid = np.arange(i[best], j[best])
        front[side, at[mid[res[mid] >= WALL_STEP_PX]]] = True
        spans.append((r[i[best]], r[j[best] - 1]))
    if len(spans) < 2 or min(spans[0][1], spans[1][1]) - max(spans[0][0], spans[1][0]) < 0.5 * min(
        b - a for a, b in spans
    ):
        return np.zeros_like(ok)
    return front


WALL_FROM = 0.1
"""The walls are read from this share of the liquid column's height below its top (the meniscus above) to a tenth
above its end; `_on_wall` and `straight_part` leave out the rows a slosh, a bottom corner or a holder takes."""
MIN_DEPTH_PX = 30
"""A liquid column less deep than this is not measured: a float's bar (144 x 24 px) has straight sides too and was taken
for the liquid once the walls were read from a tenth of the height down; a shallow fill's 576 x 48 px is measured."""
WALL_SHARE = 4
"""At least one in this many of the rows that may be a wall's must be on its straight part (sensor speckle on a
path-traced glass moves the liquid's edge by more than WALL_TOL_PX in up to half of them)."""
WALL_TOL_PX = 1.5
"""A wall's colour crossings lie within this of its line (compression blocks move them by up to 1.3 px)."""
WALL_MAX_SLOPE = 0.84
"""Walls lean by at most 40 deg in the picture (x per row): a sloped surface's run along a wall is flatter."""
WALL_SPREAD_DEG = 30.0
"""Two walls of a container lean apart by less than this in the picture: a tumbler's taper (the pbr corpus's strongest,
0.19 of radius per height, 11 deg a side) and a camera's convergence looking down at it spread them by 21-27 as
tracked. Beyond it the glass's own edges are looked for, and when they lean apart by at least a third of it less, the
walls are theirs (a Blender-rendered juice's right side ran along a shading edge across the liquid, 33 deg from its
left side where the glass's edges spread by 10, and turned the container by 14 deg)."""
CORNER_SHARE = 0.05
"""Rows closer than this share of the liquid's width to the bottom (at a side's crossing; at most the tenth of the
height that an upright container's rows end above it) are not read for that wall: a container tilted in the picture
raises one bottom corner into the rows read for the walls (12 deg at 640x480: 48 px), whose side crossings there lie on
the bottom and had dropped the wall's true rows (two thirds of the frames lost)."""


def _bottom_at(cols: np.ndarray, bottom: np.ndarray, ok: np.ndarray, margin: float):
    """The row `margin` above the bottom at given columns, as a function, from the bottom's crossings (`bottom` at
    `cols`, where `ok`): a line through the medians of their outer thirds (a few stray columns move no median). None
    when a third holds no crossing."""
    third = cols.size // 3
    ends = [(cols[s][ok[s]], bottom[s][ok[s]]) for s in (slice(None, third), slice(cols.size - third, None))]
    if third < 2 or any(c.size == 0 for c, _ in ends):
        return None
    (xl, yl), (xr, yr) = ((median(c.astype(float)), median(b)) for c, b in ends)
    slope = (yr - yl) / (xr - xl)
    return lambda x: yl + slope * (x - xl) - margin


def _glass_sides(frame: np.ndarray | Picture, origin: tuple[int, int], sides: tuple[int, int], rows: tuple[int, int]):
    """The walls (x = a y + b per row in the crop at `origin`, NaN when not found) as the glass's longest straight
    edges near the liquid's sides (`glass_walls` about vertical seeds at the body box's sides), over `rows` (crop's)."""
    X0, Y0 = origin
    y0, y1 = rows[0] + Y0, rows[1] + Y0
    seeds = [EdgeLine(0.0, float(x + X0), y0, y1, 0.0, y1 - y0) for x in sides]
    found = glass_walls(frame, seeds, (y0, y1))
    if len(found) < 2:
        return np.full((2, 2), np.nan)
    walls = wall_lines(found)
    return np.array([[w.a, w.b + w.a * Y0 - X0] for w in walls])


def _container_axes(
    body: np.ndarray,
    inside: np.ndarray,
    gray: np.ndarray,
    frame: np.ndarray | Picture,
    origin: tuple[int, int],
    box: tuple[int, int, int, int],
):
    """Inner walls (robust lines from the body's side crossings) and bottom; the container's axes, or None.

    Returns ((aL, bL), (aR, bR)) of the walls x = a y + b, the origin o on the inner bottom midway between the
    walls and the unit vectors e_u (right) and e_w (up along the walls), all in crop coordinates.
    """
    X0, Y0 = origin
    x0, y0, x1, y1 = box
    r0, r1 = y0 - Y0 + int(WALL_FROM * (y1 - y0)), y1 - Y0 - int(0.1 * (y1 - y0)) - 2
    if r1 - r0 < 10 or y1 - y0 < MIN_DEPTH_PX:
        return None
    rows = np.arange(r0, r1)
    band, band_in = body[r0:r1], inside[r0:r1]
    left, okl = _crossings_first(band, band_in, axis=1)
    right, okr = _crossings_first(band[:, ::-1], band_in[:, ::-1], axis=1)
    right = band.shape[1] - 1 - right
    c0, c1 = int(0.2 * (x1 - x0)) + x0 - X0, int(0.8 * (x1 - x0)) + x0 - X0
    # the bottom: where the liquid ends going down from mid-height for BOTTOM_ROWS rows at least (a holder of its
    # colour may go on below; a beaker's graduation marks cross the liquid above it)
    mid = (y0 + y1) // 2 - Y0
    bottom, okb = _crossings_first(1.0 - body[mid:, c0:c1], _sustained(~inside[mid:, c0:c1], BOTTOM_ROWS), axis=0)
    bottom += mid
    if np.count_nonzero(okb) < okb.size // 3:  # the liquid runs on below (a label or holder of its colour): the
        bottom[:], okb[:] = y1 - Y0, True  # column's end, where that begins, stands for the bottom
    # within the rows already left out above the bottom (a tenth of the height): an upright container keeps every row
    # it had, also a shallow fill (a twentieth of its width reached past them and took its walls)
    margin = min(CORNER_SHARE * (x1 - x0), 0.1 * (y1 - y0) + 2)
    corner = _bottom_at(np.arange(c0, c1), bottom, okb, margin)
    n = len(rows)
    wall_rows = [n, n]  # rows that may be a wall's: a quarter of them must be (robust_lines' min_points)
    if corner is not None:  # a container tilted in the picture: its raised side's lower rows end on the bottom
        above = rows < corner(left), rows < corner(right)
        okl, okr = okl & above[0], okr & above[1]
        wall_rows = [int(np.count_nonzero(a)) for a in above]
    # a label of the liquid's colour on the glass: its rows are not the wall's (they still count among those that may
    # be: what is left of a wall beside a label must be a quarter of its rows, or the label's curved end made one)
    front = _in_front(rows, np.vstack([left, right]), np.vstack([okl, okr]), y0 - Y0)
    okl, okr = okl & ~front[0], okr & ~front[1]
    okl, okr = okl & _on_wall(left, okl, 1.0), okr & _on_wall(right, okr, -1.0)
    okl, okr = straight_part(rows, np.vstack([left, right]), np.vstack([okl, okr]), WALL_TOL_PX, WALL_MAX_SLOPE)
    # both walls in one call: each row's luma is read at its left and at its right crossing
    both, good = _luma_crossings(
        gray[r0:r1].T, np.concatenate([left, right]), np.concatenate([okl, okr]), reach=2, cols=np.tile(np.arange(n), 2)
    )
    # a wall is placed on luma only where every row of it has the contrast: the colour and the luma crossings differ
    # by a fraction of a pixel, so a wall mixing them (a weak contrast, some rows short of it) tilts by tenths of a
    # degree, which moves the wall heights by as many tenths of a pixel
    if np.array_equal(good[:n], okl):
        left = both[:n]
    if np.array_equal(good[n:], okr):
        right = both[n:]
    # the walls (x over the rows) and the bottom (y over its columns) in one robust fit, padded to one length
    length, m = max(n, c1 - c0), c1 - c0
    t, v, ok = np.zeros((3, length)), np.zeros((3, length)), np.zeros((3, length), bool)
    t[:2, :n], t[2, :m] = rows, np.arange(c0, c1)
    v[0, :n], v[1, :n], v[2, :m] = left, right, bottom
    ok[0, :n], ok[1, :n], ok[2, :m] = okl, okr, okb
    lines, _ = robust_lines(t, v, ok, 0.3, min_points=np.array([max(10, k // WALL_SHARE) for k in (*wall_rows, m)]))
    if np.isnan(lines[:2]).any():  # the liquid's sides are not straight (a label, a holder, clutter of its colour)
        lines[:2] = _glass_sides(frame, origin, (x0 - X0, x1 - X0), (r0, r1))
    elif (spread := _spread_deg(lines)) > WALL_SPREAD_DEG:  # a strong taper, or a side that is no wall: ask the glass
        glass = _glass_sides(frame, origin, (x0 - X0, x1 - X0), (r0, r1))
        if not np.isnan(glass).any() and _spread_deg(glass) < spread - WALL_SPREAD_DEG / 3:
            lines[:2] = glass
    if np.isnan(lines).any():
        return None
    (aL, bL), (aR, bR), (k, d) = lines
    a = math.tan(float(_axis_angle(aL, aR)))
    norm = math.hypot(1, a)
    e_w, e_u = np.array([-a, -1.0]) / norm, np.array([1.0, -a]) / norm
    # the bottom line y = k x + d meets the centre line between the walls
    xm_at = lambda y: 0.5 * ((aL + aR) * y + bL + bR)  # noqa: E731
    y_b = float(d)
    for _ in range(3):
        y_b = k * xm_at(y_b) + d
    o = np.array([xm_at(y_b), y_b])
    return ((aL, bL), (aR, bR)), o, e_u, e_w
