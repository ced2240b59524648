"""A liquid model as `predict` uses it (pendulum, input gain, geometry) and its prediction for a pose log."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.hashing import file_sha256
from sloshid.core.settings import check_in_metres
from sloshid.core.tables import write_csv
from sloshid.identification.stage import check_sampling
from sloshid.model.pendulum import SloshParams
from sloshid.model.pose import SMOOTH_S, PoseLog, PoseResponse, excitation, pose_from_trajectory, respond
from sloshid.model.trajectory import Trajectory


@dataclass(frozen=True)
class LiquidModel:
    """Everything a prediction needs besides the motion: the mode, the input gain and the geometry."""

    params: SloshParams
    input_gain: float = 1.0
    """Scale of the horizontal pivot acceleration the mode feels (1 for a decay-only or physical model)."""
    radius_m: float | None = None
    """Container radius R; wall height = R tan(relative angle)."""
    axis_offset_m: float = 0.0
    """Distance up the container axis from the logged point to the pendulum pivot."""
    smooth_s: float = SMOOTH_S
    """Savitzky-Golay window for the pose log's accelerations."""
    output_gain: float = 1.0
    """Scale of the reading (wall height, or angle) against the plane of the pendulum's surface: the sloshing mode's
    wall elevation per surface angle and the sensor's own scale (1 for a decay-only or physical model)."""
    crest_coeff: float = 0.0
    """Second-order crest term: the reading grows by this times tan(relative angle) (0: a plane's wall height)."""
    vertical_gain: float = 1.0
    """Scale of the vertical pivot acceleration in the effective gravity g + vertical_gain az (1 for a pendulum): how
    strongly vertical motion pumps the mode."""
    fitted_on: tuple[Path, ...] = ()
    """The measurement files the model was identified from (identify JSON `sources`, as found from here): a validate
    run of one of them scores the fit, not a prediction."""
    fitted_sha256: tuple[str, ...] = ()
    """Their contents' hashes (identify JSON `source_sha256`): the same file wherever it is now, or a copy."""

    def fitted_to(self, source: str) -> bool:
        """The measurement file `source` is one the model was identified from (by its path or its content)."""
        path = Path(source)
        if not path.is_file():
            return False
        return path.resolve() in self.fitted_on or (
            bool(self.fitted_sha256) and file_sha256(path) in self.fitted_sha256
        )

    def __post_init__(self) -> None:
        for name in ("input_gain", "output_gain", "vertical_gain"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise UserError(f"the {name.replace('_', ' ')} must be a positive number, got {value!r}.")
        if self.radius_m is not None and not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise UserError(f"the container radius must be a positive number of m, got {self.radius_m!r}.")
        if not math.isfinite(self.crest_coeff):
            raise UserError(f"the crest coefficient must be a number, got {self.crest_coeff!r}.")
        if not math.isfinite(self.axis_offset_m):
            raise UserError(f"the axis offset must be a number of m, got {self.axis_offset_m!r}.")

    def with_geometry(
        self, radius_m: float | None = None, axis_offset_m: float | None = None, smooth_s: float | None = None
    ) -> LiquidModel:
        """The same model with the given geometry values replacing the stored ones (None keeps them)."""
        check_in_metres("container_radius_m", radius_m)
        return replace(
            self,
            radius_m=self.radius_m if radius_m is None else radius_m,
            axis_offset_m=self.axis_offset_m if axis_offset_m is None else axis_offset_m,
            smooth_s=self.smooth_s if smooth_s is None else smooth_s,
        )

    def reading(self, resp: PoseResponse, kind: str) -> np.ndarray:
        """What the sensor reads from the predicted surface: the wall height (mm) for kind 'wall_height_mm', else the
        relative angle (deg)."""
        return read_out(*plane_series(resp, kind, self.radius_m), self.output_gain, self.crest_coeff)


def plane_series(resp: PoseResponse, kind: str, radius_m: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The plane's value a reading of this kind scales (R tan(relative angle) in mm, or the angle in deg) and the
    surface slope tan(relative angle)."""
    slope = np.tan(np.minimum(resp.rel_angle_rad, 1.4))
    return (resp.wall_height_mm(radius_m) if kind == "wall_height_mm" else resp.rel_angle_deg), slope


def read_out(plane: np.ndarray, slope: np.ndarray, output_gain: float, crest_coeff: float) -> np.ndarray:
    """output_gain x the plane's value x (1 + crest_coeff x slope): the first mode's wall elevation is a fraction of
    the plane's (2 / (xi^2 - 1) = 0.84 in linear theory) and a steep wave's crest rises above it (second order)."""
    return output_gain * plane * (1.0 + crest_coeff * slope)


def load_model(path: str | Path) -> LiquidModel:
    """Read `sloshid identify` JSON: the mode, the input, output and vertical gains (input-output fits; 1 where a file
    lacks them) and any stored geometry."""
    params = SloshParams.from_identify_json(path)
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    try:
        gain = float(data["parameters"].get("input_gain", {}).get("value", 1.0))
        out_gain = float(data["parameters"].get("output_gain", {}).get("value", 1.0))
        crest = float(data["parameters"].get("crest_coeff", {}).get("value", 0.0))
        vertical = float(data["parameters"].get("vertical_gain", {}).get("value", 1.0))
        geometry = data.get("geometry") or {}
        radius = geometry.get("container_radius_m") or (data.get("prior") or {}).get("container_radius_m")
        radius = None if radius is None else float(radius)
        offset, smooth = float(geometry.get("axis_offset_m", 0.0)), float(geometry.get("smooth_s", SMOOTH_S))
    except (AttributeError, TypeError, ValueError):
        raise UserError(
            f"parameter file {path}: a gain, the crest coefficient or the geometry is not a number."
        ) from None
    sources = data.get("sources") if isinstance(data.get("sources"), list) else []
    fitted = tuple(f for src in sources if isinstance(src, str) for f in [_found(src, Path(path).parent)] if f)
    hashes = data.get("source_sha256") if isinstance(data.get("source_sha256"), list) else []
    digests = tuple(h for h in hashes if isinstance(h, str))
    return LiquidModel(params, gain, radius, offset, smooth, out_gain, crest, vertical, fitted, digests)


def _found(source: str, beside: Path) -> Path | None:
    """The file an identify JSON's source names, resolved: as written (from the working directory), else beside the
    JSON; None when it is not there (an array, or a file moved away)."""
    for candidate in (Path(source), beside / source):
        if candidate.is_file():
            return candidate.resolve()
    return None


def planning_note(path: str | Path, trajectory: str = "TRAJ.csv", plan: Trajectory | None = None) -> str | None:
    """For `plan` and `compare` with an input-output model (`identify --trajectory`, gains other than 1): they plan
    and score with its f and zeta alone, as a pendulum; the sentence says so, how far the whole model moves the liquid
    in `plan` (when given: the planned trajectory) and how to check a plan with it (None for a plain model)."""
    model = load_model(path)
    if model.input_gain == 1 and model.vertical_gain == 1:
        return None
    moved = "the liquid moves during a plan"
    if plan is not None:
        pose = pose_from_trajectory(plan, trajectory)
        peak = float(predict(pose, pivot_for(pose, model, None)[0]).rel_angle_deg.max())
        moved = f"this plan moves the liquid by up to {peak:.2g} deg against the container"
    return (
        f"{path} is an input-output model (input gain {model.input_gain:.3g}, vertical gain {model.vertical_gain:.3g}); "
        f"plans and scores use its f and zeta alone, as a pendulum with gains of 1, so by the whole model {moved}: "
        f"check a plan with `sloshid predict {trajectory} --params {path}`."
    )


def pivot_for(pose: PoseLog, model: LiquidModel, axis_offset_m: float | None) -> tuple[LiquidModel, str | None]:
    """The model with the pivot offset for this motion: the one given; else, for a sloshid trajectory, whose point is
    the liquid surface's centre (the pivot the planner moved), none instead of the stored one (fitted to robot logs
    of another point), with a note saying so; else the stored one."""
    if axis_offset_m is not None:
        return model.with_geometry(axis_offset_m=axis_offset_m), None
    if pose.acc_m_s2 is None or model.axis_offset_m == 0:
        return model, None
    note = (
        f"{pose.source} is a sloshid trajectory, whose point is the pivot (the liquid surface's centre), so the "
        f"parameters' axis offset of {model.axis_offset_m:g} m (from the robot logs they were fitted to) is not "
        "applied; give --axis-offset-m to apply one."
    )
    return model.with_geometry(axis_offset_m=0.0), note


def predict(pose: PoseLog, model: LiquidModel, settle_s: float = 3.0, rtol: float = 1e-9) -> PoseResponse:
    """The liquid's response to the logged motion, held at the last pose for settle_s after the log ends; a log
    sampled too slowly for the liquid's mode (a time column in milliseconds) is refused."""
    f_hz = model.params.f_hz
    check_sampling(pose.source, 1.0 / float(np.median(np.diff(pose.t_s))), (f_hz, f_hz))
    exc = excitation(pose, model.axis_offset_m, model.smooth_s)
    return respond(exc, model.params, model.input_gain, settle_s, rtol, rtol * 1e-3, model.vertical_gain)


def prediction_columns(resp: PoseResponse, model: LiquidModel) -> dict[str, np.ndarray]:
    """The `sloshid predict` CSV columns (SI, angles in degrees); the wall height is the model's reading."""
    cols = {
        "t_s": resp.t_s,
        "ax_m_s2": resp.acc_m_s2[:, 0],
        "ay_m_s2": resp.acc_m_s2[:, 1],
        "az_m_s2": resp.acc_m_s2[:, 2],
        "liquid_phi_deg": np.degrees(resp.liquid_rad[:, 0]),
        "liquid_theta_deg": np.degrees(resp.liquid_rad[:, 1]),
        "rel_roll_deg": np.degrees(resp.rel_rad[:, 0]),
        "rel_pitch_deg": np.degrees(resp.rel_rad[:, 1]),
        "rel_angle_deg": resp.rel_angle_deg,
    }
    if model.radius_m is not None:
        cols["wall_height_mm"] = model.reading(resp, "wall_height_mm")
    return cols


def write_prediction(path: str | Path, resp: PoseResponse, model: LiquidModel) -> None:
    """Write the prediction CSV atomically."""
    write_csv(path, prediction_columns(resp, model))
