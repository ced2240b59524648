"""Kalman filter + RTS smoother (filterpy) of an angle trace on its real, uneven timestamps, bridging gaps.

Model: a slowly drifting baseline plus a lightly damped oscillator at the trace's dominant frequency
(found with a Welch PSD of the valid samples), both driven by white noise; F and Q are discretised for
every step's own dt (Van Loan). A sloshing angle is exactly such a signal, so frames with valid = 0 are
bridged along the oscillation instead of by a straight or cubic line. Traces too short for a spectrum
fall back to a constant-velocity model. Noise levels are set from the valid data's own spread.
SciPy and filterpy are imported on first use, so a command starts fast; `SmoothingWorker` imports them in a forked
process beside decoding, as their imports would hold this process's GIL against the measuring loop for seconds.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import signal
import sys

import numpy as np

from sloshid.core.parallel import forked_helper

MEASUREMENT_SIGMA_DEG = 0.05
"""Standard deviation of a quality-1 angle measurement, degrees (tracker accuracy on synthetic video)."""
ASSUMED_ZETA = 0.05
"""Damping ratio of the bridging oscillator (typical sloshing); the data corrects it wherever measured."""
BASELINE_CHANGE_PER_PERIOD = 0.5
"""How much the baseline may move within one oscillation period, relative to the trace's spread."""
OSCILLATION_CHANGE_PER_PERIOD = 1.0
"""How much the oscillation may change within one period, relative to the trace's spread: small values
bridge gaps more faithfully, large ones follow sudden excitation (a tap) without ringing; 1.0 balances both."""


def dominant_omega(t: np.ndarray, z: np.ndarray) -> float | None:
    """Angular frequency (rad/s) of the strongest spectral peak of valid samples, or None if too short."""
    from sloshid.core.spectrum import welch_spectrum  # SciPy on first use: `track` warms it up while decoding

    if len(t) < 32 or t[-1] - t[0] <= 0:
        return None
    f = welch_spectrum(t, z, nperseg=min(len(t), 256)).peak_f_hz
    return 2 * math.pi * f if f > 0 else None


def _discretise(a: np.ndarray, qc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Van Loan: exact discrete F and Q of dx = A x dt + dW with spectral density Qc over a step dt."""
    from scipy.linalg import expm

    n = len(a)
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n], m[:n, n:], m[n:, n:] = -a, qc, a.T
    e = expm(m * dt)
    f = e[n:, n:].T
    return f, f @ e[:n, n:]


def _model(omega: float | None, spread: float, period: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, Qc, H): oscillator + baseline when omega is known, else constant velocity."""
    if omega is None:
        a = np.array([[0.0, 1.0], [0.0, 0.0]])
        qc = np.diag([0.0, (spread / period**1.5) ** 2 * 10])
        return a, qc, np.array([[1.0, 0.0]])
    a = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -(omega**2), -2 * ASSUMED_ZETA * omega]])
    # per period, the baseline (a robot move's quasi-static tilt) may move by half the trace's spread and
    # the oscillation change by its spread: stiffer settings lag behind moves and taps (measured on
    # synthetic traces), looser ones bridge gaps less faithfully
    qc = np.diag(
        [
            (BASELINE_CHANGE_PER_PERIOD * spread) ** 2 / period,
            0.0,
            (OSCILLATION_CHANGE_PER_PERIOD * spread * omega) ** 2 / period,
        ]
    )
    return a, qc, np.array([[1.0, 1.0, 0.0]])


def smooth_angle(t_s: np.ndarray, angle_deg: np.ndarray, valid: np.ndarray, quality: np.ndarray) -> np.ndarray:
    """RTS-smoothed angle (degrees) at every timestamp; invalid samples are bridged, not used."""
    from filterpy.kalman import predict as kf_predict
    from filterpy.kalman import rts_smoother
    from filterpy.kalman import update as kf_update

    t = np.asarray(t_s, float)
    z = np.asarray(angle_deg, float)
    ok = np.asarray(valid, bool) & np.isfinite(z)
    if ok.sum() < 2:
        return np.full(len(t), z[ok][0] if ok.any() else np.nan)
    omega = dominant_omega(t[ok], z[ok])
    spread = max(float(np.std(z[ok])), 10 * MEASUREMENT_SIGMA_DEG)
    period = 2 * math.pi / omega if omega else max(t[-1] - t[0], 1e-3)
    a, qc, h = _model(omega, spread, period)
    n = len(a)
    first = int(np.argmax(ok))
    x = np.zeros(n)
    x[0] = z[first]
    P = np.diag([spread**2, spread**2, (spread * (omega or 1.0)) ** 2][:n]) * 4
    dts = np.diff(t, prepend=t[0])
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    Fs, Qs = [], []
    for dt in dts:
        key = round(max(float(dt), 1e-6), 7)  # constant-rate videos reuse one discretisation
        if key not in cache:
            cache[key] = _discretise(a, qc, key)
        Fs.append(cache[key][0])
        Qs.append(cache[key][1])
    r = (MEASUREMENT_SIGMA_DEG / np.clip(np.asarray(quality, float), 0.05, 1.0)) ** 2
    xs, ps = np.zeros((len(t), n)), np.zeros((len(t), n, n))
    for k in range(len(t)):  # filterpy's functional filter: the same equations as KalmanFilter, less overhead
        x, P = kf_predict(x, P, Fs[k], Qs[k])
        if ok[k]:
            x, P = kf_update(x, P, z[k], r[k], h)
        xs[k], ps[k] = x, P
    # filterpy's functional smoother steps from k to k+1 with Fs[k]; ours hold the step into k: shift by one
    smoothed, _, _, _ = rts_smoother(xs, ps, Fs[1:] + Fs[-1:], Qs[1:] + Qs[-1:])
    return smoothed @ h[0]


