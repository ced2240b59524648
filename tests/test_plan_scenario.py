"""Scenario TOML parsing for the planner: bundled examples, the [compare] pass-through, obstacle geometry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sloshid.core.errors import UserError
from sloshid.model.pendulum import TABLE_I
from sloshid.model.trajectory import RobotLimits
from sloshid.planning.ocp import bang_bang_time, segment_axis
from sloshid.planning.scenario import Obstacle, body_clearance, load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]


def test_bundled_scenarios_load():
    one = load_scenario(ROOT / "data" / "scenarios" / "paper_1d.toml")
    assert one.waypoints == [(0.3, -0.27, 0.2), (0.3, 0.27, 0.2)] and one.liquid == TABLE_I
    assert one.limits.acc_max == (0.5, 0.5, 0.5) and one.robot == RobotLimits() and one.compare == {}
    three = load_scenario(ROOT / "data" / "scenarios" / "paper_3d.toml")
    assert len(three.waypoints) == 6 and len(three.obstacles) == 2 and three.container_radius_m == 0.04


def test_compare_table_is_kept_unvalidated_and_robot_overrides_apply():
    sc = scenario_from_dict(
        {
            "move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]},
            "compare": {"anything": [1, 2], "bandwidth_hz": 20},
            "robot": {"rot_acc_rad_s2": 10.0},
        }
    )
    assert sc.compare == {"anything": [1, 2], "bandwidth_hz": 20}
    assert sc.robot.rot_acc_rad_s2 == 10.0 and sc.robot.vel_m_s == 1.7 and sc.liquid is None


@pytest.mark.parametrize(
    "data, message",
    [
        (
            {"move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]}, "obstacles": [{"center": [0, 0, 0], "radus": 1}]},
            r"unknown key '\[\[obstacles\]\] #1.radus' \(did you mean 'radius'\?\)",
        ),
        (
            {"move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]}, "obstacles": [{"center": [0, 0], "radius": 0.1}]},
            r"a sphere obstacle needs center = \[x, y, z\]",
        ),
        ({"move": {"start": [0, 0, 0.3], "goal": [0, 0, 0.3]}}, r"positions 0 and 1 coincide"),
        ({"move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]}, "limits": {"z_range": [0.5, 0.1]}}, r"low < high"),
        (
            {"move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]}, "robot": {"vel_m_s": -1}},
            r"vel_m_s must be positive",
        ),
        ({"limits": {}}, r"has no \[move\] table"),
        (
            {"move": {"start": [0, 0, 0.3], "goal": [0.1, 0, 0.3]}, "solver": {"jerk_max": [9, 9, 9]}},
            r"'\[solver\].jerk_max' belongs in the \[limits\] table",
        ),
    ],
)
def test_scenario_errors_name_the_key(data, message):
    with pytest.raises(UserError, match=message):
        scenario_from_dict(data)


def test_obstacle_clearance_is_exact():
    sphere = Obstacle(center=(0.0, 0.0, 0.0), radius=0.1)
    assert sphere.clearance([0.3, 0.0, 0.0], 0.05) == pytest.approx(0.15)
    cyl = Obstacle(center=(0.0, 0.0), radius=0.1, kind="cylinder", z_range=(0.0, 0.5))
    pts = np.array([[0.3, 0, 0.2], [0.0, 0.0, 0.6], [0.05, 0, 0.2]])
    # beside: radial 0.3 - 0.15; above the inflated top (0.55): 0.05; inside: negative
    assert cyl.clearance(pts, 0.05) == pytest.approx([0.15, 0.05, -0.1])


def test_body_clearance_covers_the_tilted_container_below_the_surface():
    sphere = Obstacle(center=(0.0, 0.0, 0.0), radius=0.02)
    above = np.array([0.0, 0.0, 0.1])  # the surface's centre 0.1 m above the sphere's
    # no depth: the sphere of radius 0.03 around that point alone, exactly as the obstacle's own clearance
    assert body_clearance([sphere], above, 0.03) == pytest.approx(sphere.clearance(above, 0.03))
    # an upright body 0.08 m deep reaches down to 0.02 m above the centre: inside the sphere grown by 0.03
    deep = float(body_clearance([sphere], above, 0.03, 0.08))
    assert deep < 0
    # its lowest covering sphere sits at the body's bottom, grown by at most 3 % to cover the cylinder
    assert -0.03 * 1.03 <= deep <= -0.03
    # tilted by 30 deg about y, the bottom swings 0.04 m sideways: a sphere beside it is reached, which the upright body misses
    tilt = math.radians(30)
    axis = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    bottom = above - 0.08 * axis
    swung = Obstacle(center=tuple(bottom + np.array([-0.02, 0.0, -0.02])), radius=0.01)
    assert body_clearance([swung], above, 0.03, 0.08, axis) < 0
    assert body_clearance([swung], above, 0.03, 0.08) > 0  # the upright body misses it
    # several samples at once, inf without obstacles
    many = np.array([above, above + np.array([1.0, 0, 0])])
    assert body_clearance([sphere], many, 0.03, 0.08).shape == (2,)
    assert np.isinf(body_clearance([], many, 0.03, 0.08)).all()


@pytest.mark.parametrize("depth", [-0.01, 80.0])
def test_container_depth_must_be_in_metres(depth):
    with pytest.raises(UserError, match=r"\[container\]\.depth_m must lie in \[0, 2\] m"):
        scenario_from_dict({"move": {"start": [0, 0, 0.3], "goal": [0.2, 0, 0.3]}, "container": {"depth_m": depth}})


def test_bang_bang_bound_and_1d_detection():
    assert bang_bang_time(0.54, 0.5, 1.7) == pytest.approx(2.0784609690826525)
    # a velocity-limited move: cruise phase, d/v + v/a
    assert bang_bang_time(2.0, 1.0, 0.5) == pytest.approx(2.0 / 0.5 + 0.5 / 1.0)
    assert segment_axis((0.3, -0.27, 0.2), (0.3, 0.27, 0.2), 0) == 1
    assert segment_axis((0.3, -0.27, 0.2), (0.3, 0.27, 0.2), 1) is None  # obstacles need the 3-D model
    assert segment_axis((0.3, 0.0, 0.2), (0.3, 0.0, 0.4), 0) is None  # vertical moves too
