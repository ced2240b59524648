"""Pipelines: validation before running, stage caching by content hash, failure handling, the index page."""

from __future__ import annotations

import html
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from sloshid.synthetic.render import SynthSettings, render_video

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def video(tmp_path_factory) -> Path:
    """A small tap-test video (f = 3.0 Hz, zeta = 0.05) that tracks and identifies in a few seconds."""
    path = tmp_path_factory.mktemp("pipe") / "tap.mp4"
    render_video(path, SynthSettings(width=320, height=240, duration_s=4.0, f_hz=3.0, zeta=0.05, noise_sigma=3))
    return path


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _statuses(index_dir: Path) -> dict[str, str]:
    manifest = json.loads((index_dir / "manifest.json").read_text())
    return {s["name"]: s["status"] for s in manifest["stages"]}


def _links_exist(index: Path) -> None:
    """Every href/src of the index page that is not embedded data points at a file of the run."""
    html = index.read_text()
    targets = [t for t in re.findall(r'(?:href|src)="([^"]+)"', html) if not t.startswith("data:")]
    assert targets, "the index links nothing"
    for t in targets:
        assert (index.parent / t).exists(), t


def test_cache_skips_unchanged_and_reruns_changed_stage_downstream_only(video, tmp_path, run_cli):
    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n\n[identify]\nmass_kg = 0.5\n')
    code, out, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert code == 0
    first = Path(out.strip()).parent
    assert _statuses(first) == {"track": "ran", "identify": "ran"}
    params = json.loads((first / "identify" / "params.json").read_text())["parameters"]
    assert params["f_hz"]["value"] == pytest.approx(3.0, rel=0.01)  # clean synthetic mode: well under 1 %
    assert params["m_kg"]["value"] == 0.5
    _links_exist(first / "index.html")
    manifest = json.loads((first / "manifest.json").read_text())
    assert str(video) in manifest["input_sha256"] and manifest["settings"]["identify"]["mass_kg"] == 0.5
    assert manifest["settings"]["run"]["output_dir"] == str(tmp_path / "runs")  # --output-dir, not the default

    code, out, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    second = Path(out.strip()).parent
    assert code == 0 and second != first
    assert _statuses(second) == {"track": "cached", "identify": "cached"}
    assert (second / "identify" / "params.json").read_text() == (first / "identify" / "params.json").read_text()
    # what identify read is named by the cached track outputs, not by the first run's folder, which may go
    sources = json.loads((second / "identify" / "params.json").read_text())["sources"]
    assert sources and all(".cache" in s and str(first) not in s and Path(s).exists() for s in sources)

    _write(pipe, f'[track]\nvideos = ["{video}"]\n\n[identify]\nmass_kg = 1.0\n')
    code, out, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    third = Path(out.strip()).parent
    assert _statuses(third) == {"track": "cached", "identify": "ran"}
    params = json.loads((third / "identify" / "params.json").read_text())["parameters"]
    assert params["m_kg"]["value"] == 1.0


def test_a_full_disk_while_a_cached_stage_is_copied_leaves_no_run_folder(video, tmp_path, run_cli, monkeypatch):
    # shutil.Error was a traceback, and the run folder kept a 0-byte params.json and no manifest
    import errno
    import shutil

    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n\n[identify]\nmass_kg = 0.5\n')
    runs = tmp_path / "runs"
    assert run_cli("run", pipe, "--output-dir", runs, "--quiet")[0] == 0
    before = sorted(p.name for p in runs.iterdir())
    copy = shutil.copyfile  # what copytree's copy2 calls for the bytes

    def full(src, dst, **kwargs):
        if os.fspath(src).endswith("params.json"):
            open(dst, "w").close()  # as a full disk leaves it: the file made, nothing in it
            raise OSError(errno.ENOSPC, "No space left on device")
        return copy(src, dst, **kwargs)

    monkeypatch.setattr(shutil, "copyfile", full)
    code, out, err = run_cli("run", pipe, "--output-dir", runs, "--quiet")
    assert code == 2, (out, err)
    assert "No space left on device" in err and err.count("\n") == 1 and out == ""
    assert sorted(p.name for p in runs.iterdir()) == before  # the new run's folder is gone, the earlier one kept


