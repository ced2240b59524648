"""Upright moves within a spill margin, trays of containers and the risk (issue 42), checked against the independent
nonlinear simulation and a separately seeded Monte Carlo."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.model.simulate import simulate_liquid
from sloshid.planning.risk import monte_carlo, scenario_epsilon, spreads
from sloshid.planning.scenario import load_scenario, resolve_liquid, scenario_from_dict
from sloshid.planning.upright import plan_upright
from sloshid.planning.vessels import vessels_of

ROOT = Path(__file__).resolve().parents[1]
UPRIGHT = ROOT / "data" / "scenarios" / "upright_move.toml"
TRAY = ROOT / "data" / "scenarios" / "tray.toml"
IDENTIFIED = ROOT / "data" / "sample_tap_identify.json"
NO_LIQUID_T_S = 2 * math.sqrt(0.54 / 0.5)
"""The fastest 0.54 m rest-to-rest move at 0.5 m/s^2 with no liquid (bang-bang): 2.078 s."""


@pytest.fixture(scope="module")
def demo_plan():
    """The issue's target: the demo move upright, Table I liquid, 8 mm allowed rise, risk not needed here."""
    sc = load_scenario(UPRIGHT)
    return plan_upright(sc, resolve_liquid(sc, None), risk_draws=200)


def test_upright_demo_meets_margin_in_an_independent_simulation(demo_plan):
    # the wall read from the project's simulate_liquid on the 1 kHz trajectory, apart from the planner's own check
    resp = simulate_liquid(demo_plan.trajectory, demo_plan.vessels[0].liquid, settle_s=3.0)
    wall = resp.wall_height_mm(0.04)
    after = resp.t_s > resp.t_arrival_s
    assert wall.max() <= 8.0, wall.max()  # the margin: rim 20 mm, margin 12 mm, during and after
    assert wall[after].max() <= 0.5, wall[after].max()  # calm on arrival
    assert np.abs(demo_plan.trajectory.euler_rad).max() == 0.0  # upright throughout
    assert demo_plan.verification_ok and demo_plan.limits_ok


def test_upright_demo_is_within_four_percent_of_the_no_liquid_move(demo_plan):
    assert demo_plan.t_no_liquid_s == pytest.approx(NO_LIQUID_T_S, rel=1e-9)
    assert demo_plan.T_s <= 1.04 * NO_LIQUID_T_S, demo_plan.T_s
    # and it does reach the goal at rest
    traj = demo_plan.trajectory
    assert traj.pos_m[-1] == pytest.approx([0.3, 0.27, 0.2], abs=1e-6)
    assert np.abs(traj.vel_m_s[-1]).max() < 1e-6


def test_a_tighter_margin_costs_time_and_is_held():
    sc = load_scenario(UPRIGHT)
    liquid = resolve_liquid(sc, None)
    tight = scenario_from_dict(
        {**_raw(UPRIGHT), "limits": {**_raw(UPRIGHT)["limits"], "spill_margin_mm": 17.0}}, str(UPRIGHT)
    )
    loose = plan_upright(sc, liquid, risk_draws=100)
    strict = plan_upright(tight, liquid, risk_draws=100)
    assert strict.checks[0].peak_mm <= 3.0 + 1e-9  # 20 mm rim - 17 mm margin
    assert strict.T_s > loose.T_s * 1.01  # the wall constraint is active: slower than the residual-bound plan


def _raw(path: Path) -> dict:
    from sloshid.core.settings import load_toml

    return load_toml(path)


def test_tray_holds_three_containers_10_percent_apart_and_names_the_limiting_one():
    sc = load_scenario(TRAY)
    result = plan_upright(sc, None, risk_draws=100)
    f = [v.liquid.f_hz for v in result.vessels]
    assert f[1] / f[0] == pytest.approx(1.1, rel=2e-3) and f[2] / f[1] == pytest.approx(1.1, rel=2e-3)
    # each cup in the independent simulation, read here from simulate_liquid
    for v, c in zip(result.vessels, result.checks):
        resp = simulate_liquid(result.trajectory, v.liquid, settle_s=3.0)
        wall = resp.wall_height_mm(v.radius_m)
        assert wall.max() <= 7.0 and wall[resp.t_s > resp.t_arrival_s].max() <= 0.5, (v.name, wall.max())
        assert c.peak_mm == pytest.approx(wall.max(), abs=0.02)
    worst = max(result.checks, key=lambda c: max(c.peak_mm / c.allowed_mm, c.residual_mm / c.residual_max_mm))
    assert result.limiting.name == worst.name
    assert f"limiting: {worst.name}" in result.summary()


