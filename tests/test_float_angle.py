"""The float finder on constructed frames whose float angle and centre are known exactly, and on a lossless clip."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from sloshid.identification.estimator import Identifier
from sloshid.identification.signals import Signal, signal_from_track
from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.tracking.float_angle import FloatFinder
from sloshid.tracking.rows import VALID_QUALITY
from sloshid.tracking.tracker import TrackSettings, track_video
from sloshid.video.colors import preset

UP = 8
"""Frames are drawn this many times larger and shrunk (INTER_AREA): edges are anti-aliased as a camera's are."""
RED = preset("red")


def _bar(cx: float, cy: float, length: float, thick: float, angle_deg: float) -> np.ndarray:
    """Corners of a bar centred at (cx, cy), its long axis `angle_deg` CCW as seen from the image horizontal."""
    a = math.radians(angle_deg)
    u, v = np.array([math.cos(a), -math.sin(a)]), np.array([math.sin(a), math.cos(a)])
    return np.array(
        [[cx, cy] + su * length / 2 * u + sv * thick / 2 * v for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    )


def _frame(shapes: list[tuple[np.ndarray, tuple[int, int, int]]], size=(320, 240), seed=0) -> np.ndarray:
    """A grey wall over a dark green liquid (from y = 130) with the given polygons (corners in px, BGR) painted on."""
    w, h = size
    big = np.full((h * UP, w * UP, 3), 150, np.uint8)
    big[130 * UP :] = (40, 90, 30)
    for corners, bgr in shapes:
        pts = np.round((corners + 0.5) * UP - 0.5).astype(np.int32)
        cv2.fillPoly(big, [pts], bgr, lineType=cv2.LINE_8)
    img = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32)
    img += np.random.default_rng(seed).normal(0, 2.0, img.shape)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8)


def _measure(frame: np.ndarray, roi=None):
    h, w = frame.shape[:2]
    return FloatFinder(RED.hsv, roi or (0, 0, w, h)).measure(frame)


def test_an_upright_box_or_a_cut_one_of_the_float_colour_is_passed_over_for_the_float():
    # a float (60 x 8 px at 3 deg) beside a box of its colour 4 times its area: upright (a label, a packet) or lying
    # but cut by the picture's edge; the float is measured, not the largest blob
    float_bar = (_bar(170.0, 128.0, 60.0, 8.0, 3.0), RED.bgr)
    for box in (_bar(280.0, 80.0, 90.0, 24.0, 88.0), _bar(10.0, 60.0, 90.0, 24.0, 2.0)):
        m = _measure(_frame([float_bar, (box, RED.bgr)]))
        assert m.found and not m.cut
        assert abs(m.angle_deg - 3.0) < 0.1 and math.hypot(m.x_px - 170.0, m.y_px - 128.0) < 0.3


def test_the_expected_area_follows_the_float_after_a_first_frame_that_saw_part_of_it():
    # in the first frame glare pales the float's left half out of the red range (S 89 against 110), so the first blob
    # is half the float; in the next ones the whole float shows. The expected area follows what is measured frame after
    # frame, so their quality is not held below the valid threshold by the first frame's half area
    bar = _bar(160.0, 126.0, 60.0, 8.0, 2.0)
    half = _bar(160.0 - 15 * math.cos(math.radians(2.0)), 126.0 + 15 * math.sin(math.radians(2.0)), 30.0, 8.0, 2.0)
    pale = tuple(int(0.45 * c + 0.55 * 235) for c in RED.bgr)
    assert cv2.cvtColor(np.uint8([[pale]]), cv2.COLOR_BGR2HSV)[0, 0, 1] < RED.hsv.low[1]
    frames = [_frame([(bar, RED.bgr), (half, pale)])] + [_frame([(bar, RED.bgr)], seed=k) for k in range(1, 10)]
    finder = FloatFinder(RED.hsv, (0, 0, 320, 240))
    ms = [finder.measure(f) for f in frames]
    assert ms[0].area_px < 0.6 * ms[-1].area_px  # the first blob: half the float
    assert all(m.quality >= VALID_QUALITY for m in ms[5:])
    assert all(abs(m.angle_deg - 2.0) < 0.1 for m in ms[1:])


def test_a_float_cut_in_two_by_a_highlight_is_measured_whole_and_its_reflection_left_out():
    # a 60 x 6 px float at 1.5 deg with a highlight across it 10 px left of its centre (pieces of 20 and 36 px) and
    # its mirror image in the surface 14 px below (30 px, -1.5 deg): both pieces are the float, the image is not
    a = math.radians(1.5)
    along = np.array([math.cos(a), -math.sin(a)])
    bar = _bar(160.0, 120.0, 60.0, 6.0, 1.5)
    glare = _bar(*(np.array([160.0, 120.0]) - 8 * along), 4.0, 10.0, 1.5)
    image = _bar(160.0, 134.0, 30.0, 4.0, -1.5)
    frame = _frame([(bar, RED.bgr), (glare, (235, 235, 235)), (image, (30, 30, 160))])
    m = _measure(frame)
    assert m.found and abs(m.angle_deg - 1.5) < 0.1
    assert abs(m.x_px - 160.57) < 0.5 and abs(m.y_px - 120.0) < 0.5  # the two pieces' centre


