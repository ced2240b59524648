"""Upright baselines against sloshid's upright plan, at the same limits, scored on the spill margin and ranked by risk.
(A tilting scenario within a spill margin is scored the same way, with sloshid's tilting plan, its upright plan and
its slosh-free tilting plan side by side.)

Baselines (container upright, straight line, the scenario's limits): constant acceleration, ZV, ZVD and ZVDD (the
robust shaper) on it, ruckig's time-optimal jerk-limited move, and TOPP-RA along the line (with and without ZVD).
A tray's shapers are tuned to the geometric mean of its containers' frequencies. Each baseline is first taken at the
full limits; when that breaks a margin or leaves too much on arrival, its acceleration limit is lowered over
ACC_SCALES to the fastest version that meets both, as a user tuning it would. Every move's risk is the same Monte
Carlo (`planning.risk.monte_carlo`, same seed and draws), and the rows are ranked by it (then by time).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import numpy as np

from sloshid.comparison.profiles import MoveTask, NotApplicable, constant_acceleration, sample_move
from sloshid.comparison.recommend import write_move
from sloshid.comparison.ruckig_moves import jerk_limited
from sloshid.comparison.shapers import design_shaper, shape, shaped_constant_acceleration
from sloshid.comparison.toppra_moves import toppra_profile
from sloshid.model.pendulum import SloshParams
from sloshid.model.trajectory import Trajectory
from sloshid.planning.risk import ROBUST_UPRIGHT_SAMPLES, RiskEstimate, monte_carlo, spreads, walls_of
from sloshid.planning.scenario import Scenario, Vec3
from sloshid.planning.upright import UprightPlan, line_limits, plan_upright
from sloshid.planning.vessels import Vessel

ACC_SCALES = tuple(np.round(np.arange(1.0, 0.195, -0.025), 3))
"""Shares of the acceleration limit a baseline is tried at, fastest first, until it meets the margin and residual."""

MARGIN_RISK_GOOD = 0.01
"""A move within a spill margin is recommended as good when its Monte-Carlo risk's 95 % upper bound is below this."""

UPRIGHT_BASELINES = {
    "constant_acc": "constant acceleration",
    "zv": "ZV shaped",
    "zvd": "ZVD shaped",
    "zvdd": "ZVDD shaped (robust)",
    "ruckig": "jerk-limited (ruckig)",
    "toppra": "TOPP-RA",
    "toppra_zvd": "TOPP-RA + ZVD",
}
"""Baseline key -> label."""


def _line_geometry(start: np.ndarray, e: np.ndarray, length: float) -> SimpleNamespace:
    """The straight line start -> goal as the path TOPP-RA parameterises (positions of the path coordinate)."""
    return SimpleNamespace(length_m=length, evaluate=lambda ss: start[None, :] + np.outer(ss, e))


def _builders(scenario: Scenario, mode: SloshParams) -> dict[str, Callable[[float], Trajectory]]:
    """Each baseline as a function of the acceleration share it runs at."""
    start = np.asarray(scenario.waypoints[0], float)
    line = line_limits(scenario)
    jerk = float(min(scenario.limits.jerk_max))
    geo = _line_geometry(start, line.direction, line.length_m)

    def task(c: float) -> MoveTask:
        acc = tuple(min(a, scenario.robot.acc_m_s2) * c for a in scenario.limits.acc_max)
        vel = tuple(min(v, scenario.robot.vel_m_s) for v in scenario.limits.vel_max)
        points = tuple(cast(Vec3, tuple(w)) for w in scenario.waypoints)
        return MoveTask(points, cast(Vec3, acc), cast(Vec3, vel))

    def toppra(c: float, shaped: bool) -> Trajectory:
        t = task(c)
        profile = toppra_profile(geo, t.vel_max_m_s, t.acc_max_m_s2, scenario.robot)
        if shaped:
            profile = shape(profile, design_shaper("ZVD", mode))
        return sample_move(t, [profile], "TOPP-RA + ZVD" if shaped else "TOPP-RA")

    return {
        "constant_acc": lambda c: constant_acceleration(task(c)),
        "zv": lambda c: shaped_constant_acceleration(task(c), mode, "ZV"),
        "zvd": lambda c: shaped_constant_acceleration(task(c), mode, "ZVD"),
        "zvdd": lambda c: shaped_constant_acceleration(task(c), mode, "ZVDD"),
        "ruckig": lambda c: jerk_limited(task(c), jerk),
        "toppra": lambda c: toppra(c, False),
        "toppra_zvd": lambda c: toppra(c, True),
    }


