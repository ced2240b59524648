"""Model-error sweep: each method keeps its nominal plan while the true liquid's frequency and damping change.

Open-loop methods replay the same trajectory; feedback methods re-run their loop against the true liquid.
Every point is scored by the nonlinear `simulate_liquid`, as in the main comparison.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from tqdm import tqdm

from .model import SloshParams
from .simulate import simulate_liquid
from .trajectory import Trajectory

Replay = Callable[[SloshParams], Trajectory]
"""The trajectory a method executes when the true liquid is the given one (open loop: always the same)."""


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
    settle_s: float = 1.5,
    progress: bool = False,
) -> RobustnessResult:
    """Residual slosh of every method at every (true omega, nominal zeta) and (nominal omega, true zeta) point."""
    omega_factors = np.asarray(sorted(omega_factors), float)
    zeta_factors = np.asarray(sorted(zeta_factors), float)
    truths = [params.scaled(f, 1.0) for f in omega_factors] + [params.scaled(1.0, z) for z in zeta_factors]
    bar = tqdm(total=len(replays) * len(truths), desc="robustness sweep", disable=not progress, leave=False)
    by_omega, by_zeta = {}, {}
    for label, replay in replays.items():
        residuals = []
        for truth in truths:
            residuals.append(simulate_liquid(replay(truth), truth, settle_s=settle_s).residual_deg)
            bar.update()
        by_omega[label] = np.array(residuals[: len(omega_factors)])
        by_zeta[label] = np.array(residuals[len(omega_factors) :])
    bar.close()
    return RobustnessResult(omega_factors, zeta_factors, by_omega, by_zeta)