def test_a_float_cut_by_the_roi_is_not_traded_for_a_speck_of_its_colour():
    # the ROI's right edge cuts the float; a 5 x 5 px speck of its colour lies inside it: the float is still the one
    # measured, as cut (quality 0, so the track asks for a wider ROI), not the speck as if it were the float
    frame = _frame([(_bar(170.0, 120.0, 60.0, 8.0, 3.0), RED.bgr), (_bar(60.0, 60.0, 5.0, 5.0, 0.0), RED.bgr)])
    m = _measure(frame, roi=(20, 20, 170, 200))
    assert m.found and m.cut and m.quality == 0.0 and m.x_px > 150


def test_the_tracked_float_adds_no_damping_on_a_lossless_video(tmp_path):
    # issue 37 item 5: zeta from tracked H.264 float videos came out 6-12 % high while f was right. The tracker reads
    # every swing alike: on a lossless encode (CRF 0) of a painted 5 deg tap decay zeta is within 1 % of the truth's;
    # the same clip at CRF 20 reads 30 % high (the encoder drops the small late swings' changes), so that error is
    # the encoder's, not the tracker's
    s = SynthSettings(noise_sigma=4.0, blur_px=0.8, quality=0.0, duration_s=4.0, tap_s=0.4, seed=37)
    s = replace(s, amplitude_deg=5.0, float_rounded=True, width=320, height=240)
    truth = render_video(tmp_path / "lossless.mp4", s).columns
    res = track_video(tmp_path / "lossless.mp4", TrackSettings())
    assert res.valid.all()
    tracked = Identifier().fit(signal_from_track(res)).result.parameters
    exact = Identifier().fit(Signal(truth["t_s"], truth["float_angle_deg"], "angle", "deg", "truth")).result.parameters
    assert abs(tracked["zeta"].value / exact["zeta"].value - 1) < 0.01
    assert abs(tracked["f_hz"].value / exact["f_hz"].value - 1) < 0.0005


def test_a_thin_float_the_colour_range_barely_holds_is_measured_whole_and_followed_by_its_own_colour():
    # issue 37: a 4 px blue stick on red juice reads purple after H.264's chroma subsampling (S 110-130 against the
    # preset's 140), so the range holds a few pixels of it or none (two pbr robot moves: 13 and 29 % of the frames
    # measured, from blobs of 12-30 px). Here a 60 x 4 px stick is a paler blue than the range holds (S 129) but for a
    # 16 x 2 px streak along its middle in the first frame (S 150); in the frames after, none of it is in the range.
    # The streak is grown to the whole stick by the stick's own colour, and the stick is then found by that colour
    blue = preset("blue")
    pale, streak = (tuple(int(f * c + (1 - f) * 150) for c in blue.bgr) for f in (0.5, 0.6))
    saturation = cv2.cvtColor(np.uint8([[pale, streak]]), cv2.COLOR_BGR2HSV)[0, :, 1]
    assert saturation[0] < blue.hsv.low[1] <= saturation[1]
    angles = [2.0, 2.0, -1.0, 3.0, 0.5, -2.5]
    frames = []
    for k, angle in enumerate(angles):
        shapes = [(_bar(160.0, 124.0, 60.0, 4.0, angle), pale)]
        if k == 0:
            shapes.append((_bar(160.0, 124.0, 16.0, 2.0, angle), streak))
        frames.append(_frame(shapes, seed=k))
    finder = FloatFinder(blue.hsv, (0, 0, 320, 240))
    ms = [finder.measure(f) for f in frames]
    assert all(m.found and m.quality >= VALID_QUALITY for m in ms)
    assert all(abs(m.length_px - 60.0) < 2.0 for m in ms)
    # a 4 px bar's rasterisation alone moves its angle by up to 0.14 deg, in the range or not
    assert all(abs(m.angle_deg - angle) < 0.2 for m, angle in zip(ms, angles))


def test_a_float_that_jumped_to_the_pictures_edge_is_searched_again_not_in_an_empty_window():
    # a blob taken for the float at the left, then one at the right edge (a jump of 230 px: another blob): the next
    # frame's window, moved on by that jump, lies past the picture's edge and holds no pixel; the finder searches
    # the whole picture again (it raised OpenCV's empty-image error: `track --float-color yellow` on a pbr still)
    finder = FloatFinder(RED.hsv, (0, 0, 320, 240))
    assert finder.measure(_frame([(_bar(40.0, 100.0, 50.0, 8.0, 0.0), RED.bgr)])).found
    assert finder.measure(_frame([(_bar(300.0, 100.0, 50.0, 8.0, 0.0), RED.bgr)])).found
    m = finder.measure(_frame([(_bar(160.0, 100.0, 50.0, 8.0, 0.0), RED.bgr)]))
    assert m.found and abs(m.x_px - 160.0) < 0.5
