"""Time-optimal jerk-limited moves from the ruckig library (offline calculation), upright or tilt-compensated.

Each leg is one rest-to-rest ruckig problem in x, y, z with phase synchronisation (a straight line between
waypoints); intermediate waypoints without stopping need Ruckig Pro, so the container stops at each, as in
every other method. The trajectory is sampled with ruckig's own `at_time` at 1 kHz.
"""

from __future__ import annotations

import math

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Synchronization
from ruckig import Trajectory as RuckigTrajectory

from sloshid.comparison.profiles import DT_S, MoveTask, NotApplicable, container_orientation
from sloshid.model.trajectory import Trajectory


def ruckig_leg(start, goal, move: MoveTask, jerk_max_m_s3: float) -> RuckigTrajectory:
    """One rest-to-rest ruckig trajectory; raises NotApplicable when ruckig reports an error."""
    inp = InputParameter(3)
    inp.current_position = list(map(float, start))
    inp.target_position = list(map(float, goal))
    inp.current_velocity = inp.current_acceleration = [0.0] * 3
    inp.target_velocity = inp.target_acceleration = [0.0] * 3
    inp.max_velocity = list(move.vel_max_m_s)
    inp.max_acceleration = list(move.acc_max_m_s2)
    inp.max_jerk = [jerk_max_m_s3] * 3
    inp.synchronization = Synchronization.Phase
    traj = RuckigTrajectory(3)
    result = Ruckig(3).calculate(inp, traj)
    if result not in (Result.Working, Result.Finished):
        raise NotApplicable(f"ruckig could not compute the leg {tuple(start)} -> {tuple(goal)} ({result.name}).")
    return traj


def jerk_limited(move: MoveTask, jerk_max_m_s3: float, tilt: bool = False, dt_s: float = DT_S) -> Trajectory:
    """Methods 3 and 4: ruckig's time-optimal jerk-limited move through the waypoints (stop at each)."""
    t_parts: list[np.ndarray] = []
    pos_parts: list[np.ndarray] = []
    vel_parts: list[np.ndarray] = []
    acc_parts: list[np.ndarray] = []
    t0 = 0.0
    for _k, (start, goal) in enumerate(zip(move.waypoints[:-1], move.waypoints[1:])):
        if np.allclose(start, goal):
            continue
        leg = ruckig_leg(start, goal, move, jerk_max_m_s3)
        n = math.ceil(leg.duration / dt_s - 1e-9)
        times = np.arange(0 if not t_parts else 1, n + 1) * dt_s
        samples = [leg.at_time(min(t, leg.duration)) for t in times]
        t_parts.append(t0 + times)
        for parts, i in ((pos_parts, 0), (vel_parts, 1), (acc_parts, 2)):
            parts.append(np.array([s[i] for s in samples]))
        t0 += n * dt_s
    if not t_parts:
        raise NotApplicable("start and goal coincide.")
    pos, vel, acc = (np.concatenate(p) for p in (pos_parts, vel_parts, acc_parts))
    t = np.arange(len(pos)) * dt_s
    name = "jerk-limited (ruckig)" + (" + tilt" if tilt else "")
    euler, rates = container_orientation(acc, dt_s, tilt)
    return Trajectory(t, pos, vel, acc, euler, rates, name=name)
