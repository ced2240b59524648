"""A liquid model as `predict` uses it (spherical pendulum, wall reading, geometry), its prediction for a pose log with
the 95 % band and the extrapolation guard."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from sloshid.core.errors import SMALL_FILE_BYTES, SettingError, UserError, read_input
from sloshid.core.hashing import file_sha256
from sloshid.core.settings import check_axis_offset, check_in_metres, setting_field
from sloshid.core.tables import write_csv
from sloshid.identification.stage import check_sampling
from sloshid.model.pendulum import SloshParams, rotation_depths
from sloshid.model.pose import (
    MOTION_QUANTITIES,
    SMOOTH_S,
    Excitation,
    PoseLog,
    PoseResponse,
    excitation,
    motion_range,
    pose_from_trajectory,
    respond,
)
from sloshid.model.simulate import MAX_SETTLE_S
from sloshid.model.trajectory import Trajectory

STRUCTURE = (
    "spherical pendulum at the surface with breaking drag; wall = static surface + wave_share x the wave (crest_coeff)"
    " + the level at rest (rest_tilt_x_deg, rest_tilt_y_deg), less its own reading; each view's arc of the wall"
    " (view_arc_deg)"
)
"""The model structure an identify --trajectory file names (`fit.structure`); a file of another is refused."""
OLD_GAINS = ("input_gain", "output_gain", "vertical_gain")
"""Parameters of the input-output model before the physics-first structure: a file holding them is refused."""
MODEL_ERROR_LOG_SD = 0.09
"""Model error of a predicted peak (root mean square of log(measured / predicted peak)), calibrated on the held-out
kinds of the shared runs (benchmarks/validate_real.py, leave-one-kind-out: 0.086 over the nine runs): part of every
band."""


@dataclass(frozen=True)
class GeometrySettings:
    """The container's geometry and the pose log's reading for `predict` and `validate`, each replacing what the
    parameters store (`LiquidModel.with_geometry`); not given: the stored value."""

    axis_offset_m: float | None = setting_field(None, unit="m", metavar="M")
    """Distance along the container axis from the logged point up to the pendulum pivot (about the liquid surface at
    rest; -3 to 3 m); not given: the value stored in the parameters, else 0 (predict: 0 for a sloshid trajectory,
    whose point is the pivot)."""
    container_radius_m: float | None = setting_field(None, unit="m", metavar="M")
    """Container radius R, for the wall height; not given: the radius the parameters were identified with (when
    identify had `container_radius_m`); without one only the angles are written."""
    pose_columns: str | None = setting_field(None, metavar="NAMES")
    """Names of a headerless pose log's columns in order, e.g. t,x,y,z,qx,qy,qz,qw (the default for 8 columns) or
    t,x,y,z,roll_deg,pitch_deg,yaw_deg; _ skips a column."""
    smooth_s: float | None = setting_field(None, unit="s", metavar="S")
    """Savitzky-Golay window for accelerations from a pose log; not given: the stored one (0.1 s by default: gain
    0.999 at 3 Hz)."""

    def __post_init__(self) -> None:
        check_in_metres("container_radius_m", self.container_radius_m)
        check_axis_offset("axis_offset_m", self.axis_offset_m)


@dataclass(frozen=True)
class PredictSettings:
    """How far a prediction runs beyond the motion it is given (`sloshid predict`)."""

    settle_s: float = setting_field(3.0, unit="s", metavar="S")
    """How long to go on after the log ends, held at its last pose: the liquid's swing after the move."""

    def __post_init__(self) -> None:
        if not 0 <= self.settle_s <= MAX_SETTLE_S:
            raise SettingError(
                "settle_s", f"{{name}} must lie between 0 and {MAX_SETTLE_S:g} s, got {self.settle_s:g}."
            )


