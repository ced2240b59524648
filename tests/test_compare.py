"""Comparison methods against closed forms and physics: profiles, shapers, ruckig, closed loop, feedback, robustness."""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

from sloshid.comparison.compare import MoveLimits, camera_seen_peak, score
from sloshid.comparison.feedback import FeedbackSettings, run_feedback
from sloshid.comparison.profiles import MoveTask, constant_acceleration
from sloshid.comparison.robot_tracking import closed_loop_response
from sloshid.comparison.robustness import Replay, RobustnessResult, sweep
from sloshid.comparison.ruckig_moves import jerk_limited
from sloshid.comparison.shapers import design_shaper, shaped_constant_acceleration
from sloshid.model.pendulum import TABLE_I, G, SloshParams
from sloshid.model.simulate import simulate_liquid
from sloshid.planning.scenario import Obstacle

# a short 0.1 m move along x keeps every simulation below a second: T = 2 sqrt(L / a) = 0.894 s
SHORT = MoveTask(((0.3, 0.0, 0.2), (0.4, 0.0, 0.2)), (0.5, 0.5, 0.5), (1.7, 1.7, 1.7))


def test_trapezoid_matches_closed_forms():
    bang = constant_acceleration(SHORT)
    assert bang.duration_s == pytest.approx(2 * math.sqrt(0.1 / 0.5), abs=1e-3)  # grid rounds up by < 1 ms
    assert bang.pos_m[-1] == pytest.approx([0.4, 0.0, 0.2], abs=1e-12)
    assert np.abs(bang.acc_m_s2).max() == pytest.approx(0.5)
    # velocity-limited: 0.54 m with v <= 0.2 m/s cruises; T = L/v + v/a
    cruise = constant_acceleration(MoveTask(((0, 0, 0), (0, 0.54, 0)), (0.5,) * 3, (0.2,) * 3))
    assert cruise.duration_s == pytest.approx(0.54 / 0.2 + 0.2 / 0.5, abs=1e-3)
    assert np.abs(cruise.vel_m_s).max() == pytest.approx(0.2, rel=1e-9)


def test_waypoints_stop_at_each_and_respect_per_axis_limits():
    task = MoveTask(((0, 0, 0.2), (0.2, 0.1, 0.2), (0.2, 0.1, 0.4)), (0.5, 0.25, 0.5), (1.7,) * 3)
    traj = constant_acceleration(task)
    stop = np.flatnonzero(np.all(np.isclose(traj.pos_m, [0.2, 0.1, 0.2], rtol=0, atol=1e-12), axis=1))
    assert len(stop) >= 1 and np.abs(traj.vel_m_s[stop]).max() < 1e-9  # at rest on the waypoint
    assert np.abs(traj.acc_m_s2).max(axis=0) == pytest.approx([0.5, 0.25, 0.5])  # y binds on leg 1, z on leg 2


def test_shaper_impulses_match_closed_forms_and_cancel_the_mode():
    p = TABLE_I
    wd = p.omega_rad_s * math.sqrt(1 - p.zeta**2)
    k = math.exp(-p.zeta * math.pi / math.sqrt(1 - p.zeta**2))
    zv, zvd = design_shaper("ZV", p), design_shaper("ZVD", p)
    assert zv.times_s == pytest.approx((0, math.pi / wd)) and zvd.times_s == pytest.approx(
        (0, math.pi / wd, 2 * math.pi / wd)
    )
    assert sum(zv.amplitudes) == pytest.approx(1) and sum(zvd.amplitudes) == pytest.approx(1)
    assert zv.amplitudes[1] / zv.amplitudes[0] == pytest.approx(k)

    # residual vibration of an impulse train on a damped mode: sum A_i exp(zeta w t_i) exp(j wd t_i) = 0 (ZV);
    # ZVD also zeroes its derivative with respect to omega (sum A_i t_i ...)
    def v(s, n):
        return sum(
            a * t**n * cmath.exp((p.zeta * p.omega_rad_s + 1j * wd) * t) for a, t in zip(s.amplitudes, s.times_s)
        )

    assert abs(v(zv, 0)) < 1e-12 and abs(v(zvd, 0)) < 1e-12 and abs(v(zvd, 1)) < 1e-12
    assert abs(v(zv, 1)) > 1e-3  # ZV does not: that is why it is fragile


def test_zv_cancels_the_residual_in_the_nonlinear_simulation():
    plain = simulate_liquid(constant_acceleration(SHORT), TABLE_I, settle_s=1.0)
    zv = shaped_constant_acceleration(SHORT, TABLE_I, "ZV")
    shaped = simulate_liquid(zv, TABLE_I, settle_s=1.0)
    assert plain.residual_deg > 1.0
    # linear theory gives zero; the pendulum's sin/cos^2 at a/g = 2.9 deg and the 1 ms acceleration ramps
    # leave ~0.01 deg, two orders below the unshaped residual
    assert shaped.residual_deg < 0.02
    assert zv.duration_s == pytest.approx(
        constant_acceleration(SHORT).duration_s + design_shaper("ZV", TABLE_I).duration_s, abs=2e-3
    )
    assert np.abs(zv.acc_m_s2).max() <= 0.5 + 1e-12  # positive amplitudes summing to one keep the limit


