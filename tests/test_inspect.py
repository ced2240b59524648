"""sloshid inspect: the first look at a user's own video finds the target and colour, suggests a track command that
runs, says what it saw when nothing is there, and refuses bad input with one sentence and no file."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import cv2
import numpy as np
import pytest

import sloshid
from sloshid.core.tables import read_csv
from sloshid.synthetic.render import SynthSettings, render_frames, render_video
from sloshid.synthetic.stills import recoloured, still_clip
from sloshid.tracking.inspect import TRIAL_S, Trial, _try, inspect_video
from sloshid.tracking.tracker import TrackSettings, measure_frame, track_video
from sloshid.video.frames import FrameReader, VideoWriter

REAL_FRAME = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "blue_cylinder_at_rest.png"
SMALL = ["--width", "320", "--height", "240", "--duration", "1", "--noise", "3", "--seed", "5"]


def _next_command(out: str) -> list[str]:
    """The words of the `next: sloshid track ...` line inspect printed."""
    line = next(line for line in out.splitlines() if line.startswith("next: "))
    return shlex.split(line.removeprefix("next: "))


def _grey_frames(rng: np.random.Generator, n: int = 5) -> list[np.ndarray]:
    """A grey wall lit from one side, with camera noise: nothing coloured."""
    ramp = np.linspace(90, 200, 320)[None, :, None]
    return [np.clip(ramp + rng.normal(0, 3, (240, 320, 3)), 0, 255).astype(np.uint8) for _ in range(n)]


def _write(path: Path, frames: list[np.ndarray], fps: float = 30.0) -> Path:
    h, w = frames[0].shape[:2]
    with VideoWriter(path, w, h, fps, quality=18) as writer:
        for i, frame in enumerate(frames):
            writer.write(frame, i / fps)
    return path


@pytest.fixture(scope="module")
def grey_video(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("grey") / "grey.mp4", _grey_frames(np.random.default_rng(3)))


@pytest.mark.parametrize(
    "scene, words",
    [
        ([], ["--float-color", "green"]),
        (["--scene", "surface"], ["--target", "surface", "--liquid-color", "orange"]),
    ],
)
def test_a_synth_clip_gets_its_target_and_colour_and_the_command_tracks(tmp_path, run_cli, scene, words):
    colour = words[-1]
    clip = tmp_path / "clip.mp4"
    option = "--float-color" if not scene else "--liquid-color"
    assert run_cli("synth", clip, *SMALL, *scene, option, colour)[0] == 0
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "look.png")
    assert code == 0, err
    command = _next_command(out)
    # the next line comes last, after the picture written, as every command's (it came before "wrote ...")
    assert out.strip().splitlines()[-2:] == [f"wrote {tmp_path / 'look.png'}", "next: " + shlex.join(command)]
    assert command[:5] == ["sloshid", "track", str(clip), "-o", str(tmp_path / "clip_angles.csv")]
    assert command[5 : 5 + len(words)] == words
    assert command[-2:] == ["--reference", "container"]  # the container's walls were found
    picture = cv2.imread(str(tmp_path / "look.png"))
    assert picture.shape[1] == 2 * 320 + 8  # two panels: surface and float target
    code, _, err = run_cli(*command[1:])  # the suggested command, as printed
    assert code == 0, err
    assert (tmp_path / "clip_angles.csv").exists()


def test_the_real_frame_shows_blue_liquid_and_a_surface_command_with_an_roi(tmp_path, run_cli):
    # at half size (960x540), where the tracker measures the frame alone (at full size a single frame's front edge fits
    # to a quality of 0.39 across the meniscus band; track measures it from the settled elevation after 15 frames)
    if not REAL_FRAME.exists():
        pytest.skip("../shared/data/real is not beside this checkout")
    frame = cv2.resize(cv2.imread(str(REAL_FRAME)), (960, 540), interpolation=cv2.INTER_AREA)
    clip = _write(tmp_path / "real.mp4", [frame] * 3)
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "real.png")
    assert code == 0, err  # measured: the liquid's column stops above the holder of its colour
    assert "colours found (share of the picture): blue" in out
    assert "surface: blue liquid " in out and "measured, surface at " in out
    command = _next_command(out)
    assert command[5:9] == ["--target", "surface", "--liquid-color", "blue"]
    x, y, w, h = map(int, command[command.index("--roi") + 1].split(","))
    # around the cylinder: its liquid spans x 325-660 with its surface at y 288; the camera body at the left
    # (x < 85) and the holder's plate below y 450 are left out
    assert 225 < x < 325 and 660 < x + w < 750 and 75 < y < 280 and 425 < y + h <= 480
    assert (tmp_path / "real.png").exists()


def test_an_roi_that_loses_the_surface_is_not_put_in_the_command(tmp_path):
    # the real frame's hues turned by 110 (a yellow-green dye in a holder of its colour): the green preset holds the
    # liquid in patches, with its holder, and the ROI around that region ran inside the liquid's sides; the command
    # with it found no liquid in any frame. The surface measured in the whole picture is suggested without that ROI
    if not REAL_FRAME.exists():
        pytest.skip("../shared/data/real is not beside this checkout")
    clip = tmp_path / "h110.mp4"
    still_clip(recoloured(cv2.imread(str(REAL_FRAME)), turn_hue=110), clip, 0.0, frames=45, width=960, seed=0)
    look = inspect_video(clip)
    assert any("the surface is not measured: not used below" in note for note in look.notes), look.notes
    assert look.track_settings is not None and "roi" not in look.track_settings
    res = track_video(clip, TrackSettings(**look.track_settings, smooth=False))
    assert res.valid.mean() >= 0.8  # measured: 39 of 45 frames valid


def test_an_roi_on_the_real_glass_outline_is_inspected_as_track_widens_it(tmp_path, run_cli):
    # an ROI drawn along the glass's outer edges (960x540): inspect found no walls in it and suggested tracking the
    # holder's shadow as a dark float. It now looks where track looks (the ROI a tenth wider on each side), says so,
    # and suggests the surface in that ROI, which tracks
    if not REAL_FRAME.exists():
        pytest.skip("../shared/data/real is not beside this checkout")
    frame = cv2.resize(cv2.imread(str(REAL_FRAME)), (960, 540), interpolation=cv2.INTER_AREA)
    clip = _write(tmp_path / "real.mp4", [frame] * 3)
    code, out, err = run_cli("inspect", clip, "--roi", "326,116,334,346", "-o", tmp_path / "real.png")
    assert code == 0, err
    assert "the ROI 326,116,334,346 cuts the container's walls" in out and "looked at 293,81,400,416" in out
    command = _next_command(out)
    assert command[5:9] == ["--target", "surface", "--liquid-color", "blue"]
    assert command[command.index("--roi") + 1] == "293,81,400,416"
    assert run_cli(*command[1:])[0] == 0


def test_a_video_with_nothing_coloured_says_what_it_saw(grey_video, tmp_path, run_cli):
    code, out, err = run_cli("inspect", grey_video, "-o", tmp_path / "g.png")
    assert code == 2
    assert err.count("\n") == 1 and "nothing track could follow was found" in err and "Traceback" not in err
    assert ": a grey picture (no coloured region, median saturation" in err and "g.png" in err
    assert "a grey picture" in out and "median saturation" in out
    assert "next:" not in out
    assert (tmp_path / "g.png").exists()  # the picture is what was seen


def _surface_clip(path: Path, paint) -> Path:
    """sloshid synth's dyed-liquid scene (blue dye, 320x240, 1 s), each frame changed by `paint(frame)` in place."""
    s = SynthSettings(scene="surface", width=320, height=240, duration_s=1.0, noise_sigma=3.0, seed=5)
    with VideoWriter(path, s.width, s.height, s.fps, quality=18) as writer:
        for row, frame in render_frames(s):
            paint(frame)
            writer.write(frame, row["t_s"])
    return path