@dataclass(frozen=True)
class LiquidModel:
    """Everything a prediction needs besides the motion: the mode, the wall's reading of it and the geometry.

    Physics fixes the structure: one spherical pendulum in the world frame (both horizontal directions coupled, gravity
    g + az, so vertical motion pumps it), pivoted at the liquid surface (with the fill height: where a turn about a
    horizontal axis reaches the first mode, `depths_m`); the wall height is that of the surface at rest
    under the current acceleration (the faster modes follow the motion) plus `wave_share` times the first mode's
    excess over it, with a second-order crest."""

    params: SloshParams
    radius_m: float | None = None
    """Container radius R; wall height = R x the surface's slope at the wall."""
    axis_offset_m: float = 0.0
    """Distance up the container axis from the logged point to the pendulum pivot."""
    smooth_s: float = SMOOTH_S
    """Savitzky-Golay window for the pose log's accelerations."""
    wave_share: float = 1.0
    """The wall's share of the first mode's wave, beyond the static surface: 2 / (xi^2 - 1) = 0.84 in linear theory for
    a cylinder; 1 reads the pendulum's plane."""
    drag: float = 0.0
    """Breaking drag (per rad, `pendulum.spherical_accel`): damping that grows with the wave's speed."""
    crest_coeff: float = 0.0
    """Second-order crest: the wave part grows by this times its own slope (Stokes: k a / 2 over the slope, 0.58)."""
    spherical: bool = True
    """One spherical pendulum (the physics-first structure); False: seed eq. 2's pendulum pair, uncoupled (the
    fixed-physics reference of issue 38)."""
    views_deg: float | None = None
    """Azimuth of the first of two views 90 deg apart that read the wall (`read_out`); None: the whole wall's peak."""
    stderr: tuple[tuple[str, float], ...] = ()
    """Standard errors of the fitted parameters (`FITTED_ERRORS`) for the band."""
    model_error: float = MODEL_ERROR_LOG_SD
    """The band's model-error term (log standard deviation of a peak), calibrated on held-out folds."""
    envelope: tuple[tuple[str, float], ...] = ()
    """The fitted runs' motion range (`pose.motion_range`): a move beyond it is an extrapolation."""
    fitted_on: tuple[Path, ...] = ()
    """The measurement files the model was identified from (identify JSON `sources`, as found from here): a validate
    run of one of them scores the fit, not a prediction."""
    fitted_sha256: tuple[str, ...] = ()
    """Their contents' hashes (identify JSON `source_sha256`): the same file wherever it is now, or a copy."""
    rest_tilt_x_deg: float = 0.0
    """The liquid at rest as the wall's reading sees it: tilted this far along the container's x axis (a container
    mounted off the logged axis, or a camera's level off); its own reading at rest is the zero."""
    rest_tilt_y_deg: float = 0.0
    """The same along the container's y axis."""
    view_arc_deg: float = 0.0
    """With `views_deg`: the half-width of the arc of wall each view's edge-on points stand for (`read_out`): 0 reads the
    four points alone, 45 or more the whole wall."""
    fill_height_m: float | None = None
    """The liquid's depth at rest: with the radius it sets where below the surface a turning container's liquid feels
    the turn (`depths_m`); None: at the pivot itself."""

    @property
    def depths_m(self) -> tuple[float, float]:
        """How far below the pivot the first mode's pendulum hangs and the faster modes' static surface takes its
        acceleration (`pendulum.rotation_depths`), (0, 0) without the radius and fill height."""
        if self.radius_m is None or self.fill_height_m is None:
            return (0.0, 0.0)
        return rotation_depths(self.radius_m, self.fill_height_m)

    @property
    def rest_slope(self) -> tuple[float, float]:
        """The surface's gradient at rest in the container frame (`rest_tilt_x_deg`, `rest_tilt_y_deg`)."""
        return rest_gradient(self.rest_tilt_x_deg, self.rest_tilt_y_deg)

    def fitted_to(self, source: str) -> bool:
        """The measurement file `source` is one the model was identified from (by its path or its content)."""
        path = Path(source)
        if not path.is_file():
            return False
        return path.resolve() in self.fitted_on or (
            bool(self.fitted_sha256) and file_sha256(path) in self.fitted_sha256
        )

    def __post_init__(self) -> None:
        if not (math.isfinite(self.wave_share) and self.wave_share > 0):
            raise UserError(f"the wave share must be a positive number, got {self.wave_share!r}.")
        if self.radius_m is not None and not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise UserError(f"the container radius must be a positive number of m, got {self.radius_m!r}.")
        if not math.isfinite(self.crest_coeff):
            raise UserError(f"the crest coefficient must be a number, got {self.crest_coeff!r}.")
        if not math.isfinite(self.axis_offset_m):
            raise UserError(f"the axis offset must be a number of m, got {self.axis_offset_m!r}.")
        if not all(abs(a) < 45 for a in (self.rest_tilt_x_deg, self.rest_tilt_y_deg)):
            raise UserError(
                f"the rest tilts must be numbers of deg below 45, got {self.rest_tilt_x_deg!r} and "
                f"{self.rest_tilt_y_deg!r}."
            )
        if self.fill_height_m is not None and not (math.isfinite(self.fill_height_m) and self.fill_height_m > 0):
            raise UserError(f"the fill height must be a positive number of m, got {self.fill_height_m!r}.")
        if not (math.isfinite(self.view_arc_deg) and self.view_arc_deg >= 0):
            raise UserError(f"the view's arc must be a number of deg, 0 or more, got {self.view_arc_deg!r}.")

    def with_geometry(
        self, radius_m: float | None = None, axis_offset_m: float | None = None, smooth_s: float | None = None
    ) -> LiquidModel:
        """The same model with the given geometry values replacing the stored ones (None keeps them)."""
        check_in_metres("container_radius_m", radius_m)
        check_axis_offset("axis_offset_m", axis_offset_m)
        return replace(
            self,
            radius_m=self.radius_m if radius_m is None else radius_m,
            axis_offset_m=self.axis_offset_m if axis_offset_m is None else axis_offset_m,
            smooth_s=self.smooth_s if smooth_s is None else smooth_s,
        )

    def reading(self, resp: PoseResponse, kind: str) -> np.ndarray:
        """What the sensor reads from the predicted surface: the wall height (mm) for kind 'wall_height_mm', else the
        surface's angle to the container (deg)."""
        return read_out(
            *wall_parts(resp),
            self.wave_share,
            self.crest_coeff,
            kind,
            self.radius_m,
            self.views_deg,
            self.rest_slope,
            self.view_arc_deg,
        )


