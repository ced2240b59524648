"""The surface tracker on a real camera frame (../shared/data/real): a glass cylinder of blue water standing in a blue
holder, turned by known angles. Nothing here was rendered: the only truth is the rotation, and that the liquid is at
rest in an upright container (its surface's angle relative to the container is constant)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from conftest import ROOT

from sloshid.synthetic.stills import recoloured, still_clip
from sloshid.tracking.tracker import TrackSettings, track_video

REAL_FRAME = ROOT.parent / "shared" / "data" / "real" / "blue_cylinder_at_rest.png"
ROTATIONS = (-10.0, -6.0, -3.0, 0.0, 4.0, 7.0, 10.0)


@pytest.fixture(scope="module")
def real_clips(tmp_path_factory):
    """Eight-frame 960x540 H.264 clips of the real frame turned by each of ROTATIONS (noise 3, seeded)."""
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    folder = tmp_path_factory.mktemp("real")
    clips = {}
    for k, angle in enumerate(ROTATIONS):
        clips[angle] = folder / f"turned_{k}.mp4"
        still_clip(image, clips[angle], angle, frames=8, width=960, seed=k)
    return clips


def _median_angle(path, reference):
    res = track_video(path, TrackSettings(target="surface", reference=reference, smooth=False))
    assert res.valid.all(), f"{path.name}: {np.count_nonzero(~res.valid)} frames not valid"
    return float(np.median(res.angle_deg))


def test_a_real_cylinder_in_a_holder_of_its_colour_is_tracked_at_every_rotation(real_clips):
    # the holder touches the liquid from below in nearly the dye's colour, the bottom is hidden and the glass is thick:
    # every clip is tracked in every frame, the surface's image angle follows the rotation within 0.3 deg (the issue's
    # figure; the rotation is applied exactly, so the error is the tracker's and the codec's), and its angle relative to
    # the container (found on the glass's edges) stays within a 0.5 deg span
    image = {a: _median_angle(p, "image") for a, p in real_clips.items()}
    relative = {a: _median_angle(p, "container") for a, p in real_clips.items()}
    level = image[0.0]
    for angle in ROTATIONS:
        assert abs(image[angle] - level - angle) < 0.3, (angle, image[angle] - level)
    assert max(relative.values()) - min(relative.values()) < 0.5, relative
    # at rest in an upright cylinder the surface is square to the container's axis, to within the glass's and the
    # camera's imperfections (a degree is generous: the unturned frame reads -0.16)
    assert all(abs(v) < 1.0 for v in relative.values()), relative


@pytest.mark.parametrize("corners", [(0, 0, 0), (255, 255, 255)], ids=["black", "white"])
def test_a_real_frame_turned_with_filled_corners_is_tracked(real_clips, tmp_path, corners):
    # a photo turned in an editor has corners of one colour, not the reflected picture of the fixture: black corners
    # are as large as the dark preset's regions get, white ones join the wall. Turned by -7 and +5 deg, every frame is
    # tracked, the image angle follows the turn within the 0.3 deg of the unturned clip's (measured 0.21 and
    # 0.03-0.04), and the relative angle stays within a 0.5 deg span with the unturned clip's (measured 0.36)
    image = cv2.imread(str(REAL_FRAME))
    level = _median_angle(real_clips[0.0], "image")
    relative = [_median_angle(real_clips[0.0], "container")]
    for seed, angle in ((7, -7.0), (8, 5.0)):
        clip = tmp_path / f"filled_{seed}.mp4"
        still_clip(image, clip, angle, frames=8, width=960, seed=seed, corners=corners)
        assert abs(_median_angle(clip, "image") - level - angle) < 0.3, angle
        relative.append(_median_angle(clip, "container"))
    assert max(relative) - min(relative) < 0.5, relative


def test_a_real_frame_with_blurred_edges_is_tracked(tmp_path):
    # the real frame scaled down three times and back up (every edge three pixels wide, as a soft lens or a picture
    # upscaled to HD gives): its edge scatters 0.7-1.1 px about the fit, which as pixels of a small picture put every
    # frame under the valid quality; read against the surface's width, every frame is valid and the angle is the
    # small picture's within 0.1 deg (measured 0.007)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    small = cv2.resize(image, (image.shape[1] // 3, image.shape[0] // 3), interpolation=cv2.INTER_AREA)
    angles = {}
    for width in (small.shape[1], 3 * small.shape[1]):
        clip = tmp_path / f"w{width}.mp4"
        still_clip(small, clip, 0.0, frames=8, width=width, seed=0)
        angles[width] = _median_angle(clip, "image")
    assert abs(angles[3 * small.shape[1]] - angles[small.shape[1]]) < 0.1, angles


def test_the_real_frame_at_its_own_size_keeps_the_container_angle(tmp_path):
    # at the photo's native 1920 px the glass's edge points scatter over more pixels than at half size: runs kept
    # within one pixel of their line broke at half their length and, turned by 4 deg, another edge won the left wall
    # (relative angle +2.18 deg against -0.14 to -0.54 at the other turns). With the run's tolerance in proportion to
    # the picture's width the relative angle stays within a 0.5 deg span (measured 0.21 over seven turns)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    relative = {}
    for seed, angle in ((3, 0.0), (4, 4.0), (6, 10.0)):
        clip = tmp_path / f"t{seed}.mp4"
        still_clip(image, clip, angle, frames=8, width=1920, seed=seed)
        relative[angle] = _median_angle(clip, "container")
    assert max(relative.values()) - min(relative.values()) < 0.5, relative


def test_an_underexposed_real_frame_takes_the_dye_between_walls(tmp_path):
    # the real frame darkened (grey levels to the power 1.3, as a picture a stop under): its shadows, the holder's
    # dark parts and the camera body read as the `dark` preset over a larger region than the blue dye, and the dye
    # chosen as the largest region was `dark`, with no container around it: every frame was refused. The dye is the
    # largest region measured as a liquid between walls in the first frame (as `sloshid inspect` chooses), and the
    # larger one is named
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    clips = {}
    for name, picture in (("level", image), ("dark", np.clip(255 * (image / 255.0) ** 1.3, 0, 255).astype(np.uint8))):
        clips[name] = tmp_path / f"{name}.mp4"
        still_clip(picture, clips[name], 0.0, frames=8, width=640, seed=1)
    res = track_video(clips["dark"], TrackSettings(target="surface", smooth=False))
    assert res.valid.all() and res.dye == "blue (chosen from the first frame)"
    assert any("dark covers a larger region" in w for w in res.warnings), res.warnings
    # measured: 0.01 deg apart
    assert abs(np.median(res.angle_deg) - _median_angle(clips["level"], "image")) < 0.3


def test_an_roi_drawn_on_the_real_glass_outline_is_widened_to_its_walls(real_clips):
    # an ROI drawn along the glass's outer edges (960x540, the unturned clip; `sloshid inspect` suggests 286,116,414,346
    # around it): the liquid's box touched the ROI's sides and every frame was refused. The first frame measures no
    # surface in it and one in the ROI a tenth wider on each side, which is tracked, with a warning that names it;
    # the angle is the suggested ROI's within 0.1 deg (measured 0.04: the walls are read at the same edges)
    tight = (326, 116, 334, 346)
    res = track_video(real_clips[0.0], TrackSettings(target="surface", roi=tight, smooth=False))
    assert res.valid.all()
    assert any("roi` 326,116,334,346 widened to 293,81,400,416" in w for w in res.warnings), res.warnings
    wide = track_video(real_clips[0.0], TrackSettings(target="surface", roi=(286, 116, 414, 346), smooth=False))
    assert not any("widened" in w for w in wide.warnings)  # an ROI that holds the walls is kept as drawn
    assert abs(np.median(res.angle_deg) - np.median(wide.angle_deg)) < 0.1


def test_a_holder_running_out_of_the_picture_does_not_hide_the_liquid(tmp_path):
    # the frame's right three quarters (the blue holder under the glass runs out at the picture's left edge): the body
    # of the dye's colour touched the picture's side, which was taken for a liquid cut off there, and every frame was
    # refused; the liquid's column inside the glass is what has to stay inside the picture
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))[:, 500:]
    clip = tmp_path / "cut.mp4"
    still_clip(image, clip, 0.0, frames=8, width=640, seed=2)
    # measured: -0.31 deg against the container (the whole frame: -0.30)
    assert abs(_median_angle(clip, "container")) < 1.0


@pytest.mark.parametrize("power", [0.6, 0.7])
def test_a_brightened_real_frame_is_tracked_against_the_image_and_the_container(tmp_path, power):
    # the real frame brightened (grey levels to the power 0.6 or 0.7, as an overexposed picture): the water's top reads
    # hue 97-101, below the blue preset's 100, and at 0.6 the liquid's sides were lost (every frame refused); the preset's
    # hue bounds move out over the hues that continue the dye's. At 0.7 the glass's walls took a highlight 40 deg off in
    # half the frames, which were valid at -41 deg against the container; walls that disagree with the liquid's sides
    # by more than GLASS_AGREE_DEG are not used (those frames are read on the liquid's sides: -1.51 deg against -0.23 in
    # the others). Measured: -0.15 / -0.10 deg against the image (the frame's own: -0.19)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    clip = tmp_path / "bright.mp4"
    still_clip(np.clip(255 * (image / 255.0) ** power, 0, 255).astype(np.uint8), clip, 0.0, frames=8, width=640, seed=5)
    assert abs(_median_angle(clip, "image")) < 0.5
    res = track_video(clip, TrackSettings(target="surface", reference="container", smooth=False))
    assert res.valid.all() and np.all(np.abs(res.angle_deg) < 2.0), res.angle_deg


LIQUID_BOX = (625, 0, 1345, 870)
"""The real frame's liquid above its holder, where `recoloured` darkens it (x0, y0, x1, y1 at 1920 x 1080)."""