def test_a_run_folder_is_its_own_and_a_damaged_cache_runs_again(video, tmp_path, run_cli):
    # run folders were hard links into the cache: a line added to one run's CSV changed every run and the cache, and a
    # deleted cache file was "unchanged, reusing", leaving the next run without it
    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n')
    runs = []
    for _ in range(2):
        code, out, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
        assert code == 0
        runs.append(Path(out.strip()).parent)
    first, second = (r / "track" / "tap.csv" for r in runs)
    text = first.read_text()
    with open(second, "a") as fh:
        fh.write("999,9,9\n")
    assert first.read_text() == text
    cached = next((tmp_path / "runs" / "p" / ".cache" / "track").glob("*/tap.csv"))
    assert cached.read_text() == text
    cached.unlink()
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    third = Path(out.strip().splitlines()[-1]).parent
    assert code == 0 and "tap.csv is missing" in err and _statuses(third) == {"track": "ran"}
    assert (third / "track" / "tap.csv").read_text() == text and cached.read_text() == text
    # a lost summary.json (the stage then failed on every run: its folder existed) and unreadable hashes run it again
    for damage in ("summary", "hashes"):
        entry = cached.parent
        if damage == "summary":
            (entry / "summary.json").unlink()
        else:
            (entry / ".files.json").write_text("null")  # valid JSON, no hashes: it was an AttributeError
        code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
        assert code == 0 and "running it again" in err, err
        assert _statuses(Path(out.strip().splitlines()[-1]).parent) == {"track": "ran"}


def test_a_truncated_video_is_said_by_the_pipeline(video, tmp_path, run_cli):
    # `track` warns and exits 1 on a cut-off file; the pipeline ran it with exit 0 and the warning only in its manifest
    cut = tmp_path / "cut.mp4"
    data = video.read_bytes()
    cut.write_bytes(data[: int(0.8 * len(data))])
    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{cut}"]\n')
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    index = Path(out.strip().splitlines()[-1])
    assert code == 1 and "looks truncated" in err and "looks truncated" in index.read_text()
    assert _statuses(index.parent) == {"track": "ran"}