def test_ruckig_profile_respects_its_limits_on_a_3d_leg():
    task = MoveTask(((0.3, -0.2, 0.2), (0.5, 0.1, 0.3)), (0.5, 0.4, 0.3), (0.3, 0.3, 0.3))
    jerk = 2.0
    traj = jerk_limited(task, jerk)
    assert traj.pos_m[-1] == pytest.approx([0.5, 0.1, 0.3], abs=1e-9)
    assert np.abs(traj.vel_m_s[-1]).max() < 1e-9
    assert (np.abs(traj.acc_m_s2) <= np.array(task.acc_max_m_s2) + 1e-9).all()
    assert (np.abs(traj.vel_m_s) <= np.array(task.vel_max_m_s) + 1e-9).all()
    # acceleration is piecewise linear, so its 1 ms difference quotient is an average jerk: bounded exactly
    assert np.abs(np.diff(traj.acc_m_s2, axis=0) / traj.dt_s).max() <= jerk * (1 + 1e-6)
    # phase synchronisation: a straight line between the waypoints
    d = np.subtract((0.5, 0.1, 0.3), (0.3, -0.2, 0.2))
    off_line = np.cross(traj.pos_m - (0.3, -0.2, 0.2), d / np.linalg.norm(d))
    assert np.abs(off_line).max() < 1e-9


def test_a_move_is_scored_against_its_own_jerk_limit():
    # [limits] jerk_max is the move's limit for every method, as for the plan: a bang-bang move steps its acceleration
    # (+0.5 to -0.5 m/s^2 within one 1 ms sample: 1000 m/s^3), a ruckig profile at 2 m/s^3 holds it. Before, compare checked
    # only acceleration, velocity and tilt, and recommended a ZV move at 503 m/s^3 against a limit of 2.
    limits = MoveLimits(SHORT, jerk_max_m_s3=(2.0, 2.0, 2.0))
    step, _ = score(constant_acceleration(SHORT), TABLE_I, limits, 1.0)
    ramp, _ = score(jerk_limited(SHORT, 2.0), TABLE_I, limits, 1.0)
    assert not step.move_limits_ok and step.limits_failed == ["move jerk_max 1e+03 > 2"]
    assert ramp.move_limits_ok and not ramp.limits_failed
    unlimited, _ = score(constant_acceleration(SHORT), TABLE_I, MoveLimits(SHORT), 1.0)  # no jerk limit given
    assert unlimited.move_limits_ok


def test_a_move_whose_container_body_hits_an_obstacle_below_is_scored_as_colliding():
    # SHORT runs at z = 0.2 m; a sphere 8 cm below its middle: the surface's centre clears it by 3 cm beyond both radii,
    # a container body 8 cm deep runs through it. The clearance a method is judged by takes the body in.
    below = [Obstacle(center=(0.35, 0.0, 0.12), radius=0.02)]
    shallow, _ = score(
        constant_acceleration(SHORT), TABLE_I, MoveLimits(SHORT, obstacles=below, container_radius_m=0.03), 1.0
    )
    deep, _ = score(
        constant_acceleration(SHORT),
        TABLE_I,
        MoveLimits(SHORT, obstacles=below, container_radius_m=0.03, container_depth_m=0.08),
        1.0,
    )
    assert shallow.min_clearance_m == pytest.approx(0.03, abs=1e-6)  # the 1 ms sample nearest the middle: 1e-8 off
    assert deep.min_clearance_m < -0.02


def test_tilt_compensation_follows_the_steady_tilt():
    traj = jerk_limited(SHORT, 2.0, tilt=True)
    assert traj.euler_rad[:, 1] == pytest.approx(np.arctan2(traj.acc_m_s2[:, 0], G), abs=1e-12)
    resp = simulate_liquid(traj, TABLE_I, settle_s=0.5)
    upright = simulate_liquid(jerk_limited(SHORT, 2.0), TABLE_I, settle_s=0.5)
    assert resp.peak_during_deg < 0.3 * upright.peak_during_deg  # the container follows the quasi-static surface


def test_linear_and_nonlinear_agree_at_small_amplitude_and_part_at_large():
    small = MoveTask(SHORT.waypoints, (0.05,) * 3, (1.7,) * 3)  # 0.3 deg steady tilt
    cl = closed_loop_response(constant_acceleration(small), TABLE_I, 20.0, settle_s=0.5)
    peak = cl.rel_nonlinear_deg.max()
    assert cl.max_gap_deg < 2e-3 * peak  # nonlinearity ~ angle^2/6 ~ 1e-5 plus integration error
    big = MoveTask(SHORT.waypoints, (4.0,) * 3, (1.7,) * 3)  # 22 deg steady tilt: sin and cos^2 bite
    cl_big = closed_loop_response(constant_acceleration(big), TABLE_I, 20.0, settle_s=0.5)
    assert cl_big.max_gap_deg > 0.03 * cl_big.rel_nonlinear_deg.max()


