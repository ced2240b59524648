"""Any recorded container motion as the liquid model's input: a robot pose log (time, position, orientation) turned
into the acceleration of the pendulum pivot and the container orientation, and the liquid's angles back in the
container's frame.

Frames: the pendulums live in the world frame (z up, gravity -z), which does not turn with the container; a rotation
about the vertical axis through the pivot therefore accelerates nothing and makes no slosh, and vertical acceleration
changes the effective gravity to g + az (`simulate_liquid`). The pivot sits `axis_offset_m` up the container axis
from the logged point (about the liquid surface at rest), so a tilt about the logged point moves the pivot; a turn
about a horizontal axis is felt where linear potential theory puts it, below the pivot (`respond`'s `depths_m`).
Accelerations come from a Savitzky-Golay filter (polynomial order 5, window `smooth_s`), never from raw double
differences: zero phase, and with the default 0.1 s window the gain at 3 Hz is 0.999 (`savgol_acceleration_response`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter
from scipy.spatial.transform import Rotation, Slerp

from sloshid.core.errors import SettingError, UserError, input_file
from sloshid.core.tables import read_table
from sloshid.model.conventions import G, wall_height_mm
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import CSV_COLUMNS, Trajectory

SMOOTH_S = 0.1
"""Default Savitzky-Golay window (s) for accelerations from a pose log."""
SG_ORDER = 5
"""Savitzky-Golay polynomial order: flat to 0.1 % at 3 Hz with the 0.1 s window (order 3 would lose 6 %)."""
UNIT_TOL = 1e-3
"""A quaternion whose norm differs from 1 by more than this is refused (logs round to ~1e-6)."""
REST_SPEED_M_S = 5e-3
"""A log whose mean speed over its first (last) tenth of a smoothing window is below this starts (ends) at rest; a
robot log's position noise of some 10 um reads as 1 mm/s over 10 ms."""
MOVE_TOL_M = 1e-5
"""Pose change (m of position, or rad of rotation times 1 m) that counts as the container moving."""
DEFAULT_COLUMNS = ("t", "x", "y", "z", "qx", "qy", "qz", "qw")
"""Column order assumed for a headerless 8-column log (the shared antisloshing commands)."""
ALIASES = {
    "t": ("t", "t_s", "time", "time_s", "timestamp", "times"),
    "x": ("x", "x_m", "px", "pos_x", "position_x"),
    "y": ("y", "y_m", "py", "pos_y", "position_y"),
    "z": ("z", "z_m", "pz", "pos_z", "position_z"),
    "qx": ("qx", "quat_x", "orientation_x"),
    "qy": ("qy", "quat_y", "orientation_y"),
    "qz": ("qz", "quat_z", "orientation_z"),
    "qw": ("qw", "quat_w", "orientation_w"),
    "roll": ("roll", "roll_rad", "phi", "phi_rad", "roll_deg", "phi_deg"),
    "pitch": ("pitch", "pitch_rad", "theta", "theta_rad", "pitch_deg", "theta_deg"),
    "yaw": ("yaw", "yaw_rad", "psi", "psi_rad", "yaw_deg", "psi_deg"),
}
"""Header names accepted for each pose quantity (positions in m; angles in rad unless the name ends in _deg)."""