def test_reported_risk_agrees_with_a_separately_seeded_monte_carlo():
    # a margin tight enough that the risk is measurable (about 10 % with a +-2 % band on the frequency)
    data = _raw(UPRIGHT)
    data["limits"]["spill_margin_mm"] = 14.0
    sc = scenario_from_dict(data, str(UPRIGHT))
    result = plan_upright(sc, resolve_liquid(sc, None))
    reported = result.risk
    assert reported.draws == 1000 and 0.02 < reported.p < 0.5
    other = monte_carlo(result.trajectory, result.vessels, spreads(result.vessels, sc.risk), 1000, seed=12345)
    gap = abs(reported.p - other.p)
    assert gap <= 3 * math.hypot(reported.stderr, other.stderr), (reported.p, other.p)
    assert f"{100 * reported.p:.2f} %" in result.summary()


def test_robust_plan_on_the_identified_intervals_keeps_the_risk_below_one_percent():
    sc = load_scenario(UPRIGHT)
    result = plan_upright(sc, resolve_liquid(sc, IDENTIFIED), params_path=IDENTIFIED, robust_samples=50)
    sd = json.loads(IDENTIFIED.read_text())["parameters"]["omega_rad_s"]["stderr"]
    assert result.vessels[0].omega_sd_rad_s == pytest.approx(sd)  # the identified spread, not the scenario's band
    assert result.risk.draws >= 1000
    assert result.risk.upper95 <= 0.01, result.risk.summary()
    assert result.risk.residual_exceeded / result.risk.draws <= 0.01
    g = result.guarantee
    assert g.samples == 50 and 0 <= g.support <= 50 and 0 < g.epsilon <= 1
    assert result.T_s <= 1.04 * NO_LIQUID_T_S


def test_scenario_bound_matches_its_closed_form():
    # k = 0: eps = 1 - (beta / N)^(1/N); it grows with the support k and shrinks with N
    assert scenario_epsilon(100, 0, 1e-3) == pytest.approx(1 - (1e-3 / 100) ** (1 / 100), rel=1e-12)
    assert scenario_epsilon(100, 3, 1e-3) > scenario_epsilon(100, 1, 1e-3)
    assert scenario_epsilon(1000, 3, 1e-3) < scenario_epsilon(100, 3, 1e-3)
    assert scenario_epsilon(10, 10, 1e-3) == 1.0


BAD = [
    (
        "margin above the rim",
        "margin_25",
        r"^\[container\]: the spill margin of 25 mm is not below the rim's 20 mm above the liquid",
    ),
    (
        "container outside the tool",
        "tray_outside",
        r"^\[\[containers\]\] #3 \(full cup\) at \(0\.14, 0\) m with radius 0\.03 m reaches outside the tool's tray",
    ),
    ("unknown liquid", "tray_unknown", r"^\[\[containers\]\] #2 \(middle cup\) has no known liquid"),
    ("container of no radius", "radius_0", r"^\[container\]\.radius_m must lie in \(0, 1\] m for a move within a"),
    ("tilting container of no radius", "tilt_radius_0", r"^\[container\]\.radius_m must lie in \(0, 1\] m"),
    ("cup with a negative margin", "tray_margin", r"^\[\[containers\]\] #1\.spill_margin_mm must be zero or"),
    ("cup of no pendulum length", "tray_l_0", r"^\[\[containers\]\] #2\.l_m must be positive, got 0"),
]


