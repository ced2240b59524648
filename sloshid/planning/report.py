"""The plan's HTML report: seed Fig. 6 (optimal states over time), Fig. 9 (3-D path, obstacles, container
z-axis arrows), robot-limit usage over time and the independent liquid verification."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sloshid.model.trajectory import limit_profiles
from sloshid.planning.scenario import Scenario
from sloshid.report.html import Report

if TYPE_CHECKING:  # the result draws itself through this module: its class is named for the annotations only
    from sloshid.planning.result import PlanResult

LIMIT_LABELS = {
    "vel_m_s": "speed (m/s)",
    "acc_m_s2": "acceleration (m/s²)",
    "jerk_m_s3": "jerk (m/s³)",
    "rot_vel_rad_s": "angular speed (rad/s)",
    "rot_acc_rad_s2": "angular acceleration (rad/s²)",
    "rot_jerk_rad_s3": "angular jerk (rad/s³)",
}
"""Human labels of the robot-limit quantities."""
LIMIT_WARN_SHARE = 0.9
"""A robot limit used above this share is flagged in the verdict: tracking errors or a heavier payload can push it
over."""

ARROW_TILT_GAIN = 5.0
"""Fig. 9 arrows show the container tilt exaggerated by this factor (real tilts are a few degrees)."""


def _segment_lines(ax, result: PlanResult) -> None:
    """Mark the waypoint stops on a time axis."""
    for t in np.cumsum([s.T_s for s in result.segments])[:-1]:
        ax.axvline(t, color="0.7", lw=0.8, ls=":")


def states_figure(result: PlanResult):
    """Seed Fig. 6: position, velocity, acceleration, tilt angles and rates of the container over time."""
    import matplotlib.pyplot as plt

    tr = result.trajectory
    fig, axes = plt.subplots(5, 1, figsize=(9, 11), sharex=True)
    rows = [
        (tr.pos_m, ("x", "y", "z"), "position (m)"),
        (tr.vel_m_s, ("vx", "vy", "vz"), "velocity (m/s)"),
        (tr.acc_m_s2, ("ax", "ay", "az"), "acceleration (m/s²)"),
        (np.degrees(tr.euler_rad[:, :2]), ("phi (roll)", "theta (pitch)"), "tilt (deg)"),
        (np.degrees(tr.euler_rate_rad_s[:, :2]), ("phi'", "theta'"), "tilt rate (deg/s)"),
    ]
    for ax, (data, names, label) in zip(axes, rows):
        for k, name in enumerate(names):
            ax.plot(tr.t_s, data[:, k], label=name)
        ax.set_ylabel(label)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
        ax.grid(alpha=0.3)
        _segment_lines(ax, result)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def _sphere(ax, center, radius, color) -> None:
    """Wireframe sphere."""
    u, v = np.mgrid[0 : 2 * np.pi : 24j, 0 : np.pi : 12j]
    ax.plot_wireframe(
        center[0] + radius * np.cos(u) * np.sin(v),
        center[1] + radius * np.sin(u) * np.sin(v),
        center[2] + radius * np.cos(v),
        color=color,
        lw=0.5,
        alpha=0.6,
    )


def _cylinder(ax, center, radius, z_range, color) -> None:
    """Wireframe vertical cylinder."""
    u, z = np.mgrid[0 : 2 * np.pi : 24j, z_range[0] : z_range[1] : 6j]
    ax.plot_wireframe(center[0] + radius * np.cos(u), center[1] + radius * np.sin(u), z, color=color, lw=0.5, alpha=0.6)


def path_figure(result: PlanResult, scenario: Scenario):
    """Seed Fig. 9: the 3-D path, waypoints, obstacles (solid) and their inflation (faint), z-axis arrows."""
    import matplotlib.pyplot as plt

    tr = result.trajectory
    fig = plt.figure(figsize=(9, 8))
    ax = fig.add_subplot(projection="3d")
    ax.plot(*tr.pos_m.T, color="C0", lw=1.5, label="container path")
    wp = np.array(scenario.waypoints)
    ax.scatter(*wp.T, color="k", s=25, label="waypoints (stops)")
    for i, p in enumerate(wp):
        ax.text(*p, f" {i}", fontsize=9)
    R = scenario.container_radius_m
    for o in scenario.obstacles:
        if o.kind == "sphere":
            _sphere(ax, o.center, o.radius, "C3")
            _sphere(ax, o.center, o.radius + R, "0.75")
        elif o.z_range is not None:  # a cylinder always has one (Obstacle checks)
            _cylinder(ax, o.center, o.radius, o.z_range, "C3")
            _cylinder(ax, o.center, o.radius + R, (o.z_range[0] - R, o.z_range[1] + R), "0.75")
    step = max(1, round(0.08 / tr.dt_s))
    idx = np.arange(0, len(tr.t_s), step)
    z = tr.z_axis[idx]
    z = np.column_stack([z[:, :2] * ARROW_TILT_GAIN, z[:, 2]])
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    ax.quiver(
        *tr.pos_m[idx].T, *z.T, length=0.05, color="C2", lw=0.8, label=f"container z-axis (tilt x{ARROW_TILT_GAIN:g})"
    )
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    span = np.ptp(np.vstack([tr.pos_m, wp]), axis=0).max() / 2 + 0.08
    mid = (tr.pos_m.max(axis=0) + tr.pos_m.min(axis=0)) / 2
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        setter(m - span, m + span)
    ax.legend(loc="upper left", fontsize=8)
    return fig


def limits_figure(result: PlanResult, scenario: Scenario):
    """Robot-limit usage over time: each quantity as a share of its limit (100 % = at the limit)."""
    import matplotlib.pyplot as plt

    tr = result.trajectory
    fig, ax = plt.subplots(figsize=(9, 4))
    top = 100.0
    for key, profile in limit_profiles(tr).items():
        share = 100 * profile / getattr(scenario.robot, key)
        top = max(top, float(share.max()))
        ax.plot(tr.t_s, share, label=LIMIT_LABELS.get(key, key), lw=1)
    ax.axhline(100, color="r", ls="--", lw=1, label="limit (100 %)")
    ax.set_ylim(0, 1.1 * top)  # the 100 % line always in view
    _segment_lines(ax, result)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("share of robot limit (%)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def verification_figure(result: PlanResult):
    """Relative angle between simulated liquid surface and exported container orientation, with the thresholds."""
    import matplotlib.pyplot as plt

    v = result.verification
    fig, ax = plt.subplots(figsize=(9, 3.5))
    ax.semilogy(v.t_s, np.maximum(v.rel_angle_deg, 1e-9), lw=1, label="|liquid - container| (simulated)")
    during = result.verify_during_deg
    ax.axhline(during, color="C1", ls="--", lw=1, label=f"{during:g} deg (during)")
    after = result.verify_after_deg
    ax.axhline(after, color="C3", ls=":", lw=1, label=f"{after} deg (after arrival)")
    ax.axvline(v.t_arrival_s, color="k", lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("relative angle (deg)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return fig


def plan_verdict(result: PlanResult) -> tuple[str, str]:
    """(sentence, css class): solver, limits with their margins, clearance and the independent verification."""
    s = result.to_dict()
    verified = "verified" if result.verification_ok else "NOT verified"
    close = [u for u in result.limits if u.ok and u.peak > LIMIT_WARN_SHARE * u.limit]
    limits = "hold" if all(u.ok for u in result.limits) else "are EXCEEDED (see the table)"
    if close:
        limits += (" but " if limits == "hold" else "; ") + ", ".join(
            f"{LIMIT_LABELS.get(u.quantity, u.quantity)} reaches {100 * u.peak / u.limit:.0f} %" for u in close
        )
    over = [u for u in result.move_limits if not u.ok]
    if over:  # the scenario's own [limits], passed between the solver's grid points
        limits += (
            ". The scenario's [limits] are EXCEEDED: "
            + ", ".join(f"{u.quantity} {u.peak:.4g} > {u.limit:.4g}" for u in over)
            + " (between the solver's grid points; a larger [solver].N holds them closer)"
        )
    if result.tightened:
        limits += (
            ". Solved again with "
            + ", ".join(f"{k} at {100 * share:.1f} % of the scenario's" for k, share in result.tightened.items())
            + ": the first solve passed them between its grid points"
        )
    clearance = (
        f" The container stays {1e3 * result.min_clearance_m:.1f} mm clear of the inflated obstacles."
        if result.min_clearance_m is not None
        else ""
    )
    text = (
        f"{len(result.segments)} segment(s), T = {result.T_s:.4f} s, {s['formulation']} formulation, solved in "
        f"{result.solve_time_s:.3f} s ({result.iterations} IPOPT iterations, {result.status}). Robot limits "
        f"{limits}.{clearance} Slosh-free motion {verified}: the simulated liquid stays within "
        f"{s['verification']['peak_during_deg']:.2g} deg of the container while moving and "
        f"{s['verification']['residual_deg']:.2g} deg after arrival."
    )
    good = result.limits_ok and result.verification_ok and not close
    good = good and (result.min_clearance_m is None or result.min_clearance_m >= 0)
    return text, "verdict-good" if good else "verdict-uncertain"


def plan_report(
    result: PlanResult, scenario: Scenario, liquid_source: str = "", links: dict[str, str] | None = None
) -> Report:
    """Assemble the report (nothing is written until `.save(dir)`); `liquid_source` says where the liquid came
    from, `links` (text -> relative href) point to the trajectory CSV and, in a pipeline, back to its index."""
    s = result.to_dict()
    rep = Report(f"sloshid plan: {scenario.source or 'scenario'}")
    rep.add_links(links or {})
    rep.add_text(*plan_verdict(result))
    p = result.params
    rep.add_text(
        f"Planned for the liquid f = {p.f_hz:.4g} Hz, zeta = {p.zeta:.3g}, l = {p.l_m:.4g} m, "
        f"d/m = {p.d_ns_per_m / p.m_kg:.3g} 1/s (the damping per mass, all the pendulum needs), from "
        f"{liquid_source or 'the scenario'}"
        + (
            f"; robust over omega x {', '.join(f'{f:g}' for f in result.robust_omega_factors)}."
            if result.robust_omega_factors
            else "."
        )
    )
    rep.add_table(
        ["segment", "start (m)", "goal (m)", "T (s)", "model", "iterations", "solve (s)", "max tilt (deg)", "status"],
        [
            [
                g["index"] + 1,
                str(g["start_m"]),
                str(g["goal_m"]),
                g["T_s"],
                g["model"],
                g["iterations"],
                g["solve_time_s"],
                g["max_tilt_deg"],
                g["status"],
            ]
            for g in s["segments"]
        ],
        "Each segment is an independent rest-to-rest problem (the container stops at every waypoint).",
    )
    rep.add_heading("Optimal states (seed Fig. 6)")
    rep.add_figure(
        states_figure(result),
        "Container position, velocity, acceleration, and tilt (= liquid surface) "
        "over time; dotted lines are waypoint stops. The container tilts into the acceleration.",
    )
    rep.add_heading("Path (seed Fig. 9)")
    rep.add_figure(
        path_figure(result, scenario),
        "3-D path with obstacles (red) and their inflation by the container "
        f"radius (grey); green arrows show the container's z-axis every 80 ms, tilt exaggerated "
        f"x{ARROW_TILT_GAIN:g}. Minimum clearance to an inflated obstacle: "
        + (f"{result.min_clearance_m * 1e3:.1f} mm." if result.min_clearance_m is not None else "no obstacles."),
    )
    _limits_section(rep, result, scenario)
    _path_and_joints_section(rep, result)
    rep.add_heading("Independent verification")
    rep.add_figure(
        verification_figure(result),
        "The nonlinear pendulum integrated by solve_ivp under the exported "
        "accelerations, compared with the exported container orientation. Below the dashed line during the "
        "move and the dotted line after arrival (black) means no relative sloshing.",
    )
    return rep


def _limits_section(rep: Report, result: PlanResult, scenario: Scenario) -> None:
    """Robot-limit usage over time and the table of peaks, limits and shares."""
    s = result.to_dict()
    rep.add_heading("Robot limits")
    rep.add_figure(
        limits_figure(result, scenario),
        "Each limited quantity as a share of the robot's limit over time "
        "(derivatives by forward differences at 1 kHz, as the robot controller sees them). Above the red "
        "line the robot would refuse or deviate.",
    )
    rep.add_table(
        ["quantity", "peak", "limit", "usage", "t at peak (s)", "ok"],
        [
            [
                u["quantity"],
                u["peak"],
                u["limit"],
                f"{100 * u['usage']:.1f} %",
                u["t_peak_s"],
                "yes" if u["ok"] else "NO",
            ]
            for u in s["limits"]
        ],
    )
    rep.add_text("The scenario's own [limits], checked the same way on the 1 kHz samples:")
    rep.add_table(
        ["quantity", "peak", "limit", "usage", "t at peak (s)", "ok"],
        [
            [u.quantity, u.peak, u.limit, f"{100 * u.peak / u.limit:.1f} %", u.t_peak_s, "yes" if u.ok else "NO"]
            for u in result.move_limits
        ],
    )


def _path_and_joints_section(rep: Report, result: PlanResult) -> None:
    """How close a [path] plan stays to the user's path, and whether the Panda can follow the trajectory."""
    if result.max_path_deviation_m is not None and result.path_tolerance_m is not None:
        rep.add_text(
            f"Prescribed path: the 1 kHz trajectory stays within {result.max_path_deviation_m * 1e3:.3f} mm of it "
            f"(tolerance {result.path_tolerance_m * 1e3:g} mm); the liquid may lean against the container by up to "
            f"{result.verify_during_deg:g} deg while moving."
        )
    if result.joints is not None:
        j = result.joints
        rep.add_heading("Joint space (Franka Panda)")
        rep.add_text(
            ("The Panda can follow the trajectory" if j.executable else "NOT executable: " + j.reason())
            + f" Inverse kinematics at every 1 kHz sample; forward kinematics of the joints reproduces the "
            f"trajectory within {j.fk_position_error_m * 1e3:.2g} mm and {j.fk_angle_error_deg:.2g} deg (container "
            f"axis). Worst: joint {j.worst.joint} {j.worst.quantity} at t = {j.worst.t_s:.3f} s.",
            "verdict-good" if j.executable else "verdict-uncertain",
        )
        rep.add_table(
            ["quantity", "worst joint", "peak", "limit (datasheet)", "margin", "t (s)", "ok"],
            [[u.quantity, u.joint, u.peak, u.limit, u.margin, u.t_s, "yes" if u.ok else "NO"] for u in j.usages],
            "Position: the joint closest to a bound, margin its distance to it. Rates by forward differences at 1 kHz.",
        )
