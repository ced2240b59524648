"""Build every method for one move and liquid, score them identically, and draw the verdict from the numbers.

Methods (keys in `METHODS`): the constant-acceleration profile, ZV and ZVD shaped, ruckig jerk-limited upright
and tilt-compensated, sloshid's plan and its robust variant, and camera feedback on top of the
constant-acceleration profile and of sloshid's plan. A method that cannot be built for the scenario is a
'not applicable' row with its reason. Scoring is the nonlinear pendulum (`simulate_liquids`, every method in one
batch).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from tqdm import tqdm

from sloshid.comparison.feedback import FeedbackSettings
from sloshid.comparison.profiles import MoveTask, NotApplicable, constant_acceleration
from sloshid.comparison.recommend import Recommendation, SlowedRow, recommend, slowed_row, write_move
from sloshid.comparison.robot_tracking import ClosedLoopResponse, closed_loop_responses
from sloshid.comparison.robustness import Replay, RobustnessResult, replay_responses, sweep
from sloshid.comparison.ruckig_moves import jerk_limited
from sloshid.comparison.shapers import shaped_constant_acceleration
from sloshid.core.errors import UserError
from sloshid.core.settings import setting_field
from sloshid.core.tables import to_pandas
from sloshid.model.pendulum import SloshParams
from sloshid.model.simulate import MAX_SETTLE_S, LiquidResponse, simulate_liquid, simulate_liquids
from sloshid.model.trajectory import RobotLimits, Trajectory, check_limits, check_move_limits, tilt_profiles
from sloshid.planning.path import PathGeometry
from sloshid.planning.planner import check_feasible
from sloshid.planning.scenario import Obstacle, Scenario, Vec3, body_clearance, check_robust_factors

if TYPE_CHECKING:
    from sloshid.planning.arm import ArmFit, ArmObjection
    from sloshid.planning.arm_settings import ArmSettings
    from sloshid.planning.result import PlanResult

METHODS: dict[str, str] = {
    "constant_acc": "constant acceleration",
    "zv": "ZV shaped",
    "zvd": "ZVD shaped",
    "ruckig": "jerk-limited (ruckig)",
    "ruckig_tilt": "jerk-limited (ruckig) + tilt",
    "sloshid": "sloshid plan",
    "sloshid_robust": "sloshid robust plan",
    "constant_acc_feedback": "constant acceleration + feedback",
    "sloshid_feedback": "sloshid plan + feedback",
    "toppra": "TOPP-RA",
    "toppra_tilt": "TOPP-RA + tilt",
    "toppra_zvd": "TOPP-RA + ZVD",
}
"""Method key -> label shown in tables and legends."""

PATH_METHODS = ["toppra", "toppra_tilt", "toppra_zvd", "sloshid"]
"""Default methods of a [path] scenario: those that can follow a prescribed path."""
FREE_METHODS = [k for k in METHODS if k not in PATH_METHODS or k == "sloshid"]
"""Default methods of a [move] scenario."""
_STRAIGHT = ("constant_acc", "zv", "zvd", "ruckig", "ruckig_tilt")


@dataclass(frozen=True)
class CompareSettings:
    """The [compare] table of a scenario: which methods, their tuning, and the studies around them."""

    methods: list[str] = field(default_factory=lambda: list(FREE_METHODS))
    """Method keys to build, in table order (see sloshid.comparison.compare.METHODS); a [path] scenario's default
    is PATH_METHODS."""
    jerk_max_m_s3: float | None = setting_field(None, unit="m/s^3")
    """Jerk limit of the ruckig methods, m/s^3; default acc_max * f (the jerk ramp lasts one slosh period)."""
    robot_bandwidth_hz: float = setting_field(20.0, unit="Hz")
    """Bandwidth of the robot's Cartesian tracking in the closed-loop study, Hz."""
    settle_s: float = setting_field(3.0, unit="s")
    """Time simulated after arrival to measure the residual slosh, s."""
    residual_ok_deg: float = setting_field(0.5, unit="deg")
    """Residual relative angle at or below which a move counts as slosh-free, degrees."""
    peak_ok_deg: float = setting_field(1.0, unit="deg")
    """Peak relative angle during the move at or below which it counts as slosh-free, degrees. One degree tilts the
    surface against the wall by R tan(1 deg), under 1 mm in a 40 mm container, so nothing spills at any practical
    freeboard; it still excludes moves that only postpone the slosh (unshaped and input-shaped moves tilt the surface
    by about a/g, 3 deg at 0.5 m/s^2)."""
    frequency_margin: float = 0.05
    """Relative margin added on both sides of the identified 95 % frequency interval (or of the nominal frequency
    when none is known) to form the band the recommendation must hold over."""
    omega_factors: list[float] = field(default_factory=lambda: [0.8, 0.85, 0.9, 0.95, 1.0, 1.05, 1.1, 1.15, 1.2])
    """True/identified natural-frequency ratios of the robustness sweep."""
    zeta_factors: list[float] = field(default_factory=lambda: [0.5, 1.0, 2.0])
    """True/identified damping-ratio ratios of the robustness sweep."""
    robust_omega_factors: list[float] = field(default_factory=lambda: [0.9, 1.0, 1.1])
    """Frequency ratios that sloshid's robust plan must all bring to rest."""
    camera_fps_sweep: list[float] = setting_field(default_factory=lambda: [15.0, 30.0, 60.0, 120.0], unit="frames/s")
    """Camera frame rates of the feedback study, frames per second."""
    camera_omega_factor: float = 0.9
    """True/identified frequency ratio at which the camera-rate study runs (feedback matters under model error)."""
    linearity_acc_m_s2: list[float] = setting_field(default_factory=lambda: [0.25, 0.5, 1.0, 2.0, 4.0], unit="m/s^2")
    """Accelerations of the constant-acceleration move in the linear-vs-nonlinear study, m/s^2."""
    feedback: FeedbackSettings = field(default_factory=FeedbackSettings)
    """Camera and LQR of the feedback methods ([compare.feedback])."""
    workers: int = 2
    """Processes for the robustness sweep (1: run in this process)."""

    def __post_init__(self) -> None:
        from sloshid.core.settings import did_you_mean

        for key in self.methods:
            if key not in METHODS:
                raise UserError(f"[compare].methods has unknown method '{key}'{did_you_mean(key, METHODS)}.")
        if not self.methods:
            raise UserError("[compare].methods is empty; name at least one method.")
        twice = sorted({m for m in self.methods if self.methods.count(m) > 1})
        if twice:
            raise UserError(f"[compare].methods names '{twice[0]}' more than once; each method is scored once.")
        positive = ("robot_bandwidth_hz", "settle_s", "residual_ok_deg", "peak_ok_deg", "camera_omega_factor")
        for name in positive:
            if not getattr(self, name) > 0:
                raise UserError(f"[compare].{name} must be positive, got {getattr(self, name)!r}.")
        if not self.settle_s <= MAX_SETTLE_S:
            raise UserError(f"[compare].settle_s must be at most {MAX_SETTLE_S:g} s, got {self.settle_s!r}.")
        if not 0 <= self.frequency_margin < 1:
            raise UserError(f"[compare].frequency_margin must lie in [0, 1), got {self.frequency_margin!r}.")
        if self.jerk_max_m_s3 is not None and not self.jerk_max_m_s3 > 0:
            raise UserError(f"[compare].jerk_max_m_s3 must be positive, got {self.jerk_max_m_s3!r}.")
        if not 1 <= self.workers <= 64:
            raise UserError(f"[compare].workers must lie between 1 and 64, got {self.workers!r}.")
        lists = ("omega_factors", "zeta_factors", "robust_omega_factors", "camera_fps_sweep", "linearity_acc_m_s2")
        for name in lists:
            values = getattr(self, name)
            if not values or not all(math.isfinite(v) and v > 0 for v in values):
                raise UserError(f"[compare].{name} must be a non-empty list of positive numbers, got {values!r}.")
            if len(values) > MAX_STUDY_POINTS:
                raise UserError(
                    f"[compare].{name} holds {len(values)} values; at most {MAX_STUDY_POINTS} (each is a simulation of "
                    "every method)."
                )
        check_robust_factors(self.robust_omega_factors, "[compare].robust_omega_factors")