def warm_up() -> None:
    """Import the smoother's libraries (seconds of start-up)."""
    import filterpy.kalman  # noqa: F401
    import scipy.linalg
    import scipy.signal  # noqa: F401


class SmoothingWorker:
    """`smooth_angle` in a process forked before decoding, which imports SciPy and filterpy on the other core.

    In this process those imports (1-2 s of Python) hold the GIL against the measuring loop even from a thread. The
    fork happens only when asked (`fork`, off for batches running many videos side by side), while filterpy is not
    imported yet and on Linux, where fork is the default start method; otherwise, or when the worker is gone (killed,
    out of memory), `smooth` runs here, with the same result.
    """

    def __init__(self, fork: bool = True) -> None:
        self._proc = self._conn = None
        if fork and "filterpy.kalman" not in sys.modules and sys.platform.startswith("linux"):
            ctx = multiprocessing.get_context("fork")
            self._conn, child = ctx.Pipe()
            self._proc = ctx.Process(
                target=_serve, args=(child, self._conn, os.getpid()), daemon=True, name="sloshid-smoother"
            )
            self._proc.start()
            child.close()

    def smooth(self, t_s: np.ndarray, angle_deg: np.ndarray, valid: np.ndarray, quality: np.ndarray) -> np.ndarray:
        """`smooth_angle` of the arguments, computed by the worker when there is one."""
        if self._proc is not None and self._conn is not None:
            try:
                self._conn.send((t_s, angle_deg, valid, quality))
                done, smoothed = self._conn.recv()
                if done:
                    return smoothed
            except (EOFError, OSError):
                pass  # the worker is gone: smooth here
            finally:
                self.close()
        return smooth_angle(t_s, angle_deg, valid, quality)

    def close(self) -> None:
        """Stop the worker: it has sent its result and ended, or it was given nothing and is ended now."""
        if self._proc is not None:
            if self._conn is not None:
                self._conn.close()
            if self._proc.is_alive():
                self._proc.terminate()
            self._proc.join()
            self._proc = None


_early: SmoothingWorker | None = None
"""The worker `start_early` forked, until a run takes it (`smoothing_worker`) or `discard_early` stops it."""


def start_early() -> None:
    """Fork the smoother first thing in a `sloshid track` run: its second of SciPy and filterpy imports then runs beside
    the command's own imports (OpenCV, PyAV) and the opening of the video, which leave the other core idle, instead of
    beside the decoding, which uses both."""
    global _early
    if _early is None:
        _early = SmoothingWorker()


def smoothing_worker(fork: bool = True) -> SmoothingWorker:
    """The smoother for a run: the one `start_early` forked when there is one (and `fork`), else a new one."""
    global _early
    worker, _early = _early, None
    if worker is not None and fork:
        return worker
    if worker is not None:
        worker.close()
    return SmoothingWorker(fork)


def discard_early() -> None:
    """Stop an early-forked smoother that no run took (the command failed before it tracked)."""
    global _early
    if _early is not None:
        _early.close()
        _early = None


def _serve(conn, callers_end, parent_pid: int) -> None:
    """The worker: import, wait for one trace, send (True, smoothed); (False, None) when smoothing raised, so the
    caller repeats it and raises the error itself; nothing when the caller closed the pipe or the user interrupted.

    It first lets go of what fork copied from the caller: the caller's end of the pipe (else a caller that dies
    without closing it, e.g. on SIGTERM, never reads as EOF here and the worker waits forever), the caller's output
    (a program waiting for the caller's stderr to close would wait for the worker too) and its SIGTERM handler
    (`terminate` must simply end the worker); and it ends with the caller, even one killed outright."""
    callers_end.close()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    forked_helper(parent_pid)
    quiet = os.open(os.devnull, os.O_WRONLY)
    os.dup2(quiet, 1)
    os.dup2(quiet, 2)
    try:
        warm_up()
        args = conn.recv()
    except (EOFError, KeyboardInterrupt):
        return
    try:
        conn.send((True, smooth_angle(*args)))
    except Exception:
        conn.send((False, None))
    except KeyboardInterrupt:
        return
