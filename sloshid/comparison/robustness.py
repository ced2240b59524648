"""Model-error sweep: each method keeps its nominal plan while the true liquid's frequency and damping change.

Open-loop methods replay the same trajectory; feedback methods re-run their loop against the true liquid (once per
true liquid: a loop's noise is seeded). Every point is scored by the nonlinear pendulums of the main comparison, all
points of a study in one batched `simulate_liquids`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from sloshid.comparison.feedback import FeedbackSettings, run_feedbacks
from sloshid.core.parallel import parallel_map
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import LiquidResponse, simulate_liquids
from sloshid.model.trajectory import Trajectory


def _liquid_key(truth: SloshParams) -> tuple[str, str]:
    """What a feedback loop's plant depends on (l and d/m), to 12 digits: `scaled(1, 1)` is the nominal liquid."""
    return f"{truth.l_m:.12g}", f"{truth.damping_rate_1_s:.12g}"


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
    runs: dict[tuple[str, str], Trajectory] = field(default_factory=dict, repr=False, compare=False)
    """Feedback only: the executed trajectories already run, by true liquid."""

    @property
    def closed_loop(self) -> bool:
        """True when the executed move depends on the true liquid (a feedback loop)."""
        return self.feedback is not None and self.model is not None

    def __call__(self, truth: SloshParams) -> Trajectory:
        """The executed trajectory against the true liquid."""
        if not self.closed_loop:
            return self.trajectory
        self.run_all([truth])
        return self.runs[_liquid_key(truth)]

    def run_all(self, truths: Sequence[SloshParams]) -> None:
        """Feedback only: run the loop against every true liquid not yet run, all of them in one pass."""
        todo = list({_liquid_key(t): t for t in truths if _liquid_key(t) not in self.runs}.values())
        if todo:
            assert self.model is not None and self.feedback is not None  # called for feedback loops only
            done = run_feedbacks(self.trajectory, self.model, todo, self.feedback, self.bandwidth_hz)
            self.runs.update({_liquid_key(t): run.trajectory for t, run in zip(todo, done)})


def replay_responses(
    pairs: Sequence[tuple[Replay, SloshParams]], settle_s: float, progress: bool = False, workers: int = 1
) -> list[LiquidResponse]:
    """The liquid's response to each replay against its true liquid: the feedback loops not yet run go first (each
    loop against all its true liquids in one pass, the loops over `workers` processes with a tqdm bar when
    `progress`), then every pendulum in one batched simulation."""
    loops: dict[int, tuple[Replay, list[SloshParams]]] = {}
    for replay, truth in pairs:
        if replay.closed_loop and _liquid_key(truth) not in replay.runs:
            loops.setdefault(id(replay), (replay, []))[1].append(truth)
    done = parallel_map(_run_all, list(loops.values()), workers, progress=progress, desc="feedback loops")
    for (replay, _), runs in zip(loops.values(), done):
        replay.runs.update(runs)
    return simulate_liquids([replay(truth) for replay, truth in pairs], [truth for _, truth in pairs], settle_s)


def _run_all(replay: Replay, truths: list[SloshParams]) -> dict[tuple[str, str], Trajectory]:
    """One feedback loop against its true liquids (a picklable unit of work); the executed trajectories by liquid."""
    replay.run_all(truths)
    return replay.runs


def band_responses(
    replays: dict[str, Replay], truths: Sequence[SloshParams], settle_s: float, progress: bool = False, workers: int = 1
) -> dict[str, np.ndarray]:
    """Per method: (peak during, residual) in deg against each true liquid, shape (len(truths), 2)."""
    pairs = [(replay, truth) for replay in replays.values() for truth in truths]
    flat = [(r.peak_during_deg, r.residual_deg) for r in replay_responses(pairs, settle_s, progress, workers)]
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
    `workers` > 1 spreads the feedback loops over that many processes.
    """
    omegas = np.asarray(sorted(set(omega_factors) | {1.0}), float)  # the nominal point is always swept
    zetas = np.asarray(sorted(set(zeta_factors) | {1.0}), float)
    truths = [params.scaled(f, 1.0) for f in omegas] + [params.scaled(1.0, z) for z in zetas]
    by_truth = band_responses(replays, truths, settle_s, progress, workers)
    by_omega, by_zeta = {}, {}
    for label, resp in by_truth.items():
        by_omega[label], by_zeta[label] = resp[: len(omegas), 1], resp[len(omegas) :, 1]
    return RobustnessResult(omegas, zetas, by_omega, by_zeta)
