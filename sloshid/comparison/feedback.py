"""Vision feedback on top of a feedforward move: Kalman filter (filterpy) on camera frames, LQR (python-control).

Per horizontal axis the robot adds an acceleration u_fb = -K [dp, dv, e, e'] to the feedforward, where dp, dv
are its own deviation from the feedforward (known exactly from the encoders) and e, e' the estimated liquid
angle relative to the commanded container tilt. A camera sees the float relative to the container at
`camera_fps` with Gaussian noise, and each frame reaches the controller `latency_s` late; the filter rewinds
to the frame's time, updates, and re-predicts with the inputs it has applied since (no information is lost
to latency, only timeliness). The plant in the loop is the robot's tracking (20 Hz) in series with the
linearised liquid of the *true* parameters; the filter and the LQR use the *model's* parameters. Feedback
keeps acting after the feedforward ends until the container is back on the goal and the estimated slosh is
calm; the executed trajectory (feedforward plus feedback) is what the comparison scores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

from sloshid.comparison.robot_tracking import filter_columns, hold_after, robot_tf
from sloshid.core.errors import UserError
from sloshid.model.conventions import TILT_AXES, G
from sloshid.model.pendulum import SloshParams, linear_tf
from sloshid.model.trajectory import Trajectory


@dataclass(frozen=True)
class FeedbackSettings:
    """The camera and the LQR weights of the feedback variant (the [compare.feedback] table)."""

    camera_fps: float = 30.0
    """Camera frame rate in frames per second."""
    latency_s: float = 0.05
    """Delay from exposure to the measurement reaching the controller (image transfer and processing), s."""
    noise_deg: float = 0.3
    """Standard deviation of the measured float angle, degrees."""
    seed: int = 0
    """Seed of the measurement noise (runs are reproducible)."""
    pos_tol_m: float = 0.01
    """LQR (Bryson): acceptable position deviation from the feedforward, m."""
    vel_tol_m_s: float = 0.05
    """LQR (Bryson): acceptable velocity deviation, m/s."""
    angle_tol_deg: float = 0.5
    """LQR (Bryson): acceptable relative liquid angle, degrees."""
    acc_tol_m_s2: float = 0.5
    """LQR (Bryson): acceptable feedback acceleration; also its saturation, m/s^2."""
    settle_s: float = 3.0
    """How long feedback may keep acting after the feedforward has arrived, s."""
    calm_deg: float = 0.2
    """The move counts as arrived once the estimated slosh amplitude stays below this (and the position is back), deg."""

    def __post_init__(self) -> None:
        for name in (
            "camera_fps",
            "noise_deg",
            "pos_tol_m",
            "vel_tol_m_s",
            "angle_tol_deg",
            "acc_tol_m_s2",
            "calm_deg",
        ):
            if not getattr(self, name) > 0:
                raise UserError(f"[compare.feedback] {name} must be positive, got {getattr(self, name)!r}.")
        if not (0 <= self.latency_s < 1.0 and 0 < self.settle_s <= 30):
            raise UserError("[compare.feedback] latency_s must be in [0, 1) s and settle_s in (0, 30] s.")


def lqr_gain(model: SloshParams, s: FeedbackSettings) -> np.ndarray:
    """LQR gain on [dp, dv, e, e'] for the double integrator plus the linearised liquid (seed eq. 5)."""
    a = np.array([[0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, -G / model.l_m, -model.damping_rate_1_s]])
    b = np.array([[0.0], [1.0], [0.0], [1.0 / model.l_m]])
    q = np.diag([s.pos_tol_m**-2, s.vel_tol_m_s**-2, math.radians(s.angle_tol_deg) ** -2, 0.0])
    k, _, _ = control.lqr(a, b, q, np.array([[s.acc_tol_m_s2**-2]]))
    return np.asarray(k)[0]


def slosh_filter(model: SloshParams, dt_s: float, s: FeedbackSettings) -> KalmanFilter:
    """Kalman filter on [liquid angle, rate] driven by the commanded acceleration, measured by the camera."""
    a = np.array([[0.0, 1.0], [-G / model.l_m, -model.damping_rate_1_s]])
    disc = control.c2d(control.ss(a, [[0.0], [1.0 / model.l_m]], [[1.0, 0.0]], [[0.0]]), dt_s)
    kf = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
    kf.F, kf.B, kf.H = np.asarray(disc.A), np.asarray(disc.B), np.array([[1.0, 0.0]])
    kf.R = np.array([[math.radians(s.noise_deg) ** 2]])
    kf.Q = Q_discrete_white_noise(2, dt_s, var=math.radians(5.0) ** 2 * model.omega_rad_s**3)  # model error
    kf.P = np.diag([math.radians(0.5) ** 2, (math.radians(0.5) * model.omega_rad_s) ** 2])
    return kf


@dataclass
class FeedbackRun:
    """The executed trajectory (feedforward plus feedback, until settled) and what the filter saw."""

    trajectory: Trajectory
    estimate_rms_deg: float
    """RMS error of the filter's liquid angle against the plant's, degrees."""
    frames: int
    """Camera frames used."""


def run_feedback(
    traj: Trajectory, model: SloshParams, truth: SloshParams, s: FeedbackSettings, bandwidth_hz: float = 20.0
) -> FeedbackRun:
    """Simulate the camera-in-the-loop feedback on `traj` with the liquid `truth`, designed for `model`."""
    padded = hold_after(traj, s.settle_s)
    t, dt, n = padded.t_s, padded.dt_s, len(padded.t_s)
    robot = robot_tf(bandwidth_hz)
    tilt_cmd = np.column_stack([sign * padded.euler_rad[:, e] for _, e, sign in TILT_AXES])
    tilt_rate = np.column_stack([sign * padded.euler_rate_rad_s[:, e] for _, e, sign in TILT_AXES])
    tilt_exec = filter_columns(robot, t, tilt_cmd)
    plant = control.c2d(control.ss(control.series(robot, linear_tf(truth))), dt)
    pa, pb, pc = (np.asarray(m) for m in (plant.A, plant.B, plant.C))
    gain = lqr_gain(model, s)
    filters = [slosh_filter(model, dt, s) for _ in TILT_AXES]
    rng = np.random.default_rng(s.seed)
    frame_step = 1.0 / (s.camera_fps * dt)
    lag = round(s.latency_s / dt)
    x_plant = np.zeros((len(TILT_AXES), pa.shape[0]))
    dev = np.zeros((len(TILT_AXES), 2))  # dp, dv per axis
    u_fb = np.zeros((n, len(TILT_AXES)))
    dev_hist = np.zeros((n, len(TILT_AXES), 2))
    q_true = np.zeros((n, len(TILT_AXES)))
    q_est = np.zeros((n, len(TILT_AXES)))
    amp_est = np.zeros((n, len(TILT_AXES)))  # estimated slosh amplitude relative to the commanded tilt
    history: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in TILT_AXES]
    pending: list[tuple[int, int, np.ndarray]] = []  # (arrival step, frame step, measurement per axis)
    next_frame, frames = 0.0, 0
    for j in range(n):
        q_true[j] = (pc @ x_plant[:, :, None])[:, 0, 0]
        if j >= next_frame:
            meas = q_true[j] - tilt_exec[j] + rng.normal(0.0, math.radians(s.noise_deg), len(TILT_AXES))
            pending.append((j + lag, j, meas))
            next_frame += frame_step
        for k, kf in enumerate(filters):
            history[k].append((kf.x.copy(), kf.P.copy()))
        while pending and pending[0][0] <= j:
            _, j0, meas = pending.pop(0)
            frames += 1
            _late_update(filters, history, j0, j, meas + tilt_cmd[j0], padded.acc_m_s2, u_fb)
        for k, kf in enumerate(filters):
            q_est[j, k] = kf.x[0, 0]
            err = np.array([dev[k, 0], dev[k, 1], kf.x[0, 0] - tilt_cmd[j, k], kf.x[1, 0] - tilt_rate[j, k]])
            amp_est[j, k] = math.hypot(err[2], err[3] / model.omega_rad_s)
            u_fb[j, k] = float(np.clip(-gain @ err, -s.acc_tol_m_s2, s.acc_tol_m_s2))
        dev_hist[j] = dev
        a_cmd = padded.acc_m_s2[j, [a for a, _, _ in TILT_AXES]] + u_fb[j]
        for k, kf in enumerate(filters):
            kf.predict(u=np.array([[a_cmd[k]]]))
        x_plant = (pa @ x_plant[:, :, None])[:, :, 0] + pb[:, 0] * a_cmd[:, None]
        dev = np.column_stack([dev[:, 0] + dev[:, 1] * dt + 0.5 * u_fb[j] * dt * dt, dev[:, 1] + u_fb[j] * dt])
    end = arrival_index(dev_hist, amp_est, len(traj.t_s), math.radians(s.calm_deg))
    run = _executed(padded, dev_hist, u_fb, end, f"{traj.name} + feedback ({s.camera_fps:g} fps)")
    rms = float(np.degrees(np.sqrt(np.mean((q_est[:end] - q_true[:end]) ** 2))))
    return FeedbackRun(run, rms, frames)


