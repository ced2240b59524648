"""Hostile input (issue 40): each class of input that gave a traceback, a hang or a wrong result with exit code 0 is
one clear sentence now. Other classes have their tests beside the command they concern (devices, outsized and silent
inputs in test_outputs, repeated timestamps in test_track, synth's ranges in test_synth, extreme signals in
test_identify_inputs, schedulers in test_batch, a full disk in test_pipeline, robust factors and edited parameter
files in test_plan and test_compare_cli)."""

from __future__ import annotations

import contextlib
import json
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import sloshid
from sloshid.core.errors import UserError
from sloshid.identification.signals import load_signal
from sloshid.model.pendulum import TABLE_I
from sloshid.synthetic.decays import free_decay

ROOT = Path(__file__).resolve().parents[1]
DEMO = ROOT / "data" / "scenarios" / "demo_move.toml"


@pytest.fixture
def decay_csv(tmp_path) -> Path:
    """A clean 3 Hz ring-down CSV (t_s, angle_deg)."""
    t, y = free_decay(3.0, 0.05, 60, amplitude=5, seed=1)
    path = tmp_path / "decay.csv"
    np.savetxt(path, np.c_[t, y], delimiter=",", header="t_s,angle_deg", comments="")
    return path


@pytest.mark.parametrize(
    "call, message",
    [
        # AttributeError / TypeError from deep inside
        (lambda: sloshid.plan(None), "scenario must be a Scenario or a scenario TOML's path, got NoneType"),
        (lambda: sloshid.compare(DEMO, plan="x"), "plan must be a PlanResult of `sloshid.plan` or None, got str"),
        (lambda: sloshid.plan(DEMO, robust_omega_factors="0.9,1.1"), "got the string '0.9,1.1'"),
        (lambda: sloshid.track(None), "video must be a path (str or Path), got NoneType"),
    ],
)
def test_the_api_says_what_it_expected(call, message):
    with pytest.raises(UserError) as caught:
        call()
    assert message in str(caught.value)


def test_the_api_takes_what_the_command_line_takes(decay_csv):
    # a NumPy number as the mass and a column by its index were refused; the command line takes both
    res = sloshid.identify(decay_csv, mass_kg=np.float32(0.5), time_col=0, value_col=1)
    assert res.params.m_kg == 0.5
    assert res.params.f_hz == pytest.approx(3.0, rel=0.01)  # a clean synthetic decay: its f within 1 %


def _params_json(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "p.json"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "kind, message",
    [
        ("nested", "nests arrays too deeply to be a parameter file"),  # RecursionError
        ("digits", "is not valid JSON (Exceeds the limit (4300 digits)"),  # ValueError
    ],
)
def test_a_params_json_no_reader_can_hold(tmp_path, run_cli, kind, message):
    if kind == "nested":
        text = '{"parameters": ' + "[" * 100_000 + "]" * 100_000 + "}"
    else:
        params = {"omega_rad_s": {"value": TABLE_I.omega_rad_s}, "zeta": {"value": TABLE_I.zeta}}
        text = json.dumps({"parameters": params}).replace(f"{TABLE_I.zeta!r}", "9" * 5000)
    code, _, err = run_cli("plan", DEMO, "--params", _params_json(tmp_path, text), "-o", tmp_path / "p.csv")
    assert code == 2 and message in err and err.count("\n") == 1
    assert not (tmp_path / "p.csv").exists()


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda text: "a = " + "[" * 100_000 + "]" * 100_000 + "\n" + text, "nests arrays or tables too deeply"),
        (lambda text: text.replace("[limits]", "[limits]\nxx = " + "9" * 5000, 1), "is not valid TOML"),
        # "needs at least inf s"
        (lambda text: text.replace("start = [0.3", "start = [inf", 1), "[move].start[0] is infinite"),
    ],
)
def test_a_scenario_no_reader_can_hold(tmp_path, run_cli, edit, message):
    path = tmp_path / "s.toml"
    path.write_text(edit(DEMO.read_text()))
    code, _, err = run_cli("plan", path, "-o", tmp_path / "p.csv")
    assert code == 2 and message in err and err.count("\n") == 1
    assert not (tmp_path / "p.csv").exists()