@dataclass
class PoseLog:
    """A container pose over time: the logged point's position and the container's orientation."""

    t_s: np.ndarray
    """Sample times (N,), strictly increasing."""
    pos_m: np.ndarray
    """Logged point, world frame, z up (N, 3)."""
    rot: Rotation
    """Container orientation, container frame to world frame (N rotations; its z axis is the container axis)."""
    source: str = "array"
    acc_m_s2: np.ndarray | None = None
    """The logged point's exact acceleration when the file carries it (sloshid trajectory CSV); else None."""

    def __post_init__(self) -> None:
        if self.t_s.size < 2:
            raise UserError(f"{self.source}: a pose log needs at least 2 samples; it has {self.t_s.size}.")
        if np.any(np.diff(self.t_s) <= 0):
            k = int(np.argmax(np.diff(self.t_s) <= 0)) + 1
            raise UserError(f"{self.source}: the pose log's time does not increase at sample {k}.")

    @property
    def move_span_s(self) -> tuple[float, float]:
        """(start, end) of the motion: the first and last sample whose pose differs from the idle start and end."""

        def differs(k: int) -> np.ndarray:
            angle = (self.rot[k].inv() * self.rot).magnitude()
            return (np.linalg.norm(self.pos_m - self.pos_m[k], axis=1) > MOVE_TOL_M) | (angle > MOVE_TOL_M)

        away_start, away_end = np.flatnonzero(differs(0)), np.flatnonzero(differs(-1))
        if away_start.size == 0:
            raise UserError(f"{self.source}: the container never moves in this pose log.")
        return float(self.t_s[max(away_start[0] - 1, 0)]), float(self.t_s[min(away_end[-1] + 1, self.t_s.size - 1)])

    def uniform(self) -> PoseLog:
        """The log on a uniform grid at its median step (positions linear, orientations slerped); self if uniform."""
        dt = float(np.median(np.diff(self.t_s)))
        if np.allclose(np.diff(self.t_s), dt, rtol=1e-3, atol=1e-9):
            return self
        t = self.t_s[0] + dt * np.arange(math.floor((self.t_s[-1] - self.t_s[0]) / dt + 1e-9) + 1)
        t = np.minimum(t, self.t_s[-1])  # the last step's rounding may pass the log's end, where Slerp refuses
        pos = np.column_stack([np.interp(t, self.t_s, self.pos_m[:, i]) for i in range(3)])
        return PoseLog(t, pos, Slerp(self.t_s, self.rot)(t), self.source)


@dataclass
class Excitation:
    """What the liquid feels: the pivot's world acceleration and the container's orientation on a uniform grid."""

    t_s: np.ndarray
    acc_m_s2: np.ndarray
    """Pivot acceleration, world frame (N, 3)."""
    rot: Rotation
    """Container orientation (N)."""
    move_span_s: tuple[float, float]
    smooth_s: float
    axis_offset_m: float
    axis_acc_m_s2: np.ndarray | None = None
    """Second derivative of the container's unit axis (N, 3): a point d further up the axis accelerates at
    acc_m_s2 + d x it (None: taken as zero)."""

    def acc_at(self, depth_m: float) -> np.ndarray:
        """The world acceleration of the point depth_m below the pivot on the container's axis (N, 3)."""
        if depth_m == 0 or self.axis_acc_m_s2 is None:
            return self.acc_m_s2
        return self.acc_m_s2 - depth_m * self.axis_acc_m_s2


def savgol_acceleration_response(f_hz: float, rate_hz: float, smooth_s: float = SMOOTH_S) -> complex:
    """Gain and phase (as one complex ratio) of the Savitzky-Golay acceleration against the true one at f_hz."""
    n = _window_samples(smooth_s, rate_hz)
    h = savgol_coeffs(n, SG_ORDER, deriv=2, delta=1.0 / rate_hz, use="dot")
    w = 2 * math.pi * f_hz
    k = np.arange(n) - n // 2
    return complex(np.sum(h * np.exp(1j * w * k / rate_hz)) / -(w**2))


def _window_samples(smooth_s: float, rate_hz: float) -> int:
    """Odd window length in samples for a window of smooth_s seconds, lengthened to the fit's order + 2 samples when
    shorter (the default 0.1 s on a 30 Hz log, or 0.2 s: 7 samples); one of fewer than two samples is no smoothing
    window at all and is refused (--smooth-s 0.001 ran as 0.014 s on a 500 Hz log without a word)."""
    if not (smooth_s > 0 and math.isfinite(smooth_s)):
        raise SettingError("smooth_s", f"the smoothing window {{name}} must be a positive number, got {smooth_s!r} s.")
    least = SG_ORDER + 2 | 1
    if smooth_s * rate_hz < 2:
        raise SettingError(
            "smooth_s",
            f"the smoothing window {{name}} {smooth_s:g} s is shorter than two samples of the pose log "
            f"({rate_hz:.4g} Hz); the order-{SG_ORDER} Savitzky-Golay fit takes at least {least / rate_hz:.3g} s.",
        )
    return max(round(smooth_s * rate_hz) | 1, least)


