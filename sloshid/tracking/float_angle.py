"""Find the float by colour and measure its centre and in-plane angle to a small fraction of a pixel/degree.

Detection is a plain OpenCV HSV range (what a user configures). Measurement does not use that binary
mask: a linear colour model (least squares on the frame's own float pixels vs. the pixels around it)
turns each pixel's BGR value into a soft float membership that is linear in the pixel's float
coverage, even where the float meets two different backgrounds (air above, liquid below). A ramp
centred at half coverage suppresses noise without moving the edges, and the grey-level moments of that
map give the centre and the principal-axis angle. The next frame is searched near the last position.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from sloshid.video.colors import HsvRange

_KERNEL = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
MIN_AREA_PX = 12
"""Blobs smaller than this many pixels are not taken for the float."""
REFIT_EVERY = 8
"""The colour model is refitted every this many frames (and after every loss): lighting drifts slowly."""
AREA_FRAMES = 9
"""The float's expected area is the median of its last this many measured areas (a rigid body's picture keeps its
size; a frame whose blob differs from it gets a lower quality)."""
GROW_SHARE = 2.0
"""A blob that the float's own colour (a balanced colour model fitted to it) extends to this many times its pixels or
more is taken as a fragment of the float and measured as that extent: a thin float whose colour H.264's chroma
subsampling mixes with the background's (a 4 px blue stick on a red juice reads purple, S 110 against the preset's
140) shows the HSV range a few pixels of itself. Below it the range's blob is the float's extent: a range that holds
most of a float is trusted (growing those moved still floats' angles by up to 0.3 deg, where a tint of the background
beside the float also passes)."""
GROW_ROUNDS = 4
"""At most this many times the searched box is widened around a growing blob."""
PAD_PX = 6
"""Margin of the measured box around the blob."""
ELONGATED = 0.5
"""The elongation (1 - minor/major variance) from which a blob's shape costs its quality nothing: a float is a long
body, at least `length_to_width(ELONGATED)` (1.41) times as long as wide; a disc's elongation is 0."""


FLOAT_HUE_REACH = 6
"""How far (OpenCV hue units, 2 deg each) a named float colour's hue bounds may move out where its range finds no float
in the first frame (`relaxed_ranges`): a thin float's colour mixes with the liquid's under it (H.264 keeps colour at
half the resolution), and a yellow plank on orange juice read hue 18-21, below the yellow preset's 22."""
FLOAT_SAT_REACH = 60
"""How far a named float colour's saturation floor may move down there: a float lit from above pales in its highlight
(an orange plank on a yellow dye read saturation 63-182, the orange preset starts at 120)."""
FLOAT_SAT_LOWEST = 40
"""The saturation floor never moves below this: a white wall and a grey glass read 0-30."""


def relaxed_ranges(hsv: HsvRange) -> list[tuple[int, int, HsvRange]]:
    """The range's relaxations, as (hue widening, saturation lowering, range), fewest steps first: both hue bounds
    widened by up to FLOAT_HUE_REACH in steps of 2 and the saturation floor lowered by up to FLOAT_SAT_REACH in steps of
    10 (not below FLOAT_SAT_LOWEST); none for a range without a hue (`dark`) or a saturation floor."""
    if hsv.low[1] <= FLOAT_SAT_LOWEST or (hsv.low[0] == 0 and hsv.high[0] == 179):
        return []
    floors = sorted({max(FLOAT_SAT_LOWEST, hsv.low[1] - ds) for ds in range(0, FLOAT_SAT_REACH + 1, 10)}, reverse=True)
    steps = [(dh, hsv.low[1] - s) for dh in range(0, FLOAT_HUE_REACH + 1, 2) for s in floors if dh or s < hsv.low[1]]
    steps.sort(key=lambda step: (step[0] / 2 + math.ceil(step[1] / 10), step[0]))
    return [
        (
            dh,
            ds,
            HsvRange(((hsv.low[0] - dh) % 180, hsv.low[1] - ds, hsv.low[2]), ((hsv.high[0] + dh) % 180, *hsv.high[1:])),
        )
        for dh, ds in steps
    ]