def test_a_dye_no_preset_takes_is_measured_with_a_range_of_its_own(tmp_path, run_cli):
    def cyan(frame):  # the blue dye turned to cyan (hue about 93), between the green and blue presets' ranges
        hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
        dyed = hsv[..., 1] > 100
        hsv[..., 0][dyed] -= 20
        frame[:] = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)

    clip = _surface_clip(tmp_path / "cyan.mp4", cyan)
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "c.png")
    assert code == 0, err
    assert "the largest coloured regions: cyan (hue 9" in out
    command = _next_command(out)
    assert command[5:7] == ["--target", "surface"] and command[7] == "--liquid-hsv-low"
    assert 82 <= int(command[8].split(",")[0]) <= 88 and 98 <= int(command[10].split(",")[0]) <= 104
    assert run_cli(*command[1:])[0] == 0  # the range inspect made tracks the clip


def test_the_liquid_in_its_container_wins_over_a_larger_label(tmp_path, run_cli):
    # a red label larger than the blue liquid: track's automatic dye takes the red; inspect measures both, and only
    # the blue one stands between the container's walls
    clip = _surface_clip(tmp_path / "label.mp4", lambda f: cv2.rectangle(f, (236, 4), (316, 144), (40, 40, 215), -1))
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "l.png")
    assert code == 0, err
    assert "colours found (share of the picture): red 1" in out and "measured as a surface too: red" in out
    command = _next_command(out)
    assert command[5:9] == ["--target", "surface", "--liquid-color", "blue"] and command[-1] == "container"
    assert run_cli(*command[1:])[0] == 0