def test_a_symlink_loop_as_an_output_folder(tmp_path, run_cli, decay_csv):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    code, _, err = run_cli("identify", decay_csv, "-o", tmp_path / "a" / "p.json")
    assert code == 2 and "its symbolic links go round in a loop" in err and err.count("\n") == 1


def test_out_of_range_numbers_are_named_as_given(tmp_path, run_cli, decay_csv):
    # `--seed -1` was a ValueError from NumPy; `--mass 1e308` said "d_ns_per_m must be zero or positive, got inf"
    code, _, err = run_cli("synth", tmp_path / "s.mp4", "--seed", "-1")
    assert code == 2 and "--seed must be a non-negative integer" in err
    code, _, err = run_cli("identify", decay_csv, "--mass", "1e308", "-o", tmp_path / "p.json")
    assert code == 2 and "--mass must be a positive number of kg up to 10000" in err
    assert not list(tmp_path.glob("s*")) and not (tmp_path / "p.json").exists()


def test_a_nul_byte_in_a_pipeline_is_one_sentence(tmp_path, run_cli):
    # ValueError: embedded null byte
    video = tmp_path / "v.mp4"
    for name, body in (
        ('[run]\nname = "a\\u0000b"\n', "[run].name must be a plain folder name (no '/' or NUL"),
        ("", "a path holds a NUL byte"),
    ):
        videos = '["v\\u0000.mp4"]' if not name else f'["{video}"]'
        pipe = tmp_path / "p.toml"
        pipe.write_text(f"{name}[track]\nvideos = {videos}\n")
        code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
        assert code == 2 and body in err and err.count("\n") == 1


def test_what_a_killed_run_left_is_removed_by_the_next(tmp_path, run_cli):
    # a run killed outright (SIGKILL) left its run folder without manifest or index, and its stage's half-made cache
    # folder (.part) was never cleaned up by later runs; a live run's are left alone
    import subprocess
    import sys

    from sloshid.core.atomic import writer_tag
    from sloshid.synthetic.render import SynthSettings, render_video

    video = tmp_path / "v.mp4"
    render_video(video, SynthSettings(width=320, height=240, duration_s=3.0, f_hz=3.0, zeta=0.05))
    pipe = tmp_path / "p.toml"
    pipe.write_text(f'[track]\nvideos = ["{video}"]\n')
    root = tmp_path / "runs" / "p"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    gone = int(dead.stdout)  # a process id that has just ended
    (root / "20260101-000000-000000").mkdir(parents=True)
    (root / "20260101-000000-000000" / f".running-{writer_tag(gone)}").touch()
    (root / ".cache" / "track" / f".abc.{writer_tag(gone)}-0123456789abcdef.part").mkdir(parents=True)
    live = root / ".cache" / "track" / f".abc.{writer_tag()}-0123456789abcdef.part"
    live.mkdir()
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert code == 0, err
    runs = [p.name for p in root.iterdir() if not p.name.startswith(".")]
    assert runs == [Path(out.strip()).parent.name]  # the killed run's folder went, this run's stays
    assert not list(Path(out.strip()).parent.glob(".running-*"))  # a finished run carries no mark
    parts = sorted(p.name for p in (root / ".cache" / "track").glob(".*.part"))
    assert parts == [live.name]
    # another machine's run on a shared folder: its processes cannot be seen from here, so it is never swept
    other = root / "20260101-000000-000001"
    other.mkdir()
    (other / f".running-00000000-{gone}").touch()
    assert run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")[0] == 0
    assert other.is_dir()


def test_ten_thousand_waypoints_are_refused_before_any_solve(tmp_path, run_cli):
    # each stop is a segment of its own: 10,000 ran for hours without a word
    text = DEMO.read_text()
    points = ", ".join(f"[{0.3 + 1e-4 * k:.4f}, -0.27, 0.2]" for k in range(10_000))
    start = text.index("start = [")
    goal_end = text.index("\n", text.index("goal = ["))
    path = tmp_path / "many.toml"
    path.write_text(text[:start] + f"waypoints = [{points}]" + text[goal_end:])
    code, _, err = run_cli("plan", path, "-o", tmp_path / "p.csv")
    assert code == 2 and "holds 10000 positions; at most 100 stops" in err