@pytest.mark.parametrize(("turn_hue", "dye"), [(30, "magenta"), (160, "green")], ids=["violet", "teal"])
def test_a_real_dye_between_two_presets_hues_is_tracked_and_inspected(tmp_path, run_cli, turn_hue, dye):
    # the real frame's blue turned to a violet (hue 131-135, between the blue and the magenta presets) and to a teal
    # (81-86, between green and blue): no preset takes the liquid, only its edges or the holder below it. track chose
    # `dark` (the holder's shadows) and refused every clip, inspect drew a 42 px sliver of the teal as the liquid and
    # suggested an ROI around it. The presets' hues are fitted to the dye (`dye_range`) before a preset is measured
    # as the liquid: every frame is tracked, following the turn within the 0.3 deg and relative to the
    # container within its 0.5 deg span (measured: violet 0.06 and 0.08 deg, teal 0.25 and 0.24), and inspect sees
    # the whole liquid
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    picture = recoloured(cv2.imread(str(REAL_FRAME)), turn_hue)
    image, relative = {}, {}
    for k, turn in enumerate((0.0, -7.0)):
        clip = tmp_path / f"turned_{k}.mp4"
        still_clip(picture, clip, turn, frames=8, width=960, seed=k)
        res = track_video(clip, TrackSettings(target="surface", smooth=False))
        assert res.valid.all() and res.dye == f"{dye} (chosen from the first frame)", (res.dye, res.valid)
        image[turn], relative[turn] = float(np.median(res.angle_deg)), _median_angle(clip, "container")
    assert abs(image[-7.0] - image[0.0] + 7.0) < 0.3, image
    assert abs(relative[-7.0] - relative[0.0]) < 0.5, relative
    code, out, err = run_cli("inspect", tmp_path / "turned_0.mp4", "-o", tmp_path / "look.png")
    assert code == 0, err
    width = int(next(line for line in out.splitlines() if line.startswith(f"surface: {dye} liquid")).split()[3][:3])
    assert width > 300, out  # the liquid is 340 px wide at 960 px (the sliver was 42)