@dataclass
class UprightRow:
    """One method's move, scored on the nominal liquids and by the Monte Carlo."""

    key: str
    label: str
    T_s: float | None
    acc_share: float | None
    """Share of the acceleration limit it runs at (1: the full limits); None for sloshid's plans."""
    peak_use: float | None
    """Largest wall height / allowed rise over the containers (nominal liquids)."""
    residual_mm: float | None
    """Largest wall height after arrival over the containers (nominal liquids)."""
    meets: bool
    risk: RiskEstimate | None = None
    reason: str = ""
    """Why the method has no move (not applicable, or no acceleration share meets the margin)."""
    trajectory: Trajectory | None = field(default=None, repr=False)
    """The move scored."""

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "key": self.key,
            "label": self.label,
            "T_s": self.T_s,
            "acc_share": self.acc_share,
            "peak_wall_use": self.peak_use,
            "residual_wall_mm": self.residual_mm,
            "meets_margin_and_residual": self.meets,
            "risk": self.risk.to_dict() if self.risk is not None else None,
            "reason": self.reason,
        }


@dataclass
class UprightComparison:
    """Every upright method at the same limits, ranked by risk (then time)."""

    rows: list[UprightRow]
    t_no_liquid_s: float
    plan: UprightPlan

    def ranked(self) -> list[UprightRow]:
        """Rows with a move, lowest risk first, then fastest; rows without one last."""

        def key(r: UprightRow):
            p = (r.risk.p, r.risk.residual_exceeded / r.risk.draws) if r.risk is not None else (2.0, 2.0)
            return (r.T_s is None, not r.meets, *p, r.T_s if r.T_s is not None else math.inf)

        return sorted(self.rows, key=key)

    def summary(self) -> str:
        """The ranked table as text."""
        lines = [
            f"{'methods' if self.plan.tilting else 'upright methods'} at the same limits (no liquid: {self.t_no_liquid_s:.3f} s), ranked by risk:"
        ]
        for i, r in enumerate(self.ranked(), 1):
            if r.T_s is None:
                lines.append(f"  {i}. {r.label}: {r.reason}")
                continue
            risk = (
                f"risk {100 * r.risk.p:.2f} +- {100 * r.risk.stderr:.2f} % (residual over its limit in "
                f"{100 * r.risk.residual_exceeded / r.risk.draws:.1f} %)"
                if r.risk is not None
                else "risk n/a (no parameter band)"
            )
            share = f" at {100 * r.acc_share:.1f} % acc" if r.acc_share is not None and r.acc_share < 1 else ""
            use = 100 * r.peak_use if r.peak_use is not None else math.nan
            lines.append(
                f"  {i}. {r.label}: T = {r.T_s:.3f} s{share}; wall {use:.0f} % of allowed, "
                f"{r.residual_mm:.2f} mm after; {'meets' if r.meets else 'BREAKS'} margin and residual; {risk}"
            )
        return "\n".join(lines)

    @property
    def recommended(self) -> UprightRow | None:
        """The first-ranked row whose move meets margin and residual: the recommended one (None: none does)."""
        return next((r for r in self.ranked() if r.meets and r.trajectory is not None), None)

    @property
    def risk_level(self) -> str:
        """The recommendation's colour: good (the risk's 95 % upper bound below MARGIN_RISK_GOOD), uncertain, or
        unreliable (none recommended)."""
        best = self.recommended
        if best is None:
            return "unreliable"
        return "good" if best.risk is not None and best.risk.upper95 < MARGIN_RISK_GOOD else "uncertain"

    @property
    def verdict(self) -> str:
        """One sentence: the recommended move and its risk, or that none meets the margin."""
        best = self.recommended
        if best is None or best.T_s is None:
            return "No method meets the spill margin and the residual on arrival; loosen the margin or the limits."
        risk = best.risk
        told = f"{100 * risk.p:.2f} % (95 % upper bound {100 * risk.upper95:.2f} %)" if risk else "not estimated"
        return (
            f"Recommended: {best.label}, T = {best.T_s:.3f} s, the first-ranked move that meets the spill margin and "
            f"the residual; risk of breaking the margin {told}."
        )

    def recommended_move(self) -> dict | None:
        """What the JSON beside the recommended move says: the method, why, and its risk of breaking the margin."""
        best = self.recommended
        if best is None:
            return None
        return {
            "method": best.key,
            "label": best.label,
            "transfer_time_s": best.T_s,
            "risk": self.risk_level,
            "reason": self.verdict,
            "margin_risk": best.risk.to_dict() if best.risk is not None else None,
            "csv_holds": "the move",
        }

    def write_first(self, path: str | Path, inputs: tuple[str | Path, ...] = ()) -> Path | None:
        """Write the recommended move (the first-ranked that meets margin and residual) as a 1 kHz trajectory CSV and
        what it is as JSON beside it (`path` with .json), as `Comparison.write_recommended` does (None: none meets)."""
        best, move = self.recommended, self.recommended_move()
        if best is None or best.trajectory is None or move is None:
            return None
        return write_move(best.trajectory, move, path, inputs)

    def report_page(self, links: dict[str, str] | None = None):
        """The comparison's HTML report: the ranked table and the plan's wall heights, drawn but not written."""
        from sloshid.report.html import Report

        rep = Report(
            "sloshid comparison within the spill margin" if self.plan.tilting else "sloshid upright comparison"
        )
        rep.add_text(self.summary().splitlines()[0])
        rows = [
            [i, r.label, r.T_s if r.T_s is not None else r.reason, r.acc_share, r.peak_use, r.residual_mm, r.meets,
             r.risk.p if r.risk is not None else None, r.risk.stderr if r.risk is not None else None]
            for i, r in enumerate(self.ranked(), 1)
        ]  # fmt: skip
        header = ["rank", "method", "T (s)", "acc share", "wall use", "after (mm)", "meets", "risk", "risk stderr"]
        rep.add_table(header, rows, "ranked by risk (Monte Carlo of the nonlinear model), then transfer time")
        what = "tilting plan within the margin" if self.plan.tilting else "upright plan"
        rep.add_figure(self.plan.plot(), f"sloshid's {what}: wall height of each container")
        return rep

    def to_dict(self) -> dict:
        """JSON form, ranked."""
        return {
            "t_no_liquid_s": self.t_no_liquid_s,
            "ranked": [r.to_dict() for r in self.ranked()],
            "plan": self.plan.to_dict(),
        }