def test_a_home_matplotlib_cannot_write_puts_nothing_on_stderr(tmp_path):
    # two Matplotlib lines ("mkdir -p failed ...", "created a temporary cache directory ...") before every report
    # command's output; a HOME whose .config and .cache are files stands in for a read-only one (root writes anywhere)
    import os
    import subprocess
    import sys

    home = tmp_path / "home"
    home.mkdir()
    (home / ".config").touch()
    (home / ".cache").touch()
    drop = ("MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")
    env = {**{k: v for k, v in os.environ.items() if k not in drop}, "HOME": str(home)}
    cmd = [sys.executable, "-m", "sloshid", "plan", DEMO, "-o", tmp_path / "p.csv", "--report", tmp_path / "rep"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "atplotlib" not in proc.stderr and (tmp_path / "rep" / "index.html").exists()


def test_a_cache_that_is_a_file_is_refused_before_any_stage_runs(tmp_path, run_cli):
    # every stage ran its work and then failed to store it ("could not write .../.cache/track/...: Not a directory")
    pipe = tmp_path / "p.toml"
    pipe.write_text(f'[track]\nvideos = ["{ROOT / "data" / "sample_tap.mp4"}"]\n')
    (tmp_path / "runs" / "p").mkdir(parents=True)
    (tmp_path / "runs" / "p" / ".cache").touch()
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and ".cache is a file, not a folder" in err and "[track] running" not in out + err
    assert [p.name for p in (tmp_path / "runs" / "p").iterdir()] == [".cache"]  # no run folder made


def test_a_cached_stage_replaced_by_a_link_runs_again_and_leaves_the_target(tmp_path, run_cli):
    # "OSError: Cannot call rmtree on a symbolic link" once the linked folder differed from what the stage wrote
    import shutil

    pipe = tmp_path / "p.toml"
    pipe.write_text(f'[track]\nvideos = ["{ROOT / "data" / "sample_tap.mp4"}"]\n')
    runs = tmp_path / "runs"
    assert run_cli("run", pipe, "--output-dir", runs, "--quiet")[0] == 0
    (cache,) = (runs / "p" / ".cache" / "track").iterdir()
    elsewhere = tmp_path / "elsewhere"
    shutil.copytree(cache, elsewhere)
    (elsewhere / "mine.txt").write_text("a user's file")
    shutil.rmtree(cache)
    cache.symlink_to(elsewhere)
    code, out, err = run_cli("run", pipe, "--output-dir", runs)
    assert code == 0, err
    assert "is a link, not the folder it wrote; running it again" in out + err
    assert cache.is_dir() and not cache.is_symlink() and (elsewhere / "mine.txt").read_text() == "a user's file"


needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")


def _write_later(fifo: Path, data: bytes, delay_s: float) -> threading.Thread:
    """A writer that opens `fifo` after `delay_s`, writes `data` at once and closes it."""

    def run() -> None:
        time.sleep(delay_s)
        with contextlib.suppress(BrokenPipeError), open(fifo, "wb") as fh:
            fh.write(data)

    writer = threading.Thread(target=run, daemon=True)
    writer.start()
    return writer


@needs_fifo
def test_a_fifo_without_a_writer_says_what_it_waits_for_and_keeps_its_data(tmp_path, capsys, monkeypatch):
    # a FIFO given as a scenario blocked in its open, without a word, until something wrote to it
    import sloshid.core.errors as errors
    from sloshid.core.settings import load_toml

    monkeypatch.setattr(errors, "PIPE_WAIT_NOTE_S", 0.2, raising=False)  # 3 s on the command line
    fifo = tmp_path / "scenario.toml"
    os.mkfifo(fifo)
    writer = _write_later(fifo, DEMO.read_bytes(), 1.0)
    assert load_toml(fifo) == load_toml(DEMO)  # the writer wrote and closed at once: nothing is lost
    writer.join(5)
    assert f"waiting for data on the pipe {fifo}: nothing has written to it yet (Ctrl-C to stop)" in (
        capsys.readouterr().err
    )
    os.mkfifo(sig := tmp_path / "decay.csv")  # a signal through a pipe, as `identify <(...)` reads it
    writer = _write_later(sig, b"t_s,angle_deg\n" + b"".join(b"%g,%g\n" % (k / 60, k % 7) for k in range(600)), 0)
    assert len(load_signal(sig).t_s) == 600
    writer.join(5)


@needs_fifo
def test_a_pipe_is_read_with_a_size_bound_and_refused_as_a_pipeline_input(tmp_path, run_cli, monkeypatch):
    # a settings file through a pipe was read whole, however long; a pipeline hashed a pipe's data for its cache and
    # left its stage nothing to read (or waiting for a writer that had gone)
    import sloshid.core.settings as settings

    monkeypatch.setattr(settings, "SMALL_FILE_BYTES", 1000)  # a small stand-in for 64 MB
    os.mkfifo(fifo := tmp_path / "big.toml")
    writer = _write_later(fifo, b"# " + b"x" * 5000 + b"\n", 0)
    code, _, err = run_cli("plan", fifo, "-o", tmp_path / "p.csv")
    writer.join(5)
    assert code == 2 and "gives more than" in err and not (tmp_path / "p.csv").exists()
    os.mkfifo(sig := tmp_path / "sig.csv")
    (pipe := tmp_path / "p.toml").write_text(f'[identify]\nsignals = ["{sig}"]\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and "is a pipe; a pipeline reads each input twice" in err and err.count("\n") == 1


def test_a_parameter_file_through_a_pipe_is_read_once_by_every_step(tmp_path, run_cli):
    # `plan --params <(cat params.json)`: the file was read by three steps, and the pipe gave its data to the first
    # alone ("parameter file /dev/fd/63 is not valid JSON")
    read, write = os.pipe()
    os.write(write, (ROOT / "data" / "sample_tap_identify.json").read_bytes())
    os.close(write)
    try:
        code, _, err = run_cli("plan", DEMO, "--params", f"/dev/fd/{read}", "-o", tmp_path / "t.csv")
    finally:
        os.close(read)
    assert code == 0 and (tmp_path / "t.csv").stat().st_size > 0, err


@needs_fifo
def test_a_pipe_as_a_batch_video_is_named_for_what_it_is(tmp_path, run_cli):
    # a FIFO given as a video was said "not to exist"
    os.mkfifo(video := tmp_path / "v.mp4")
    code, _, err = run_cli("batch", video, "--out", tmp_path / "o")
    assert code == 2 and f"1 video(s) are not regular files (a pipe or a device): {video}." in err
    assert not (tmp_path / "o").exists()


def test_a_long_prediction_shows_its_phases_on_a_terminal(tmp_path, run_cli, stderr_as, monkeypatch):
    # a 1,000 s log at 1 kHz: predict worked for a minute without a word (a simulation made slow stands in for it)
    import sloshid.cli.predict_cmd as predict_cmd
    import sloshid.validation.predict as predict

    t = np.arange(0, 3, 0.001)
    log = np.c_[t, 0.05 * np.sin(2 * np.pi * t), 0 * t, 0 * t + 0.2, 0 * t, 0 * t, 0 * t, 1 + 0 * t]
    np.savetxt(tmp_path / "log.csv", log, delimiter=",", header="t,x,y,z,qx,qy,qz,qw", comments="")
    forecast = predict.forecast
    monkeypatch.setattr(predict, "forecast", lambda *a, **k: (time.sleep(1.5), forecast(*a, **k))[1])
    monkeypatch.setattr(predict_cmd, "PHASES_DELAY_S", 0.5, raising=False)
    err = stderr_as(terminal=True)
    params = ROOT / "data" / "sample_tap_identify.json"
    code, _, _ = run_cli("predict", tmp_path / "log.csv", "--params", params, "-o", tmp_path / "p.csv")
    assert code == 0 and "predict: simulate 3,000 samples" in err.getvalue()
