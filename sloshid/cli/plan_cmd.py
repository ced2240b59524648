"""Plan a time-optimal, slosh-free container move (seed section III, CasADi + IPOPT) and write it as a 1 kHz
robot trajectory CSV. The container follows the liquid's surface, so the liquid never moves relative to it.
The plan is checked against the robot's Cartesian limits and verified by simulating the liquid independently.
"""

from __future__ import annotations

import argparse
import json
import os
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
        "--json",
        action="store_true",
        help="print a JSON summary (T_s in s, solve_time_s in s, iterations, status, max_tilt_deg, "
        "max_tilt_rate_deg_s, limits_ok, verification, per-segment figures) on stdout",
    )


def run(args: argparse.Namespace) -> int:
    """Load, plan, then write the CSV (and report) only after everything succeeded."""
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.planner import VERIFY_AFTER_DEG, VERIFY_DURING_DEG, plan
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    if not str(args.output).lower().endswith(".csv"):
        raise UserError(f"the output {args.output} must be a .csv file.")
    scenario = load_scenario(args.scenario)
    params = resolve_liquid(scenario, args.params)
    if args.params:
        freq = IdentifiedFrequency.from_identify_json(args.params)
        if freq.quality not in (None, "good"):
            why = f": {freq.reasons[0]}" if freq.reasons else ""
            print(f"sloshid: warning: the identified frequency is {freq.quality}{why}", file=sys.stderr)
    result = plan(scenario, params, progress=sys.stderr.isatty())
    report = None
    if args.report:
        from sloshid.planning.report import plan_report

        source = f"identify's {args.params}" if args.params else f"the [liquid] table of {args.scenario}"
        csv = os.path.relpath(os.path.abspath(args.output), os.path.abspath(args.report))
        report = plan_report(result, scenario, source, {"trajectory CSV": csv})
    result.trajectory.to_csv(args.output)
    if report is not None:
        report.save(args.report)
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
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(
            f"planned {len(result.segments)} segment(s): T = {result.T_s:.4f} s, solved in {result.solve_time_s:.3f} s "
            f"({result.status}); max tilt {result.max_tilt_deg:.2f} deg; robot limits "
            f"{'ok' if result.limits_ok else 'EXCEEDED'}; liquid-container angle {v.peak_during_deg:.4f} deg "
            f"during, {v.residual_deg:.4f} deg after; wrote {args.output}"
        )
    return 0