def rest_gradient(tilt_x_deg: float, tilt_y_deg: float) -> tuple[float, float]:
    """The surface's gradient at rest in the container frame from its tilts along the container's x and y axes."""
    return math.tan(math.radians(tilt_x_deg)), math.tan(math.radians(tilt_y_deg))


def wall_parts(resp: PoseResponse) -> tuple[np.ndarray, np.ndarray]:
    """The static surface's gradient and the first mode's excess over it (the pendulum's gradient minus it), in the
    container frame (N, 2 each)."""
    assert resp.slope is not None and resp.static_slope is not None  # a response computed with its slopes
    return resp.static_slope, resp.slope - resp.static_slope


def read_out(
    static: np.ndarray,
    wave: np.ndarray,
    share: float,
    crest: float,
    kind: str,
    radius_m: float | None,
    views_deg: float | None = None,
    rest: tuple[float, float] = (0.0, 0.0),
    arc_deg: float = 0.0,
) -> np.ndarray:
    """|static + share x wave + rest| (1 + crest x share |wave|), less the same of the rest alone: the slope at the wall
    above its reading at rest, as a wall height R x it (mm) or an angle atan(it) (deg); the higher modes follow the
    motion (static), the first mode adds its wave, `rest` is the surface's gradient at rest in the container frame (a
    level the reading does not share: a wave smaller than it reads signed, at the mode's own frequency). With
    `views_deg` the wall is seen in two planes 90 deg apart, the first at that azimuth from the container's x axis (two
    cameras on the container, as in the shared runs): the highest point of the wall within `arc_deg` of the four
    points where the views see it edge-on (`view_size`; 0: the larger of the slope's components along them)."""
    part = share * wave
    total = static + part + np.asarray(rest)
    if views_deg is None:
        size, zero = np.linalg.norm(total, axis=1), math.hypot(*rest)
    else:
        size = view_size(total, views_deg, arc_deg)
        zero = float(view_size(np.atleast_2d(np.asarray(rest, float)), views_deg, arc_deg)[0])
    slope = size * (1.0 + crest * np.linalg.norm(part, axis=1)) - zero
    if kind == "wall_height_mm":
        if radius_m is None:
            raise ValueError("a wall height needs the container's radius")
        return 1000.0 * radius_m * slope
    return np.degrees(np.arctan(slope))


def view_size(slope: np.ndarray, views_deg: float, arc_deg: float) -> np.ndarray:
    """The highest point, per unit radius, of the plane of gradient `slope` (N, 2) on the arcs of the wall within
    `arc_deg` of the azimuths views_deg + k 90 deg: |slope| cos(the gradient's distance to the nearest arc), which for
    `arc_deg` 0 is the larger of its components along the two views and from 45 deg on is |slope|."""
    direction = np.arctan2(slope[:, 1], slope[:, 0]) - math.radians(views_deg)
    apart = np.abs(np.mod(direction + math.pi / 4, math.pi / 2) - math.pi / 4)  # to the nearest edge-on azimuth
    return np.linalg.norm(slope, axis=1) * np.cos(np.maximum(apart - math.radians(arc_deg), 0.0))