MAX_STUDY_POINTS = 201
"""Most values a [compare] study list may hold: a frequency sweep at half-percent steps over +-50 %; 10,001 ran for
long without a word."""


@dataclass
class Score:
    """How one method does on the liquid's relative angle (what spills) and on the limits."""

    transfer_time_s: float
    """From the start of the move to arrival (feedback methods: until settled on the goal)."""
    peak_during_deg: float
    """Largest relative angle liquid - container while moving."""
    residual_deg: float
    """Largest relative angle after arrival."""
    peak_tilt_deg: float
    """Largest tilt of the container from upright."""
    peak_tilt_rate_deg_s: float
    """Largest angular speed of the container."""
    robot_limits_ok: bool
    """Franka (or [robot]) Cartesian limits hold on every sample."""
    limits_failed: list[str]
    """Robot or move limits that do not hold, e.g. 'robot rot_acc_rad_s2 87.4 > 25'."""
    move_limits_ok: bool
    """The scenario's own acceleration, velocity, jerk, tilt and tilt-rate limits hold."""
    min_clearance_m: float | None = None
    """Smallest distance to an inflated obstacle (negative: collides); None without obstacles."""
    max_path_deviation_m: float | None = None
    """[path] scenarios: largest distance from the prescribed path (m); None for free moves."""