def _mode(vessels: list[Vessel]) -> SloshParams:
    """The mode the shapers are tuned to: the container's, or a tray's geometric-mean frequency and mean damping."""
    if len(vessels) == 1:
        return vessels[0].liquid
    omega = math.exp(float(np.mean([math.log(v.liquid.omega_rad_s) for v in vessels])))
    return SloshParams.from_modal(omega, float(np.mean([v.liquid.zeta for v in vessels])))


def _score(trajs: list[Trajectory], vessels: list[Vessel]) -> tuple[np.ndarray, np.ndarray]:
    """(peak use, residual mm) of each move: worst container, nominal liquids, one batched simulation."""
    peaks, residuals = walls_of([(t, v, v.liquid) for t in trajs for v in vessels])
    allowed = np.array([1000 * v.rise_allowed_m for v in vessels])
    use = (peaks.reshape(len(trajs), len(vessels)) / allowed).max(axis=1)
    return use, residuals.reshape(len(trajs), len(vessels)).max(axis=1)


def _fastest_meeting(
    key: str, build, vessels: list[Vessel], residual_max: float
) -> tuple[UprightRow, Trajectory | None]:
    """The baseline at the largest acceleration share that meets margin and residual (the full limits if none)."""
    label = UPRIGHT_BASELINES[key]
    try:
        trajs = [build(c) for c in ACC_SCALES]
    except NotApplicable as exc:
        return UprightRow(key, label, None, None, None, None, False, reason=f"not applicable: {exc}"), None
    use, residual = _score(trajs, vessels)
    ok = (use <= 1.0) & (residual <= residual_max)
    k = int(np.argmax(ok)) if ok.any() else 0
    traj = trajs[k]
    return UprightRow(
        key, label, traj.duration_s, float(ACC_SCALES[k]), float(use[k]), float(residual[k]), bool(ok[k])
    ), traj