def load_model(path: str | Path) -> LiquidModel:
    """Read `sloshid identify` JSON: the mode, the wall's wave share and crest (identify --trajectory; 1 and 0 for a
    decay-only file), their errors, the motion range and any stored geometry; a file of another model structure is
    refused."""
    params = SloshParams.from_identify_json(path)
    data = json.loads(read_input(path, "parameter file", SMALL_FILE_BYTES))
    p, fit = data["parameters"], data.get("fit") if isinstance(data.get("fit"), dict) else {}
    old = [k for k in OLD_GAINS if k in p]
    structure = fit.get("structure")
    if old or (structure is not None and structure != STRUCTURE):
        what = ", ".join(old) if old else f"'{structure}'"
        raise SettingError(  # named by each front-end: `sloshid identify RUN.mat --trajectory RUN.csv`
            "params",
            f"parameter file {path} comes from a liquid model of another structure ({what}), whose parameters mean "
            "something else here; identify the runs again against their trajectories (`sloshid identify RUN.mat "
            "{trajectory} RUN.csv`).",
            "trajectory",
        )
    try:
        share = float(p.get("wave_share", {}).get("value", 1.0))
        crest = float(p.get("crest_coeff", {}).get("value", 0.0))
        drag = float(p.get("drag", {}).get("value", 0.0))
        stderr = tuple((k, float(p[k]["stderr"])) for k in FITTED_ERRORS if "stderr" in p.get(k, {}))
        envelope = tuple((k, float(v)) for k, v in (fit.get("motion_range") or {}).items())
        model_error = float(fit.get("model_error_log_sd", MODEL_ERROR_LOG_SD))
        geometry = data.get("geometry") or {}
        radius = geometry.get("container_radius_m") or (data.get("prior") or {}).get("container_radius_m")
        radius = None if radius is None else float(radius)
        offset, smooth = float(geometry.get("axis_offset_m", 0.0)), float(geometry.get("smooth_s", SMOOTH_S))
        views = geometry.get("views_deg")
        views = None if views is None else float(views)
        fill = geometry.get("fill_height_m")
        fill = None if fill is None else float(fill)
        tilts = [float(p.get(k, {}).get("value", 0.0)) for k in REST_TILTS]
        arc = float(p.get("view_arc_deg", {}).get("value", 0.0))
    except (AttributeError, TypeError, ValueError):
        raise UserError(
            f"parameter file {path}: the wave share, the crest coefficient, a rest tilt, the view's arc, an error, the "
            "motion range or the geometry is not a number."
        ) from None
    sources = data.get("sources") if isinstance(data.get("sources"), list) else []
    fitted = tuple(f for src in sources if isinstance(src, str) for f in [_found(src, Path(path).parent)] if f)
    hashes = data.get("source_sha256") if isinstance(data.get("source_sha256"), list) else []
    digests = tuple(h for h in hashes if isinstance(h, str))
    return LiquidModel(
        params,
        radius,
        offset,
        smooth,
        share,
        drag,
        crest,
        True,
        views,
        stderr,
        model_error,
        envelope,
        fitted,
        digests,
        rest_tilt_x_deg=tilts[0],
        rest_tilt_y_deg=tilts[1],
        view_arc_deg=arc,
        fill_height_m=fill,
    )


REST_TILTS = ("rest_tilt_x_deg", "rest_tilt_y_deg")
"""The wall reading's level at rest, per container axis (`LiquidModel.rest_tilt_x_deg`)."""
READING = ("wave_share", "crest_coeff", *REST_TILTS, "view_arc_deg")
"""The parameters of the wall's reading alone (a step of one of them simulates nothing)."""
FITTED_ERRORS = ("f_hz", "zeta", "drag", *READING)
"""Parameters whose standard errors widen the band."""


def _found(source: str, beside: Path) -> Path | None:
    """The file an identify JSON's source names, resolved: as written (from the working directory), else beside the
    JSON; None when it is not there (an array, or a file moved away)."""
    for candidate in (Path(source), beside / source):
        if candidate.is_file():
            return candidate.resolve()
    return None


