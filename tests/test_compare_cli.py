"""`sloshid compare` end to end: report content, JSON keys, not-applicable rows, and every bad input named in issue 5."""

from __future__ import annotations

import json
import re
from html import escape as html_escape

import pytest

from sloshid.core.errors import UserError
from sloshid.core.tables import read_csv
from sloshid.model.trajectory import Trajectory

SCENARIO = """
[move]
start = [0.3, 0.0, 0.2]
goal = [0.4, 0.0, 0.2]
[limits]
acc_max = [0.5, 0.5, 0.5]
[liquid]
m_kg = 0.5
l_m = 0.021
d_ns_per_m = 1.51
[solver]
N = 50
{solver}
[compare]
methods = {methods}
omega_factors = [0.9, 1.1]
zeta_factors = [1.0]
camera_fps_sweep = [30]
linearity_acc_m_s2 = [0.5]
settle_s = 0.7
workers = 1
{extra}
[compare.feedback]
settle_s = 1.5
"""


def write_scenario(tmp_path, methods='["constant_acc", "zvd", "sloshid"]', solver="", extra=""):
    """A short 0.1 m move along x (fast to simulate) with a reduced [compare] table."""
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO.format(methods=methods, solver=solver, extra=extra))
    return path


@pytest.mark.slow
def test_report_and_json_carry_every_method_and_the_verdict(tmp_path, run_cli):
    path = write_scenario(tmp_path, methods='["constant_acc", "zvd", "sloshid", "constant_acc_feedback"]')
    report = tmp_path / "rep"
    code, out, err = run_cli("compare", path, "--report", report, "--json")
    assert code == 0, err
    summary = json.loads(out)
    rows = {m["method"]: m for m in summary["methods"]}
    assert list(rows) == ["constant_acc", "zvd", "sloshid", "constant_acc_feedback"]
    for key in (
        "transfer_time_s",
        "peak_during_deg",
        "residual_deg",
        "peak_tilt_deg",
        "peak_tilt_rate_deg_s",
        "robot_limits_ok",
        "move_limits_ok",
    ):
        assert all(key in m for m in rows.values())
    # the physics the report must show: the plan is the fastest slosh-free move, the unshaped one sloshes
    assert rows["sloshid"]["residual_deg"] < 0.05 and rows["constant_acc"]["residual_deg"] > 1.0
    assert rows["sloshid"]["transfer_time_s"] < rows["zvd"]["transfer_time_s"]
    # the headline is the recommendation over the nominal frequency +-5 % (no identified interval here): the nominal
    # plan tolerates no frequency error and ZVD's acceleration steps break the move's own jerk limit ([limits]
    # jerk_max, 100 m/s^3 by default, which the plan holds), so none qualifies
    rec = summary["recommendation"]
    assert rec["band_hz"] == pytest.approx([summary["liquid"]["f_hz"] * 0.95, summary["liquid"]["f_hz"] * 1.05])
    assert rec["method"] is None and rec["risk"] == "unreliable"
    assert summary["verdict"].startswith("No method stays slosh-free")
    assert "sloshid plan leaves" in rec["reason"] and "ZVD shaped breaks a limit (move jerk_max" in rec["reason"]
    assert not rows["zvd"]["move_limits_ok"] and rows["sloshid"]["move_limits_ok"]
    assert max(rec["checks"]["sloshid"]["residual_deg"]) > 0.5
    html = (report / "index.html").read_text()
    for text in (
        "Relative slosh angle over time",
        "Scores",
        "Closed loop",
        "Robustness to model error",
        "camera rate",
        "ZVD shaped",
        "constant acceleration + feedback",
        html_escape(summary["verdict"][:40]),
        "verdict-" + rec["risk"],
    ):
        assert text in html
    # Fig. 7, closed loop, robustness, camera; the linearity study has one acceleration here: a table, no plot
    assert len(re.findall(r"<img ", html)) == 4


def test_a_method_that_cannot_be_built_is_reported_not_applicable(tmp_path, run_cli):
    # two IPOPT iterations cannot converge: the planner raises, the comparison goes on without it
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid", "sloshid_feedback"]', solver="max_iter = 2")
    code, out, err = run_cli("compare", path, "--json")
    assert code == 0, err
    rows = {m["method"]: m for m in json.loads(out)["methods"]}
    assert rows["constant_acc"]["applicable"]
    assert not rows["sloshid"]["applicable"] and "did not converge" in rows["sloshid"]["reason"]
    assert not rows["sloshid_feedback"]["applicable"] and "not applicable" in rows["sloshid_feedback"]["reason"]
    code, table, err = run_cli("compare", path)
    assert code == 0, err
    assert re.search(r"sloshid plan\s+not applicable", table)  # the plain table too