def test_a_dark_liquid_beside_a_dark_camera_body_is_tracked(tmp_path):
    # the real frame's liquid darkened to a third of its brightness (a dark dye, the `dark` preset) while its blue
    # holder stays: the camera body at the picture's left edge is dark too and shares the liquid's rows. The liquid's
    # column was taken to reach the picture's side wherever anything dark touched it in a row, and every frame was
    # refused; now every frame is tracked, and the surface reads as the blue liquid's within the 0.3 deg
    # against the image (measured 0.09) and within its 0.5 deg span relative to the container (0.30)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    clips = {}
    image = cv2.imread(str(REAL_FRAME))
    for name, picture in (("blue", image), ("dark", recoloured(image, value=0.3, region=LIQUID_BOX))):
        clips[name] = tmp_path / f"{name}.mp4"
        still_clip(picture, clips[name], 0.0, frames=8, width=960, seed=0)
    res = track_video(clips["dark"], TrackSettings(target="surface", smooth=False))
    assert res.valid.all() and res.dye == "dark (chosen from the first frame)", res.dye
    for reference, within in (("image", 0.3), ("container", 0.5)):
        apart = _median_angle(clips["dark"], reference) - _median_angle(clips["blue"], reference)
        assert abs(apart) < within, (reference, apart)