def test_warnings_of_a_track_stage_with_several_videos_name_their_video(tmp_path, run_cli):
    # "the encoder repeated the moving float's previous picture in 28 of 300 frames", twice, with no file named (a
    # trial); at 120 fps the encoder repeats pictures of a moving float
    render_video(tmp_path / "a.mp4", SynthSettings(width=320, height=240, duration_s=4.0, fps=120, seed=3))
    (tmp_path / "b.mp4").write_bytes((tmp_path / "a.mp4").read_bytes())
    pipe = _write(tmp_path / "p.toml", '[track]\nvideos = ["a.mp4", "b.mp4"]\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    repeated = [line for line in err.splitlines() if "repeated the moving float's previous picture" in line]
    assert code == 0 and len(repeated) == 2
    assert repeated[0].startswith("sloshid: warning: a.mp4: ") and repeated[1].startswith("sloshid: warning: b.mp4: ")


def test_a_stage_another_run_finished_meanwhile_is_reused_not_failed(video, tmp_path, run_cli, monkeypatch):
    # two runs of one pipeline at once: the second to finish a stage found its cache folder taken and failed with
    # "could not write runs/p3/.cache/track/...: Directory not empty" (a trial). Simulated here: while this run tracks,
    # the other run's finished outputs land in the stage's cache folder
    import shutil

    import sloshid.workflow.stages as stages

    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n')
    code, _, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    (cache,) = (tmp_path / "runs" / "p" / ".cache" / "track").iterdir()
    saved = tmp_path / "other_run"
    shutil.move(cache, saved)
    track_one = stages.track_one

    def racing(*args, **kwargs):
        summary = track_one(*args, **kwargs)
        shutil.copytree(saved, cache)  # the other run renames its finished folder into place first
        return summary

    monkeypatch.setattr(stages, "track_one", racing)
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 0 and "another run wrote its outputs meanwhile" in err, err
    assert _statuses(Path(out.strip().splitlines()[-1]).parent) == {"track": "cached"}


def test_failing_stage_keeps_finished_results(video, tmp_path, run_cli):
    # a constant signal has no oscillatory mode: identify must fail, track's outputs must stay
    flat = _write(tmp_path / "flat.csv", "t_s,y\n" + "".join(f"{i / 50},1.0\n" for i in range(500)))
    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n[identify]\nsignals = ["{flat}"]\n')
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 1 and "stage [identify] failed" in err
    assert err.count("is constant") == 1, err  # the reason once, not in the progress log too
    out = out.strip().splitlines()[-1]
    run_dir = Path(out.strip()).parent
    assert _statuses(run_dir) == {"track": "ran", "identify": "failed"}
    assert (run_dir / "track" / "tap.csv").exists() and not (run_dir / "identify").exists()
    assert not list((tmp_path / "runs" / "p" / ".cache" / "identify").glob("*")), "no half-written cache entry"
    _links_exist(run_dir / "index.html")


def test_identify_stage_keeps_what_reading_the_inputs_noticed(tmp_path, run_cli):
    # a clean 3 Hz decay with three NaN samples: identify drops them, and the run must say so, not only the CLI
    t = np.arange(1500) / 100
    y = np.exp(-0.05 * 2 * np.pi * 3 * t) * np.cos(2 * np.pi * 3 * t)
    y[[100, 400, 900]] = np.nan
    sig = _write(tmp_path / "decay.csv", "t_s,angle_deg\n" + "".join(f"{a:.3f},{b:.6g}\n" for a, b in zip(t, y)))
    pipe = _write(tmp_path / "p.toml", f'[identify]\nsignals = ["{sig}"]\n')
    code, out, _ = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert code == 0
    run_dir = Path(out.strip()).parent
    summary = json.loads((run_dir / "manifest.json").read_text())["stages"][0]["summary"]
    assert summary["input_warnings"] == [f"{sig}: dropped 3 NaN/inf samples of 1500."]
    assert "dropped 3 NaN/inf samples" in (run_dir / "index.html").read_text()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[trak]\nvideos = []\n", "unknown section [trak] (did you mean 'track'?)"),
        ('[track]\nvideos = ["missing.mp4"]\n', "[track].videos: "),
        ("[track]\nvidoes = []\n", "did you mean 'videos'"),
        ("[run]\nworkers = 0\n[track]\n", "[run].workers must be at least 1"),
        ("[identify]\nmass_kg = 0.5\n", "[identify] needs a [track] section"),
        ("[run]\n", "declares no stage"),
        ("[track\n", "is not valid TOML"),
        # asked for an identified liquid without an [identify] stage: it planned for the scenario's [liquid] silently
        (
            f'[plan]\nscenario = "{(ROOT / "data" / "scenarios" / "paper_1d.toml").as_posix()}"\nuse_identified = true\n',
            "[plan].use_identified = true, but the pipeline has no [identify] stage",
        ),
    ],
)
def test_malformed_pipeline_is_rejected_before_anything_runs(tmp_path, run_cli, text, message):
    pipe = _write(tmp_path / "bad.toml", text)
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and message in err
    assert not (tmp_path / "runs").exists()


