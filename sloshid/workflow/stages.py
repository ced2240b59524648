"""The stages a pipeline can declare, each a thin wrapper over the same library call the matching command makes."""

from __future__ import annotations

import contextlib
import pickle
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sloshid.comparison.compare import compare_scenario, compare_settings
from sloshid.comparison.recommend import joints_path
from sloshid.core.atomic import atomic_path, write_json
from sloshid.core.errors import UserError
from sloshid.core.parallel import parallel_map
from sloshid.identification.stage import identify_sources, to_signal
from sloshid.model.pendulum import IdentifiedFrequency
from sloshid.planning.planner import plan
from sloshid.planning.scenario import MAX_RISK_SCENARIOS, Scenario, load_scenario, resolve_liquid
from sloshid.tracking.tracker import track_video
from sloshid.workflow.options import IdentifyOptions, TrackOptions, check_tracked_columns
from sloshid.workflow.pipeline import Stage, StageContext

RECOMMENDED_CSV = "recommended.csv"
"""The [compare] stage's recommended move (1 kHz trajectory; recommended.json beside it says which method and why)."""
JOINTS_CSV = joints_path("trajectory.csv").name
"""The [plan] stage's joint trajectory (t_s, q1..q7 in rad) of trajectory.csv, when the scenario's arm follows it."""
PLAN_PICKLE = "plan.pickle"
"""The [plan] stage's solution with the scenario it solved, kept so that [compare] does not solve it again."""


def _save_figure(fig: Any, path: Path) -> str:
    """Write a matplotlib figure as PNG (2x resolution) and close it; returns the file name for the index page."""
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=200, bbox_inches="tight")  # twice screen resolution
    plt.close(fig)
    return path.name


def track_one(video: Path, opts: TrackOptions, out_dir: Path, one_core: bool = False) -> dict[str, Any]:
    """Track one video into out_dir/<stem>.csv (and overlay); returns its summary. On Dask workers one_core
    keeps each video to one core, since the workers already run videos side by side."""
    overlay = out_dir / f"{video.stem}_overlay.mp4" if opts.overlay else None
    res = track_video(video, opts.track_settings(), overlay=overlay, progress=not one_core, multithreaded=not one_core)
    res.to_csv(out_dir / f"{video.stem}.csv")
    return {
        **res.to_dict(),
        "csv": f"{video.stem}.csv",
        "valid_share": float(res.valid.mean()),
        "overlay": overlay.name if overlay else None,
    }


