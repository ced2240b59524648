"""Trajectory CSV, orientation maths, robot-limit checks and the nonlinear liquid simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sloshid.model.pendulum import TABLE_I, G
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import CSV_COLUMNS, RobotLimits, Trajectory, check_limits, euler_rates_to_omega


def _upright_move(acc_y: np.ndarray, dt: float = 1e-3) -> Trajectory:
    """An upright container driven along y by a sampled acceleration (velocity/position by cumulative sums)."""
    n = len(acc_y)
    acc = np.zeros((n, 3))
    acc[:, 1] = acc_y
    vel = np.cumsum(acc, axis=0) * dt
    pos = np.cumsum(vel, axis=0) * dt
    return Trajectory(np.arange(n) * dt, pos, vel, acc, np.zeros((n, 3)), np.zeros((n, 3)), name="test")


def test_omega_matches_numerical_derivative_of_rotation():
    rng = np.random.default_rng(3)
    euler = rng.uniform(-0.5, 0.5, 3)
    rates = rng.uniform(-2, 2, 3)
    h = 1e-6
    rot = lambda e: Rotation.from_euler("ZYX", e[::-1])  # noqa: E731
    # world angular velocity: (R(t+h) R(t)^T) as rotation vector / h
    numeric = (rot(euler + h * rates) * rot(euler).inv()).as_rotvec() / h
    assert euler_rates_to_omega(euler, rates)[0] == pytest.approx(numeric, abs=1e-5)


def test_csv_round_trip(tmp_path):
    rng = np.random.default_rng(4)
    n = 50
    traj = Trajectory(np.arange(n) * 1e-3, *(rng.normal(size=(n, 3)) * 0.1 for _ in range(5)))
    path = tmp_path / "traj.csv"
    traj.to_csv(path)
    header = path.read_text().splitlines()[0].split(",")
    assert tuple(header) == CSV_COLUMNS
    back = Trajectory.from_csv(path)
    # 9 significant digits are written: round-trip error is below 1e-8 (rates go through a 3x3 solve)
    for name in ("pos_m", "vel_m_s", "acc_m_s2", "euler_rad", "euler_rate_rad_s"):
        assert getattr(back, name) == pytest.approx(getattr(traj, name), abs=1e-7)
    q = back.quaternion_xyzw
    assert np.linalg.norm(q, axis=1) == pytest.approx(np.ones(n), abs=1e-12)


def test_limits_check_catches_a_jerk_violation():
    # a 13 m/s^2 acceleration step within one 1 ms sample is 13000 m/s^3 of jerk, twice the Panda's 6500
    acc = np.r_[np.zeros(10), np.full(10, 13.0), np.zeros(10)]
    usage = {u.quantity: u for u in check_limits(_upright_move(acc), RobotLimits())}
    assert not usage["jerk_m_s3"].ok and usage["jerk_m_s3"].peak == pytest.approx(13000)
    assert usage["acc_m_s2"].ok and usage["vel_m_s"].ok and usage["rot_vel_rad_s"].ok


def test_small_step_matches_linear_pt2_step_response():
    # 0.05 m/s^2 makes a 0.29 deg tilt: nonlinearity (sin, cos^2) is below 1e-5 relative there.
    u, dt = 0.05, 1e-3
    traj = _upright_move(np.full(1500, u), dt)
    resp = simulate_liquid(traj, TABLE_I, settle_s=0.0)
    w, z = TABLE_I.omega_rad_s, TABLE_I.zeta
    wd = w * math.sqrt(1 - z * z)
    t = resp.t_s
    step = (u / G) * (1 - np.exp(-z * w * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t)))
    # roll phi = -(tilt toward +y); the upright container makes the relative angle the liquid angle
    assert -resp.liquid_rad[:, 0] == pytest.approx(step, abs=2e-3 * u / G)
    assert resp.liquid_rad[:, 1] == pytest.approx(0.0, abs=1e-12)
    assert resp.peak_during_deg == pytest.approx(np.degrees(step.max()), rel=1e-3)
