"""A solved plan, `PlanResult`: the 1 kHz trajectory, the solver's figures, the limits' usage and the independent
verification, with its text, JSON, figure and report; the free-move planner (`planner`) and the path planner
(`path_planner`) both build it."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.tables import to_pandas
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import LiquidResponse
from sloshid.model.trajectory import (
    EXPORT_RATE_HZ,
    LimitUsage,
    Trajectory,
    check_limits,
    check_move_limits,
    tilt_profiles,
)
from sloshid.planning.ocp import SegmentResult
from sloshid.planning.report import plan_report
from sloshid.planning.scenario import Scenario

VERIFY_DURING_DEG = 0.1
"""Largest relative liquid-container angle allowed while moving (issue 4)."""
VERIFY_AFTER_DEG = 0.05
"""Largest relative angle allowed after arrival (issue 4)."""


@dataclass(kw_only=True)
class PlanResult:
    """A solved plan: the 1 kHz trajectory, solver figures, robot-limit usage and the independent verification."""

    trajectory: Trajectory
    T_s: float
    status: str
    solve_time_s: float
    iterations: int
    segments: list[SegmentResult]
    limits: list[LimitUsage]
    limits_ok: bool
    verification: LiquidResponse
    params: SloshParams
    robust_omega_factors: tuple[float, ...] = ()
    min_clearance_m: float | None = None
    """Smallest distance of any 1 kHz sample to an inflated obstacle (None without obstacles)."""
    wall_time_s: float = 0.0
    """Everything: construction, solves, export and verification."""
    verify_during_deg: float = VERIFY_DURING_DEG
    """Largest relative angle accepted while moving: 0.1 deg, or [limits].rel_angle_max_deg for [path] plans."""
    max_path_deviation_m: float | None = None
    """[path] plans: largest distance of a 1 kHz sample from the user's path (m)."""
    path_tolerance_m: float | None = None
    """[path] plans: [path].path_tolerance_m."""
    joints: Any = None
    """`sloshid.planning.arm.JointCheck` when the scenario has a [robot] model and joints were requested."""
    scenario: Scenario | None = None
    """The scenario that was planned (its report shows the obstacles and limits)."""
    move_limits: list[LimitUsage] = field(default_factory=list)
    """The scenario's own [limits] (per-axis acceleration and velocity, tilt, tilt rate) on the 1 kHz trajectory: the
    solver holds them at its grid points, and between them a move riding a bound can pass it by a few per cent."""
    tightened: dict[str, float] = field(default_factory=dict)
    """Limits the solver was given below the scenario's (share of it, e.g. {"[limits].tilt_max_deg": 0.92}) because
    a first solve passed them between its grid points; empty when it did not."""

    @property
    def verification_ok(self) -> bool:
        """Relative angle below verify_during_deg while moving and < 0.05 deg after arrival."""
        v = self.verification
        return v.peak_during_deg < self.verify_during_deg and v.residual_deg < VERIFY_AFTER_DEG

    @property
    def verify_after_deg(self) -> float:
        """Largest relative angle accepted after arrival (VERIFY_AFTER_DEG)."""
        return VERIFY_AFTER_DEG

    @property
    def path_ok(self) -> bool:
        """True for free moves, and for [path] plans within the path tolerance."""
        deviation, tolerance = self.max_path_deviation_m, self.path_tolerance_m
        return deviation is None or tolerance is None or deviation <= tolerance

    def segment_of_samples(self) -> np.ndarray:
        """The segment of every 1 kHz sample (each segment's samples follow the last one's)."""
        return segment_of_samples(self.segments, len(self.trajectory.t_s))

    @property
    def max_tilt_deg(self) -> float:
        """Largest tilt of the container's z-axis from vertical."""
        return float(tilt_profiles(self.trajectory)[0].max())

    @property
    def max_tilt_rate_deg_s(self) -> float:
        """Largest angular speed of the container."""
        return float(tilt_profiles(self.trajectory)[1].max())

    def to_csv(self, path: str | Path) -> None:
        """Write the 1 kHz trajectory CSV (`Trajectory.to_csv`), never over the scenario it was planned from."""
        self.trajectory.to_csv(path, (self.scenario.source,) if self.scenario and self.scenario.source else ())

    def to_dict(self) -> dict:
        """The `--json` content: timing, solver status, tilt, limits, verification, per-segment figures (the tilt's
        on the 1 kHz samples of each segment, as the whole move's)."""
        v = self.verification
        tilt, rate = tilt_profiles(self.trajectory)
        seg_of = self.segment_of_samples()
        return {
            "T_s": self.T_s,
            "solve_time_s": self.solve_time_s,
            "wall_time_s": self.wall_time_s,
            "iterations": self.iterations,
            "status": self.status,
            "formulation": self.segments[0].formulation,
            "max_tilt_deg": self.max_tilt_deg,
            "max_tilt_rate_deg_s": self.max_tilt_rate_deg_s,
            "limits_ok": self.limits_ok,
            "limits": [_usage_dict(u) for u in self.limits],
            "move_limits": [_usage_dict(u) for u in self.move_limits],
            "limits_lowered_for_solver": dict(self.tightened),
            "verification": {
                "peak_during_deg": v.peak_during_deg,
                "residual_deg": v.residual_deg,
                "during_max_deg": self.verify_during_deg,
                "after_max_deg": VERIFY_AFTER_DEG,
                "ok": self.verification_ok,
            },
            "min_clearance_m": self.min_clearance_m,
            "max_path_deviation_m": self.max_path_deviation_m,
            "path_tolerance_m": self.path_tolerance_m,
            "path_ok": self.path_ok,
            "joints": self.joints.to_dict() if self.joints is not None else None,
            "robust_omega_factors": list(self.robust_omega_factors),
            "liquid": self.params.to_dict(),
            "samples": len(self.trajectory.t_s),
            "sample_rate_hz": 1.0 / self.trajectory.dt_s,
            "segments": [
                {
                    "index": s.index,
                    "start_m": list(s.start),
                    "goal_m": list(s.goal),
                    "T_s": s.T_s,
                    "status": s.status,
                    "iterations": s.iterations,
                    "solve_time_s": s.solve_time_s,
                    "model": "1-D" if s.axis is not None else "3-D",
                    "max_tilt_deg": float(tilt[seg_of == k].max()),
                    "max_tilt_rate_deg_s": float(rate[seg_of == k].max()),
                }
                for k, s in enumerate(self.segments)
            ],
        }

    def summary(self) -> str:
        """One line: segments, transfer time, solver, tilt, limits and verification (what `sloshid plan` prints)."""
        v = self.verification
        return (
            f"planned {len(self.segments)} segment(s): T = {self.T_s:.4f} s, solved in {self.solve_time_s:.3f} s "
            f"({self.status}); max tilt {self.max_tilt_deg:.2f} deg; robot limits "
            f"{'ok' if all(u.ok for u in self.limits) else 'EXCEEDED'}"
            f"{'' if all(u.ok for u in self.move_limits) else '; [limits] EXCEEDED'}; liquid-container angle "
            f"{v.peak_during_deg:.4f} deg "
            f"during, {v.residual_deg:.4f} deg after"
            + (
                "; re-planned with "
                + ", ".join(f"{k} at {100 * share:.1f} %" for k, share in self.tightened.items())
                + " (passed between the solver's grid points)"
                if self.tightened
                else ""
            )
        )

    def to_pandas(self):
        """The 1 kHz trajectory as a table (the trajectory CSV's columns)."""
        return to_pandas(self.trajectory.columns())

    def plot(self, ax=None):
        """Container speed and tilt over time (the tilt is the liquid surface's); returns the figure."""
        import matplotlib.pyplot as plt

        own = ax is None
        if own:
            _, ax = plt.subplots(figsize=(9, 3.2))
        traj = self.trajectory
        ax.plot(traj.t_s, np.linalg.norm(traj.vel_m_s, axis=1), color="#36c", label="speed (m/s)")
        ax.set(xlabel="time t (s)", ylabel="container speed (m/s)", title=f"planned move, T = {self.T_s:.3f} s")
        tilt = ax.twinx()
        tilt.plot(traj.t_s, np.degrees(traj.euler_rad[:, 0]), color="tab:orange", lw=1, label="roll phi (deg)")
        tilt.plot(traj.t_s, np.degrees(traj.euler_rad[:, 1]), color="tab:green", lw=1, label="pitch theta (deg)")
        tilt.set_ylabel("container tilt = liquid surface (deg)")
        ax.figure.legend(loc="upper right", bbox_to_anchor=(1.0, 1.0), fontsize=8, ncols=3)
        if own:  # legend and labels inside the figure: a plain savefig keeps them
            ax.figure.tight_layout(rect=(0, 0, 1, 0.9))
        return ax.figure

    def report(self, directory: str | Path, links: dict[str, str] | None = None, liquid_source: str = "") -> Path:
        """Write the plan report (states, 3-D path, limits, verification) to directory/index.html; `links` (text ->
        relative href) are shown at the top, `liquid_source` says where the liquid's parameters came from."""
        return self.report_page(links, liquid_source).save(directory)

    def report_page(self, links: dict[str, str] | None = None, liquid_source: str = ""):
        """The plan report, drawn but not written (`.save(directory)` writes it): a command draws it before it writes
        any file, so a report that cannot be drawn leaves the trajectory CSV untouched."""
        if self.scenario is None:
            raise UserError("this plan does not know its scenario, so no report can be drawn.")
        return plan_report(self, self.scenario, liquid_source, links)


def limit_usages(traj: Trajectory, scenario: Scenario) -> tuple[list[LimitUsage], list[LimitUsage]]:
    """The robot's limits and the scenario's own [limits] on a planned 1 kHz trajectory."""
    lim = scenario.limits
    move = check_move_limits(
        traj, lim.acc_max, lim.vel_max, lim.tilt_max_deg, lim.tilt_rate_max_deg_s, scenario.move_jerk_max
    )
    return check_limits(traj, scenario.robot), move


def _usage_dict(u: LimitUsage) -> dict:
    """One limit's line in the `--json` summary."""
    return {
        "quantity": u.quantity,
        "peak": u.peak,
        "limit": u.limit,
        "usage": u.usage,
        "t_peak_s": u.t_peak_s,
        "ok": u.ok,
    }


def segment_of_samples(segments: Sequence[SegmentResult], n: int) -> np.ndarray:
    """The segment index of each of `n` 1 kHz samples of the joined segments (as sample_segments joins them)."""
    edges = np.cumsum([math.ceil(s.T_s * EXPORT_RATE_HZ - 1e-9) for s in segments])
    return np.searchsorted(edges, np.arange(n), side="left").clip(0, len(segments) - 1)
