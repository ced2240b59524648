"""Batch on Dask: good videos finish, a corrupt one is recorded, re-runs skip, an interrupted batch resumes."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time

import pytest

from sloshid.synthetic.render import SynthSettings, render_video

# 4 s at 30 fps, 320x240: a short tap test that still holds > 9 periods of each mode after the tap.
FREQS_HZ = (2.6, 3.44)


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    """Two small tap-test videos with known frequencies and one corrupt file named like a video."""
    root = tmp_path_factory.mktemp("videos")
    paths = []
    for i, f in enumerate(FREQS_HZ):
        p = root / f"tap_{i}.mp4"
        render_video(p, SynthSettings(width=320, height=240, duration_s=4.0, f_hz=f, zeta=0.05, noise_sigma=3, seed=i))
        paths.append(p)
    bad = root / "corrupt.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(range(256)) * 40)
    return paths, bad


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_batch_records_failure_and_skips_finished_videos_on_rerun(videos, tmp_path, run_cli):
    good, bad = videos
    out = tmp_path / "out"
    code, stdout, _ = run_cli("batch", *good, bad, "--out", out, "--workers", "2")
    assert code == 1  # one video failed
    rows = {r["file"].rsplit("/", 1)[-1]: r for r in _rows(out / "summary.csv")}
    assert rows["corrupt.mp4"]["status"] == "failed" and rows["corrupt.mp4"]["reasons"]
    # the corrupt video left an empty folder behind, named in its row (a trial): nothing of it is kept now
    assert rows["corrupt.mp4"]["outputs"] == "" and not list((out / "videos").glob("corrupt-*"))
    for i, f in enumerate(FREQS_HZ):
        r = rows[f"tap_{i}.mp4"]
        assert r["status"] == "ok"
        # the tracker + identifier chain recovers a clean synthetic mode to well under 1 %
        assert float(r["f_hz"]) == pytest.approx(f, rel=0.01)
        assert float(r["f_lo_hz"]) < float(r["f_hz"]) < float(r["f_hi_hz"])
        assert int(r["frames"]) == 120
    failures = _rows(out / "failures.csv")
    assert [r["file"].rsplit("/", 1)[-1] for r in failures] == ["corrupt.mp4"]
    html = (out / "summary.html").read_text()
    # the frequency-distribution figure is embedded and every video has a table row
    assert html.count("data:image/png;base64,") == 1 and "identified frequencies spread" in html
    assert all(name in html for name in ("tap_0.mp4", "tap_1.mp4", "corrupt.mp4"))

    # interrupted batch: one video's folder lost its completion marker (as if killed mid-write)
    done = sorted((out / "videos").glob("tap_0-*"))[0]
    (done / "result.json").unlink()
    code, stdout, _ = run_cli("batch", *good, "--out", out, "--workers", "1")
    assert code == 0
    statuses = {r["file"].rsplit("/", 1)[-1]: r["status"] for r in _rows(out / "summary.csv")}
    assert statuses == {"tap_0.mp4": "ok", "tap_1.mp4": "cached"}
    assert "1 unchanged, skipped" in stdout

    # other settings: written beside the earlier results, which stay as they were
    before = {p: (p / "params.json").read_bytes() for p in (out / "videos").iterdir() if p.name.startswith("tap_")}
    cfg = tmp_path / "c.toml"
    cfg.write_text("[identify]\nmass_kg = 1.0\n")
    code, _, _ = run_cli("batch", *good, "--config", cfg, "--out", out, "--workers", "1")
    assert code == 0 and {r["status"] for r in _rows(out / "summary.csv")} == {"ok"}
    assert all((p / "params.json").read_bytes() == text for p, text in before.items())
    assert len([p for p in (out / "videos").iterdir() if p.name.startswith("tap_")]) == 2 * len(before)


def test_batch_bad_input(videos, tmp_path, run_cli):
    good, _ = videos
    code, _, err = run_cli("batch", tmp_path / "nope.mp4", "--out", tmp_path / "o")
    assert code == 2 and "do not exist" in err and not (tmp_path / "o").exists()
    cfg = tmp_path / "c.toml"
    cfg.write_text("[track]\nfloat_colour = 'red'\n")
    code, _, err = run_cli("batch", good[0], "--config", cfg, "--out", tmp_path / "o")
    assert code == 2 and "did you mean 'float_color'" in err and not (tmp_path / "o").exists()
    code, _, err = run_cli("batch", good[0], "--out", tmp_path / "o", "--workers", "0")
    assert code == 2 and "--workers" in err


def test_batch_keeps_the_users_files_and_names_folders(videos, tmp_path, run_cli):
    good, _ = videos
    # a summary.csv of the user's in --out was replaced without a word
    own = tmp_path / "own"
    own.mkdir()
    (own / "summary.csv").write_text("my,precious,data\n")
    code, _, err = run_cli("batch", good[0], "--out", own)
    assert code == 2 and "holds a summary.csv that sloshid batch did not write" in err
    assert (own / "summary.csv").read_text() == "my,precious,data\n" and not (own / "videos").exists()
    # a folder among the videos was said not to exist
    code, _, err = run_cli("batch", tmp_path, "--out", tmp_path / "o")
    assert code == 2 and "is a folder, not a video" in err and not (tmp_path / "o").exists()


def test_batch_says_when_a_video_is_truncated(videos, tmp_path, run_cli):
    # a cut-off file decodes a prefix: tracked and identified as far as it goes, but it was "ok", "good", exit 0
    good, _ = videos
    cut = tmp_path / "cut.mp4"
    data = good[1].read_bytes()
    cut.write_bytes(data[: int(0.8 * len(data))])
    code, out, _ = run_cli("batch", cut, "--out", tmp_path / "o", "--workers", "1")
    row = _rows(tmp_path / "o" / "summary.csv")[0]
    assert row["status"] == "ok" and float(row["lost_share"]) > 0.05 and "looks truncated" in row["warnings"]
    assert code == 1 and "truncated: " in out and "looks truncated" in (tmp_path / "o" / "summary.html").read_text()


@pytest.mark.slow
def test_unreachable_scheduler_is_one_clear_error(videos, tmp_path, run_cli):
    good, _ = videos
    # port 9 (discard) on loopback: nothing listens, the connection is refused at once
    code, _, err = run_cli("batch", good[0], "--out", tmp_path / "o", "--scheduler", "tcp://127.0.0.1:9")
    assert code == 2 and "could not reach the Dask scheduler" in err
    assert not (tmp_path / "o" / "summary.csv").exists()


@pytest.mark.slow
def test_ctrl_c_from_a_terminal_stops_the_batch_without_worker_tracebacks(videos, tmp_path):
    # a terminal sends Ctrl-C to the whole process group: every Dask worker printed its own KeyboardInterrupt
    # traceback (5 in a trial) while the batch itself stopped cleanly
    good, _ = videos
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "sloshid", "batch", *map(str, good), "--out", str(out), "--workers", "2"]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as a terminal's foreground job has it
    )
    deadline = time.monotonic() + 60
    while not (out / "videos").exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # the workers are tracking once the first video's folder exists
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err


def test_videos_that_share_a_file_name_are_told_apart_in_the_summary(tmp_path):
    # d1/x.mp4 and d2/x.mp4 both read "x.mp4" in summary.html (3.001 and 4.509 Hz side by side)
    from sloshid.core.tables import distinct_names

    files = [str(tmp_path / "d1" / "x.mp4"), str(tmp_path / "d2" / "x.mp4"), str(tmp_path / "d2" / "copy.mp4")]
    assert distinct_names(files) == ["d1/x.mp4", "d2/x.mp4", "copy.mp4"]
    assert distinct_names(files[1:]) == ["x.mp4", "copy.mp4"]  # unique names stay short
