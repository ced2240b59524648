"""Vision feedback on top of a feedforward move: Kalman filter on camera frames, LQR (python-control).

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

from sloshid.comparison.robot_tracking import filter_columns, hold_after, robot_tf
from sloshid.core.errors import UserError
from sloshid.core.settings import setting_field
from sloshid.model.conventions import TILT_AXES, G
from sloshid.model.pendulum import SloshParams, linear_tf
from sloshid.model.trajectory import Trajectory


@dataclass(frozen=True)
class FeedbackSettings:
    """The camera and the LQR weights of the feedback variant (the [compare.feedback] table)."""

    camera_fps: float = setting_field(30.0, unit="frames/s")
    """Camera frame rate in frames per second."""
    latency_s: float = setting_field(0.05, unit="s")
    """Delay from exposure to the measurement reaching the controller (image transfer and processing), s."""
    noise_deg: float = setting_field(0.3, unit="deg")
    """Standard deviation of the measured float angle, degrees."""
    seed: int = 0
    """Seed of the measurement noise (runs are reproducible)."""
    pos_tol_m: float = setting_field(0.01, unit="m")
    """LQR (Bryson): acceptable position deviation from the feedforward, m."""
    vel_tol_m_s: float = setting_field(0.05, unit="m/s")
    """LQR (Bryson): acceptable velocity deviation, m/s."""
    angle_tol_deg: float = setting_field(0.5, unit="deg")
    """LQR (Bryson): acceptable relative liquid angle, degrees."""
    acc_tol_m_s2: float = setting_field(0.5, unit="m/s^2")
    """LQR (Bryson): acceptable feedback acceleration; also its saturation, m/s^2."""
    settle_s: float = setting_field(3.0, unit="s")
    """How long feedback may keep acting after the feedforward has arrived, s."""
    calm_deg: float = setting_field(0.2, unit="deg")
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


@dataclass(frozen=True)
class SloshFilter:
    """Kalman filter on [liquid angle, rate] driven by the commanded acceleration, measured by the camera: the same
    matrices for both axes, and since both see the same frames and model, one covariance serves both."""

    F: np.ndarray
    B: np.ndarray
    Q: np.ndarray
    R: float
    P0: np.ndarray

    def predict(self, x: np.ndarray, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States x (..., 2) and covariance one step on under the accelerations u (...)."""
        return x @ self.F.T + u[..., None] * self.B, self.F @ P @ self.F.T + self.Q

    def update(self, x: np.ndarray, P: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Measured angles z (...) folded into the states x (..., 2) (Joseph form, as filterpy's KalmanFilter)."""
        k = P[:, 0] / (P[0, 0] + self.R)
        i_kh = np.eye(2) - np.outer(k, [1.0, 0.0])
        return x + (z - x[..., 0])[..., None] * k, i_kh @ P @ i_kh.T + self.R * np.outer(k, k)


def slosh_filter(model: SloshParams, dt_s: float, s: FeedbackSettings) -> SloshFilter:
    """The filter designed for the model's liquid at the camera's noise."""
    a = np.array([[0.0, 1.0], [-G / model.l_m, -model.damping_rate_1_s]])
    disc = control.c2d(control.ss(a, [[0.0], [1.0 / model.l_m]], [[1.0, 0.0]], [[0.0]]), dt_s)
    return SloshFilter(
        np.asarray(disc.A),
        np.asarray(disc.B)[:, 0],
        Q_discrete_white_noise(2, dt_s, var=math.radians(5.0) ** 2 * model.omega_rad_s**3),  # model error
        math.radians(s.noise_deg) ** 2,
        np.diag([math.radians(0.5) ** 2, (math.radians(0.5) * model.omega_rad_s) ** 2]),
    )


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
    return run_feedbacks(traj, model, [truth], s, bandwidth_hz)[0]


def run_feedbacks(
    traj: Trajectory, model: SloshParams, truths: list[SloshParams], s: FeedbackSettings, bandwidth_hz: float = 20.0
) -> list[FeedbackRun]:
    """`run_feedback` against several true liquids in one pass: each run has its own plant; the filter's covariance,
    the camera's frames and their seeded noise are the same in all of them."""
    padded = hold_after(traj, s.settle_s)
    t, dt, n = padded.t_s, padded.dt_s, len(padded.t_s)
    robot = robot_tf(bandwidth_hz)
    tilt_cmd = np.column_stack([sign * padded.euler_rad[:, e] for _, e, sign in TILT_AXES])
    tilt_rate = np.column_stack([sign * padded.euler_rate_rad_s[:, e] for _, e, sign in TILT_AXES])
    tilt_exec = filter_columns(robot, t, tilt_cmd)
    plants = [control.c2d(control.ss(control.series(robot, linear_tf(truth))), dt) for truth in truths]
    pa, pb, pc = (np.stack([np.asarray(getattr(p, m)) for p in plants]) for m in "ABC")  # one plant per run
    gain = lqr_gain(model, s)
    kf = slosh_filter(model, dt, s)
    axes = [a for a, _, _ in TILT_AXES]
    acc_ff = padded.acc_m_s2[:, axes]
    rng = np.random.default_rng(s.seed)
    frame_step = 1.0 / (s.camera_fps * dt)
    lag = round(s.latency_s / dt)
    powers = np.stack([np.linalg.matrix_power(kf.F, m) for m in range(lag + 1)])  # F^m: m predictions
    q_sum = np.zeros((lag + 1, 2, 2))  # the process noise m predictions add: sum of F^l Q F^l' for l < m
    for m in range(1, lag + 1):
        q_sum[m] = kf.F @ q_sum[m - 1] @ kf.F.T + kf.Q
    shape = (len(truths), len(axes))  # (run, axis) leads every per-step array
    x_plant = np.zeros((*shape, pa.shape[1]))
    x, P = np.zeros((*shape, 2)), kf.P0
    dev = np.zeros((*shape, 2))  # dp, dv per axis
    u_fb = np.zeros((n, *shape))
    dev_hist = np.zeros((n, *shape, 2))
    q_true = np.zeros((n, *shape))
    q_est = np.zeros((n, *shape))
    amp_est = np.zeros((n, *shape))  # estimated slosh amplitude relative to the commanded tilt
    x_hist, p_hist = np.zeros((n, *shape, 2)), np.zeros((n, 2, 2))  # the filter before each step's frames
    pending: list[tuple[int, int, np.ndarray]] = []  # (arrival step, frame step, measurement per run and axis)
    next_frame, frames = 0.0, 0
    for j in range(n):
        q_true[j] = np.einsum("rxs,rs->rx", x_plant, pc[:, 0])
        if j >= next_frame:
            meas = q_true[j] - tilt_exec[j] + rng.normal(0.0, math.radians(s.noise_deg), len(axes))
            pending.append((j + lag, j, meas))
            next_frame += frame_step
        x_hist[j], p_hist[j] = x, P
        while pending and pending[0][0] <= j:
            # a frame taken at step j0 arrives now (latency): rewind to j0, update with the measured surface angle,
            # and predict forward again with the inputs applied since: the filter is linear and those inputs stay,
            # so the update's correction moves step j0 + m by F^m, and the covariance follows its own recursion
            _, j0, meas = pending.pop(0)
            frames += 1
            x, P = kf.update(x_hist[j0], p_hist[j0], meas + tilt_cmd[j0])
            m = j - j0 + 1
            x_hist[j0 : j + 1] += np.einsum("mab,rxb->mrxa", powers[:m], x - x_hist[j0])
            p_hist[j0 : j + 1] = powers[:m] @ P @ powers[:m].transpose(0, 2, 1) + q_sum[:m]
            x, P = x_hist[j].copy(), p_hist[j].copy()
        q_est[j] = x[..., 0]
        err = np.concatenate([dev, (x - np.stack([tilt_cmd[j], tilt_rate[j]], axis=-1))], axis=-1)
        amp_est[j] = np.hypot(err[..., 2], err[..., 3] / model.omega_rad_s)
        u_fb[j] = np.clip(-(err @ gain), -s.acc_tol_m_s2, s.acc_tol_m_s2)
        dev_hist[j] = dev
        a_cmd = acc_ff[j] + u_fb[j]
        x, P = kf.predict(x, P, a_cmd)
        x_plant = np.einsum("rxs,rts->rxt", x_plant, pa) + pb[:, None, :, 0] * a_cmd[..., None]
        dev = np.stack([dev[..., 0] + dev[..., 1] * dt + 0.5 * u_fb[j] * dt * dt, dev[..., 1] + u_fb[j] * dt], -1)
    runs = []
    for r in range(len(truths)):
        end = arrival_index(dev_hist[:, r], amp_est[:, r], len(traj.t_s), math.radians(s.calm_deg))
        run = _executed(padded, dev_hist[:, r], u_fb[:, r], end, f"{traj.name} + feedback ({s.camera_fps:g} fps)")
        rms = float(np.degrees(np.sqrt(np.mean((q_est[:end, r] - q_true[:end, r]) ** 2))))
        runs.append(FeedbackRun(run, rms, frames))
    return runs


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
