"""The comparison's decision: the fastest method that stays slosh-free over the frequency band the user actually
knows (the identified 95 % interval of f widened by a margin), within robot and move limits and collision-free."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from sloshid.comparison.robustness import Replay, band_responses
from sloshid.core.outputs import Outputs
from sloshid.model.pendulum import SloshParams

if TYPE_CHECKING:
    from sloshid.comparison.compare import CompareSettings, MethodResult
    from sloshid.model.trajectory import Trajectory
    from sloshid.planning.arm import ArmFit, JointCheck

LOW_RISK_SHARE = 0.5
"""A recommendation whose worst residual and peak over the band stay below this share of their thresholds is low
risk (green); closer to a threshold it is coloured as uncertain."""


@dataclass(frozen=True)
class BandCheck:
    """One method over the band: the frequencies tried (the band's low end, the identified frequency, its high end),
    its peak during the move and residual after it at each."""

    f_hz: tuple[float, ...]
    peak_during_deg: tuple[float, ...]
    residual_deg: tuple[float, ...]
    loses_because: str = ""
    """Empty when the method stays slosh-free over the whole band."""

    def to_dict(self) -> dict[str, Any]:
        """Plain lists and the reason it lost (None when it did not)."""
        return {
            "f_hz": list(self.f_hz),
            "peak_during_deg": list(self.peak_during_deg),
            "residual_deg": list(self.residual_deg),
            "loses_because": self.loses_because or None,
        }


@dataclass(frozen=True)
class Recommendation:
    """The recommended method (None when no method qualifies), the band it was judged over, and why."""

    method: str | None
    label: str
    band_hz: tuple[float, float]
    band_source: str
    reason: str
    risk: str
    """'good' (clear margin), 'uncertain' (close to a threshold) or 'unreliable' (no method qualifies)."""
    checks: dict[str, BandCheck] = field(default_factory=dict)
    """Per method key: what the band check found (only the methods it had to try, fastest first; a move slowed for
    the arm is checked as slowed)."""
    arm: ArmFit | None = None
    """How the scenario's [robot] arm follows the recommended move (slowed for it, or why it cannot); None without an
    arm, or with [robot] fit_joints = false."""

    def to_dict(self) -> dict[str, Any]:
        """The JSON `recommendation`: method, band_hz [lo, hi], reason, and the checks behind it."""
        return {
            "method": self.method,
            "label": self.label,
            "band_hz": list(self.band_hz),
            "band_source": self.band_source,
            "reason": self.reason,
            "risk": self.risk,
            "checks": {k: c.to_dict() for k, c in self.checks.items()},
            "arm_fit": self.arm.to_dict() if self.arm is not None else None,
        }


class SlowedRow(NamedTuple):
    """The score tables' row of the move sent when it is a method's move slowed for the scenario's arm: under that
    method's row at full speed, so that the table shows the transfer time the verdict and the JSON give."""

    method: str
    """The key of the method whose row it follows."""
    label: str
    transfer_time_s: float
    peak_during_deg: float
    residual_deg: float


def slowed_label(label: str) -> str:
    """How the tables name a method's move slowed for the scenario's arm."""
    return f"{label}, slowed for the arm"


def slowed_row(move: dict[str, Any] | None, checks: dict[str, dict[str, Any]]) -> SlowedRow | None:
    """The row of the recommended move when it was slowed for the arm (None otherwise): the transfer time sent, and
    its peak and residual at the identified frequency as the band check re-checked the slowed move. Read from the JSON
    forms (`Comparison.recommended_move`, `Recommendation.to_dict`'s checks), so the pipeline's index, which has only
    a run's record, draws the same row."""
    fit = (move or {}).get("arm_fit")
    if move is None or not fit or not fit["slowed"]:
        return None
    check = checks[move["method"]]  # a slowed move's check is the slowed move's (`recommend`)
    at = 1  # the identified frequency, the middle of the three the band check tries
    seconds, peak, residual = move["transfer_time_s"], check["peak_during_deg"][at], check["residual_deg"][at]
    return SlowedRow(move["method"], slowed_label(move["label"]), seconds, peak, residual)


def frequency_band(f_hz: float, interval_hz: tuple[float, float] | None, margin: float) -> tuple[tuple, str]:
    """((lo, hi), where it came from): the identified band (the 95 % interval of f, or where one more run may land
    when jointly identified runs disagreed) widened by `margin` (relative), or the nominal
    frequency widened by it when no interval is known (a scenario's [liquid] table)."""
    lo, hi = interval_hz if interval_hz is not None else (f_hz, f_hz)
    band = (min(lo, f_hz) * (1 - margin), max(hi, f_hz) * (1 + margin))
    if interval_hz is not None:
        return band, f"the identified band {lo:.4g}-{hi:.4g} Hz widened by {100 * margin:g} %"
    return band, f"the nominal {f_hz:.4g} Hz widened by {100 * margin:g} % (no identified interval)"


def _transfer_time(r: MethodResult) -> float:
    """A scored method's transfer time (s); an unscored one's is infinite."""
    return r.score.transfer_time_s if r.score is not None else math.inf


def _static_failure(r: MethodResult) -> str:
    """Why a method loses before any band check: limits or a collision (empty when it passes)."""
    s = r.score
    assert s is not None  # an applicable method is scored
    if s.min_clearance_m is not None and s.min_clearance_m < 0:
        return "collides with an obstacle"
    if s.limits_failed:
        why = "breaks a limit (" + s.limits_failed[0] + ")"
        if r.key in ("sloshid", "sloshid_robust") and s.limits_failed[0].startswith("move "):
            # the solver holds [limits] at its grid points only: a plan riding one passes it a little between them
            why += ", between the planner's grid points: a larger [solver].N holds it closer"
        return why
    return ""


def _band_failure(check: BandCheck, settings: CompareSettings) -> str:
    """Why a method is not slosh-free somewhere in the band (empty when it is)."""
    worst = int(np.argmax(np.asarray(check.residual_deg) / settings.residual_ok_deg))
    if check.residual_deg[worst] > settings.residual_ok_deg:
        return f"leaves {check.residual_deg[worst]:.2g} deg of residual slosh at {check.f_hz[worst]:.3g} Hz"
    worst = int(np.argmax(check.peak_during_deg))
    if check.peak_during_deg[worst] > settings.peak_ok_deg:
        return f"sloshes to {check.peak_during_deg[worst]:.2g} deg during the move at {check.f_hz[worst]:.3g} Hz"
    return ""


def recommend(
    results: list[MethodResult],
    params: SloshParams,
    settings: CompareSettings,
    interval_hz: tuple[float, float] | None,
    progress: bool = False,
    arm: Callable[[MethodResult], ArmFit] | None = None,
) -> Recommendation:
    """Try the methods fastest first: limits and collisions, then the band's ends and middle; the first to pass wins.
    With `arm` (how the scenario's arm follows a method's move, sloshid's plans slowed for it) the fastest that passes
    as the arm follows it wins; when the arm can follow none, the first to pass, with why the arm cannot follow it."""
    band, source = frequency_band(params.f_hz, interval_hz, settings.frequency_margin)
    freqs = (band[0], params.f_hz, band[1])
    truths = [params.scaled(f / params.f_hz, 1.0) for f in freqs]

    def band_check(replay: Replay, label: str) -> BandCheck:
        resp = band_responses({label: replay}, truths, settings.settle_s, progress)[label]
        check = BandCheck(freqs, tuple(resp[:, 0]), tuple(resp[:, 1]))
        return replace(check, loses_because=_band_failure(check, settings))

    checks: dict[str, BandCheck] = {}
    losers: list[str] = []
    first: tuple | None = None  # the first to pass the band (what is recommended without an arm): method, check, fit
    best: tuple | None = None  # the fastest the arm follows: (its transfer time, method, band check, fit)
    ranked = sorted((r for r in results if r.applicable), key=_transfer_time)
    for r in ranked:
        if best is not None and _transfer_time(r) >= best[0]:
            break
        why = _static_failure(r)
        if not why and r.replay is not None:
            check = checks[r.key] = band_check(r.replay, r.label)
            why = check.loses_because
            if not why and arm is None:
                return _chosen(r, check, band, source, losers, checks, settings)
            if not why and arm is not None:
                fit = arm(r)
                if fit.slowed:  # a slower plan is another move: it must stay slosh-free over the band too
                    slowed = band_check(Replay(fit.trajectory), r.label)
                    if slowed.loses_because:
                        fit = _refused(fit, r.require_replay().trajectory, slowed.loses_because)
                    else:
                        check = checks[r.key] = slowed
                first = first or (r, checks[r.key], fit, len(losers))
                if fit.follows:
                    best = (fit.trajectory.duration_s, r, check, fit)
                    continue
                why = fit.objection.reason if fit.objection is not None else ""
        losers.append(f"{r.label} {why}")
    if best is not None:
        _, r, check, fit = best
        return _chosen(r, check, band, source, losers, checks, settings, fit)
    if first is not None:  # the arm follows none: the first to pass, with why the arm cannot follow it
        r, check, fit, faster = first
        return _chosen(r, check, band, source, losers[:faster], checks, settings, fit)
    reason = (
        f"No method stays slosh-free (residual <= {settings.residual_ok_deg:g} deg, peak <= "
        f"{settings.peak_ok_deg:g} deg) over {band[0]:.3g}-{band[1]:.3g} Hz ({source}): " + "; ".join(losers) + "."
        if losers
        else "No method of [compare].methods applies to this scenario (the table says why), so none is recommended."
    )
    return Recommendation(None, "none", band, source, reason, "unreliable", checks)


def _refused(fit: ArmFit, first: Trajectory, loses_because: str) -> ArmFit:
    """A fit whose slowed plan is not slosh-free over the band: the move first given, with why the arm gets none."""
    from sloshid.planning.arm import ArmObjection

    why = (
        f"the Panda of [robot] cannot follow it ({fit.steps[0].reason.rstrip('.')}), and slowed for it, it "
        f"{loses_because}"
    )
    return replace(fit, trajectory=first, joints=None, plan=None, objection=ArmObjection(why, refit=False))


def _chosen(r, check, band, source, losers, checks, settings, arm: ArmFit | None = None) -> Recommendation:
    """The recommendation for method r (as the scenario's arm follows it: `arm`), with one sentence on why the faster
    ones lose."""
    share = max(max(check.residual_deg) / settings.residual_ok_deg, max(check.peak_during_deg) / settings.peak_ok_deg)
    follows = arm is not None and arm.follows
    seconds = arm.trajectory.duration_s if arm is not None else r.score.transfer_time_s
    reason = (
        f"Recommended: {r.label} ({seconds:.3g} s), the fastest move that stays slosh-free "
        f"(residual <= {settings.residual_ok_deg:g} deg, peak during the move <= {settings.peak_ok_deg:g} deg) over "
        f"{band[0]:.3g}-{band[1]:.3g} Hz, {source}{' and that the Panda of [robot] can follow' * follows}; worst "
        f"case there {max(check.residual_deg):.2g} deg residual, {max(check.peak_during_deg):.2g} deg peak."
    )
    if arm is not None and arm.slowed:
        said = arm.describe()
        reason += f" {said[:1].upper()}{said[1:]}."
    if losers:
        reason += " Faster ones lose: " + "; ".join(losers) + "."
    if arm is not None and arm.objection is not None:
        reason += f" Do not send it: {arm.objection.reason}."
    risk = "good" if share <= LOW_RISK_SHARE else "uncertain"
    return Recommendation(r.key, r.label, band, source, reason, risk, checks, arm)


MOVE_JSON_MARK = '"trajectory_csv": '
"""What every recommended move's JSON holds (the name of its CSV): a JSON beside TRAJ.csv without it is a user's file,
and sloshid never replaces it."""
JOINTS_CSV_MARK = "t_s,q1,q2,q3,q4,q5,q6,q7"
"""The header of every joint trajectory sloshid writes (`JointCheck.write_csv`): a TRAJ_joints.csv without it is a
user's file, and sloshid never replaces it."""


def joints_path(path: str | Path) -> Path:
    """Where a move's joint trajectory goes: beside its CSV, the stem + _joints.csv (as `plan --joints` is told)."""
    move = Path(path)
    return move.with_name(move.stem + "_joints.csv")


def declare_move(outputs: Outputs, path: str | Path, role: str, how: str) -> tuple[Path, Path, Path]:
    """Declare a recommended move's CSV (`role`), its JSON and its joints CSV beside it in `outputs`; a JSON or joints
    CSV there that sloshid did not write is refused, the sentence ending in `how` to proceed."""
    csv = outputs.file(path, role, (".csv",))
    sidecar = outputs.file(
        csv.with_suffix(".json"), f"{role}'s description beside it", (".json",), (MOVE_JSON_MARK, how)
    )
    joints = outputs.file(joints_path(csv), f"{role}'s joint trajectory beside it", (".csv",), (JOINTS_CSV_MARK, how))
    return csv, sidecar, joints


def write_move(
    trajectory: Trajectory, move: dict[str, Any], path: str | Path, inputs: tuple = (), joints: JointCheck | None = None
) -> Path:
    """Write a recommended move as a 1 kHz trajectory CSV at `path`, `move` (which method, why) as JSON beside it and,
    given, the arm's `joints` (`joints_path`, named in the JSON); all are checked before any is written."""
    from sloshid.core.atomic import write_json

    csv, sidecar, joints_csv = declare_move(
        Outputs(inputs), path, "the recommended move", "write the move to another path, or move that file away"
    )
    trajectory.to_csv(csv, inputs)
    if joints is not None:
        joints.write_csv(joints_csv)
    write_json(sidecar, {**move, "trajectory_csv": csv.name, "joints_csv": joints_csv.name if joints else None})
    return csv