def test_robot_tracking_lag_shows_in_the_closed_loop():
    zv = shaped_constant_acceleration(SHORT, TABLE_I, "ZV")
    ideal = simulate_liquid(zv, TABLE_I, settle_s=0.5).residual_deg
    slow = closed_loop_response(zv, TABLE_I, bandwidth_hz=2.0, settle_s=0.5)
    fast = closed_loop_response(zv, TABLE_I, bandwidth_hz=50.0, settle_s=0.5)
    # a 50 Hz loop barely disturbs the shaper's cancellation; a 2 Hz loop (below the 3.4 Hz mode) lags so far
    # behind that the container still moves after the commanded arrival and the cancellation is lost
    assert fast.residual_linear_deg < ideal + 0.02
    assert slow.residual_linear_deg > 0.05 > fast.residual_linear_deg


@pytest.mark.slow
def test_feedback_damps_the_constant_acceleration_residual():
    traj = constant_acceleration(SHORT)
    s = FeedbackSettings(camera_fps=30.0, latency_s=0.05, noise_deg=0.3, seed=1, settle_s=2.0)
    run = run_feedback(traj, TABLE_I, TABLE_I, s)
    plain = simulate_liquid(traj, TABLE_I, settle_s=1.0).residual_deg
    fb = simulate_liquid(run.trajectory, TABLE_I, settle_s=1.0).residual_deg
    assert fb < plain / 5  # LQR on the estimated slosh state takes most of it out before arrival
    assert run.trajectory.pos_m[-1] == pytest.approx([0.4, 0.0, 0.2], abs=1.5e-3)  # arrival = within 1 mm
    # the filter tracks the true liquid to about the camera noise despite 50 ms latency (replayed)
    assert run.estimate_rms_deg < 0.5
    # frames keep coming while the loop runs (move + settle_s); the last 50 ms of frames arrive too late
    assert run.frames == pytest.approx(30.0 * (traj.duration_s + s.settle_s - s.latency_s), abs=2)


@pytest.mark.slow
def test_robustness_ordering_at_and_around_the_nominal_point():
    replays = {
        "const": Replay(constant_acceleration(SHORT)),
        "zv": Replay(shaped_constant_acceleration(SHORT, TABLE_I, "ZV")),
        "zvd": Replay(shaped_constant_acceleration(SHORT, TABLE_I, "ZVD")),
    }
    rob = sweep(replays, TABLE_I, [0.85, 1.0, 1.15], [1.0], settle_s=0.6)
    r = rob.residual_vs_omega_deg
    assert r["zv"][1] < 0.02 and r["zvd"][1] < 0.02 and r["const"][1] > 1.0  # nominal: both shapers cancel
    for i in (0, 2):  # 15 % off: ZVD stays flatter than ZV, both far below the unshaped move
        assert r["zvd"][i] < 0.5 * r["zv"][i] < 0.5 * r["const"][i]
    assert rob.tolerance_band("zvd", 0.3) == (0.85, 1.15) and rob.tolerance_band("zv", 0.3) == (1.0, 1.0)
    assert rob.tolerance_band("const", 0.3) is None
    # 15 % apart the points are said as points: between them the residual was not simulated (a trial's ZV move held
    # at -10 % and 0 % left 0.73 deg at -5 %, while the report said "-10 % .. +0 %" was tolerated)
    assert rob.describe_band("zvd", 0.3) == "at -15 %, +0 %, +15 % (swept points; not simulated between them)"
    assert rob.describe_band("zv", 0.3) == "+0 % .. +0 %" and rob.describe_band("const", 0.3) == "none"
    dense = RobustnessResult(np.array([0.95, 1.0, 1.05]), np.array([1.0]), {"m": np.array([0.1, 0.0, 0.2])}, {})
    assert dense.describe_band("m", 0.3) == "-5 % .. +5 %"


def test_scaled_truth_changes_the_feedback_loop_only():
    truth = TABLE_I.scaled(0.9)
    assert isinstance(truth, SloshParams) and truth.omega_rad_s == pytest.approx(0.9 * TABLE_I.omega_rad_s)
    open_loop = Replay(constant_acceleration(SHORT))
    assert open_loop(truth) is open_loop.trajectory


def test_a_slow_camera_misses_a_fast_peak():
    # seed Remark 1: a 20 ms wide 10 deg peak; 30 fps frames (33 ms apart) land on its flank on average,
    # 1 kHz sees it whole. The average over frame phases of a Gaussian sampled every 33 ms is well below 10.
    t = np.arange(0, 1.0, 1e-3)
    pulse = 10.0 * np.exp(-0.5 * ((t - 0.5) / 0.01) ** 2)
    assert camera_seen_peak(pulse, 1e-3, 1000.0) == pytest.approx(10.0)
    slow, fast = camera_seen_peak(pulse, 1e-3, 30.0), camera_seen_peak(pulse, 1e-3, 240.0)
    assert slow < 0.8 * 10.0 and fast > 0.98 * 10.0
