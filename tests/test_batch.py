"""Batch on Dask: good videos finish, a corrupt one is recorded, re-runs skip, an interrupted batch resumes."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import threading
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
    failed = [line for line in stdout.splitlines() if "failed: " in line]  # the path once (it was said twice)
    assert len(failed) == 1 and failed[0].count("corrupt.mp4") == 1 and "is not a video" in failed[0]
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
    cfg.write_text('[identify]\nvalue_col = "left_wall_mm"\n')  # every video was tracked, then failed
    code, _, err = run_cli("batch", good[0], "--config", cfg, "--out", tmp_path / "o")
    assert code == 2 and "[identify].value_col 'left_wall_mm' is not a column" in err and not (tmp_path / "o").exists()


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
def test_unreachable_scheduler_is_one_clear_error(videos, tmp_path, run_cli, monkeypatch):
    from sloshid.core import parallel

    good, _ = videos
    # port 9 (discard) on loopback: nothing listens, the connection is refused at once; Dask tries again until its
    # connect timeout, so a short stand-in for the 10 s wait, as the silent port's test below takes (the same path)
    monkeypatch.setattr(parallel, "CONNECT_WAIT_S", 0.5)
    code, _, err = run_cli("batch", good[0], "--out", tmp_path / "o", "--scheduler", "tcp://127.0.0.1:9")
    assert code == 2 and "could not reach the Dask scheduler" in err
    assert not (tmp_path / "o").exists()  # not even the folder (it was left empty)


def test_a_silent_port_and_a_scheduler_without_workers_are_one_sentence(videos, tmp_path, run_cli, monkeypatch):
    # both waited for ever with no message: a port that takes the connection and never answers, and a scheduler
    # that no worker ever joins
    import socket
    import threading

    from dask.distributed import LocalCluster

    from sloshid.core import parallel

    good, _ = videos
    monkeypatch.setattr(parallel, "CONNECT_WAIT_S", 0.5)  # short stand-ins for the 10 s and 30 s waits
    monkeypatch.setattr(parallel, "WORKER_WAIT_S", 1.0)
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        threading.Thread(target=silent.accept, daemon=True).start()
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        start = time.monotonic()
        code, _, err = run_cli("batch", good[0], "--out", tmp_path / "o", "--scheduler", address)
    # Dask's own timeout or, where it hangs in the handshake, the watch of its thread: one sentence either way
    assert code == 2 and f"the Dask scheduler at {address}" in err and err.count("\n") == 1
    assert time.monotonic() - start < 20
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        code, _, err = run_cli("batch", good[0], "--out", tmp_path / "o", "--scheduler", cluster.scheduler_address)
    assert code == 2 and "has no worker (none joined in 1 s)" in err
    assert not (tmp_path / "o").exists()


_RELEASE = threading.Event()
"""Lets `_held`'s job go: its thread outlives its worker in an in-process cluster, and the cluster's exit waits for it."""


def _held() -> None:
    """A job that runs until `_RELEASE` (at most 30 s)."""
    _RELEASE.wait(30)


def test_a_cluster_that_loses_its_last_worker_stops_the_wait(monkeypatch):
    # the batch waited for ever when the only worker died; now it stops with what to do
    from dask.distributed import Client, LocalCluster

    from sloshid.core import parallel
    from sloshid.core.errors import UserError

    monkeypatch.setattr(parallel, "WORKER_WAIT_S", 1.0)
    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster, Client(cluster) as client:
        job = client.submit(_held, pure=False)
        threading.Timer(0.5, cluster.scale, args=(0,)).start()
        start = time.monotonic()
        try:
            with pytest.raises(UserError, match=r"no worker for 1 s .* with 1 job"):
                list(parallel.wait_with_workers(client, [job], poll_s=0.2))
            assert time.monotonic() - start < 15
        finally:
            _RELEASE.set()


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


def _config(**identify):
    from sloshid.workflow.options import BatchConfig, IdentifyOptions, TrackOptions

    return BatchConfig(TrackOptions(), IdentifyOptions(**identify))


def test_a_cached_video_is_named_as_this_run_gives_it_and_checked_against_its_outputs(videos, tmp_path):
    # a re-run replayed the stored row: a copy of a video in another folder (or a moved output folder) was listed
    # under the first one's name and folder; a damaged result.json failed the video on every re-run with a JSON
    # error, and a deleted params.json was never noticed (a trial)
    import json
    import shutil

    from sloshid.workflow.batch import process_video

    good, _ = videos
    copies = []
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        copies.append(str(shutil.copy(good[0], tmp_path / folder / "x.mp4")))
    out, config = tmp_path / "out", _config(mass_kg=0.5)
    first = process_video(copies[0], config, str(out))
    assert first["status"] == "ok"
    folder = first["outputs"]
    second = process_video(copies[1], config, str(out))  # the same content and name: the same folder, finished
    assert second["status"] == "cached" and second["file"] == copies[1] and second["outputs"] == folder
    moved = tmp_path / "moved"
    shutil.copytree(out, moved)
    again = process_video(copies[0], config, str(moved))
    assert again["status"] == "cached" and again["outputs"].startswith(str(moved)) and again["f_hz"] == first["f_hz"]
    marker = json.loads((tmp_path / folder / "result.json").read_text())
    assert marker["settings"]["identify"]["mass_kg"] == 0.5  # the settings themselves, not only their hash
    # a result.json of an earlier sloshid (no outputs listed) with its outputs there: finished, not done again
    (tmp_path / folder / "result.json").write_text(json.dumps({"key": marker["key"], "row": marker["row"]}))
    assert process_video(copies[0], config, str(out))["status"] == "cached"
    for damage in (
        lambda d: (d / "params.json").unlink(),
        lambda d: (d / "angles.csv").write_text((d / "angles.csv").read_text()[:-40]),
        lambda d: (d / "result.json").write_text('{"broken'),
    ):
        damage(moved / "videos" / (tmp_path / folder).name)
        redone = process_video(copies[0], config, str(moved))
        assert redone["status"] == "ok" and redone["f_hz"] == first["f_hz"]


def test_an_unwritable_videos_folder_is_refused_before_any_work(videos, tmp_path, run_cli):
    good, _ = videos
    out = tmp_path / "out"
    out.mkdir()
    (out / "videos").write_text("not a folder")  # as a folder that takes no files: each video failed in turn
    code, _, err = run_cli("batch", good[0], "--out", out)
    assert code == 2 and "cannot write --out" in err and "is a file, not a folder" in err
    assert sorted(p.name for p in out.iterdir()) == ["videos"]


def test_the_summary_page_shows_every_interval_to_its_digits_and_the_damping_constant(tmp_path):
    # 1.2 [1.2, 1.2] hid a 0.1 % interval, and d (with --mass) was missing from the page
    from sloshid.workflow.batch import SUMMARY_COLUMNS, BatchResult, batch_report

    row = {c: "" for c in SUMMARY_COLUMNS}
    row.update(file=str(tmp_path / "v.mp4"), status="ok", f_hz=1.20031, f_lo_hz=1.19987, f_hi_hz=1.20075)
    row.update(zeta=0.0101, zeta_lo=0.0099, zeta_hi=0.0103, d_ns_per_m=0.19, d_lo_ns_per_m=0.187, d_hi_ns_per_m=0.193)
    html = batch_report(BatchResult([row], *(tmp_path / n for n in ("s.csv", "f.csv", "s.html")))).to_html()
    assert "1.20031 [1.19987, 1.20075]" in html and "d (N s/m)" in html and "0.19 [0.187, 0.193]" in html


def test_the_local_cluster_leaves_port_8787_alone(tmp_path):
    # its dashboard (unused) took 8787, and with that port held Dask warned on stderr in the middle of a batch
    import socket
    import warnings

    from sloshid.core.parallel import dask_client

    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))
    except OSError:
        holder.close()
        pytest.skip("port 8787 is taken already")
    holder.listen()
    try:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            client = dask_client(1)
            try:
                assert client.submit(sum, [1, 2]).result() == 3
            finally:
                client.close()
        assert not [w for w in seen if "8787" in str(w.message)]
    finally:
        holder.close()
