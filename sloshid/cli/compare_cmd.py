"""Score sloshid's plan against the usual alternatives on the same move, liquid and limits.

Builds the constant-acceleration profile, ZV/ZVD input shaping, ruckig jerk-limited moves (upright and
tilt-compensated), sloshid's plan and its robust variant, and camera feedback on top of the first and of the
plan; scores each by the nonlinear liquid's angle relative to the container (transfer time s, peak during
the move deg, residual after arrival deg, tilt deg and deg/s, robot and move limits), runs the closed-loop,
robustness (frequency +-20 %, damping x0.5..x2) and camera-rate studies, and prints a verdict. Tune it in
the scenario's [compare] table (keys: see the README).
"""

from __future__ import annotations

import argparse
import json
import sys

from sloshid.cli.plan_cmd import note_io_model
from sloshid.core.outputs import Outputs


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid compare`."""
    parser.add_argument(
        "scenario",
        metavar="SCENARIO.toml",
        help="scenario file as for `sloshid plan` (move, limits in m, m/s, m/s^2, deg; optional [compare])",
    )
    parser.add_argument(
        "--params",
        metavar="PARAMS.json",
        default=None,
        help="liquid parameters from `sloshid identify` (omega in rad/s, zeta); default: the scenario's [liquid]",
    )
    parser.add_argument(
        "--report", metavar="DIR", default=None, help="write the HTML report to DIR/index.html (figures embedded)"
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help="print the full summary as JSON (times in s, angles in deg) instead of the table",
    )


def run(args: argparse.Namespace) -> int:
    """Load and validate everything first (nothing is written on bad input), compare, then write outputs."""
    from sloshid.comparison.compare import compare_scenario
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    outputs = Outputs([p for p in (args.scenario, args.params) if p])
    report_dir = outputs.report_dir(args.report, "--report") if args.report is not None else None
    scenario = load_scenario(args.scenario)
    params = resolve_liquid(scenario, args.params)
    note_io_model(args.params, "TRAJ.csv")
    interval = IdentifiedFrequency.from_identify_json(args.params).ci95_hz if args.params else None
    comp = compare_scenario(scenario, params, f_interval_hz=interval, progress=sys.stderr.isatty())
    if report_dir is not None:
        print(f"report written to {comp.report(report_dir)}", file=sys.stderr)
    print(json.dumps(comp.to_dict(), indent=2) if args.json else comp.summary())
    return 0
