"""Plan a time-optimal, slosh-free container move (seed section III, CasADi + IPOPT) and write it as a 1 kHz
robot trajectory CSV. The container follows the liquid's surface, so the liquid never moves relative to it.
The plan is checked against the robot's Cartesian limits and verified by simulating the liquid independently.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from sloshid.core.outputs import Outputs


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
    """Check every output, load, plan, then write the CSV (and report) only after everything succeeded."""
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.planner import VERIFY_AFTER_DEG, VERIFY_DURING_DEG, plan
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    outputs = Outputs([p for p in (args.scenario, args.params) if p])
    output = outputs.file(args.output, "-o", (".csv",))
    report_dir = outputs.report_dir(args.report) if args.report else None
    scenario = load_scenario(args.scenario)
    params = resolve_liquid(scenario, args.params)
    if args.params:
        freq = IdentifiedFrequency.from_identify_json(args.params)
        if freq.quality not in (None, "good"):
            why = f": {freq.reasons[0]}" if freq.reasons else ""
            print(f"sloshid: warning: the identified frequency is {freq.quality}{why}", file=sys.stderr)
    result = plan(scenario, params, progress=sys.stderr.isatty())
    result.trajectory.to_csv(output)
    if report_dir is not None:
        source = f"identify's {args.params}" if args.params else f"the [liquid] table of {args.scenario}"
        csv = os.path.relpath(os.path.abspath(output), os.path.abspath(report_dir))
        result.report(report_dir, {"trajectory CSV": csv}, liquid_source=source)
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
    print(json.dumps(result.to_dict(), indent=2) if args.json else f"{result.summary()}; wrote {output}")
    return 0