def check_comparable(scenario: Scenario) -> None:
    """Refuse a move within a margin that the baselines cannot follow: they run along one straight line."""
    if len(scenario.waypoints) > 2:
        from sloshid.core.errors import UserError

        raise UserError(
            f"{scenario.source or 'the scenario'}: compare scores one straight move within a spill margin, and this "
            "one has waypoints; plan it with `sloshid plan` (the upright baselines along waypoints are not there yet)."
        )


def _upright_of(scenario: Scenario) -> Scenario:
    """The same scenario with the tool held upright (tilt_max_deg = 0)."""
    import dataclasses

    return dataclasses.replace(scenario, limits=dataclasses.replace(scenario.limits, tilt_max_deg=0.0))


def _level_row(scenario: Scenario, vessels: list[Vessel]) -> tuple[UprightRow, Trajectory | None]:
    """sloshid's slosh-free tilting plan (the liquid held level with the container) scored on the margin."""
    from sloshid.core.errors import UserError
    from sloshid.planning.planner import plan

    key, label = "sloshid_level", "sloshid slosh-free tilting plan"
    try:
        traj = plan(scenario, vessels[0].liquid).trajectory
    except UserError as exc:
        return UprightRow(key, label, None, None, None, None, False, reason=f"not solved: {exc}"), None
    use, residual = _score([traj], vessels)
    residual_max = min(1000 * min(v.residual_max_m, v.rise_allowed_m) for v in vessels)
    meets = bool(use[0] <= 1.0 and residual[0] <= residual_max)
    return UprightRow(
        key, label, traj.duration_s, None, float(use[0]), float(residual[0]), meets, trajectory=traj
    ), traj


def compare_upright(
    scenario: Scenario,
    liquid: SloshParams | None,
    params_path: str | Path | None = None,
    robust_samples: int | None = None,
    draws: int | None = None,
) -> UprightComparison:
    """sloshid's upright plan (and its robust variant over `robust_samples` sampled models, default [risk].scenarios or
    50, when the uncertainty is known) against every baseline. A tilting scenario (tilt within the margin) also scores
    the same move upright and sloshid's slosh-free tilting plan, so that what the tilt buys is in the table."""
    check_comparable(scenario)
    plan = plan_upright(scenario, liquid, params_path=params_path, risk_draws=draws)
    vessels = plan.vessels
    settings = scenario.risk
    spread = spreads(vessels, settings)
    n = draws if draws is not None else (settings.draws if settings else 1000)
    seed = settings.seed if settings else 1
    if robust_samples is None:
        robust_samples = settings.scenarios if settings and settings.scenarios else ROBUST_UPRIGHT_SAMPLES
    residual_max = min(1000 * min(v.residual_max_m, v.rise_allowed_m) for v in vessels)
    rows, moves = [], []
    for key, build in _builders(scenario, _mode(vessels)).items():
        row, traj = _fastest_meeting(key, build, vessels, residual_max)
        rows.append(row)
        moves.append(traj)
    what = "tilting plan within the margin" if plan.tilting else "upright plan"
    plans = [("sloshid", f"sloshid {what}", plan)]
    if spread is not None and robust_samples:
        robust = plan_upright(scenario, liquid, params_path=params_path, robust_samples=robust_samples, risk_draws=n)
        plans.append(("sloshid_robust", f"sloshid robust {what} ({robust_samples} sampled models)", robust))
    if plan.tilting:  # what the tilt buys: the same move upright, and the slosh-free tilting move
        upright = _upright_of(scenario)
        plans.append(("sloshid_upright", "sloshid upright plan", plan_upright(upright, liquid, params_path=params_path,
                                                                             risk_draws=n)))  # fmt: skip
        row, traj = _level_row(scenario, vessels)
        rows.append(row)
        moves.append(traj)
    for key, label, p in plans:
        worst = max(p.checks, key=lambda c: c.peak_mm / c.allowed_mm)
        rows.append(
            UprightRow(key, label, p.T_s, None, worst.peak_mm / worst.allowed_mm,
                       max(c.residual_mm for c in p.checks), p.verification_ok, p.risk, trajectory=p.trajectory)
        )  # fmt: skip
    if spread is not None:
        for row, traj in zip(rows, moves):
            if traj is not None:
                row.risk = monte_carlo(traj, vessels, spread, n, seed)
    return UprightComparison(rows, plan.t_no_liquid_s, plan)