def test_at_picks_the_frame_on_screen_at_that_time(tmp_path, run_cli):
    frames = _grey_frames(np.random.default_rng(5), 10)
    for f in frames[6:]:  # from 0.2 s on, a blue bar floats in the picture
        cv2.rectangle(f, (120, 110), (200, 122), (215, 80, 30), -1)
    clip = _write(tmp_path / "late.mp4", frames)
    assert run_cli("inspect", clip, "-o", tmp_path / "a.png", "--at", "0.19")[0] == 2  # frame 5, at 0.167 s
    code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "b.png", "--at", "0.21")
    assert code == 0 and "frame at 0.200 s" in out and "--float-color blue" in out


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--at", "0.4"], "--at 0.4 s is beyond the end of"),
        (["--at", "60"], "is beyond the end of"),
        (["--at", "-1"], "--at must be a time of 0 s or more"),
        (["--at", "inf"], "--at must be a finite number of seconds, got inf"),  # it said "of 0 s or more"
        (["--roi", "300,200,50,50"], "--roi 300,200,50,50 reaches beyond the 320x240 frame"),  # it said "ROI"
        (["-o", "{video}"], "must end in .png"),
        (["--float-color", "purple"], "unknown colour 'purple'"),
    ],
)
def test_bad_input_is_one_sentence_and_writes_nothing(grey_video, tmp_path, run_cli, extra, message):
    extra = [str(grey_video) if e == "{video}" else e for e in extra]
    args = ["-o", tmp_path / "p.png", *extra] if "-o" not in extra else extra
    code, out, err = run_cli("inspect", grey_video, *args)
    assert code == 2 and message in err, err
    assert err.count("\n") == 1 and "Traceback" not in err and out == ""
    assert list(tmp_path.iterdir()) == []  # no picture, no temporary leftovers


