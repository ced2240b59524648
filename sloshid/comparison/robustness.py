"""Model-error sweep: each method keeps its nominal plan while the true liquid's frequency and damping change.

Open-loop methods replay the same trajectory; feedback methods re-run their loop against the true liquid.
Every point is scored by the nonlinear `simulate_liquid`, as in the main comparison.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sloshid.comparison.feedback import FeedbackSettings, run_feedback
from sloshid.core.parallel import parallel_map
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import simulate_liquid
from sloshid.model.trajectory import Trajectory


@dataclass
class Replay:
    """What a method executes when the true liquid is `truth`: its fixed trajectory, or its feedback loop re-run."""

    trajectory: Trajectory
    """The open-loop move, or the feedforward under the feedback."""
    model: SloshParams | None = None
    """Feedback only: the liquid the filter and LQR are designed for."""
    feedback: FeedbackSettings | None = None
    """Feedback only: camera and LQR settings (None: open loop)."""
    bandwidth_hz: float = 20.0
    """Feedback only: robot tracking bandwidth in the loop, Hz."""

    def __call__(self, truth: SloshParams) -> Trajectory:
        """The executed trajectory against the true liquid."""
        if self.feedback is None or self.model is None:
            return self.trajectory
        return run_feedback(self.trajectory, self.model, truth, self.feedback, self.bandwidth_hz).trajectory


def peak_and_residual(job: tuple[Replay, SloshParams, float]) -> tuple[float, float]:
    """Peak relative angle during the move and residual after it (deg) of one replay against one true liquid
    (a picklable unit of work)."""
    replay, truth, settle_s = job
    resp = simulate_liquid(replay(truth), truth, settle_s=settle_s)
    return resp.peak_during_deg, resp.residual_deg


def residual(job: tuple[Replay, SloshParams, float]) -> float:
    """Residual slosh (deg) of one replay against one true liquid (a picklable unit of work)."""
    return peak_and_residual(job)[1]


def band_responses(
    replays: dict[str, Replay], truths: Sequence[SloshParams], settle_s: float, progress: bool = False, workers: int = 1
) -> dict[str, np.ndarray]:
    """Per method: (peak during, residual) in deg against each true liquid, shape (len(truths), 2)."""
    jobs = [(replay, truth, settle_s) for replay in replays.values() for truth in truths]
    flat = parallel_map(peak_and_residual, [(job,) for job in jobs], workers, progress=progress, desc="frequency band")
    n = len(truths)
    return {label: np.array(flat[i * n : (i + 1) * n]) for i, label in enumerate(replays)}


DENSE_STEP = 0.05
"""Frequency factors at most this far apart (the default sweep's step) are read as covering the range between them;
coarser ones are named as points (a ZV move held at -10 % and 0 % left 0.73 deg at -5 %)."""


@dataclass
class RobustnessResult:
    """Residual slosh (deg) per method against the true/model frequency ratio and damping ratio."""

    omega_factors: np.ndarray
    """True natural frequency / identified one (damping nominal)."""
    zeta_factors: np.ndarray
    """True damping ratio / identified one (frequency nominal)."""
    residual_vs_omega_deg: dict[str, np.ndarray]
    residual_vs_zeta_deg: dict[str, np.ndarray]

    def tolerance_band(self, label: str, limit_deg: float) -> tuple[float, float] | None:
        """Widest interval of frequency factors around 1 (contiguous sweep points) with residual <= limit_deg."""
        f, r = self.omega_factors, self.residual_vs_omega_deg[label]
        i = int(np.argmin(np.abs(f - 1.0)))
        if r[i] > limit_deg:
            return None
        lo = hi = i
        while lo > 0 and r[lo - 1] <= limit_deg:
            lo -= 1
        while hi < len(f) - 1 and r[hi + 1] <= limit_deg:
            hi += 1
        return float(f[lo]), float(f[hi])

    def describe_band(self, label: str, limit_deg: float) -> str:
        """`tolerance_band` in words: a range when the swept points lie at most DENSE_STEP apart in it, else the
        points themselves, since between coarse points the residual was not simulated and can exceed the limit
        (a ZV move held at -10 % and 0 % left 0.73 deg at -5 %)."""
        band = self.tolerance_band(label, limit_deg)
        if band is None:
            return "none"
        f = self.omega_factors[(self.omega_factors >= band[0]) & (self.omega_factors <= band[1])]
        if f.size < 2 or np.max(np.diff(f)) <= DENSE_STEP + 1e-9:
            return f"{100 * (band[0] - 1):+.0f} % .. {100 * (band[1] - 1):+.0f} %"
        return "at " + ", ".join(f"{100 * (x - 1):+.0f} %" for x in f) + " (swept points; not simulated between them)"

    def to_dict(self) -> dict:
        """JSON-ready form (lists)."""
        return {
            "omega_factors": self.omega_factors.tolist(),
            "zeta_factors": self.zeta_factors.tolist(),
            "residual_vs_omega_deg": {k: v.tolist() for k, v in self.residual_vs_omega_deg.items()},
            "residual_vs_zeta_deg": {k: v.tolist() for k, v in self.residual_vs_zeta_deg.items()},
        }


def sweep(
    replays: dict[str, Replay],
    params: SloshParams,
    omega_factors: Sequence[float],
    zeta_factors: Sequence[float],
    settle_s: float = 1.0,
    progress: bool = False,
    workers: int = 1,
) -> RobustnessResult:
    """Residual slosh of every method at every (true omega, nominal zeta) and (nominal omega, true zeta) point.

    The residual peaks in the first slosh period after arrival, so `settle_s` = 1 s covers it for f > 1 Hz;
    `workers` > 1 spreads the points over that many processes.
    """
    omega_factors = np.asarray(sorted(set(omega_factors) | {1.0}), float)  # the nominal point is always swept
    zeta_factors = np.asarray(sorted(set(zeta_factors) | {1.0}), float)
    truths = [params.scaled(f, 1.0) for f in omega_factors] + [params.scaled(1.0, z) for z in zeta_factors]
    jobs = [(replay, truth, settle_s) for replay in replays.values() for truth in truths]
    flat = parallel_map(residual, [(job,) for job in jobs], workers, progress=progress, desc="robustness sweep")
    by_omega, by_zeta = {}, {}
    for i, label in enumerate(replays):
        row = np.array(flat[i * len(truths) : (i + 1) * len(truths)])
        by_omega[label], by_zeta[label] = row[: len(omega_factors)], row[len(omega_factors) :]
    return RobustnessResult(omega_factors, zeta_factors, by_omega, by_zeta)
