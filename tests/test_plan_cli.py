"""`sloshid plan` on the command line: a good run writes CSV, report and JSON; every bad input named in
issue 4 ends with one sentence, exit code 2 and no output file."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sloshid.core.tables import read_csv
from sloshid.model.trajectory import CSV_COLUMNS
from sloshid.planning import planner
from sloshid.planning.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
PAPER_1D = ROOT / "data" / "scenarios" / "paper_1d.toml"

BASE = """
[move]
start = [0.4, -0.15, 0.3]
goal = [0.4, 0.15, 0.3]
[limits]
acc_max = [0.5, 0.5, 0.5]
[container]
radius_m = 0.03
[solver]
N = 30
[liquid]
m_kg = 0.5
l_m = 0.021
d_ns_per_m = 1.51
"""


def _scenario(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def test_plan_writes_csv_report_and_json(run_cli, tmp_path):
    out = tmp_path / "traj.csv"
    code, stdout, stderr = run_cli("plan", PAPER_1D, "-o", out, "--report", tmp_path / "rep", "--json")
    assert code == 0, stderr
    summary = json.loads(stdout)
    for key in ("T_s", "solve_time_s", "iterations", "status", "max_tilt_deg", "max_tilt_rate_deg_s", "limits_ok"):
        assert key in summary
    assert summary["status"] == "Solve_Succeeded" and summary["limits_ok"] and summary["verification"]["ok"]
    assert summary["T_s"] <= 2.15 and len(summary["segments"]) == 1
    assert out.read_text().splitlines()[0].split(",") == list(CSV_COLUMNS)
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "seed Fig. 6" in html and "seed Fig. 9" in html and "Robot limits" in html
    assert "warning" not in stderr
    # the report says which liquid it planned for and where it came from, and links the trajectory it describes
    assert "Planned for the liquid f = 3.44 Hz, zeta = 0.0699" in html and "[liquid] table of" in html
    # the damping per mass, which the plan uses: a params file without a mass had d shown with an invented 1 kg
    assert "d/m = 3.02 1/s" in html and " kg)" not in html
    assert 'href="../traj.csv"' in html
    # every robot limit used above 90 % is named in the verdict (the 1-D plan runs at its jerk limit)
    for u in summary["limits"]:
        if 0.9 < u["usage"] <= 1.001:
            assert "reaches" in html, u


def test_plan_warns_and_exits_1_when_robot_limits_are_exceeded(run_cli, tmp_path):
    # the seed's piecewise-constant acceleration exceeds the Panda's angular acceleration: said, not hidden
    path = _scenario(tmp_path, BASE.replace("N = 30", "N = 30\njerk_limited = false"))
    code, stdout, stderr = run_cli("plan", path, "-o", tmp_path / "t.csv", "--json")
    # exit code 1, so that a script does not send it to the robot; the CSV is still written for inspection
    assert code == 1 and "warning: robot limit rot_acc_rad_s2 exceeded" in stderr
    assert json.loads(stdout)["limits_ok"] is False and (tmp_path / "t.csv").stat().st_size > 0
    # but never over a file already there (a trial's good plan was replaced by the failed one): kept, and said
    good = tmp_path / "good.csv"
    good.write_text("t_s,x_m\n0,0\n")
    code, _, stderr = run_cli("plan", path, "-o", good)
    assert code == 1 and good.read_text() == "t_s,x_m\n0,0\n"
    assert f"kept {good}: a plan that fails its checks does not replace a file already there" in stderr
    # nor a report already in the report folder, and then none of its files is written (no failed CSV beside a kept
    # report: a reviewer's pair of a failed trajectory and a good plan's joints)
    (tmp_path / "ok").mkdir()
    good_plan = _scenario(tmp_path / "ok", BASE)
    assert run_cli("plan", good_plan, "-o", tmp_path / "ok.csv", "--report", tmp_path / "rep")[0] == 0
    report = (tmp_path / "rep" / "index.html").read_text()
    code, _, stderr = run_cli("plan", path, "-o", tmp_path / "new.csv", "--report", tmp_path / "rep")
    assert code == 1 and (tmp_path / "rep" / "index.html").read_text() == report
    assert not (tmp_path / "new.csv").exists() and "index.html" in stderr


def test_a_plan_for_an_input_output_model_says_how_far_that_model_moves_the_liquid(run_cli, tmp_path):
    # plan uses an input-output model's f and zeta alone; its note quoted a fixed figure from another user's plan.
    # It gives this plan's own now, which `sloshid predict` on the written CSV confirms
    doc = {"parameters": {"omega_rad_s": {"value": 21.6}, "zeta": {"value": 0.07}}}
    doc["parameters"].update(wave_share={"value": 0.72}, crest_coeff={"value": 0.3})
    (tmp_path / "io.json").write_text(json.dumps(doc))
    code, plan_out, stderr = run_cli("plan", PAPER_1D, "--params", tmp_path / "io.json", "-o", tmp_path / "t.csv")
    assert code == 0, stderr
    quoted = re.search(r"this plan moves the liquid by up to ([0-9.e-]+) deg against the container", stderr)
    code, _, err = run_cli(
        "predict",
        tmp_path / "t.csv",
        "--params",
        tmp_path / "io.json",
        "-o",
        tmp_path / "p.csv",
        "--container-radius-m",
        0.05,
    )
    assert code == 0, err
    peak = read_csv(tmp_path / "p.csv")["rel_angle_deg"].max()
    # the note gives two digits; the physics-first model drives its pendulum with gains of 1, as the planner does, so a
    # plan slosh-free for the pair stays within 0.1 deg for the spherical pendulum (measured: 0.005 deg)
    assert peak < 0.1 and float(quoted.group(1)) == pytest.approx(peak, abs=0.006)
    # slosh-free by the whole model too: what holds it back is paper_1d's Panda, which cannot follow the fastest plan
    assert f"next: do not send {tmp_path / 't.csv'}: the Panda of [robot] cannot follow it" in plan_out


def test_a_plan_the_whole_input_output_model_calls_sloshing_is_not_sent(run_cli, tmp_path):
    # with the container's depth the whole model moved the liquid by 16 deg in the plan (its own note said so, predict
    # agreed), yet the next line said to send the plan to the robot
    doc = {"parameters": {"omega_rad_s": {"value": 19.04}, "zeta": {"value": 0.0032}}}
    doc["parameters"].update(wave_share={"value": 0.84}, crest_coeff={"value": -0.16})
    doc["geometry"] = {"container_radius_m": 0.049, "fill_height_m": 0.078}
    params, move = tmp_path / "io.json", tmp_path / "move.csv"
    params.write_text(json.dumps(doc))
    code, out, err = run_cli("plan", PAPER_1D, "--params", params, "-o", move)
    assert code == 0, err
    peak = float(re.search(r"this plan moves the liquid by up to ([0-9.e-]+) deg", err).group(1))
    step = out.strip().splitlines()[-1]
    assert peak > 1 and "to the robot" not in step
    assert step.startswith(f"next: do not send {move}: by the whole model of {params} it moves the liquid by up to ")
    assert f"check a move with `sloshid predict {move} --params {params} -o {tmp_path / 'move_prediction.csv'}`" in step


BAD = [
    (
        "goal inside obstacle",
        BASE + "[[obstacles]]\ncenter = [0.4, 0.17, 0.3]\nradius = 0.05\n",
        r"the goal \[0.4, 0.15, 0.3\] lies inside obstacle 1 \(sphere",
    ),
    (
        "waypoint inside obstacle",
        BASE.replace(
            "start = [0.4, -0.15, 0.3]\ngoal = [0.4, 0.15, 0.3]",
            "waypoints = [[0.4, -0.15, 0.3], [0.5, 0.0, 0.3], [0.4, 0.15, 0.3]]",
        )
        + "[[obstacles]]\nkind = 'cylinder'\ncenter = [0.52, 0.0]\nradius = 0.02\nz_range = [0.0, 0.4]\n",
        r"waypoint 1 \[0.5, 0.0, 0.3\] lies inside obstacle 1 \(cylinder",
    ),
    (
        "z outside range",
        BASE.replace("goal = [0.4, 0.15, 0.3]", "goal = [0.4, 0.15, 0.9]"),
        r"z = 0.9 m outside \[limits\].z_range \[0.05, 0.8\] m",
    ),
    (
        "too little time",
        BASE.replace("acc_max = [0.5, 0.5, 0.5]", "acc_max = [0.5, 0.5, 0.5]\nt_max_s = 0.5"),
        r"needs at least 1.55 s under \[limits\].acc_max and vel_max .* more than \[limits\].t_max_s = 0.5 s",
    ),
    (
        "solver does not converge",
        BASE.replace("N = 30", "N = 30\nmax_iter = 2"),
        r"did not converge on segment 1 .*IPOPT status Maximum_Iterations_Exceeded .*raise \[solver\].max_iter",
    ),
    (
        "infeasible tilt",
        BASE.replace("acc_max = [0.5, 0.5, 0.5]", "acc_max = [0.5, 0.5, 0.5]\ntilt_max_deg = 0.01\nt_max_s = 2"),
        r"did not converge on segment 1 .*IPOPT status .*relax \[limits\]",
    ),
    (
        "unknown key",
        BASE.replace("N = 30", "N = 30\nkapa_r = 0.1"),
        r"unknown key '\[solver\].kapa_r' \(did you mean 'kappa_r'\?\)",
    ),
    (
        "unknown table",
        BASE + "[limts]\nacc_max = [1, 1, 1]\n",
        r"unknown table '\[limts\]' \(did you mean 'limits'\?\)",
    ),
    ("wrong type", BASE.replace("radius_m = 0.03", "radius_m = 'big'"), r"\[container\].radius_m must be a number"),
    (
        "radius in millimetres",
        BASE.replace("radius_m = 0.03", "radius_m = 30"),
        r"\[container\].radius_m must lie in \[0, 1\] m \(metres, not millimetres\), got 30",
    ),
    ("pendulum of no length", BASE.replace("l_m = ", "l_m = 0 #"), r"\[liquid\].l_m must be positive, got 0"),
    ("malformed toml", "[move\nstart = 1", r"is not valid TOML"),
    (
        "start and waypoints",
        BASE.replace("goal = [0.4, 0.15, 0.3]", "goal = [0.4, 0.15, 0.3]\nwaypoints = [[0, 0, 0.3]]"),
        r"\[move\] takes either start and goal, or waypoints, not both",
    ),
    ("no liquid", BASE.split("[liquid]")[0], r"has no \[liquid\] table .* pass --params"),
]


@pytest.mark.parametrize("name, text, message", BAD, ids=[b[0] for b in BAD])
def test_bad_scenarios_fail_cleanly(run_cli, tmp_path, name, text, message):
    out = tmp_path / "traj.csv"
    code, _stdout, stderr = run_cli("plan", _scenario(tmp_path, text), "-o", out, "--report", tmp_path / "rep")
    assert code == 2
    assert stderr.startswith("sloshid: error: ") and stderr.count("\n") == 1
    assert re.search(message, stderr), stderr
    assert not out.exists() and not (tmp_path / "rep").exists()
    assert list(tmp_path.iterdir()) == [tmp_path / "scenario.toml"]  # no temporary leftovers either


@pytest.mark.parametrize(
    "content, message",
    [
        ("{not json", r"is not valid JSON"),
        (
            json.dumps({"parameters": {"omega_rad_s": {"value": 21.6}}}),
            r"lacks parameters.omega_rad_s.value and parameters.zeta.value",
        ),
        (
            json.dumps({"parameters": {"omega_rad_s": {"value": -3}, "zeta": {"value": 0.07}}}),
            r"omega_rad_s.value must be positive",
        ),
    ],
)
def test_bad_params_file_fails_cleanly(run_cli, tmp_path, content, message):
    params = tmp_path / "params.json"
    params.write_text(content)
    out = tmp_path / "traj.csv"
    code, _, stderr = run_cli("plan", PAPER_1D, "--params", params, "-o", out)
    assert code == 2 and re.search(message, stderr), stderr
    assert not out.exists()


def test_params_json_from_identify_overrides_the_scenario_liquid(run_cli, tmp_path):
    # a 2 Hz liquid instead of Table I's 3.44 Hz: slower sloshing costs a longer move
    params = tmp_path / "params.json"
    params.write_text(
        json.dumps(
            {
                "parameters": {
                    "omega_rad_s": {"value": 2 * 3.14159 * 2.0},
                    "zeta": {"value": 0.05},
                    "m_kg": {"value": 0.4},
                }
            }
        )
    )
    code, stdout, stderr = run_cli("plan", PAPER_1D, "--params", params, "-o", tmp_path / "t.csv", "--json")
    assert code == 0, stderr
    summary = json.loads(stdout)
    assert summary["liquid"]["f_hz"] == pytest.approx(2.0, rel=1e-4) and summary["verification"]["ok"]


def test_a_plan_past_the_scenarios_own_limits_says_so(run_cli, tmp_path, monkeypatch):
    # the solver holds [limits] at its grid points; a move riding vel_max = 0.1 m/s passed it by 4.8 % between them
    # (measured at N = 100) and the plan said "robot limits ok", limits_ok true, since only the robot's were checked.
    # The planner now re-plans such a move with the limit lowered: off here, to see what a passed limit reads like
    monkeypatch.setattr(planner, "LIMIT_TRIES", 0)
    sc = tmp_path / "slow.toml"
    sc.write_text(PAPER_1D.read_text().replace("vel_max = [1.7, 1.7, 1.7]", "vel_max = [0.1, 0.1, 0.1]"))
    code, out, err = run_cli("plan", sc, "-o", tmp_path / "t.csv", "--json")
    assert code == 1  # past a limit: not for a script to run
    summary = json.loads(out)
    vel = next(u for u in summary["move_limits"] if u["quantity"] == "vel_max")
    peak = np.abs(read_csv(tmp_path / "t.csv")["vy_m_s"]).max()
    assert vel["peak"] == pytest.approx(peak) and 0.1001 < peak < 0.11 and not vel["ok"]
    assert not summary["limits_ok"] and "[limits].vel_max exceeded" in err
    assert all(u["ok"] for u in summary["limits"])  # the robot's own limits hold


def test_a_limit_passed_between_grid_points_is_planned_again_lower(run_cli, tmp_path):
    # tilt_max_deg = 1 on the seed's move: the first solve's 1 kHz trajectory tilted 1.08 deg, and the advice to
    # raise [solver].N did not help (N = 400: 1.002 deg); the planner now solves again with the limit lowered
    sc = tmp_path / "tilt1.toml"
    sc.write_text(PAPER_1D.read_text().replace("tilt_max_deg = 30", "tilt_max_deg = 1"))
    code, out, err = run_cli("plan", sc, "-o", tmp_path / "t.csv", "--json")
    assert code == 0, err
    summary = json.loads(out)
    tilt = next(u for u in summary["move_limits"] if u["quantity"] == "tilt_max_deg")
    assert tilt["limit"] == 1.0 and tilt["ok"] and summary["max_tilt_deg"] <= 1.001  # the user's limit, held
    assert 0.85 < summary["limits_lowered_for_solver"]["[limits].tilt_max_deg"] < 1.0
    first = planner._plan_free(load_scenario(sc), load_scenario(sc).liquid, None, False, None)
    assert first.max_tilt_deg > 1.05  # without the second solve it was passed


def test_suggested_commands_run_as_printed_with_a_space_in_a_path():
    # `sloshid predict my runs/move.csv --params ...` and `sloshid plan my scenarios/a.toml ...` split a path in two
    # in a shell; the commands are quoted now, as track's and synth's next lines are
    import shlex

    from sloshid.cli.plan_cmd import fit_command, predict_command

    line = predict_command("my runs/move.csv", "liquid params.json").strip("`")
    assert shlex.split(line) == [
        "sloshid", "predict", "my runs/move.csv", "--params", "liquid params.json", "-o", "my runs/move_prediction.csv"
    ]  # fmt: skip
    line = fit_command("my scenarios/a.toml", "p q.json", True, "out dir/T.csv")
    assert shlex.split(line)[2:] == [
        "my scenarios/a.toml", "--params", "p q.json", "--robust", "-o", "out dir/T.csv",
        "--joints", "out dir/T_joints.csv", "--fit-joints",
    ]  # fmt: skip
