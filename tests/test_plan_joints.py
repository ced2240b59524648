"""Joint-space feasibility on the Franka Panda (issue 13, part 2): IK at 1 kHz whose forward kinematics (an
independent pinocchio model built here from the URDF) reproduces the trajectory, the datasheet check, the
re-planning that fits the joint limits, and the bad inputs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.core.tables import read_csv
from sloshid.model.trajectory import Trajectory
from sloshid.planning.arm import (
    PANDA_DQ_MAX,
    PANDA_Q_MAX,
    PANDA_Q_MIN,
    ArmSettings,
    _urdf_path,
    check_joints,
)

ROOT = Path(__file__).resolve().parents[1]
PAPER_1D = ROOT / "data" / "scenarios" / "paper_1d.toml"


@pytest.fixture(scope="module")
def joints_run(tmp_path_factory):
    """`sloshid plan paper_1d.toml --joints` (the arm cannot follow the fastest plan: exit 1, files written)."""
    import contextlib
    import io

    from sloshid.cli.app import main

    out = tmp_path_factory.mktemp("joints")
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["plan", str(PAPER_1D), "-o", str(out / "t.csv"), "--joints", str(out / "q.csv"), "--json"])
    (out / "summary.json").write_text(stdout.getvalue())
    (out / "stderr.txt").write_text(stderr.getvalue())
    return code, out


def _fk(q: np.ndarray, settings: ArmSettings) -> tuple[np.ndarray, np.ndarray]:
    """Liquid surface centre and container axis by pinocchio from the URDF (independent of sloshid.planning.arm)."""
    import pinocchio as pin
    from scipy.spatial.transform import Rotation

    full = pin.buildModelFromUrdf(_urdf_path())
    model = pin.buildReducedModel(full, [8, 9], pin.neutral(full))  # lock the two finger joints
    data = model.createData()
    base_R = Rotation.from_euler("xyz", settings.base_rpy_deg, degrees=True).as_matrix()
    pos, axis = [], []
    for qi in q:
        pin.framesForwardKinematics(model, data, qi)
        M = data.oMf[model.getFrameId("panda_link8")]
        R = base_R @ M.rotation
        pos.append(np.asarray(settings.base_xyz_m) + base_R @ M.translation + R @ np.asarray(settings.tool_offset_m))
        axis.append(-R[:, 2])  # the flange points down onto the upright container
    return np.array(pos), np.array(axis)


def test_forward_kinematics_of_the_written_joints_reproduces_the_trajectory(joints_run):
    from sloshid.planning.scenario import load_scenario

    code, out = joints_run
    assert code == 1  # the seed case's tilt accelerates faster than joint 5 can: reported, files still there
    traj = Trajectory.from_csv(out / "t.csv")
    table = read_csv(out / "q.csv")
    assert list(table) == ["t_s", *(f"q{j}" for j in range(1, 8))]
    q = np.column_stack([table[f"q{j}"] for j in range(1, 8)])
    assert np.allclose(table["t_s"], traj.t_s)
    settings = load_scenario(PAPER_1D).arm
    assert q[0] == pytest.approx(settings.q_start, abs=1e-3)  # continuous from q_start
    pos, axis = _fk(q, settings)
    assert np.linalg.norm(pos - traj.pos_m, axis=1).max() < 0.5e-3
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", axis, traj.z_axis), -1, 1)))
    assert angle.max() < 0.05
    # no jumps: every joint step stays below the datasheet speed times the sample period
    assert (np.abs(np.diff(q, axis=0)) <= PANDA_DQ_MAX * 1e-3).all()


def test_not_executable_names_the_joint_and_the_json_gives_margins(joints_run):
    _code, out = joints_run
    d = json.loads((out / "summary.json").read_text())["joints"]
    stderr = (out / "stderr.txt").read_text()
    assert not d["executable"]
    reason = d["reason"]
    assert reason.startswith("joint ") and "acceleration limit" in reason and reason.rstrip(".") in stderr
    # and what fitting would cost, measured (issue 39): the fitted plan's T, +3.5 % on this move
    assert "not executable on the Panda" in stderr and "--fit-joints (or [robot] fit_joints = true)" in stderr
    assert re.search(r"T 2\.131 -> 2\.\d+ s \(\+\d+\.\d %\)", stderr)
    assert d["worst"]["joint"] == int(reason.split()[1]) and d["worst"]["margin"] < 0
    quantities = {u["quantity"] for u in d["limits"]}
    assert quantities == {"position_rad", "velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3"}
    assert all("margin" in u and "t_s" in u and 1 <= u["joint"] <= 7 for u in d["limits"])


def test_a_trajectory_made_too_fast_is_not_executable():
    # a gentle 10 cm move is executable; the same move replayed 4x faster breaks a joint's velocity or
    # acceleration limit, and the reason names that joint
    from sloshid.comparison.profiles import MoveTask, constant_acceleration

    settings = ArmSettings(q_start=[-0.2601, -0.2369, -0.4947, -2.6876, -0.1801, 2.4704, 0.184])
    slow = constant_acceleration(MoveTask(((0.3, -0.27, 0.2), (0.3, -0.17, 0.2)), (0.3, 0.3, 0.3), (0.2, 0.2, 0.2)))
    ok = check_joints(slow, settings)
    assert ok.executable, ok.reason()
    k = 4  # every 4th sample at 1 kHz: the same path 4x faster
    n = len(slow.t_s[::k])
    fast = Trajectory(
        np.arange(n) * 1e-3,
        slow.pos_m[::k],
        slow.vel_m_s[::k] * k,
        slow.acc_m_s2[::k] * k**2,
        slow.euler_rad[::k],
        slow.euler_rate_rad_s[::k] * k,
    )

    bad = check_joints(fast, settings)
    assert not bad.executable
    failing = [u for u in bad.usages if not u.ok]
    assert failing and f"joint {bad.worst.joint} exceeds" in bad.reason()
    assert {u.quantity for u in failing} <= {"velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3"}


def test_fit_joints_replans_until_the_arm_can_follow(run_cli, tmp_path):
    code, stdout, stderr = run_cli(
        "plan", PAPER_1D, "-o", tmp_path / "t.csv", "--joints", tmp_path / "q.csv", "--fit-joints", "--json"
    )
    assert code == 0, stderr
    d = json.loads(stdout)
    fit = d["joints"]["fit"]
    assert d["joints"]["executable"] and len(fit) >= 2 and not fit[0]["executable"] and fit[-1]["executable"]
    assert fit[-1]["T_s"] > fit[0]["T_s"] and d["T_s"] == pytest.approx(fit[-1]["T_s"])
    assert d["verification"]["ok"] and d["limits_ok"]  # still slosh-free: re-planned, not slowed down
    assert "re-planned" in stderr


def test_datasheet_limits_match_the_shipped_urdf():
    import pinocchio as pin

    model = pin.buildModelFromUrdf(_urdf_path())
    assert model.lowerPositionLimit[:7] == pytest.approx(PANDA_Q_MIN)
    assert model.upperPositionLimit[:7] == pytest.approx(PANDA_Q_MAX)
    assert model.velocityLimit[:7] == pytest.approx(PANDA_DQ_MAX)


BASE_1D = """
[move]
start = [0.3, -0.1, 0.2]
goal = [0.3, 0.0, 0.2]
[limits]
acc_max = [0.5, 0.5, 0.5]
[solver]
N = 30
[liquid]
m_kg = 0.5
l_m = 0.021
d_ns_per_m = 1.51
"""


@pytest.mark.parametrize(
    "robot, message",
    [
        ('model = "ur5"', r"\[robot\].model 'ur5' is unknown; sloshid knows panda"),
        ('model = "panda"\nq_start = [0, 0, 0]', r"q_start must give 7 joint angles"),
        ('model = "panda"\nq_start = [0, 0, 0, 0, 0, 0, 0]', r"joint 4 = 0 rad lies outside"),
        ('model = "panda"\nbase_xyz_m = [3.0, 0.0, 0.0]', r"out of the Panda's reach"),
        (
            "",
            r"--joints needs a \[robot\] table with model = \"panda\" in the scenario \(base_xyz_m and q_start are optional\)",
        ),
    ],
)
def test_bad_robot_input_is_one_sentence_exit_2(run_cli, tmp_path, robot, message):
    sc = tmp_path / "s.toml"
    sc.write_text(BASE_1D + ("\n[robot]\n" + robot if robot else ""))
    code, _out, err = run_cli("plan", sc, "-o", tmp_path / "t.csv", "--joints", tmp_path / "q.csv")
    assert code == 2, err
    import re

    assert re.search(message, err) and err.count("\n") == 1
    assert not (tmp_path / "q.csv").exists()


def test_unknown_model_in_the_api():
    with pytest.raises(UserError, match="unknown"):
        ArmSettings(model="kuka")


def test_q_start_is_a_seed_and_joint_space_takes_one_run(run_cli, tmp_path):
    # issue 39: a rough q_start failed ("the arm would jump by up to 0.865 rad at t = 0"), then the plan failed a joint
    # limit, and only a third run worked. The move shifted 0.2 m along x with paper_1d's q_start kept: the start
    # configuration is solved from q_start, the output says how far it moved, and --fit-joints makes it executable
    sc = tmp_path / "shift.toml"
    sc.write_text(
        PAPER_1D.read_text().replace("[0.3, -0.27, 0.2]", "[0.5, -0.27, 0.2]").replace("[0.3, 0.27", "[0.5, 0.27")
    )
    code, out, err = run_cli(
        "plan", sc, "-o", tmp_path / "t.csv", "--joints", tmp_path / "q.csv", "--fit-joints", "--json"
    )
    assert code == 0, err
    joints = json.loads(out)["joints"]
    assert joints["executable"] and joints["start_offset_m"] == pytest.approx(0.2, abs=0.005)
    assert joints["start_jump_rad"] > 0.3  # the solved start lies far from the seed, and the user is told so
    assert "the arm starts at the joints CSV's first row" in err and "200 mm" in err
    first = [read_csv(tmp_path / "q.csv")[f"q{j}"][0] for j in range(1, 8)]
    # the first row is that start (the joints CSV keeps 9 significant digits: 1e-8 rad at 2 rad)
    assert first == pytest.approx(joints["q_start_solved_rad"], abs=1e-7)
    # without --fit-joints the refusal says what fitting would cost, measured
    code, _, err = run_cli("plan", sc, "-o", tmp_path / "t2.csv", "--joints", tmp_path / "q2.csv")
    assert code == 1 and re.search(r"--fit-joints \(or \[robot\] fit_joints = true\) re-plans .* \(\+\d+\.\d %\)", err)
    # [robot] fit_joints = true does it without the option
    fitting = tmp_path / "fitting.toml"
    fitting.write_text(sc.read_text().replace('model = "panda"', 'model = "panda"\nfit_joints = true'))
    code, _, err = run_cli("plan", fitting, "-o", tmp_path / "t3.csv", "--joints", tmp_path / "q3.csv")
    assert code == 0 and "re-planned" in err, err
    # the shipped scenario's q_start holds the container at its start (rounded to 1e-4 rad)
    code, out, err = run_cli("plan", PAPER_1D, "-o", tmp_path / "p.csv", "--joints", tmp_path / "p.csv.q.csv", "--json")
    joints = json.loads(out)["joints"]
    assert joints["start_offset_m"] < 1e-4 and joints["start_jump_rad"] < 1e-3
    position = next(u for u in joints["limits"] if u["quantity"] == "position_rad")
    assert 0 < position["usage"] < 1  # |angle| over |nearer bound|: read -0.977 against a negative bound


def test_without_joints_the_next_line_checks_the_scenarios_arm(run_cli, tmp_path):
    # the scenario's Panda was ignored without --joints, yet plan said "next: send far.csv to the robot." for a goal
    # 1.5 m away, and for paper_1d's plan whose joint 5 the arm cannot accelerate as fast
    far = tmp_path / "far.toml"
    far.write_text(PAPER_1D.read_text().replace("goal = [0.3, 0.27, 0.2]", "goal = [1.5, 0.27, 0.2]"))
    code, out, err = run_cli("plan", far, "-o", tmp_path / "far.csv")
    assert code == 0, err  # the plan passed its own checks; the arm's verdict is the next line's
    last = out.strip().splitlines()[-1]
    assert re.match(
        rf"next: do not send {re.escape(str(tmp_path / 'far.csv'))}: the pose at .* out of the Panda's", last
    )
    move = tmp_path / "t.csv"
    code, out, err = run_cli("plan", PAPER_1D, "-o", move, "--json")
    assert code == 0 and json.loads(out)["joints"] is None  # stdout stays the JSON, the line goes to stderr
    command = f"sloshid plan {PAPER_1D} -o {move} --joints {tmp_path / 't_joints.csv'} --fit-joints"
    assert err.strip().splitlines()[-1] == (
        f"next: do not send {move}: the Panda of [robot] cannot follow it (joint 5 exceeds its acceleration limit at "
        f"t = 0.008 s: -32.7 against 15 rad/s2); `{command}` plans sloshid's move slower until the arm can follow it, "
        "and writes its joints."
    )
    code, out, err = run_cli(*command.split()[1:])  # the command it gives does what it says
    assert code == 0 and out.strip().splitlines()[-1].startswith(f"next: send {move} (or the joints, ")