def _bad_scenario(kind, tmp_path: Path) -> Path:
    """A scenario file with one mistake."""
    if kind == "margin_25":
        text = UPRIGHT.read_text().replace("spill_margin_mm = 12", "spill_margin_mm = 25")
    elif kind == "tray_outside":
        text = TRAY.read_text().replace("position_m = [0.09, 0.0]", "position_m = [0.14, 0.0]")
    elif kind in ("radius_0", "tilt_radius_0"):
        source = UPRIGHT if kind == "radius_0" else UPRIGHT.with_name("tilt_margin_move.toml")
        text = source.read_text().replace("radius_m = 0.04 ", "radius_m = 0 ")
    elif kind == "tray_margin":
        text = TRAY.read_text().replace('name = "shallow cup"', 'name = "shallow cup"\nspill_margin_mm = -3')
    elif kind == "tray_l_0":
        text = TRAY.read_text().replace("fill_m = 0.014590\nzeta = 0.05", "m_kg = 0.5\nl_m = 0\nd_ns_per_m = 1")
    else:
        text = TRAY.read_text().replace("fill_m = 0.014590\n", "")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("case", "kind", "message"), BAD, ids=[b[0] for b in BAD])
def test_bad_upright_input_is_one_sentence_and_exit_2(run_cli, tmp_path, case, kind, message):
    import re

    scenario = _bad_scenario(kind, tmp_path)
    out = tmp_path / "traj.csv"
    code, _stdout, err = run_cli("plan", scenario, "-o", out)
    assert code == 2, (case, err)
    text = err.removeprefix("sloshid: error: ").strip()
    assert re.search(message, text), text
    assert text.count("\n") == 0 and "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == [scenario]  # nothing half-written


def test_upright_scenario_keys_are_checked():
    with pytest.raises(UserError, match=r"rim_above_surface_m must lie in \(0, 1\] m"):
        scenario_from_dict({**_raw(UPRIGHT), "container": {"radius_m": 0.04, "rim_above_surface_m": 20}})
    tilting = _raw(TRAY)
    tilting["limits"]["tilt_max_deg"] = 10
    with pytest.raises(UserError, match=r"tray of \[\[containers\]\], which is planned upright"):
        scenario_from_dict(tilting)
    with pytest.raises(UserError, match=r"needs \[limits\]\.spill_margin_mm"):
        data = _raw(UPRIGHT)
        del data["limits"]["spill_margin_mm"]
        vessels_of(scenario_from_dict(data), resolve_liquid(scenario_from_dict(data), None))


def _with_100_draws(tmp_path: Path) -> Path:
    """The upright demo scenario with 100 Monte-Carlo draws instead of its 1000 (the least [risk].draws takes), for
    the tests of what `plan` prints and writes: none of them reads the risk's value, and the 1000 draws of each plan
    were most of their time."""
    path = tmp_path / "upright_100_draws.toml"
    path.write_text(UPRIGHT.read_text().replace("draws = 1000", "draws = 100"))
    return path


def test_plan_cli_prints_risk_and_draws_the_margin_sweep(run_cli, tmp_path):
    out = tmp_path / "up.csv"
    scenario = _with_100_draws(tmp_path)
    code, stdout, err = run_cli("plan", scenario, "-o", out, "--sweep-margin", "12:16:2", "--report", tmp_path / "rep")
    assert code == 0, err
    page = (tmp_path / "rep" / "index.html").read_text(encoding="utf-8")
    assert "sloshid upright plan" in page and "data:image/png;base64" in page
    assert "risk of breaking the spill margin" in stdout and "margin sweep: 12 mm: T = " in stdout
    figure = tmp_path / "up_margin_sweep.png"
    assert out.exists() and figure.stat().st_size > 10_000
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from sloshid.core.outputs import FIGURE_MARK, holds_mark

    assert holds_mark(figure, FIGURE_MARK)  # sloshid's own picture, which the next run replaces


@pytest.mark.slow
def test_compare_cli_writes_the_move_and_its_json_and_ends_with_the_next_step(run_cli, tmp_path):
    # within a spill margin compare wrote best.csv alone, though its help promises best.json, and ended without `next:`
    text = UPRIGHT.read_text().replace("draws = 1000", "draws = 100\nscenarios = 4").replace("N = 100", "N = 50")
    scenario = tmp_path / "up.toml"
    scenario.write_text(text)
    best = tmp_path / "cmp" / "best.csv"
    code, out, err = run_cli("compare", scenario, "-o", best)
    assert code == 0, err
    move = json.loads(best.with_suffix(".json").read_text())
    assert move["trajectory_csv"] == "best.csv" and move["reason"].startswith(f"Recommended: {move['label']}, T = ")
    assert move["margin_risk"]["draws"] == 100 and move["risk"] in ("good", "uncertain")
    lines = out.strip().splitlines()
    assert lines[-2] == move["reason"]
    assert lines[-1] == f"next: send {best} to the robot ({move['label']}; {best.with_suffix('.json')} says why)."


