"""The public Python API: one function per stage, each calling the same library function as the CLI, the pipeline
and the batch. Keywords are the settings dataclasses' fields (`sloshid.track(video, reference="container")`);
an unknown keyword is refused with a "did you mean"."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

from sloshid.core.settings import from_dict

if TYPE_CHECKING:
    from collections.abc import Sequence

    from sloshid.comparison.compare import Comparison
    from sloshid.identification.estimator import IdentResult, IdentSettings
    from sloshid.identification.stage import SignalColumns, Source
    from sloshid.model.pendulum import SloshParams
    from sloshid.planning.planner import PlanResult
    from sloshid.planning.scenario import Scenario
    from sloshid.tracking.inspect import InspectResult
    from sloshid.tracking.tracker import TrackResult, TrackSettings

    Liquid = SloshParams | IdentResult | str | Path | None
    """What `plan` and `compare` take as the liquid: parameters, an identification, its JSON file, or None (the
    scenario's own [liquid])."""

S = TypeVar("S")


def track(
    video: str | Path,
    settings: TrackSettings | None = None,
    *,
    overlay: str | Path | None = None,
    progress: bool = False,
    **keywords: Any,
) -> TrackResult:
    """Track the float (or, with target="surface", the dyed liquid's surface) in every frame of `video`, with
    `settings` (a `sloshid.TrackSettings`, typed) or its fields as keywords (`reference="container"`, checked, an
    unknown one refused). `overlay` also writes the annotated video."""
    from sloshid.core.outputs import Outputs
    from sloshid.tracking.tracker import TrackSettings, track_video
    from sloshid.video.frames import VIDEO_SUFFIXES

    _check_path(video, "video")
    track_settings = _settings(TrackSettings, settings, keywords)
    if overlay is not None:  # the command line's check: never over the video, and a video the overlay writer makes
        overlay = Outputs([video]).file(overlay, "overlay", VIDEO_SUFFIXES)
    return track_video(video, track_settings, overlay=overlay, progress=progress)


def inspect(
    video: str | Path,
    *,
    at: float | None = None,
    roi: tuple[int, int, int, int] | None = None,
    picture: str | Path | None = None,
    float_color: str | None = None,
) -> InspectResult:
    """Look at one frame of `video` (the first, or the one shown at `at` seconds; or a still picture, `.still`, whose
    settings are for the video it is a frame of) as each target would track it:
    the colour presets found, the liquid's surface and walls, the float candidates, a suggested ROI and the
    settings to track it with (`.track_settings`: `sloshid.track(video, **result.track_settings)`; `.summary()`);
    `picture` also writes the annotated frame (PNG); `float_color`: the float's colour preset, looked at as track
    looks for it (relaxed where the preset finds nothing) and tracked when found."""
    from sloshid.tracking.inspect import inspect_video

    result = inspect_video(video, at, roi, float_color)
    if picture is not None:
        result.save_picture(picture)
    return result


def identify(
    *sources: Source, settings: IdentSettings | None = None, columns: SignalColumns | None = None, **keywords: Any
) -> IdentResult:
    """Identify the sloshing mode jointly from signal files, Signals or TrackResults (or one list of them), with
    `settings` (a `sloshid.IdentSettings`) and `columns` (a `sloshid.SignalColumns`: the files' columns, or, when every
    source is a TrackResult, the tracked tables', value_col="left_wall_mm"), or the fields of either as keywords
    (`mass_kg=0.5`, checked, an unknown one refused)."""
    from dataclasses import fields

    from sloshid.identification.estimator import IdentSettings
    from sloshid.identification.stage import SignalColumns, identify_sources

    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):  # identify(["a.csv", tracked]) as well
        sources = tuple(sources[0])
    column_keys = {f.name for f in fields(SignalColumns)}
    # a column by its 0-based index, as the command line's `--time-col 0` gives it
    given = {k: str(v) if isinstance(v, int) and not isinstance(v, bool) else v for k, v in keywords.items()}
    picked = _settings(SignalColumns, columns, {k: v for k, v in given.items() if k in column_keys})
    ident = _settings(IdentSettings, settings, {k: v for k, v in keywords.items() if k not in column_keys})
    return identify_sources(sources, ident, picked)


def _settings(cls: type[S], given: S | None, keywords: dict[str, Any]) -> S:
    """Settings class `cls` from an instance or from keywords (each checked, an unknown one refused with a "did you
    mean"), not both."""
    from sloshid.core.errors import UserError

    if given is None:
        return from_dict(cls, keywords)
    if not isinstance(given, cls):
        raise UserError(f"settings must be a {cls.__name__}, got {type(given).__name__}.")
    if keywords:
        raise UserError(f"give a {cls.__name__} or its fields as keywords ({', '.join(keywords)}), not both.")
    return given