@pytest.mark.parametrize(
    "extra, message",
    [
        ("jerk_max = 2.0", "unknown key '[compare].jerk_max' (did you mean 'jerk_max_m_s3'?)"),
        ('residual_ok_deg = "small"', "[compare].residual_ok_deg must be a number"),
        ("robust_omega_factors = []", "[compare].robust_omega_factors must be a non-empty list"),
        ("robot_bandwidth_hz = 0.0", "[compare].robot_bandwidth_hz must be positive"),
        (f"robust_omega_factors = {[1.0] * 10}", "[compare].robust_omega_factors holds 10 factors; at most 9"),
    ],
)
def test_bad_compare_table_is_one_sentence_and_writes_nothing(tmp_path, run_cli, extra, message):
    path = write_scenario(tmp_path, extra=extra)
    report = tmp_path / "rep"
    code, out, err = run_cli("compare", path, "--report", report)
    assert code == 2 and message in err and err.count("\n") == 1 and out == ""
    assert not report.exists()


def test_when_no_method_applies_the_recommendation_says_so(tmp_path, run_cli):
    # TOPP-RA alone on a [move] scenario: "No method stays slosh-free (...) over 2.88-3.18 Hz (...): ." was printed
    code, out, err = run_cli("compare", write_scenario(tmp_path, methods='["toppra"]'))
    assert code == 0, err
    assert "No method of [compare].methods applies to this scenario" in out and "): ." not in out


def test_writing_the_recommended_move_when_none_is_recommended_says_why(tmp_path, run_cli):
    # write_recommended returned None and wrote nothing without a word: the README's chain went on with no move
    import sloshid

    path = write_scenario(tmp_path, methods='["toppra"]')
    move = tmp_path / "move.csv"
    with pytest.raises(UserError, match=r"move\.csv was not written, as no method is recommended: no method of") as e:
        sloshid.compare(path).write_recommended(move)
    assert "\n" not in str(e.value) and not move.exists() and not move.with_suffix(".json").exists()
    # compare -o says so in its next line, and exits 1: `compare -o move.csv && send move.csv` must stop
    code, out, err = run_cli("compare", path, "-o", move)
    assert code == 1 and "next: no method is recommended" in out and not move.exists(), err
    assert err.endswith("sloshid: no method is recommended, so nothing was written.\n")
    # a move already there (an older comparison's) is left as it was, and said to be no move of this one
    move.write_text("old\n")
    code, out, err = run_cli("compare", path, "-o", move)
    assert code == 1 and move.read_text() == "old\n" and not move.with_suffix(".json").exists()
    assert f"nothing was written; {move} was left as it was, not this comparison's move." in err


def test_writing_the_recommended_move_never_replaces_a_json_sloshid_did_not_write(tmp_path):
    # write_recommended("rec.csv") replaced the user's rec.json with the move's description
    import sloshid

    comparison = sloshid.compare(write_scenario(tmp_path, methods='["constant_acc", "sloshid_robust"]'))
    assert comparison.recommended is not None
    mine = tmp_path / "rec.json"
    mine.write_text('{"mine": 1}')
    with pytest.raises(UserError, match=r"rec\.json is already there and sloshid did not write it; write the move"):
        comparison.write_recommended(tmp_path / "rec.csv")
    assert mine.read_text() == '{"mine": 1}' and not (tmp_path / "rec.csv").exists()
    mine.unlink()
    comparison.write_recommended(tmp_path / "rec.csv")
    comparison.write_recommended(tmp_path / "rec.csv")  # its own description is replaced
    assert json.loads(mine.read_text())["trajectory_csv"] == "rec.csv"


