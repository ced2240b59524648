"""sloshid track: accuracy against synth ground truth, container reference, VFR timing, gap bridging, bad input."""

from __future__ import annotations

import math
import shlex
import shutil
import subprocess
import sys
from dataclasses import replace
from fractions import Fraction
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import av
import cv2
import numpy as np
import pytest

from sloshid.core.errors import SettingError, UserError
from sloshid.core.tables import read_csv
from sloshid.identification.estimator import Identifier
from sloshid.identification.signals import load_signal, make_signal, signal_from_track
from sloshid.synthetic.render import SynthSettings, frame_times, relative_angle_rad, render_frames, render_video
from sloshid.synthetic.stills import still_clip
from sloshid.tracking import container_ref, repeats, surface_track, tracker
from sloshid.tracking.container_ref import (
    HOLD_FRAMES,
    STEADY_DEG,
    ContainerMeasurement,
    ContainerTracker,
    WallsRecord,
    held_angles,
)
from sloshid.tracking.float_angle import ELONGATED, FloatFinder, length_to_width
from sloshid.tracking.repeats import REPEAT_SHARE, Copies, line_regions, repeated_share, stale_repeats
from sloshid.tracking.rows import SurfaceGeometry, TrackRow
from sloshid.tracking.smooth import smooth_angle
from sloshid.tracking.surface import (
    LINE_SLOPE_OF_CUBIC,
    LOW_MIN_FRAMES,
    OWN_HUE_REACH,
    SurfaceFinder,
    SurfaceMeasurement,
    _column_box,
    _container_axes,
    _crossings_first,
    _fit_front,
    _fitted,
    _front_below,
    _in_front,
    _inside,
    _on_wall,
    _sustained,
    dye_range,
    own_range,
    steady_axes,
)
from sloshid.tracking.surface_track import SurfaceStep, _spikes
from sloshid.tracking.tracker import TRACK_COLUMNS, TrackResult, TrackSettings, track_video
from sloshid.video.colors import PRESETS
from sloshid.video.frames import FrameReader, Picture, VideoInfo, VideoWriter
from sloshid.video.keyframes import key_frame_times

# Small, fast videos: 320x240, 2 s, H.264 CRF 18. The float is 72 px long (0.3 of the height); at this size
# H.264's half-resolution chroma carries the float's colour on only ~36x6 samples, so tolerances are looser
# than the benchmark targets (which use 640x480 and 1280x720).
SMALL = dict(
    width=320,
    height=240,
    fps=30.0,
    duration_s=2.0,
    noise_sigma=3.0,
    blur_px=1.0,
    quality=18,
    float_length_frac=0.3,
    seed=11,
)


def _rmse(e: np.ndarray) -> float:
    """Root mean square."""
    return float(np.sqrt(np.mean(np.square(e))))


@pytest.fixture(scope="module")
def decay_video(tmp_path_factory):
    """A 2 s H.264 tap test with a 2 deg camera roll, and its truth."""
    path = tmp_path_factory.mktemp("decay") / "decay.mp4"
    truth = render_video(path, SynthSettings(**SMALL, camera_roll_deg=2.0, amplitude_deg=6.0))
    return path, truth


def test_image_reference_matches_truth(decay_video):
    path, truth = decay_video
    res = track_video(path)
    # every frame is measured; those whose float the encoder copied from the previous frame are not valid
    ok = res.valid.astype(bool)
    assert (ok | res.repeated).all() and ok.mean() > 0.5
    # image reference: the float's angle in the picture includes the 2 deg camera roll.
    # measured 0.08 deg RMSE / 0.26 max here; 0.2 / 0.6 leaves room for other FFmpeg builds' encoders.
    err = (res.angle_deg - truth["float_angle_deg"])[ok]
    assert _rmse(err) < 0.2 and np.abs(err).max() < 0.6
    # the centre to better than a pixel (H.264's half-resolution chroma shifts colour edges a little)
    assert np.abs(res.x_px - truth["float_x_px"]).max() < 1.0
    assert np.abs(res.y_px - truth["float_y_px"]).max() < 1.0
    assert np.all(res.container_angle_deg == 0)
    assert np.all((res.quality > 0.5) & (res.quality <= 1))


def test_readme_main_job_on_the_bundled_sample(tmp_path, run_cli):
    # the command the README opens with, on data/sample_tap.mp4 (seed Table I tap test, noise 5, H.264);
    # measured 0.063 deg RMSE, 0.20 max: 0.15 / 0.5 leave room for other FFmpeg builds' decoders
    root = Path(__file__).resolve().parents[1]
    out, overlay = tmp_path / "sample_angles.csv", tmp_path / "sample_overlay.mp4"
    code, stdout, _ = run_cli("track", root / "data" / "sample_tap.mp4", "-o", out, "--overlay", overlay)
    assert code == 0 and "180 frames" in stdout
    got, truth = read_csv(out), read_csv(root / "data" / "sample_tap_truth.csv")
    ok = got["valid"] == 1
    assert ok.mean() > 0.5  # the rest are frames the encoder repeated
    err = (got["angle_deg"] - truth["rel_angle_deg"])[ok]
    assert _rmse(err) < 0.15 and np.abs(err).max() < 0.5
    assert overlay.stat().st_size > 0


def test_container_reference_on_tilting_travelling_container(tmp_path):
    # Container tilts +-4 deg and crosses 100 px while the liquid decays; the camera is rolled 1.5 deg.
    s = SynthSettings(**SMALL, container_tilt_deg=4.0, container_tilt_hz=0.5, travel_px=100, camera_roll_deg=1.5)
    truth = render_video(tmp_path / "c.mp4", s)
    res = track_video(tmp_path / "c.mp4", TrackSettings(reference="container"))
    assert (res.valid.astype(bool) | res.repeated).all()
    # the walls are ~170 px long straight lines: their angle is good to a few hundredths of a degree
    assert _rmse(res.container_angle_deg - truth["container_angle_deg"]) < 0.1
    assert _rmse(res.angle_deg - truth["rel_angle_deg"]) < 0.25


def test_vfr_timestamps_reach_the_csv(tmp_path, run_cli):
    s = SynthSettings(**{**SMALL, "duration_s": 1.0}, vfr_jitter=0.4)
    truth = render_video(tmp_path / "vfr.mp4", s)
    code, _, _ = run_cli("track", tmp_path / "vfr.mp4", "-o", tmp_path / "a.csv")
    assert code == 0
    got = read_csv(tmp_path / "a.csv")
    assert list(got) == list(TRACK_COLUMNS)
    np.testing.assert_allclose(got["t_s"], truth["t_s"], atol=1 / 180000)  # half a 90 kHz tick


def test_repeated_timestamps_are_retimed_by_frame_number_and_said(tmp_path, run_cli):
    # A Matroska file whose every third frame repeats the previous frame's timestamp (as some muxers and screen
    # recorders write): track exited 0 without a word with a third of its rows not later than the row before, its
    # smoothed angle off by up to 2.7 deg, and identify then refused the CSV. Now every frame is timed by its number
    # at the declared 30 fps (the truth's own times here), a warning says so, and identify reads the CSV.
    s = SynthSettings(**{**SMALL, "duration_s": 3.0})
    truth = list(render_frames(s))
    video = tmp_path / "dup.mkv"
    with av.open(str(video), "w", format="matroska") as out:
        stream = out.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = s.width, s.height, "yuv420p"
        stream.codec_context.gop_size, stream.codec_context.max_b_frames = 1, 0  # every picture coded alone, in order
        stream.bit_rate = 8_000_000  # PyAV's default blurs the float's edges by 0.4 deg

        def mux(packets) -> None:
            for p in packets:
                n = round(p.pts * p.time_base * 30)
                p.pts = p.dts = round((n - (n % 3 == 2)) / 30 / p.time_base)  # frame 3k+2 takes 3k+1's time
                out.mux(p)

        for i, (_, bgr) in enumerate(truth):
            frame = av.VideoFrame.from_ndarray(bgr, format="bgr24").reformat(format="yuv420p")
            frame.pts, frame.time_base = i, Fraction(1, 30)
            mux(stream.encode(frame))
        mux(stream.encode())
    code, _, err = run_cli("track", video, "-o", tmp_path / "a.csv")
    assert code == 0 and "have a timestamp that does not increase" in err
    got = read_csv(tmp_path / "a.csv")
    rows = [row for row, _ in truth]
    np.testing.assert_allclose(got["t_s"], [r["t_s"] for r in rows], atol=1e-9)
    # within 0.3 deg: the painted float's tracking error on these 320x240 frames (0.12 deg from an MP4 of them)
    assert np.abs(got["angle_deg"] - np.array([r["rel_angle_deg"] for r in rows])).max() < 0.3
    assert np.isfinite(got["angle_smoothed_deg"]).all()
    code, _, err = run_cli("identify", tmp_path / "a.csv", "-o", tmp_path / "p.json")
    assert code == 0, err


def test_key_frames_reach_the_csv_and_identify(tmp_path, run_cli):
    # sloshid synth's MPEG-4 codes every 12th picture afresh (PyAV's default GOP, checked here on the decoded pictures'
    # own flags); the tracker marks exactly those frames from the packets, and identify reads them from the CSV
    s = SynthSettings(**{**SMALL, "duration_s": 1.5}, codec="mpeg4")
    render_video(tmp_path / "m.mp4", s)
    with av.open(str(tmp_path / "m.mp4")) as container:
        decoded = np.array([frame.key_frame for frame in container.decode(video=0)], int)
    assert decoded.sum() == 4 and decoded[0] == 1
    code, _, _ = run_cli("track", tmp_path / "m.mp4", "-o", tmp_path / "m.csv")
    assert code == 0
    got = read_csv(tmp_path / "m.csv")
    np.testing.assert_array_equal(got["key_frame"], decoded)
    assert load_signal(tmp_path / "m.csv").key_t_s == pytest.approx(got["t_s"][decoded == 1])
    res = track_video(tmp_path / "m.mp4")
    np.testing.assert_array_equal(res.key_frame, decoded)
    assert signal_from_track(res).key_t_s == pytest.approx(res.t_s[decoded == 1])


def _video_with_gap(path, settings, gap, display_rotation_deg=0):
    """Render `settings` but replace frames in `gap` (a slice) with an empty grey picture."""
    rows = []
    with VideoWriter(
        path, settings.width, settings.height, settings.fps, display_rotation_deg=display_rotation_deg
    ) as w:
        for row, frame in render_frames(settings):
            if gap.start <= row["frame"] < gap.stop:
                frame[:] = 128
            w.write(frame, row["t_s"])
            rows.append(row)
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def test_kalman_bridges_a_gap_with_known_truth(tmp_path, run_cli):
    # 1.5 Hz decay at 30 fps; the float vanishes for 5 frames (0.17 s, a quarter period) mid-swing.
    s = SynthSettings(**SMALL, f_hz=1.5, zeta=0.05, amplitude_deg=6.0, tap_s=0.2)
    gap = slice(30, 35)
    truth = _video_with_gap(tmp_path / "gap.mp4", s, gap)
    out = tmp_path / "gap.csv"
    code, _, err = run_cli("track", tmp_path / "gap.mp4", "-o", out)
    assert code == 0
    assert "5 of 60 frames (8.3 %)" in err  # the warning names the share of lost frames
    res = read_csv(out)
    assert np.all(res["valid"][gap] == 0) and res["valid"].sum() > 40  # and a few encoder repeats
    inside = res["angle_smoothed_deg"][gap] - truth["rel_angle_deg"][gap]
    linear = np.interp(res["t_s"][gap], res["t_s"][[29, 35]], res["angle_deg"][[29, 35]]) - truth["rel_angle_deg"][gap]
    # the signal moves ~5 deg across the gap; a smooth (cubic-spline-like) bridge stays within 0.5 deg
    # and beats a straight line between the neighbours
    assert np.abs(inside).max() < 0.5
    assert np.abs(inside).max() < np.abs(linear).max()
    # (0.23 measured: it also bridges the frames the encoder repeated while the float moved)
    assert _rmse(res["angle_smoothed_deg"] - truth["rel_angle_deg"]) < 0.3


def test_smoother_on_uneven_timestamps_follows_a_tap_and_bridges():
    # No video: the seed Table I tap trace on strongly jittered timestamps plus seeded 0.05 deg noise (the
    # tracker's typical error), with 4 samples missing. The smoother must use each step's own dt: it then
    # stays within 0.3 deg of the truth even at the tap's sudden start and lowers the RMSE below the noise.
    s = SynthSettings(fps=30, duration_s=4, vfr_jitter=0.4, amplitude_deg=12, seed=5)
    t = frame_times(s)
    truth = np.degrees(relative_angle_rad(s, t))
    noisy = truth + np.random.default_rng(5).normal(0, 0.05, len(t))
    valid = np.ones(len(t), bool)
    valid[40:44] = False
    smoothed = smooth_angle(t, noisy, valid, np.ones(len(t)))
    assert np.abs(smoothed - truth).max() < 0.3
    assert _rmse((smoothed - truth)[valid]) < 0.05


WORKER_CHECK = """
import sys
import numpy as np
from sloshid.synthetic.render import SynthSettings, frame_times, relative_angle_rad
from sloshid.tracking.smooth import SmoothingWorker, smooth_angle
s = SynthSettings(fps=30, duration_s=4, vfr_jitter=0.4, amplitude_deg=12, seed=5)
t = frame_times(s)
z = np.degrees(relative_angle_rad(s, t)) + np.random.default_rng(5).normal(0, 0.05, len(t))
valid, q = np.arange(len(t)) % 7 != 3, np.ones(len(t))
served, killed = SmoothingWorker(), SmoothingWorker()
assert "filterpy.kalman" not in sys.modules and served._proc is not None and killed._proc is not None
killed._proc.kill()
a, b = served.smooth(t, z, valid, q), killed.smooth(t, z, valid, q)
assert served._proc is None and killed._proc is None
here = smooth_angle(t, z, valid, q)
assert np.array_equal(a, here) and np.array_equal(b, here), (np.abs(a - here).max(), np.abs(b - here).max())
assert SmoothingWorker()._proc is None  # filterpy is imported now: no fork
del sys.modules["filterpy.kalman"]  # as before the import: the next worker forks
abandoned = SmoothingWorker()
abandoned._conn.close()  # the caller's end goes away unused (a caller killed by SIGTERM): the worker must end
abandoned._proc.join(timeout=60)
assert abandoned._proc.exitcode == 0, abandoned._proc.exitcode
print("ok")
"""


