"""ZV and ZVD input shapers tuned to the identified sloshing mode, applied to the constant-acceleration move.

Closed forms (Singer & Seering): K = exp(-zeta pi / sqrt(1 - zeta^2)), damped period Td = 2 pi / omega_d;
ZV puts impulses [1, K] / (1 + K) at [0, Td/2], ZVD [1, 2K, K^2] / (1 + K)^2 at [0, Td/2, Td], ZVDD (the robust
one: a flatter notch around the mode) [1, 3K, 3K^2, K^3] / (1 + K)^3 at [0, Td/2, Td, 3Td/2]. Amplitudes are
positive and sum to one, so the shaped move keeps the acceleration and velocity limits of the unshaped one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sloshid.comparison.profiles import MoveTask, PathProfile, sample_move, trapezoid
from sloshid.model.pendulum import SloshParams
from sloshid.model.trajectory import Trajectory


@dataclass(frozen=True)
class Shaper:
    """Impulse train that is convolved with a reference: times in s, amplitudes summing to one."""

    name: str
    times_s: tuple[float, ...]
    amplitudes: tuple[float, ...]

    @property
    def duration_s(self) -> float:
        """How much the shaper lengthens a move."""
        return self.times_s[-1]


def design_shaper(kind: Literal["ZV", "ZVD", "ZVDD"], params: SloshParams) -> Shaper:
    """ZV, ZVD or ZVDD shaper for the mode (omega, zeta) of `params`."""
    zeta = params.zeta
    root = math.sqrt(1.0 - zeta * zeta)
    k = math.exp(-zeta * math.pi / root)
    half_period = math.pi / (params.omega_rad_s * root)
    if kind == "ZV":
        return Shaper("ZV", (0.0, half_period), (1 / (1 + k), k / (1 + k)))
    if kind == "ZVD":
        norm = (1 + k) ** 2
        return Shaper("ZVD", (0.0, half_period, 2 * half_period), (1 / norm, 2 * k / norm, k * k / norm))
    if kind == "ZVDD":
        norm = (1 + k) ** 3
        amps = (1 / norm, 3 * k / norm, 3 * k * k / norm, k**3 / norm)
        return Shaper("ZVDD", tuple(i * half_period for i in range(4)), amps)
    raise ValueError(f"unknown shaper {kind!r}")


def shape(profile: PathProfile, shaper: Shaper) -> PathProfile:
    """The profile convolved with the shaper's impulses, evaluated exactly (no grid rounding of impulse times)."""

    def evaluate(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        parts = [profile.evaluate(np.asarray(t, float) - ti) for ti in shaper.times_s]
        zero = np.zeros(np.shape(t))
        pos, vel, acc = (sum((a * p[k] for a, p in zip(shaper.amplitudes, parts)), zero) for k in range(3))
        return pos, vel, acc

    return PathProfile(profile.length_m, profile.duration_s + shaper.duration_s, evaluate)


def shaped_constant_acceleration(move: MoveTask, params: SloshParams, kind: Literal["ZV", "ZVD", "ZVDD"]) -> Trajectory:
    """Method 2: the constant-acceleration move of every leg shaped with a ZV, ZVD or ZVDD shaper, container upright."""
    shaper = design_shaper(kind, params)
    profiles = [
        shape(
            trapezoid(length, MoveTask.path_limit(move.acc_max_m_s2, e), MoveTask.path_limit(move.vel_max_m_s, e)),
            shaper,
        )
        for _, e, length in move.segments()
    ]
    return sample_move(move, profiles, f"{kind} shaped")