@dataclass
class MethodResult:
    """One row of the comparison: the trajectory it built and its score, or why it is not applicable."""

    key: str
    label: str
    trajectory: Trajectory | None = None
    response: LiquidResponse | None = None
    score: Score | None = None
    reason: str = ""
    """Why the method is not applicable (empty when it is)."""
    build_time_s: float = 0.0
    """Time to compute the trajectory (planner solve time for sloshid's methods), s."""
    replay: Replay | None = None
    """What it executes when the true liquid differs (robustness sweep)."""
    plan: PlanResult | None = None
    """sloshid's planner methods: the plan behind the trajectory (re-planned slower when an arm cannot follow it)."""

    @property
    def applicable(self) -> bool:
        """True when the method produced a trajectory."""
        return self.trajectory is not None

    def require_trajectory(self) -> Trajectory:
        """The trajectory of an applicable method; ValueError for one that is not applicable."""
        if self.trajectory is None:
            raise ValueError(f"{self.label} is not applicable ({self.reason}): it has no trajectory")
        return self.trajectory

    def require_score(self) -> Score:
        """The score of an applicable method once scored; ValueError before."""
        if self.score is None:
            raise ValueError(f"{self.label} has not been scored")
        return self.score

    def require_response(self) -> LiquidResponse:
        """The liquid's simulated response to an applicable method once scored; ValueError before."""
        if self.response is None:
            raise ValueError(f"{self.label} has not been simulated")
        return self.response

    def require_replay(self) -> Replay:
        """What an applicable method executes against a true liquid; ValueError for one that is not applicable."""
        if self.replay is None:
            raise ValueError(f"{self.label} is not applicable ({self.reason}): it has nothing to replay")
        return self.replay


@dataclass
class MoveLimits:
    """The scenario limits a method is held to (tilt limits only when the scenario has them)."""

    task: MoveTask
    tilt_max_deg: float = 90.0
    tilt_rate_max_deg_s: float = math.inf
    robot: RobotLimits = field(default_factory=RobotLimits)
    obstacles: list[Obstacle] = field(default_factory=list)
    """The scenario's obstacles (their `clearance(points, inflate_m)` is scored)."""
    container_radius_m: float = 0.0
    container_depth_m: float = 0.0
    """How far the container's body reaches below the point the move carries (sloshid.planning.scenario.body_clearance)."""
    path: PathGeometry | None = None
    """The prescribed curve of a [path] scenario (deviations are scored against it), else None."""
    jerk_max_m_s3: tuple[float, float, float] | None = None
    """Per-axis jerk limit of the move ([limits].jerk_max with the jerk-limited formulation), else None."""


def score(
    traj: Trajectory, params: SloshParams, limits: MoveLimits, settle_s: float, resp: LiquidResponse | None = None
) -> tuple[Score, LiquidResponse]:
    """Score a trajectory: nonlinear slosh relative to the container (`resp`, simulated here when not given), tilt,
    robot and move limits, clearance."""
    resp = resp or simulate_liquid(traj, params, settle_s=settle_s)
    tilt, rate = tilt_profiles(traj)
    failed = [f"robot {u.quantity} {u.peak:.3g} > {u.limit:.3g}" for u in check_limits(traj, limits.robot) if not u.ok]
    robot_ok = not failed
    move = check_move_limits(
        traj,
        limits.task.acc_max_m_s2,
        limits.task.vel_max_m_s,
        limits.tilt_max_deg,
        limits.tilt_rate_max_deg_s,
        limits.jerk_max_m_s3,
    )
    failed += [f"move {u.quantity} {u.peak:.3g} > {u.limit:.3g}" for u in move if not u.ok]
    clearance = None
    if limits.obstacles:
        R, depth = limits.container_radius_m, limits.container_depth_m
        clearance = float(body_clearance(limits.obstacles, traj.pos_m, R, depth, traj.z_axis).min())
    deviation = float(limits.path.deviation(traj.pos_m).max()) if limits.path is not None else None
    sc = Score(
        traj.duration_s,
        resp.peak_during_deg,
        resp.residual_deg,
        float(tilt.max()),
        float(rate.max()),
        robot_ok,
        failed,
        not any(f.startswith("move") for f in failed),
        clearance,
        deviation,
    )
    return sc, resp


@dataclass
class CompareInput:
    """Everything the builders need: the move, the identified liquid, settings, and the scenario for the planner."""

    limits: MoveLimits
    params: SloshParams
    settings: CompareSettings
    scenario: Scenario | None = None
    """The scenario, for the planner methods (None: those are not applicable)."""
    f_interval_hz: tuple[float, float] | None = None
    """The identified 95 % interval of the natural frequency (None: only the nominal value is known)."""
    plan: PlanResult | None = None
    """An existing nominal PlanResult of this scenario and liquid, reused instead of solving again."""

    @property
    def jerk_max_m_s3(self) -> float:
        """Jerk limit of the ruckig methods: configured, or the largest axis acc_max times the slosh frequency, at
        most the move's own jerk limit."""
        s = self.settings.jerk_max_m_s3
        if s is not None:
            return s
        own = min(self.limits.jerk_max_m_s3) if self.limits.jerk_max_m_s3 is not None else math.inf
        return min(max(self.limits.task.acc_max_m_s2) * self.params.f_hz, own)


def compare_scenario(
    scenario: Scenario,
    params: SloshParams,
    plan: PlanResult | None = None,
    f_interval_hz: tuple[float, float] | None = None,
    progress: bool = False,
) -> Comparison:
    """The comparison stage in one call (CLI, pipeline and `sloshid.compare`): every method of the scenario's
    [compare] table for this liquid, reusing `plan` (a PlanResult of the same scenario and liquid) when given;
    `f_interval_hz`, the identified 95 % interval of f, sets the band the recommendation must hold over."""
    if plan is not None and plan.params != params:
        raise UserError("the plan given to compare was made for another liquid; plan again or drop it.")
    if plan is not None and plan.scenario is not None and _move(plan.scenario) != _move(scenario):
        raise UserError(
            f"the plan given to compare was made for another move ({plan.scenario.source or 'another scenario'}: its "
            "waypoints, path, limits, obstacles or container differ); plan this scenario or drop the plan."
        )
    check_feasible(scenario)  # the same refusals as `plan` (start inside an obstacle, ...) before any work
    return compare(replace(from_scenario(scenario, params, f_interval_hz), plan=plan), progress=progress)


