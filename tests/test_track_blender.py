"""The surface tracker on glasses rendered by an independent renderer (Blender's Cycles, tests/data/blender): light
that no code of sloshid's drew, turned as the outside check turned its photos, with the truth from the scene."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from conftest import ROOT

from sloshid.synthetic.stills import still_clip
from sloshid.tracking.surface import SurfaceFinder, auto_liquid_preset, coloured_regions, darker_liquid, dye_range
from sloshid.tracking.tracker import TrackSettings, track_video
from sloshid.video.colors import PRESETS

BLENDER = ROOT / "tests" / "data" / "blender"
TURNS_DEG = (0.0, 5.0, -7.0)


@pytest.mark.parametrize("name", ["glass06", "glass07"])
@pytest.mark.parametrize("turn", TURNS_DEG)
def test_a_glass_rendered_by_blender_is_tracked_against_the_image_and_the_container(tmp_path, name, turn):
    # glass06: a straight glass of red dye seen 8.8 deg from above; glass07: a tumbler of orange juice leaning 1.2 deg,
    # seen 6.7 deg from above; both with a thick bottom, camera rolled. The surface targets are 0.15 / 0.4 deg
    # (median / p95) against the image, 0.3 / 0.6 relative to the container: a still clip's median is held to 0.3.
    record = json.loads((BLENDER / f"{name}.json").read_text())
    truth = record["truth"]
    clip = tmp_path / "turned.mp4"
    still_clip(cv2.imread(str(BLENDER / f"{name}.jpg")), clip, turn, frames=10, seed=3)
    for reference, want in (("image", truth["surface_angle_deg"] + turn), ("container", truth["rel_angle_deg"])):
        res = track_video(clip, TrackSettings(target="surface", reference=reference, smooth=False))
        assert res.valid.mean() >= 0.8, f"{reference}: {res.valid.mean():.0%} of frames valid"
        got = float(np.median(res.angle_deg[res.valid.astype(bool)]))
        assert got == pytest.approx(want, abs=0.3), reference


def _read_at_every_turn(tmp_path, image: np.ndarray, truth: dict) -> list[str]:
    """The picture turned by each of TURNS_DEG, tracked with no option: the surface within 0.3 deg against the image.
    Returns the dye each turn was tracked by."""
    dyes = []
    for turn in TURNS_DEG:
        clip = tmp_path / f"turned{turn:+.0f}.mp4"
        still_clip(image, clip, turn, frames=10, seed=3)
        res = track_video(clip, TrackSettings(target="surface", smooth=False))
        assert res.valid.mean() >= 0.8, f"{turn:+.0f} deg"
        got = float(np.median(res.angle_deg[res.valid.astype(bool)]))
        assert got == pytest.approx(truth["surface_angle_deg"] + turn, abs=0.3), f"{turn:+.0f} deg"
        dyes.append(res.dye)
    return dyes


def test_a_pale_dye_that_its_preset_holds_in_part_is_measured_across_the_glass(tmp_path):
    # glass14: a tumbler of blue dye (saturation 90-160) that pales towards a highlight; the blue preset (from 140)
    # holds a tenth of it. Read with the preset's floor, the liquid was a sliver at the glass's right (74 px of the
    # glass's 246 px box) and its angle relative to the container 26-32 deg off in some turns. The floor now follows
    # the dye down: the liquid spans the glass (the inner width at the surface is at least 0.75 of the box: taper 0.16,
    # glass 10 % of the radius; measured 0.84) and the surface is read within 0.3 deg against the image at every turn.
    record = json.loads((BLENDER / "glass14.json").read_text())
    truth = record["truth"]
    box_width = truth["box_x1_px"] - truth["box_x0_px"]
    image = cv2.imread(str(BLENDER / "glass14.jpg"))
    roi = (0, 0, image.shape[1], image.shape[0])
    finder = SurfaceFinder(dye_range(image, roi, PRESETS["blue"].hsv), roi)
    m = finder.measure(image)
    assert m.found and m.width_px >= 0.75 * box_width, m.width_px
    _read_at_every_turn(tmp_path, image, truth)


def test_a_near_black_liquid_that_greys_behind_its_glass_is_tracked_with_no_option(tmp_path):
    # glass02: a straight glass of cola seen 0.9 deg from above; behind the bright glass its body reads value 40-100,
    # and the dark preset (to 60) holds a patch of its upper middle (4 % of the picture). With the preset's ceiling no
    # frame of the unturned clip was valid; the ceiling now follows the liquid up (to 113, measured) and the surface is
    # read within 0.3 deg against the image at every turn.
    record = json.loads((BLENDER / "glass02.json").read_text())
    truth = record["truth"]
    image = cv2.imread(str(BLENDER / "glass02.jpg"))
    ceiling = dye_range(image, (0, 0, image.shape[1], image.shape[0]), PRESETS["dark"].hsv).high[2]
    assert 90 <= ceiling <= 120, ceiling  # between the body's 100 and the preset's reach (60 + 60)
    _read_at_every_turn(tmp_path, image, truth)


def test_a_cola_greyed_past_every_preset_is_tracked_as_the_region_darker_than_the_rest(tmp_path):
    # glass20: a tumbler of cola seen 1.6 deg from above, its body value 74-108 with no hue behind the bright glass
    # (the wall reads 230-250): no preset's region is large enough, nor any coloured one (the table's beige is too
    # pale), and track refused with "no dyed liquid of any preset colour". It now takes the largest region darker than
    # the rest that reaches neither side nor the top of the picture (`darker_liquid`, as inspect suggests it), and reads
    # the surface within 0.3 deg against the image at every turn.
    truth = json.loads((BLENDER / "glass20.json").read_text())["truth"]
    image = cv2.imread(str(BLENDER / "glass20.jpg"))
    roi = (0, 0, image.shape[1], image.shape[0])
    assert auto_liquid_preset(image, roi)[0] is None
    hsv, _, stats, order = coloured_regions(image, roi)
    (x, y, w, _), dark = darker_liquid(hsv, stats, order)
    # the region lies inside the glass's outline, below its rim; its range ends between the body's and the wall's value
    assert truth["box_x0_px"] - 2 <= x and x + w <= truth["box_x1_px"] + 2 and truth["box_y0_px"] <= y, (x, y, w)
    assert 108 <= dark.high[2] < 230, dark
    assert "darker than the rest" in _read_at_every_turn(tmp_path, image, truth)[0]


def test_walls_found_afresh_carry_no_motion_into_the_next_frames_search(tmp_path):
    # glass16: a tumbler of orange juice seen from the side (0.3 deg), turned by +5 deg. Its first walls were found by
    # Hough and refitted 2.1 px off the Hough lines; that offset was kept as the walls' motion per frame, the glass's
    # walls were then sought 2.1 px to the left of where they stood and the right one settled on another edge (the
    # container read 1.9 deg off in every later frame; 0.03 now). The relative angle is held to the 0.3 deg
    record = json.loads((BLENDER / "glass16.json").read_text())
    clip = tmp_path / "turned.mp4"
    still_clip(cv2.imread(str(BLENDER / "glass16.jpg")), clip, 5.0, frames=10, seed=3)
    res = track_video(clip, TrackSettings(target="surface", reference="container", smooth=False))
    ok = res.valid.astype(bool)
    assert ok.mean() >= 0.8
    assert np.abs(res.angle_deg[ok] - record["truth"]["rel_angle_deg"]).max() < 0.3