def _late_update(filters, history, j0: int, j: int, measured: np.ndarray, acc: np.ndarray, u_fb: np.ndarray) -> None:
    """A camera frame taken at step j0 arrives at step j (latency): rewind each filter to j0, update with the
    measured surface angle, and predict forward again with the inputs applied since."""
    for k, kf in enumerate(filters):
        kf.x, kf.P = (a.copy() for a in history[k][j0])
        kf.update(np.array([[measured[k]]]))
        for i in range(j0, j):
            history[k][i] = (kf.x.copy(), kf.P.copy())
            kf.predict(u=np.array([[acc[i, TILT_AXES[k][0]] + u_fb[i, k]]]))
        history[k][j] = (kf.x.copy(), kf.P.copy())


def _executed(padded: Trajectory, dev_hist: np.ndarray, u_fb: np.ndarray, end: int, name: str) -> Trajectory:
    """The feedforward plus the feedback's corrections (position, velocity, acceleration), cut at arrival."""
    pos, vel, acc = padded.pos_m.copy(), padded.vel_m_s.copy(), padded.acc_m_s2.copy()
    for k, (col, _, _) in enumerate(TILT_AXES):
        pos[:, col] += dev_hist[:, k, 0]
        vel[:, col] += dev_hist[:, k, 1]
        acc[:, col] += u_fb[:, k]
    cut = slice(0, end)
    return Trajectory(
        padded.t_s[cut], pos[cut], vel[cut], acc[cut], padded.euler_rad[cut], padded.euler_rate_rad_s[cut], name=name
    )


def arrival_index(
    dev_hist: np.ndarray,
    amp_est: np.ndarray,
    n_ff: int,
    calm_rad: float,
    pos_tol_m: float = 1e-3,
    vel_tol_m_s: float = 5e-3,
) -> int:
    """Samples until the container is back on the goal (1 mm, 5 mm/s) and the estimated slosh calm, for good."""
    n = len(dev_hist)
    off = (np.abs(dev_hist[:, :, 0]) > pos_tol_m).any(axis=1) | (np.abs(dev_hist[:, :, 1]) > vel_tol_m_s).any(axis=1)
    off |= (amp_est > calm_rad).any(axis=1)
    off[:n_ff] = True
    last = np.flatnonzero(off)
    return int(min(n, last[-1] + 2)) if len(last) else n