def test_not_a_video_a_one_frame_video_and_an_output_over_the_input_are_refused(grey_video, tmp_path, run_cli):
    (tmp_path / "notes.mp4").write_text("not a video\n")
    _write(tmp_path / "one.mp4", _grey_frames(np.random.default_rng(6), 1))
    disguised = tmp_path / "clip.png"  # a video named like a picture: -o the same path would replace it
    disguised.write_bytes(grey_video.read_bytes())
    still = tmp_path / "still.png"
    cv2.imwrite(str(still), _grey_frames(np.random.default_rng(6), 1)[0])
    cases = [
        (tmp_path / "notes.mp4", ["-o", tmp_path / "n.png"], "is not a video FFmpeg can decode"),
        (tmp_path / "one.mp4", ["-o", tmp_path / "o.png"], "holds a single frame: inspect looks at a picture"),
        (disguised, ["-o", disguised], "is also an input of this run"),
        (still, ["-o", tmp_path / "s.png", "--at", "0.5"], "is a still picture, its one frame at 0 s: leave out --at"),
    ]
    before = sorted(tmp_path.iterdir())
    for video, args, message in cases:
        code, _, err = run_cli("inspect", video, *args)
        assert code == 2 and message in err and err.count("\n") == 1, err
    assert sorted(tmp_path.iterdir()) == before
    assert disguised.read_bytes() == grey_video.read_bytes()


@pytest.fixture(scope="module")
def float_frames():
    """sloshid synth's red float scene (320x240, 0.5 s): its frames."""
    s = SynthSettings(width=320, height=240, duration_s=0.5, noise_sigma=3.0, seed=5)
    return [frame for _, frame in render_frames(s)]


@pytest.mark.parametrize("suffix", [".png", ".jpg"])
def test_a_still_picture_is_inspected_and_its_command_is_for_the_video(float_frames, tmp_path, run_cli, suffix):
    # a frame saved as a picture is inspected, and the command it prints names VIDEO (track measures a video), which
    # with the video put in tracks it
    picture = tmp_path / f"frame{suffix}"
    cv2.imwrite(str(picture), float_frames[0])
    clip = _write(tmp_path / "clip.mp4", float_frames)
    code, out, err = run_cli("inspect", picture, "-o", tmp_path / "look.png")
    assert code == 0, err
    assert out.startswith(f"{picture}: a still picture, 320x240 px\n") and "frame at" not in out
    assert "run the command below on the video this picture is a frame of (VIDEO;" in out
    command = _next_command(out)
    assert command[:5] == ["sloshid", "track", "VIDEO", "-o", "VIDEO_angles.csv"]
    assert cv2.imread(str(tmp_path / "look.png")).shape[1] == 2 * 320 + 8
    assert command[5:] == ["--float-color", "red", "--reference", "container"]
    assert run_cli("inspect", picture, "-o", tmp_path / "at0.png", "--at", "0")[0] == 0
    angles = tmp_path / "angles.csv"
    code, _, err = run_cli("track", clip, "-o", angles, *command[5:])
    assert code == 0, err
    assert read_csv(angles)["valid"].mean() > 0.9


def test_the_api_inspects_a_still_picture(float_frames, tmp_path):
    picture = tmp_path / "frame.png"
    cv2.imwrite(str(picture), float_frames[0])
    res = sloshid.inspect(picture)
    assert res.still and res.t_s == 0.0 and res.target == "float" and res.measured
    assert "sloshid.track(VIDEO, float_color='red'" in res.summary()
    assert json.loads(json.dumps(res.to_dict(), allow_nan=False))["still"] is True
    with pytest.raises(sloshid.UserError, match="is a still picture, its one frame at 0 s"):
        sloshid.inspect(picture, at=0.1)


def test_the_default_picture_goes_beside_the_video_but_never_over_a_file(tmp_path, run_cli):
    clip = _write(tmp_path / "grey.mp4", _grey_frames(np.random.default_rng(7)))
    assert run_cli("inspect", clip)[0] == 2
    made = tmp_path / "grey_inspect.png"
    first = made.read_bytes()
    code, _, err = run_cli("inspect", clip)
    assert code == 2 and "already exists; give -o PICTURE.png" in err
    assert made.read_bytes() == first