def is_input_output(model: LiquidModel) -> bool:
    """A model from `identify --trajectory` (a wall reading besides the pendulum), which plan and compare use only in
    part."""
    return not (model.wave_share == 1 and model.crest_coeff == 0 and model.rest_slope == (0.0, 0.0))


def whole_model_peak_deg(path: str | Path, plan: Trajectory, trajectory: str = "TRAJ.csv") -> float | None:
    """How far (deg, against the container) the whole input-output model at `path` moves the liquid in the planned
    trajectory `plan` (written as `trajectory`); None for a plain model, whose plan the planner's check covers."""
    model = load_model(path)
    if not is_input_output(model):
        return None
    pose = pose_from_trajectory(plan, trajectory)
    return float(predict(pose, pivot_for(pose, model, None)[0]).rel_angle_deg.max())


def planning_note(path: str | Path, trajectory: str = "TRAJ.csv", peak_deg: float | None = None) -> str | None:
    """For `plan` and `compare` with a model from `identify --trajectory`: they plan and score with its f and zeta
    alone, as a pendulum; the sentence says so, how far the whole model moves the liquid in the plan (`peak_deg`, from
    `whole_model_peak_deg`, when given) and how to check a plan with it (None for a plain model); a front-end adds its
    own command for that check."""
    model = load_model(path)
    if not is_input_output(model):
        return None
    moved = "the liquid moves during a plan"
    if peak_deg is not None:
        moved = f"this plan moves the liquid by up to {peak_deg:.2g} deg against the container"
    return (
        f"{path} is an input-output model (wave share {model.wave_share:.3g}, crest coefficient "
        f"{model.crest_coeff:.3g}); plans and scores use its f and zeta alone, as a pendulum pair, so by the whole "
        f"model {moved}: check a plan by predicting the liquid's response to {trajectory} with {path}."
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
        "applied; give `axis_offset_m` to apply one."
    )
    return model.with_geometry(axis_offset_m=0.0), note


def predict(
    pose: PoseLog, model: LiquidModel, settle_s: float = PredictSettings.settle_s, rtol: float = 1e-9
) -> PoseResponse:
    """The liquid's response to the logged motion, held at the last pose for settle_s after the log ends; a log
    sampled too slowly for the liquid's mode (a time column in milliseconds) is refused."""
    return forecast(pose, model, settle_s, rtol, band=False).resp


Z95 = 1.96
EXTRAPOLATION_MARGIN = 1.1
"""A move whose quantity exceeds the fitted runs' largest by more than 10 % is an extrapolation (the runs' own
spread of a quantity within one kind is about that)."""


@dataclass
class Forecast:
    """A prediction with what its 95 % band needs: the central response, the responses with each fitted parameter one
    standard error off, the extrapolation notes and the model-error term (widened by them)."""

    resp: PoseResponse
    model: LiquidModel
    steps: list[tuple[PoseResponse, LiquidModel]]
    notes: list[str]
    log_sd: float

    def band(self, column) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) of `column(resp, model)`: the model error as a factor exp(+-1.96 log_sd) on its size, plus 1.96
        times the parameters' spread (their one-sigma steps added in quadrature)."""
        centre = column(self.resp, self.model)
        spread = np.sqrt(sum((column(r, m) - centre) ** 2 for r, m in self.steps)) if self.steps else 0.0
        size = np.abs(centre)
        up, down = size * (math.exp(Z95 * self.log_sd) - 1) + Z95 * spread, size * (1 - math.exp(-Z95 * self.log_sd))
        down = down + Z95 * spread
        lo, hi = np.where(centre >= 0, centre - down, centre - up), np.where(centre >= 0, centre + up, centre + down)
        if np.all(centre >= 0):  # a magnitude stays one
            lo = np.maximum(lo, 0.0)
        return lo, hi


UNITS = {
    "vertical_accel_m_s2": "m/s2",
    "horizontal_accel_m_s2": "m/s2",
    "speed_m_s": "m/s",
    "tilt_deg": "deg",
    "yaw_rate_deg_s": "deg/s",
}
MAX_WIDENING = 5.0
"""The model error is widened at most this many times: a move far beyond the fitted ones is flagged either way."""