@pytest.mark.parametrize(
    "edit, message",
    [
        # printed as "the band 5-1 Hz" while another band was used
        (lambda f: f.__setitem__("ci95", [5, 1]), "parameters.f_hz.ci95 must be two positive numbers, low first"),
        (lambda f: f.__setitem__("value", -3.4), "parameters.f_hz.value -3.4 is not the frequency"),
        (lambda f: f.__setitem__("value", "3.4"), "parameters.f_hz.value '3.4' is not the frequency"),
    ],
)
def test_an_edited_parameter_file_is_refused(tmp_path, run_cli, edit, message):
    from sloshid.model.pendulum import TABLE_I

    f_hz = TABLE_I.f_hz
    section = {"value": f_hz, "ci95": [0.99 * f_hz, 1.01 * f_hz], "quality": "good"}
    edit(section)
    params = {"omega_rad_s": {"value": TABLE_I.omega_rad_s}, "zeta": {"value": TABLE_I.zeta}, "f_hz": section}
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"parameters": params}))
    code, out, err = run_cli("compare", write_scenario(tmp_path), "--params", path)
    assert code == 2 and message in err and err.count("\n") == 1 and out == ""


def test_a_settling_time_of_terabytes_is_refused():
    # [compare] settle_s = 1e9 asked simulate_liquid for 7 TiB of samples: a traceback
    from sloshid.comparison.compare import CompareSettings

    with pytest.raises(UserError, match=r"\[compare\]\.settle_s must be at most 600 s"):
        CompareSettings(settle_s=1e9)
    # a NaN passed a check on the list's minimum (a TOML file's is refused as it is read); 10,001 study frequencies
    # ran on without a word
    with pytest.raises(UserError, match=r"\[compare\]\.zeta_factors must be a non-empty list of positive numbers"):
        CompareSettings(zeta_factors=[float("nan")])
    with pytest.raises(UserError, match=r"\[compare\]\.omega_factors holds 10001 values; at most 201"):
        CompareSettings(omega_factors=[1.0 + k * 1e-4 for k in range(10001)])


def test_bad_method_name_suggests_the_right_one(tmp_path, run_cli):
    path = write_scenario(tmp_path, methods='["constant_acc", "contant_acc_feedback"]')
    code, _, err = run_cli("compare", path)
    assert code == 2 and "unknown method 'contant_acc_feedback'" in err
    assert "did you mean 'constant_acc_feedback'" in err


def test_bad_files_and_options(tmp_path, run_cli):
    report = tmp_path / "rep"
    code, _, err = run_cli("compare", tmp_path / "missing.toml", "--report", report)
    assert code == 2 and "does not exist" in err and not report.exists()
    path = write_scenario(tmp_path)
    bad_params = tmp_path / "p.json"
    bad_params.write_text("{not json")
    code, _, err = run_cli("compare", path, "--params", bad_params, "--report", report)
    assert code == 2 and "not valid JSON" in err and not report.exists()
    code, _, err = run_cli("compare", path, "--report", tmp_path / "out.html")
    assert code == 2 and "--report takes a directory" in err and not (tmp_path / "out.html").exists()
    code, _, err = run_cli("compare", path, "--report", bad_params)  # an existing file, not a directory
    assert code == 2 and "--report takes a directory" in err and bad_params.read_text() == "{not json"
    broken = tmp_path / "broken.toml"
    broken.write_text("[move\nstart = 1")
    code, _, err = run_cli("compare", broken)
    assert code == 2 and "not valid TOML" in err


def test_a_method_that_collides_reads_collide_in_the_table(tmp_path, run_cli):
    # the table said "ok" in the limits column for a straight move through an obstacle (min clearance -0.08 m); only
    # the HTML report flagged it
    extra = "[[obstacles]]\ncenter = [0.35, 0.0, 0.2]\nradius = 0.01\n[container]\nradius_m = 0.005\n"
    path = tmp_path / "scenario.toml"
    path.write_text(
        SCENARIO.format(methods='["constant_acc"]', solver="", extra="").replace("[solver]", extra + "[solver]")
    )
    code, out, err = run_cli("compare", path)
    assert code == 0, err
    row = next(line for line in out.splitlines() if line.startswith("constant acceleration"))
    assert row.split()[-1] == "COLLIDE"
    assert "collides with an obstacle: constant acceleration" in out