def test_the_api_gives_the_commands_result(tmp_path, run_cli):
    clip = tmp_path / "clip.mp4"
    assert run_cli("synth", clip, *SMALL)[0] == 0
    res = sloshid.inspect(clip, picture=tmp_path / "api.png")
    assert isinstance(res, sloshid.InspectResult)
    assert res.target == "float" and res.measured and res.track_settings["float_color"] == "red"
    assert "float_color='red'" in res.summary()  # the Python call, in the library's own names
    assert sloshid.track(clip, **res.track_settings, smooth=False).valid.mean() > 0.9  # and the call tracks
    assert res.suggested_roi is not None and (tmp_path / "api.png").exists()
    doc = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert doc["target"] == "float" and doc["float_candidates"][0]["color"] == "red"
    code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "cli.png")
    from sloshid.cli.inspect_cmd import track_command, track_options

    assert code == 0 and shlex.join(_next_command(out)) == track_command(clip, res.track_settings, track_options())
    assert all(line in out for line in res.summary().splitlines() if "`" not in line and "sloshid.track(" not in line)


@pytest.mark.parametrize("target", ["float", "surface"])
def test_measure_frame_is_what_track_measures_in_the_first_frame(tmp_path, target):
    # inspect's one call into the tracker: it must keep measuring what track does (a level camera: track's revision
    # of a span's first frames, with the elevation held after them, changes nothing there)
    clip = tmp_path / "clip.mp4"
    settings = SynthSettings(scene=target, width=320, height=240, duration_s=0.6, noise_sigma=3.0, seed=8)
    render_video(clip, settings)
    tracked = track_video(clip, TrackSettings(target=target, reference="container", smooth=False))
    frame = next(iter(FrameReader(clip, False)))[2]
    colour = {"liquid_color": "blue"} if target == "surface" else {}
    track = TrackSettings(target=target, reference="container", **colour)
    row, drawn, _ = measure_frame(frame, 0.0, track, (0, 0, 320, 240), None)
    assert row[8] == 1 and tracked.valid[0] == 1
    assert row[2] == pytest.approx(tracked.angle_deg[0], abs=1e-6)
    assert row[4] == pytest.approx(tracked.container_angle_deg[0], abs=1e-6)
    assert row[5:7] == pytest.approx((tracked.x_px[0], tracked.y_px[0]), abs=1e-6)
    assert drawn.shape == frame.shape


def test_a_given_roi_is_searched_alone_and_kept_in_the_command(tmp_path, run_cli):
    clip = tmp_path / "clip.mp4"
    assert run_cli("synth", clip, *SMALL)[0] == 0
    code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "in.png", "--roi", "60,40,200,180")
    assert code == 0 and "(share of the ROI): red 1.0" in out
    command = _next_command(out)
    assert command[command.index("--roi") + 1] == "60,40,200,180"
    x, y, w, h = map(int, out.split("suggested ROI: --roi ")[1].split()[0].split(","))
    assert x >= 60 and y >= 40 and x + w <= 260 and y + h <= 220  # inside the ROI searched
    code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "out.png", "--roi", "0,0,80,60")  # beside the float
    assert code == 2 and "next:" not in out


@pytest.mark.parametrize("turn_deg", [-10.0, 10.0])
def test_the_suggested_roi_holds_the_real_liquid_turned_in_the_picture(tmp_path, turn_deg):
    if not REAL_FRAME.exists():
        pytest.skip("../shared/data/real is not beside this checkout")
    frame = cv2.imread(str(REAL_FRAME))
    turn = cv2.getRotationMatrix2D((960, 540), turn_deg, 0.5)  # turned about the centre, at half size
    turn[:, 2] -= (480, 270)  # the centre to the half-size picture's centre
    turned = cv2.warpAffine(frame, turn, (960, 540), borderMode=cv2.BORDER_REFLECT)
    res = sloshid.inspect(_write(tmp_path / "turned.mp4", [turned] * 3))
    assert res.target == "surface" and res.liquid.dye == "blue"
    # the blue liquid's corners in the real frame (x 650-1320 between the walls, surface at y 575; the holder from y 900
    # rises above y 880 on one side once turned, and the ROI stops where it begins)
    corners = np.array([[650, 575, 1], [1320, 575, 1], [650, 800, 1], [1320, 800, 1]]) @ turn.T
    x, y, w, h = res.suggested_roi
    assert (corners[:, 0] > x).all() and (corners[:, 0] < x + w).all()
    assert (corners[:, 1] > y).all() and (corners[:, 1] < y + h).all()
    assert w < 0.6 * 960  # the container, not the picture