def _move(scenario: Scenario) -> tuple:
    """What makes a scenario's move: a plan of another one must not be scored as this one's."""
    return (
        scenario.waypoints,
        scenario.limits,
        scenario.obstacles,
        scenario.path_table,
        scenario.container_radius_m,
        scenario.container_depth_m,
    )


def compare_settings(scenario: Scenario) -> CompareSettings:
    """The scenario's [compare] table, validated (UserError naming the key); a [path] scenario's default methods are
    the path methods."""
    from sloshid.core.settings import from_dict

    settings = from_dict(CompareSettings, scenario.compare, "[compare]")
    if getattr(scenario, "path", None) is not None and "methods" not in scenario.compare:
        settings = replace(settings, methods=list(PATH_METHODS))
    return settings


def from_scenario(
    scenario: Scenario, params: SloshParams, f_interval_hz: tuple[float, float] | None = None
) -> CompareInput:
    """The comparison's input from a loaded sloshid.planning.scenario.Scenario (and the identified frequency
    interval when the liquid was identified); the [compare] table is validated here."""
    settings = compare_settings(scenario)
    lim = scenario.limits
    waypoints = tuple(_triple(map(float, p)) for p in scenario.waypoints)
    task = MoveTask(waypoints, _triple(lim.acc_max), _triple(lim.vel_max))
    limits = MoveLimits(
        task,
        lim.tilt_max_deg,
        lim.tilt_rate_max_deg_s,
        scenario.robot,
        list(scenario.obstacles),
        scenario.container_radius_m,
        scenario.container_depth_m,
        getattr(scenario, "path", None),
        scenario.move_jerk_max,
    )
    return CompareInput(limits, params, settings, scenario, f_interval_hz)


def _triple(values: Iterable[float]) -> Vec3:
    """One of the scenario's 3-vectors (Vec3) as a tuple; tuple() keeps its three numbers three, which mypy cannot
    tell."""
    return cast("Vec3", tuple(values))


def _path_only(key: str, inp: CompareInput) -> None:
    """Raise NotApplicable when a method cannot follow the scenario's [path], or needs one that is not there."""
    path = inp.limits.path
    if key.startswith("toppra") and path is None:
        raise NotApplicable("needs a [path] scenario (a prescribed path to parameterise).")
    if path is None:
        return
    if key in _STRAIGHT:
        raise NotApplicable("goes straight between waypoints and stops at each: it cannot follow the [path].")
    if key == "sloshid_robust":
        raise NotApplicable("the path planner has no robust variant.")
    if key.endswith("_feedback"):
        raise NotApplicable("camera feedback corrects the acceleration and would leave the [path].")


def robust_scenario(scenario: Scenario) -> Scenario:
    """The scenario whose plan is compare's 'sloshid robust plan' (`sloshid plan --robust`, `sloshid.plan(...,
    robust=True)`): [solver].robust_omega_factors set to its [compare].robust_omega_factors (default 0.9, 1.0, 1.1:
    the liquid at -10 %, 0 and +10 % of its frequency must all end at rest); UserError for a [path] scenario."""
    if getattr(scenario, "path", None) is not None:
        raise UserError("the path planner has no robust variant; plan a [path] scenario without it.")
    factors = list(compare_settings(scenario).robust_omega_factors)
    return replace(scenario, solver=replace(scenario.solver, robust_omega_factors=factors))


def _copies(factors: Iterable[float]) -> tuple[float, ...]:
    """The extra pendulum copies a plan with these factors holds (1.0 is the nominal one, always there)."""
    return tuple(float(f) for f in factors if abs(f - 1.0) > 1e-9)


def planned_scenario(scenario: Scenario, robust: bool) -> Scenario:
    """The scenario that sloshid's plan (robust or nominal: no copies, whatever [solver] lists) is solved for, and
    re-planned for when an arm cannot follow it."""
    if robust:
        return robust_scenario(scenario)
    return replace(scenario, solver=replace(scenario.solver, robust_omega_factors=[]))


def sloshid_plan(inp: CompareInput, robust: bool) -> PlanResult:
    """sloshid's plan (issue 4's planner) for the scenario, nominal or robust, reusing the given plan when it is that
    variant."""
    if inp.scenario is None:
        raise NotApplicable("needs a scenario file for the planner.")
    try:
        from sloshid.planning.planner import plan
        from sloshid.planning.result import PlanResult
    except ImportError as exc:
        raise NotApplicable(f"the planner is not available ({exc}).") from None
    wanted = _copies(inp.settings.robust_omega_factors) if robust else ()
    if inp.plan is not None and _copies(inp.plan.robust_omega_factors) == wanted:
        return inp.plan
    try:
        result = plan(planned_scenario(inp.scenario, robust), inp.params)
    except UserError as exc:
        raise NotApplicable(f"the planner could not solve this scenario: {exc}") from None
    assert isinstance(result, PlanResult)  # a move within a spill margin is compared by upright_compare
    return result