def excitation(pose: PoseLog, axis_offset_m: float = 0.0, smooth_s: float = SMOOTH_S) -> Excitation:
    """Pivot acceleration (Savitzky-Golay second derivative of the pivot's position) and orientation of a pose log."""
    pose = pose.uniform()
    dt = float(pose.t_s[1] - pose.t_s[0])
    n = _window_samples(smooth_s, 1.0 / dt)
    if pose.t_s.size < n:
        raise UserError(f"{pose.source}: {pose.t_s.size} samples are fewer than the {n}-sample smoothing window.")
    axis = pose.rot.apply([0.0, 0.0, 1.0])

    # a log that starts (ends) at rest is continued at rest for a window before (after) it, and the excitation runs
    # over that rest too: the ends' polynomial, extrapolated across a move that starts at the first sample, read
    # 0.47 m/s2 there instead of 0, and a smoothed deceleration cut at the log's end stepped to zero (a 0.12 deg slosh
    # predicted for a slosh-free plan); a log that starts or stops mid-move keeps the extrapolation
    point = pose.pos_m + axis_offset_m * axis
    k = max(1, n // 10)  # the mean speed over the first (last) tenth of a window: the ends' own polynomials err
    speed = [np.linalg.norm(point[k] - point[0]) / (k * dt), np.linalg.norm(point[-1] - point[-1 - k]) / (k * dt)]
    before, after = (n if v < REST_SPEED_M_S else 0 for v in speed)

    def rest(x: np.ndarray) -> np.ndarray:
        """`x` (one row per sample) continued by its first row before and its last row after."""
        return np.concatenate([np.repeat(x[:1], before, axis=0), x, np.repeat(x[-1:], after, axis=0)])

    def second_derivative(x: np.ndarray) -> np.ndarray:
        """SG acceleration of `x` continued at rest; the window's polynomial extrapolated at the ends."""
        return savgol_filter(rest(x), n, SG_ORDER, deriv=2, delta=dt, axis=0, mode="interp")

    axis_acc = second_derivative(axis)
    if pose.acc_m_s2 is not None:  # exact point acceleration from the file; only the offset's part is smoothed
        acc = axis_offset_m * axis_acc
        acc[before : before + pose.t_s.size] += pose.acc_m_s2
    else:
        acc = second_derivative(point)
    _check_plausible(pose.source, acc, axis[0])
    t = np.concatenate(
        [pose.t_s[0] - dt * np.arange(before, 0, -1), pose.t_s, pose.t_s[-1] + dt * np.arange(1, after + 1)]
    )
    rot = Rotation.from_quat(rest(pose.rot.as_quat()))
    return Excitation(t, acc, rot, pose.move_span_s, smooth_s, axis_offset_m, axis_acc)


MOTION_QUANTITIES = {
    "vertical_accel_m_s2": "vertical acceleration",
    "horizontal_accel_m_s2": "horizontal acceleration",
    "speed_m_s": "speed",
    "tilt_deg": "tilt",
    "yaw_rate_deg_s": "yaw rate",
}
"""The quantities of a move that say how far it is from the ones a model was fitted on (key: words for a user)."""


def motion_range(exc: Excitation) -> dict[str, float]:
    """The largest of each MOTION_QUANTITIES over a move: the pivot's vertical and horizontal acceleration and speed
    (the acceleration integrated from rest), the container's tilt from upright and its turning rate about the vertical."""
    dt = float(exc.t_s[1] - exc.t_s[0])
    vel = np.cumsum(exc.acc_m_s2, axis=0) * dt
    axis = exc.rot.apply([0.0, 0.0, 1.0])
    turn = (exc.rot[1:] * exc.rot[:-1].inv()).as_rotvec()[:, 2] / dt
    return {
        "vertical_accel_m_s2": float(np.max(np.abs(exc.acc_m_s2[:, 2]))),
        "horizontal_accel_m_s2": float(np.max(np.linalg.norm(exc.acc_m_s2[:, :2], axis=1))),
        "speed_m_s": float(np.max(np.linalg.norm(vel, axis=1))),
        "tilt_deg": float(np.degrees(np.max(np.arccos(np.clip(axis[:, 2], -1.0, 1.0))))),
        "yaw_rate_deg_s": float(np.degrees(np.max(np.abs(turn)))) if turn.size else 0.0,
    }


MAX_ACCEL_M_S2 = 100.0
"""A pose log whose point accelerates faster than this (about 10 g; a Franka Panda reaches 13 m/s2, fast industrial
arms some 50) is refused: positions in millimetres read as metres give a thousand times the acceleration."""
MAX_START_TILT_DEG = 90.0
"""A container that starts tilted further than this from upright holds no liquid: a quaternion read in the wrong
order (w, x, y, z as x, y, z, w) turns an upright start upside down. Refused."""


def _check_plausible(source: str, acc: np.ndarray, start_axis: np.ndarray) -> None:
    """Refuse a pose log in the wrong units (millimetres) or orientation convention (quaternion order)."""
    peak = float(np.max(np.linalg.norm(acc, axis=1)))
    if peak > MAX_ACCEL_M_S2:
        raise UserError(
            f"{source}: the logged point accelerates at up to {peak:.4g} m/s2 ({peak / G:.0f} g), beyond any robot "
            "carrying an open liquid; are its positions in millimetres? They must be in metres."
        )
    tilt = math.degrees(math.acos(float(np.clip(start_axis[2], -1.0, 1.0))))
    if tilt > MAX_START_TILT_DEG:
        raise UserError(
            f"{source}: the container starts tilted {tilt:.0f} deg from upright (180: upside down), where it holds no "
            "liquid; is the quaternion order x, y, z, w (w last; `pose_columns` names it)?"
        )


@dataclass
class PoseResponse:
    """The liquid's response to an Excitation: surface angles in the world and relative to the container."""

    t_s: np.ndarray
    acc_m_s2: np.ndarray
    """Pivot acceleration (N, 3), zero after the log ends."""
    liquid_rad: np.ndarray
    """World-frame surface roll phi and pitch theta (N, 2), the pendulum states."""
    rel_rad: np.ndarray
    """Surface tilt in the container frame, roll about its x and pitch about its y (N, 2)."""
    rel_angle_rad: np.ndarray
    """Angle between surface normal and container axis (N,)."""
    move_span_s: tuple[float, float]
    slope: np.ndarray | None = None
    """The pendulum surface's gradient in the container frame (N, 2): its magnitude is tan(relative angle)."""
    static_slope: np.ndarray | None = None
    """The gradient of the surface at rest under the acceleration (ax, ay, g + az) of the pivot (or, with `respond`'s
    `depths_m`, of the point below it where the faster modes feel a turn), in the container frame (N, 2): where the
    liquid's faster modes, which follow the motion, lift it."""

    @property
    def rel_angle_deg(self) -> np.ndarray:
        """Relative angle magnitude in degrees."""
        return np.degrees(self.rel_angle_rad)

    def wall_height_mm(self, radius_m: float) -> np.ndarray:
        """Highest point of the tilted plane at the wall, R tan(relative angle), in mm."""
        return wall_height_mm(radius_m, self.rel_angle_rad)


def respond(
    exc: Excitation,
    params: SloshParams,
    input_gain: float = 1.0,
    settle_s: float = 3.0,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    vertical_gain: float = 1.0,
    spherical: bool = False,
    drag: float = 0.0,
    depths_m: tuple[float, float] = (0.0, 0.0),
) -> PoseResponse:
    """Integrate the pendulums (simulate_liquid; `spherical`: one spherical pendulum with its `drag`) under the pivot acceleration;
    horizontal input scaled by input_gain, vertical by vertical_gain (gravity becomes g + vertical_gain az).
    `depths_m`: how far below the pivot the pendulum hangs and the static surface's acceleration is taken
    (`pendulum.rotation_depths`; they differ only while the container turns about a horizontal axis)."""
    gains = np.array([input_gain, input_gain, vertical_gain])
    acc, hung = exc.acc_m_s2 * gains, exc.acc_at(depths_m[0]) * gains
    zero = np.zeros_like(acc)
    # integrated from the log's start: at a logger's Unix time (1.7e9 s) a tenth of a microsecond is the spacing of
    # the numbers, finer than the solver's steps, and the solver gave up
    t0 = float(exc.t_s[0])
    # only t_s and acc_m_s2 drive the liquid
    traj = Trajectory(exc.t_s - t0, zero, zero, hung, zero, zero, name="pivot")
    res = simulate_liquid(traj, params, settle_s, rtol, atol, spherical, drag)
    n_after = res.t_s.size - exc.t_s.size
    quat = exc.rot.as_quat()
    rot = Rotation.from_quat(np.vstack([quat, np.repeat(quat[-1:], n_after, axis=0)]))  # the last pose is held
    phi, theta = res.liquid_rad[:, 0], res.liquid_rad[:, 1]
    normal = np.column_stack([np.cos(phi) * np.sin(theta), -np.sin(phi), np.cos(phi) * np.cos(theta)])
    local = rot.inv().apply(normal)
    rel = np.column_stack([np.arctan2(-local[:, 1], local[:, 2]), np.arctan2(local[:, 0], local[:, 2])])
    magnitude = np.arccos(np.clip(local[:, 2], -1.0, 1.0))
    acc_all = np.vstack([acc, np.zeros((n_after, 3))])
    static = np.vstack([exc.acc_at(depths_m[1]) * gains, np.zeros((n_after, 3))])
    rest = rot.inv().apply(static + np.array([0.0, 0.0, G]))
    return PoseResponse(
        res.t_s + t0, acc_all, res.liquid_rad, rel, magnitude, exc.move_span_s, _gradient(local), _gradient(rest)
    )


def _gradient(normal: np.ndarray) -> np.ndarray:
    """Gradient (dz/dx, dz/dy) of the plane with this normal in the container frame; held to a slope of 5 (79 deg)
    where the plane stands near upright."""
    g = -normal[:, :2] / np.maximum(normal[:, 2:3], 1e-9)
    size = np.linalg.norm(g, axis=1, keepdims=True)
    return g * np.minimum(1.0, 5.0 / np.maximum(size, 1e-12))


def pose_from_trajectory(traj: Trajectory, source: str = "trajectory") -> PoseLog:
    """A sloshid Trajectory as a PoseLog that keeps its exact accelerations."""
    rot = Rotation.from_euler("ZYX", traj.euler_rad[:, ::-1])
    return PoseLog(np.asarray(traj.t_s, float), np.asarray(traj.pos_m, float), rot, source, traj.acc_m_s2)


def load_pose_log(path: str | Path, columns: str | None = None) -> PoseLog:
    """Read a sloshid trajectory CSV or a robot pose log (header or not, `,` or `;`; see ALIASES for the names).

    `columns` names a headerless file's columns in order, comma-separated (`_` skips one), e.g.
    `t,x,y,z,qx,qy,qz,qw` (the default for 8 columns) or `t,x,y,z,roll_deg,pitch_deg,yaw_deg`."""
    p = input_file(path, "trajectory file")
    if p.suffix.lower() == ".mat":  # read as text it is "not UTF-8", which sends the user to the wrong fix
        raise UserError(
            f"{p} is a .mat file, a measured signal: the trajectory is the robot's pose log or a sloshid trajectory "
            "(CSV); a measurement is validated against (`measured`) or identified."
        )
    table = read_table(p)
    header, data = table.header, table.data
    if header is not None and all(c in header for c in CSV_COLUMNS) and columns is None:
        _check_finite(p, data[:, [header.index(c) for c in CSV_COLUMNS]])
        traj = Trajectory.from_columns(dict(zip(header, data.T)), str(p), p.stem)
        return pose_from_trajectory(traj, str(p))
    names = _column_names(header, columns, data.shape[1], p)
    return _pose_from_columns(names, data, p)


def _column_names(header: list[str] | None, columns: str | None, ncols: int, p: Path) -> list[str]:
    """Canonical names (t, x, ..., qw or roll/pitch/yaw with a unit) of the file's columns, '' for unused ones."""
    given = [c.strip().lower() for c in columns.split(",")] if columns else None
    if given is None and header is None:
        if ncols != len(DEFAULT_COLUMNS):
            raise SettingError(
                "pose_columns",
                f"{p} has no header and {ncols} columns; name them with {{name}} "
                "(e.g. t,x,y,z,qx,qy,qz,qw or t,x,y,z,roll_deg,pitch_deg,yaw_deg).",
            )
        given = list(DEFAULT_COLUMNS)
    raw = given if given is not None else [h.strip().lower() for h in header or ()]
    if len(raw) != ncols:
        raise SettingError("pose_columns", f"{{name}} names {len(raw)} columns but {p} has {ncols}.")
    names = []
    for name in raw:
        canon = next((k for k, alias in ALIASES.items() if name in alias), "")
        if canon in ("roll", "pitch", "yaw"):
            canon += "_deg" if name.endswith("_deg") else "_rad"
        if given is not None and not canon and name not in ("_", "-", ""):
            raise SettingError(
                "pose_columns", f"{{name}}: unknown column name '{name}'; use t, x, y, z, qx..qw, roll, pitch, yaw."
            )
        names.append(canon)
    return names


def _check_finite(p: Path, data: np.ndarray) -> None:
    """Refuse a log whose used columns hold NaN or inf (a logger's dropped sample), naming the first such row."""
    bad = np.flatnonzero(~np.all(np.isfinite(data), axis=1))
    if bad.size:
        raise UserError(f"{p}: data row {bad[0] + 1} holds NaN or an infinite value; drop or fill the incomplete rows.")


def _pose_from_columns(names: list[str], data: np.ndarray, p: Path) -> PoseLog:
    """Build the PoseLog from canonical column names; quaternions must be unit."""
    base = [n.split("_")[0] for n in names]
    col = lambda key: data[:, base.index(key)]  # noqa: E731
    need = ["t", "x", "y", "z"]
    quat, rpy = all(q in base for q in ("qx", "qy", "qz", "qw")), all(a in base for a in ("roll", "pitch", "yaw"))
    missing = [k for k in need if k not in base]
    if missing or not (quat or rpy):
        what = ", ".join(missing) or "an orientation (qx, qy, qz, qw or roll, pitch, yaw)"
        raise SettingError("pose_columns", f"{p} lacks {what}; name the columns with a header or {{name}}.")
    _check_finite(p, data[:, [i for i, n in enumerate(names) if n]])
    pos = np.column_stack([col("x"), col("y"), col("z")])
    if quat:
        q = np.column_stack([col("qx"), col("qy"), col("qz"), col("qw")])
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > UNIT_TOL)
        if bad.size:
            raise UserError(
                f"{p}: the quaternion on data row {bad[0] + 1} has norm {norm[bad[0]]:.4g}, not 1 "
                "(orientation must be a unit quaternion x, y, z, w)."
            )
        rot = Rotation.from_quat(q)
    else:
        degrees = names[base.index("roll")].endswith("_deg")
        rot = Rotation.from_euler("ZYX", np.column_stack([col("yaw"), col("pitch"), col("roll")]), degrees=degrees)
    return PoseLog(col("t"), pos, rot, str(p))