def test_a_float_measured_beside_the_liquid_gets_its_command_too(tmp_path, run_cli):
    clip = _surface_clip(tmp_path / "both.mp4", lambda f: cv2.rectangle(f, (140, 112), (180, 120), (40, 40, 215), -1))
    code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "b.png")
    assert code == 0 and "--target surface --liquid-color blue" in " ".join(_next_command(out))
    line = next(line for line in out.splitlines() if line.startswith("a red float is measured too"))
    other = shlex.split(line.split("instead: ")[1])
    assert other[5:7] == ["--float-color", "red"] and run_cli(*other[1:])[0] == 0


def _yellow_float_on_orange(path: Path) -> list:
    """A painted yellow float recoloured to hue 18 on its blue liquid recoloured to hue 12 (a thin yellow plank on
    orange juice read hue 18-21 in a held-out path-traced clip): the orange preset holds both as one body, the yellow
    preset (from hue 22) not the float. Its (truth, frame) list."""
    small = dict(width=320, height=240, duration_s=0.5, noise_sigma=3.0, blur_px=1.0, quality=18, seed=11)
    s = SynthSettings(**small, float_length_frac=0.3, float_color="yellow")
    frames = list(render_frames(s))
    with VideoWriter(path, s.width, s.height, s.fps, "h264", s.quality) as video:
        for row, frame in frames:
            hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
            hue, coloured = hsv[..., 0], hsv[..., 1] >= 20
            yellow, blue = coloured & (hue >= 22) & (hue <= 35), coloured & (hue >= 85) & (hue <= 130)
            hue[yellow], hue[blue] = 18, 12
            video.write(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), row["t_s"])
    return frames


def test_a_named_float_colour_is_looked_at_relaxed_as_track_relaxes_it(tmp_path, run_cli):
    # unnamed, inspect sees the orange liquid and no yellow float, and suggests the surface; named, the yellow range
    # is relaxed as track relaxes it (hues widened by 4), the float found on the liquid, and the command tracks it
    frames = _yellow_float_on_orange(tmp_path / "y.mp4")
    code, out, _ = run_cli("inspect", tmp_path / "y.mp4", "-o", tmp_path / "a.png")
    assert code == 0 and "--target surface" in " ".join(_next_command(out)) and "relaxed" not in out
    code, out, _ = run_cli("inspect", tmp_path / "y.mp4", "-o", tmp_path / "b.png", "--float-color", "yellow")
    assert code == 0 and "float, yellow (the preset's range relaxed, its hues widened by 4" in out
    command = _next_command(out)
    assert "--target" not in command and command[5:7] == ["--float-color", "yellow"]
    assert run_cli(*command[1:])[0] == 0
    tracked = read_csv(command[4])
    assert tracked["valid"].mean() > 0.9
    # the float's centre (truth), not a speck of the relaxed range elsewhere on the liquid
    assert np.abs(tracked["x_px"] - np.array([row["float_x_px"] for row, _ in frames])).max() < 1.0