def test_smoothing_worker_gives_the_in_process_result_and_survives_its_loss():
    # In a fresh interpreter (filterpy not yet imported, so the worker forks): the forked worker's smoothing is
    # bit-identical to smooth_angle here, a worker killed before it got the trace falls back to smoothing here
    # with the same result, once filterpy is imported no process is forked, and a worker whose caller's end of the
    # pipe closes unused ends by itself (fork copies that end into the worker, which must close its copy).
    done = subprocess.run([sys.executable, "-c", WORKER_CHECK], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


LEFT_DECODER_CHECK = """
import gc, sys
import av
import numpy as np
from sloshid.tracking.smooth import SmoothingWorker
container = av.open(sys.argv[1])
stream = container.streams.video[0]
stream.thread_type = "AUTO"  # frame threads, which fork does not copy
for k, frame in enumerate(container.decode(stream)):
    if k == 5:
        break
cycle = [container, stream]
cycle.append(cycle)
gc.collect()
gc.collect()  # the cycle, still named, grows old: once its names go, only a full collection frees it
del container, stream, cycle, frame
worker = SmoothingWorker()
assert worker._proc is not None
t = np.arange(200) / 30.0
print("ok" if worker.smooth(t, np.sin(t), np.ones(200, bool), np.ones(200)).shape == (200,) else "no")
"""


def test_a_decoder_left_to_the_garbage_collector_does_not_hang_the_forked_smoother():
    # tracking a video in a program that had left a PyAV decoder to the garbage collector (a test before it) hung:
    # the forked smoother's collections freed the copied decoder, which waited in FFmpeg for frame threads that exist
    # only in the caller, and the caller waited for the smoother. A forked helper now leaves the caller's objects alone
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            LEFT_DECODER_CHECK,
            str(Path(__file__).resolve().parents[1] / "data" / "sample_tap.mp4"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


EARLY_CHECK = """
from sloshid.tracking import smooth
smooth.start_early()
early = smooth._early
assert early._proc is not None
assert smooth.smoothing_worker() is early and smooth._early is None  # the run takes the early worker
early.close()
smooth.start_early()
unused = smooth._early
smooth.discard_early()  # the command failed before tracking: the worker is stopped at once
assert unused._proc is None and smooth._early is None
smooth.start_early()
unused = smooth._early
batch = smooth.smoothing_worker(fork=False)  # a run that must not fork stops it and smooths in its own process
assert batch is not unused and batch._proc is None and unused._proc is None
print("ok")
"""


def test_track_forks_its_smoother_first_and_stops_it_when_unused():
    # `sloshid track` forks the smoother before its own imports (start_early); the run takes that worker, and one that
    # no run took (the command failed first, or the run may not fork) is stopped, not left running
    done = subprocess.run([sys.executable, "-c", EARLY_CHECK], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


def test_key_frame_column_marks_the_encoders_key_frames(tmp_path):
    # MPEG-4 as sloshid writes it codes a key frame every 12 frames: exactly those rows are marked (identify restarts
    # the encoder hold there)
    path = tmp_path / "gop.mp4"
    render_video(path, SynthSettings(**{**SMALL, "codec": "mpeg4", "quality": 3}))
    res = track_video(path)
    assert np.flatnonzero(res.key_frame).tolist() == [0, 12, 24, 36, 48]


def test_orientation_metadata_is_respected(tmp_path):
    # A phone-style file: pixels stored landscape with a "rotate 90 deg CCW" display matrix. The tracker
    # must see the picture as displayed (portrait), so the float lies at its true angle + 90 deg.
    s = SynthSettings(**{**SMALL, "duration_s": 1.0})
    truth = _video_with_gap(tmp_path / "rot.mp4", s, slice(0, 0), display_rotation_deg=90)
    res = track_video(tmp_path / "rot.mp4")
    assert FrameReader(tmp_path / "rot.mp4").frame_size == (240, 320)
    turned = res.angle_deg - (truth["float_angle_deg"] + 90)
    err = (turned + 90) % 180 - 90  # a line's angle is defined modulo 180 deg
    assert _rmse(err) < 0.3
    # displayed (x, y) = (stored y, width - 1 - stored x) for a 90 deg CCW turn
    assert np.abs(res.x_px - truth["float_y_px"]).max() < 1.0
    assert np.abs(res.y_px - (319 - truth["float_x_px"])).max() < 1.0


def test_overlay_is_written_frame_for_frame(decay_video, tmp_path, run_cli):
    path, truth = decay_video
    code, _, _ = run_cli("track", path, "-o", tmp_path / "a.csv", "--overlay", tmp_path / "o.mp4")
    assert code == 0
    frames = list(FrameReader(tmp_path / "o.mp4"))
    assert len(frames) == len(truth)
    # the drawn float axis is green (BGR ~ (60, 220, 60)) near the float centre
    _, _, img = frames[len(frames) // 2]
    x, y = int(truth["float_x_px"][len(frames) // 2]), int(truth["float_y_px"][len(frames) // 2])
    patch = img[y - 3 : y + 4, x - 3 : x + 4].reshape(-1, 3).astype(int)
    assert np.any((patch[:, 1] > 170) & (patch[:, 2] < 120))


def test_named_preset_and_explicit_hsv(tmp_path, run_cli):
    truth = render_video(tmp_path / "g.mp4", SynthSettings(**{**SMALL, "duration_s": 0.5}, float_color="green"))
    for args in (["--float-color", "green"], ["--float-hsv-low", "45,110,60", "--float-hsv-high", "80,255,255"]):
        code, _, _ = run_cli("track", tmp_path / "g.mp4", "-o", tmp_path / "g.csv", *args)
        assert code == 0
        res = read_csv(tmp_path / "g.csv")
        assert res["valid"].mean() > 0.5
        assert _rmse(res["angle_deg"] - truth["float_angle_deg"]) < 0.3


@pytest.mark.parametrize("colour", sorted(PRESETS))
def test_every_preset_finds_the_float_synth_paints(tmp_path, colour):
    # each preset's HSV range must catch the float painted in that colour and nothing else in the scene
    s = SynthSettings(**{**SMALL, "duration_s": 0.5}, float_color=colour)
    truth = render_video(tmp_path / "p.mp4", s)
    res = track_video(tmp_path / "p.mp4", TrackSettings(float_color=colour))
    assert (res.valid.astype(bool) | res.repeated).all()
    assert np.abs(res.x_px - truth["float_x_px"]).max() < 1.0  # the float, not the liquid
    assert _rmse(res.angle_deg - truth["float_angle_deg"]) < 0.3


def _yellow_float_at_hue_19(path: Path) -> list:
    """A painted yellow float clip (0.5 s) recoloured to hue 19, below the yellow preset's 22; its (truth, frame) list."""
    s = SynthSettings(**{**SMALL, "duration_s": 0.5}, float_color="yellow")
    frames = list(render_frames(s))
    with VideoWriter(path, s.width, s.height, s.fps, "h264", s.quality) as out:
        for row, frame in frames:
            hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
            hsv[..., 0][(hsv[..., 0] >= 22) & (hsv[..., 0] <= 35) & (hsv[..., 1] >= 20)] = 19
            out.write(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), row["t_s"])
    return frames


def test_a_float_seen_just_outside_its_colour_is_found_with_the_range_relaxed(tmp_path):
    # a yellow float whose picture reads hue 19 (as a thin yellow plank on orange juice read 18-21 in a held-out pbr
    # clip: its colour mixed with the liquid's), below the yellow preset's 22: the preset finds nothing in any frame; the
    # range fitted to the first frame (hues widened by 4) tracks it, and says so
    frames = _yellow_float_at_hue_19(tmp_path / "y.mp4")
    truth = np.array([row["float_angle_deg"] for row, _ in frames])
    with pytest.warns(UserWarning, match="its hues widened by 4"):
        res = track_video(tmp_path / "y.mp4", TrackSettings(float_color="yellow"))
    assert (res.valid.astype(bool) | res.repeated).all()
    assert np.abs(res.x_px - np.array([row["float_x_px"] for row, _ in frames])).max() < 1.0  # the float itself
    assert _rmse(res.angle_deg - truth) < 0.3  # the preset's own float is measured to 0.3 (test above)
    # a range given as HSV corners is the user's: never relaxed
    with pytest.raises(UserError, match="no float found"):
        track_video(tmp_path / "y.mp4", TrackSettings(float_hsv_low=(22, 110, 90), float_hsv_high=(35, 255, 255)))


def test_the_relaxed_runs_progress_bar_says_why_a_second_one_runs(tmp_path, monkeypatch):
    # the clip is tracked twice; the second bar is named for the relaxed colour, not a bare "track" again
    _yellow_float_at_hue_19(tmp_path / "y.mp4")
    names, bar = [], tracker.tqdm
    monkeypatch.setattr(tracker, "tqdm", lambda **kw: names.append(kw["desc"]) or bar(**kw))
    with pytest.warns(UserWarning, match="relaxed"):
        track_video(tmp_path / "y.mp4", TrackSettings(float_color="yellow"), progress=True)
    assert names == ["track", "track again, float colour relaxed"]


@pytest.mark.parametrize("tape_until", [60, 40])
def test_a_float_absent_from_the_first_frames_is_not_traded_for_a_label_of_a_near_colour(tmp_path, tape_until):
    # the default red float painted out of the first 40 of 60 frames, and a strip of orange tape (hue 14, inside the
    # red range relaxed by 4) on the wall behind, in every frame or only until the float comes in: the preset's run
    # measures the float in a third of the frames; the relaxed range finds the tape (in every frame, or before the
    # float and then the float), elsewhere than the preset's float; the preset's run is kept
    s = SynthSettings(**SMALL)
    frames = list(render_frames(s))
    tape = cv2.cvtColor(np.uint8([[[14, 200, 230]]]), cv2.COLOR_HSV2BGR)[0, 0].tolist()
    with VideoWriter(tmp_path / "a.mp4", s.width, s.height, s.fps, "h264", s.quality) as out:
        for i, (row, frame) in enumerate(frames):
            picture = frame.copy()
            if i < 40:
                hsv = cv2.cvtColor(picture, cv2.COLOR_BGR2HSV)
                red = ((hsv[..., 0] >= 160) | (hsv[..., 0] <= 20)) & (hsv[..., 1] >= 60)
                mask = cv2.dilate(red.astype(np.uint8), np.ones((7, 7), np.uint8))
                picture = cv2.inpaint(picture, mask, 5, cv2.INPAINT_TELEA)
            if i < tape_until:
                cv2.rectangle(picture, (20, 20), (80, 28), tape, -1)
            out.write(picture, row["t_s"])
    res = track_video(tmp_path / "a.mp4", TrackSettings(), overlay=tmp_path / "o.mp4")
    valid = res.valid.astype(bool)
    assert 0.2 < valid.mean() < 0.5 and not valid[:40].any()
    assert np.abs(res.x_px - np.array([row["float_x_px"] for row, _ in frames]))[valid].max() < 1.0
    assert not any("relaxed" in w for w in res.warnings)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4", "o.mp4"]  # the relaxed run's overlay removed


def test_the_relaxed_run_is_the_presets_float_where_the_preset_measured_some():
    # `_same_float` on positions alone: a long clip whose preset measured two stray fragments near the float (3 and 28
    # px off a float 96 px long, a 24 s clip of the hue-19 yellow float) keeps the relaxed run; one that tracked a label
    # 110 px away in the frames the preset missed, and the float in the rest, does not; nor one measuring fewer frames
    def run(x: np.ndarray) -> TrackResult:
        return cast(
            TrackResult,
            SimpleNamespace(valid=np.isfinite(x).astype(int), x_px=x, y_px=np.where(np.isfinite(x), 100.0, np.nan)),
        )

    nan = np.nan
    relaxed = run(np.full(720, 160.0))
    strays = run(np.where(np.isin(np.arange(720), [17, 518]), np.where(np.arange(720) == 17, 157.0, 131.7), nan))
    assert tracker._same_float(relaxed, strays, 96.0) and tracker._same_float(relaxed, None, 96.0)
    preset = run(np.r_[np.full(40, nan), np.full(20, 160.0)])
    label_then_float = run(np.r_[np.full(40, 50.0), np.full(17, 160.0), np.full(3, nan)])
    assert not tracker._same_float(label_then_float, preset, 96.0)
    assert not tracker._same_float(run(np.r_[np.full(50, nan), np.full(10, 160.0)]), preset, 96.0)


def test_the_relaxed_runs_overlay_is_removed_when_the_run_fails(tmp_path, monkeypatch):
    # the relaxed run writes its overlay beside the requested one and moves it over only when kept: a run interrupted
    # after writing it leaves no hidden file
    _yellow_float_at_hue_19(tmp_path / "y.mp4")

    def interrupted(*_args):
        raise KeyboardInterrupt

    monkeypatch.setattr(tracker, "_same_float", interrupted)
    with pytest.raises(KeyboardInterrupt):
        track_video(tmp_path / "y.mp4", TrackSettings(float_color="yellow"), overlay=tmp_path / "o.mp4")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.mp4", "y.mp4"]  # the preset's diagnosis overlay only


def test_roi_restricts_the_search(decay_video, tmp_path, run_cli):
    path, _truth = decay_video
    code, _, _ = run_cli("track", path, "-o", tmp_path / "r.csv", "--roi", "100,80,140,100")
    assert code == 0
    assert read_csv(tmp_path / "r.csv")["valid"].mean() > 0.5
    code, _, err = run_cli("track", path, "-o", tmp_path / "r.csv", "--roi", "0,0,100,60")
    assert code == 2 and "no float found" in err  # the float lies outside that ROI


def test_a_float_cut_by_the_roi_is_not_valid(decay_video, tmp_path, run_cli):
    # the float spans x = 112-208 around 160: a ROI ending at x = 175 shows part of it, whose axis passed for the
    # float's in every frame (exit 0, 39 valid rows); now those frames are found but not valid, and said
    path, _truth = decay_video
    code, _, err = run_cli("track", path, "-o", tmp_path / "c.csv", "--roi", "0,0,175,240")
    assert code == 2 and "always at the edge of the searched region" in err and "--roi" in err
    assert not (tmp_path / "c.csv").exists()
    # a ROI whose lower edge the float's lower corner reaches at the largest tilts: those frames only
    res = track_video(path, TrackSettings(roi=(0, 0, 320, 140)))
    cut = res.quality == 0
    note = next(w for w in res.warnings if "reached the edge of the searched region" in w)
    assert 0 < cut.sum() < 10 and f"in {cut.sum()} of 60 frames" in note and not res.valid[cut].any()


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    """Files a user might wrongly pass: text named .mp4, a video without frames, a truncated video."""
    d = tmp_path_factory.mktemp("bad")
    (d / "text.mp4").write_text("this is not a video\n")
    (d / "zero.mp4").write_bytes(b"")  # was "not a video FFmpeg can decode (or it is cut off before its index)"
    empty = av.open(str(d / "empty.mp4"), "w")  # an MP4 with a video stream and zero frames
    stream = empty.add_stream("libx264", rate=30)
    stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
    empty.start_encoding()
    empty.close()
    render_video(d / "full.mp4", SynthSettings(**{**SMALL, "duration_s": 2.0}))
    data = (d / "full.mp4").read_bytes()
    (d / "truncated.mp4").write_bytes(data[: len(data) // 2])
    return d


@pytest.mark.parametrize(
    "name, extra, message",
    [
        ("missing.mp4", [], "does not exist"),
        ("text.mp4", [], "is not a video"),
        ("zero.mp4", [], "is empty (0 bytes)"),
        ("empty.mp4", [], "contains no video frames"),
        ("full.mp4", ["--float-color", "yellow"], "no float found in any of the 60 frames"),
        ("full.mp4", ["--roi", "300,200,50,50"], "--roi 300,200,50,50 reaches beyond the 320x240 frame"),
        ("full.mp4", ["--float-hsv-low", "10,20", "--float-hsv-high", "30,255,255"], "three whole numbers"),
        ("full.mp4", ["--float-hsv-low", "0,x,0", "--float-hsv-high", "30,255,255"], "three whole numbers"),
        ("full.mp4", ["--float-hsv-low", "200,50,50", "--float-hsv-high", "30,255,255"], "outside H 0..179"),
        ("full.mp4", ["--float-hsv-low", "10,50,50"], "together"),
    ],
)
def test_bad_input_is_one_sentence_and_leaves_nothing(bad_files, tmp_path, run_cli, name, extra, message):
    out = tmp_path / "angles.csv"
    code, _, err = run_cli("track", bad_files / name, "-o", out, *extra)
    assert code == 2
    assert message in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary leftovers either


def test_the_next_line_runs_as_printed_with_a_space_in_the_path(bad_files, tmp_path, run_cli):
    # it printed `next: sloshid identify my clips/a b.csv -o params.json`: a shell split the path in two
    folder = tmp_path / "my clips"
    folder.mkdir()
    angles = folder / "a b.csv"
    code, out, err = run_cli("track", bad_files / "full.mp4", "-o", angles)
    assert code == 0, err
    line = out.strip().splitlines()[-1]
    assert line.startswith("next: ") and line.endswith(" identifies the liquid from this angle trace.")
    words = shlex.split(line.removeprefix("next: ").removesuffix(" identifies the liquid from this angle trace."))
    assert words == ["sloshid", "identify", str(angles), "-o", str(folder / "a b_params.json")]  # beside the trace


def test_never_found_names_the_range_and_writes_a_first_look(bad_files, tmp_path, run_cli):
    # nothing found: the sentence names the range searched and the inspect picture written beside the video; a second
    # run keeps that picture (never over a file) and suggests inspect or an overlay instead
    video = tmp_path / "v.mp4"
    shutil.copyfile(bad_files / "full.mp4", video)
    picture = tmp_path / "v_inspect.png"
    code, _, err = run_cli("track", video, "-o", tmp_path / "a.csv", "--float-color", "yellow")
    assert code == 2
    assert "H 22..35, S 110..255, V 90..255" in err and str(picture) in err
    assert cv2.imread(str(picture)) is not None
    before = picture.stat().st_mtime_ns
    code, _, err = run_cli("track", video, "-o", tmp_path / "a.csv", "--float-color", "yellow")
    assert code == 2 and "--overlay" in err and "sloshid inspect" in err
    assert picture.stat().st_mtime_ns == before and not (tmp_path / "a.csv").exists()


def test_never_found_still_writes_the_overlay_as_diagnosis(bad_files, tmp_path, run_cli):
    code, _, err = run_cli(
        "track",
        bad_files / "full.mp4",
        "-o",
        tmp_path / "a.csv",
        "--float-color",
        "yellow",
        "--overlay",
        tmp_path / "o.mp4",
    )
    assert code == 2 and f"see the overlay {tmp_path / 'o.mp4'}" in err
    assert not (tmp_path / "a.csv").exists()
    assert len(list(FrameReader(tmp_path / "o.mp4"))) == 60


def _disc_video(path: Path, disc: bool) -> None:
    """12 frames of noisy grey, with a still red disc (the float's colour, not its shape) when `disc`."""
    rng = np.random.default_rng(3)
    with VideoWriter(path, 160, 120, 30.0, "h264", 18) as writer:
        for i in range(12):
            frame = np.clip(128 + rng.normal(0, 3, (120, 160, 3)), 0, 255).astype(np.uint8)
            if disc:
                cv2.circle(frame, (80, 60), 14, (30, 30, 220), -1)
            writer.write(frame, i / 30)


def test_a_round_blob_of_the_float_colour_is_named_not_called_no_float(tmp_path, run_cli):
    # a red disc was found in every frame but never valid (elongation ~0), and the error said "no float found ... with
    # HSV range ...", sending the user to the colour range that did find it; a picture without red still says that
    _disc_video(tmp_path / "disc.mp4", disc=True)
    code, _, err = run_cli("track", tmp_path / "disc.mp4", "-o", tmp_path / "d.csv", "--target", "float")
    need = f"{length_to_width(ELONGATED):.2f}"
    assert code == 2 and err.count("\n") == 1 and "no float found" not in err
    assert "was found in 12 of 12 frames" in err and "but round, not elongated (at most 1.0" in err
    assert f"a float needs a length at least {need} times its width" in err and need == "1.41"
    assert "film a float longer than wide" in err and "--float-hsv-low" in err and "--roi" in err
    assert not (tmp_path / "d.csv").exists()
    _disc_video(tmp_path / "grey.mp4", disc=False)
    code, _, err = run_cli("track", tmp_path / "grey.mp4", "-o", tmp_path / "g.csv", "--target", "float")
    assert code == 2 and "no float found in any of the 12 frames" in err and "not elongated" not in err


def test_container_reference_without_walls_says_so(tmp_path, run_cli):
    # a float with no container walls in view (the ROI cuts them off): the float is found, the walls are not
    truth = render_video(tmp_path / "v.mp4", SynthSettings(**{**SMALL, "duration_s": 0.5}))
    x, y = int(truth["float_x_px"][0]), int(truth["float_y_px"][0])
    code, _, err = run_cli(
        "track",
        tmp_path / "v.mp4",
        "-o",
        tmp_path / "a.csv",
        "--reference",
        "container",
        "--roi",
        f"{x - 45},{y - 30},90,60",
    )
    assert code == 2 and "side walls in none of them" in err and "--reference image" in err
    assert not (tmp_path / "a.csv").exists()


def test_truncated_video_tracks_what_decodes_and_warns(bad_files, tmp_path, run_cli):
    out = tmp_path / "t.csv"
    code, _, err = run_cli("track", bad_files / "truncated.mp4", "-o", out)
    assert code == 1  # output written, but the exit code tells scripts the video was incomplete
    assert "looks truncated" in err and "% lost" in err
    res = read_csv(out)
    # the float rests until 0.5 s (frame 15): the encoder repeats it, and the motion after makes that run stale
    assert 10 < len(res["t_s"]) < 60 and res["valid"][16:].mean() > 0.5


# --- the liquid surface (--target surface) -------------------------------------------------------------------------
# A dyed liquid seen from 4 deg above (thin ellipse), with a bright meniscus, two highlight stripes, the surface's
# image on the walls, a weak second mode, a container tilting +-2 deg and H.264 at 320x240: every effect at once,
# at half the benchmark's size.
SMALL_SURFACE = {k: v for k, v in SMALL.items() if k != "float_length_frac"}
"""SMALL for a dyed-liquid scene, which has no float to size."""
SURFACE = dict(
    SMALL_SURFACE,
    scene="surface",
    duration_s=4.0,
    tap_s=1.0,
    f_hz=2.0,
    zeta=0.04,
    amplitude_deg=7.0,
    elevation_deg=4.0,
    meniscus_px=1.5,
    specular=0.4,
    reflection=0.5,
    second_mode=0.15,
    container_tilt_deg=2.0,
    container_tilt_hz=0.3,
    liquid_color="green",
    seed=21,
)


@pytest.fixture(scope="module")
def surface_video(tmp_path_factory):
    """The SURFACE scene rendered once, and its truth."""
    path = tmp_path_factory.mktemp("surface") / "surface.mp4"
    return path, render_video(path, SynthSettings(**SURFACE))


@pytest.mark.parametrize("label_bgr", [(245, 245, 245), (211, 94, 50)], ids=["white", "dye-coloured"])
def test_a_label_on_the_glass_across_the_surface_is_left_out(tmp_path, label_bgr):
    # a user trial's label stuck on the glass across a fifth of the surface near the right wall (50x70 px, its top
    # above the surface, its bottom below): the columns behind it show the liquid's top at the label's lower edge
    # (white) or upper edge (a label of the dye's colour), a step of 35 px, and the robust fit bent through both levels:
    # 11.7 and 12.1 deg angle RMSE in valid frames, the walls unmoved. The step's columns are dropped now (measured
    # 0.05 deg, 0.3 px)
    truth = _trial_surface_clip(tmp_path / "l.mp4", (380, 230), (429, 299), label_bgr)
    assert truth["surface_y_px"].min() > 230 and truth["surface_y_px"].max() < 300  # the label spans the surface
    res = track_video(tmp_path / "l.mp4", TrackSettings(target="surface", liquid_color="blue", smooth=False))
    _assert_tracks_the_trial_clip(res, truth)


def test_another_region_of_the_dyes_colour_is_left_out_and_named(tmp_path):
    # a user trial's 100x100 px square of the dye's colour in the picture's corner, far from the container: the liquid's
    # box took it in and no frame found walls (exit 2, "widen --roi", where narrowing it was the fix)
    truth = _trial_surface_clip(tmp_path / "s.mp4", (10, 10), (109, 109), (211, 94, 50))
    res = track_video(tmp_path / "s.mp4", TrackSettings(target="surface", liquid_color="blue", smooth=False))
    _assert_tracks_the_trial_clip(res, truth)
    assert any("another region of the dye's colour (100x100 px at x 10-110, y 10-110)" in w for w in res.warnings)


def test_an_exposure_step_refits_the_colour_model_at_once(tmp_path):
    # a user trial's camera exposure step: a yellow dye's clip (H.264 CRF 10) encoded again at CRF 14 with the picture
    # at 60 % brightness from 2 s on. The colour model fitted before the step moved the bottom's edge, and both wall
    # heights with it, by 2 px until the next refit (measured: wall RMSE 0.99 / 0.97 px, at most 2.7 px); it is fitted
    # again in the step's frame now (0.20 / 0.20 px, at most 0.68)
    s = SynthSettings(
        scene="surface",
        liquid_color="yellow",
        f_hz=2.5,
        zeta=0.03,
        amplitude_deg=5.0,
        tap_s=1.0,
        duration_s=5.0,
        noise_sigma=3.0,
        quality=10,
        seed=3,
    )
    truth = render_video(tmp_path / "raw.mp4", s)
    with VideoWriter(tmp_path / "e.mp4", s.width, s.height, s.fps, quality=14) as w:
        for _, t, frame in FrameReader(tmp_path / "raw.mp4"):
            w.write(np.clip(frame * (0.6 if t >= 2.0 else 1.0), 0, 255).astype(np.uint8), t)
    res = track_video(tmp_path / "e.mp4", TrackSettings(target="surface", smooth=False))
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.7
    for side in ("left", "right"):
        err = (res.columns()[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok]
        assert _rmse(err) < 0.5 and np.abs(err).max() < 1.5


def test_an_automatic_dye_names_the_other_colour_it_passed_over(tmp_path):
    # a user trial's red label (180x240 px) beside blue water, no --liquid-color: the label, the largest region of a
    # preset colour, was measured as the liquid, with no word of the blue; the warning names it now
    _trial_surface_clip(tmp_path / "r.mp4", (455, 100), (634, 339), (40, 40, 220))
    res = track_video(tmp_path / "r.mp4", TrackSettings(target="surface", smooth=False))
    assert res.dye == "red (chosen from the first frame)"
    assert any(
        "blue covers a region at least a quarter as large" in w and "`liquid_color` blue" in w for w in res.warnings
    )
    alone = track_video(tmp_path / "r.mp4", TrackSettings(target="surface", liquid_color="blue", smooth=False))
    assert not any("quarter as large" in w for w in alone.warnings)


def test_a_cola_before_a_box_of_a_preset_colour_is_taken_as_the_liquid(tmp_path):
    # a near-black liquid (the `dark` preset, the largest region) and a magenta box behind, left of the glass: `dark`
    # is passed over where it is not measured as a liquid (an underexposed picture's shadows), and the box, measured as
    # one (its sides and its level top), was taken; the cola is measured as a liquid between walls, so it is kept
    truth = _trial_surface_clip(tmp_path / "c.mp4", (20, 60), (110, 330), (200, 40, 200), liquid_color="dark")
    res = track_video(tmp_path / "c.mp4", TrackSettings(target="surface", smooth=False))
    assert res.dye == "dark (chosen from the first frame)"
    cols = res.columns()
    assert 195 < np.median(cols["x_px"]) < 445  # the glass's, not the box's (20-110)
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9 and _rmse((cols["angle_deg"] - truth["surface_angle_deg"])[ok]) < 0.2


def test_a_liquid_standing_in_a_dark_holder_is_taken_over_the_holder(tmp_path):
    # a magenta liquid whose lower part stands in a black holder larger than it (the real frame's blue cylinder turned
    # magenta: its holder's shadows): `dark`, the largest region, measured validly at the holder's top and was taken,
    # and the holder tracked; a surface has air above it, so the holder's top under the liquid's body is no surface
    truth = _trial_surface_clip(tmp_path / "h.mp4", (120, 360), (520, 475), (15, 15, 15), liquid_color="magenta")
    res = track_video(tmp_path / "h.mp4", TrackSettings(target="surface", smooth=False))
    assert res.dye == "magenta (chosen from the first frame)"
    assert any("dark covers a larger region" in w and "what this one stands on" in w for w in res.warnings)
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9 and _rmse((res.columns()["angle_deg"] - truth["surface_angle_deg"])[ok]) < 0.2


def _trial_surface_clip(
    path: Path, corner: tuple, end: tuple, bgr: tuple, liquid_color: str = "blue"
) -> dict[str, np.ndarray]:
    """A user trial's 640x480 tap test (3 s, blue dye unless `liquid_color`) with a filled rectangle drawn into every
    frame; its truth."""
    s = SynthSettings(scene="surface", f_hz=2.0, zeta=0.04, amplitude_deg=6.0, tap_s=1.0, duration_s=3.0, seed=1)
    s = replace(s, liquid_color=liquid_color)
    rows = []
    with VideoWriter(path, s.width, s.height, s.fps) as w:
        for row, frame in render_frames(s):
            cv2.rectangle(frame, corner, end, bgr, -1)
            w.write(frame, row["t_s"])
            rows.append(row)
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def _assert_tracks_the_trial_clip(res: TrackResult, truth: dict[str, np.ndarray]) -> None:
    """Nearly every frame measured, within the issue's targets (0.3 deg, 1 px; the clip alone: 0.026 deg, 0.2 px)."""
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9
    assert _rmse((res.angle_deg - truth["surface_angle_deg"])[ok]) < 0.3
    for side in ("left", "right"):
        assert _rmse((res.columns()[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok]) < 1.0


def test_a_steep_slosh_does_not_turn_the_walls(tmp_path):
    # a move sloshing the surface to 29 deg brought it down the left wall into the rows read for the wall, whose fit
    # went through the sloped surface: that wall's height was 50 px off and the angle 1.9 deg, in valid frames (a trial
    # at 640x480; measured 3.9 px wall RMSE, 0.17 deg angle RMSE before, 0.28 px and 0.026 deg after)
    s = SynthSettings(
        scene="surface",
        motion="move",
        f_hz=3.0,
        zeta=0.04,
        accel_m_s2=1.5,
        duration_s=2.5,
        elevation_deg=4.0,
        meniscus_px=1.0,
        seed=7,
    )
    truth = render_video(tmp_path / "steep.mp4", s)
    assert np.abs(truth["rel_angle_deg"]).max() > 25
    res = track_video(tmp_path / "steep.mp4", TrackSettings(target="surface", reference="container"))
    ok, cols = res.valid.astype(bool), res.columns()
    assert _rmse((res.angle_deg - truth["rel_angle_deg"])[ok]) < 0.1  # measured 0.056
    # measured 0.35-0.44 px RMSE, 2.3-2.6 px at most: in the three frames at the slosh's steepest, which the luma edge
    # measures under the valid quality and the colour edge at 0.59 (they were not valid before that fallback: 0.15-0.19
    # px, 0.3-0.4 at most in the others); the bug this guards against was 50 px
    for side in ("left", "right"):
        err = (cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok]
        assert _rmse(err) < 0.6 and np.abs(err).max() < 3.0


def test_a_move_within_the_first_second_ends_the_rest_window(tmp_path):
    # the wall heights' rest level was the median of the first second, and a robot's move that starts within it put
    # its leaning surface into that median: every height was off by the lean (Blender's carried glass: 3.6 px; this
    # clip: 2.1-2.7 px RMSE before, 0.16-0.25 measured after). The rest window now ends where the container moves
    early = dict(motion="move", f_hz=3.0, zeta=0.04, accel_m_s2=1.0, move_start_s=0.3, duration_s=2.5)
    s = SynthSettings(**dict(SMALL_SURFACE, scene="surface", elevation_deg=4.0, seed=3, **early))
    truth = render_video(tmp_path / "early.mp4", s)
    for reference in ("image", "container"):
        res = track_video(tmp_path / "early.mp4", TrackSettings(target="surface", reference=reference))
        ok, cols = res.valid.astype(bool), res.columns()
        for side in ("left", "right"):
            assert np.abs(truth[f"{side}_wall_px"]).max() > 15  # the move leans the surface far (21 px)
            assert _rmse((cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok]) < 0.6
        assert any("the container moved at" in w and "`rest_frames`" in w for w in res.warnings)


def test_a_rest_window_is_cut_at_the_move_when_frames_at_rest_come_before_it():
    from sloshid.tracking.surface_track import _rest_before

    rest = np.arange(40) < 30
    assert _rest_before(rest, 13)
    assert not _rest_before(rest, 2)  # fewer than three frames before the move
    assert not _rest_before(rest, 35)  # the move after the window: nothing to cut


def _finished(left, right, x=None, y=None, valid=None):
    """The surface step's `finish` on raw rows: 30 fps, a level surface read against the liquid's sides, 130 px wide,
    its centre at (`x`, `y`) in the picture (default 320, 240), measured in the frames `valid` (default all)."""
    from sloshid.tracking.rows import SurfaceGeometry, step_row
    from sloshid.tracking.surface_track import SurfaceStep

    n = len(left)
    x = np.full(n, 320.0) if x is None else x
    y = np.full(n, 240.0) if y is None else y
    rows = [
        step_row(
            0.0,
            0.0,
            0.0,
            float(x[k]),
            float(y[k]),
            0.9,
            1 if valid is None else int(valid[k]),
            SurfaceGeometry(0.0, 0.0, left[k], right[k], 130.0, 0.0),
        )._replace(frame=k, t_s=k / 30)
        for k in range(n)
    ]
    step = SurfaceStep(TrackSettings(target="surface"), (0, 0, 640, 480))
    body, walls, notes = step.finish(rows)
    return np.array([b.valid for b in body], bool), walls, notes


def test_wall_heights_are_the_surfaces_rise_about_its_centre_whatever_the_bottom_reads():
    # the wall heights were read from the liquid's bottom: a Blender tumbler's bottom read at depths 24-30 px apart in
    # turn put that into both heights (and into their rest level). A planar slosh keeps the surface's centre where it
    # was (the liquid's volume), so each height is the rise about the centre. A level 24 px off (18 % of the width,
    # more than the 5 % a slosh stays within) whose surface stayed where it was in the picture is the bottom's misread
    # and keeps its frame (the tumbler's: 25 of 60 frames dropped); where the surface's centre moved in the picture
    # with the level (2 % of the width is 2.6 px), what was measured there is not the surface, and the frame is dropped
    t = np.arange(90) / 30
    rise = np.where(t > 1.0, 12.0 * np.sin(2 * np.pi * 2.0 * (t - 1.0)), 0.0)
    centre = 70.0 + np.random.default_rng(4).normal(0.0, 2.0, t.size)  # the bottom's read: +-2 px
    centre[5::7] -= 24.0
    valid, walls, notes = _finished(centre - rise, centre + rise)
    assert valid.all() and not any("centre left its level" in n for n in notes)  # the centre stayed at y 240
    assert np.allclose(walls["right_wall_px"], rise, atol=1e-9)
    assert np.allclose(walls["left_wall_px"], -rise, atol=1e-9)
    # the same levels with the surface's centre seen 24 px lower in those frames: not the surface
    valid, walls, notes = _finished(centre - rise, centre + rise, y=240.0 + np.where(centre < 60.0, 24.0, 0.0))
    assert np.array_equal(valid, np.abs(centre - 70.0) < 10.0)
    assert np.allclose(walls["right_wall_px"][valid], rise[valid], atol=1e-9)
    assert any("centre left its level" in n for n in notes)


def test_a_still_containers_glass_walls_misread_with_the_slosh_give_way_to_its_steady_sides():
    # pbr decay80 (cola in a beaker standing in a dark holder): the glass's walls read -16 to +18 deg with the slosh
    # while the liquid's sides held -7.0 +- 0.1 deg, and the walls turned every frame (within GLASS_AGREE_DEG of the
    # sides in most): relative to them 1.07 deg off (p95 6.8), wall heights 6.7 px RMSE. Sides that kept their angle
    # show a container that did not turn: its angle is the walls' median
    from sloshid.tracking.rows import SurfaceGeometry, step_row
    from sloshid.tracking.surface_track import SurfaceStep

    rng = np.random.default_rng(80)
    t = np.arange(120) / 30
    slosh = np.where(t > 0.4, 5.0 * np.exp(-0.9 * (t - 0.4)) * np.sin(2 * np.pi * 3.0 * (t - 0.4)), 0.0)
    sides = -7.0 + rng.normal(0.0, 0.08, t.size)
    glass = -7.0 + rng.normal(0.0, 0.02, t.size) - 1.8 * slosh  # up to 9 deg off at the slosh's crests
    surface = -2.2 + slosh  # in the picture
    rows = [
        step_row(
            0.0, 0.0, 0.0, 320.0, 240.0, 0.9, 1,
            SurfaceGeometry(math.tan(math.radians(surface[k] - glass[k])), glass[k], 70.0, 70.0, 130.0, 0.0, sides[k]),
        )._replace(frame=k, t_s=t[k])
        for k in range(t.size)
    ]  # fmt: skip

    def finished(rows):
        return SurfaceStep(TrackSettings(target="surface", reference="container"), (0, 0, 640, 480)).finish(rows)[0]

    body = finished(rows)
    cang = np.array([b.container_angle_deg for b in body])
    rel = np.array([b.angle_deg for b in body])
    assert np.ptp(cang) == 0 and abs(cang[0] + 7.0) < 0.1  # the walls' median: their misreads at the crests cancel
    assert np.max(np.abs(rel - (surface + 7.0))) < 0.1
    # sides held at one value throughout (the finder found the container's axes still): the same
    held = [r._replace(surface=r.surface._replace(sides_deg=-7.0)) for r in rows]
    body = finished(held)
    assert np.ptp([b.container_angle_deg for b in body]) == 0
    # a container that turned is read on its glass's walls frame by frame, also a turn of 0.8 deg in the last 40 % of
    # the frames, within the sides' noise and scatter but seen by walls that read it precisely (a review's case: the
    # walls' median read it up to 0.8 deg off)
    still = -7.0 + rng.normal(0.0, 0.02, t.size)
    for turn in (np.linspace(0.0, 3.0, t.size), np.where(t > 0.6 * t[-1], 0.8, 0.0)):
        turned = [
            r._replace(
                surface=r.surface._replace(
                    rel_slope=math.tan(math.radians(surface[k] - still[k] - turn[k])),
                    container_angle_deg=still[k] + turn[k],
                    sides_deg=sides[k] + turn[k],
                )
            )
            for k, r in enumerate(rows)
        ]
        assert np.allclose([b.angle_deg for b in finished(turned)], surface - still - turn, atol=1e-9)


def test_a_region_of_the_dyes_colour_left_out_is_named_beside_a_bottom_read_at_two_depths():
    # the note on another region of the dye's colour unpacked its box into the names of the surface centre's columns,
    # which the centre check reads after it: a crash wherever both happened
    from sloshid.tracking.rows import SurfaceGeometry, step_row
    from sloshid.tracking.surface_track import SurfaceStep

    level = np.where(np.arange(60) % 7 == 5, 46.0, 70.0)
    rows = [
        step_row(0.0, 0.0, 0.0, 320.0, 240.0, 0.9, 1, SurfaceGeometry(0.0, 0.0, v, v, 130.0, 0.0))._replace(
            frame=k, t_s=k / 30
        )
        for k, v in enumerate(level)
    ]
    step = SurfaceStep(TrackSettings(target="surface"), (0, 0, 640, 480))
    step.finder.elsewhere = (900, (500, 20, 60, 40))
    body, _, notes = step.finish(rows)
    assert all(b.valid for b in body)
    assert any("(60x40 px at x 500-560, y 20-60) was left out" in n for n in notes)


def test_a_move_in_the_first_second_ends_the_rest_window_though_the_bottom_reads_at_two_depths():
    # the Blender tumbler carried from 0.43 s: its window was not cut, as its frames disagreed on the centre (the
    # bottom), and the slosh of its move's first 0.6 s set the rest level: wall RMSE 10 px. The heights no longer
    # read the centre, so the window is cut at the move
    t = np.arange(90) / 30
    x = np.where(t < 0.4, 320.0, 320.0 + 200.0 * np.minimum(t - 0.4, 1.0))
    rise = np.where(t > 0.4, 10.0 + 3.0 * np.sin(2 * np.pi * 2.0 * t), 0.0)
    centre = np.full(t.size, 70.0)
    centre[1:12:3] -= 5.0  # within the centre check, not within the old window cut's agreement
    valid, walls, notes = _finished(centre - rise, centre + rise, x)
    assert valid.all()
    assert np.allclose(walls["right_wall_px"], rise, atol=1e-9)
    assert any("the container moved at 0.43 s" in n for n in notes)
    # one centre among the first frames misread 10 px off is not a container moving from the start (the review's
    # case: its rest level had been taken after the move, 9.7 px off)
    valid, walls, notes = _finished(centre - rise, centre + rise, x, y=np.where(t == t[1], 250.0, 240.0))
    assert np.allclose(walls["right_wall_px"], rise, atol=1e-9)
    assert any("the container moved at 0.43 s" in n for n in notes)


def test_a_container_moving_when_first_measured_takes_its_rest_level_where_it_stood_after_the_move():
    # Blender's move_h: a glow hid the surface until 0.53 s, mid-move, and the rest window (the first second, cut at
    # the move when three frames come before it) took three frames of the move, leaning 11 px, for the level at rest:
    # every height 9 px off. A container measured first while it moved gives its liquid's level where it stood after
    t = np.arange(90) / 30
    x = 320.0 - 200.0 * np.minimum(t / 1.2, 1.0)
    ring = 3.0 * np.sin(2 * np.pi * 3.0 * (t - 1.2)) * np.exp(-0.5 * (t - 1.2))
    rise = np.where(t < 1.2, 11.0 * np.sin(np.pi * t / 1.2), ring)
    valid = t > 0.5
    ok, walls, notes = _finished(70.0 - rise, 70.0 + rise, x, valid=valid)
    assert np.array_equal(ok, valid)
    err = (walls["right_wall_px"] - rise)[valid]
    assert np.abs(err).max() < 0.3  # the level: the median of a ringing over the 1.8 s after the move (9 px before)
    assert any("was moving when its surface was first measured (0.53 s)" in n and "(from 1.20 s)" in n for n in notes)
    # moving to the last frame: no place after the move, so the heights are above all valid frames' median, as said
    ok, walls, notes = _finished(70.0 - rise, 70.0 + rise, 320.0 - 200.0 * t, valid=valid)
    assert np.isclose(np.nanmedian(walls["right_wall_px"]), 0.0)
    assert any("moving when" in n and "the median of all valid frames" in n for n in notes)


def test_a_tracked_tables_column_is_chosen_as_in_its_csv(surface_video, tmp_path):
    # value_col was ignored for a TrackResult (API, pipelines, batch): the angle was fitted, and a misspelt column
    # passed silently. The chosen column now comes from the table, on the same rows as from the written CSV
    from sloshid.identification.stage import SignalColumns, to_signal

    path, _ = surface_video
    res = track_video(path, TrackSettings(target="surface", container_diameter_m=0.1))
    res.to_csv(tmp_path / "s.csv")
    for column in ("left_wall_mm", "angle_smoothed_deg"):  # read on the valid rows, and on every row
        mem = to_signal(res, SignalColumns(value_col=column))
        csv = load_signal(tmp_path / "s.csv", value_col=column)
        assert mem.label == csv.label == column
        assert np.allclose(mem.t_s, csv.t_s, rtol=0, atol=1e-9) and np.allclose(mem.value, csv.value, atol=1e-6)
    with pytest.raises(UserError, match="has no value column 'left_wall'; available: frame, t_s"):
        to_signal(res, SignalColumns(value_col="left_wall"))


@pytest.mark.parametrize("reference, column", [("image", "surface_angle_deg"), ("container", "rel_angle_deg")])
def test_surface_angle_and_wall_heights_match_truth(surface_video, reference, column):
    path, truth = surface_video
    res = track_video(path, TrackSettings(target="surface", reference=reference, container_diameter_m=0.1))
    ok = res.valid.astype(bool)
    # 0.75-0.78 measured (x264's code differs by CPU): the rest are frames the encoder repeated while the surface moved
    assert ok.mean() > 0.7
    # measured here: 0.07-0.08 deg RMSE and 0.4-0.5 px wall RMSE; the bounds leave room for other encoders.
    # (the benchmark's targets, 0.3 deg and 1 px, are for 640x480, where the walls are twice as long)
    assert _rmse((res.angle_deg - truth[column])[ok]) < 0.3
    cols = res.columns()
    for side in ("left", "right"):
        assert _rmse((cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok]) < 1.2
        # the scale comes from the measured walls (inner width 0.1 m = 120 px): 1.2 px is 1.0 mm
        assert _rmse((cols[f"{side}_wall_mm"] - truth[f"{side}_wall_mm"])[ok]) < 1.0
    if reference == "container":
        # the heights are turned onto the whole walls' axes, whose tilt is far better known than the liquid's sides':
        # 0.25 px over both walls measured (0.44 px read along the liquid's sides)
        both = np.concatenate([(cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok] for side in ("left", "right")])
        assert _rmse(both) < 0.35
    assert list(cols)[:11] == ["frame", "t_s", "angle_deg", "surface_angle_deg", *TRACK_COLUMNS[4:]]
    # against the image the angle includes the container's +-2 deg tilt, and track says so (3.9 deg measured)
    turned = [w for w in res.warnings if "container turned by" in w]
    assert len(turned) == (reference == "image") and all("`reference` container" in w for w in turned)
    # the dye chosen automatically is named (a trial's orange robot link was tracked as the liquid without a word)
    assert res.dye == f"{SURFACE['liquid_color']} (chosen from the first frame)" and res.to_dict()["dye"] == res.dye
    assert res.summary().endswith(f", dye {res.dye}")


def _axes(a_left: float, a_right: float, x_left: float, x_right: float, o: tuple[float, float]) -> tuple:
    """Container axes as `_container_axes` gives them (frame coordinates): walls of these slopes through these x at the
    bottom centre's row o[1], and the unit vectors from their mean slope."""
    a = 0.5 * (a_left + a_right)
    n = math.hypot(1, a)
    walls = ((a_left, x_left - a_left * o[1]), (a_right, x_right - a_right * o[1]))
    return walls, np.array(o, float), np.array([1.0, -a]) / n, np.array([-a, -1.0]) / n


def test_steady_axes_are_the_median_of_a_standing_container_and_none_for_a_moving_one():
    # a sloshing liquid's sides turn the walls read along them by degrees from frame to frame (0.9 deg here, as on the
    # path-traced tumbler of benchmarks/track_pbr.py's decay0); the bottom's centre stays within hundredths of a pixel
    rng = np.random.default_rng(3)
    n = 100  # a 3.3 s clip at 30 fps: the frame-to-frame noise is then known to a tenth (`steady_angle`)
    jitter = rng.normal(0, [0.015, 0.015, 0.5, 0.5, 0.02, 0.02], (n, 6))
    standing = [_axes(0.02 + j[0], -0.03 + j[1], 100 + j[2], 300 + j[3], (200 + j[4], 240 + j[5])) for j in jitter]
    (wl, wr), centre, e_u, e_w = steady_axes(standing)
    # the median of 100 draws of sd 0.015 is within 0.005 of the truth in 99.9 % of draws (1.25 sd / 10 x 3.3)
    assert abs(wl[0] - 0.02) < 0.005 and abs(wr[0] + 0.03) < 0.005
    assert abs(wl[0] * 240 + wl[1] - 100) < 0.25 and abs(wr[0] * 240 + wr[1] - 300) < 0.25
    assert np.allclose(centre, (200, 240), atol=0.02) and np.isclose(e_u @ e_w, 0)
    # a container slid by a robot (its bottom 0.2 px further each frame) or turned (0.05 deg a frame) moved: no median
    k = np.arange(n)
    slid = [
        _axes(0.02 + j[0], -0.03 + j[1], 100 + j[2] + 0.2 * i, 300 + j[3] + 0.2 * i, (200 + 0.2 * i, 240))
        for i, j in zip(k, jitter)
    ]
    turned = [
        _axes(0.02 + j[0] + 0.0009 * i, -0.03 + j[1] + 0.0009 * i, 100 + j[2], 300 + j[3], (200, 240))
        for i, j in zip(k, jitter)
    ]
    assert steady_axes(slid) is None and steady_axes(turned) is None
    # axes held over frames count once: 100 frames holding 10 measurements are too few to tell
    assert steady_axes([standing[i // 10] for i in k]) is None


def test_a_presets_hue_bounds_move_out_over_the_dyes_own_hues_and_stop_at_a_gap():
    # a blue dye whose top pales to hue 96-99 (below the blue preset's 100) and a cyan object of hue 90 touching it, with
    # no pixel of hues 91-95 between: the range takes the dye's continuing hues, not the object's across the gap
    hsv = np.zeros((120, 160, 3), np.uint8)
    hsv[..., 1:] = (20, 230)  # a grey wall
    hsv[20:100, 40:120] = (110, 220, 150)  # the dye's body
    hsv[20:40, 40:120, 0] = np.repeat(np.arange(96, 100), 5)[:, None]  # its top, hue 96-99 in bands of five rows
    hsv[40:100, 120:140] = (90, 220, 150)  # the object beside it
    frame = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)
    blue = PRESETS["blue"].hsv
    fitted = dye_range(frame, (0, 0, 160, 120), blue)
    assert fitted.low[0] == 96 and fitted.high == blue.high and fitted.low[1:] == blue.low[1:]
    # a range that wraps through red, or takes every hue (dark), is left as it is
    assert dye_range(frame, (0, 0, 160, 120), PRESETS["red"].hsv) == PRESETS["red"].hsv
    assert dye_range(frame, (0, 0, 160, 120), PRESETS["dark"].hsv) == PRESETS["dark"].hsv


def test_a_presets_saturation_floor_moves_down_over_the_dyes_paler_part_and_stops_before_a_table_of_its_hue():
    # a blue dye paling from saturation 160 to 90 towards a highlight (the blue preset starts at 140, and holds a third
    # of it), also on a blue-grey table of saturation 82 that runs out of the picture: the floor takes the dye's
    # palest pixels, not the table's
    hsv = np.zeros((120, 160, 3), np.uint8)
    hsv[..., 1:] = (20, 230)  # a grey wall
    hsv[20:100, 40:120] = (115, 160, 180)  # the dye's body
    hsv[20:100, 50:120, 1] = np.linspace(160, 90, 70).astype(np.uint8)  # most of it pales to the right
    frame = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)
    blue = PRESETS["blue"].hsv
    roi = (0, 0, 160, 120)
    assert 85 <= dye_range(frame, roi, blue).low[1] <= 92  # the palest column's 90 (less the conversion's rounding)
    table = hsv.copy()
    table[100:, :] = (112, 82, 160)  # the table, touching the dye's bottom
    floor = dye_range(cv2.cvtColor(table, cv2.COLOR_HSV2BGR), roi, blue).low[1]
    assert 85 <= floor <= 92, floor  # above the table's 82
    # the dye's pale colour also away from it (a patch on the wall): the preset's floor stays
    hsv[5:15, 140:150] = (115, 100, 180)
    assert dye_range(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), roi, blue).low[1] == blue.low[1]
    # a dye the preset holds mostly (its pale part a fringe) keeps the preset's floor
    hsv[5:15, 140:150] = (0, 20, 230)
    hsv[20:100, 50:120, 1] = 160
    hsv[20:100, 110:120, 1] = 100
    assert dye_range(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), roi, blue).low[1] == blue.low[1]
    # ... also when highlight stripes cut it into pieces, none of them half of it, that the lower floor joins (a painted
    # glass): the preset holds most of the dye in all its pieces together
    hsv[20:100, 110:120, 1] = 160
    hsv[20:100, 64:68, 1] = 90
    hsv[20:100, 92:96, 1] = 90
    hsv[20:24, 40:120, 1] = 90  # the surface's pale reflection along the top
    assert dye_range(cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR), roi, blue).low[1] == blue.low[1]


def test_the_dark_presets_value_ceiling_moves_up_over_a_greyed_near_black_liquid_and_stops_before_a_dark_table():
    # a near-black liquid greying from value 50 to 100 towards a bright glass's side (the dark preset ends at 60 and
    # holds a third of it), on a white wall: the ceiling takes the liquid's brightest pixels; a grey table of value 110
    # touching it and running out of the picture is left out, and a grey patch of the liquid's value away from it
    # keeps the preset's ceiling (a shadow or a dark object: the liquid's grey part cannot be told from it)
    hsv = np.zeros((120, 160, 3), np.uint8)
    hsv[..., 1:] = (10, 235)  # a white wall
    hsv[20:100, 40:120] = (18, 40, 40)  # the liquid's body
    hsv[20:100, 55:120, 2] = np.linspace(50, 100, 65).astype(np.uint8)  # most of it greys to the right
    dark = PRESETS["dark"].hsv
    roi = (0, 0, 160, 120)

    def ceiling(picture: np.ndarray) -> int:
        got = dye_range(cv2.cvtColor(picture, cv2.COLOR_HSV2BGR), roi, dark)
        assert got.low == dark.low and got.high[:2] == dark.high[:2]
        return got.high[2]

    assert 98 <= ceiling(hsv) <= 102  # the brightest column's 100 (less the conversion's rounding)
    table = hsv.copy()
    table[100:, :] = (18, 20, 110)
    assert 98 <= ceiling(table) <= 102  # below the table's 110
    hsv[5:15, 140:150] = (18, 20, 90)
    assert ceiling(hsv) == dark.high[2]
    # a liquid the preset holds mostly keeps the preset's ceiling
    hsv[5:15, 140:150] = (0, 10, 235)
    hsv[20:100, 55:110, 2] = 40
    assert ceiling(hsv) == dark.high[2]


def test_a_surface_measured_again_in_turned_axes_keeps_its_angle_in_the_picture(surface_video):
    # a frame's front edge refitted in other axes (what a standing container's frames get: the median of theirs) is
    # the same picture: its own axes give the same measurement, and axes turned by 1 deg turn the container's angle by
    # 1 deg while the surface's angle in the picture stays (the line is read off the same edge points)
    path, _ = surface_video
    frames = [f.to_ndarray(format="bgr24") for f in av.open(str(path)).decode(video=0)][:48]
    finder = SurfaceFinder(None, (0, 0, frames[0].shape[1], frames[0].shape[0]))
    for frame in frames:
        m = finder.measure(frame)
    assert m.found and m.in_axes is not None
    held, source = finder.settled()
    same = m.in_axes(m.axes, held, source)
    assert math.isclose(same.rel_slope, m.rel_slope, abs_tol=1e-9) and math.isclose(same.left_w, m.left_w, abs_tol=1e-9)
    # turned about the surface's row: the walls stay where the surface meets them (turned about the bottom they would
    # move the surface ellipse's centre there, and 1.5 px of it turned the line by 0.15 deg)
    (wl, wr), o, _, _ = m.axes
    turn, y = math.radians(1.0), m.y_px
    walls = [a * o[1] + b + turn * (o[1] - y) for a, b in (wl, wr)]
    turned = m.in_axes(_axes(wl[0] + turn, wr[0] + turn, *walls, o), held, source)
    assert turned.found and abs(turned.container_angle_deg - m.container_angle_deg - 1.0) < 0.02

    def seen(x):
        return math.degrees(math.atan(x.rel_slope)) + x.container_angle_deg

    # measured: 0.007 deg (the turned axes move the columns near the walls in or out of the fit)
    assert abs(seen(turned) - seen(m)) < 0.05


def test_surface_csv_identifies_like_its_truth(surface_video, tmp_path, run_cli):
    # the contract with identify: a surface CSV is read like a float CSV, and its f matches the truth trace's
    path, truth = surface_video
    out = tmp_path / "s.csv"
    code, stdout, _ = run_cli("track", path, "-o", out, "--target", "surface", "--reference", "container")
    assert code == 0 and "valid" in stdout
    from sloshid.identification.estimator import Identifier
    from sloshid.identification.signals import Signal, load_signal

    tracked = Identifier().fit(load_signal(out)).result.parameters
    exact = Identifier().fit(Signal(truth["t_s"], truth["rel_angle_deg"], "angle", "deg", "truth")).result.parameters
    # 3 s of a 2 Hz decay at 30 fps: f to 0.5 %, zeta to 15 % of the truth trace's (benchmark: longer clips)
    assert tracked["f_hz"].value == pytest.approx(exact["f_hz"].value, rel=0.005)
    assert tracked["zeta"].value == pytest.approx(exact["zeta"].value, rel=0.15)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--target", "surface", "--liquid-color", "red"], "no liquid of colour H 170..10"),
        (["--target", "surface", "--roi", "110,40,100,150"], "not the container's inner walls"),
        (["--container-diameter-m", "0.1"], "only --target surface measures"),
        (["--target", "surface", "--liquid-hsv-low", "40,100,60"], "together"),
        # an option of the other target would be ignored: refused
        (["--rest-frames", "10"], "--rest-frames applies only to --target surface"),
        (["--liquid-color", "blue"], "--liquid-color applies only to --target surface"),
        (["--target", "surface", "--float-color", "blue"], "--float-color applies only to --target float"),
        # also when they name the float's default colour, red (both were taken without a word)
        (["--liquid-color", "red"], "--liquid-color applies only to --target surface"),
        (["--target", "surface", "--float-color", "red"], "--float-color applies only to --target float"),
        # a diameter in millimetres would scale the heights a thousandfold
        (["--target", "surface", "--container-diameter-m", "100"], "at most 10 (0.1 for 100 mm), got 100: is it in"),
        # a slip the other way gave wall heights in nanometres (1e-9) and exit 0
        (["--target", "surface", "--container-diameter-m", "1e-9"], "at least 0.001 (0.1 for 100 mm), got 1e-09."),
        (["--target", "surface", "--liquid-hsv-low", "100,140,60", "--liquid-hsv-high", "125,300,255"], "-high: HSV"),
    ],
)
def test_surface_bad_input_is_one_sentence_and_leaves_nothing(surface_video, tmp_path, run_cli, extra, message):
    path, _ = surface_video
    out = tmp_path / "a.csv"
    code, _, err = run_cli("track", path, "-o", out, *extra)
    assert code == 2 and message in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()


def test_repeats_are_stale_when_they_held_motion_not_when_a_still_object_was_copied():
    # a still start copied by the encoder until the tap: the motion began at the run's end, the copies are right
    tap = np.r_[np.zeros(36), 0.4, 1.2, 2.2, 3.0]
    rep = [False] + [True] * 35 + [False] * 4
    assert not stale_repeats(tap, np.ones(40, bool), rep).any()
    # a tap whose first frame holds most of its rise (d5: 5.6 deg, then 2.3 deg a frame) after 18 copied frames of a
    # still float: the jump is more than two frames of the motion after it, but spread over the run it is 0.3 deg a
    # frame, an eighth of that motion: the run held none of it (its frames read stale before)
    sharp = np.r_[np.zeros(19), 5.6, 7.95, 6.4]
    rep = [False] + [True] * 18 + [False] * 3
    assert not stale_repeats(sharp, np.ones(22, bool), rep).any()
    # a run inside a steady motion (0.1 deg per frame): the fresh frame after it jumps by the run's length of motion
    ramp = 0.1 * np.arange(20)
    ramp[10:14] = ramp[9]
    rep = [False] * 10 + [True] * 4 + [False] * 6
    np.testing.assert_array_equal(np.flatnonzero(stale_repeats(ramp, np.ones(20, bool), rep)), [10, 11, 12, 13])
    # at rest before, then a step hidden in the run (the frames after it barely move): when it came is unknown
    step = np.r_[0.02 * (-1) ** np.arange(10), 0.0, 0.0, 0.0, 0.5, 0.52, 0.5]
    rep = [False] * 10 + [True] * 3 + [False] * 3
    np.testing.assert_array_equal(np.flatnonzero(stale_repeats(step, np.ones(16, bool), rep)), [10, 11, 12])


def test_a_copied_picture_takes_its_measured_frame_and_a_drifting_one_is_measured():
    # a picture whose edges in every region the last measured frame was read from are all that frame's is not measured
    # again; one whose edges moved a little at each frame is, though each frame is most of the one before (an encoder
    # updating a slowly moving float's blocks a few at a time: copies of the first frame would hide the drift), and so
    # is one whose wall moved under an unchanged surface band
    y = np.zeros((40, 60), np.uint8)
    y[20:, 10:50] = 200  # a surface line across the box between two walls
    uv = np.full((20, 30), 128, np.uint8)
    first = Picture(y, uv, uv)
    copies = Copies()
    regions = [((10, 10, 50, 30), True), *line_regions([(0.0, 10.0, 20, 39), (0.0, 50.0, 20, 39)])]
    copies.measured(0, first, regions, ("row 0",))
    assert copies.source(Picture(y.copy(), uv, uv), 1) == ("row 0",)
    drifted = y.copy()
    drifted[19, 10:23] = 200  # a third of the line moved up by a pixel: two thirds of its edge pixels are unchanged
    assert repeated_share(Picture(drifted, uv, uv), first, (10, 10, 50, 30), True) >= REPEAT_SHARE
    assert copies.source(Picture(drifted, uv, uv), 2) is None
    slid = y.copy()
    slid[30:, 48:50] = 0  # the right wall moved in by 2 px below the band: the band is as it was
    assert repeated_share(Picture(slid, uv, uv), first, (10, 10, 50, 30), True) >= REPEAT_SHARE
    assert copies.source(Picture(slid, uv, uv), 3) is None
    rows = [(0.0, 1.5), (0.1, 9.9), (0.2, 2.5), (0.3, 3.5)]
    copies.fill(rows)
    assert rows == [(0.0, 1.5), (0.1, 1.5), (0.2, 2.5), (0.3, 3.5)] and copies.last is None


def test_a_container_turning_under_level_liquid_is_measured_in_every_frame(tmp_path):
    # a reviewer's container turned 3 deg over 2.5 s around liquid at rest: the level surface's band stays the same, and
    # frames copied on the band alone kept their container angle: a staircase of 0.7 deg in valid rows. The walls and
    # the bottom are compared too now (measured: within 0.06 deg, as when measuring every frame)
    rng = np.random.default_rng(0)

    def frame_at(tilt_deg: float) -> np.ndarray:
        s = 2  # drawn at twice the size, then shrunk: anti-aliased edges
        img = np.zeros((480 * s, 640 * s, 3), np.uint8)
        img[:] = np.linspace(215, 175, 480 * s)[:, None, None].astype(np.uint8)
        c, si = math.cos(math.radians(tilt_deg)), math.sin(math.radians(tilt_deg))
        px, py = 320 * s, 420 * s

        def turned(pts):
            return np.array([[px + (x - px) * c + (y - py) * si, py - (x - px) * si + (y - py) * c] for x, y in pts])

        inner = turned([(200 * s, 175 * s), (440 * s, 175 * s), (440 * s, 420 * s), (200 * s, 420 * s)]).astype(
            np.int32
        )
        outer = turned([(194 * s, 175 * s), (446 * s, 175 * s), (446 * s, 426 * s), (194 * s, 426 * s)]).astype(
            np.int32
        )
        cv2.fillPoly(img, [outer], (80, 80, 80))
        cv2.fillPoly(img, [inner], (210, 212, 214))
        liquid = np.zeros(img.shape[:2], np.uint8)
        cv2.fillPoly(liquid, [inner], 255)
        liquid[: 300 * s] = 0  # the level surface at y = 300
        img[liquid > 0] = (215, 80, 30)
        small = cv2.resize(img, (640, 480), interpolation=cv2.INTER_AREA).astype(float)
        return np.clip(small + rng.normal(0, 3.0, small.shape), 0, 255).astype(np.uint8)

    tilt = np.clip((np.arange(90) / 30 - 0.5) * 3.0 / 2.5, 0, None)
    with VideoWriter(tmp_path / "t.mp4", 640, 480, 30.0, quality=18) as w:
        for k, deg in enumerate(tilt):
            w.write(frame_at(deg), k / 30)
    settings = TrackSettings(target="surface", reference="container", smooth=False)
    res = track_video(tmp_path / "t.mp4", settings, multithreaded=False)
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9
    assert np.abs(res.angle_deg + tilt)[ok].max() < 0.2  # the liquid stays level: against the container, -tilt


def test_repeated_pictures_are_not_measured_again_and_track_as_before(tmp_path, monkeypatch):
    # the still container's liquid rests before its tap and the encoder copies it (at CRF 26): those frames take the row
    # of the frame they copy, and count toward the colour model's refits; measuring them anyway gives the same track
    # (measured: within 0.012 deg and 0.15 px; 0.006 deg and 0.04 px before the walls were read from a tenth of the
    # liquid's height down, where the wall's reflection of the surface lies and each colour refit moves its edge a
    # little; 0.054 deg and 0.58 px when copies did not count toward the refits)
    path = tmp_path / "still.mp4"
    truth = render_video(path, SynthSettings(**dict(STILL_SURFACE, quality=26)))
    settings = TrackSettings(target="surface", smooth=False)
    frames, measure = [], SurfaceFinder.measure
    monkeypatch.setattr(SurfaceFinder, "measure", lambda self, frame: frames.append(frame) or measure(self, frame))
    res = track_video(path, settings, multithreaded=False)
    assert len(frames) < 0.8 * len(res.t_s)  # measured: 62 of 90
    monkeypatch.setattr(repeats.Copies, "source", lambda self, frame, index: None)  # no frame is a copy
    every = track_video(path, settings, multithreaded=False)
    ok = res.valid.astype(bool) & every.valid.astype(bool)
    assert ok.mean() > 0.5
    assert np.abs(res.angle_deg - every.angle_deg)[ok].max() < 0.02
    for side in ("left", "right"):
        column = f"{side}_wall_px"
        assert np.abs(res.columns()[column] - every.columns()[column])[ok].max() < 0.2
    assert _rmse((res.angle_deg - truth["surface_angle_deg"])[ok]) < 0.3


def test_a_run_that_finds_nothing_keeps_an_overlay_already_there(surface_video, tmp_path, run_cli):
    # the overlay of a run that finds nothing is its diagnosis: written to a new path, never over an existing file
    path, _ = surface_video
    old, new = tmp_path / "old.mp4", tmp_path / "new.mp4"
    old.write_bytes(b"an earlier overlay")
    errors = []
    for overlay in (old, new):
        args = ["-o", tmp_path / "a.csv", "--target", "surface", "--liquid-color", "red", "--overlay", overlay]
        code, _, err = run_cli("track", path, *args)
        assert code == 2 and err.count("\n") == 1
        errors.append(err)
    assert f"{old} was kept" in errors[0] and f"see the overlay {new}" in errors[1]
    assert old.read_bytes() == b"an earlier overlay" and new.stat().st_size > 1000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.mp4", "old.mp4"]  # no CSV, no temporary file


def test_the_front_edge_is_the_crossing_into_the_body_not_a_pale_band_above_it():
    # a yellow dye's surface ellipse, seen from slightly above, is a pale band whose membership hovers about 0.5
    # (measured 0.38-0.51 over 8-10 rows, at most two rows at 0.5 or more): in some columns it crosses 0.5 near the
    # band's top, the ellipse's back edge. The front edge is where the solid body begins (row 15.5 in every column)
    body = np.zeros((30, 40))
    body[10:15, 0::2] = np.array([0.42, 0.49, 0.51, 0.50, 0.46])[:, None]  # a measured column: two rows at 0.5
    body[10:15, 1::2] = np.array([0.40, 0.45, 0.49, 0.48, 0.46])[:, None]  # and one that stays below
    body[15], body[16], body[17:] = 0.4, 0.6, 1.0
    inside = _inside(body)
    plain, _ = _crossings_first(body, inside, axis=0)
    edge, found = _crossings_first(body, _sustained(inside), axis=0)
    assert (plain < 15).any()  # the bare 0.5 crossing lands on the band in some columns
    assert found.all() and np.allclose(edge, 15.5)


def test_the_front_edge_below_a_surface_band_that_reads_as_liquid_in_some_columns():
    # a dark dye's surface ellipse seen from above reflects its own colour in some columns: there the first crossing is
    # the ellipse's back edge (row 10), in the others its front edge (row 18). Below a gap of two rows without liquid
    # the body is solid: each column's front edge is at 17.5 (membership 0.0 -> 1.0 between rows 17 and 18)
    body = np.zeros((40, 30))
    body[10:13, 0::2] = 1.0  # the band's liquid-coloured top rows in every second column
    body[18:] = 1.0
    inside = _inside(body)
    held = _sustained(inside)
    first, found = _crossings_first(body, held, axis=0)
    assert found.all() and np.allclose(first[0::2], 9.5) and np.allclose(first[1::2], 17.5)
    below, gap = _front_below(body, inside, held, first, found, reach=12)
    assert np.allclose(below, 17.5) and gap[0::2].all() and not gap[1::2].any()
    # a gap further than `reach` below the first crossing (a label's edge, a graduation mark) is not taken
    body[30:32] = 0.0
    inside = _inside(body)
    held = _sustained(inside)
    assert np.allclose(_front_below(body, inside, held, first, found, reach=12)[0], 17.5)


def test_a_surface_found_but_never_clear_is_refused_for_that_not_for_the_walls(tmp_path):
    # walls and a surface line found in every frame, each under the valid quality (a dye whose colour changes with
    # what stands behind it: the boundary between its two looks was read): the refusal says so and what to try,
    # not that the walls were missing
    step = SurfaceStep(TrackSettings(target="surface"), (0, 0, 640, 480))
    step.finder.hsv = PRESETS["magenta"].hsv
    step.liquid_frames = step.line_frames = 15
    text = str(step.nothing_found(15, tmp_path / "clip.mp4", "see the overlay x.mp4"))
    assert "walls were found in 15 of 15 frames" in text and "quality under 0.5" in text
    assert "not the container's inner walls" not in text
    step.line_frames = 0
    assert "not the container's inner walls" in str(step.nothing_found(15, tmp_path / "clip.mp4", "see x.mp4"))


def test_surface_target_on_a_float_video_measures_the_water_it_floats_on(tmp_path):
    # a float video's pale blue water between the container's walls: with no colour given the red float covers the
    # largest region of a preset's colour but has no walls, so the water's own range is taken (it was refused) and its
    # surface follows the float's truth (it floats on it) within 0.2 deg RMS (measured 0.065 over an 8 deg decay)
    path = tmp_path / "float.mp4"
    render_video(path, SynthSettings(**{**SMALL, "width": 640, "height": 480}), tmp_path / "truth.csv")
    truth = read_csv(tmp_path / "truth.csv")
    res = track_video(path, TrackSettings(target="surface", smooth=False))
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9 and res.dye.endswith("no preset's (chosen from the first frame)")
    assert np.sqrt(np.mean((res.angle_deg - truth["float_angle_deg"])[ok] ** 2)) < 0.2
    assert any(
        "red covers a larger region, which was not measured as a liquid, or only as what this one stands on" in w
        for w in res.warnings
    ), res.warnings


def test_surface_target_on_a_float_named_as_the_dye_is_a_user_error(tmp_path, run_cli):
    # the float's colour given as the dye's: the float has no straight inner walls beside it, and walls fitted to its
    # ragged sides once left the mapped box (a crash)
    path = tmp_path / "float.mp4"
    render_video(path, SynthSettings(**{**SMALL, "width": 640, "height": 480}))
    out = tmp_path / "a.csv"
    red = ("--target", "surface", "--liquid-color", "red")
    code, _, err = run_cli("track", path, "-o", out, *red)
    assert code == 2 and "not the container's inner walls" in err and "Traceback" not in err
    assert not out.exists()
    # what was found is drawn (inspect's picture of the first frame, beside the video) and the sentence points to it
    picture = tmp_path / "float_inspect.png"
    assert f"see {picture} (what each target finds" in err
    assert cv2.imread(str(picture)).shape[0] > 0
    # a file already there is kept, and the sentence points to inspect instead
    picture.write_bytes(b"mine")
    code, _, err = run_cli("track", path, "-o", out, *red)
    assert code == 2 and picture.read_bytes() == b"mine" and "look at a frame with `sloshid inspect`" in err


# A container that stands still is measured in a band of rows around the surface (plus two strips that watch the
# walls and the bottom) instead of the whole liquid body.
STILL_SURFACE = dict(SURFACE, container_tilt_deg=0.0, duration_s=3.0, seed=23)


@pytest.fixture(scope="module")
def still_surface_video(tmp_path_factory):
    """A still container's surface video, and its truth."""
    path = tmp_path_factory.mktemp("still") / "still.mp4"
    return path, render_video(path, SynthSettings(**STILL_SURFACE))


def test_a_rest_window_without_a_measurement_is_said_and_one_covering_the_video_refused(
    still_surface_video, monkeypatch
):
    # the wall heights are heights above rest: the median of the rest window's valid frames (the first second). A
    # window with none falls back on every valid frame, which a warning says; one covering the video is refused
    path, truth = still_surface_video
    frames = len(truth["t_s"])
    with pytest.raises(SettingError, match=f"rest_frames {frames} covers the whole video, which has {frames} frames"):
        track_video(path, TrackSettings(target="surface", rest_frames=frames, smooth=False), multithreaded=False)
    measure, calls = SurfaceFinder.measure, [0]

    def late(self, frame):
        """The surface found only from the 40th frame on (past the first second at 30 fps)."""
        calls[0] += 1
        return measure(self, frame) if calls[0] > 40 else SurfaceMeasurement(False, liquid=True)

    monkeypatch.setattr(SurfaceFinder, "measure", late)
    res = track_video(path, TrackSettings(target="surface", smooth=False), multithreaded=False)
    assert [w for w in res.warnings if "none of the first second (the rest window)" in w]
    left = res.columns()["left_wall_px"][res.valid.astype(bool)]
    assert left.size > 30 and abs(np.median(left)) < 1e-9  # above the median of every valid frame


def test_a_clip_shorter_than_the_rest_window_says_so(tmp_path):
    # a trial's 0.7 s clip: the default rest window (the first second) held every frame, and the heights were above
    # the whole clip's median without a word (--rest-frames covering it was already refused)
    s = SynthSettings(**dict(STILL_SURFACE, duration_s=0.7, tap_s=0.1))
    render_video(tmp_path / "short.mp4", s)
    res = track_video(tmp_path / "short.mp4", TrackSettings(target="surface", smooth=False), multithreaded=False)
    assert [w for w in res.warnings if "the video lasts 0.67 s, less than the rest window (the first second)" in w]
    res = track_video(tmp_path / "short.mp4", TrackSettings(target="surface", smooth=False, rest_frames=3))
    assert not [w for w in res.warnings if "rest window" in w]


def test_a_still_image_is_refused_as_a_video(tmp_path, run_cli):
    # a trial's PNG (or one named .mp4) was tracked as a video of one frame, exit 0
    frame = next(render_frames(SynthSettings(**STILL_SURFACE)))[1]
    cv2.imwrite(str(tmp_path / "still.png"), frame)
    out = tmp_path / "a.csv"
    code, _, err = run_cli("track", tmp_path / "still.png", "-o", out, "--target", "surface")
    assert code == 2 and "still.png holds a single picture, not a video" in err and not out.exists()
    # and it says what looks at a picture
    assert f"`sloshid inspect {tmp_path / 'still.png'}` shows what each target would find in it." in err


def _tracked_with_band(path: Path, band: bool, monkeypatch) -> tuple[TrackResult, int, int]:
    """The surface track of `path` with band frames allowed or not, how many frames were band frames and how many
    were measured (not copies of a repeated picture)."""
    used, measured = [0], [0]
    measure_band, measure = SurfaceFinder._measure_band, SurfaceFinder.measure

    def counted(self, frame):
        m = measure_band(self, frame)
        used[0] += m is not None
        return m

    def all_counted(self, frame):
        measured[0] += 1
        return measure(self, frame)

    with monkeypatch.context() as mp:
        mp.setattr(SurfaceFinder, "_measure_band", counted)
        mp.setattr(SurfaceFinder, "measure", all_counted)
        if not band:
            mp.setattr(SurfaceFinder, "_band_ready", lambda self: False)
        res = track_video(path, TrackSettings(target="surface", smooth=False), multithreaded=False)
    return res, used[0], measured[0]


def test_band_frames_measure_a_still_container_like_whole_body_frames(still_surface_video, monkeypatch):
    path, truth = still_surface_video
    band, n_band, measured = _tracked_with_band(path, True, monkeypatch)
    whole, n_whole, _ = _tracked_with_band(path, False, monkeypatch)
    # 47 of the 53 frames measured (the other 37 repeated a picture): the first frames fit the axes (two fits must
    # agree), and the colours are refitted at 48
    assert n_whole == 0 and n_band > 0.8 * measured
    ok = band.valid.astype(bool) & whole.valid.astype(bool)
    assert ok.mean() > 0.5  # 0.6: the surface rests for the first second, and the encoder repeats it
    # the same surface, but the axes are refitted at other frames and columns under a highlight stripe find no edge
    # in the band (the robust fit drops them either way): measured 0.03 deg and 0.2 px at most; the accuracy against
    # the truth is the same (0.09 deg and 0.27-0.31 px RMSE both ways)
    assert np.abs(band.angle_deg - whole.angle_deg)[ok].max() < 0.1
    for side in ("left", "right"):
        b, w = band.columns()[f"{side}_wall_px"], whole.columns()[f"{side}_wall_px"]
        assert np.abs(b - w)[ok].max() < 0.5
        assert _rmse((b - truth[f"{side}_wall_px"])[ok]) < 1.2
    assert _rmse((band.angle_deg - truth["surface_angle_deg"])[ok]) < 0.3
    # a container standing still draws no warning that it turned (0.0 deg measured; the threshold is 1 deg)
    assert not any("container turned by" in w for w in band.warnings + whole.warnings)


def test_the_elevation_is_held_from_the_frames_measured_validly():
    # a faint yellow dye in a cylinder seen 9.2 deg from above (pbr scene 7007): three frames read the ellipse's
    # opening at 0.16 of the width (sin 9.2 deg = 0.160) at quality 0.58, twelve (by their noise: each frame alone reads
    # so) at 0.068 and quality 0.26; their median was held and the surface read 1.8 deg off (0.5 now)
    finder = SurfaceFinder(PRESETS["yellow"].hsv, (0, 0, 640, 480))
    finder._k, finder._e, finder._q = [0.160] * 3 + [0.068] * 12, [0.0] * 15, [0.58] * 3 + [0.26] * 12
    assert finder.settled()[0] == (0.160, 0.0)
    # before any frame is valid (as a first frame may be until the elevation is held) every frame counts
    finder._q = [0.3] * 3 + [0.26] * 12
    assert finder.settled()[0] == (0.068, 0.0)


def test_of_two_readings_of_the_elevation_the_one_that_fits_every_first_frame_is_held():
    # a Blender tumbler of orange juice seen 6.7 deg from above (sin 0.117): its lit top face's front edge was fitted in
    # 5 first frames (k / R 0.094-0.098, quality 0.60-0.75) and a line above it in 10 (0.27-0.285, quality 0.50-0.55):
    # the median was held and the surface read 1.5 deg off. Measured again with each reading's medians (the elevation
    # and the ellipse's centre), every first frame fits the first one better; a frame under the valid quality is left
    # out of the readings
    def refit(quality_at: dict):
        return lambda held, source: SurfaceMeasurement(True, True, quality=quality_at[round(held[0], 3), held[1]])

    finder = SurfaceFinder(PRESETS["orange"].hsv, (0, 0, 640, 480))
    finder._k = [0.094, 0.094, 0.094, 0.094, 0.098] + [0.285] * 10
    finder._e = [0.007] * 5 + [0.099] * 10
    finder._q = [0.75, 0.75, 0.75, 0.75, 0.60] + [0.50] * 9 + [0.30]
    finder._k[-1] = 0.5  # under the valid quality: no reading of its own
    finder._refits = [refit({(0.094, 0.007): 0.75, (0.285, 0.099): 0.55, (0.5, 0.099): 0.9})] * 15
    assert finder.settled()[0] == (0.094, 0.007)
    # a reading that fits hardly better (under ELEVATION_GAIN) does not replace the median
    finder._refits = [refit({(0.094, 0.007): 0.58, (0.285, 0.099): 0.55, (0.5, 0.099): 0.9})] * 15
    assert finder.settled()[0] == (0.285, 0.099)
    # a front edge (k > 0) is not weighed against a back edge (k < 0): a pbr cola seen 5 deg from above fitted its
    # two front-edge frames better, but the back edge read the line 0.11 deg closer to the truth
    finder._k, finder._e, finder._q = [0.064] * 2 + [-0.085] * 13, [0.0] * 15, [0.85] * 2 + [0.74] * 13
    finder._refits = [refit({(0.064, 0.0): 0.85, (-0.085, 0.0): 0.74})] * 15
    assert finder.settled()[0] == (-0.085, 0.0)


def test_first_frames_are_measured_again_with_the_held_elevation(surface_video, monkeypatch):
    # the camera's elevation with the surface ellipse's centre (and the front edge's source) are chosen in each span's
    # first 15 frames and then held; those first frames are measured again with them at the span's end, as if they had
    # been held from the start
    path, _ = surface_video
    settings = TrackSettings(target="surface", reference="container", smooth=False)
    settled, held = SurfaceFinder.settled, []
    monkeypatch.setattr(SurfaceFinder, "settled", lambda self: held.append(settled(self)) or held[-1])
    revised = track_video(path, settings, multithreaded=False)
    assert len(held) == 1 and 0.05 < held[0][0][0] < 0.09  # sin(4 deg) = 0.070; measured 0.076
    assert held[0][1] == "luma"  # a green dye: the luma edge scatters less than the colour one
    init = SurfaceFinder.__init__

    def held_from_the_start(self, *args):
        init(self, *args)
        self._held, self._edges = held[0]

    monkeypatch.setattr(SurfaceFinder, "__init__", held_from_the_start)
    ahead = track_video(path, settings, multithreaded=False)
    first = np.arange(len(revised.t_s)) < 15
    ok = revised.valid.astype(bool) & ahead.valid.astype(bool) & first
    assert ok.sum() >= 10
    # measured: identical; without the second measurement they were up to 0.005 deg and 0.19 px apart
    assert np.abs(revised.angle_deg - ahead.angle_deg)[ok].max() < 1e-6
    for side in ("left", "right"):
        a, b = revised.columns()[f"{side}_wall_px"], ahead.columns()[f"{side}_wall_px"]
        assert np.abs(a - b)[ok].max() < 1e-6


def test_a_camera_well_above_the_liquid_does_not_take_the_dark_walls_for_liquid(tmp_path):
    # from 16 deg above, the colour model had to tell the dye from its own paler surface and gave the dark walls a
    # membership near 0.5: their outer faces passed for the inner walls at some colour refits (measured here: 0.39 deg
    # angle RMSE before, 0.07 after; at 640x480 blue and orange dyes read 0.6-0.8 deg and 5.7 px before, 0.02-0.03 deg
    # and 0.1 px after). Greys now count as background for a dye whose range holds none
    scene = dict(SURFACE, liquid_color="orange", elevation_deg=16.0, container_tilt_deg=0.0, second_mode=0.0)
    scene.update(duration_s=3.0, seed=5)
    path = tmp_path / "high.mp4"
    truth = render_video(path, SynthSettings(**scene))
    res = track_video(path, TrackSettings(target="surface", smooth=False), multithreaded=False)
    ok, cols = res.valid.astype(bool), res.columns()
    assert ok.mean() > 0.9
    assert _rmse((res.angle_deg - truth["surface_angle_deg"])[ok]) < 0.15  # 2x the 0.07 measured; 0.39 before
    walls = np.concatenate([(cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok] for side in ("left", "right")])
    assert _rmse(walls) < 0.5  # measured 0.17 px, 0.31 before


def test_a_container_tilted_20_degrees_in_the_picture_keeps_its_walls(tmp_path):
    # its raised bottom corner reached into the rows read for the walls, whose crossings there lay on the bottom:
    # the wall's true rows were dropped and 80 % of the frames lost (measured here: valid 0.20 before, 0.98 after)
    scene = dict(SURFACE, container_tilt_deg=20.0, container_tilt_hz=0.3, duration_s=3.0, seed=8)
    path = tmp_path / "tilted.mp4"
    truth = render_video(path, SynthSettings(**scene))
    assert np.ptp(truth["container_angle_deg"]) > 35
    res = track_video(path, TrackSettings(target="surface", reference="container", smooth=False), multithreaded=False)
    ok, cols = res.valid.astype(bool), res.columns()
    assert ok.mean() > 0.9
    assert _rmse((res.angle_deg - truth["rel_angle_deg"])[ok]) < 0.2  # measured 0.077 deg
    walls = np.concatenate([(cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok] for side in ("left", "right")])
    assert _rmse(walls) < 0.6  # measured 0.18 px


def test_a_yellow_dye_on_a_pale_wall_is_measured_on_its_colour(tmp_path, monkeypatch):
    # a yellow dye's luma is close to the pale background's: with camera noise its luma-refined front edge scatters
    # (0.4-0.8 px) more than its colour edge, so the span's first frames choose the colour
    scene = dict(SURFACE, width=640, height=480, liquid_color="yellow", noise_sigma=9.0, elevation_deg=3.0)
    scene.update(specular=0.3, reflection=0.4, meniscus_px=0.9, container_tilt_deg=0.0, seed=33)
    path = tmp_path / "yellow.mp4"
    truth = render_video(path, SynthSettings(**scene))
    settings = TrackSettings(target="surface", reference="container", smooth=False)
    settled, chosen = SurfaceFinder.settled, []
    monkeypatch.setattr(SurfaceFinder, "settled", lambda self: chosen.append(settled(self)) or chosen[-1])
    res = {"auto": track_video(path, settings, multithreaded=False)}
    assert chosen[0][1] == "colour"
    monkeypatch.setattr(SurfaceFinder, "_edge_source", lambda self: "luma")
    res["luma"] = track_video(path, settings, multithreaded=False)
    errors = {}
    for key, r in res.items():
        ok, cols = r.valid.astype(bool), r.columns()
        walls = [(cols[f"{side}_wall_px"] - truth[f"{side}_wall_px"])[ok] for side in ("left", "right")]
        errors[key] = (_rmse((r.angle_deg - truth["rel_angle_deg"])[ok]), _rmse(np.concatenate(walls)))
    # measured on colour 0.090 deg and 0.37 px, on luma 0.105 deg and 0.47 px (ratios 0.85 and 0.79; before the
    # second mode's prior in the front edge's fit 0.082 / 0.41 on colour and 0.123 / 0.55 on luma: the prior steadied
    # the noisier luma edge's line more)
    assert errors["auto"][0] < 0.9 * errors["luma"][0] and errors["auto"][1] < 0.85 * errors["luma"][1]


@pytest.mark.parametrize(
    "move",
    [
        lambda f: np.roll(f, 1, axis=0),  # lowered by a pixel
        lambda f: np.roll(f, -1, axis=1),  # slid left by a pixel
        # tilted by half a degree about the picture's centre
        lambda f: cv2.warpAffine(
            f, cv2.getRotationMatrix2D((f.shape[1] / 2, f.shape[0] / 2), 0.5, 1.0), f.shape[1::-1]
        ),
    ],
)
def test_band_frames_stop_when_the_container_moves(still_surface_video, move):
    path, _ = still_surface_video
    frames = [np.asarray(p) for _, _, p in FrameReader(path, False, pictures=True)]
    finder = SurfaceFinder(PRESETS["green"].hsv, (0, 0, frames[0].shape[1], frames[0].shape[0]))
    k = 0
    while not finder._band_ready():  # the elevation is fixed after 15 frames, the axes held after two agree
        assert finder.measure(frames[k]).found
        k += 1
    assert k < 30
    # the picture as it was: the band measures it; moved by a pixel or tilted: the whole body must be measured
    assert finder._measure_band(frames[k - 1]) is not None
    assert finder._measure_band(move(frames[k - 1])) is None


def test_walls_are_held_over_still_frames_and_measured_when_they_turn(still_surface_video, monkeypatch):
    # the container reference's walls, told the container stood still, are measured in every HOLD_FRAMES-th frame
    # once two measurements agree; a turn faster than STEADY_DEG per HOLD_FRAMES - 1 frames is measured every frame,
    # a slower one is held within STEADY_DEG of what measuring every frame gives
    path, _ = still_surface_video
    still = np.asarray(next(iter(FrameReader(path, False, pictures=True)))[2])
    m = SurfaceFinder(PRESETS["green"].hsv, (0, 0, still.shape[1], still.shape[0])).measure(still)
    centre = (still.shape[1] / 2, still.shape[0] / 2)
    held, every = (ContainerTracker((0, 0, still.shape[1], still.shape[0])) for _ in range(2))
    measure, measured = held._measure, []
    monkeypatch.setattr(held, "_measure", lambda *a: measured.append(1) or measure(*a))

    def run(degrees):
        """Container angles, held and measured in every frame, as the picture turns; whether each was measured."""
        first, angles = len(measured), []
        for deg in degrees:
            frame = cv2.warpAffine(still, cv2.getRotationMatrix2D(centre, deg, 1.0), still.shape[1::-1])
            pose = (m.x_px, m.y_px, 0.8 * m.width_px)
            angles.append((held.measure(frame, *pose, still=True).angle_deg, every.measure(frame, *pose).angle_deg))
        return np.array(angles), measured[first:]

    level, n = run(np.zeros(18))
    assert len(n) == 2 + 16 // HOLD_FRAMES and np.ptp(level) == 0  # two that agree, then every HOLD_FRAMES-th
    fast, n = run(0.03 * np.arange(1, 19))  # 0.15 deg per five frames (measured as 0.07 per three)
    assert len(n) >= 18 - (HOLD_FRAMES - 1)  # the hold may run out over the first frames: from then on, every frame
    assert np.abs(fast[HOLD_FRAMES:, 0] - fast[HOLD_FRAMES:, 1]).max() < 0.005  # measured: equal
    slow, n = run(0.36 + 0.002 * np.arange(1, 25))  # 0.01 deg per five frames
    assert len(n) < 24 - 8
    assert np.abs(slow[:, 0] - slow[:, 1]).max() < STEADY_DEG  # measured 0.011, 6 of 24 measured


def _counted(frames: list[int], step):
    """A tracker step's call that first notes its frame's number in `frames`."""

    def call(self, *args):
        frames.append(len(frames))
        return step(self, *args)

    return call


def _held_and_every(path: Path, settings: TrackSettings, want: np.ndarray, monkeypatch):
    """Track with the walls held where they may be, checking that the held frames got the container angle interpolated
    between the measured ones; then measuring the walls in every frame. Returns the first track, the share of frames
    held, the largest angle difference between the two tracks and each one's angle RMSE against `want`."""
    calls, frames, measure = [], [], ContainerTracker.measure
    for kind in (SurfaceStep, tracker._FloatStep):  # the frames in order (one span), for the calls' frame numbers
        monkeypatch.setattr(kind, "__call__", _counted(frames, kind.__call__))

    def recorded(self, *args, **kwargs):
        calls.append((frames[-1], measure(self, *args, **kwargs)))
        return calls[-1][1]

    monkeypatch.setattr(ContainerTracker, "measure", recorded)
    res = track_video(path, settings, multithreaded=False)
    # the target was found in every frame: the walls were measured (or held) in each one whose picture changed, and
    # the others (repeats) took the row of the frame they copied
    index = np.array([i for i, _ in calls])
    copies = np.setdiff1d(np.arange(len(res.t_s)), index)
    assert np.all(res.container_angle_deg[copies] == res.container_angle_deg[copies - 1])
    held = np.array([c.held for _, c in calls])
    at = index[~held]
    measured = np.array([c.angle_deg for _, c in calls if not c.held])
    np.testing.assert_allclose(res.container_angle_deg[at], measured, atol=1e-12)
    np.testing.assert_allclose(res.container_angle_deg[index[held]], np.interp(index[held], at, measured), atol=1e-12)
    monkeypatch.setattr(container_ref, "HOLD_FRAMES", 1)
    every = track_video(path, settings, multithreaded=False)
    ok = res.valid.astype(bool) & every.valid.astype(bool)
    err = [_rmse((r.angle_deg - want)[ok]) for r in (res, every)]
    return res, held.mean(), np.abs(res.angle_deg - every.angle_deg)[ok].max(), err


def test_held_walls_are_interpolated_between_their_measurements(still_surface_video, monkeypatch):
    # a still container's band frames hold its walls (measured in every HOLD_FRAMES-th): those frames get the container
    # angle interpolated between the measurements around them, and track as if every frame had been measured
    path, truth = still_surface_video
    # the dye named: with none, choosing it measures the first frame once more, which `_held_and_every` would count
    settings = TrackSettings(target="surface", reference="container", liquid_color="green", smooth=False)
    # walls this still are read as their median (STEADY_FLOOR_DEG); the interpolation itself is checked here, as it
    # serves a container whose walls move a little more
    monkeypatch.setattr(surface_track, "STEADY_FLOOR_DEG", 0.0)
    _, held, most, err = _held_and_every(path, settings, truth["surface_angle_deg"], monkeypatch)
    assert 0.5 < held <= (HOLD_FRAMES - 1) / HOLD_FRAMES  # measured 0.81
    assert most < STEADY_DEG  # measured 0.018 (0.009 holding 3 frames of 4)
    assert err[0] < 1.05 * err[1]  # measured 0.0861 and 0.0857 deg


# Measured container angles (frame, deg, walls' ends unmoved since the measurement before) around holds: 0 -> 4 a
# slow tilt (the ends stayed within GUARD_PX), 4 -> 8 a turn the ends saw at the hold's end, then the walls were lost
# at 12 and found again only at 49 after a turn
MEASURED = [(0, 0.0, False), (4, 0.012, True), (8, 0.512, False), (49, 2.0, True)]
HELD = [1, 2, 3, 5, 6, 7, 9, 10, 11]
HELD_ANGLES = [0.003, 0.006, 0.009, 0.012, 0.012, 0.012, 0.512, 0.512, 0.512]
"""Linear across the slow tilt's hold; the held angle where the turn came after the held frames or the walls were
lost."""


def test_held_angles_interpolate_only_holds_whose_walls_ends_stayed_put():
    np.testing.assert_allclose(held_angles(MEASURED, HELD), HELD_ANGLES, atol=1e-12)
    with pytest.raises(ValueError, match="before the walls' first measurement"):
        held_angles(MEASURED[1:], [1])
    # frames that copied a measured picture do not lengthen a hold (nobody asked for the walls there): a hold of five
    # frames and four copies is interpolated, ten frames held are not (the walls were lost, or not looked for)
    slow = [(0, 0.0, False), (10, 0.02, True)]
    np.testing.assert_allclose(held_angles(slow, [1, 2, 3, 4, 5], [6, 7, 8, 9]), 0.002 * np.arange(1, 6), atol=1e-12)
    np.testing.assert_allclose(held_angles(slow, [1, 2, 3, 4, 5]), 0.0, atol=1e-12)


def test_held_walls_give_both_targets_rows_their_interpolated_angles():
    # the surface's rows are turned onto the interpolated container angle, the float's angle is taken against it
    surface = SurfaceStep(TrackSettings(target="surface", reference="container"), (0, 0, 640, 480))
    m = SurfaceMeasurement(True, True, 0.0, 0.0, 10.0, 10.0, 100.0, 0.0, 320.0, 240.0, 1.0)
    surface.walls_record = WallsRecord(list(MEASURED), list(HELD))
    surface.held_surfaces = {i: replace(m) for i in HELD}
    rows = [surface._row(replace(m), ContainerMeasurement(True, 0.0))._replace(t_s=i / 30) for i in range(50)]
    surface.revise(rows)
    np.testing.assert_allclose([rows[i].container_angle_deg for i in HELD], HELD_ANGLES, atol=1e-12)
    floats = tracker._FloatStep(TrackSettings(reference="container"), (0, 0, 640, 480))
    floats.walls_record = WallsRecord(list(MEASURED), list(HELD))
    rows = [TrackRow(0, i / 30, 5.0, 5.0, 0.0, 320.0, 240.0, 1.0, 1) for i in range(50)]
    floats.revise(rows)
    np.testing.assert_allclose([rows[i].container_angle_deg for i in HELD], HELD_ANGLES, atol=1e-12)
    np.testing.assert_allclose([rows[i].angle_deg for i in HELD], 5.0 - np.array(HELD_ANGLES), atol=1e-12)
    assert [r.angle_deg for r in rows[12:]] == [5.0] * 38  # measured rows are left as they were


@pytest.fixture(scope="module")
def still_float_video(tmp_path_factory):
    """A 3 s H.264 tap test of a float in a container that stands still (camera rolled 1 deg), and its truth."""
    path = tmp_path_factory.mktemp("still_float") / "still.mp4"
    truth = render_video(path, SynthSettings(**{**SMALL, "duration_s": 3.0}, camera_roll_deg=1.0, amplitude_deg=6.0))
    return path, truth


def test_float_walls_are_held_until_their_ends_move(still_float_video):
    # with the float, nothing else says the container stands still: the walls' own ends do. On a still picture
    # (fresh noise in every frame) the walls are measured in every HOLD_FRAMES-th; a jolt of 0.4 px, a turn of 0.3 deg
    # about the picture's centre (0.4 px at the walls' lower ends) or a jolt of 7 px with a turn of 1 deg (which one
    # Lucas-Kanade step reads as a small shift) is measured in the frame it happens, and the frames held before it
    # keep the angle measured before them instead of a share of the turn
    path, _ = still_float_video
    still = np.asarray(next(iter(FrameReader(path, False, pictures=True)))[2])
    h, w = still.shape[:2]
    fm = FloatFinder(TrackSettings().hsv, (0, 0, w, h)).measure(still)
    walls, rng = ContainerTracker((0, 0, w, h)), np.random.default_rng(5)

    def seen(matrix=None):
        """The picture (moved by `matrix`) with fresh noise, as the float tracker hands it to the walls."""
        frame = still if matrix is None else cv2.warpAffine(still, matrix, (w, h), flags=cv2.INTER_LINEAR)
        noisy = frame.astype(np.float32) + rng.normal(0, 2.0, frame.shape)
        return np.clip(noisy, 0, 255).astype(np.uint8)

    measured: list[tuple[int, float]] = []
    held_frames: list[int] = []

    def run(frames):
        """Whether each frame's walls were held."""
        held = []
        for f in frames:
            m = walls.measure(f, fm.x_px, fm.y_px, fm.length_px, still=True)
            frame = len(measured) + len(held_frames)
            if m.held:
                held_frames.append(frame)
            else:
                measured.append((frame, m.angle_deg, m.unmoved))
            held.append(m.held)
        return held

    held = run([seen() for _ in range(18)])
    assert held.count(False) == 2 + 16 // HOLD_FRAMES  # two that agree, then every HOLD_FRAMES-th of the other 16
    jolt = np.float32([[1, 0, 0.4], [0, 1, 0]])
    turn = cv2.getRotationMatrix2D((w / 2, h / 2), 0.3, 1.0) @ np.vstack([jolt, [0, 0, 1]])
    big = cv2.getRotationMatrix2D((w / 2, h / 2), 1.3, 1.0) @ np.vstack(
        [np.float32([[1, 0, 7.4], [0, 1, 0]]), [0, 0, 1]]
    )
    for before, moved in ((None, jolt), (jolt, turn), (turn, big)):
        held = run([seen(before) for _ in range(2 * HOLD_FRAMES)])  # steady: held again
        assert held[-HOLD_FRAMES:].count(True) == HOLD_FRAMES - 1
        if held[-1]:  # the next frame would be held: the move comes then
            assert run([seen(moved)]) == [False]
        else:
            assert run([seen(before), seen(moved)]) == [True, False]
        at, angle, _ = measured[-2]  # the measurement before the move, and the frames held after it
        since = [i for i in held_frames if i > at]
        np.testing.assert_allclose(held_angles(measured, since), angle, atol=0.01)  # measured 0.003 deg
    # a hold that ends with the walls found anew (following them failed): not interpolated, whatever the ends say
    run([seen(big) for _ in range(2 * HOLD_FRAMES)])
    walls._held = HOLD_FRAMES - 1  # the next frame ends the hold
    follow = walls._follow
    walls._follow = lambda *a: walls.__dict__.pop("_follow") and ContainerMeasurement(False)  # fails once
    ends = walls.measure(seen(big), fm.x_px, fm.y_px, fm.length_px, still=True)
    assert ends.found and not ends.unmoved and walls._follow == follow


def test_float_track_holds_a_still_containers_walls(still_float_video, monkeypatch, tmp_path):
    # tracked with --reference container, a still container's walls are measured in about every HOLD_FRAMES-th; the
    # held frames get the container angle interpolated between the measurements around them (and the float's angle
    # against it) and track as if every frame had been measured. Drawing an overlay (every picture converted whole)
    # gives the same table: the walls' ends are compared on the decoded luma either way
    path, truth = still_float_video
    settings = TrackSettings(reference="container", smooth=False)
    drawn = track_video(path, settings, overlay=tmp_path / "o.mp4")
    res, held, most, err = _held_and_every(path, settings, truth["rel_angle_deg"], monkeypatch)
    for name, column in res.columns().items():
        np.testing.assert_array_equal(drawn.columns()[name], column, err_msg=name)
    np.testing.assert_allclose(res.angle_deg, res.float_angle_deg - res.container_angle_deg, atol=1e-12)
    assert 0.5 < held <= (HOLD_FRAMES - 1) / HOLD_FRAMES  # measured 0.82
    assert most < STEADY_DEG  # measured 0.011
    assert err[0] < 1.05 * err[1]  # measured 0.0920 and 0.0917 deg


@pytest.mark.parametrize("contrast_rows", [slice(0, 0), slice(0, None), slice(0, 75)])
def test_a_wall_is_placed_on_luma_in_every_row_or_in_none(contrast_rows):
    # a liquid body whose colour puts its left side at x = 20.4 in every row, while the luma edge lies at x = 21.5 in
    # the rows that have the contrast: a wall through both (here the upper half of the rows the walls are fitted on,
    # 50-99, on luma) would lean by degrees; it stands straight, on the colour or, when every row has the contrast,
    # on the luma
    x = np.arange(100, dtype=np.float32)
    body = np.zeros((130, 100), np.float32)
    body[10:111] = np.clip(0.5 + 0.5 * np.minimum(x - 20.4, 80.4 - x), 0, 1)
    gray = np.full((130, 100), 80, np.uint8)
    gray[contrast_rows] = np.where(x < 22, 60, 100)[None, :]
    geom = _container_axes(body, body >= 0.5, gray, cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR), (0, 0), (20, 10, 81, 111))
    (a_left, b_left), _ = geom[0]
    assert a_left == pytest.approx(0.0, abs=1e-9)
    assert b_left == pytest.approx(21.5 if contrast_rows.stop is None else 20.4, abs=1e-6)


def test_a_frame_whose_angle_jumps_away_and_back_is_a_spike_and_a_fast_slosh_is_not():
    # a 3 Hz decay of 8 deg at 30 fps (the most curved a slosh gets in a tracked clip: 0.63 rad a frame) with 0.05 deg
    # of noise: no frame is a spike; two frames read 3 and 5 deg off (a fit that strayed to the back edge) are, and
    # only they, not their neighbours (whose cubics they move by two thirds of their error)
    rng = np.random.default_rng(7)
    t = np.arange(120) / 30.0
    angle = 8 * np.exp(-0.3 * t) * np.cos(2 * np.pi * 3 * t) + rng.normal(0, 0.05, t.size)
    valid = np.ones(t.size, bool)
    assert not _spikes(angle, valid).any()
    angle[[40, 77]] += [3.0, -5.0]
    assert np.flatnonzero(_spikes(angle, valid)).tolist() == [40, 77]
    # beside an invalid frame (too low a quality: the cola clip's doublet) it is judged against the valid frames
    # beyond it; with three invalid frames on one side (a gap past SPIKE_REACH) it is not judged
    valid[76] = False
    assert np.flatnonzero(_spikes(angle, valid)).tolist() == [40, 77]
    valid[74:76] = False
    assert np.flatnonzero(_spikes(angle, valid)).tolist() == [40]
    # a tap starts the swing at once (a kink: at rest, then 2.4 deg a frame): not a spike
    tap = np.where(t < 1, 0.0, 8 * np.sin(2 * np.pi * 3 * (t - 1)) * np.exp(-0.3 * (t - 1)))
    assert not _spikes(tap + rng.normal(0, 0.05, t.size), np.ones(t.size, bool)).any()


def test_a_beakers_graduation_marks_are_not_its_bottom():
    # marks two rows high across the left third of the liquid below mid-height (a beaker's scale, white through a
    # dark cola): taken for the bottom there, the bottom read as tilted by tens of degrees and the raised "corner"
    # dropped the left wall's rows (every other frame of a path-traced beaker lost); the bottom stays at row 110
    x = np.arange(100, dtype=np.float32)
    body = np.zeros((130, 100), np.float32)
    body[10:111] = np.clip(0.5 + 0.5 * np.minimum(x - 20.4, 80.4 - x), 0, 1)
    for row in (64, 74, 84, 94):
        body[row : row + 2, 21:45] = 0.0
    gray = np.full((130, 100), 80, np.uint8)
    geom = _container_axes(body, body >= 0.5, gray, cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR), (0, 0), (20, 10, 81, 111))
    assert geom is not None
    ((a_left, b_left), (a_right, b_right)), origin, _, _ = geom
    assert a_left == pytest.approx(0.0, abs=1e-9) and a_right == pytest.approx(0.0, abs=1e-9)
    assert (b_left, b_right) == (pytest.approx(20.4, abs=1e-4), pytest.approx(80.4, abs=1e-4))  # float32 map
    assert origin[1] == pytest.approx(110.5, abs=0.5)  # the last liquid row is 110


def test_a_label_of_the_liquids_colour_on_the_glass_is_not_a_wall():
    # a band of the dye's colour round the glass, 5 px outside the liquid's sides in rows 45-84 (its edges straighter
    # than the liquid's speckled ones, as a path tracer draws them): its edge had been taken for the wall and the
    # liquid's rows above it dropped as a slosh's run, or no wall found at all; the walls stay the liquid's sides
    rng = np.random.default_rng(4)
    x = np.arange(100, dtype=np.float32)
    body = np.zeros((130, 100), np.float32)
    sides = np.array([20.4, 80.4]) + rng.normal(0, 0.6, (101, 2))
    body[10:111] = np.clip(0.5 + 0.5 * np.minimum(x - sides[:, :1], sides[:, 1:] - x), 0, 1)
    body[45:85] = np.clip(0.5 + 0.5 * np.minimum(x - 15.4, 85.4 - x), 0, 1)
    gray = np.full((130, 100), 80, np.uint8)
    geom = _container_axes(body, body >= 0.5, gray, cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR), (0, 0), (15, 10, 86, 111))
    assert geom is not None
    ((a_left, b_left), (a_right, b_right)), _, _, _ = geom
    # the sides' scatter of 0.6 px over about 60 rows moves a fitted wall by about 0.1 px and 0.005 in slope
    assert abs(a_left) < 0.02 and abs(a_right) < 0.02
    assert abs(b_left - 20.4) < 0.5 and abs(b_right - 80.4) < 0.5


@pytest.mark.parametrize(("first", "label"), [(20, False), (50, True)])
def test_a_band_at_the_liquids_top_is_its_own_not_a_label(first, label):
    # a liquid 200 px wide (half width 100) whose top is row 0, its sides read from row 10, with a band 6 px outside
    # them in 30 rows from `first`: a band that begins within the surface ellipse's reach below the top (a camera at
    # most MAX_ELEVATION_SIN = 0.3 above it: 30 rows) has the ellipse's back above it, not the liquid's side, and is
    # the liquid's own top band (a juice seen wider through a thick glass near its surface); one that begins deeper,
    # with the liquid's side above it, is a label in front of it
    rows = np.arange(10, 110, dtype=float)
    x = np.vstack([np.full(rows.size, 20.0), np.full(rows.size, 220.0)])
    band = (rows >= first) & (rows < first + 30)
    x[0, band], x[1, band] = 14.0, 226.0
    front = _in_front(rows, x, np.ones_like(x, bool), 0)
    assert front[:, band].all() == label and not front[:, ~band].any()


def test_walls_are_the_glass_edges_where_the_liquids_sides_are_not_straight():
    # a liquid whose sides zig-zag by +-10 px (a print on the glass, a holder of its colour round it): no straight side,
    # and the frame had been refused ("the liquid was found ... but not the container's inner walls"); the walls are
    # then the glass's own straight edges, dark lines over columns 16-17 and 85-86 on a pale picture
    x = np.arange(104, dtype=np.float32)
    rows = np.arange(101, dtype=np.float32)[:, None]
    wander = 10 - np.abs(rows % 40 - 20)
    body = np.zeros((130, 104), np.float32)
    body[10:111] = np.clip(0.5 + 0.5 * np.minimum(x - 22 - wander, 80 + wander - x), 0, 1)
    gray = np.full((130, 104), 200, np.uint8)
    gray[:, 16:18] = gray[:, 85:87] = 60
    geom = _container_axes(body, body >= 0.5, gray, cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR), (0, 0), (18, 10, 85, 111))
    assert geom is not None
    ((a_left, b_left), (a_right, b_right)), _, _, _ = geom
    # a wall is the mean of its two faces (the dark line's edges at 15.5 and 17.5, 84.5 and 86.5), placed by line sums
    # on a slope grid of 0.005 (measured: slopes +-0.005, at 16.2 and 85.8)
    assert abs(a_left) <= 0.0051 and abs(a_right) <= 0.0051
    assert abs(b_left - 16.5) < 0.5 and abs(b_right - 85.5) < 0.5


def _liquid_in_glass(liquid: list, walls: list) -> tuple:
    """`_container_axes` of a red liquid (polygon `liquid`) in a glass drawn as two grey lines (x at rows 100 and 404
    each) on a pale picture: the walls' slopes."""
    picture = np.full((480, 640, 3), 228, np.uint8)
    for x0, x1 in walls:
        for y in range(100, 405):
            x = round(x0 + (x1 - x0) * (y - 100) / 304)
            picture[y, x - 2 : x + 3] = 150
    cv2.fillPoly(picture, [np.array(liquid, np.int32)], (40, 40, 200))
    body = (cv2.inRange(picture, (30, 30, 190), (50, 50, 210)) > 0).astype(np.float32)
    ys, xs = np.nonzero(body)
    box = (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
    geom = _container_axes(body, body >= 0.5, cv2.cvtColor(picture, cv2.COLOR_BGR2GRAY), picture, (0, 0), box)
    assert geom is not None
    return geom[0][0][0], geom[0][1][0]


def test_a_liquid_side_that_leans_away_from_the_other_is_not_a_wall_where_the_glass_says_so():
    # a liquid whose right side runs along a shading edge across it (34 deg from its upright left side: a Blender-
    # rendered juice's, which turned the container by 14 deg), in a glass tapered by 1.5 deg a side (slopes +-0.026):
    # two walls leaning apart by more than WALL_SPREAD_DEG are checked against the glass's edges, which spread by far
    # less, so the walls are the glass's (the sides' own slopes had been taken: 0.011 and -0.771)
    left, right = _liquid_in_glass([[205, 220], [435, 220], [300, 395], [208, 395]], [(200, 208), (440, 432)])
    # placed by line sums on a slope grid of 0.005 (measured 0.030 and -0.025)
    assert left == pytest.approx(0.026, abs=0.006) and right == pytest.approx(-0.026, abs=0.006)
    # a vessel tapered by 16 deg a side (spread 32) keeps its liquid's sides (slopes +-0.29): the glass's edges about
    # them (slopes +-0.33, its outer faces') spread by as much
    left, right = _liquid_in_glass([[150, 220], [490, 220], [439, 395], [201, 395]], [(100, 200), (540, 440)])
    assert left == pytest.approx(0.29, abs=0.015) and right == pytest.approx(-0.29, abs=0.015)


def test_surface_overlay_draws_the_line_and_wall_points(surface_video, tmp_path):
    path, truth = surface_video
    track_video(path, TrackSettings(target="surface"), overlay=tmp_path / "o.mp4")
    frames = list(FrameReader(tmp_path / "o.mp4"))
    assert len(frames) == len(truth)
    _, _, img = frames[5]  # at rest: the surface line is green across the middle of the liquid
    x, y = int(truth["surface_x_px"][5]), int(truth["surface_y_px"][5])
    patch = img[y - 3 : y + 4, x - 3 : x + 4].reshape(-1, 3).astype(int)
    assert np.any((patch[:, 1] > 170) & (patch[:, 2] < 120) & (patch[:, 0] < 120))


def test_realistic_float_keeps_its_angle(tmp_path):
    # a rounded, slightly curved float with a specular spot, 40 % under the tinted liquid, motion blur over half
    # the frame interval: every artefact keeps the float symmetric, so the moments still give its axis
    s = SynthSettings(
        **{**SMALL, "duration_s": 1.5},
        tap_s=0.3,
        float_rounded=True,
        float_bend_px=2.0,
        float_specular=0.6,
        float_submerged=0.4,
        motion_blur=0.5,
    )
    truth = render_video(tmp_path / "f.mp4", s)
    res = track_video(tmp_path / "f.mp4")
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.5
    # measured 0.14 deg (the spot, fixed to the light, is a hole the float turns under); target 0.2 at 640x480
    assert _rmse((res.angle_deg - truth["float_angle_deg"])[ok]) < 0.25


def test_pipeline_track_table_takes_the_target():
    # [track] target = "surface" in a pipeline or batch config reaches the tracker; a typo is one sentence
    from sloshid.core.errors import UserError
    from sloshid.workflow.options import TrackOptions

    assert TrackOptions(target="surface").track_settings().target == "surface"
    assert TrackOptions().track_settings().target == "float"
    with pytest.raises(UserError, match="target must be 'float' or 'surface'"):
        TrackOptions(target="liquid")


def _tracked_and_truth(tmp_path, synth: SynthSettings, settings: TrackSettings):
    """The issue-12 measure of a float clip: (its tracked signal, the identification of its truth trace)."""
    truth = render_video(tmp_path / "c.mp4", synth)
    tracked = signal_from_track(track_video(tmp_path / "c.mp4", settings))
    return tracked, Identifier().fit(make_signal(truth["t_s"], truth["float_angle_deg"], "angle_deg", "deg", "truth"))


@pytest.mark.slow
def test_tracked_clip_keeps_the_dynamics(tmp_path):
    # the issue-12 measure of a tracker: identify the tracked trace and the truth trace of the same video. A 640x480
    # 60 fps H.264 CRF 18 tap test (the track_accuracy benchmark's clip 04, its drawn settings): H.264 keeps the float's edges
    # where they were until they have moved further than it codes, so the tracked angle lags by a nearly constant
    # amount that grows against the decaying swing, and a plain fit comes out f about 0.2 % low, zeta 3.5 % high
    s = SynthSettings(
        width=640,
        height=480,
        fps=60.0,
        duration_s=5.0,
        tap_s=0.5,
        f_hz=3.092799020231121,
        zeta=0.04744746060710295,
        amplitude_deg=6.855964496598662,
        camera_roll_deg=0.5459483244632999,
        noise_sigma=3.872645053371003,
        blur_px=0.7103336248966194,
        quality=18,
        float_color="green",
        float_length_frac=0.1894750427990906,
        seed=1004,
    )
    tracked, exact = _tracked_and_truth(tmp_path, s, TrackSettings(float_color="green"))
    want = exact.result.parameters
    plain = Identifier().fit(replace(tracked, tracked="")).result.parameters
    assert plain["f_hz"].value < want["f_hz"].value * (1 - 0.001)  # the bias the correction is for (measured -0.20 %)
    result = Identifier().fit(tracked).result
    got = result.parameters
    # what the hold does not model is said for the tracked trace, and only for it
    codec = [n for n in result.notes if "shrinks the smallest swings" in n]
    assert len(codec) == 1 and not any("shrinks the smallest swings" in n for n in exact.result.notes)
    # the issue's targets: f within 0.1 % and zeta within 3 % of the truth trace's (measured -0.08 % and +1.9 %),
    # and the 95 % intervals cover the truth trace's values
    assert got["f_hz"].value == pytest.approx(want["f_hz"].value, rel=0.001)
    assert got["zeta"].value == pytest.approx(want["zeta"].value, rel=0.03)
    for key in ("f_hz", "zeta"):
        assert got[key].ci95[0] <= want[key].value <= got[key].ci95[1]


CODEC_FLOATS = {
    # issue 37's outside check: zeta from H.264 floats at 60-120 fps came out 6-10 % high. The realistic float at
    # the synth's default CRF 23 (60 fps, Table I liquid, 8 deg): P-frames take 0.1-0.3 deg off every swing, and zeta
    # reads +13.3 % high, outside the held fit's interval (+8.3 .. +18.3 %, measured); the codec-shrink allowance
    # widens it to -4.2 .. +30.8 % (docs/design/zeta_from_video.md). f keeps the issue's 0.3 % (measured -0.02 %)
    "consumer_bit_rate": SynthSettings(
        width=640,
        height=480,
        fps=60.0,
        duration_s=5.0,
        f_hz=3.44,
        zeta=0.07,
        amplitude_deg=8.0,
        noise_sigma=4.0,
        blur_px=1.0,
        quality=23,
        float_rounded=True,
        float_bend_px=3.0,
        float_specular=0.5,
        float_submerged=0.3,
        seed=11,
    ),
    # benchmarks/track_pbr.py's painted float decay (30 fps, 5 deg, zeta 0.07, H.264 CRF 20, seed 37): the decoded
    # pictures lose the small swings (gain 1.00 above 2 deg, 0.86 below 1 deg; lossless: zeta +0.3 %), and zeta reads
    # 11 % high. Its interval with 1 % of zeta for the codec ended 0.4 % above the truth (measured); a float's 2.5 %
    # holds it (-0.8 .. +22.7 %, measured). f is kept (measured +0.06 %; 0.3 % is the issue's target)
    "painted_benchmark": SynthSettings(
        noise_sigma=4.0,
        blur_px=0.8,
        quality=20.0,
        duration_s=4.0,
        tap_s=0.4,
        amplitude_deg=5.0,
        float_rounded=True,
        seed=37,
    ),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CODEC_FLOATS))
def test_codec_float_zeta_interval_covers_the_truth(tmp_path, case):
    tracked, exact = _tracked_and_truth(tmp_path, CODEC_FLOATS[case], TrackSettings(smooth=False))
    want = exact.result.parameters
    got = Identifier().fit(tracked).result.parameters
    assert got["zeta"].value > want["zeta"].value * 1.05  # the codec's bias, which stays in the value
    assert got["zeta"].ci95[0] <= want["zeta"].value <= got["zeta"].ci95[1]
    assert got["f_hz"].value == pytest.approx(want["f_hz"].value, rel=0.003)


def test_a_losslessly_coded_float_keeps_the_dynamics_without_any_correction(tmp_path):
    # the tracker's own share of the dynamics error: the track_accuracy benchmark's calibration clip 10 (a plain green
    # bar, noise 6; zeta +3.1 % at H.264 CRF 18, whose decoded picture shrinks the late small swings), shortened and at
    # 640x480, coded losslessly (CRF 0). Nothing then holds the float's edges: the fitted hold is nil, and the plain
    # fit is within a tenth of the issue's targets (measured: f -0.001 %, zeta -0.01 %; the benchmark's 800x600 clip
    # +0.002 % and +0.09 %), so a tracker that distorted the swing itself fails here, not in the codec's allowance:
    # this clip at CRF 18 gives f -0.038 % and zeta +2.1 %, which fail these bounds
    s = SynthSettings(
        width=640,
        height=480,
        fps=60.0,
        duration_s=4.0,
        tap_s=0.5,
        f_hz=3.0008254584595537,
        zeta=0.04055497877648151,
        amplitude_deg=8.112895703064549,
        camera_roll_deg=-1.2526902864741554,
        noise_sigma=5.856794974778641,
        blur_px=1.2690863118593017,
        quality=0,
        float_color="green",
        float_length_frac=0.18010964533136292,
        seed=1010,
    )
    tracked, exact = _tracked_and_truth(tmp_path, s, TrackSettings(float_color="green", smooth=False))
    want = exact.result.parameters
    fitted = Identifier().fit(tracked).result
    assert fitted.fit.hold is not None and fitted.fit.hold.width < 0.005  # deg: no hold where the codec holds nothing
    plain = Identifier().fit(replace(tracked, tracked="")).result.parameters
    assert plain["f_hz"].value == pytest.approx(want["f_hz"].value, rel=1e-4)
    assert plain["zeta"].value == pytest.approx(want["zeta"].value, rel=0.003)


def test_spans_give_one_table_in_every_mode_and_lose_no_frame(tmp_path, monkeypatch):
    # a long video is tracked in spans from key frames; here MPEG-4 puts one every 0.4 s and the spans are 1 s
    # instead of 10 s. Side by side in processes, one after the other on one core, and while drawing an overlay, the
    # table is the same; against one span over the whole video no frame is lost or doubled, and the angles differ
    # only by the few frames in which each span's tracker settles
    path = tmp_path / "s.mp4"
    truth = render_video(path, SynthSettings(**{**SURFACE, "codec": "mpeg4", "quality": 3}))
    monkeypatch.setattr(tracker, "SPAN_S", 1.0)
    reader = FrameReader(path)
    spans = tracker._spans(reader.info, key_frame_times(path))
    reader.close()
    assert len(spans) >= 3 and spans[0][0] is None and spans[-1][1] is None
    settings = TrackSettings(target="surface", reference="container", container_diameter_m=0.1)
    parallel = track_video(path, settings)
    for other in (
        track_video(path, settings, multithreaded=False),
        track_video(path, settings, overlay=tmp_path / "o.mp4"),
    ):
        for name, column in parallel.columns().items():
            np.testing.assert_array_equal(other.columns()[name], column, err_msg=name)
    monkeypatch.setattr(tracker, "SPAN_S", 1e9)
    whole = track_video(path, settings)
    np.testing.assert_array_equal(whole.t_s, parallel.t_s)
    np.testing.assert_array_equal(whole.frame, parallel.frame)
    ok = parallel.valid.astype(bool) & whole.valid.astype(bool)
    assert ok.mean() > 0.7
    # measured: 0.007 deg and 0.10 px between the two; both 0.072 deg and 0.44 px from the truth
    assert _rmse((parallel.angle_deg - whole.angle_deg)[ok]) < 0.03
    assert _rmse((parallel.angle_deg - truth["rel_angle_deg"])[ok]) < 0.3
    left = parallel.columns()["left_wall_px"] - whole.columns()["left_wall_px"]
    assert _rmse(left[ok]) < 0.3


def test_spans_start_at_key_frames_far_enough_apart():
    # 120 s at 30 fps with a key frame every 4 s: spans from the first key frame at least SPAN_S (10 s) after the last
    # start, none starting within 10 s of the end; a video whose frames carry no timestamps is one span
    info = VideoInfo(Path("v.mp4"), 640, 480, 30.0, 3600)
    keys = np.arange(0.0, 120.0, 4.0)
    assert tracker._spans(info, keys) == [
        (None, 12.0),
        (12.0, 24.0),
        (24.0, 36.0),
        (36.0, 48.0),
        (48.0, 60.0),
        (60.0, 72.0),
        (72.0, 84.0),
        (84.0, 96.0),
        (96.0, 108.0),
        (108.0, None),
    ]
    assert tracker._spans(info, np.array([0.0])) == [(None, None)]
    assert tracker._spans(replace(info, timed=False), keys) == [(None, None)]
    assert tracker._spans(replace(info, frame_count=500), keys) == [(None, None)]  # 16.7 s: too short for two


@pytest.mark.parametrize(
    "look",
    [
        {},
        {"float_length_frac": 0.05, "width": 640, "height": 480},
        {"float_rounded": True, "float_bend_px": 6.0, "float_submerged": 0.5, "float_specular": 0.5},
        {"float_color": "green", "camera_roll_deg": 5.0, "container_tilt_deg": 3.0, "motion_blur": 0.5},
        {"scene": "surface", "liquid_color": "blue"},
        {"scene": "surface", "liquid_color": "red", "elevation_deg": 4.0, "meniscus_px": 1.0, "specular": 0.3},
        {"scene": "surface", "liquid_color": "green", "width": 640, "height": 480, "container_tilt_deg": 3.0},
    ],
)
def test_dyed_liquid_is_told_from_a_float(look):
    # a dyed liquid tracked as a float "succeeds" with the body's principal axis as its angle: the surface tracker
    # finds the liquid's straight walls, bottom and surface in it, and never in a float of any look (mid-swing)
    base = SMALL_SURFACE if look.get("scene") == "surface" else SMALL
    s = SynthSettings(**{**base, "duration_s": 1.0, "tap_s": 0.2, **look})
    colour = s.liquid_color if s.scene == "surface" else s.float_color
    hsv = TrackSettings(float_color=colour).hsv
    frames = [frame for k, (_, frame) in enumerate(render_frames(s)) if k in (0, 12)]
    widths = [tracker._liquid_width(f, hsv, (0, 0, s.width, s.height)) for f in frames]
    if s.scene == "float":
        assert widths == [0.0, 0.0]
    else:  # the rendered container's inner width is 0.375 of the frame's (120 px at 320x240)
        assert all(0.36 * s.width < w < 0.39 * s.width for w in widths), widths


def test_a_tinted_liquid_under_a_float_tracked_as_the_float_is_told():
    # a float scene whose pale-blue liquid a user's "float" range (hue 95-125) covers: the liquid's body was tracked as
    # the float, valid in every frame, without the warning, because the real float breaking its surface left the
    # surface fit too ragged (2.7 px) for the quality the check asked for; the walls and bottom are found all the same
    s = SynthSettings(duration_s=0.5, tap_s=0.2, seed=3)  # 640x480: the surface fit's quality was 0 in both frames
    hsv = TrackSettings(float_hsv_low=(95, 40, 60), float_hsv_high=(125, 255, 255)).hsv
    frames = [frame for k, (_, frame) in enumerate(render_frames(s)) if k in (0, 12)]
    widths = [tracker._liquid_width(f, hsv, (0, 0, s.width, s.height)) for f in frames]
    # the container's inner width is 0.375 of the frame's; this wide range's edge sits a pixel or two outside it
    assert all(0.36 * s.width < w < 0.41 * s.width for w in widths), widths


def test_a_dyed_liquid_tracked_as_a_float_is_warned_of(surface_video, tmp_path, run_cli):
    out = tmp_path / "a.csv"
    code, _, err = run_cli("track", surface_video[0], "-o", out, "--float-color", "green")
    assert code == 0 and out.exists(), err
    assert "looks like dyed liquid in its container" in err and "use --target surface" in err


def test_a_written_track_csv_identifies_like_the_result_it_was_written_from(tmp_path):
    # `track` + `identify` and `batch` (which identifies the TrackResult) gave different intervals and a different
    # encoder hold (0.026 vs 0.140 deg) on a 3 s clip: t_s written with 9 digits moved a window end by one sample;
    # timestamps now round-trip exactly
    path = tmp_path / "v.mp4"
    render_video(path, SynthSettings(width=320, height=240, fps=60, duration_s=3.0, f_hz=2.2, zeta=0.02, seed=1))
    res = track_video(path, TrackSettings())
    res.to_csv(tmp_path / "v.csv")
    assert np.array_equal(load_signal(tmp_path / "v.csv").t_s, signal_from_track(res).t_s)
    mem, csv = (Identifier().fit([s]).result for s in (signal_from_track(res), load_signal(tmp_path / "v.csv")))
    for key in ("f_hz", "zeta"):
        assert csv.parameters[key].value == pytest.approx(mem.parameters[key].value, rel=1e-5)
        assert csv.parameters[key].ci95 == pytest.approx(mem.parameters[key].ci95, rel=1e-4)
    assert csv.fit.hold.width == pytest.approx(mem.fit.hold.width, rel=1e-3, abs=1e-4)


def test_python_api_keeps_the_command_lines_output_guards(decay_video, tmp_path):
    # the API wrote the overlay over its own input video, the table into a video file, and a report over a page the
    # user wrote; the command line refused all three, and so does the API now, leaving every file as it was
    import sloshid

    path, _ = decay_video
    video = tmp_path / "a.mp4"
    video.write_bytes(path.read_bytes())
    with pytest.raises(UserError, match="also an input of this run"):
        sloshid.track(video, overlay=video)
    with pytest.raises(UserError, match=r"must end in \.mp4"):
        sloshid.track(video, overlay=tmp_path / "o.avi")
    assert video.read_bytes() == path.read_bytes() and not (tmp_path / "o.avi").exists()
    res = sloshid.track(video)
    other = tmp_path / "b.mp4"
    other.write_bytes(b"a video")
    for target in (video, other):
        with pytest.raises(UserError, match=r"must end in \.csv"):
            res.to_csv(target)
    assert video.read_bytes() == path.read_bytes() and other.read_bytes() == b"a video"
    page = tmp_path / "rep" / "index.html"
    page.parent.mkdir()
    page.write_text("<html>my own page</html>")
    with pytest.raises(UserError, match=r"index\.html that sloshid did not write"):
        sloshid.identify(res).report(page.parent)
    assert page.read_text() == "<html>my own page</html>"


def test_a_float_that_never_moves_draws_a_warning(decay_video, tmp_path):
    # a static label of the float's colour was tracked as the float, valid in every frame, without a word (its angle
    # spanned 0.02 deg); identify then blamed a container moving in the picture. A tapped float spans degrees.
    still = tmp_path / "still.mp4"
    render_video(still, SynthSettings(**{**SMALL, "duration_s": 1.0}, amplitude_deg=0.0))
    res = track_video(still, TrackSettings())
    assert res.valid.mean() > 0.9
    assert any("nothing moved it" in w and "`overlay`" in w for w in res.warnings), res.warnings
    moving = track_video(decay_video[0], TrackSettings())
    assert not any("nothing moved it" in w for w in moving.warnings)


def test_columns_beside_a_sensor_file_are_the_files(surface_video, tmp_path):
    # value_col names a sensor CSV's column beside a tracker result: the result keeps its angle (a pipeline with
    # tracked videos and a "height" sensor file failed on the tracked table once the columns reached it)
    import sloshid

    path, _ = surface_video
    res = track_video(path, TrackSettings(target="surface", reference="container", container_diameter_m=0.1))
    sensor = tmp_path / "sensor.csv"
    ok = res.valid.astype(bool)
    np.savetxt(sensor, np.c_[res.t_s[ok], res.columns()["left_wall_mm"][ok] + 0.01], delimiter=",",
               header="time_s,height", comments="")  # fmt: skip
    both = sloshid.identify(res, sensor, value_col="height")
    assert [s.label for s in both.signals] == ["angle_deg", "height"]
    # one list of sources, as a user collects them, raised a TypeError
    listed = sloshid.identify([res, sensor], value_col="height")
    assert listed.parameters["f_hz"].value == both.parameters["f_hz"].value
    # the track page reads as a report, not a key dump, and says what the angle is of
    html = res.report(tmp_path / "track_report").read_text()
    assert "frames the encoder repeated (not valid)" in html and "dyed liquid&#x27;s surface" in html
    assert "invalid_share" not in html and res.plot().axes[0].get_ylabel() == "surface angle (deg)"
    assert sloshid.identify(res, value_col="left_wall_mm").signals[0].label == "left_wall_mm"
    with pytest.raises(UserError, match="has no value column 'height'"):
        sloshid.identify(res, value_col="height")


def test_a_surface_whose_centre_leaves_its_level_is_not_valid():
    # a move that slopped the liquid to the rim read a flat line there, 0.005 deg against 46 deg and both walls 115 px
    # up, valid with quality 1 (a trial): a planar slosh keeps the mean of the wall heights where it was, so such a frame
    # is dropped. Rows as the step keeps them (TrackRow, with the surface's raw geometry: slope, container angle,
    # left, right, width, opening); a 200 px inner width sloshing +-10 px at its walls
    step = SurfaceStep(TrackSettings(target="surface"), (0, 0, 320, 240))
    rows = []
    for k in range(60):
        swing = 10 * math.sin(2 * math.pi * 2 * k / 30) if k >= 30 else 0.0
        left, right = 100 - swing, 100 + swing
        if k == 45:
            left = right = 130  # both walls 30 px (0.15 of the width) up: the rim, not the surface, seen 30 px higher
        raw = SurfaceGeometry(swing / 100, 0.0, left, right, 200.0, 0.0)
        rows.append(TrackRow(k, k / 30, 0.0, 0.0, 0.0, 160, 120 - 30 * (k == 45), 1.0, 1, raw))
    body, walls, notes = step.finish(rows)
    valid = np.array([b.valid for b in body])
    assert valid.sum() == 59 and valid[45] == 0
    assert np.isnan(walls["left_wall_px"][45]) and walls["right_wall_px"][46] == pytest.approx(
        rows[46].surface.right_w - 100
    )
    assert any("centre left its level" in n and "1 frame(s), first at 1.50 s" in n for n in notes)


def test_the_elevation_is_corrected_whichever_edge_of_the_ellipse_was_read():
    # over an opaque liquid seen from above the tracker reads the ellipse's back edge, whose opening is negative: the
    # elevation's sine read as zero, so slopes and wall heights went uncorrected (a path-traced cola from 5.2 deg
    # above). Rows as the step keeps them: a 200 px inner width seen from asin(0.26) = 15 deg above, its walls
    # sloshing +-10 px in the picture; the back edge's rows give the front edge's angles and heights, both corrected
    cos_e = math.sqrt(1 - 0.26**2)
    swing = 10 * np.sin(2 * np.pi * 2 * np.arange(60) / 30)
    finished = {}
    for sign in (1, -1):
        raw = [SurfaceGeometry(w / 100, 0.0, 100 - w, 100 + w, 200.0, sign * 52.0) for w in swing]
        rows = [TrackRow(k, k / 30, 0.0, 0.0, 0.0, 160, 120, 1.0, 1, g) for k, g in enumerate(raw)]
        body, walls, _ = SurfaceStep(TrackSettings(target="surface"), (0, 0, 320, 240)).finish(rows)
        finished[sign] = (np.array([b.angle_deg for b in body]), walls["right_wall_px"])
    rest = np.median(100 + swing[:30])  # the first second's median: the rest level
    for angle, right in finished.values():
        assert angle == pytest.approx(np.degrees(np.arctan(swing / 100 / cos_e)))
        assert right == pytest.approx((100 + swing - rest) / cos_e)


def test_the_surface_is_measured_inside_the_roi_only(surface_video):
    # with --roi cutting the container below the sloshing surface's reach, a trial's walls read up to 17 px above the
    # ROI's top, valid: the frames where the liquid meets the ROI's top are now not measured (the float's rule). The
    # ROI's top here is 2 px above the surface at rest; the walls rise up to 7.9 px. The surface seen as an ellipse
    # from 4 deg above, in a container tilting +-2 deg, reaches the ROI's top up to 3 px before its walls' mid-line
    path, truth = surface_video
    full = track_video(path, TrackSettings(target="surface"))
    top = int(np.median(full.y_px[:20])) - 2  # the surface centre at rest, before the tap at 1 s
    cut = track_video(path, TrackSettings(target="surface", roi=(0, top, 320, 240 - top)))
    reach = np.maximum(truth["left_wall_px"], truth["right_wall_px"])
    ok = cut.valid.astype(bool)
    assert ok.sum() > 20 and reach[ok].max() < 2 + 3
    assert (reach > 2 + 3).sum() > 10 and not ok[reach > 2 + 3].any()


def test_a_shallow_fill_in_an_upright_container_keeps_its_walls(tmp_path, monkeypatch):
    # the tilted container's corner margin (a twentieth of the width above the bottom) took every wall row of a
    # shallow fill, depth a tenth of the width: no frame found a container (a review; 576x48 px liquid, 960x480)
    from dataclasses import replace as changed

    import sloshid.synthetic.render as render
    import sloshid.synthetic.surface_scene as scene

    geometry = render.scene_geometry

    def shallow(s):
        return changed(geometry(s), inner_w=1.2 * s.height, depth=0.1 * s.height)

    monkeypatch.setattr(render, "scene_geometry", shallow)
    monkeypatch.setattr(scene, "scene_geometry", shallow)
    s = SynthSettings(scene="surface", width=960, height=480, duration_s=2.0, amplitude_deg=4.0, quality=16, seed=1)
    truth = render_video(tmp_path / "shallow.mp4", s)
    res = track_video(tmp_path / "shallow.mp4", TrackSettings(target="surface", smooth=False), multithreaded=False)
    ok = res.valid.astype(bool)
    assert ok.mean() > 0.9 and _rmse((res.angle_deg - truth["surface_angle_deg"])[ok]) < 0.1  # measured 0.010 deg


def test_a_thing_of_the_dyes_colour_at_the_maps_side_leaves_the_liquids_column_walled():
    # a dark liquid 200 px wide in a map whose left edge holds another dark thing in the same rows (a camera body
    # beside a cola): the column through the liquid's centre stops short of both sides, so it is the liquid's box.
    # Reading "walled" off the map's edge columns refused it (None), and no frame of such a clip was measured
    inside = np.zeros((240, 400), bool)
    inside[60:200, 150:350] = True  # the liquid
    inside[40:180, 0:40] = True  # the other thing, touching the map's left side
    assert _column_box(inside, (10, 20)) == (160, 80, 360, 220)
    inside[60:200, 40:150] = True  # the liquid itself reaches the side: no walls there
    assert _column_box(inside, (10, 20)) is None


def test_a_reflection_in_the_walls_lowest_rows_leaves_its_upper_rows_on_the_wall():
    # a left wall leaning 0.04 px per row (a camera looking down: vertical edges converge), whose lowest 30 of 130 rows
    # curve 0.8 px per row inward (a reflection or the bottom's corner seen through the glass, as in a render of a
    # glass on a table seen from 18 deg above). A least-squares line through the lower half leaned with them and put
    # the upper 82 rows more than 3 px "inside" the wall: the wall was then read off the curve, tilted by degrees
    rows = np.arange(130.0)
    x = 12 + 0.04 * rows
    x[100:] += 0.8 * (rows[100:] - 100)
    on = _on_wall(x, np.ones(130, bool), 1.0)
    assert on[:100].all() and not on[105:].any()
    # a steep slosh's surface run down the upper 50 rows still leaves them out (what `_on_wall` is for)
    x = np.full(130, 12.0)
    x[:50] += 1.5 * (50 - rows[:50])
    assert np.array_equal(_on_wall(x, np.ones(130, bool), 1.0), rows >= 49)


def test_a_front_edge_seen_from_above_gives_the_ellipses_centre_and_a_level_line_when_the_walls_are_read_off_it():
    # a level surface seen from above (its front edge 30 px below the mid-line at the centre, 120 px half width,
    # 0.3 px edge noise), the walls' midpoint read 3 px off the container's axis (a wall on a reflection, as in a
    # render of a glass on a table seen from 18 deg above): the fit without the centre turns the line by 0.6 deg,
    # the fit with it finds the offset (within 0.5 px) and the line level within 0.05 deg (measured: 0.006)
    half, k, shift = 120.0, 30.0, 3.0 / 120.0
    s = np.linspace(-0.94, 0.94, 120)
    w = -k * np.sqrt(1 - (s - shift) ** 2) + np.random.default_rng(7).normal(0.0, 0.3, s.size)

    def line_deg(fit):
        (_, c1, c3, _, _), _, _ = fit
        return math.degrees(math.atan((c1 + LINE_SLOPE_OF_CUBIC * c3) / half))

    assert abs(line_deg(_fit_front(s, w, 10))) > 0.5
    with_centre = _fit_front(s, w, 10, half)
    assert abs(line_deg(with_centre)) < 0.05 and abs(with_centre[0][4] * half - 3.0) < 0.5


def _turned_tumbler_front(turn_deg: float, rel_deg: float):
    """`_fitted`'s input for a tumbler turned `turn_deg` in the picture, seen 16 deg from above: walls widening by 0.1 px
    per px of height, the surface `rel_deg` against the container's axis; its back edge in every column."""
    phi = math.radians(turn_deg)
    e_u, e_w = np.array([math.cos(phi), -math.sin(phi)]), np.array([-math.sin(phi), -math.cos(phi)])
    o, taper, hs, r0 = np.array([300.0, 400.0]), 0.1, 200.0, 120.0
    walls = []
    for side in (-1, 1):  # x = a y + b through the wall's points at heights 0 and 300
        p, q = (o + h * e_w + side * (r0 + taper * h) * e_u for h in (0.0, 300.0))
        a = (q[0] - p[0]) / (q[1] - p[1])
        walls.append((a, p[0] - a * p[1]))
    a = math.tan(0.5 * (math.atan(walls[0][0]) + math.atan(walls[1][0])))
    norm = math.hypot(1, a)
    geom = (tuple(walls), o, np.array([1.0, -a]) / norm, np.array([-a, -1.0]) / norm)
    # the surface's contact line: where the plane tilted by rel_deg across meets the tapered wall, seen from above
    t, slope = np.linspace(0, 2 * math.pi, 20001), math.tan(math.radians(rel_deg))
    rho = (r0 + taper * hs) / (1 - taper * slope * np.cos(t))  # on the cone: rho = r0 + taper (hs + slope u)
    u = rho * np.cos(t)
    w = hs + slope * u - math.sin(math.radians(16.0)) * rho * np.sin(t)
    x, y = (o[i] + u * e_u[i] + w * e_w[i] for i in (0, 1))
    front = np.sin(t) < 0  # the back edge, above the mid-line (what a juice's top shows: `_fitted` finds k < 0)
    cols = np.arange(math.ceil(x[front].min()) + 1, int(x[front].max()))
    order = np.argsort(x[front])
    rows = np.interp(cols, x[front][order], y[front][order]) + np.random.default_rng(5).normal(0.0, 0.3, cols.size)
    ytop = float(np.floor(y.min()))
    (ox, oy), (eux, euy), (ewx, ewy) = o, geom[2], geom[3]
    uL, uR = ((aa * ytop + bb - ox) * eux + (ytop - oy) * euy for aa, bb in walls)
    du, dw = cols - ox, rows - oy
    sv = (du * eux + dw * euy - 0.5 * (uL + uR)) / (0.5 * (uR - uL))
    edges = ((sv, du * ewx + dw * ewy, np.abs(sv) <= 0.9, dw, rows, 1.0),)
    return {"luma": edges}, geom, (ytop, uL, uR, du)


@pytest.mark.parametrize("turn_deg", [-7.0, 5.0])
@pytest.mark.parametrize("rel_deg", [0.0, 3.0])
def test_a_tapered_glass_turned_in_the_picture_keeps_its_surfaces_angle(turn_deg, rel_deg):
    # A tumbler seen from 16 deg above, turned in the picture (a tilted camera or robot), its surface's back edge found
    # with 0.3 px of noise (the edge a juice's top shows; its ellipse's centre is not fitted). The liquid's top row
    # meets the walls at heights far apart along the axis, where they stand nearer it or farther out: read there, the
    # ellipse's ends were off centre and the line turned by 0.23-0.37 deg. The walls where the surface's line meets
    # them, on the axis their angles' mean gives, give the line back within 0.1 deg (measured 0.01-0.04: the noise).
    points, geom, where = _turned_tumbler_front(turn_deg, rel_deg)
    m = _fitted(points, 10, geom, (0, 0), where, None, "luma")
    assert m.found
    assert math.degrees(math.atan(m.rel_slope)) == pytest.approx(rel_deg, abs=0.1)


def _lit_juice(fade: float) -> np.ndarray:
    """An opaque orange juice in a straight glass seen from above, level: its top face (an ellipse 120 x 20 px) lit
    evenly on the left and paling toward its back edge on the right (mixed with white by 0.1 + `fade` at the back
    edge's right end), as a juice's top face is under a light at its left."""
    img = np.full((300, 400, 3), 185, np.uint8)
    orange = np.array((20, 110, 230), float)
    cx, half, ys, k = 199.5, 60.0, 120, 10.0
    img[ys:250, 140:260] = orange.astype(np.uint8)
    yy, xx = np.mgrid[0:300, 0:400].astype(float)
    s = np.clip((xx - cx) / half, -1, 1)
    chord = np.sqrt(1 - s * s)
    depth = np.clip((yy - ys + k * chord) / (2 * k * chord + 1e-9), 0, 1)  # 0 at the back edge, 1 at the front
    face = s * s + ((yy - ys) / k) ** 2 <= 1
    pale = 0.1 + fade * (s + 1) / 2 * (1 - depth)
    img[face] = ((1 - pale[face])[:, None] * orange + pale[face][:, None] * 255.0).astype(np.uint8)
    img[80:262, 136:138] = img[80:262, 262:264] = 160  # the glass's walls
    img[250:262, 136:264] = 225  # its thick bottom
    return img


def _held_source(rms, quality):
    """The edge source `_edge_source` holds after first frames whose medians are `rms` (px per EDGE_SOURCES) and
    `quality`."""
    finder = SurfaceFinder(None, (0, 0, 640, 480))
    finder._scatter = [tuple(rms) + tuple(quality)] * LOW_MIN_FRAMES
    return finder._edge_source()


def test_the_plateau_crossing_is_held_only_where_the_half_crossing_fits_poorly_and_it_clearly_better():
    # a Blender glass of orange juice (held out, seeds 1300 on: glass09) read 4.2 deg off and was refused in two of
    # three turns: its lit top face holds at 0.5-0.8 under a paler highlight at its back, and its 0.5 crossings fitted
    # poorly (median quality 0.55, scatter 0.56 px) where those of PLATEAU_LEVEL, the face's front edge, fitted well
    # (0.94, 0.21 px). The first frames' medians (rms px per EDGE_SOURCES, then quality) as measured there and in three
    # scenes whose high crossings fitted well too but read worse (a Blender tumbler turned 5 deg, whose 0.5 crossings
    # fitted at 0.66; a pbr still and still55, whose 0.5 crossings scattered 12 px)
    assert _held_source([0.56, 0.75, 0.54, 0.54, 0.21, 0.96], [0.55, 0.51, 0.51, 0.51, 0.94, 0.46]) == "luma high"
    assert _held_source([0.12, 0.42, 0.26, 0.36, 0.09, 0.22], [0.66, 0.65, 0.95, 0.53, 0.97, 0.97]) == "luma"
    assert _held_source([11.92, 11.86, 3.32, 3.05, 0.41, 0.34], [0.58, 0.56, 0.65, 0.67, 0.65, 0.93]) == "colour"
    assert _held_source([12.7, 12.53, 4.94, 5.08, 0.97, 0.26], [0.0, 0.0, 0.58, 0.75, 0.58, 0.79]) == "colour"
    # a high crossing that scatters more than the poor half crossing is not held either
    assert _held_source([0.56, 0.75, 0.54, 0.54, 0.60, 0.96], [0.55, 0.51, 0.51, 0.51, 0.94, 0.46]) == "luma"


def test_the_cleaner_low_crossing_is_held_where_both_half_crossings_run_onto_another_edge():
    # Blender's move_h (a faint blue dye lit from behind, held out) was measured in none of its first 16 frames: a glow
    # on the surface over a third of its width put both sources' 0.5 crossings 8 px off the front edge there (median
    # scatter 1.84 and 1.66 px, quality 0), where the luma's low crossing traced the front edge on the rest (0.11 px,
    # quality 0.67), but the low sources were held only where the 0.5 crossings scatter at most 1 px. The first frames'
    # medians as measured there, and in pbr stills whose 0.5 crossings scattered with the render's speckle and whose
    # low ones, clean, are now held: still52 (0.11 -> 0.02 deg), still48 (a faint red seen 13 deg from above, whose
    # colour low crossing, clean too, reads 0.33 deg off where the 0.5 crossings read 0.08: the rule's cost)
    cases = {  # rms px and quality per EDGE_SOURCES: the source held
        "move_h": ((1.84, 1.66, 0.11, 0.33, 1.08, 1.75), (0.0, 0.0, 0.67, 0.41, 0.27, 0.0), "luma low"),
        "still52": ((2.87, 3.04, 0.26, 0.29, 0.34, 0.38), (0.8, 0.82, 0.9, 0.9, 0.67, 0.69), "luma low"),
        "still48": ((8.98, 8.44, 0.49, 0.37, 3.1, 1.75), (0.57, 0.55, 0.69, 0.74, 0.29, 0.48), "colour low"),
        # a low crossing that scatters with the picture's noise (above LOW_CLEAN_PX), or fits under the valid
        # quality, is not held: the 0.5 crossings' source is
        "speckled low": ((1.84, 1.66, 0.61, 0.73, 1.08, 1.75), (0.0, 0.0, 0.67, 0.61, 0.27, 0.0), "colour"),
        "poor low": ((1.84, 1.66, 0.11, 0.33, 1.08, 1.75), (0.0, 0.0, 0.45, 0.41, 0.27, 0.0), "colour"),
        # ... or fits worse than the 0.5 crossings (test_synth_pbr's red juice turned 5 deg, 45 frames: its frames
        # read on the colour low crossing fell under the valid quality)
        "juice": ((7.23, 7.1, 0.47, 0.27, 0.3, 0.47), (0.61, 0.62, 0.71, 0.56, 0.76, 0.8), "colour"),
    }
    held = {name: _held_source(rms, quality) for name, (rms, quality, _) in cases.items()}
    assert held == {name: want for name, (_, _, want) in cases.items()}


def test_a_juices_top_face_pale_toward_its_back_is_read_on_its_back_edge(tmp_path, monkeypatch):
    # Blender's robot move of an orange juice (move_b) read 4.6 deg RMSE off: the juice's lit top face held at 0.4-0.9
    # of the dye, dimmer on the side away from the light, so that the 0.5 crossings ran along the back edge on one side
    # and across the face on the other. The low sources cross LOW_LEVEL there. On this level surface, the 0.5 crossings
    # read 1.0-2.4 deg off (six noise seeds, faded 0.55-0.65); a low source is held in 15 of the 18 and reads 0.4-0.9
    # (the face's right end pales under LOW_LEVEL too, so its crossing sits a little below the back edge there): held
    # to 1.0. Sensor noise of 4 grey levels, so that the encoder does not copy the frames and the choice has them all
    clip = tmp_path / "juice.mp4"
    still_clip(_lit_juice(0.6), clip, 0.0, frames=15, seed=3, noise=4.0)
    held = []
    chosen = SurfaceFinder._edge_source

    def watched(finder):
        held.append(chosen(finder))
        return held[-1]

    monkeypatch.setattr(SurfaceFinder, "_edge_source", watched)
    res = track_video(clip, TrackSettings(target="surface", smooth=False), multithreaded=False)
    assert held[-1].endswith(" low") and res.valid.mean() == 1.0
    assert abs(float(np.median(res.angle_deg))) < 1.0
    monkeypatch.setattr("sloshid.tracking.surface.LOW_SCATTER_SHARE", 0.0)  # the 0.5 crossings only, as before
    res = track_video(clip, TrackSettings(target="surface", smooth=False), multithreaded=False)
    assert not held[-1].endswith(" low") and abs(float(np.median(res.angle_deg))) > 1.0


def test_a_faint_dye_whose_first_frame_is_not_measured_is_still_chosen_by_its_own_range():
    # a faint blue (saturation 100, under every preset's 140) whose first frame shows no surface to measure (a round
    # blob: no walls; a Blender tumbler's first frames, where a glow on the surface tilted the fitted ellipse, were not
    # measured either, and the later ones were, 40 of 60 frames with this range against 9 with none chosen): with no
    # preset's region at all, the largest coloured region's own range is the dye, not none
    frame = np.full((240, 320, 3), 200, np.uint8)
    blue = cv2.cvtColor(np.uint8([[[120, 100, 180]]]), cv2.COLOR_HSV2BGR)[0, 0].tolist()
    cv2.circle(frame, (160, 120), 60, blue, -1)
    name, liquid, rival, _ = tracker._auto_dye(frame, (0, 0, 320, 240), TrackSettings(target="surface"))
    assert name is not None and name.endswith("no preset's") and rival is None
    assert liquid.low[0] <= 120 <= liquid.high[0] and liquid.low[1] <= 100
    # a grey picture has no coloured region: still none
    assert (
        tracker._auto_dye(np.full((240, 320, 3), 200, np.uint8), (0, 0, 320, 240), TrackSettings(target="surface"))[1]
        is None
    )


def test_a_region_of_two_colours_joined_gets_the_range_of_the_larger_one():
    # cross80 of the earlier pbr draw: a faint blue dye (hue 111) joined through its glass to a violet box behind it
    # (hue 128) in one coloured region. Its median hue (117) centred the range between them (H 109-125): the tracker
    # then measured the box's top edge as the surface, with quality 1, through the whole crossing. The larger group's
    # own hue centres it on the dye; a region of one colour keeps its median.
    rng = np.random.default_rng(3)
    dye = np.clip(rng.normal(112, 3.0, 1000), 0, 179).round()  # the dye's hue spreads; the box's is tight
    box = np.clip(rng.normal(128, 1.0, 960), 0, 179).round()
    sv = np.tile([[120, 160]], (1960, 1))
    joined = own_range(np.column_stack([np.concatenate([dye, box]), sv]))  # their median: 118
    assert (joined.low[0], joined.high[0]) == (112 - OWN_HUE_REACH, 112 + OWN_HUE_REACH)  # the dye's median, 112
    one = own_range(np.column_stack([box, sv[:960]]))
    assert (one.low[0], one.high[0]) == (128 - OWN_HUE_REACH, 128 + OWN_HUE_REACH)
    # one dye whose hue spreads (sd 7: Otsu halves it, 10 units apart, but no valley lies between): its median
    spread = np.clip(rng.normal(110, 7.0, 4000), 0, 179).round()
    wide = own_range(np.column_stack([spread, np.tile([[120, 160]], (4000, 1))]))
    assert (wide.low[0], wide.high[0]) == (110 - OWN_HUE_REACH, 110 + OWN_HUE_REACH)
    # a red of hues 170-179 and 0-10 in equal parts is one colour round the circle (its plain median, 90, is cyan)
    red = np.concatenate([rng.integers(170, 180, 1000), rng.integers(0, 11, 1000)])
    ring = own_range(np.column_stack([red, np.tile([[120, 160]], (2000, 1))]))
    assert ring.wraps and ring.low[0] >= 166 and ring.high[0] <= 12
