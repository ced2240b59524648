"""Plan a time-optimal, slosh-free container move (seed section III, CasADi + IPOPT) and write it as a 1 kHz
robot trajectory CSV. The container follows the liquid's surface, so the liquid never moves relative to it.
The plan is checked against the robot's Cartesian limits and verified by simulating the liquid independently.
"""

from __future__ import annotations

import argparse
import json
import sys

from sloshid.core.errors import UserError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid plan`."""
    parser.add_argument(
        "scenario",
        help="scenario TOML: [move] start/goal (m) or waypoints, [limits], "
        "[[obstacles]], [container], [solver], [liquid], [robot] (see README)",
    )
    parser.add_argument(
        "--params",
        metavar="PARAMS.json",
        default=None,
        help="liquid parameters written by `sloshid identify` (omega in rad/s, zeta, m in kg); "
        "overrides the scenario's [liquid] table",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="TRAJ.csv",
        required=True,
        help="robot trajectory at 1 kHz: time (s), position (m), velocity (m/s), acceleration "
        "(m/s^2), Euler angles (rad), angular velocity (rad/s), quaternion",
    )
    parser.add_argument(
        "--report",
        metavar="DIR",
        default=None,
        help="write an HTML report (states over time, 3-D path, limit usage, verification) to DIR",
    )
    parser.add_argument(
        "--joints",
        metavar="JOINTS.csv",
        default=None,
        help="also write the arm's joint angles at 1 kHz (t_s, q1..q7 in rad) by inverse kinematics, checked "
        "against the datasheet's joint position, velocity, acceleration and jerk limits; needs a [robot] table "
        'with model = "panda"; exit code 1 when the arm cannot follow (files are still written)',
    )
    parser.add_argument(
        "--fit-joints",
        action="store_true",
        help="with --joints: when the arm cannot follow, re-plan with lower Cartesian limits until it can "
        "(slower; the JSON's joints.fit lists each attempt's T in s)",
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print a JSON summary (T_s in s, solve_time_s in s, iterations, status, max_tilt_deg, "
        "max_tilt_rate_deg_s, limits_ok, verification, per-segment figures) on stdout",
    )


def run(args: argparse.Namespace) -> int:
    """Load, plan, then write the CSV (and report) only after everything succeeded."""
    from sloshid.planning.planner import VERIFY_AFTER_DEG, VERIFY_DURING_DEG, plan
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    if not str(args.output).lower().endswith(".csv"):
        raise UserError(f"the output {args.output} must be a .csv file.")
    scenario = load_scenario(args.scenario)
    params = resolve_liquid(scenario, args.params)
    joints = getattr(args, "joints", None)
    if joints is not None:
        if not str(joints).lower().endswith(".csv"):
            raise UserError(f"--joints {joints} must be a .csv file.")
        if scenario.arm is None:
            raise UserError(
                '--joints needs a [robot] table with model = "panda" (and base_xyz_m, q_start) in the scenario.'
            )
    elif getattr(args, "fit_joints", False):
        raise UserError("--fit-joints needs --joints JOINTS.csv.")
    result = plan(scenario, params, progress=sys.stderr.isatty())
    fit = []
    if joints is not None:
        from sloshid.planning.arm import check_joints, fit_to_joints

        check = check_joints(result.trajectory, scenario.arm)
        if args.fit_joints and not check.executable:
            result, check, fit = fit_to_joints(scenario, params, result, check)
        result.joints = check
    report = None
    if args.report:
        from sloshid.planning.report import plan_report

        report = plan_report(result, scenario)
    result.trajectory.to_csv(args.output)
    if joints is not None:
        result.joints.write_csv(joints)
    if report is not None:
        report.save(args.report)
    if result.max_path_deviation_m is not None and not result.path_ok:
        print(
            f"sloshid: warning: the trajectory leaves the path by {result.max_path_deviation_m * 1e3:.3f} mm, more "
            f"than [path].path_tolerance_m = {result.path_tolerance_m * 1e3:g} mm.",
            file=sys.stderr,
        )
    if fit:
        print(
            f"sloshid: re-planned {len(fit) - 1} time(s) with lower Cartesian limits for the joints: T "
            + " -> ".join(f"{f.T_s:.3f}" for f in fit)
            + f" s (+{100 * (fit[-1].T_s / fit[0].T_s - 1):.1f} %).",
            file=sys.stderr,
        )
    for usage in result.limits:
        if not usage.ok:
            print(
                f"sloshid: warning: robot limit {usage.quantity} exceeded: peak {usage.peak:.4g} > {usage.limit:.4g} "
                f"at t = {usage.t_peak_s:.3f} s.",
                file=sys.stderr,
            )
    v = result.verification
    if not result.verification_ok:
        print(
            f"sloshid: warning: verification failed: liquid-container angle {v.peak_during_deg:.3g} deg during the "
            f"move (limit {VERIFY_DURING_DEG}) and {v.residual_deg:.3g} deg after (limit {VERIFY_AFTER_DEG}).",
            file=sys.stderr,
        )
    if args.json:
        summary = result.to_dict()
        if fit and summary["joints"] is not None:
            summary["joints"]["fit"] = [vars(f) for f in fit]
        print(json.dumps(summary, indent=2))
    else:
        print(
            f"planned {len(result.segments)} segment(s): T = {result.T_s:.4f} s, solved in {result.solve_time_s:.3f} s "
            f"({result.status}); max tilt {result.max_tilt_deg:.2f} deg; robot limits "
            f"{'ok' if result.limits_ok else 'EXCEEDED'}; liquid-container angle {v.peak_during_deg:.4f} deg "
            f"during, {v.residual_deg:.4f} deg after; wrote {args.output}"
            + (f" and {joints}" if joints is not None else "")
        )
    if result.joints is not None and not result.joints.executable:
        hint = "" if args.fit_joints else " (--fit-joints re-plans slower until it can)"
        print(f"sloshid: not executable on the Panda: {result.joints.reason()}{hint}", file=sys.stderr)
        return 1
    return 0