def test_a_column_the_tracked_tables_lack_is_refused_before_tracking(video, tmp_path, run_cli):
    # value_col = "left_wall_mm" on a float video was found only after tracking, in a hidden cache file's name
    pipe = _write(tmp_path / "p.toml", f'[track]\nvideos = ["{video}"]\n[identify]\nvalue_col = "left_wall_mm"\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert (
        code == 2 and "[identify].value_col 'left_wall_mm' is not a column of the tracked tables (target float)" in err
    )
    assert not (tmp_path / "runs").exists()
    # the surface's tables have it, but empty without the container's scale; an index past the columns; the time
    for track, ident, message in (
        ('target = "surface"', 'value_col = "left_wall_mm"', "is empty in the tracked tables"),
        ("", 'value_col = "99"', "'99' is not a column"),
        ("", 'value_col = "t_s"', "is the tracked tables' time column"),
    ):
        pipe = _write(tmp_path / "s.toml", f'[track]\nvideos = ["{video}"]\n{track}\n[identify]\n{ident}\n')
        code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
        assert code == 2 and message in err and not (tmp_path / "runs").exists()
    scaled = 'target = "surface"\ncontainer_diameter_m = 0.1'
    pipe = _write(
        tmp_path / "d.toml", f'[track]\nvideos = ["{video}"]\n{scaled}\n[identify]\nvalue_col = "left_wall_mm"\n'
    )
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert "tracked tables" not in err  # with the scale it is a column (this video has no dye: exit 1 from tracking)


