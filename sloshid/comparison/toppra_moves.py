"""Baselines along a prescribed path: TOPP-RA (the `toppra` package), with and without tilt, and ZVD-shaped.

TOPP-RA (Pham & Pham 2018) is the time-optimal path parameterisation under per-axis velocity and acceleration
limits (no jerk limit, no liquid): here the path's coordinates are the "joints" and the limits are the
scenario's per-axis boxes (capped by the robot's norm limits). Its path velocity at the grid points gives
sigma(t) (constant path acceleration between grid points), which is mapped through the same planning curve
as sloshid's plan, so every method moves on exactly the same path:
- "TOPP-RA": container upright;
- "TOPP-RA + tilt": container at the liquid's quasi-static tilt atan(a/g) at every sample;
- "TOPP-RA + ZVD": the path parameter sigma(t) convolved with a ZVD shaper tuned to the liquid (the shaped
  sigma stays on the path; the Cartesian acceleration is shaped exactly along the path's tangent and
  approximately in the centripetal part), container upright.
"""

from __future__ import annotations

import math

import numpy as np

from sloshid.comparison.profiles import DT_S, NotApplicable, PathProfile, container_orientation
from sloshid.model.pendulum import SloshParams
from sloshid.model.trajectory import RobotLimits, Trajectory

GRIDPOINTS = 400
"""TOPP-RA's discretisation of the path (its grid; the time law is exact between grid points)."""


def toppra_profile(geo, vel_box, acc_box, robot: RobotLimits) -> PathProfile:
    """TOPP-RA's time-optimal sigma(t), at rest at both ends, as a PathProfile."""
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint
    except ImportError as exc:  # pragma: no cover - a declared dependency
        raise NotApplicable(f"the toppra package is not available ({exc}).") from None
    toppra.setup_logging("WARNING")
    L = geo.length_m
    ss = np.linspace(0.0, L, GRIDPOINTS + 1)
    path = toppra.SplineInterpolator(ss, geo.evaluate(ss))
    vel = np.minimum(np.asarray(vel_box, float), robot.vel_m_s)
    acc = np.minimum(np.asarray(acc_box, float), robot.acc_m_s2)
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.column_stack([-vel, vel])),
        toppra.constraint.JointAccelerationConstraint(np.column_stack([-acc, acc])),
    ]
    algo = toppra.algorithm.TOPPRA(constraints, path, gridpoints=ss, parametrizer="ParametrizeConstAccel")
    _sdd, sd, _v = algo.compute_parameterization(0.0, 0.0)
    if sd is None:
        raise NotApplicable("TOPP-RA found no feasible parameterisation of the path.")
    sd = np.maximum(np.asarray(sd, float), 0.0)  # path velocity at the grid points
    dt = 2 * np.diff(ss) / np.maximum(sd[:-1] + sd[1:], 1e-12)
    t_grid = np.concatenate([[0.0], np.cumsum(dt)])
    sdd = np.diff(sd) / dt

    def evaluate(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.clip(np.asarray(t, float), 0.0, t_grid[-1])
        k = np.clip(np.searchsorted(t_grid, t, side="right") - 1, 0, len(dt) - 1)
        tau = t - t_grid[k]
        s = ss[k] + sd[k] * tau + sdd[k] * tau**2 / 2
        v = sd[k] + sdd[k] * tau
        a = np.where(t >= t_grid[-1], 0.0, sdd[k])
        return np.clip(s, 0.0, L), np.maximum(v, 0.0), a

    return PathProfile(L, float(t_grid[-1]), evaluate)


def along_path(geo, profile: PathProfile, name: str, tilt: bool = False, dt_s: float = DT_S) -> Trajectory:
    """The 1 kHz trajectory of a path-parameter profile on the planning curve, upright or quasi-statically tilted."""
    n = math.ceil(profile.duration_s / dt_s - 1e-9)
    t = np.arange(n + 1) * dt_s
    s, sd, sdd = profile.evaluate(t)
    p1, p2 = geo.evaluate(s, 1), geo.evaluate(s, 2)
    acc = p2 * sd[:, None] ** 2 + p1 * sdd[:, None]
    euler, rates = container_orientation(acc, dt_s, tilt)
    return Trajectory(t, geo.evaluate(s), p1 * sd[:, None], acc, euler, rates, name=name)


def toppra_move(geo, vel_box, acc_box, robot: RobotLimits, tilt: bool = False) -> Trajectory:
    """TOPP-RA along the path, container upright or at the quasi-static tilt."""
    name = "TOPP-RA" + (" + tilt" if tilt else "")
    return along_path(geo, toppra_profile(geo, vel_box, acc_box, robot), name, tilt)


def toppra_shaped(geo, vel_box, acc_box, robot: RobotLimits, params: SloshParams) -> Trajectory:
    """TOPP-RA's path parameter convolved with a ZVD shaper for the liquid, container upright."""
    from sloshid.comparison.shapers import design_shaper, shape

    profile = shape(toppra_profile(geo, vel_box, acc_box, robot), design_shaper("ZVD", params))
    return along_path(geo, profile, "TOPP-RA + ZVD")