@dataclass
class FloatMeasurement:
    """One frame's measurement of the float (image coordinates: x right, y down, pixel centres at integers)."""

    found: bool
    x_px: float = math.nan
    y_px: float = math.nan
    angle_deg: float = math.nan
    """Principal-axis angle against the image horizontal, CCW positive as seen, in (-90, 90]."""
    quality: float = 0.0
    """0..1: colour separation x area consistency x elongation; 0 when not found."""
    area_px: float = 0.0
    length_px: float = 0.0
    """Length of the float's long axis (rectangle equivalent, sqrt(12 * major variance))."""
    bbox: tuple[int, int, int, int] | None = None
    """Blob box (x0, y0, x1, y1), exclusive end, in frame coordinates."""
    elongation: float = 0.0
    """1 - minor/major variance of the measured blob (`principal_axis`): 0 for a disc, near 1 for a thin bar."""
    cut: bool = False
    """The blob reaches the edge of the ROI (or of the picture): part of the float lies outside what was searched, so
    its axis is not the float's; measured with quality 0."""


def hsv_mask(bgr: np.ndarray, hsv: HsvRange) -> np.ndarray:
    """Binary 0/255 mask of the pixels inside the HSV box (hue wrapping through 0 handled)."""
    im = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    lo, hi = hsv.low, hsv.high
    if not hsv.wraps:
        return cv2.inRange(im, lo, hi)
    upper = cv2.inRange(im, (lo[0], lo[1], lo[2]), (179, hi[1], hi[2]))
    lower = cv2.inRange(im, (0, lo[1], lo[2]), (hi[0], hi[1], hi[2]))
    return cv2.bitwise_or(upper, lower)


def fit_colour_model(
    crop: np.ndarray, blob: np.ndarray, greys: float = 0.0, balanced: bool = False
) -> tuple[np.ndarray, float] | None:
    """Least-squares linear colour model w.bgr + c ~ float membership, fitted to this crop's own pixels.

    `blob` (0/255) marks the float roughly: eroded blob pixels are 'float' (1), pixels beyond a dilated
    blob are 'background' (0), whatever colours they have (air above, liquid below). `greys`: neutral greys from
    black to white are background too, with this share of the background pixels' weight (for a colour whose range
    holds no grey: a dark wall, a few pixels of the crop, is otherwise fitted as it falls). `balanced`: the float's
    pixels weigh as much in all as the background's (a blob of a few pixels among thousands is otherwise fitted near 0:
    its own pixels come out below half membership; `FloatFinder` seeks the float's extent with such a model). Returns
    (`membership_map`'s transform of the model, rms fit error) or None when the crop holds no background.
    """
    core = cv2.erode(blob, _KERNEL, iterations=2)
    if cv2.countNonZero(core) < 6:
        core = blob
    inside = core.reshape(-1) > 0
    used = inside | (cv2.dilate(blob, _KERNEL, iterations=3) == 0).reshape(-1)
    if np.count_nonzero(used) == np.count_nonzero(inside):  # no background
        return None
    X = np.ones((np.count_nonzero(used), 4), np.float64)
    for k, plane in enumerate(cv2.split(crop)):  # per plane: NumPy selects 3-byte pixels ten times slower
        X[:, k] = plane.reshape(-1)[used]
    target = inside[used].astype(np.float64)
    weight = None
    if balanced:
        n_in = np.count_nonzero(target)
        if n_in == 0:
            return None
        weight = np.where(target > 0, (len(target) - n_in) / n_in, 1.0)
        normal, right = (X * weight[:, None]).T @ X, (X * weight[:, None]).T @ target
    else:
        normal, right = X.T @ X, X.T @ target
    if greys > 0:  # target 0, so they add to the normal matrix only
        level = np.linspace(0.0, 255.0, 18)[:, None]  # black to white in steps of 15
        grey = np.hstack([level, level, level, np.ones_like(level)])
        normal += greys * (len(target) - np.count_nonzero(target)) / len(grey) * (grey.T @ grey)
    try:  # normal equations: 4 unknowns, thousands of rows, well conditioned when float and background differ
        coef = np.linalg.solve(normal, right)
    except np.linalg.LinAlgError:
        return None
    # the membership ramp (linear from 0.1 to 0.9) goes into the transform, once per fit: the blur is linear
    ramp = np.append(coef[:3], coef[3] - 0.1)[None, :] * 1.25
    residual = (X @ coef - target) ** 2
    rms = np.sqrt(np.mean(residual) if weight is None else np.sum(weight * residual) / np.sum(weight))
    return ramp.astype(np.float32), float(rms)