def arm_follower(inp: CompareInput) -> Callable[[MethodResult], ArmFit] | None:
    """How the scenario's [robot] arm follows a method's move (`planning.arm.fit_arm`: sloshid's plans re-planned
    slower where the arm cannot follow them); None without an arm, or with [robot] fit_joints = false."""
    scenario = inp.scenario
    if scenario is None or scenario.arm is None or not scenario.arm.fits_sent_moves:
        return None
    from sloshid.planning.arm import fit_arm

    def follow(r: MethodResult) -> ArmFit:
        planned = planned_scenario(scenario, r.key == "sloshid_robust")
        return fit_arm(r.require_replay().trajectory, planned, inp.params, r.plan)

    return follow


def with_feedback(inp: CompareInput, base: Trajectory, fb: FeedbackSettings | None = None) -> Replay:
    """Closed-loop replay: the feedback loop around `base`, re-run against the given true liquid."""
    return Replay(base, inp.params, fb or inp.settings.feedback, inp.settings.robot_bandwidth_hz)


def build_method(key: str, inp: CompareInput, built: dict[str, MethodResult]) -> MethodResult:
    """Build and score one method (feedback methods reuse their base's trajectory from `built`); never raises
    NotApplicable."""
    res = build_trajectory(key, inp, built)
    if res.applicable:
        res.score, res.response = score(res.require_trajectory(), inp.params, inp.limits, inp.settings.settle_s)
    return res


def build_trajectory(key: str, inp: CompareInput, built: dict[str, MethodResult]) -> MethodResult:
    """Build one method's trajectory, unscored (feedback methods reuse their base's trajectory from `built`); never
    raises NotApplicable."""
    res = MethodResult(key, METHODS[key])
    task = inp.limits.task
    t0 = time.perf_counter()
    try:
        _path_only(key, inp)
        if key in ("toppra", "toppra_tilt"):
            from sloshid.comparison.toppra_moves import toppra_move

            lim = inp.limits
            traj = toppra_move(lim.path, task.vel_max_m_s, task.acc_max_m_s2, lim.robot, tilt=key == "toppra_tilt")
        elif key == "toppra_zvd":
            from sloshid.comparison.toppra_moves import toppra_shaped

            lim = inp.limits
            traj = toppra_shaped(lim.path, task.vel_max_m_s, task.acc_max_m_s2, lim.robot, inp.params)
        elif key == "constant_acc":
            traj = constant_acceleration(task)
        elif key in ("zv", "zvd"):
            traj = shaped_constant_acceleration(task, inp.params, "ZV" if key == "zv" else "ZVD")
        elif key in ("ruckig", "ruckig_tilt"):
            traj = jerk_limited(task, inp.jerk_max_m_s3, tilt=key == "ruckig_tilt")
        elif key in ("sloshid", "sloshid_robust"):
            res.plan = sloshid_plan(inp, robust=key == "sloshid_robust")
            traj, res.build_time_s = res.plan.trajectory, float(res.plan.solve_time_s)
        else:
            base_key = key.removesuffix("_feedback")
            base = built.get(base_key)
            if base is None or not base.applicable:
                base = build_trajectory(base_key, inp, built)
            if not base.applicable:
                raise NotApplicable(f"its feedforward '{base.label}' is not applicable.")
            res.replay = with_feedback(inp, base.require_trajectory())
            traj = res.replay(inp.params)
    except NotApplicable as exc:
        res.reason = str(exc)
        return res
    if not res.build_time_s:
        res.build_time_s = time.perf_counter() - t0
    traj.name = res.label
    res.trajectory = traj
    res.replay = res.replay or Replay(traj)
    return res


@dataclass
class CameraPoint:
    """Feedback at one camera rate, under the camera study's model error."""

    base: str
    camera_fps: float
    transfer_time_s: float
    peak_during_deg: float
    residual_deg: float
    seen_peak_deg: float
    """Seed Remark 1: the feedforward's peak relative angle (nominal liquid, no feedback) as frames at this rate
    see it, averaged over the frame clock's phase."""
    true_peak_deg: float
    """The same peak at 1 kHz (the feedforward's peak_during_deg)."""


@dataclass
class LinearityPoint:
    """Peak relative angle of the constant-acceleration move, linear (python-control) vs nonlinear pendulum."""

    acc_m_s2: float
    peak_linear_deg: float
    peak_nonlinear_deg: float
    max_gap_deg: float