def test_a_mistake_in_a_stages_scenario_names_the_scenario_file(tmp_path, run_cli):
    # '[compare].methods has unknown method' sent the user to the pipeline's own [compare] table (which has no such
    # key), and the suggestion for 'zdv' was 'zv', not 'zvd' (a trial)
    scenario = (ROOT / "data" / "scenarios" / "paper_1d.toml").read_text() + '\n[compare]\nmethods = ["zdv"]\n'
    _write(tmp_path / "move.toml", scenario)
    pipe = _write(tmp_path / "p.toml", '[compare]\nscenario = "move.toml"\nuse_identified = false\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and f"scenario {tmp_path / 'move.toml'}: " in err and "(did you mean 'zvd'?)" in err
    assert not (tmp_path / "runs").exists()


def test_a_driven_signal_in_a_pipeline_names_the_pipelines_keys(tmp_path, run_cli):
    # the identify stage told a pipeline user to run `sloshid track --reference container`: it names the pipeline's
    # [identify].window_s and [track] reference key as well now
    from sloshid.synthetic.decays import free_decay

    t, ringing = free_decay(3.0, 0.005, 60, amplitude=5, seed=2)
    sway = tmp_path / "sway.csv"
    np.savetxt(sway, np.c_[t, ringing + 3 * np.sin(2 * np.pi * 0.4 * t)], delimiter=",", header="t_s,angle_deg",
               comments="")  # fmt: skip
    pipe = _write(tmp_path / "p.toml", f'[identify]\nsignals = ["{sway.as_posix()}"]\n')
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code != 0
    text = out + err
    assert "[identify].window_s" in text and 'reference = "container" in a pipeline\'s [track]' in text


def test_the_index_says_whether_joint_signals_agree_and_keeps_fs_digits(tmp_path, run_cli):
    # two signals of different liquids (3.0 and 3.3 Hz): the JSON said they disagree, the pipeline index did not; and
    # the index's table showed 4 significant digits, as the identify report did (1.9996 read 2)
    from sloshid.synthetic.decays import free_decay

    files = []
    for f, seed in ((3.0, 1), (3.3, 2)):
        t, y = free_decay(f, 0.03, 100, amplitude=5, seed=seed)
        files.append(
            _write(tmp_path / f"s{seed}.csv", "t_s,angle_deg\n" + "".join(f"{a:.3f},{b:.6g}\n" for a, b in zip(t, y)))
        )
    pipe = _write(tmp_path / "p.toml", f"[identify]\nsignals = {[str(p) for p in files]}\n".replace("'", '"'))
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert code == 0, err
    run_dir = Path(out.strip()).parent
    page = (run_dir / "index.html").read_text()
    assert "Signals fitted alone: f 3.001-3.301 Hz" in page and "f disagree" in page
    f = json.loads((run_dir / "manifest.json").read_text())["stages"][0]["summary"]["parameters"]["f_hz"]
    from sloshid.identification.estimates import shown_with_error

    assert f"<td>{shown_with_error(f['value'], f['stderr'])}</td>" in page
    # each reason is a sentence: they were joined as "...stays linear.; RD_3D..."
    reasons = json.loads((run_dir / "identify" / "params.json").read_text())["reasons"]
    assert len(reasons) > 1 and "Verdict: uncertain. " + html.escape(" ".join(reasons)) in page and ".;" not in page


@pytest.mark.parametrize("name", ["upright_move", "tilt_margin_move"])
def test_a_pipeline_plans_and_compares_a_move_within_a_spill_margin(tmp_path, run_cli, name):
    # upright and tilting moves within a spill margin: plan, compare (ranked by risk) and the index, like a tilting one
    # 100 Monte-Carlo draws (the least [risk].draws takes): no check here reads a risk's value, only that the
    # scenario's number of draws reaches the ranking
    text = (ROOT / "data" / "scenarios" / f"{name}.toml").read_text().replace("draws = 1000", "draws = 100")
    # one point of each sensitivity study (the full sweeps are the comparison's minutes): every path still runs
    studies = "omega_factors = [1.0]\nzeta_factors = [1.0]\ncamera_fps_sweep = [30.0]\nlinearity_acc_m_s2 = [0.5]\n"
    _write(tmp_path / "move.toml", f"{text}\n[compare]\n{studies}")
    pipe = _write(
        tmp_path / "p.toml",
        '[plan]\nscenario = "move.toml"\nuse_identified = false\n\n'
        '[compare]\nscenario = "move.toml"\nuse_identified = false\nrobust_samples = 0\n',
    )
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs", "--quiet")
    assert code == 0, err
    index = Path(out.strip())
    run_dir = index.parent
    assert _statuses(run_dir) == {"plan": "ran", "compare": "ran"}
    stages = {s["name"]: s["summary"] for s in json.loads((run_dir / "manifest.json").read_text())["stages"]}
    plan, compare = stages["plan"], stages["compare"]
    assert plan["kind"] == ("upright" if name == "upright_move" else "tilt_margin") and plan["verification_ok"]
    assert plan["containers"][0]["peak_wall_mm"] <= 8.0 and plan["T_s"] < 2.11
    assert compare["recommended"]["csv"] == "recommended.csv" and (run_dir / "compare" / "recommended.csv").exists()
    described = json.loads((run_dir / "compare" / "recommended.json").read_text())  # as for a slosh-free move
    assert described["method"] == compare["recommended"]["method"] and described["reason"] == compare["verdict"]
    ours = next(r for r in compare["ranked"] if r["key"] == "sloshid")
    assert ours["meets_margin_and_residual"] and ours["risk"]["draws"] == 100
    assert {r["key"] for r in compare["ranked"]} >= {"zv", "zvd", "zvdd", "constant_acc", "sloshid"}
    page = index.read_text()
    assert "Recommended: " in page and "peak wall (mm)" in page and "Overall: plan verified" in page
    _links_exist(index)


def test_a_bad_robust_samples_key_is_refused_before_anything_runs(tmp_path, run_cli):
    scenario = ROOT / "data" / "scenarios" / "upright_move.toml"
    pipe = _write(tmp_path / "p.toml", f'[compare]\nscenario = "{scenario}"\nrobust_samples = -1\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and "[compare].robust_samples must lie in 0..200 (0: no robust plan), got -1." in err
    assert err.count("\n") == 1 and not (tmp_path / "runs").exists()


def test_run_sends_the_plan_slowed_for_the_scenarios_arm(tmp_path, run_cli):
    # paper_1d names a Panda, whose joint 5 cannot follow the fastest plan (`plan --joints` exits 1): run said "send
    # to the robot: .../plan/trajectory.csv", then why not; it now writes the plan re-planned slower until the arm
    # can follow it, as `plan --joints --fit-joints` does, and its joints beside it
    from sloshid.model.trajectory import Trajectory
    from sloshid.planning.arm import check_joints
    from sloshid.planning.scenario import load_scenario

    scenario = ROOT / "data" / "scenarios" / "paper_1d.toml"
    pipe = _write(tmp_path / "p.toml", f'[plan]\nscenario = "{scenario.as_posix()}"\nuse_identified = false\n')
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 0, err
    run_dir = Path(out.strip()).parent
    plan = json.loads((run_dir / "manifest.json").read_text())["stages"][0]["summary"]
    fit = plan["arm_fit"]
    assert fit["follows"] and fit["slowed"] and plan["arm"] is None and plan["joints"]["executable"]
    move, joints = run_dir / "plan" / "trajectory.csv", run_dir / "plan" / "trajectory_joints.csv"
    line = err.strip().splitlines()[-1]
    assert line == (
        f"next: send {move} (or the joints, {joints}) to the robot (the nominal plan (not compared with the "
        f"alternatives, slowed for the arm from {fit['transfer_time_first_s']:.3f} s)); open:"
    )
    sent = Trajectory.from_csv(move)
    assert check_joints(sent, load_scenario(scenario).arm).executable and joints.exists()
    # `plan --joints --fit-joints` writes the same move: one transfer time, to a sample (1 ms)
    code, _, err = run_cli("plan", scenario, "-o", tmp_path / "t.csv", "--joints", tmp_path / "q.csv", "--fit-joints")
    assert code == 0, err
    assert abs(Trajectory.from_csv(tmp_path / "t.csv").duration_s - sent.duration_s) <= 1e-3
    assert abs(plan["T_s"] - sent.duration_s) <= 1e-3 and sent.duration_s > fit["transfer_time_first_s"]
    page = (run_dir / "index.html").read_text()
    assert "Send to the robot" in page and 'href="plan/trajectory_joints.csv"' in page


def test_run_with_fit_joints_false_does_not_say_send_a_plan_the_scenarios_arm_cannot_follow(tmp_path, run_cli):
    # [robot] fit_joints = false keeps the fastest plan, and says why not to send it and what fits one
    text = (ROOT / "data" / "scenarios" / "paper_1d.toml").read_text()
    scenario = _write(tmp_path / "move.toml", text.replace('model = "panda"', 'model = "panda"\nfit_joints = false'))
    pipe = _write(tmp_path / "p.toml", '[plan]\nscenario = "move.toml"\nuse_identified = false\n')
    code, out, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 0, err
    run_dir = Path(out.strip()).parent
    fit = f"`sloshid plan {scenario} -o TRAJ.csv --joints TRAJ_joints.csv --fit-joints`"
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"next: do not send {run_dir / 'plan' / 'trajectory.csv'} to the robot (the nominal plan")
    assert "the Panda of [robot] cannot follow it (joint 5 exceeds its acceleration limit" in line and fit in line
    assert not (run_dir / "plan" / "trajectory_joints.csv").exists()
    page = (run_dir / "index.html").read_text()
    assert "Send to the robot" not in page and "to the robot: the Panda of [robot] cannot follow it" in page


def test_run_refuses_a_container_of_no_radius_before_its_first_stage(tmp_path, run_cli):
    # "stage [plan] failed: unexpected error: ZeroDivisionError" after the stages before it had run
    text = (ROOT / "data" / "scenarios" / "upright_move.toml").read_text()
    _write(tmp_path / "move.toml", text.replace("radius_m = 0.04 ", "radius_m = 0 "))
    pipe = _write(tmp_path / "p.toml", '[plan]\nscenario = "move.toml"\nuse_identified = false\n')
    code, _, err = run_cli("run", pipe, "--output-dir", tmp_path / "runs")
    assert code == 2 and "[container].radius_m must lie in (0, 1] m for a move within a spill margin" in err
    assert err.count("\n") == 1 and not (tmp_path / "runs").exists()
