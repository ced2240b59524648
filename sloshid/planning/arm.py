"""Joint-space feasibility on a real arm: the Franka Emika Panda, via pinocchio and example-robot-data's URDF.

The [robot] table places the arm (`base_xyz_m`, `base_rpy_deg`), says where the liquid surface centre sits in
the flange frame (`tool_offset_m`) and where the arm starts (`q_start`, rad). The container is mounted so that
it is upright when the flange points straight down (flange z = -world z); the container's tilt of the
trajectory tilts the flange with it. A round container does not care about its yaw about its own axis, so
the task is 5-D: the liquid surface centre's position and the container's axis.

Inverse kinematics runs at every 1 kHz sample, each solve started from the previous one (q_start at t = 0):
damped Newton to 1e-10, each step the least-norm joint change, so the two redundant freedoms (the 7th joint
and the yaw) move as little as they can: the joints are continuous, without jumps. The joint trajectory is checked

against the Panda datasheet's position, velocity, acceleration and jerk limits (rates by forward differences
at 1 kHz, as the robot's controller sees them). Nothing is downloaded: the URDF ships in the example-robot-data
wheel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np

from sloshid.core.errors import UserError
from sloshid.model.trajectory import Trajectory
from sloshid.planning.arm_settings import (  # the settings live apart from pinocchio; kept importable here
    PANDA_DDDQ_MAX,
    PANDA_DDQ_MAX,
    PANDA_DQ_MAX,
    PANDA_Q_MAX,
    PANDA_Q_MIN,
    ArmSettings,
    arm_settings,
)
from sloshid.planning.planner import plan

FLANGE = "panda_link8"

IK_TOL = 1e-10
"""Pose error (m and rad) at which a Newton solve stops."""
IK_MAX_ITER = 30
IK_SEED_ITER = 300
"""Newton steps allowed from the q_start seed to the start configuration (it may lie a radian away)."""
IK_DAMPING = 1e-6


def _urdf_path() -> str:
    """The Panda URDF shipped in the example-robot-data wheel."""
    import importlib.metadata as md

    try:
        files = md.files("example-robot-data") or []
    except md.PackageNotFoundError:
        files = []
    for f in files:
        if str(f).endswith("panda_description/urdf/panda.urdf"):
            return str(f.locate())
    raise UserError("the Panda model needs the example-robot-data package (pip install example-robot-data).")


@cache
def _panda():
    """(pinocchio model of the 7 arm joints, its data, flange frame id); the fingers are locked."""
    import pinocchio as pin

    full = pin.buildModelFromUrdf(_urdf_path())
    fingers = [full.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    model = pin.buildReducedModel(full, fingers, pin.neutral(full))
    return model, model.createData(), model.getFrameId(FLANGE)


def _rpy(rpy_deg) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("ZYX", np.radians(rpy_deg)[::-1]).as_matrix()


@dataclass
class Arm:
    """A placed Panda with its tool: forward kinematics of the liquid surface centre, and IK along a trajectory."""

    settings: ArmSettings

    def __post_init__(self) -> None:
        import pinocchio as pin

        self.pin = pin
        self.model, self.data, self.flange = _panda()
        self.base_R = _rpy(self.settings.base_rpy_deg)
        self.base_p = np.asarray(self.settings.base_xyz_m, float)
        self.tool = np.asarray(self.settings.tool_offset_m, float)
        R0 = self._flange(np.asarray(self.settings.q_start, float))[0]
        yaw = math.atan2(R0[1, 0], R0[0, 0])  # flange x-axis direction in the world, about world z
        c, s = math.cos(yaw), math.sin(yaw)
        # the flange pointing down (x along yaw, z = -world z) when the container is upright
        self.mount = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])

    def _flange(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rotation and position of the flange."""
        pin = self.pin
        pin.forwardKinematics(self.model, self.data, q)
        M = pin.updateFramePlacement(self.model, self.data, self.flange)
        return self.base_R @ M.rotation, self.base_p + self.base_R @ M.translation

    def tool_pose(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(container rotation, liquid surface centre) in the world for joint angles q."""
        R, p = self._flange(q)
        return R @ self.mount.T, p + R @ self.tool

    def _error_and_jacobian(self, q, z_goal, p_goal) -> tuple[np.ndarray, np.ndarray]:
        """Task error (position, container-axis rotation vector) in the world and its Jacobian (6 x 7, rank 5).

        The container is rotationally symmetric: only its axis is prescribed, its yaw about that axis is free."""
        pin = self.pin
        J = pin.computeFrameJacobian(self.model, self.data, q, self.flange, pin.LOCAL_WORLD_ALIGNED)
        M = self.data.oMf[self.flange]
        R_f, p_f = self.base_R @ M.rotation, self.base_p + self.base_R @ M.translation
        arm = R_f @ self.tool
        z = -R_f[:, 2]  # container axis = -flange z
        Jw = self.base_R @ J[3:]
        Jv = self.base_R @ J[:3] - _skew(arm) @ Jw
        P = np.eye(3) - np.outer(z, z)  # rotations about the axis do not count
        return np.concatenate([p_goal - (p_f + arm), np.cross(z, z_goal)]), np.vstack([Jv, P @ Jw])

    def solve(
        self, q0: np.ndarray, z_goal: np.ndarray, p_goal: np.ndarray, max_iter: int = IK_MAX_ITER
    ) -> np.ndarray | None:
        """Joint angles placing the liquid surface centre at p_goal with the container axis z_goal (damped Newton
        from q0: each step the smallest joint change, so the redundant freedom moves as little as it can)."""
        q = q0.copy()
        eye = IK_DAMPING**2 * np.eye(6)
        for _ in range(max_iter):
            err, J = self._error_and_jacobian(q, z_goal, p_goal)
            if np.abs(err).max() < IK_TOL:
                return q
            q = q + J.T @ np.linalg.solve(J @ J.T + eye, err)
        err, _ = self._error_and_jacobian(q, z_goal, p_goal)
        return q if np.abs(err).max() < 1e-7 else None

    def inverse(self, traj: Trajectory) -> np.ndarray:
        """Joint angles (n, 7) following the trajectory at every sample; UserError if a pose is unreachable.

        Each solve starts from the previous sample's angles, the first from the q_start seed (with more Newton steps:
        the start configuration nearest to it), so the redundant freedom (the 7th joint and the container's yaw) is
        resolved by least joint motion: continuous, no jumps."""
        from scipy.spatial.transform import Rotation

        z_all = Rotation.from_euler("ZYX", traj.euler_rad[:, ::-1]).apply([0.0, 0.0, 1.0])
        q = np.asarray(self.settings.q_start, float)
        out = np.zeros((len(traj.t_s), 7))
        for i in range(len(traj.t_s)):
            sol = self.solve(q, z_all[i], traj.pos_m[i], IK_SEED_ITER if i == 0 else IK_MAX_ITER)
            if sol is None:
                raise UserError(
                    f"the pose at t = {traj.t_s[i]:.3f} s ({np.round(traj.pos_m[i], 4).tolist()} m) is out of the "
                    "Panda's reach from [robot].q_start; move the path or the base (base_xyz_m)."
                )
            out[i] = q = sol
        return out


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


@dataclass(frozen=True)
class JointUsage:
    """Peak of one joint quantity (position margin, velocity, acceleration or jerk) against the datasheet."""

    quantity: str
    """'position_rad', 'velocity_rad_s', 'acceleration_rad_s2' or 'jerk_rad_s3'."""
    joint: int
    """Worst joint, 1..7."""
    peak: float
    """Position: the joint angle closest to a limit; rates: largest magnitude."""
    limit: float
    """The limit it is measured against (position: the nearer bound)."""
    margin: float
    """limit - |peak| for rates; distance to the nearer bound for position (negative: violated)."""
    t_s: float

    @property
    def ok(self) -> bool:
        """True when within the limit (0.1 % slack on rates for sampling round-off, as for Cartesian limits)."""
        if self.quantity == "position_rad":
            return self.margin >= 0
        return abs(self.peak) <= self.limit * 1.001

    def to_dict(self) -> dict:
        return {**vars(self), "ok": self.ok, "usage": abs(self.peak / self.limit) if self.limit else 0.0}


@dataclass
class JointCheck:
    """The joint trajectory and its check against the datasheet."""

    t_s: np.ndarray
    q: np.ndarray
    usages: list[JointUsage]
    fk_position_error_m: float
    """Largest distance between FK of the joints and the Cartesian trajectory (m)."""
    fk_angle_error_deg: float
    """Largest angle between the container axis by FK and the trajectory's (deg); its yaw about the axis is free."""
    start_offset_m: float = 0.0
    """Distance of the container at the [robot].q_start seed from the trajectory's first point (m)."""
    start_jump_rad: float = 0.0
    """Largest joint change from the q_start seed to the start configuration solved from it (the first row)."""
    start_m: np.ndarray | None = None
    """The trajectory's first point (m)."""
    q_seed: np.ndarray | None = None
    """[robot].q_start, the seed the start configuration was solved from."""

    @property
    def start_moved(self) -> str:
        """One sentence when the start configuration lies away from the q_start seed (empty when q_start held the
        container there already): where the arm must be before the move starts."""
        if self.start_jump_rad <= START_JUMP_RAD:
            return ""
        j = int(np.argmax(np.abs(self.q[0] - self.q_seed))) + 1 if self.q_seed is not None else 0
        return (
            f"the arm starts at the joints CSV's first row, solved from [robot].q_start (which holds the container "
            f"{1e3 * self.start_offset_m:.0f} mm from the move's start): joints moved by up to "
            f"{self.start_jump_rad:.3g} rad (joint {j}); bring the arm there before the move."
        )

    @property
    def executable(self) -> bool:
        return all(u.ok for u in self.usages)

    @property
    def worst(self) -> JointUsage:
        """The usage closest to (or furthest past) its limit."""
        return min(self.usages, key=lambda u: u.margin / max(abs(u.limit), 1e-9))

    def reason(self) -> str:
        """One sentence: why the arm cannot follow, naming the joint and the time."""
        bad = [u for u in self.usages if not u.ok]
        if not bad:
            return "the Panda can follow the trajectory."
        u = min(bad, key=lambda u: u.margin / max(abs(u.limit), 1e-9))
        what = u.quantity.split("_")[0]
        return (
            f"joint {u.joint} exceeds its {what} limit at t = {u.t_s:.3f} s: {u.peak:.4g} against "
            f"{u.limit:.4g} {u.quantity.split('_', 1)[1].replace('_', '/')}"
            + (f" ({len(bad)} limit(s) fail in all)." if len(bad) > 1 else ".")
        )

    def to_dict(self) -> dict:
        w = self.worst
        return {
            "model": "panda",
            "executable": self.executable,
            "reason": None if self.executable else self.reason(),
            "worst": {"joint": w.joint, "quantity": w.quantity, "t_s": w.t_s, "margin": w.margin},
            "limits": [u.to_dict() for u in self.usages],
            "fk_position_error_m": self.fk_position_error_m,
            "fk_angle_error_deg": self.fk_angle_error_deg,
            "start_offset_m": self.start_offset_m,
            "start_jump_rad": self.start_jump_rad,
            "q_start_solved_rad": self.q[0].tolist(),
        }

    def objection(self) -> ArmObjection | None:
        """Why the arm cannot follow the checked move (None when it can): the joint limit it breaks, and whether a
        slower plan can fix it (a position limit no timing fixes)."""
        if self.executable:
            return None
        why = f"the Panda of [robot] cannot follow it ({self.reason().rstrip('.')})"
        if any(u.quantity == "position_rad" and not u.ok for u in self.usages):
            return ArmObjection(
                f"{why}; no timing fixes a joint position limit: move the path, the base or q_start", False
            )
        return ArmObjection(why, refit=True)

    def write_csv(self, path) -> None:
        """t_s, q1 ... q7 (rad)."""
        from sloshid.core.tables import write_csv

        write_csv(path, {"t_s": self.t_s, **{f"q{j + 1}": self.q[:, j] for j in range(7)}})


def _rates(q: np.ndarray, dt: float, order: int) -> np.ndarray:
    """Forward differences of the given order (last rows repeated), as a 1 kHz controller sees them."""
    x = q
    for _ in range(order):
        d = np.diff(x, axis=0) / dt
        x = np.vstack([d, d[-1:]])
    return x


def joint_usages(t_s: np.ndarray, q: np.ndarray) -> list[JointUsage]:
    """Position, velocity, acceleration and jerk of every joint against the Panda datasheet."""
    dt = float(t_s[1] - t_s[0])
    margin_lo, margin_hi = q - PANDA_Q_MIN, PANDA_Q_MAX - q
    margin = np.minimum(margin_lo, margin_hi)
    i, j = np.unravel_index(np.argmin(margin), margin.shape)
    near = PANDA_Q_MIN[j] if margin_lo[i, j] < margin_hi[i, j] else PANDA_Q_MAX[j]
    out = [JointUsage("position_rad", int(j) + 1, float(q[i, j]), float(near), float(margin[i, j]), float(t_s[i]))]
    for order, name, lim in (
        (1, "velocity_rad_s", PANDA_DQ_MAX),
        (2, "acceleration_rad_s2", PANDA_DDQ_MAX),
        (3, "jerk_rad_s3", PANDA_DDDQ_MAX),
    ):
        r = _rates(q, dt, order)
        use = np.abs(r) / lim
        i, j = np.unravel_index(np.argmax(use), use.shape)
        out.append(
            JointUsage(name, int(j) + 1, float(r[i, j]), float(lim[j]), float(lim[j] - abs(r[i, j])), float(t_s[i]))
        )
    return out


def check_joints(traj: Trajectory, settings: ArmSettings, arm: Arm | None = None) -> JointCheck:
    """IK along the whole trajectory, FK back for the errors, and the datasheet check."""
    arm = arm or Arm(settings)
    q = arm.inverse(traj)
    from scipy.spatial.transform import Rotation

    z_goal = Rotation.from_euler("ZYX", traj.euler_rad[:, ::-1]).apply([0.0, 0.0, 1.0])
    pos_err, ang_err = 0.0, 0.0
    for i in range(len(q)):
        R, p = arm.tool_pose(q[i])
        pos_err = max(pos_err, float(np.linalg.norm(p - traj.pos_m[i])))
        ang_err = max(ang_err, math.acos(min(1.0, float(R[:, 2] @ z_goal[i]))))
    q0 = np.asarray(settings.q_start, float)
    offset = float(np.linalg.norm(arm.tool_pose(q0)[1] - traj.pos_m[0]))
    jump = float(np.abs(q[0] - q0).max())
    return JointCheck(
        traj.t_s, q, joint_usages(traj.t_s, q), pos_err, math.degrees(ang_err), offset, jump, traj.pos_m[0], q0
    )


@dataclass(frozen=True)
class ArmObjection:
    """Why the [robot] arm cannot follow a move: `reason`, one clause (a pose out of reach, or the joint limit it
    breaks); `refit`: a plan made slower for the arm can fix it (fit_joints), which a reach or position limit cannot."""

    reason: str
    refit: bool


def arm_objection(traj: Trajectory, settings: ArmSettings) -> ArmObjection | None:
    """Why the [robot] arm cannot follow `traj` (None when it can): inverse kinematics and the joint limits, as
    `check_joints`, about a second."""
    try:
        check = check_joints(traj, settings)
    except UserError as exc:  # a pose out of reach, which says to move the path or the base
        return ArmObjection(str(exc).rstrip("."), refit=False)
    return check.objection()


__all__ = [
    "Arm",
    "ArmFit",
    "ArmObjection",
    "ArmSettings",
    "JointCheck",
    "arm_objection",
    "arm_settings",
    "check_joints",
    "fit_arm",
    "joint_usages",
]


START_JUMP_RAD = 1e-3
"""Largest joint change from [robot].q_start to the solved start configuration that counts as none: a q_start that
holds the container at the start gives the first sample's angles to the IK's tolerance."""
FIT_TRIES = 6
"""Re-plans at most this many times when fitting a plan to the joint limits."""
FIT_SAFETY = 0.9
"""Each re-plan scales the failing Cartesian limits by this share of limit / peak."""
_SCALED = {
    "velocity_rad_s": ("vel_m_s", "rot_vel_rad_s"),
    "acceleration_rad_s2": ("acc_m_s2", "rot_acc_rad_s2"),
    "jerk_rad_s3": ("jerk_m_s3", "rot_jerk_rad_s3"),
}


@dataclass
class FitStep:
    """One plan of the fitting loop."""

    T_s: float
    robot: dict
    executable: bool
    reason: str


def fit_to_joints(scenario, params, first=None, check: JointCheck | None = None):
    """Re-plan with lower Cartesian limits until the arm can follow: (PlanResult, JointCheck, [FitStep]).

    Slowing a slosh-free trajectory down in time would make it slosh (the liquid's dynamics do not scale), so the
    planner runs again: the [robot] Cartesian limits behind each failing joint quantity (velocity: vel_m_s and
    rot_vel_rad_s; acceleration: acc_m_s2 and rot_acc_rad_s2; jerk: jerk_m_s3 and rot_jerk_rad_s3) are scaled by
    FIT_SAFETY * limit / peak of the worst joint. A joint position limit cannot be fixed by timing: the loop stops
    and the result stays not executable."""

    import dataclasses

    result = first or plan(scenario, params)
    arm = Arm(scenario.arm)
    check = check or check_joints(result.trajectory, scenario.arm, arm)
    steps = [FitStep(result.T_s, dataclasses.asdict(scenario.robot), check.executable, check.reason())]
    for _ in range(FIT_TRIES):
        if check.executable:
            break
        bad = [u for u in check.usages if not u.ok]
        if any(u.quantity == "position_rad" for u in bad):
            steps[-1].reason += " Re-planning cannot fix a joint position limit: move the path, the base or q_start."
            break
        changes = {}
        for u in bad:
            factor = FIT_SAFETY * u.limit / abs(u.peak)
            for key in _SCALED[u.quantity]:
                changes[key] = getattr(scenario.robot, key) * factor
        scenario = dataclasses.replace(scenario, robot=dataclasses.replace(scenario.robot, **changes))
        result = plan(scenario, params)
        check = check_joints(result.trajectory, scenario.arm, arm)
        steps.append(FitStep(result.T_s, dataclasses.asdict(scenario.robot), check.executable, check.reason()))
    return result, check, steps


@dataclass
class ArmFit:
    """A move as the scenario's [robot] arm follows it (`fit_arm`): the move to send, its joints, and how much slower
    it is than the move first given; or why the arm cannot follow it."""

    trajectory: Trajectory
    """The move to send: the one given, or sloshid's plan re-planned slower when the arm could not follow that."""
    first_s: float
    """Transfer time of the move first given (s)."""
    joints: JointCheck | None
    """The joint trajectory of `trajectory` and its check; None when a pose is out of reach."""
    objection: ArmObjection | None
    """Why the arm cannot follow `trajectory` (None: it can)."""
    steps: list[FitStep] = field(default_factory=list)
    """`fit_to_joints`' plans, the first one first (empty when it did not run)."""
    plan: Any = None
    """The re-planned `PlanResult` when the move was slowed, else None."""

    @property
    def follows(self) -> bool:
        """True when the arm can follow `trajectory`."""
        return self.objection is None

    @property
    def slowed(self) -> bool:
        """True when `trajectory` is a slower plan than the move first given."""
        return self.plan is not None

    def describe(self) -> str:
        """One clause on what fitting did: slowed (T before -> after, re-plans, the joint limit that made it) or not."""
        if not self.slowed:
            return self.objection.reason if self.objection is not None else "the Panda of [robot] can follow it"
        cost = 100 * (self.trajectory.duration_s / self.first_s - 1)
        return (
            f"slowed for the Panda of [robot] from {self.first_s:.3f} to {self.trajectory.duration_s:.3f} s "
            f"(+{cost:.1f} %; re-planned {len(self.steps) - 1} time(s) with lower Cartesian limits), as at full speed "
            f"{self.steps[0].reason[:1].lower()}{self.steps[0].reason[1:].rstrip('.')}"
        )

    def to_dict(self) -> dict:
        """The JSON `arm_fit`: whether the arm follows the move, whether it was slowed and from what transfer time."""
        return {
            "model": "panda",
            "follows": self.follows,
            "reason": self.objection.reason if self.objection is not None else None,
            "slowed": self.slowed,
            "transfer_time_first_s": self.first_s,
            "transfer_time_s": self.trajectory.duration_s,
            "replans": max(len(self.steps) - 1, 0),
            "T_steps_s": [s.T_s for s in self.steps],
        }


def fit_arm(traj: Trajectory, scenario, params=None, first=None) -> ArmFit:
    """How the scenario's arm follows `traj`: checked as `check_joints` does and, when a slower plan can fix what the
    arm cannot follow and `first` is the `PlanResult` behind `traj` (planned for `scenario` and `params`), re-planned
    by `fit_to_joints` (as `plan --fit-joints`); a fit that fails keeps `traj` with why the arm cannot follow it."""
    arm = Arm(scenario.arm)
    try:
        check = check_joints(traj, scenario.arm, arm)
    except UserError as exc:  # a pose out of reach, which says to move the path or the base
        return ArmFit(traj, traj.duration_s, None, ArmObjection(str(exc).rstrip("."), refit=False))
    found = check.objection()
    if found is None or not found.refit or first is None:
        return ArmFit(traj, traj.duration_s, check, found)
    try:
        result, fitted, steps = fit_to_joints(scenario, params, first, check)
    except UserError as exc:  # a lower limit the planner cannot solve
        return ArmFit(
            traj, traj.duration_s, check, ArmObjection(f"{found.reason}; re-planning it slower failed: {exc}", False)
        )
    if not fitted.executable:
        T = " -> ".join(f"{s.T_s:.3f}" for s in steps)
        why = f"{found.reason}, nor a plan re-planned slower (T {T} s): {steps[-1].reason.rstrip('.')}"
        return ArmFit(traj, traj.duration_s, check, ArmObjection(why, refit=False), steps)
    result.joints = fitted
    return ArmFit(result.trajectory, traj.duration_s, fitted, None, steps, result)