@dataclass(kw_only=True)
class Comparison:
    """All methods scored on one move, with the closed-loop, robustness, camera-rate and linearity studies."""

    params: SloshParams
    settings: CompareSettings
    results: list[MethodResult]
    closed_loop: dict[str, ClosedLoopResponse]
    robustness: RobustnessResult
    camera: list[CameraPoint]
    no_feedback_at_camera_error: dict[str, float]
    """Residual (deg) of each feedback base without feedback at the camera study's model error."""
    linearity: list[LinearityPoint]
    recommendation: Recommendation | None = None
    """The fastest method slosh-free over the known frequency band (the headline)."""
    verdict: str = ""

    def result(self, key: str) -> MethodResult | None:
        """The row of method `key`, if it was requested."""
        return next((r for r in self.results if r.key == key), None)

    @property
    def recommended(self) -> MethodResult | None:
        """The recommended method's row (None when no method qualifies)."""
        rec = self.recommendation
        return self.result(rec.method) if rec is not None and rec.method else None

    def recommended_trajectory(self) -> Trajectory | None:
        """The move to send (None when no method is recommended): the recommended method's, or sloshid's plan
        re-planned slower for the scenario's arm (`Recommendation.arm`)."""
        r, rec = self.recommended, self.recommendation
        if r is None or rec is None:
            return None
        return rec.arm.trajectory if rec.arm is not None else r.require_replay().trajectory

    def arm_objection(self, arm: ArmSettings | None) -> ArmObjection | None:
        """Why the scenario's [robot] `arm` cannot follow the move to send (None when it can, or without an arm or a
        move): the fit's answer (`Recommendation.arm`), or with [robot] fit_joints = false the move checked as it is."""
        traj, rec = self.recommended_trajectory(), self.recommendation
        if traj is None or rec is None or arm is None:
            return None
        if rec.arm is not None:
            return rec.arm.objection
        from sloshid.planning.arm import arm_objection

        return arm_objection(traj, arm)

    def recommended_move(self) -> dict[str, Any] | None:
        """What the sidecar JSON of the recommended move says: the method, why, the band it holds over, how the
        scenario's arm follows it (`arm_fit`: slowed, from what transfer time), and for a feedback method that the
        CSV is its feedforward (the camera loop corrects it on the robot)."""
        r, rec, traj = self.recommended, self.recommendation, self.recommended_trajectory()
        if r is None or rec is None or traj is None:  # a recommended row comes with its recommendation
            return None
        closed = r.replay is not None and r.replay.closed_loop
        return {
            "method": r.key,
            "label": r.label,
            "transfer_time_s": traj.duration_s if rec.arm is not None else r.require_score().transfer_time_s,
            "band_hz": list(rec.band_hz),
            "risk": rec.risk,
            "reason": rec.reason,
            "robust_omega_factors": list(self.settings.robust_omega_factors) if r.key == "sloshid_robust" else None,
            "csv_holds": "the feedforward; the camera feedback corrects it on the robot" if closed else "the move",
            "arm_fit": rec.arm.to_dict() if rec.arm is not None else None,
        }

    def write_recommended(self, path: str | Path, inputs: tuple[str | Path, ...] = ()) -> Path:
        """Write the recommended move as a 1 kHz trajectory CSV at `path`, what it is as JSON beside it (`path` with
        .json) and, when the scenario's arm follows it, its joints (`path` stem + _joints.csv). With no method
        recommended a UserError says why, and nothing is written: a silent None left a script believing it had a move
        to send."""
        move, traj, rec = self.recommended_move(), self.recommended_trajectory(), self.recommendation
        if move is None or traj is None or rec is None:  # the move is described when a method is recommended
            why = self.recommendation.reason if self.recommendation is not None else "nothing was scored."
            raise UserError(f"{path} was not written, as no method is recommended: {why[:1].lower()}{why[1:]}")
        joints = rec.arm.joints if rec.arm is not None and rec.arm.follows else None
        return write_move(traj, move, path, inputs, joints)

    def slowed_row(self) -> SlowedRow | None:
        """The score table's row of the move sent when it is the recommended method's slowed for the scenario's arm
        (`recommend.slowed_row`), else None."""
        rec = self.recommendation
        return slowed_row(self.recommended_move(), rec.to_dict()["checks"] if rec is not None else {})

    def summary(self) -> str:
        """The score table as aligned plain text (the move sent, when slowed for the arm, under its method's row at
        full speed: `slowed_row`; tilt and limits are not scored for it), then the verdict (what `sloshid compare`
        prints)."""
        slowed = self.slowed_row()
        labels = [r.label for r in self.results] + ([slowed.label] if slowed is not None else [])
        w = max([34, *(len(label) + 1 for label in labels)])  # 34 unless a label is longer
        head = f"{'method':{w}s} {'T_s':>7s} {'peak_deg':>9s} {'resid_deg':>9s} {'tilt_deg':>8s} {'limits':>7s}"
        lines = [head]
        for r in self.results:
            if not r.applicable:
                lines.append(f"{r.label:{w}s} not applicable: {r.reason}")
                continue
            sc = r.require_score()
            collides = sc.min_clearance_m is not None and sc.min_clearance_m < 0
            ok = "COLLIDE" if collides else "ok" if sc.robot_limits_ok and sc.move_limits_ok else "FAIL"
            lines.append(
                f"{r.label:{w}s} {sc.transfer_time_s:7.3f} {sc.peak_during_deg:9.3f} "
                f"{sc.residual_deg:9.3f} {sc.peak_tilt_deg:8.2f} {ok:>7s}"
            )
            if slowed is not None and slowed.method == r.key:
                lines.append(
                    f"{slowed.label:{w}s} {slowed.transfer_time_s:7.3f} {slowed.peak_during_deg:9.3f} "
                    f"{slowed.residual_deg:9.3f} {'-':>8s} {'-':>7s}"
                )
        return "\n".join([*lines, "", self.verdict])

    def to_pandas(self):
        """One row per applicable method with its scores (the methods of `summary()`'s table, all columns; the move
        sent when slowed for the arm is `slowed_row()`)."""
        rows = [{"method": r.key, "label": r.label, **vars(r.score)} for r in self.results if r.applicable]
        return to_pandas({key: [row.get(key) for row in rows] for key in (rows[0] if rows else {})})

    def plot(self, ax=None):
        """Relative angle liquid - container over time for every method (dots mark arrival); returns the figure."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(10, 3.6))
        for r in self.results:
            if r.applicable:
                resp = r.require_response()
                (line,) = ax.plot(resp.t_s, resp.rel_angle_deg, lw=1.2, label=r.label)
                i = int(np.searchsorted(resp.t_s, resp.t_arrival_s))
                ax.plot(resp.t_s[i], resp.rel_angle_deg[i], "o", color=line.get_color(), ms=5)
        ax.set(xlabel="time from start of move (s)", ylabel="liquid - container angle (deg)")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
        return ax.figure

    def report(self, directory: str | Path, links: dict[str, str] | None = None, progress: bool = False) -> Path:
        """Write the comparison report to directory/index.html (`links`: text -> relative href shown at the top;
        `progress`: a tqdm bar counts its figures)."""
        from sloshid.comparison.report import save_report

        return save_report(self, directory, links, progress)

    def to_dict(self) -> dict:
        """JSON-ready summary (unit-named keys)."""
        rows = []
        for r in self.results:
            row: dict[str, Any] = {"method": r.key, "label": r.label, "applicable": r.applicable}
            if r.applicable:
                row.update(vars(r.score))
                row["build_time_s"] = r.build_time_s
                band = self.robustness.tolerance_band(r.label, self.settings.residual_ok_deg)
                row["omega_band_residual_ok"] = list(band) if band else None
            else:
                row["reason"] = r.reason
            rows.append(row)
        return {
            "liquid": self.params.to_dict(),
            "residual_ok_deg": self.settings.residual_ok_deg,
            "methods": rows,
            "closed_loop": {
                k: {
                    "robot_bandwidth_hz": self.settings.robot_bandwidth_hz,
                    "max_linear_nonlinear_gap_deg": c.max_gap_deg,
                    "peak_linear_deg": float(c.rel_linear_deg.max()),
                    "residual_linear_deg": c.residual_linear_deg,
                }
                for k, c in self.closed_loop.items()
            },
            "robustness": self.robustness.to_dict(),
            "camera": [vars(c) for c in self.camera],
            "camera_omega_factor": self.settings.camera_omega_factor,
            "no_feedback_residual_at_camera_error_deg": self.no_feedback_at_camera_error,
            "linearity": [vars(p) for p in self.linearity],
            "recommendation": self.recommendation.to_dict() if self.recommendation else None,
            "verdict": self.verdict,
        }


def camera_seen_peak(angle_deg: np.ndarray, dt_s: float, fps: float, phases: int = 16) -> float:
    """Largest value a camera at `fps` samples from a 1 kHz signal, averaged over `phases` frame-clock offsets."""
    peaks = []
    for offset in np.arange(phases) / (phases * fps):
        frames = np.round(np.arange(offset, len(angle_deg) * dt_s, 1.0 / fps) / dt_s).astype(int)
        peaks.append(angle_deg[frames[frames < len(angle_deg)]].max())
    return float(np.mean(peaks))


def camera_study(
    inp: CompareInput, built: dict[str, MethodResult], progress: bool = False
) -> tuple[list[CameraPoint], dict[str, float]]:
    """Feedback residual against camera rate at the configured model error, for each applicable feedforward (every
    loop against the true liquid first, then all of them in one batched simulation)."""
    s = inp.settings
    truth = inp.params.scaled(s.camera_omega_factor, 1.0)
    bases = [
        built[k] for k in ("constant_acc", "sloshid") if k in built and built[k].applicable and f"{k}_feedback" in built
    ]
    loops = {}
    for base in bases:
        for fps in s.camera_fps_sweep:
            fb = FeedbackSettings(**{**vars(s.feedback), "camera_fps": fps})
            own = built[f"{base.key}_feedback"].replay  # the configured camera: its loop at this liquid may have run
            loops[base.label, fps] = (
                own if own is not None and fb == own.feedback else with_feedback(inp, base.require_trajectory(), fb)
            )
    pairs = [(Replay(b.require_trajectory()), truth) for b in bases] + [(loop, truth) for loop in loops.values()]
    resp = replay_responses(pairs, s.settle_s, progress, s.workers)
    reference = {b.label: r.residual_deg for b, r in zip(bases, resp)}
    points = []
    for ((label, fps), loop), r in zip(loops.items(), resp[len(bases) :]):
        base = next(b for b in bases if b.label == label)
        traj = base.require_trajectory()
        rel = base.require_response().rel_angle_deg[: len(traj.t_s)]  # while moving
        seen = camera_seen_peak(rel, traj.dt_s, fps)
        points.append(
            CameraPoint(label, fps, loop(truth).duration_s, r.peak_during_deg, r.residual_deg, seen, float(rel.max()))
        )
    return points, reference


def linearity_study(inp: CompareInput) -> list[LinearityPoint]:
    """Where linearisation holds: the constant-acceleration move at growing accelerations, linear vs nonlinear."""
    task = inp.limits.task
    accs = inp.settings.linearity_acc_m_s2
    moves = [constant_acceleration(MoveTask(task.waypoints, (acc, acc, acc), task.vel_max_m_s)) for acc in accs]
    closed = closed_loop_responses(moves, inp.params, inp.settings.robot_bandwidth_hz, 1.0)
    return [
        LinearityPoint(acc, float(cl.rel_linear_deg.max()), float(cl.rel_nonlinear_deg.max()), cl.max_gap_deg)
        for acc, cl in zip(accs, closed)
    ]


def compare(inp: CompareInput, progress: bool = False) -> Comparison:
    """Build every requested method, score them in one batched simulation, then run the closed-loop, robustness,
    camera and linearity studies; with `progress`, one tqdm bar counts the methods and the studies."""
    s = inp.settings
    studies = ("scoring", "closed loop", "robustness", "camera rates", "linearity", "recommendation")
    bar = tqdm(total=len(s.methods) + len(studies), desc="compare", disable=None if progress else True, leave=False)

    def step(name: str) -> None:
        bar.set_postfix_str(name)
        bar.update()

    built: dict[str, MethodResult] = {}
    for key in s.methods:
        bar.set_postfix_str(key)
        built[key] = build_trajectory(key, inp, built)
        bar.update()
    results = [built[k] for k in s.methods]
    ok = [r for r in results if r.applicable]
    moves = [r.require_trajectory() for r in ok]
    for r, traj, resp in zip(ok, moves, simulate_liquids(moves, inp.params, s.settle_s)):
        r.score, r.response = score(traj, inp.params, inp.limits, s.settle_s, resp)
    step(studies[0])
    cls = closed_loop_responses(moves, inp.params, s.robot_bandwidth_hz, s.settle_s)
    closed = {r.key: cl for r, cl in zip(ok, cls)}
    step(studies[1])
    replays = {r.label: r.require_replay() for r in ok}
    robust = sweep(replays, inp.params, s.omega_factors, s.zeta_factors, progress=progress, workers=s.workers)
    step(studies[2])
    camera, reference = camera_study(inp, built, progress)
    step(studies[3])
    comp = Comparison(
        params=inp.params,
        settings=s,
        results=results,
        closed_loop=closed,
        robustness=robust,
        camera=camera,
        no_feedback_at_camera_error=reference,
        linearity=linearity_study(inp),
    )
    step(studies[4])
    comp.recommendation = recommend(results, inp.params, s, inp.f_interval_hz, progress, arm_follower(inp))
    step(studies[5])
    bar.close()
    comp.verdict = verdict(comp)
    return comp


def verdict(comp: Comparison) -> str:
    """A few sentences drawn from the numbers: the recommendation and why the faster methods lose, then what the
    alternatives cost and how robust they are."""
    limit = comp.settings.residual_ok_deg
    ok = [r for r in comp.results if r.applicable]
    scores = {r.key: r.require_score() for r in ok}
    collides = [r for r in ok if (c := scores[r.key].min_clearance_m) is not None and c < 0]
    parts = [comp.recommendation.reason] if comp.recommendation is not None else []
    const = comp.result("constant_acc")
    if const is not None and const.applicable:
        parts.append(
            f"The constant-acceleration profile sloshes to {scores[const.key].peak_during_deg:.3g} deg during the "
            f"move and leaves {scores[const.key].residual_deg:.3g} deg behind."
        )
    bands = []
    for r in ok:
        band = comp.robustness.tolerance_band(r.label, limit)
        if band and r.key in ("zv", "zvd", "sloshid", "sloshid_robust"):
            bands.append(f"{r.label} {comp.robustness.describe_band(r.label, limit)}")
    if bands:
        parts.append(f"Frequency error tolerated with residual <= {limit:g} deg: " + ", ".join(bands) + ".")
    nominal, rob = comp.result("sloshid"), comp.result("sloshid_robust")
    if nominal is not None and rob is not None and nominal.applicable and rob.applicable:
        cost = scores[rob.key].transfer_time_s / scores[nominal.key].transfer_time_s - 1
        parts.append(f"The robust plan costs {100 * cost:.1f} % more transfer time.")
    if collides:
        parts.append(
            "Going straight between waypoints collides with an obstacle: " + ", ".join(r.label for r in collides) + "."
        )
    broken = [r.label for r in ok if not scores[r.key].robot_limits_ok]
    if broken:
        parts.append("Robot limits fail for: " + ", ".join(broken) + ".")
    passed = [r.label for r in ok if not scores[r.key].move_limits_ok]
    if passed:
        parts.append("The scenario's [limits] fail for: " + ", ".join(passed) + ".")
    return " ".join(parts)