def test_a_faint_real_dye_below_every_presets_saturation_is_tracked_with_its_own_range(tmp_path, run_cli):
    # the real frame's saturation halved (a faint dye: the liquid at saturation 127-135, under the blue preset's 140):
    # no preset measures it, and track took the holder's shadows (dark) and refused every clip, while inspect
    # suggested an 18 x 12 px blue speck as a float. The largest coloured region's own range (`own_range`, its value
    # above the dark preset's) is measured as the liquid: every frame is tracked, the turn followed within the issue's
    # 0.3 deg and the relative angle kept within its 0.5 deg (measured 0.02 and 0.00), and inspect suggests that range
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    picture = recoloured(cv2.imread(str(REAL_FRAME)), saturation=0.5)
    image, relative = {}, {}
    for k, turn in enumerate((0.0, -7.0)):
        clip = tmp_path / f"turned_{k}.mp4"
        still_clip(picture, clip, turn, frames=8, width=960, seed=k)
        res = track_video(clip, TrackSettings(target="surface", smooth=False))
        assert res.valid.all() and res.dye.endswith("no preset's (chosen from the first frame)"), res.dye
        image[turn], relative[turn] = float(np.median(res.angle_deg)), _median_angle(clip, "container")
    assert abs(image[-7.0] - image[0.0] + 7.0) < 0.3, image
    assert abs(relative[-7.0] - relative[0.0]) < 0.5, relative
    code, out, err = run_cli("inspect", tmp_path / "turned_0.mp4", "-o", tmp_path / "look.png")
    assert code == 0, err
    command = next(line for line in out.splitlines() if line.startswith("next: "))
    assert "--target surface --liquid-hsv-low" in command, out


def test_a_holder_base_running_out_of_one_side_ends_the_liquids_column(tmp_path):
    # the real frame brightened by 1.4 and turned by -7 deg: the blue holder's base runs out of the picture's left
    # side below the liquid, in the blue preset's colour, and the liquid's right side does not step out there. The
    # column through the liquid reached the picture's side below its walls and every frame was refused; it now ends
    # where it does, and the angle is the unbrightened frame's within 0.3 deg (measured 0.06)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    image = cv2.imread(str(REAL_FRAME))
    angles = {}
    for name, picture in (("level", image), ("bright", np.clip(image * 1.4, 0, 255).astype(np.uint8))):
        clip = tmp_path / f"{name}.mp4"
        still_clip(picture, clip, -7.0, frames=8, width=960, seed=2)
        angles[name] = _median_angle(clip, "image")
    assert abs(angles["bright"] - angles["level"]) < 0.3, angles


def test_a_container_filling_a_portrait_pictures_width_keeps_its_angle_across_turns(tmp_path):
    # the real frame cropped to 800 x 1080 about the cylinder, which then fills the picture's width: the liquid's sides
    # carried up to the glass above the liquid leave the picture at its top corner once the picture is turned, and the
    # glass's walls were not read at all; the liquid's sides alone moved the relative angle by 1.7 deg across the
    # turns. The glass is read over the rows where it is in the picture: the relative angle stays within the issue's
    # 0.5 deg across 0, +5 and -7 deg (measured 0.37)
    if not REAL_FRAME.is_file():
        pytest.skip("../shared/data/real is not beside this checkout")
    portrait = cv2.imread(str(REAL_FRAME))[:, 585:1385]
    relative = []
    for k, turn in enumerate((0.0, 5.0, -7.0)):
        clip = tmp_path / f"turned_{k}.mp4"
        still_clip(portrait, clip, turn, frames=8, width=540, seed=k)
        relative.append(_median_angle(clip, "container"))
    assert max(relative) - min(relative) < 0.5, relative
