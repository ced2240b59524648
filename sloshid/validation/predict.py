"""A liquid model as `predict` uses it (pendulum, input gain, geometry) and its prediction for a pose log."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sloshid.core.errors import UserError
from sloshid.core.tables import write_csv
from sloshid.model.pendulum import SloshParams
from sloshid.model.pose import SMOOTH_S, PoseLog, PoseResponse, excitation, respond


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

    def __post_init__(self) -> None:
        if not (math.isfinite(self.input_gain) and self.input_gain > 0):
            raise UserError(f"the input gain must be a positive number, got {self.input_gain!r}.")
        if self.radius_m is not None and not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise UserError(f"the container radius must be a positive number of m, got {self.radius_m!r}.")
        if not math.isfinite(self.axis_offset_m):
            raise UserError(f"the axis offset must be a number of m, got {self.axis_offset_m!r}.")

    def with_geometry(
        self, radius_m: float | None = None, axis_offset_m: float | None = None, smooth_s: float | None = None
    ) -> LiquidModel:
        """The same model with the given geometry values replacing the stored ones (None keeps them)."""
        return LiquidModel(
            self.params,
            self.input_gain,
            self.radius_m if radius_m is None else radius_m,
            self.axis_offset_m if axis_offset_m is None else axis_offset_m,
            self.smooth_s if smooth_s is None else smooth_s,
        )


def load_model(path: str | Path) -> LiquidModel:
    """Read `sloshid identify` JSON: the mode, the input gain (input-output fits) and any stored geometry."""
    params = SloshParams.from_identify_json(path)
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    try:
        gain = float(data["parameters"].get("input_gain", {}).get("value", 1.0))
        geometry = data.get("geometry") or {}
        radius = geometry.get("container_radius_m") or (data.get("prior") or {}).get("container_radius_m")
        radius = None if radius is None else float(radius)
        offset, smooth = float(geometry.get("axis_offset_m", 0.0)), float(geometry.get("smooth_s", SMOOTH_S))
    except (AttributeError, TypeError, ValueError):
        raise UserError(f"parameter file {path}: input_gain or geometry is not a number.") from None
    return LiquidModel(params, gain, radius, offset, smooth)


def predict(pose: PoseLog, model: LiquidModel, settle_s: float = 3.0, rtol: float = 1e-9) -> PoseResponse:
    """The liquid's response to the logged motion, held at the last pose for settle_s after the log ends."""
    exc = excitation(pose, model.axis_offset_m, model.smooth_s)
    return respond(exc, model.params, model.input_gain, settle_s, rtol=rtol, atol=rtol * 1e-3)


def prediction_columns(resp: PoseResponse, radius_m: float | None) -> dict[str, np.ndarray]:
    """The `sloshid predict` CSV columns (SI, angles in degrees)."""
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
    if radius_m is not None:
        cols["wall_height_mm"] = resp.wall_height_mm(radius_m)
    return cols


def write_prediction(path: str | Path, resp: PoseResponse, radius_m: float | None) -> None:
    """Write the prediction CSV atomically."""
    write_csv(path, prediction_columns(resp, radius_m))
