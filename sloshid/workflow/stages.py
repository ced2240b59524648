"""The stages a pipeline can declare, each a thin wrapper over the library call the matching command makes."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sloshid.core.atomic import write_text
from sloshid.core.errors import UserError
from sloshid.workflow.options import IdentifyOptions, TrackOptions
from sloshid.workflow.pipeline import Stage, StageContext


def _save_figure(fig: Any, path: Path) -> str:
    """Write a matplotlib figure as PNG and close it; returns the file name for the index page."""
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=200, bbox_inches="tight")  # twice screen resolution
    plt.close(fig)
    return path.name


def track_one(video: Path, opts: TrackOptions, out_dir: Path, one_core: bool = False) -> dict[str, Any]:
    """Track one video into out_dir/<stem>.csv (and overlay); returns its summary. On Dask workers one_core
    keeps each video to one core, since the workers already run videos side by side."""
    from sloshid.tracking.tracker import track_video

    overlay = out_dir / f"{video.stem}_overlay.mp4" if opts.overlay else None
    res = track_video(video, opts.track_settings(), overlay=overlay, progress=not one_core, multithreaded=not one_core)
    res.to_csv(out_dir / f"{video.stem}.csv")
    return {
        "video": str(video),
        "csv": f"{video.stem}.csv",
        "frames": len(res.t_s),
        "valid_share": float(res.valid.mean()),
        "warnings": res.warnings,
        "overlay": overlay.name if overlay else None,
    }


def run_track(opts: TrackOptions, ctx: StageContext) -> dict[str, Any]:
    """Track every video (on a local Dask cluster when [run].workers > 1); one angles CSV per video."""
    import matplotlib.pyplot as plt

    from sloshid.core.tables import read_csv

    if not opts.videos:
        raise UserError("[track].videos is empty; list at least one video.")
    if len({v.stem for v in opts.videos}) < len(opts.videos):
        raise UserError("[track].videos has two files with the same name; their CSVs would collide.")
    if ctx.run.workers > 1 and len(opts.videos) > 1:
        from sloshid.workflow.batch import dask_client

        with dask_client(ctx.run.workers, None) as client:
            summaries = client.gather(client.map(track_one, opts.videos, opts=opts, out_dir=ctx.out_dir, one_core=True))
    else:
        summaries = [track_one(v, opts, ctx.out_dir) for v in opts.videos]
    fig, ax = plt.subplots(figsize=(10, 3.2))
    for summary in summaries:
        table = read_csv(ctx.out_dir / summary["csv"])
        ok = table["valid"] == 1
        ax.plot(table["t_s"][ok], table["angle_deg"][ok], ".", ms=2, alpha=0.5)
        ax.plot(table["t_s"], table["angle_smoothed_deg"], lw=1, label=f"{Path(summary['video']).name} (smoothed)")
    ax.set(xlabel="time t (s)", ylabel="float angle (deg)", title="tracked float angle (dots: measured frames)")
    ax.legend(fontsize=8)
    return {"figure": _save_figure(fig, ctx.out_dir / "angle.png"), "videos": summaries}


def run_identify(opts: IdentifyOptions, ctx: StageContext) -> dict[str, Any]:
    """Joint identification of the tracked angles and the listed signal files; JSON and HTML report."""
    from sloshid.identification.estimator import Identifier
    from sloshid.identification.report import build_report
    from sloshid.identification.signals import load_signal

    files = sorted((ctx.upstream["track"]).glob("*.csv")) if "track" in ctx.upstream else []
    signals = [load_signal(p) for p in files] + [load_signal(p, **opts.load_options()) for p in opts.signals]
    result = Identifier(opts.ident_settings()).fit(signals).result
    doc = result.to_dict()
    write_text(ctx.out_dir / "params.json", json.dumps(doc, indent=2, allow_nan=False) + "\n")
    (ctx.out_dir / "report").mkdir()
    build_report(result, {"pipeline index": "../../index.html", "parameters JSON": "../params.json"}).save(
        ctx.out_dir / "report"
    )
    return {
        "params": "params.json",
        "report": "report/index.html",
        "quality": doc["quality"],
        "reasons": doc["reasons"],
        "parameters": doc["parameters"],
        "n_signals": len(signals),
    }


def _identify_needs(opts: IdentifyOptions, present: set[str]) -> list[str]:
    """Identify consumes the track stage when the pipeline has one; without it, it needs its own signals."""
    if "track" in present:
        return ["track"]
    return [] if opts.signals else ["track"]


@dataclass(frozen=True)
class PlanOptions:
    """The [plan] table: the scenario to plan and where the liquid model comes from."""

    scenario: Path
    """Scenario TOML ([move], [limits], [[obstacles]], [container], [solver], [liquid]), relative to the pipeline."""
    use_identified: bool = True
    """Plan for the liquid identified by this pipeline's [identify] stage; false (or no [identify]) uses the
    scenario's [liquid] table."""