def _check_path(value: Any, what: str) -> None:
    """Refuse a `what` that is not a path (None, a number) in one sentence, before anything deep tries it."""
    from sloshid.core.errors import UserError

    if not isinstance(value, (str, os.PathLike)):
        raise UserError(f"{what} must be a path (str or Path), got {type(value).__name__}.")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML ([move], [limits], [[obstacles]], [container], [solver], [liquid], ...)."""
    from sloshid.planning.scenario import load_scenario as load

    return load(path)


def _scenario_and_liquid(
    scenario: Scenario | str | Path, params: Liquid
) -> tuple[Scenario, SloshParams, tuple[float, float] | None]:
    """The scenario (loaded if a path), the liquid and the identified 95 % interval of f (None when unknown).
    `params` is SloshParams, an IdentResult, an identify JSON path, or None for the scenario's own [liquid]."""
    from sloshid.core.errors import UserError
    from sloshid.model.pendulum import IdentifiedFrequency, SloshParams
    from sloshid.planning.scenario import Scenario, resolve_liquid

    if isinstance(scenario, (str, Path)):
        scenario = load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise UserError(f"scenario must be a Scenario or a scenario TOML's path, got {type(scenario).__name__}.")
    if isinstance(params, SloshParams):
        return scenario, params, None
    if params is None or isinstance(params, (str, Path)):
        liquid = resolve_liquid(scenario, params)  # reads and checks the file first: the interval's reader does not
        interval = IdentifiedFrequency.from_identify_json(params).ci95_hz if params is not None else None
        return scenario, liquid, interval
    if not isinstance(getattr(params, "params", None), SloshParams):  # an IdentResult
        raise UserError(
            "params must be SloshParams, an IdentResult, the path of a `sloshid identify` JSON or None (the "
            f"scenario's [liquid]), got {type(params).__name__}."
        )
    band = getattr(params, "frequency_band_hz", None) or params.parameters["f_hz"].ci95  # IdentResult, IOFit
    return scenario, params.params, band


def plan(
    scenario: Scenario | str | Path,
    params: Liquid = None,
    *,
    robust: bool = False,
    robust_omega_factors: Sequence[float] | None = None,
    progress: bool = False,
) -> PlanResult:
    """Plan the scenario's time-optimal slosh-free move for the liquid `params` (SloshParams, an IdentResult, an
    identify JSON path, or None for the scenario's [liquid]). `robust=True` plans the robust variant `compare` scores
    (the frequency factors of [compare] robust_omega_factors, default (0.9, 1.0, 1.1), as `sloshid plan --robust`);
    `robust_omega_factors` gives the factors themselves; None takes the scenario's [solver].robust_omega_factors."""
    from sloshid.comparison.compare import robust_scenario
    from sloshid.core.errors import UserError
    from sloshid.planning.planner import plan as solve

    if robust and robust_omega_factors is not None:
        raise UserError("give robust=True or robust_omega_factors, not both.")
    if isinstance(robust_omega_factors, str):
        raise UserError(
            f"robust_omega_factors must be numbers such as (0.9, 1.1), got the string {robust_omega_factors!r}."
        )
    if isinstance(scenario, (str, Path)):
        scenario = load_scenario(scenario)
    if getattr(scenario, "within_margin", False):  # upright, or tilting within a spill margin
        return plan_upright_scenario(scenario, params, robust)
    loaded, liquid, _ = _scenario_and_liquid(scenario, params)
    if robust:
        loaded = robust_scenario(loaded)
    # a scenario within a margin (the one kind solve() plans as an UprightPlan) was planned above
    return cast("PlanResult", solve(loaded, liquid, robust_omega_factors=robust_omega_factors, progress=progress))


def plan_upright_scenario(scenario: Scenario, params: Liquid, robust: bool = False) -> Any:
    """An upright scenario's plan (`planning.upright.UprightPlan`): a tray needs no [liquid], and an identify JSON's
    standard errors give the risk's draws; robust=True holds the margin for sampled models ([risk].scenarios, or
    50) as `sloshid plan --robust` does."""
    from sloshid.planning.risk import ROBUST_UPRIGHT_SAMPLES
    from sloshid.planning.upright import plan_upright

    path = params if isinstance(params, (str, Path)) else None
    liquid = None
    if params is not None or scenario.liquid is not None:
        _, liquid, _ = _scenario_and_liquid(scenario, params)
    samples = None
    if robust:
        samples = scenario.risk.scenarios if scenario.risk and scenario.risk.scenarios else ROBUST_UPRIGHT_SAMPLES
    return plan_upright(scenario, liquid, params_path=path, robust_samples=samples)


def compare(
    scenario: Scenario | str | Path,
    params: Liquid = None,
    plan: PlanResult | None = None,
    *,
    progress: bool = False,
    **settings: Any,
) -> Comparison:
    """Score every method of the scenario's [compare] table for the liquid `params`; a `plan` of the same scenario
    and liquid is reused instead of solved again. Keywords override keys of the [compare] table (methods, ...)."""
    from sloshid.comparison.compare import compare_scenario
    from sloshid.core.errors import UserError
    from sloshid.planning.planner import PlanResult

    scenario, liquid, interval = _scenario_and_liquid(scenario, params)
    if plan is not None and not isinstance(plan, PlanResult):
        raise UserError(f"plan must be a PlanResult of `sloshid.plan` or None, got {type(plan).__name__}.")
    if settings:
        scenario = replace(scenario, compare={**scenario.compare, **settings})
    return compare_scenario(scenario, liquid, plan=plan, f_interval_hz=interval, progress=progress)