def run_track(opts: TrackOptions, ctx: StageContext) -> dict[str, Any]:
    """Track every video (in parallel when [run].workers > 1); one angles CSV per video."""
    import matplotlib.pyplot as plt

    from sloshid.core.tables import read_csv

    if ctx.run.workers > 1 and len(opts.videos) > 1:
        jobs = [(video, opts, ctx.out_dir, True) for video in opts.videos]
        summaries = parallel_map(track_one, jobs, ctx.run.workers)
    else:
        summaries = [track_one(v, opts, ctx.out_dir) for v in opts.videos]
    fig, ax = plt.subplots(figsize=(10, 3.2))
    for summary in summaries:
        table = read_csv(ctx.out_dir / summary["csv"])
        ok = table["valid"] == 1
        ax.plot(table["t_s"][ok], table["angle_deg"][ok], ".", ms=2, alpha=0.5)
        ax.plot(table["t_s"], table["angle_smoothed_deg"], lw=1, label=f"{Path(summary['video']).name} (smoothed)")
    what = "liquid surface" if opts.target == "surface" else "float"
    ax.set(xlabel="time t (s)", ylabel=f"{what} angle (deg)", title=f"tracked {what} angle (dots: measured frames)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    return {"figure": _save_figure(fig, ctx.out_dir / "angle.png"), "videos": summaries}


def _check_track(opts: TrackOptions) -> None:
    """At least one video, and no two with the same name (their CSVs would collide)."""
    if not opts.videos:
        raise UserError("[track].videos is empty; list at least one video.")
    if len({v.stem for v in opts.videos}) < len(opts.videos):
        raise UserError("[track].videos has two files with the same name; their CSVs would collide.")


@contextlib.contextmanager
def _in_scenario(path: Path) -> Iterator[None]:
    """A problem found in a stage's scenario file names that file: the pipeline's own tables have keys of the same
    names ([compare] in both), and '[compare].methods has unknown method' sent the user to the wrong file."""
    try:
        yield
    except UserError as exc:
        text = str(exc)
        raise UserError(text if str(path) in text else f"scenario {path}: {text}") from None


def _check_scenario(opts: PlanOptions | CompareOptions) -> None:
    """The scenario file is a valid scenario (loading it validates every table)."""
    with _in_scenario(opts.scenario):
        load_scenario(opts.scenario)


def _check_compare(opts: CompareOptions) -> None:
    """The scenario is valid and so is its [compare] table, which only the compare stage of a slosh-free move reads."""
    with _in_scenario(opts.scenario):
        scenario = load_scenario(opts.scenario)
        if scenario.within_margin:
            from sloshid.comparison.upright_compare import check_comparable

            check_comparable(scenario)
        else:
            compare_settings(scenario)


def run_identify(opts: IdentifyOptions, ctx: StageContext) -> dict[str, Any]:
    """Joint identification of the tracked angles and the listed signal files; JSON and HTML report. What the
    inputs' reading noticed (dropped frames, NaN samples) goes into the summary and the index."""
    tracked = sorted((ctx.upstream["track"]).glob("*.csv")) if "track" in ctx.upstream else []
    # the columns are the signal files'; without any, the tracked tables' (value_col = "left_wall_mm": the wall height)
    tracked_columns = opts.columns() if not opts.signals else None
    signals = [to_signal(p, tracked_columns) for p in tracked] + [to_signal(p, opts.columns()) for p in opts.signals]
    result = identify_sources(signals, opts.ident_settings())
    doc = result.to_dict()
    write_json(ctx.out_dir / "params.json", doc)
    result.report(ctx.out_dir / "report", {"pipeline index": "../../index.html", "parameters JSON": "../params.json"})
    return {
        "params": "params.json",
        "report": "report/index.html",
        "quality": doc["quality"],
        "reasons": doc["reasons"],
        "parameters": doc["parameters"],
        "n_signals": len(signals),
        "input_warnings": [w for sig in signals for w in sig.warnings],
        "between": result.between.summary() if result.between else None,
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


def _liquid(ctx: StageContext, scenario: Any) -> Any:
    """The identified liquid when the stage consumes [identify], else the scenario's own [liquid]."""
    params = ctx.upstream["identify"] / "params.json" if "identify" in ctx.upstream else None
    return resolve_liquid(scenario, params)


def _liquid_needs(opts: Any, present: set[str]) -> list[str]:
    """Plan and compare consume [identify] when asked to and when the pipeline has it."""
    return ["identify"] if opts.use_identified and "identify" in present else []


def _margin_liquid(ctx: StageContext, scenario: Scenario) -> Path | None:
    """What a plan within a spill margin takes as `params`: the identify stage's JSON (its standard errors give the
    risk's draws), else None for the scenario's own liquids ([liquid], or a tray's containers)."""
    return ctx.upstream["identify"] / "params.json" if "identify" in ctx.upstream else None


def _run_margin_plan(scenario: Scenario, ctx: StageContext) -> dict[str, Any]:
    """A move within a spill margin (upright or tilting): its plan, trajectory, report and wall figure."""
    from sloshid.api import plan_upright_scenario

    result = plan_upright_scenario(scenario, _margin_liquid(ctx, scenario))
    result.trajectory.to_csv(ctx.out_dir / "trajectory.csv")
    source = "the pipeline's identify stage" if "identify" in ctx.upstream else "the scenario's liquids"
    links = {"pipeline index": "../../index.html", "trajectory CSV": "../trajectory.csv"}
    result.report(ctx.out_dir / "report", links, liquid_source=source)
    figure = _save_figure(result.plot(), ctx.out_dir / "plan.png")
    arm = _arm(scenario, result.trajectory, ctx, robust=False)
    return {"trajectory": "trajectory.csv", "report": "report/index.html", "figure": figure, **result.to_dict(), **arm}


def _arm(scenario: Scenario, traj: Any, ctx: StageContext, robust: bool) -> dict[str, Any]:
    """`{"arm": ...}`: why the scenario's [robot] arm cannot follow the move the run would send
    (`planning.arm.arm_objection`), with what plans one it can (`_objection`); None when it can or the scenario names
    none."""
    if scenario.arm is None:
        return {"arm": None}
    from sloshid.planning.arm import arm_objection

    return _objection(scenario, arm_objection(traj, scenario.arm), ctx, robust)


def _objection(scenario: Scenario, found: Any, ctx: StageContext, robust: bool) -> dict[str, Any]:
    """`{"arm": ...}` for an `ArmObjection` (None: the arm follows the move): why, and what plans one it can (the
    scenario, the liquid's JSON, robust). A move within a spill margin is not fitted to the arm (refit false)."""
    if found is None:
        return {"arm": None}
    params = ctx.upstream["identify"] / "params.json" if "identify" in ctx.upstream else None
    return {
        "arm": {
            "reason": found.reason,
            "refit": found.refit and not scenario.within_margin,
            "scenario": scenario.source,
            "params": str(params) if params is not None else None,
            "robust": robust,
        }
    }


def run_plan(opts: PlanOptions, ctx: StageContext) -> dict[str, Any]:
    """Solve the scenario, write the 1 kHz trajectory CSV, the plan (for compare to reuse) and the plan report; with a
    [robot] arm (unless fit_joints = false) the plan the arm can follow, re-planned slower when needed, and its joints
    (trajectory_joints.csv)."""
    scenario = load_scenario(opts.scenario)
    if scenario.within_margin:
        return _run_margin_plan(scenario, ctx)
    params = _liquid(ctx, scenario)
    fastest = plan(scenario, params, progress=True)
    with atomic_path(ctx.out_dir / PLAN_PICKLE) as tmp:  # the fastest plan: compare scores it, and fits it itself
        tmp.write_bytes(pickle.dumps({"scenario": str(opts.scenario), "result": fastest}))
    result: Any = fastest
    fitted: dict[str, Any] | None = None
    if scenario.arm is not None and scenario.arm.fits_sent_moves:
        from sloshid.planning.arm import fit_arm

        fit = fit_arm(fastest.trajectory, scenario, params, fastest)
        result = fit.plan or fastest
        result.joints = fit.joints
        if fit.follows and fit.joints is not None:
            fit.joints.write_csv(ctx.out_dir / JOINTS_CSV)
        fitted = {**fit.to_dict(), "joints_csv": JOINTS_CSV if fit.follows else None}
        arm = _objection(scenario, fit.objection, ctx, robust=False)
    else:
        arm = _arm(scenario, fastest.trajectory, ctx, robust=False)
    result.trajectory.to_csv(ctx.out_dir / "trajectory.csv")
    source = "the pipeline's identify stage" if "identify" in ctx.upstream else "the scenario's [liquid] table"
    links = {"pipeline index": "../../index.html", "trajectory CSV": "../trajectory.csv"}
    result.report(ctx.out_dir / "report", links, liquid_source=source)
    figure = _save_figure(result.plot(), ctx.out_dir / "plan.png")
    summary = {"trajectory": "trajectory.csv", "report": "report/index.html", "figure": figure, **result.to_dict()}
    return {**summary, **arm, "arm_fit": fitted}


@dataclass(frozen=True)
class CompareOptions:
    """The [compare] table of a pipeline: the scenario whose move is compared (its own [compare] table tunes it)."""

    scenario: Path
    """Scenario TOML, relative to the pipeline; the methods and studies come from its [compare] table."""
    use_identified: bool = True
    """Compare for the liquid identified by this pipeline's [identify] stage; false uses the scenario's [liquid]."""
    robust_samples: int | None = None
    """A move within a spill margin: the sampled models of sloshid's robust plan in the ranking (default the
    scenario's [risk].scenarios, else 50; 0 leaves the robust plan out, which saves most of the stage's time)."""

    def __post_init__(self) -> None:
        if self.robust_samples is not None and not 0 <= self.robust_samples <= MAX_RISK_SCENARIOS:
            raise UserError(
                f"[compare].robust_samples must lie in 0..{MAX_RISK_SCENARIOS} (0: no robust plan), got "
                f"{self.robust_samples}."
            )


def _compare_needs(opts: CompareOptions, present: set[str]) -> list[str]:
    """Compare consumes [identify] like plan does, and [plan]'s solution when it planned the same scenario."""
    return _liquid_needs(opts, present) + (["plan"] if "plan" in present else [])


def _upstream_plan(ctx: StageContext, scenario_path: Path, params: Any) -> Any:
    """The [plan] stage's solution when it solved this very scenario for this very liquid, else None."""
    if "plan" not in ctx.upstream or not (ctx.upstream["plan"] / PLAN_PICKLE).exists():
        return None
    planned = pickle.loads((ctx.upstream["plan"] / PLAN_PICKLE).read_bytes())
    same = planned["scenario"] == str(scenario_path) and planned["result"].params == params
    return planned["result"] if same else None


def _run_margin_compare(scenario: Scenario, opts: CompareOptions, ctx: StageContext) -> dict[str, Any]:
    """A move within a spill margin: sloshid's plans against the upright baselines, ranked by risk; the first-ranked
    move that meets margin and residual is the recommended one (recommended.csv, and recommended.json beside it)."""
    from sloshid.comparison.upright_compare import compare_upright

    path = _margin_liquid(ctx, scenario)
    liquid = resolve_liquid(scenario, path) if path is not None or scenario.liquid is not None else None
    comp = compare_upright(scenario, liquid, params_path=path, robust_samples=opts.robust_samples)
    summary = comp.to_dict()
    write_json(ctx.out_dir / "scores.json", summary)
    links = {"pipeline index": "../../index.html", "scores JSON": "../scores.json"}
    best, move = comp.recommended, None
    recommendation: dict[str, str | None] = {"method": None, "label": "none", "risk": comp.risk_level}
    if best is not None:
        comp.write_first(ctx.out_dir / RECOMMENDED_CSV)
        links = {"recommended move CSV": f"../{RECOMMENDED_CSV}", **links}
        move = {"method": best.key, "label": best.label, "transfer_time_s": best.T_s, "csv": RECOMMENDED_CSV}
        move.update(_arm(scenario, best.trajectory, ctx, robust=False))
        recommendation = {"method": best.key, "label": best.label, "risk": comp.risk_level}
    comp.report_page(links).save(ctx.out_dir / "report")
    return {
        "kind": "margin",
        "scores": "scores.json",
        "report": "report/index.html",
        "recommended": move,
        "verdict": comp.verdict,
        "recommendation": recommendation,
        "ranked": summary["ranked"],
        "t_no_liquid_s": summary["t_no_liquid_s"],
    }


def run_compare(opts: CompareOptions, ctx: StageContext) -> dict[str, Any]:
    """Build and score every method (reusing the plan stage's solution), write scores.json and the report."""
    scenario = load_scenario(opts.scenario)
    if scenario.within_margin:
        return _run_margin_compare(scenario, opts, ctx)
    params = _liquid(ctx, scenario)
    interval = None
    if "identify" in ctx.upstream:
        interval = IdentifiedFrequency.from_identify_json(ctx.upstream["identify"] / "params.json").ci95_hz
    planned = _upstream_plan(ctx, opts.scenario, params)
    comp = compare_scenario(scenario, params, plan=planned, f_interval_hz=interval, progress=True)
    summary = comp.to_dict()
    write_json(ctx.out_dir / "scores.json", summary)
    move = comp.recommended_move()
    links = {"pipeline index": "../../index.html", "scores JSON": "../scores.json"}
    if move is not None and comp.recommended is not None:
        comp.write_recommended(ctx.out_dir / RECOMMENDED_CSV)
        found = comp.arm_objection(scenario.arm)
        move = {**move, **_objection(scenario, found, ctx, robust=move["method"] == "sloshid_robust")}
        if move["arm_fit"] is not None and move["arm_fit"]["follows"]:
            move["arm_fit"]["joints_csv"] = joints_path(RECOMMENDED_CSV).name
        links = {"recommended move CSV": f"../{RECOMMENDED_CSV}", **links}
    comp.report(ctx.out_dir / "report", links, progress=True)
    return {
        "scores": "scores.json",
        "report": "report/index.html",
        "recommended": {**move, "csv": RECOMMENDED_CSV} if move is not None else None,
        "verdict": summary["verdict"],
        "recommendation": summary["recommendation"],
        "methods": summary["methods"],
    }


TRACK = Stage("track", TrackOptions, run_track, input_files=lambda o: list(o.videos), check=_check_track)
IDENTIFY = Stage(
    "identify",
    IdentifyOptions,
    run_identify,
    input_files=lambda o: list(o.signals),
    needs=_identify_needs,
    check_with=lambda o, others: check_tracked_columns(others["track"], o) if "track" in others else None,
)

PLAN = Stage(
    "plan", PlanOptions, run_plan, input_files=lambda o: [o.scenario], needs=_liquid_needs, check=_check_scenario
)

COMPARE = Stage(
    "compare",
    CompareOptions,
    run_compare,
    input_files=lambda o: [o.scenario],
    needs=_compare_needs,
    check=_check_compare,
)

REGISTRY: dict[str, Stage] = {"track": TRACK, "identify": IDENTIFY, "plan": PLAN, "compare": COMPARE}
"""Stages in the order they run."""
