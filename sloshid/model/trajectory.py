"""A container trajectory sampled on a uniform grid (what a robot executes), its CSV form and its limits check.

Orientation convention: R = Rz(psi) Ry(theta) Rx(phi) (intrinsic Z-Y-X), so phi is the roll about x0 and
theta the pitch about y0 of design.md; quaternions are scalar-last (qx, qy, qz, qw).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from sloshid.core.errors import UserError
from sloshid.core.outputs import Outputs
from sloshid.core.settings import setting_field
from sloshid.core.tables import read_csv, write_csv

EXPORT_RATE_HZ = 1000.0
"""Rate of every trajectory sloshid writes or compares: a Franka Panda's 1 kHz control rate."""

CSV_COLUMNS = (
    "t_s",
    "x_m",
    "y_m",
    "z_m",
    "vx_m_s",
    "vy_m_s",
    "vz_m_s",
    "ax_m_s2",
    "ay_m_s2",
    "az_m_s2",
    "phi_rad",
    "theta_rad",
    "psi_rad",
    "wx_rad_s",
    "wy_rad_s",
    "wz_rad_s",
    "qx",
    "qy",
    "qz",
    "qw",
)


def euler_rates_to_omega(euler_rad: np.ndarray, rates_rad_s: np.ndarray) -> np.ndarray:
    """World-frame angular velocity of R = Rz(psi) Ry(theta) Rx(phi) from (phi, theta, psi) and their rates."""
    _phi, theta, psi = np.moveaxis(np.atleast_2d(euler_rad), -1, 0)
    dphi, dtheta, dpsi = np.moveaxis(np.atleast_2d(rates_rad_s), -1, 0)
    cps, sps, cth, sth = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
    wx = -sps * dtheta + cps * cth * dphi
    wy = cps * dtheta + sps * cth * dphi
    wz = dpsi - sth * dphi
    return np.stack([wx, wy, wz], axis=-1)


TRAJECTORY_DIGITS = 12
"""Significant digits of the trajectory CSV: a robot that checks jerk differentiates the 1 kHz positions three times,
and at 9 digits (1 nm at 1 m) those jerks were quantised in steps of 1 m/s^3 (a plan holding 8 read 11)."""


@dataclass
class Trajectory:
    """Container pose, velocity and acceleration on a uniform time grid (SI units, rad)."""

    t_s: np.ndarray
    """Sample times, uniform, starting at the start of the move (N,)."""
    pos_m: np.ndarray
    """Container position x, y, z (N, 3)."""
    vel_m_s: np.ndarray
    """Container velocity (N, 3)."""
    acc_m_s2: np.ndarray
    """Container acceleration, the liquid model's input u (N, 3)."""
    euler_rad: np.ndarray
    """Container orientation phi (roll about x), theta (pitch about y), psi (yaw) (N, 3)."""
    euler_rate_rad_s: np.ndarray
    """Time derivatives of phi, theta, psi (N, 3)."""
    name: str = ""
    """Which method produced it (shown in tables and legends)."""

    def __post_init__(self) -> None:
        n = len(self.t_s)
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray) and f.name != "t_s" and value.shape != (n, 3):
                raise ValueError(f"Trajectory.{f.name} has shape {value.shape}, expected ({n}, 3)")

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample."""
        return float(self.t_s[-1] - self.t_s[0])

    @property
    def dt_s(self) -> float:
        """Sample period."""
        return float(self.t_s[1] - self.t_s[0])

    @property
    def omega_rad_s(self) -> np.ndarray:
        """World-frame angular velocity (N, 3)."""
        return euler_rates_to_omega(self.euler_rad, self.euler_rate_rad_s)

    @property
    def quaternion_xyzw(self) -> np.ndarray:
        """Orientation as unit quaternions, scalar last (N, 4)."""
        return Rotation.from_euler("ZYX", self.euler_rad[:, ::-1]).as_quat()

    @property
    def z_axis(self) -> np.ndarray:
        """The container's z-axis in the world frame (N, 3): the arrows of the seed's Fig. 9."""
        return Rotation.from_euler("ZYX", self.euler_rad[:, ::-1]).apply([0.0, 0.0, 1.0])

    def table(self) -> np.ndarray:
        """All CSV columns as one (N, 20) array, in CSV_COLUMNS order."""
        return np.column_stack(
            [self.t_s, self.pos_m, self.vel_m_s, self.acc_m_s2, self.euler_rad, self.omega_rad_s, self.quaternion_xyzw]
        )

    def columns(self) -> dict[str, np.ndarray]:
        """The robot-ready table keyed by CSV_COLUMNS."""
        return dict(zip(CSV_COLUMNS, self.table().T))

    def to_csv(self, path: str | Path, inputs: tuple[str | Path, ...] = ()) -> None:
        """Write the robot-ready CSV (columns CSV_COLUMNS) atomically: a .csv file, never over one of `inputs`."""
        write_csv(Outputs(inputs).file(path, "the trajectory", (".csv",)), self.columns(), TRAJECTORY_DIGITS)

    @classmethod
    def from_csv(cls, path: str | Path, name: str = "") -> Trajectory:
        """Read a CSV written by `to_csv` (euler rates are recovered from the angular velocity)."""
        return cls.from_columns(read_csv(path), str(path), name or Path(path).stem)

    @classmethod
    def from_columns(cls, data: dict[str, np.ndarray], path: str, name: str) -> Trajectory:
        """The trajectory held by CSV_COLUMNS-named columns read from `path`."""
        missing = [c for c in CSV_COLUMNS if c not in data]
        if missing:
            raise UserError(f"trajectory file {path} lacks columns {', '.join(missing)}.")
        col = lambda *names: np.column_stack([data[n] for n in names])  # noqa: E731
        euler = col("phi_rad", "theta_rad", "psi_rad")
        omega = col("wx_rad_s", "wy_rad_s", "wz_rad_s")
        rates = np.linalg.solve(_omega_matrix(euler), omega[..., None])[..., 0]
        return cls(
            data["t_s"],
            col("x_m", "y_m", "z_m"),
            col("vx_m_s", "vy_m_s", "vz_m_s"),
            col("ax_m_s2", "ay_m_s2", "az_m_s2"),
            euler,
            rates,
            name=name,
        )


def _omega_matrix(euler_rad: np.ndarray) -> np.ndarray:
    """(N, 3, 3) matrices E with omega = E @ [dphi, dtheta, dpsi] (the map of euler_rates_to_omega)."""
    return np.stack([euler_rates_to_omega(euler_rad, np.eye(3)[i]) for i in range(3)], axis=-1)


@dataclass(frozen=True)
class RobotLimits:
    """Cartesian limits of the robot that executes the trajectory; defaults: Franka Emika Panda datasheet."""

    vel_m_s: float = setting_field(1.7, unit="m/s")
    """Translational speed (norm)."""
    acc_m_s2: float = setting_field(13.0, unit="m/s^2")
    """Translational acceleration (norm)."""
    jerk_m_s3: float = setting_field(6500.0, unit="m/s^3")
    """Translational jerk (norm)."""
    rot_vel_rad_s: float = setting_field(2.5, unit="rad/s")
    """Angular speed (norm)."""
    rot_acc_rad_s2: float = setting_field(25.0, unit="rad/s^2")
    """Angular acceleration (norm)."""
    rot_jerk_rad_s3: float = setting_field(12500.0, unit="rad/s^3")
    """Angular jerk (norm)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            if not getattr(self, f.name) > 0:
                raise UserError(f"robot limit {f.name} must be positive, got {getattr(self, f.name)!r}.")