def test_zvdd_shaper_cancels_the_mode_and_flattens_the_notch():
    from sloshid.comparison.shapers import design_shaper
    from sloshid.model.pendulum import TABLE_I

    def vibration(shaper, omega: float) -> float:
        """Residual vibration of the impulse train at omega (zeta of Table I), relative to one impulse."""
        z = TABLE_I.zeta
        wd = omega * math.sqrt(1 - z * z)
        t_end = shaper.times_s[-1]
        terms = [a * math.exp(-z * omega * (t_end - t)) * complex(math.cos(wd * t), math.sin(wd * t))
                 for a, t in zip(shaper.amplitudes, shaper.times_s)]  # fmt: skip
        return abs(sum(terms))

    w = TABLE_I.omega_rad_s
    zvd, zvdd = design_shaper("ZVD", TABLE_I), design_shaper("ZVDD", TABLE_I)
    assert sum(zvdd.amplitudes) == pytest.approx(1.0, abs=1e-12) and min(zvdd.amplitudes) > 0
    assert vibration(zvdd, w) < 1e-12
    assert vibration(zvdd, 1.2 * w) < 0.5 * vibration(zvd, 1.2 * w)  # the robust notch: flatter 20 % off the mode
    assert zvdd.duration_s == pytest.approx(1.5 * zvd.duration_s, rel=1e-12)


def test_upright_compare_ranks_by_risk_and_sloshid_is_fastest_among_those_that_meet():
    from sloshid.comparison.upright_compare import UPRIGHT_BASELINES, compare_upright

    sc = load_scenario(UPRIGHT)
    comp = compare_upright(sc, resolve_liquid(sc, None), robust_samples=0, draws=200)
    rows = comp.ranked()
    assert {r.key for r in rows} == {*UPRIGHT_BASELINES, "sloshid"}
    risks = [(r.risk.p, r.risk.residual_exceeded / r.risk.draws) for r in rows if r.meets]
    assert risks == sorted(risks)  # ranked by risk among those that meet
    ours = next(r for r in rows if r.key == "sloshid")
    meeting = [r for r in rows if r.meets and r.key != "sloshid"]
    assert meeting and all(ours.T_s < r.T_s for r in meeting), [(r.key, r.T_s) for r in meeting]
    assert all(r.peak_use <= 1.0 and r.residual_mm <= 0.5 for r in meeting)  # what 'meets' claims, nominally
    assert "ranked by risk" in comp.summary()


def test_a_diagonal_upright_move_holds_the_margin_with_both_angles():
    # x and y both move: phi and theta both swing, and the wall reads their combined tilt
    data = _raw(UPRIGHT)
    data["move"] = {"start": [0.0, 0.0, 0.2], "goal": [0.3, 0.4, 0.2]}
    data["limits"]["spill_margin_mm"] = 16.0  # 4 mm of rise: the wall bound is active
    data.pop("risk")
    sc = scenario_from_dict(data, str(UPRIGHT))
    result = plan_upright(sc, resolve_liquid(sc, None))
    resp = simulate_liquid(result.trajectory, result.vessels[0].liquid, settle_s=3.0)
    assert np.abs(resp.liquid_rad).max(axis=0).min() > 0.01  # both angles swing (rad)
    wall = resp.wall_height_mm(0.04)
    assert wall.max() <= 4.0 and wall[resp.t_s > resp.t_arrival_s].max() <= 0.5, wall.max()
    assert result.risk is None and "risk: not estimated" in result.summary()
    assert result.trajectory.pos_m[-1] == pytest.approx([0.3, 0.4, 0.2], abs=1e-6)


def test_a_tilting_path_move_with_a_spill_margin_uses_both():
    from sloshid.model.pendulum import TABLE_I
    from sloshid.planning.planner import plan

    data = _raw(ROOT / "data" / "scenarios" / "path_arc.toml")
    data.pop("robot")
    data["limits"].pop("rel_angle_max_deg")
    data["limits"]["spill_margin_mm"] = 18.0  # rim 20 mm: 2 mm of rise at the 40 mm container's wall
    data["container"]["rim_above_surface_m"] = 0.02
    sc = scenario_from_dict(data, str(ROOT / "data" / "scenarios" / "path_arc.toml"))
    assert sc.limits.rel_angle_max_deg == pytest.approx(math.degrees(math.atan(2 / 40)), rel=1e-12)
    result = plan(sc, TABLE_I)
    assert result.verification_ok and result.max_tilt_deg > 1.0  # it tilts
    rel = np.radians(result.verification.rel_angle_deg)
    assert 1000 * 0.04 * np.tan(rel).max() <= 2.0  # and the liquid uses the margin within it
    assert result.verification.peak_during_deg > 1.0


