"""Planning along a prescribed path (issue 13, part 1): the curve, the plan on it, the baselines, bad paths."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from sloshid.comparison.compare import PATH_METHODS, build_method, from_scenario, score
from sloshid.core.errors import UserError
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import Trajectory
from sloshid.planning.path import PathTable, build_geometry
from sloshid.planning.path_planner import check_path
from sloshid.planning.path_problem import PathStructure, build_path_problem
from sloshid.planning.planner import plan
from sloshid.planning.scenario import load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]
PATH_ARC = ROOT / "data" / "scenarios" / "path_arc.toml"


@pytest.fixture(scope="module")
def arc():
    return load_scenario(PATH_ARC)


@pytest.fixture(scope="module")
def arc_plan(arc):
    return plan(arc, arc.liquid)


def test_planning_curve_is_the_waypoint_spline_in_arc_length(arc):
    # The truncated-power form reproduces the cubic spline through the waypoints (chord length): every point of
    # the planning curve lies on it within 0.3 mm, and |p'| = 1 (nearly arc length) within 1 %.
    geo = arc.path
    pts = np.array(arc.path_table.waypoints)
    u = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    user = CubicSpline(u, pts)(np.linspace(0, u[-1], 20001))
    sigma = np.linspace(0, geo.length_m, 501)
    on = geo.evaluate(sigma)
    dist = np.min(np.linalg.norm(on[:, None, :] - user[None, ::10, :], axis=2), axis=1)
    assert dist.max() < 3e-4 and geo.deviation(on).max() < 3e-4
    assert np.abs(np.linalg.norm(geo.evaluate(sigma, 1), axis=1) - 1).max() < 1e-2
    # the CasADi curve of the NLP is the same function, derivatives included
    prob = build_path_problem(PathStructure(10, "k", 1), geo)
    for s in (0.0, 0.1234, geo.length_m * 0.77):
        values = [np.asarray(v).ravel() for v in prob.geometry(s)]
        for order in range(4):
            assert values[order] == pytest.approx(geo.evaluate(s, order)[0], abs=1e-9)
    # the quarter circle of radius 0.15 m: curvature 1/0.15 in the middle of the arc
    mid = geo.length_m * 0.25
    assert np.linalg.norm(geo.evaluate(mid, 2)) == pytest.approx(1 / 0.15, rel=0.03)


def test_path_plan_stays_on_the_path_and_passes_the_independent_verification(arc, arc_plan, tmp_path):
    res, tr = arc_plan, arc_plan.trajectory
    assert res.max_path_deviation_m <= arc.path_table.path_tolerance_m and res.path_ok
    assert res.limits_ok and res.verification_ok
    # rest to rest at the ends of the path, without stopping in between
    assert tr.pos_m[0] == pytest.approx(arc.path_table.waypoints[0], abs=1e-9)
    assert tr.pos_m[-1] == pytest.approx(arc.path_table.waypoints[-1], abs=1e-6)
    assert np.abs(tr.vel_m_s[[0, -1]]).max() < 1e-6 and np.abs(tr.euler_rad[-1]).max() < 1e-6
    speed = np.linalg.norm(tr.vel_m_s, axis=1)
    assert speed[50:-50].min() > 0.02  # never stops at a waypoint
    # the independent simulation (solve_ivp under the exported accelerations): the liquid leans against the
    # container by less than rel_angle_max_deg while moving and is at rest (< 0.05 deg) after arrival
    v = res.verification
    assert v.peak_during_deg < arc.limits.rel_angle_max_deg and v.residual_deg < 0.05
    path = tmp_path / "t.csv"
    tr.to_csv(path)
    assert Trajectory.from_csv(path).pos_m == pytest.approx(tr.pos_m, abs=1e-8)

    # the same timing with the container held upright sloshes by degrees: the tilt is doing the work
    upright = Trajectory(tr.t_s, tr.pos_m, tr.vel_m_s, tr.acc_m_s2, 0 * tr.euler_rad, 0 * tr.euler_rate_rad_s)
    assert simulate_liquid(upright, res.params).peak_during_deg > 2.0
    d = res.to_dict()
    assert d["max_path_deviation_m"] == res.max_path_deviation_m and d["verification"]["during_max_deg"] == 0.5


def test_plan_is_faster_than_every_slosh_free_baseline(arc, arc_plan):
    # compare's rule: among the methods that leave <= 0.5 deg of residual slosh, the fastest wins
    inp = from_scenario(arc, arc.liquid)
    assert inp.settings.methods == PATH_METHODS
    built = {}
    for key in ("toppra", "toppra_tilt", "toppra_zvd"):
        built[key] = build_method(key, inp, built)
        assert built[key].applicable, built[key].reason
        assert built[key].score.max_path_deviation_m < arc.path_table.path_tolerance_m  # same path for everyone
    ours, _ = score(arc_plan.trajectory, arc.liquid, inp.limits, inp.settings.settle_s)
    limit = inp.settings.residual_ok_deg
    assert ours.residual_deg <= limit and ours.robot_limits_ok and ours.move_limits_ok
    free = [r for r in built.values() if r.score.residual_deg <= limit]
    assert free, "no slosh-free baseline: the ranking would be vacuous"
    assert all(ours.transfer_time_s < r.score.transfer_time_s for r in free)
    # TOPP-RA itself (no jerk limit, no liquid) is the time bound the plan stays close to
    assert built["toppra"].score.transfer_time_s < ours.transfer_time_s < 1.05 * built["toppra"].score.transfer_time_s
    assert built["toppra"].score.residual_deg > 1.0  # and it sloshes
    straight = build_method("zvd", inp, built)
    assert not straight.applicable and "cannot follow the [path]" in straight.reason


def test_csv_path_is_smoothed_within_its_tolerance(tmp_path):
    # a dense arc with 0.1 mm of noise: the smoothed curve stays within smoothing_m of every point
    rng = np.random.default_rng(3)
    a = np.linspace(0, math.pi / 2, 200)
    pts = np.column_stack([0.4 + 0.2 * np.cos(a), 0.2 * np.sin(a), 0.3 + 0 * a]) + rng.normal(0, 1e-4, (200, 3))
    csv = tmp_path / "path.csv"
    csv.write_text("x_m,y_m,z_m\n" + "\n".join(",".join(f"{v:.6f}" for v in p) for p in pts))
    geo = build_geometry(PathTable(points_csv=str(csv), path_tolerance_m=0.001))
    assert geo.smoothing_error_m <= 0.0005
    sigma = np.linspace(0, geo.length_m, 400)
    assert geo.deviation(geo.evaluate(sigma)).max() <= 0.001
    assert geo.length_m == pytest.approx(0.2 * math.pi / 2, rel=0.01)


BASE = {
    "limits": {"acc_max": [0.5, 0.5, 0.5]},
    "liquid": {"m_kg": 0.5, "l_m": 0.021, "d_ns_per_m": 1.51},
}


@pytest.mark.parametrize(
    "path, extra, message",
    [
        ({"waypoints": [[0.4, 0.0, 0.3]]}, {}, r"has 1 point\(s\); a path needs at least 2"),
        ({"waypoints": [[0.4, 0.0, 0.3], [0.4, 0.0, 0.3], [0.5, 0, 0.3]]}, {}, r"points 0 and 1 repeat"),
        ({"waypoints": [[0.4, 0.0, 0.3]], "points_csv": "x.csv"}, {}, r"either waypoints or points_csv"),
        ({"points_csv": "missing.csv"}, {}, r"does not exist"),
        ({"waypoints": [[0.4, 0.0, 0.3], [0.5, 0.0, 0.3]], "spline": "linear"}, {}, r"spline"),
        # in mm: splined at 0.2 mm steps over kilometres, it ran a 24 GB machine out of memory
        ({"waypoints": [[400, 0, 300], [500, 100, 300], [600, 200, 300]]}, {}, r"1000 times too large"),
        ({"waypoints": [[0.4, 0, 0.3], [0.5, 0, 0.3]]}, {"move": {"start": [0, 0, 0.3], "goal": [1, 0, 0.3]}}, r"both"),
    ],
)
def test_bad_paths_are_named(path, extra, message):
    with pytest.raises(UserError, match=message):
        scenario_from_dict({**BASE, "path": path, **extra})


def test_path_through_an_obstacle_is_reported_not_avoided(run_cli, tmp_path):
    text = PATH_ARC.read_text() + "\n[[obstacles]]\ncenter = [0.55, -0.05, 0.3]\nradius = 0.03\n"
    sc = tmp_path / "s.toml"
    sc.write_text(text)
    code, _out, err = run_cli("plan", sc, "-o", tmp_path / "t.csv")
    assert code == 2 and "runs through obstacle 1" in err and err.count("\n") == 1
    assert not (tmp_path / "t.csv").exists()


def test_a_path_over_an_obstacle_is_refused_when_the_body_below_reaches_it(tmp_path):
    # a sphere 9 cm below the arc: the surface's centre clears it (by 2 cm beyond both radii), an upright body 8 cm deep
    # reaches 1 cm into it; the check refuses the path only with [container].depth_m, naming the body
    below = "\n[[obstacles]]\ncenter = [0.55, -0.05, 0.21]\nradius = 0.03\n"
    sc = tmp_path / "s.toml"
    sc.write_text(PATH_ARC.read_text() + below)
    check_path(load_scenario(sc))
    sc.write_text(PATH_ARC.read_text().replace("radius_m = 0.04", "radius_m = 0.04\ndepth_m = 0.08") + below)
    with pytest.raises(UserError, match=r"runs through obstacle 1 .*upright body 0\.08 m below the surface's centre"):
        check_path(load_scenario(sc))


def test_a_path_whose_tilted_body_swings_into_an_obstacle_writes_no_plan(run_cli, tmp_path):
    # A container 0.3 m deep (radius 0.01 m) on the arc leans into the turn, its bottom swinging 2.2 cm outward at
    # t = 0.89 s; a sphere 1.2 cm beyond that bottom is clear of the upright body all along the path (check_path passes),
    # but the planned tilt brings the body 8 mm into it: one sentence, exit 2, no CSV.
    text = PATH_ARC.read_text().replace("radius_m = 0.04", "radius_m = 0.01\ndepth_m = 0.3")
    sc = tmp_path / "s.toml"
    sc.write_text(text + "\n[[obstacles]]\ncenter = [0.3711, -0.0337, 0.0008]\nradius = 0.01\n")
    check_path(load_scenario(sc))
    code, _out, err = run_cli("plan", sc, "-o", tmp_path / "t.csv")
    assert code == 2 and "tilted as the plan tilts it along the path" in err and err.count("\n") == 1
    assert not (tmp_path / "t.csv").exists()


def test_a_path_plan_draws_its_report(arc_plan, tmp_path):
    # a path plan knew no scenario, so `--report` (and a pipeline's [plan] on a path) failed after writing the CSV
    page = arc_plan.report(tmp_path / "rep")
    text = page.read_text()
    assert page.name == "index.html" and "Optimal states" in text and "path_arc.toml" in text


def test_plan_never_writes_over_its_path_csv(run_cli, tmp_path):
    # the [path] points_csv is an input of the run like the scenario: -o or --joints naming it is refused first
    a = np.linspace(0, math.pi / 2, 40)
    pts = tmp_path / "pts.csv"
    pts.write_text("x_m,y_m,z_m\n" + "\n".join(f"{0.4 + 0.2 * math.cos(v):.6f},{0.2 * math.sin(v):.6f},0.3" for v in a))
    before = pts.read_bytes()
    text = re.sub(r"\[path\].*?\n\n", '[path]\npoints_csv = "pts.csv"\n\n', PATH_ARC.read_text(), count=1, flags=re.S)
    sc = tmp_path / "s.toml"
    sc.write_text(text)
    code, _out, err = run_cli("plan", sc, "-o", pts)
    assert code == 2 and "is also an input of this run" in err and err.count("\n") == 1
    assert pts.read_bytes() == before


def test_path_plan_bounds_the_tilt_from_upright_on_a_diagonal():
    # a straight diagonal path: both angles lean at once. Each was held to tilt_max_deg, so the container tilted by up
    # to sqrt(2) times the limit from upright; the tilt from upright is bounded now (between grid points by 1 %)
    sc = scenario_from_dict(
        {
            **BASE,
            "limits": {"acc_max": [2.0, 2.0, 2.0], "vel_max": [1.0, 1.0, 1.0], "tilt_max_deg": 10},
            "path": {"waypoints": [[0.4, -0.2, 0.3], [0.55, -0.05, 0.3], [0.7, 0.1, 0.3]]},
        }
    )
    res = plan(sc, sc.liquid)
    tilt = np.degrees(np.arccos(res.trajectory.z_axis[:, 2].clip(-1, 1)))
    assert 10 * 0.95 <= tilt.max() <= 10 * 1.01