@dataclass(frozen=True)
class LimitUsage:
    """Peak of one limited quantity over a trajectory."""

    quantity: str
    """Name with unit, as the RobotLimits field (e.g. `jerk_m_s3`)."""
    peak: float
    limit: float
    t_peak_s: float

    @property
    def ok(self) -> bool:
        """True when the peak stays within the limit (with 0.1 % slack for sampling round-off)."""
        return self.peak <= self.limit * 1.001

    @property
    def usage(self) -> float:
        """Peak as a share of the limit."""
        return self.peak / self.limit


def _rate(x: np.ndarray, dt: float) -> np.ndarray:
    """Forward difference per sample (what a 1 kHz controller sees between two commands); last row repeated."""
    d = np.diff(x, axis=0) / dt
    return np.vstack([d, d[-1:]])


def limit_profiles(traj: Trajectory) -> dict[str, np.ndarray]:
    """Norms of velocity, acceleration and jerk, translational and rotational, at each sample."""
    dt = traj.dt_s
    omega = traj.omega_rad_s
    alpha = _rate(omega, dt)
    return {
        "vel_m_s": np.linalg.norm(traj.vel_m_s, axis=1),
        "acc_m_s2": np.linalg.norm(traj.acc_m_s2, axis=1),
        "jerk_m_s3": np.linalg.norm(_rate(traj.acc_m_s2, dt), axis=1),
        "rot_vel_rad_s": np.linalg.norm(omega, axis=1),
        "rot_acc_rad_s2": np.linalg.norm(alpha, axis=1),
        "rot_jerk_rad_s3": np.linalg.norm(_rate(alpha, dt), axis=1),
    }


def check_limits(traj: Trajectory, limits: RobotLimits = RobotLimits()) -> list[LimitUsage]:
    """Peak of every limited quantity against `limits`; derivatives by finite differences on the sample grid."""
    usages = []
    for key, profile in limit_profiles(traj).items():
        i = int(np.argmax(profile))
        usages.append(LimitUsage(key, float(profile[i]), getattr(limits, key), float(traj.t_s[i])))
    return usages


def tilt_profiles(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Container tilt from upright (deg) and angular speed (deg/s) at every sample."""
    tilt = np.degrees(np.arccos(np.clip(traj.z_axis[:, 2], -1.0, 1.0)))
    return tilt, np.degrees(np.linalg.norm(traj.omega_rad_s, axis=1))


def check_move_limits(
    traj: Trajectory, acc_max, vel_max, tilt_max_deg: float, tilt_rate_max_deg_s: float, jerk_max=None
) -> list[LimitUsage]:
    """Peaks against a move's own limits (a scenario's [limits]): per-axis acceleration, velocity and, when given,
    jerk (the axis closest to its bound; jerk as the robot's limits take it, between two samples), tilt from upright
    and tilt rate; quantities named as the [limits] keys."""
    tilt, rate = tilt_profiles(traj)
    checks = {
        "acc_max": (np.abs(traj.acc_m_s2), np.asarray(acc_max, float)),
        "vel_max": (np.abs(traj.vel_m_s), np.asarray(vel_max, float)),
        **({} if jerk_max is None else {"jerk_max": (np.abs(_rate(traj.acc_m_s2, traj.dt_s)), np.asarray(jerk_max))}),
        "tilt_max_deg": (tilt[:, None], np.array([tilt_max_deg])),
        "tilt_rate_max_deg_s": (rate[:, None], np.array([tilt_rate_max_deg_s])),
    }
    usages = []
    for name, (values, bound) in checks.items():
        with np.errstate(invalid="ignore", divide="ignore"):  # an upright move's tilt: 0 of 0 deg
            use = np.nan_to_num(values / bound, nan=0.0)
        k, axis = np.unravel_index(int(np.argmax(use)), values.shape)
        usages.append(LimitUsage(name, float(values[k, axis]), float(bound[axis]), float(traj.t_s[k])))
    return usages