def test_compare_shows_its_progress_on_a_terminal_and_ends_with_the_next_step(tmp_path, run_cli, stderr_as):
    # issue 39: compare ran for minutes without a word; a bar counts its methods and studies on a terminal
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid_robust"]')  # the robust plan is recommended
    err = stderr_as(terminal=True)
    code, out, _ = run_cli("compare", path, "-o", tmp_path / "move.csv", "--report", tmp_path / "rep")
    assert code == 0
    assert "compare" in err.getvalue() and "robustness" in err.getvalue()  # the bar and its study names
    assert "sloshid compare: figures" in err.getvalue()  # and the report's figures, seconds of drawing
    last = out.strip().splitlines()[-1]
    recommended = json.loads((tmp_path / "move.json").read_text())
    # a scenario without [robot]: the move alone, as before, with no joints and no word of an arm
    assert (
        last
        == f"next: send {tmp_path / 'move.csv'} to the robot ({recommended['label']}; {tmp_path / 'move.json'} says why)."
    )
    assert recommended["arm_fit"] is None and recommended["joints_csv"] is None
    assert not (tmp_path / "move_joints.csv").exists() and "Panda" not in out


@pytest.mark.parametrize("fit_joints", [None, False], ids=["fitted", "fit_joints_false"])
def test_compare_sends_a_move_the_scenarios_arm_can_follow(tmp_path, run_cli, fit_joints):
    # the scenario's Panda was ignored: compare said "next: send move.csv to the robot" for a move whose joint
    # accelerations the arm cannot follow (`plan --joints` refused it, exit 1); then it said not to send it. It now
    # sends the robust plan re-planned slower for the arm, with its joints, unless [robot] fit_joints = false
    from sloshid.planning.arm import check_joints
    from sloshid.planning.scenario import load_scenario

    arm = '[robot]\nmodel = "panda"\ntool_offset_m = [0.0, 0.0, 0.1]\n'
    arm += "q_start = [-0.2601, -0.2369, -0.4947, -2.6876, -0.1801, 2.4704, 0.184]\n"
    arm += "fit_joints = false\n" if fit_joints is False else ""
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid_robust"]', extra=arm)
    move, joints = tmp_path / "move.csv", tmp_path / "move_joints.csv"
    code, out, err = run_cli("compare", path, "-o", move)
    assert code == 0, err
    last = out.strip().splitlines()[-1]
    described = json.loads((tmp_path / "move.json").read_text())
    if fit_joints is False:  # as before: the fastest slosh-free move, which the arm cannot follow
        fit = f"sloshid plan {path} --robust -o TRAJ.csv --joints TRAJ_joints.csv --fit-joints"
        assert last.startswith(f"next: do not send {move} (sloshid robust plan): the Panda of [robot]")
        assert f"`{fit}` plans sloshid's move slower" in last and "to the robot" not in last
        assert described["arm_fit"] is None and not joints.exists() and "slowed for the arm " not in out
        return
    fitted = described["arm_fit"]
    assert fitted["follows"] and fitted["slowed"] and fitted["transfer_time_s"] > fitted["transfer_time_first_s"]
    assert last == (
        f"next: send {move} (or the joints, {joints}) to the robot (sloshid robust plan, slowed for the arm from "
        f"{fitted['transfer_time_first_s']:.3f} s; {tmp_path / 'move.json'} says why)."
    )
    sent = Trajectory.from_csv(move)
    assert check_joints(sent, load_scenario(path).arm).executable and joints.exists()
    assert (
        f"Slowed for the Panda of [robot] from {fitted['transfer_time_first_s']:.3f} to {sent.duration_s:.3f} s" in out
    )
    # the score table shows the move sent under the robust plan at full speed, not the full speed's time alone
    table = out.split("\n\n")[0].splitlines()
    at = next(i for i, line in enumerate(table) if line.startswith("sloshid robust plan, slowed for the arm "))
    cells = table[at].removeprefix("sloshid robust plan, slowed for the arm").split()  # T, peak, residual, -, -
    assert cells[0] == f"{sent.duration_s:.3f}" and cells[3:] == ["-", "-"]
    full = table[at - 1].removeprefix("sloshid robust plan ").split()
    assert full[0] == f"{fitted['transfer_time_first_s']:.3f}"


