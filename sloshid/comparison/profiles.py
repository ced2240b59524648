"""Classical rest-to-rest motion profiles along straight segments between waypoints (stop at each).

A profile is a 1-D path coordinate s(t) along one segment (`PathProfile`); `sample_move` turns a chain of
them into a 1 kHz container `Trajectory`, upright or tilted quasi-statically to the liquid's steady tilt.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from sloshid.core.errors import UserError
from sloshid.model.conventions import steady_tilt
from sloshid.model.trajectory import EXPORT_RATE_HZ, Trajectory

DT_S = 1.0 / EXPORT_RATE_HZ
"""Sample period of every profile: the robot's control rate."""


class NotApplicable(Exception):
    """A method cannot be built for this scenario; the comparison shows it as 'not applicable' with this reason."""


@dataclass(frozen=True)
class MoveTask:
    """What every method has to do: visit the waypoints in order, stopping at each, within box limits."""

    waypoints: tuple[tuple[float, float, float], ...]
    """Start, intermediate stops, goal (m)."""
    acc_max_m_s2: tuple[float, float, float]
    """Acceleration limit per axis."""
    vel_max_m_s: tuple[float, float, float]
    """Velocity limit per axis."""

    def __post_init__(self) -> None:
        if len(self.waypoints) < 2:
            raise UserError("a move needs at least a start and a goal.")
        for name in ("acc_max_m_s2", "vel_max_m_s"):
            if len(getattr(self, name)) != 3 or min(getattr(self, name)) <= 0:
                raise UserError(f"{name} must be three positive numbers, got {getattr(self, name)!r}.")

    def segments(self) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """(start point, unit direction, length in m) of each straight leg; zero-length legs are dropped."""
        legs = []
        for a, b in zip(self.waypoints[:-1], self.waypoints[1:]):
            delta = np.subtract(b, a, dtype=float)
            length = float(np.linalg.norm(delta))
            if length > 1e-9:
                legs.append((np.asarray(a, float), delta / length, length))
        if not legs:
            raise UserError("start and goal coincide: there is nothing to move.")
        return legs

    @staticmethod
    def path_limit(box: Sequence[float], direction: np.ndarray) -> float:
        """Largest path-coordinate bound that keeps every axis of `direction * s` within `box`."""
        return min(b / abs(e) for b, e in zip(box, direction) if abs(e) > 1e-12)


@dataclass(frozen=True)
class PathProfile:
    """Path coordinate along one segment as a function of time since the segment's start."""

    length_m: float
    duration_s: float
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
    """t -> (s, s', s''); defined for any t (at rest before 0 and after the duration)."""


def trapezoid(length_m: float, acc_max: float, vel_max: float) -> PathProfile:
    """Time-optimal rest-to-rest profile under |s''| <= acc_max, |s'| <= vel_max (bang-bang or trapezoidal)."""
    t_acc = min(vel_max / acc_max, math.sqrt(length_m / acc_max))
    v_peak = acc_max * t_acc
    t_cruise = (length_m - acc_max * t_acc**2) / v_peak
    t1, t2 = t_acc, t_acc + t_cruise
    total = t2 + t_acc

    def evaluate(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, float)
        moving = (t >= 0.0) & (t < total)
        t = np.clip(t, 0.0, total)
        up, cruise, down = t < t1, (t >= t1) & (t < t2), t >= t2
        tau = t - t2
        s = np.where(up, 0.5 * acc_max * t**2, 0.0)
        s = np.where(cruise, 0.5 * acc_max * t1**2 + v_peak * (t - t1), s)
        s = np.where(down, length_m - 0.5 * acc_max * (total - t) ** 2, s)
        sd = np.where(up, acc_max * t, np.where(cruise, v_peak, v_peak - acc_max * tau))
        sdd = np.where(up, acc_max, np.where(cruise, 0.0, -acc_max))
        sdd = np.where(moving, sdd, 0.0)
        return s, sd, sdd

    return PathProfile(length_m, total, evaluate)


def container_orientation(acc_m_s2: np.ndarray, dt_s: float, tilt: bool) -> tuple[np.ndarray, np.ndarray]:
    """Container euler angles and rates: upright (zeros), or quasi-static, at the liquid's steady tilt per sample."""
    euler = np.zeros_like(acc_m_s2)
    if tilt:
        euler[:, 0], euler[:, 1] = steady_tilt(acc_m_s2[:, 0], acc_m_s2[:, 1], acc_m_s2[:, 2])
    return euler, np.gradient(euler, dt_s, axis=0)


def sample_move(
    move: MoveTask,
    profiles: Sequence[PathProfile],
    name: str,
    tilt: bool = False,
    dt_s: float = DT_S,
) -> Trajectory:
    """Chain one PathProfile per segment of `move` on a uniform grid (each leg ends at rest on a grid point)."""
    legs = move.segments()
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    t0 = 0.0
    for (start, direction, _length), prof in zip(legs, profiles):
        n = math.ceil(prof.duration_s / dt_s - 1e-9)
        t = np.arange(n + 1) * dt_s
        s, sd, sdd = prof.evaluate(t)
        if chunks:  # the first sample repeats the previous leg's last one
            t, s, sd, sdd = t[1:], s[1:], sd[1:], sdd[1:]
        chunks.append((t0 + t, start + np.outer(s, direction), np.outer(sd, direction), np.outer(sdd, direction)))
        t0 += n * dt_s
    t, pos, vel, acc = (np.concatenate(parts) for parts in zip(*chunks))
    t = np.arange(len(t)) * dt_s  # exact uniform grid (no accumulated round-off)
    euler, rates = container_orientation(acc, dt_s, tilt)
    return Trajectory(t, pos, vel, acc, euler, rates, name=name)


def constant_acceleration(move: MoveTask) -> Trajectory:
    """Method 1: the seed's 'classical' planning, trapezoidal velocity per leg, container upright."""
    profiles = [
        trapezoid(length, MoveTask.path_limit(move.acc_max_m_s2, e), MoveTask.path_limit(move.vel_max_m_s, e))
        for _, e, length in move.segments()
    ]
    return sample_move(move, profiles, "constant acceleration")