def extrapolation(exc: Excitation, model: LiquidModel, source: str) -> tuple[list[str], float]:
    """One line per motion quantity beyond the fitted runs' range (EXTRAPOLATION_MARGIN), and the factor that widens
    the model error: the largest ratio of the move's quantity to the fitted range (1 inside it, at most MAX_WIDENING)."""
    if not model.envelope:
        return [], 1.0
    fitted, move = dict(model.envelope), motion_range(exc)
    notes, factor = [], 1.0
    for key, words in MOTION_QUANTITIES.items():
        limit = max(fitted.get(key, math.inf), 1e-9)
        if move[key] <= EXTRAPOLATION_MARGIN * limit:
            continue
        ratio = min(move[key] / limit, MAX_WIDENING)
        factor = max(factor, ratio)
        notes.append(
            f"{source}: its {words} reaches {move[key]:.3g} {UNITS[key]}, beyond the {limit:.3g} of the runs the model "
            f"was fitted on: an extrapolation, its band widened {ratio:.2g} times."
        )
    return notes, factor


def forecast(
    pose: PoseLog, model: LiquidModel, settle_s: float = PredictSettings.settle_s, rtol: float = 1e-9, band: bool = True
) -> Forecast:
    """Predict the move and, with `band`, what its band needs (one simulation more for f and for zeta when they carry
    an error; the wall's parameters need none); a log sampled too slowly for the mode is refused."""
    f_hz = model.params.f_hz
    check_sampling(pose.source, 1.0 / float(np.median(np.diff(pose.t_s))), (f_hz, f_hz))
    exc = excitation(pose, model.axis_offset_m, model.smooth_s)

    def run(params: SloshParams, drag: float = model.drag) -> PoseResponse:
        return respond(
            exc,
            params,
            settle_s=settle_s,
            rtol=rtol,
            atol=rtol * 1e-3,
            spherical=model.spherical,
            drag=drag,
            depths_m=model.depths_m,
        )

    resp = run(model.params)
    if not band:
        return Forecast(resp, model, [], [], model.model_error)
    se, p, steps = dict(model.stderr), model.params, []
    if se.get("f_hz", 0) > 0:
        steps.append((run(p.scaled(omega_factor=1 + se["f_hz"] / p.f_hz)), model))
    if se.get("zeta", 0) > 0 and p.zeta > 0:
        steps.append((run(p.scaled(zeta_factor=1 + se["zeta"] / p.zeta)), model))
    if se.get("drag", 0) > 0:
        steps.append((run(p, model.drag + se["drag"]), model))
    for name in READING:
        if se.get(name, 0) > 0:
            steps.append((resp, replace(model, **{name: getattr(model, name) + se[name]})))
    notes, factor = extrapolation(exc, model, pose.source)
    return Forecast(resp, model, steps, notes, model.model_error * factor)


ANGLES = {
    "liquid_phi_deg": lambda r, m: np.degrees(r.liquid_rad[:, 0]),
    "liquid_theta_deg": lambda r, m: np.degrees(r.liquid_rad[:, 1]),
    "rel_roll_deg": lambda r, m: np.degrees(r.rel_rad[:, 0]),
    "rel_pitch_deg": lambda r, m: np.degrees(r.rel_rad[:, 1]),
    "rel_angle_deg": lambda r, m: r.rel_angle_deg,
}
"""The predicted angles (CSV column: value from a response and model)."""


def wall_height(resp: PoseResponse, model: LiquidModel) -> np.ndarray:
    """The model's wall-height reading (mm)."""
    return model.reading(resp, "wall_height_mm")


def prediction_columns(fc: Forecast) -> dict[str, np.ndarray]:
    """The `sloshid predict` CSV columns (SI, angles in degrees), each angle and the wall height (the model's reading)
    with its 95 % band (`_lo`, `_hi`)."""
    resp, model = fc.resp, fc.model
    cols = {
        "t_s": resp.t_s,
        "ax_m_s2": resp.acc_m_s2[:, 0],
        "ay_m_s2": resp.acc_m_s2[:, 1],
        "az_m_s2": resp.acc_m_s2[:, 2],
    }
    columns = dict(ANGLES)
    if model.radius_m is not None:
        columns["wall_height_mm"] = wall_height
    for name, column in columns.items():
        lo, hi = fc.band(column)
        stem = name.removesuffix("_deg").removesuffix("_mm")
        unit = name[len(stem) :]
        cols.update({name: column(resp, model), f"{stem}_lo{unit}": lo, f"{stem}_hi{unit}": hi})
    return cols


def write_prediction(path: str | Path, fc: Forecast) -> None:
    """Write the prediction CSV atomically."""
    write_csv(path, prediction_columns(fc))
