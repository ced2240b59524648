"""The public Python API: one function per stage, each calling the same library function as the CLI, the pipeline
and the batch. Keywords are the settings dataclasses' fields (`sloshid.track(video, reference="container")`);
an unknown keyword is refused with a "did you mean"."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sloshid.core.settings import from_dict

if TYPE_CHECKING:
    from collections.abc import Sequence

    from sloshid.comparison.compare import Comparison
    from sloshid.identification.estimator import IdentResult
    from sloshid.identification.stage import Source
    from sloshid.model.pendulum import SloshParams
    from sloshid.planning.planner import PlanResult
    from sloshid.planning.scenario import Scenario
    from sloshid.tracking.inspect import InspectResult
    from sloshid.tracking.tracker import TrackResult


def track(
    video: str | Path, *, overlay: str | Path | None = None, progress: bool = False, **settings: Any
) -> TrackResult:
    """Track the float (or, with target="surface", the dyed liquid's surface) in every frame of `video`; keywords
    are TrackSettings fields (float_color, float_hsv_low, float_hsv_high, roi, reference, smooth, target,
    liquid_color, liquid_hsv_low, liquid_hsv_high, rest_frames, container_diameter_m). `overlay` also writes the
    annotated video."""
    from sloshid.core.outputs import Outputs
    from sloshid.tracking.tracker import TrackSettings, track_video
    from sloshid.video.frames import VIDEO_SUFFIXES

    track_settings = from_dict(TrackSettings, settings)
    if overlay is not None:  # the command line's check: never over the video, and a video the overlay writer makes
        overlay = Outputs([video]).file(overlay, "overlay", VIDEO_SUFFIXES)
    return track_video(video, track_settings, overlay=overlay, progress=progress)


def inspect(
    video: str | Path,
    *,
    at: float | None = None,
    roi: tuple[int, int, int, int] | None = None,
    picture: str | Path | None = None,
) -> InspectResult:
    """Look at one frame of `video` (the first, or the one shown at `at` seconds) as each target would track it:
    the colour presets found, the liquid's surface and walls, the float candidates, a suggested ROI and the
    `sloshid track` command to run (`.command`, `.summary()`); `picture` also writes the annotated frame (PNG)."""
    from sloshid.tracking.inspect import inspect_video

    result = inspect_video(video, at, roi)
    if picture is not None:
        result.save_picture(picture)
    return result


def identify(*sources: Source, **settings: Any) -> IdentResult:
    """Identify the sloshing mode jointly from signal files, Signals or TrackResults (or one list of them); keywords
    are IdentSettings fields (mass_kg, window_s, f_range_hz, drift, min_fit_percent, container_radius_m, ...) and
    the SignalColumns fields (time_col, value_col, time_var, value_var): the files' columns, or, when every source is
    a TrackResult, the tracked tables' (value_col="left_wall_mm")."""
    from sloshid.identification.estimator import IdentSettings
    from sloshid.identification.stage import SignalColumns, identify_sources

    if len(sources) == 1 and isinstance(sources[0], (list, tuple)):  # identify(["a.csv", tracked]) as well
        sources = tuple(sources[0])
    column_keys = {"time_col", "value_col", "time_var", "value_var"}
    columns = from_dict(SignalColumns, {k: v for k, v in settings.items() if k in column_keys})
    ident = from_dict(IdentSettings, {k: v for k, v in settings.items() if k not in column_keys})
    return identify_sources(sources, ident, columns)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML ([move], [limits], [[obstacles]], [container], [solver], [liquid], ...)."""
    from sloshid.planning.scenario import load_scenario as load

    return load(path)


def _scenario_and_liquid(scenario: Scenario | str | Path, params: Any) -> tuple[Scenario, SloshParams, Any]:
    """The scenario (loaded if a path), the liquid and the identified 95 % interval of f (None when unknown).
    `params` is SloshParams, an IdentResult, an identify JSON path, or None for the scenario's own [liquid]."""
    from sloshid.core.errors import UserError
    from sloshid.model.pendulum import IdentifiedFrequency, SloshParams
    from sloshid.planning.scenario import resolve_liquid

    if isinstance(scenario, (str, Path)):
        scenario = load_scenario(scenario)
    if isinstance(params, SloshParams):
        return scenario, params, None
    if hasattr(params, "params") and isinstance(params.params, SloshParams):  # an IdentResult
        band = getattr(params, "frequency_band_hz", None) or params.parameters["f_hz"].ci95  # IdentResult, IOFit
        return scenario, params.params, band
    if params is not None and not isinstance(params, (str, Path)):
        raise UserError(
            "params must be SloshParams, an IdentResult, the path of a `sloshid identify` JSON or None (the "
            f"scenario's [liquid]), got {type(params).__name__}."
        )
    liquid = resolve_liquid(scenario, params)  # reads and checks the file first: the interval's reader does not
    interval = IdentifiedFrequency.from_identify_json(params).ci95_hz if params is not None else None
    return scenario, liquid, interval


def plan(
    scenario: Scenario | str | Path,
    params: Any = None,
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
    scenario, liquid, _ = _scenario_and_liquid(scenario, params)
    if robust:
        scenario = robust_scenario(scenario)
    return solve(scenario, liquid, robust_omega_factors=robust_omega_factors, progress=progress)


def compare(
    scenario: Scenario | str | Path,
    params: Any = None,
    plan: PlanResult | None = None,
    *,
    progress: bool = False,
    **settings: Any,
) -> Comparison:
    """Score every method of the scenario's [compare] table for the liquid `params`; a `plan` of the same scenario
    and liquid is reused instead of solved again. Keywords override keys of the [compare] table (methods, ...)."""
    from sloshid.comparison.compare import compare_scenario

    scenario, liquid, interval = _scenario_and_liquid(scenario, params)
    if settings:
        scenario = replace(scenario, compare={**scenario.compare, **settings})
    return compare_scenario(scenario, liquid, plan=plan, f_interval_hz=interval, progress=progress)