WAYPOINTS = [[0.3, -0.27, 0.2], [0.3, 0.0, 0.2], [0.5, 0.0, 0.2]]
"""An L-shaped upright move: 0.27 m along y, a stop, 0.2 m along x."""


def _upright_waypoints(tmp_path: Path | None = None):
    data = _raw(UPRIGHT)
    data.pop("risk")
    data["move"] = {"waypoints": WAYPOINTS}
    if tmp_path is None:
        return scenario_from_dict(data, str(UPRIGHT))
    text = UPRIGHT.read_text().replace(
        "start = [0.3, -0.27, 0.2]   # m\ngoal = [0.3, 0.27, 0.2]     # m", f"waypoints = {WAYPOINTS}"
    )
    path = tmp_path / "l_move.toml"
    path.write_text(text)
    return path


def test_an_upright_move_with_waypoints_stops_calm_at_each_and_keeps_the_margin():
    from sloshid.model.pendulum import TABLE_I

    result = plan_upright(_upright_waypoints(), TABLE_I)
    traj = result.trajectory
    resp = simulate_liquid(traj, TABLE_I, settle_s=3.0)
    wall = resp.wall_height_mm(0.04)
    assert wall.max() <= 8.0 and wall[resp.t_s > resp.t_arrival_s].max() <= 0.5, wall.max()
    k = int(np.argmin(np.linalg.norm(traj.pos_m - WAYPOINTS[1], axis=1)))
    assert np.linalg.norm(traj.pos_m[k] - WAYPOINTS[1]) < 1e-9 and np.linalg.norm(traj.vel_m_s[k]) < 1e-9  # stops
    assert 0.05 < wall[k] <= 0.5  # the liquid still swings there, within the residual allowed on arrival
    assert np.abs(resp.liquid_rad[k:, 1]).max() > 0.01 and np.abs(resp.liquid_rad[k, 0]) > 0  # phi goes on, theta
    assert traj.pos_m[-1] == pytest.approx(WAYPOINTS[2], abs=1e-9)
    free = 2 * math.sqrt(0.27 / 0.5) + 2 * math.sqrt(0.2 / 0.5)  # the two legs with no liquid
    assert result.t_no_liquid_s == pytest.approx(free, rel=1e-9)
    assert free < result.T_s <= 1.04 * free, result.T_s
    assert result.verification_ok and result.limits_ok and np.abs(traj.euler_rad).max() == 0.0


def test_compare_refuses_an_upright_move_with_waypoints_in_one_sentence(run_cli, tmp_path):
    scenario = _upright_waypoints(tmp_path)
    code, _stdout, err = run_cli("compare", scenario, "-o", tmp_path / "best.csv")
    assert code == 2 and "compare scores one straight move within a spill margin, and this one has waypoints" in err
    assert err.count("\n") == 1 and list(tmp_path.iterdir()) == [scenario]


def test_plan_json_of_a_margin_plan_holds_what_the_help_says(run_cli, tmp_path):
    # the help promised verification, max_tilt_rate_deg_s and per-segment figures, which a margin plan's JSON lacks
    import argparse
    import re

    from sloshid.cli.app import build_parser

    parser = build_parser("plan")
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["plan"]
    text = next(a.help for a in sub._actions if "--json" in a.option_strings)
    margin = text.split("a plan within a spill margin's ")[1]
    named = {k for k in re.findall(r"[A-Za-z_]+", margin) if "_" in k or k in ("kind", "status", "containers", "risk")}
    code, out, err = run_cli("plan", _with_100_draws(tmp_path), "-o", tmp_path / "u.csv", "--json")
    assert code == 0, err
    keys = set(json.loads(out))
    assert named <= keys and {"kind", "verification_ok", "containers", "margin_sweep"} <= named
    assert "verification" not in keys and "segments" not in keys
