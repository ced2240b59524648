"""The surface tracker on glasses rendered by an independent renderer (Blender's Cycles, tests/data/blender): light
that no code of sloshid's drew, turned as the outside check turned its photos, with the truth from the scene."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from conftest import ROOT

from sloshid.synthetic.stills import still_clip
from sloshid.tracking.surface import SurfaceFinder, dye_range
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
    for turn in TURNS_DEG:
        clip = tmp_path / f"turned{turn:+.0f}.mp4"
        still_clip(image, clip, turn, frames=10, seed=3)
        res = track_video(clip, TrackSettings(target="surface", smooth=False))
        assert res.valid.mean() >= 0.8
        got = float(np.median(res.angle_deg[res.valid.astype(bool)]))
        assert got == pytest.approx(truth["surface_angle_deg"] + turn, abs=0.3)