def _liquid(opts: Any, ctx: StageContext, scenario: Any) -> Any:
    """The identified liquid when the stage consumes [identify], else the scenario's own [liquid]."""
    from sloshid.model.pendulum import SloshParams
    from sloshid.planning.scenario import resolve_liquid

    if "identify" in ctx.upstream:
        return SloshParams.from_identify_json(ctx.upstream["identify"] / "params.json")
    return resolve_liquid(scenario, None)


def _liquid_needs(opts: Any, present: set[str]) -> list[str]:
    """Plan and compare consume [identify] when asked to and when the pipeline has it."""
    return ["identify"] if opts.use_identified and "identify" in present else []


def run_plan(opts: PlanOptions, ctx: StageContext) -> dict[str, Any]:
    """Solve the scenario, write the 1 kHz trajectory CSV and the plan report."""
    from sloshid.planning.planner import plan
    from sloshid.planning.report import plan_report
    from sloshid.planning.scenario import load_scenario

    scenario = load_scenario(opts.scenario)
    result = plan(scenario, _liquid(opts, ctx, scenario), progress=True)
    traj = result.trajectory
    traj.to_csv(ctx.out_dir / "trajectory.csv")
    (ctx.out_dir / "report").mkdir()
    source = "the pipeline's identify stage" if "identify" in ctx.upstream else "the scenario's [liquid] table"
    links = {"pipeline index": "../../index.html", "trajectory CSV": "../trajectory.csv"}
    plan_report(result, scenario, source, links).save(ctx.out_dir / "report")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3))
    ax1.plot(traj.t_s, np.linalg.norm(traj.vel_m_s, axis=1), color="#36c")
    ax1.set(xlabel="time t (s)", ylabel="speed (m/s)", title="container speed")
    ax2.plot(traj.t_s, np.degrees(traj.euler_rad[:, 0]), label="roll phi")
    ax2.plot(traj.t_s, np.degrees(traj.euler_rad[:, 1]), label="pitch theta")
    ax2.set(xlabel="time t (s)", ylabel="tilt (deg)", title="container tilt = liquid surface")
    ax2.legend(fontsize=8)
    figure = _save_figure(fig, ctx.out_dir / "plan.png")
    return {"trajectory": "trajectory.csv", "report": "report/index.html", "figure": figure, **result.to_dict()}


@dataclass(frozen=True)
class CompareOptions:
    """The [compare] table of a pipeline: the scenario whose move is compared (its own [compare] table tunes it)."""

    scenario: Path
    """Scenario TOML, relative to the pipeline; the methods and studies come from its [compare] table."""
    use_identified: bool = True
    """Compare for the liquid identified by this pipeline's [identify] stage; false uses the scenario's [liquid]."""


def run_compare(opts: CompareOptions, ctx: StageContext) -> dict[str, Any]:
    """Build and score every method, write scores.json and the comparison report."""
    from sloshid.comparison.compare import compare, from_scenario
    from sloshid.comparison.report import save_report
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.scenario import load_scenario

    scenario = load_scenario(opts.scenario)
    interval = None
    if "identify" in ctx.upstream:
        interval = IdentifiedFrequency.from_identify_json(ctx.upstream["identify"] / "params.json").ci95_hz
    comp = compare(from_scenario(scenario, _liquid(opts, ctx, scenario), interval), progress=True)
    summary = comp.to_dict()
    write_text(ctx.out_dir / "scores.json", json.dumps(summary, indent=2, default=float) + "\n")
    save_report(comp, ctx.out_dir / "report", {"pipeline index": "../../index.html", "scores JSON": "../scores.json"})
    return {
        "scores": "scores.json",
        "report": "report/index.html",
        "verdict": summary["verdict"],
        "recommendation": summary["recommendation"],
        "methods": summary["methods"],
    }


TRACK = Stage("track", TrackOptions, run_track, input_files=lambda o: list(o.videos))
IDENTIFY = Stage(
    "identify", IdentifyOptions, run_identify, input_files=lambda o: list(o.signals), needs=_identify_needs
)

PLAN = Stage("plan", PlanOptions, run_plan, input_files=lambda o: [o.scenario], needs=_liquid_needs)

COMPARE = Stage("compare", CompareOptions, run_compare, input_files=lambda o: [o.scenario], needs=_liquid_needs)

REGISTRY: dict[str, Stage] = {"track": TRACK, "identify": IDENTIFY, "plan": PLAN, "compare": COMPARE}
"""Stages in the order they run."""