def membership_map(crop: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """Soft membership 0..1 of every crop pixel: the colour model (`transform`, as `fit_colour_model` gives it),
    linear from 0.1 to 0.9 and clipped.

    The ramp is symmetric about half coverage, so edges stay where they are, while background noise
    (membership near 0) and the float's interior (near 1) stop adding scatter to the moments.
    """
    value = cv2.transform(crop.astype(np.float32), transform).reshape(crop.shape[:2])
    # a slight isotropic blur smooths H.264's 2-pixel chroma staircase; it cannot turn the moments' axes
    value = cv2.GaussianBlur(value, (3, 3), 0.8)
    return np.clip(value, 0, 1, out=value)


def length_to_width(elongation: float) -> float:
    """How many times as long as wide a rectangle of this elongation (`principal_axis`) is: its sides' ratio is the
    square root of its variances' ratio."""
    return 1 / math.sqrt(max(1 - elongation, 1e-12))


def principal_axis(mo: dict) -> tuple[float, float, float]:
    """Of OpenCV moments (`cv2.moments`, m00 > 0): the long axis's angle against the image horizontal (CCW as seen, in
    (-90, 90]), the elongation 1 - minor/major variance (0 for a disc, near 1 for a thin bar) and the major variance."""
    a, b, c = mo["mu20"] / mo["m00"], mo["mu11"] / mo["m00"], mo["mu02"] / mo["m00"]
    spread = math.hypot(a - c, 2 * b)
    lam1, lam2 = 0.5 * (a + c + spread), 0.5 * (a + c - spread)
    angle = -0.5 * math.degrees(math.atan2(2 * b, a - c))  # y points down: negate for CCW as seen
    if angle <= -90:
        angle += 180
    return angle, (1 - lam2 / lam1 if lam1 > 0 else 0.0), lam1


class FloatFinder:
    """Stateful per-video float finder: searches near the last position, falls back to the whole ROI."""

    def __init__(self, hsv: HsvRange, roi: tuple[int, int, int, int]) -> None:
        self.hsv = hsv
        self.roi = roi  # x, y, w, h within the frame
        self._last: FloatMeasurement | None = None
        self._ref_area = 0.0
        self._areas: deque[float] = deque(maxlen=AREA_FRAMES)
        self._velocity = (0.0, 0.0)  # px per frame
        self._model: tuple[np.ndarray, float] | None = None
        self._seek: tuple[np.ndarray, float] | None = None  # the balanced model: where the float's colour extends
        self._frames_since_fit = 0

    def copied(self) -> None:
        """A frame that copied the last measured picture (`Copies`) was not measured: it counts toward the colour
        model's refit as one that was (REFIT_EVERY frames of video, whatever the encoder repeated)."""
        self._frames_since_fit += 1

    def measure(self, frame: np.ndarray) -> FloatMeasurement:
        """Measure the float in one BGR frame (near the last position first, by the HSV range and then by the float's
        own colour, then the whole ROI by the range)."""
        if self._last is not None:
            for box in (self._tight_box(self._last), self._window(self._last)):
                m = self._measure_in(frame, box, local=True)
                if m.found:
                    return self._remember(m)
            m = self._by_own_colour(frame, self._window(self._last))
            if m.found:
                return self._remember(m)
        return self._remember(self._measure_in(frame, self._roi_box(), local=False))

    def _by_own_colour(self, frame: np.ndarray, box: tuple[int, int, int, int]) -> FloatMeasurement:
        """The float near the last position by its own colour (the balanced model of the last fit, membership >= 0.5)
        where the HSV range found none of it: the blob nearest the last position of at least half the expected area,
        not cut by the window."""
        x0, y0, x1, y1 = box
        if self._seek is None or self._last is None or x1 <= x0 or y1 <= y0:
            return FloatMeasurement(False)
        mask = (membership_map(frame[y0:y1, x0:x1], self._seek[0]) >= 0.5).astype(np.uint8)
        n, labels, stats, cents = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if n <= 1:
            return FloatMeasurement(False)
        d = np.hypot(cents[1:, 0] + x0 - self._last.x_px, cents[1:, 1] + y0 - self._last.y_px)
        d[stats[1:, cv2.CC_STAT_AREA] < max(MIN_AREA_PX, 0.5 * self._ref_area)] = np.inf
        k = int(np.argmin(d))
        bx, by, bw, bh = stats[k + 1, :4]
        if not np.isfinite(d[k]) or bx == 0 or by == 0 or bx + bw == x1 - x0 or by + bh == y1 - y0:
            return FloatMeasurement(False)
        return self._refine(frame, labels == k + 1, (x0, y0), (bx, by, bw, bh))

    def _roi_box(self) -> tuple[int, int, int, int]:
        """The ROI as (x0, y0, x1, y1)."""
        x, y, w, h = self.roi
        return x, y, x + w, y + h

    def _tight_box(self, last: FloatMeasurement) -> tuple[int, int, int, int]:
        """The last measurement box moved by the last motion plus a few pixels: the cheap first try."""
        if last.bbox is None:  # a found measurement has its box
            raise ValueError("the last float measurement has no box")
        vx, vy = self._velocity
        x0, y0, x1, y1 = last.bbox
        m = 3.0 + 0.05 * last.length_px
        rx0, ry0, rx1, ry1 = self._roi_box()
        return (
            max(rx0, int(x0 + vx - m)),
            max(ry0, int(y0 + vy - m)),
            min(rx1, int(x1 + vx + m) + 1),
            min(ry1, int(y1 + vy + m) + 1),
        )

    def _window(self, last: FloatMeasurement) -> tuple[int, int, int, int]:
        """Search box around where the float should be now (last position plus last motion), half its
        length plus a margin in every direction (covers any rotation and a change of speed)."""
        vx, vy = self._velocity
        cx, cy = last.x_px + vx, last.y_px + vy
        r = 0.5 * last.length_px + max(8.0, 0.15 * last.length_px + 0.5 * math.hypot(vx, vy))
        rx0, ry0, rx1, ry1 = self._roi_box()
        return (max(rx0, int(cx - r)), max(ry0, int(cy - r)), min(rx1, int(cx + r) + 1), min(ry1, int(cy + r) + 1))

    def _remember(self, m: FloatMeasurement) -> FloatMeasurement:
        """Keep the measurement, the motion since the last one and the float's typical area for the next frame."""
        last = self._last
        self._velocity = (m.x_px - last.x_px, m.y_px - last.y_px) if (m.found and last is not None) else (0.0, 0.0)
        self._last = m if m.found else None
        if m.found and not m.cut:  # every measured frame: a first blob that was part of the float is soon outvoted
            self._areas.append(m.area_px)
            self._ref_area = float(np.median(self._areas))
        return m

    def _measure_in(self, frame: np.ndarray, box: tuple[int, int, int, int], local: bool) -> FloatMeasurement:
        """Detect the float blob by HSV inside `box` (near the last one when `local`) and refine it; a box that holds
        no pixel (moved past the ROI's edge by the last motion) finds none."""
        x0, y0, x1, y1 = box
        if x1 <= x0 or y1 <= y0:
            return FloatMeasurement(False)
        mask = hsv_mask(frame[y0:y1, x0:x1], self.hsv)
        if local:
            # fast path: the window holds one blob of the expected size that the window does not cut
            area = cv2.countNonZero(mask)
            bx, by, bw, bh = cv2.boundingRect(mask)
            if (
                0.5 * self._ref_area <= area <= 1.5 * self._ref_area
                and bx > 0
                and by > 0
                and bx + bw < x1 - x0
                and by + bh < y1 - y0
                and bw * bh <= 4 * area
            ):
                return self._refine(frame, mask > 0, (x0, y0), (bx, by, bw, bh))
        n, labels, stats, cents = cv2.connectedComponentsWithStats(mask, connectivity=8)
        if n <= 1:
            return FloatMeasurement(False)
        areas = stats[1:, cv2.CC_STAT_AREA]
        edge = (
            (stats[1:, 0] == 0)
            | (stats[1:, 1] == 0)
            | (stats[1:, 0] + stats[1:, 2] == x1 - x0)
            | (stats[1:, 1] + stats[1:, 3] == y1 - y0)
        )
        if local and self._last is not None:
            # closest sizeable blob to the last position
            d = np.hypot(cents[1:, 0] + x0 - self._last.x_px, cents[1:, 1] + y0 - self._last.y_px)
            d[areas < max(MIN_AREA_PX, 0.3 * self._ref_area)] = np.inf
            k = int(np.argmin(d))
            if not np.isfinite(d[k]):
                return FloatMeasurement(False)
        else:
            k = _likeliest(labels, stats, edge)
        if areas[k] < MIN_AREA_PX:
            return FloatMeasurement(False)
        bx, by, bw, bh = stats[k + 1, :4]
        cut = bool(edge[k])
        if local and cut:
            return FloatMeasurement(False)  # cut by the window: measure on the whole ROI instead
        blob = _with_pieces(labels, stats, cents, k)
        if blob is not None:  # the box over all pieces
            bx, by, bw, bh = cv2.boundingRect(blob.astype(np.uint8))
        else:
            blob = labels == k + 1
        m = self._refine(frame, blob, (x0, y0), (bx, by, bw, bh))
        if cut and m.found:  # cut by the ROI itself
            m.cut, m.quality = True, 0.0
        return m

    def _refine(
        self, frame: np.ndarray, blob_full: np.ndarray, origin: tuple[int, int], stat: tuple[int, int, int, int]
    ) -> FloatMeasurement:
        """Sub-pixel centre and angle from moments of the soft membership in a padded box around the blob (grown to the
        float's own colour's extent when the blob is a fragment of it, `GROW_SHARE`)."""
        h, w = frame.shape[:2]
        ox, oy = origin
        bx, by, bw, bh = stat
        box = (
            max(0, ox + bx - PAD_PX),
            max(0, oy + by - PAD_PX),
            min(w, ox + bx + bw + PAD_PX),
            min(h, oy + by + bh + PAD_PX),
        )
        blob = _pasted(blob_full.astype(np.uint8) * 255, (ox, oy), box)
        self._frames_since_fit += 1
        refit = self._model is None or self._frames_since_fit >= REFIT_EVERY or self._last is None
        if refit or self._seek is None:
            self._seek = fit_colour_model(_crop(frame, box), blob, balanced=True)
        # a blob of half the float's expected area or more cannot grow to twice its size without growing beyond the
        # float: only a smaller one (and the first) is grown (growing costs about as much as the rest of a measurement)
        if not self._ref_area or cv2.countNonZero(blob) < self._ref_area / GROW_SHARE:
            blob, box = self._grown(frame, blob, box)
        X0, Y0, X1, Y1 = box
        crop = frame[Y0:Y1, X0:X1]
        if refit:
            self._model = fit_colour_model(crop, blob)
            self._frames_since_fit = 0
        if self._model is None:
            return FloatMeasurement(False)
        transform, rms = self._model
        soft = membership_map(crop, transform)
        soft *= cv2.dilate(blob, _KERNEL, iterations=PAD_PX - 1) > 0  # only this blob, not other things
        mo = cv2.moments(soft)
        if mo["m00"] <= 1e-6:
            return FloatMeasurement(False)
        cx, cy = mo["m10"] / mo["m00"], mo["m01"] / mo["m00"]
        angle, elong, lam1 = principal_axis(mo)
        area = mo["m00"]
        q_sep = min(1.0, max(0.0, 1 - 2 * rms))
        q_area = min(area, self._ref_area) / max(area, self._ref_area) if self._ref_area else 1.0
        quality = q_sep * q_area * min(1.0, elong / ELONGATED)
        length = math.sqrt(12 * max(lam1, 0))
        return FloatMeasurement(True, X0 + cx, Y0 + cy, angle, quality, area, length, (X0, Y0, X1, Y1), elong)

    def _grown(
        self, frame: np.ndarray, blob: np.ndarray, box: tuple[int, int, int, int]
    ) -> tuple[np.ndarray, tuple[int, int, int, int]]:
        """(blob, box): the blob with the pixels of the float's own colour connected to it (the balanced model,
        membership >= 0.5; the box widened after it, within the ROI) when that is `GROW_SHARE` times the blob or more,
        else the blob and box as given."""
        if self._seek is None:
            return blob, box
        rx0, ry0, rx1, ry1 = self._roi_box()
        seed, seed_box = blob, box
        for _ in range(GROW_ROUNDS):
            soft = membership_map(_crop(frame, box), self._seek[0])
            _, labels = cv2.connectedComponents((soft >= 0.5).astype(np.uint8), connectivity=8)
            touched = np.unique(labels[(blob > 0) & (labels > 0)])
            grown = (np.isin(labels, touched) | (blob > 0)).astype(np.uint8) * 255
            gx, gy, gw, gh = cv2.boundingRect(grown)
            wider = (
                max(rx0, box[0] + gx - PAD_PX),
                max(ry0, box[1] + gy - PAD_PX),
                min(rx1, box[0] + gx + gw + PAD_PX),
                min(ry1, box[1] + gy + gh + PAD_PX),
            )
            done = wider == box and cv2.countNonZero(grown) == cv2.countNonZero(blob)
            blob, box = _pasted(grown, box[:2], wider), wider
            if done:
                break
        if cv2.countNonZero(blob) < GROW_SHARE * cv2.countNonZero(seed):
            return seed, seed_box
        return blob, box


def _crop(frame: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """The frame's pixels in box (x0, y0, x1, y1)."""
    return frame[box[1] : box[3], box[0] : box[2]]


def _pasted(mask: np.ndarray, origin: tuple[int, int], box: tuple[int, int, int, int]) -> np.ndarray:
    """A 0/255 mask whose top left corner is at `origin` (frame coordinates) as a mask of `box` (x0, y0, x1, y1): what
    lies outside the box is cut off, what the mask does not cover is 0."""
    x0, y0, x1, y1 = box
    out = np.zeros((y1 - y0, x1 - x0), np.uint8)
    ox, oy = origin
    ax0, ay0 = max(ox, x0), max(oy, y0)
    ax1, ay1 = min(ox + mask.shape[1], x1), min(oy + mask.shape[0], y1)
    if ax1 > ax0 and ay1 > ay0:
        out[ay0 - y0 : ay1 - y0, ax0 - x0 : ax1 - x0] = mask[ay0 - oy : ay1 - oy, ax0 - ox : ax1 - ox]
    return out


def _with_pieces(labels: np.ndarray, stats: np.ndarray, cents: np.ndarray, k: int) -> np.ndarray | None:
    """Blob k with the other blobs (of MIN_AREA_PX or more) centred on its long axis's line, within its thickness and
    at most one blob length beyond its ends: a float is one straight body, which a highlight or glare can cut in
    pieces (a reflection or the submerged part seen through the liquid lies beside it). None when there are none."""
    x, y, w, h = stats[k + 1, :4]
    mo = cv2.moments((labels[y : y + h, x : x + w] == k + 1).astype(np.uint8), True)
    angle, elong, lam1 = principal_axis(mo)
    a = math.radians(angle)
    half_len, half_thick = math.sqrt(3 * lam1), math.sqrt(3 * lam1 * (1 - elong)) + 1.0
    d = cents[1:] - cents[k + 1]
    along = np.abs(d[:, 0] * math.cos(a) - d[:, 1] * math.sin(a))
    across = np.abs(d[:, 0] * math.sin(a) + d[:, 1] * math.cos(a))
    near = (stats[1:, cv2.CC_STAT_AREA] >= MIN_AREA_PX) & (across <= half_thick) & (along <= 3 * half_len)
    near[k] = False
    if elong < ELONGATED or not near.any():
        return None
    return np.isin(labels, np.flatnonzero(near) + 1) | (labels == k + 1)


def _likeliest(labels: np.ndarray, stats: np.ndarray, edge: np.ndarray) -> int:
    """Index (into `stats[1:]`) of the blob likeliest to be the float: of the 8 largest, the largest that looks like one
    (not cut by the searched box, elongated as the quality asks, within 45 deg of the horizontal as a float on a liquid
    lies), else the largest. A label, a packet or a container edge of the float's colour stands upright or is cut."""
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = [int(k) for k in np.argsort(-areas) if areas[k] >= MIN_AREA_PX][:8]

    def float_like(k: int) -> bool:
        x, y, w, h = stats[k + 1, :4]
        angle, elong, _ = principal_axis(cv2.moments((labels[y : y + h, x : x + w] == k + 1).astype(np.uint8), True))
        return not edge[k] and elong >= ELONGATED and abs(angle) <= 45

    return next((k for k in order if float_like(k)), int(np.argmax(areas)))