def test_a_named_float_colour_not_in_the_frame_says_so_and_suggests_what_it_would_unnamed(tmp_path, run_cli):
    # a review's cases: relaxed, a colour finds something on any clip; inspect takes it only as a float lying on the
    # surface, no part of another float, not the liquid's own colour, and on the first frame, which track relaxes on
    surface = _surface_clip(tmp_path / "s.mp4", lambda f: None)  # a blue dye, no float
    frames = _yellow_float_on_orange(tmp_path / "y.mp4")
    cases = [
        (surface, ["--float-color", "magenta"], "no magenta float was measured", "--target surface"),
        (surface, ["--float-color", "blue"], "(it is the liquid's colour here)", "--target surface"),
        (tmp_path / "y.mp4", ["--float-color", "orange"], "(it is the liquid's colour here)", "--target surface"),
        # frame 3 of 15: track decides on the first frame whether to relax
        (
            tmp_path / "y.mp4",
            ["--float-color", "yellow", "--at", str(frames[3][0]["t_s"])],
            "on the video's first",
            "-o",
        ),
    ]
    for clip, extra, note, command in cases:
        code, out, _ = run_cli("inspect", clip, "-o", tmp_path / "p.png", *extra)
        assert code == 0 and note in out and "relaxed, its hues" not in out, (extra, out)
        assert command in " ".join(_next_command(out))
        (tmp_path / "p.png").unlink()


def test_a_relaxed_colour_across_the_surface_or_on_another_float_is_not_taken_for_the_float(tmp_path, run_cli):
    # an orange dye's rim, read yellow relaxed (hues widened by 6), lies across the level surface (+28 deg): not a
    # float; a magenta range widened by 6 finds the red float's end: a part of that float, which stays the command's
    orange = tmp_path / "o.mp4"
    assert run_cli("synth", orange, "--scene", "surface", "--liquid-color", "orange", *SMALL)[0] == 0
    code, out, _ = run_cli("inspect", orange, "-o", tmp_path / "o.png", "--float-color", "yellow")
    assert code == 0 and "across the liquid's surface" in out and "--target surface" in " ".join(_next_command(out))
    red = tmp_path / "r.mp4"
    assert run_cli("synth", red, *SMALL)[0] == 0
    code, out, _ = run_cli("inspect", red, "-o", tmp_path / "r.png", "--float-color", "magenta")
    assert code == 0 and "a part of the red float" in out
    assert _next_command(out)[5:7] == ["--float-color", "red"]


def test_a_path_traced_render_gets_a_surface_command_that_tracks(tmp_path, run_cli):
    # a physically based render (scene seed 1000: an orange juice in a beaker with graduation marks, 320x240 at 4
    # samples per pixel): inspect finds the orange liquid, and its suggested command tracks the surface against the image
    # within 1 deg of the scene's truth (measured 0.38 deg; the path tracer's specks at this size are most of it)
    clip = tmp_path / "pbr.mp4"
    size = ("--width", "320", "--height", "240", "--spp", "4", "--duration", "0.3", "--fps", "10")
    assert run_cli("synth", clip, "--renderer", "pbr", "--scene-seed", 1000, "--scene", "surface", *size)[0] == 0
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "look.png")
    assert code == 0, err
    command = _next_command(out)
    assert command[5:9] == ["--target", "surface", "--liquid-color", "orange"]
    image_reference = [word for word in command[1:] if word not in ("--reference", "container")]
    code, _, err = run_cli(*image_reference)
    assert code == 0, err
    tracked = read_csv(tmp_path / "pbr_angles.csv")
    truth = read_csv(tmp_path / "pbr_truth.csv")
    assert tracked["valid"].all()
    assert np.abs(tracked["angle_deg"] - truth["surface_angle_deg"]).max() < 1.0


