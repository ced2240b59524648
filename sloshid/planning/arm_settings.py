"""The [robot] table's arm keys (`ArmSettings`) and the Panda's datasheet limits they are checked against: apart from
`arm`, which needs pinocchio, so that reading a scenario never imports it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.settings import from_dict, setting_field

MODELS = ("panda",)
"""Arms sloshid knows."""

# Franka Emika Panda datasheet ("Robot and interface specifications", joint space), rad, rad/s, rad/s^2, rad/s^3
PANDA_Q_MIN = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
PANDA_Q_MAX = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
PANDA_DQ_MAX = np.array([2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100])
PANDA_DDQ_MAX = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
PANDA_DDDQ_MAX = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])
PANDA_Q_READY = (0.0, -0.785398, 0.0, -2.356194, 0.0, 1.570796, 0.785398)
"""Franka's 'ready' pose: the flange points down in front of the base."""


@dataclass(frozen=True)
class ArmSettings:
    """[robot] arm keys: which arm, where, the tool and the start configuration."""

    model: str = "panda"
    """Arm model; "panda" (Franka Emika Panda, from example-robot-data's URDF)."""
    base_xyz_m: tuple[float, float, float] = setting_field((0.0, 0.0, 0.0), unit="m")
    """Position of the arm's base in the scenario's world frame (m)."""
    base_rpy_deg: tuple[float, float, float] = setting_field((0.0, 0.0, 0.0), unit="deg")
    """Roll, pitch, yaw of the base in the world frame (deg, R = Rz Ry Rx)."""
    tool_offset_m: tuple[float, float, float] = setting_field((0.0, 0.0, 0.1), unit="m")
    """Liquid surface centre in the flange frame (m): the flange's z points down, so (0, 0, 0.1) is 0.1 m below."""
    q_start: list[float] = setting_field(default_factory=lambda: list(PANDA_Q_READY), unit="rad")
    """Joint angles near the start (rad), one per joint: a seed, from which the configuration that holds the container
    at the move's start is solved (the nearest, by least joint change)."""
    fit_joints: bool | None = None
    """When the arm cannot follow the fastest plan, re-plan it with lower Cartesian limits until it can (slower; the
    JSON's joints.fit lists each attempt's T in s). compare and run send such a fitted move unless [robot] fit_joints
    = false (then they say not to send the fastest); plan fits its joints only when asked (this, or fit_joints = true)."""

    @property
    def fits_sent_moves(self) -> bool:
        """Whether compare and run fit the move they send to this arm (all but `fit_joints = false`)."""
        return self.fit_joints is not False

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise UserError(f"[robot].model '{self.model}' is unknown; sloshid knows {', '.join(MODELS)}.")
        if len(self.q_start) != 7:
            raise UserError(f"[robot].q_start must give 7 joint angles (rad) for the Panda, got {len(self.q_start)}.")
        q = np.asarray(self.q_start, dtype=float)
        bad = np.nonzero((q < PANDA_Q_MIN) | (q > PANDA_Q_MAX))[0]
        if bad.size:
            j = int(bad[0])
            raise UserError(
                f"[robot].q_start joint {j + 1} = {q[j]:.4g} rad lies outside the Panda's range "
                f"[{PANDA_Q_MIN[j]:g}, {PANDA_Q_MAX[j]:g}] rad."
            )


def arm_settings(data: dict) -> ArmSettings:
    """Validate the arm keys of [robot] (UserError naming the key)."""
    return from_dict(ArmSettings, data, "[robot]")
