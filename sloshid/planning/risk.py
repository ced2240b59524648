"""How sure an upright move is: liquid models drawn from the identified uncertainty, the Monte Carlo of the nonlinear
model that estimates the probability of breaking the spill margin, and the scenario approach's guarantee.

Draws: per container, omega ~ N(omega, sd_omega) and zeta ~ N(zeta, sd_zeta), from the identify JSON's standard
errors, or a band the user gives ([risk] omega_ci95_rel, zeta_ci95_rel: the 95 % half-width as a share, so
sd = share x value / 1.96) for a liquid that came without them. Every draw is seeded. The Monte Carlo integrates every drawn liquid under the move with
the compiled RK4 (`model.simulate.simulate_liquids`, many pendulums per call).

The robust plan holds the margin for N sampled models (the scenario approach). Its guarantee is the one of the
nonconvex scenario theory (Campi, Garatti and Ramponi, "A general scenario theory for nonconvex optimization and
decision making", IEEE TAC 2018): with probability at least 1 - beta over the N samples, the probability that a new
model breaks the constraints is at most eps(k) = 1 - (beta / (N C(N, k)))^(1 / (N - k)), k the size of a support
set. Here k counts the samples whose wall or residual constraint is active at the optimum (taken as the support set,
not proven by re-solving without the others).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import beta as beta_dist

from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import simulate_liquids
from sloshid.model.trajectory import Trajectory
from sloshid.planning.scenario import RiskSettings
from sloshid.planning.vessels import Vessel

Z95 = 1.959964
"""Two-sided 95 % quantile of the normal distribution."""
ROBUST_UPRIGHT_SAMPLES = 50
"""Sampled liquid models a robust upright plan holds when [risk].scenarios does not say (`sloshid plan --robust`)."""
MC_BATCH = 256
"""Pendulums per compiled integration call (memory: the call holds every member's inputs on the 1 kHz grid)."""
SETTLE_PERIODS = 4.0
"""After arrival the Monte Carlo follows the liquid this many periods of its slowest draw (at least 1 s): the
swing only decays after the first crest."""


@dataclass(frozen=True)
class Spread:
    """One container's liquid uncertainty: standard deviations of omega (rad/s) and zeta."""

    omega_sd_rad_s: float
    zeta_sd: float


def spreads(vessels: Sequence[Vessel], settings: RiskSettings | None) -> list[Spread] | None:
    """Per container: the identify JSON's standard errors where its liquid came from one, else the band [risk]
    gives; None when some container's uncertainty is unknown (no risk can be stated)."""
    out = []
    for v in vessels:
        if v.omega_sd_rad_s is None and settings is not None and settings.omega_ci95_rel is not None:
            zeta_rel = settings.zeta_ci95_rel or 0.0
            out.append(Spread(settings.omega_ci95_rel * v.liquid.omega_rad_s / Z95, zeta_rel * v.liquid.zeta / Z95))
        elif v.omega_sd_rad_s is not None:
            out.append(Spread(v.omega_sd_rad_s, v.zeta_sd or 0.0))
        else:
            return None
    return out


def draw_models(vessels: Sequence[Vessel], spread: Sequence[Spread], n: int, seed: int) -> list[list[SloshParams]]:
    """n seeded draws; each a liquid per container (omega kept above a tenth of its value, zeta in [0, 0.95])."""
    rng = np.random.default_rng(seed)
    omega0 = np.array([v.liquid.omega_rad_s for v in vessels])
    zeta0 = np.array([v.liquid.zeta for v in vessels])
    omega = omega0 + rng.standard_normal((n, len(vessels))) * [s.omega_sd_rad_s for s in spread]
    zeta = zeta0 + rng.standard_normal((n, len(vessels))) * [s.zeta_sd for s in spread]
    omega, zeta = np.maximum(omega, 0.1 * omega0), np.clip(zeta, 0.0, 0.95)
    return [
        [SloshParams.from_modal(float(omega[i, j]), float(zeta[i, j]), v.liquid.m_kg) for j, v in enumerate(vessels)]
        for i in range(n)
    ]


@dataclass(frozen=True)
class WallFigures:
    """Wall heights of every (draw, container) pair under one move (mm)."""

    peak_mm: np.ndarray
    """Highest wall height during and after the move (draws, containers)."""
    residual_mm: np.ndarray
    """Highest wall height after arrival (draws, containers)."""


def wall_figures(traj: Trajectory, vessels: Sequence[Vessel], models: Sequence[Sequence[SloshParams]]) -> WallFigures:
    """Integrate every drawn liquid of every container under `traj` (nonlinear, batched) and read its wall."""
    peaks, residuals = walls_of([(traj, vessels[j], m) for draw in models for j, m in enumerate(draw)])
    shape = (len(models), len(vessels))
    return WallFigures(peaks.reshape(shape), residuals.reshape(shape))


def walls_of(members: Sequence[tuple[Trajectory, Vessel, SloshParams]]) -> tuple[np.ndarray, np.ndarray]:
    """Peak wall height during and after the move, and after arrival (mm), of each (move, container, liquid), in
    batches of MC_BATCH pendulums per compiled call."""
    slowest = min(m.omega_rad_s for _, _, m in members)
    settle = max(1.0, SETTLE_PERIODS * 2 * math.pi / slowest)
    peaks, residuals = np.zeros(len(members)), np.zeros(len(members))
    for lo in range(0, len(members), MC_BATCH):
        chunk = members[lo : lo + MC_BATCH]
        responses = simulate_liquids([t for t, _, _ in chunk], [m for _, _, m in chunk], settle_s=settle)
        for i, ((_, vessel, _), r) in enumerate(zip(chunk, responses)):
            wall = r.wall_height_mm(vessel.radius_m)
            peaks[lo + i] = wall.max()
            residuals[lo + i] = wall[r.t_s > r.t_arrival_s].max()
    return peaks, residuals


@dataclass(frozen=True)
class RiskEstimate:
    """Monte-Carlo probability that the move breaks a spill margin, with its sampling error."""

    draws: int
    seed: int
    broken: int
    """Draws in which some container's wall height passed its allowed rise."""
    residual_exceeded: int
    """Draws in which some container kept swinging above its residual limit after arrival."""
    by_container: dict[str, int]
    """Draws in which each container broke its margin."""

    @property
    def p(self) -> float:
        """Estimated probability of breaking a margin."""
        return self.broken / self.draws

    @property
    def stderr(self) -> float:
        """Binomial standard error of `p` (sqrt(p (1 - p) / n); 0 draws broken gives 0)."""
        return math.sqrt(self.p * (1 - self.p) / self.draws)

    @property
    def upper95(self) -> float:
        """One-sided 95 % Clopper-Pearson upper bound of the probability."""
        return (
            float(beta_dist.ppf(0.95, self.broken + 1, self.draws - self.broken)) if self.broken < self.draws else 1.0
        )

    def summary(self) -> str:
        """One line: the risk with its sampling error and upper bound."""
        return (
            f"risk of breaking the spill margin {100 * self.p:.2f} % +- {100 * self.stderr:.2f} % "
            f"(Monte Carlo, {self.draws} draws, seed {self.seed}; 95 % upper bound {100 * self.upper95:.2f} %); "
            f"residual above its limit in {100 * self.residual_exceeded / self.draws:.2f} %"
        )

    def to_dict(self) -> dict:
        """JSON form (probabilities as shares)."""
        return {
            "draws": self.draws,
            "seed": self.seed,
            "broken": self.broken,
            "p_margin_broken": self.p,
            "stderr": self.stderr,
            "upper95": self.upper95,
            "p_residual_exceeded": self.residual_exceeded / self.draws,
            "broken_by_container": dict(self.by_container),
        }


def monte_carlo(
    traj: Trajectory, vessels: Sequence[Vessel], spread: Sequence[Spread], n: int, seed: int
) -> RiskEstimate:
    """P(margin broken) of a move over `n` seeded draws of the liquids (nonlinear, batched)."""
    figures = wall_figures(traj, vessels, draw_models(vessels, spread, n, seed))
    allowed = np.array([1000 * v.rise_allowed_m for v in vessels])
    residual = np.array([1000 * min(v.residual_max_m, v.rise_allowed_m) for v in vessels])
    over = figures.peak_mm > allowed
    return RiskEstimate(
        draws=n,
        seed=seed,
        broken=int(over.any(axis=1).sum()),
        residual_exceeded=int((figures.residual_mm > residual).any(axis=1).sum()),
        by_container={v.name: int(over[:, j].sum()) for j, v in enumerate(vessels)},
    )


@dataclass(frozen=True)
class ScenarioGuarantee:
    """The robust plan's sampled models and the bound on its violation probability."""

    samples: int
    """N: sampled models the plan holds the margin and residual for."""
    support: int
    """k: samples with an active constraint at the optimum."""
    beta: float
    """The bound holds with confidence 1 - beta."""
    seed: int

    @property
    def epsilon(self) -> float:
        """eps(k) = 1 - (beta / (N C(N, k)))^(1 / (N - k)): P(violation) <= eps with confidence 1 - beta."""
        return scenario_epsilon(self.samples, self.support, self.beta)

    def summary(self) -> str:
        """One line: N, k and the guarantee."""
        return (
            f"robust over {self.samples} sampled models (scenario approach, seed {self.seed}; {self.support} "
            f"active): P(violation) <= {100 * self.epsilon:.1f} % with confidence {100 * (1 - self.beta):.1f} % "
            "(nonconvex scenario bound)"
        )

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "samples": self.samples,
            "support": self.support,
            "beta": self.beta,
            "epsilon": self.epsilon,
            "seed": self.seed,
        }


def scenario_epsilon(n: int, k: int, beta: float) -> float:
    """The nonconvex scenario bound eps(k) for N = n samples and a support set of k (1 when k >= n)."""
    if k >= n:
        return 1.0
    log_term = math.log(beta) - math.log(n) - (math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1))
    return 1.0 - math.exp(log_term / (n - k))