def test_a_grey_liquid_darker_than_the_rest_gets_a_range_of_its_own(tmp_path, run_cli):
    # a liquid with no hue, darker than a pale wall (a cola greyed by a bright glass, as Blender renders it: value
    # 140-200 where the dark preset ends at 60), in a glass drawn as two grey lines, its surface turned by
    # atan(6 / 100) = 3.43 deg, beige specks on the wall: no preset and no coloured region is the liquid, so inspect
    # looks at the darker region and its command tracks the surface
    rng = np.random.default_rng(11)
    frames = []
    for _ in range(8):
        frame = np.full((240, 320, 3), 230, np.float64)
        frame[60:215, 104:107] = frame[60:215, 213:216] = 150  # the glass's walls
        cv2.fillPoly(frame, [np.array([[107, 123], [213, 117], [213, 205], [107, 205]], np.int32)], (120, 122, 128))
        frame[30:32, 40:42] = (150, 190, 215)  # beige specks
        frames.append(np.clip(frame + rng.normal(0, 3, frame.shape), 0, 255).astype(np.uint8))
    clip = _write(tmp_path / "grey_liquid.mp4", frames)
    code, out, err = run_cli("inspect", clip, "-o", tmp_path / "g.png")
    assert code == 0, err
    assert "a region darker than the rest" in out
    command = _next_command(out)
    assert command[5:9] == ["--target", "surface", "--liquid-hsv-low", "0,0,0"]
    assert 128 < int(command[10].split(",")[2]) < 190  # above the liquid's value, below the wall's
    assert run_cli(*command[1:])[0] == 0
    angles = read_csv(Path(command[command.index("-o") + 1]))
    assert float(np.median(angles["angle_deg"][angles["valid"] == 1])) == pytest.approx(3.43, abs=0.3)


def test_the_suggestion_is_tried_and_tracks_own_choice_replaces_a_worse_one(tmp_path, run_cli):
    # an orange dye, 2.5 s: the suggestion is tried on the first TRIAL_S seconds and measures them all; given a colour
    # that holds no liquid (green) and an ROI off the container, the trial measures nothing with them, and track's own
    # choice of colour and region (every frame) replaces them; a suggestion that works is kept
    clip = tmp_path / "clip.mp4"
    small = [*SMALL[: SMALL.index("--duration")], "--duration", "2.5", *SMALL[SMALL.index("--noise") :]]
    assert run_cli("synth", clip, *small, "--scene", "surface", "--liquid-color", "orange")[0] == 0
    res = inspect_video(clip)
    tracked = track_video(clip, TrackSettings(target="surface", smooth=False))
    first = tracked.t_s < TRIAL_S
    frames, valid = int(np.count_nonzero(first)), int(np.count_nonzero(tracked.valid[first]))
    assert valid >= 0.8 * frames  # a clean painted clip: only the encoder's repeated pictures are not valid
    # the suggestion names the colour track finds itself: both measure the same frames, and the suggestion is kept
    assert res.trial == Trial(TRIAL_S, frames, valid, valid, False) and res.works
    assert f"the command below measured {valid} of {frames} frames validly" in res.notes[-1]
    res.track_settings = {"target": "surface", "liquid_color": "green", "roi": (0, 0, 40, 40)}
    _try(res, None)
    assert res.trial == Trial(TRIAL_S, frames, 0, valid, True) and res.works
    assert res.track_settings == {"target": "surface"}
    assert "leaves the colour and region to it" in res.notes[-1]
    # an ROI the user gave is kept in track's own choices, in place of inspect's
    x, y, w, h = res.suggested_roi
    given = (x - 10, y - 10, w + 20, h + 20)
    res.track_settings = {"target": "surface", "liquid_color": "green", "roi": res.suggested_roi}
    _try(res, given)
    assert res.track_settings == {"target": "surface", "roi": given} and res.trial.own == valid
    assert "leaves the colour to it" in res.notes[-1]
    assert json.loads(json.dumps(res.to_dict()))["trial"]["own_taken"] is True
    # a suggestion that measures half the frames or more is kept (track's own colour may be a label's)
    res.track_settings = {"target": "surface", "liquid_color": "orange", "roi": given}
    _try(res, None)
    assert res.trial == Trial(TRIAL_S, frames, valid, valid, False) and res.works
    assert res.track_settings == {"target": "surface", "liquid_color": "orange", "roi": given}
    # a clip shorter than TRIAL_S is tried whole, and says how long it is
    short = tmp_path / "short.mp4"
    assert run_cli("synth", short, *SMALL, "--scene", "surface", "--liquid-color", "orange")[0] == 0
    look = inspect_video(short)
    assert look.trial.seconds == pytest.approx(1.0, abs=0.04) and look.trial.frames == 30
    assert look.notes[-1].startswith("tried on the first 1 s:")