def test_compare_says_not_to_send_a_move_no_slower_plan_fits_to_the_arm(tmp_path, run_cli):
    # a goal 1.2 m away is out of the Panda's reach: no timing fixes that, so the fastest slosh-free move is written
    # as before and the line says not to send it, and why
    arm = '[robot]\nmodel = "panda"\ntool_offset_m = [0.0, 0.0, 0.1]\n'
    arm += "q_start = [-0.2601, -0.2369, -0.4947, -2.6876, -0.1801, 2.4704, 0.184]\n"
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid_robust"]', extra=arm)
    path.write_text(path.read_text().replace("goal = [0.4, 0.0, 0.2]", "goal = [1.5, 0.0, 0.2]"))
    move = tmp_path / "move.csv"
    code, out, err = run_cli("compare", path, "-o", move)
    assert code == 0, err
    last = out.strip().splitlines()[-1]
    assert re.match(
        rf"next: do not send {re.escape(str(move))} \(sloshid robust plan\): the pose at .* out of the", last
    )
    described = json.loads((tmp_path / "move.json").read_text())
    fit = described["arm_fit"]
    assert not fit["follows"] and not fit["slowed"] and "out of the Panda's reach" in fit["reason"]
    assert described["joints_csv"] is None and not (tmp_path / "move_joints.csv").exists()
    assert described["transfer_time_s"] == fit["transfer_time_first_s"] == fit["transfer_time_s"]


@pytest.mark.parametrize(
    ("parameters", "sent"),
    [
        ({"omega_rad_s": 19.04, "zeta": 0.05, "wave_share": 0.84, "crest_coeff": -0.16}, False),
        ({"omega_rad_s": 21.6, "zeta": 0.07, "wave_share": 0.72, "crest_coeff": 0.3}, True),
    ],
    ids=["deep", "shallow"],
)
def test_compare_does_not_send_a_move_the_whole_input_output_model_calls_sloshing(tmp_path, run_cli, parameters, sent):
    # compare scores with an input-output model's f and zeta alone; with the container's depth that model's whole
    # response moved the liquid by 2.3 deg in the recommended move (`predict` agrees), and compare said to send it.
    # Past the comparison's own slosh-free peak (1 deg) it now says not to; a model whose whole response stays within
    # it (0.002 deg here) is sent as before
    doc = {"parameters": {k: {"value": v} for k, v in parameters.items()}}
    if not sent:
        doc["geometry"] = {"container_radius_m": 0.049, "fill_height_m": 0.078}
    params, move = tmp_path / "io.json", tmp_path / "move.csv"
    params.write_text(json.dumps(doc))
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid", "sloshid_robust"]')
    code, out, err = run_cli("compare", path, "--params", params, "-o", move)
    assert code == 0, err
    last = out.strip().splitlines()[-1]
    code, _, err = run_cli("predict", move, "--params", params, "-o", tmp_path / "p.csv", "--container-radius-m", 0.05)
    assert code == 0, err
    peak = max(read_csv(tmp_path / "p.csv")["rel_angle_deg"])
    assert (peak <= 1.0) == sent, peak
    if sent:
        assert last.startswith(f"next: send {move} to the robot"), last
    else:
        assert last.startswith(f"next: do not send {move} (sloshid robust plan): by the whole model of {params}"), last
        assert (
            f"up to {peak:.2g} deg" in last
            and f"`sloshid predict {move} --params {params} -o {tmp_path / 'move_prediction.csv'}`" in last
        )


def test_compare_never_replaces_a_users_file_where_the_joints_would_go(tmp_path, run_cli):
    # with a [robot] arm compare writes TRAJ_joints.csv beside TRAJ.csv, a name the user did not give: a file there
    # that sloshid did not write is refused before any work (as TRAJ.json is, whether or not the scenario names an
    # arm: the outputs are checked before the fit says whether there are joints), and nothing is written
    path = write_scenario(tmp_path, methods='["constant_acc", "sloshid_robust"]')  # the robust plan is recommended
    mine = tmp_path / "move_joints.csv"
    mine.write_text("my own notes\n")
    code, _, err = run_cli("compare", path, "-o", tmp_path / "move.csv")
    assert code == 2 and "move_joints.csv is already there and sloshid did not write it" in err
    assert mine.read_text() == "my own notes\n" and not (tmp_path / "move.csv").exists()
    # one sloshid wrote (its header) is replaced as before
    mine.write_text("t_s,q1,q2,q3,q4,q5,q6,q7\n0,0,0,0,0,0,0,0\n")
    code, _, err = run_cli("compare", path, "-o", tmp_path / "move.csv")
    assert code == 0, err
