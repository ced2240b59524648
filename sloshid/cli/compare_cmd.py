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
from pathlib import Path

from sloshid.core.errors import UserError


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


def table_text(summary: dict) -> str:
    """The score table as aligned plain text."""
    head = f"{'method':34s} {'T_s':>7s} {'peak_deg':>9s} {'resid_deg':>9s} {'tilt_deg':>8s} {'limits':>7s}"
    lines = [head]
    for m in summary["methods"]:
        if not m["applicable"]:
            lines.append(f"{m['label']:34s} not applicable: {m['reason']}")
            continue
        ok = "ok" if m["robot_limits_ok"] and m["move_limits_ok"] else "FAIL"
        lines.append(
            f"{m['label']:34s} {m['transfer_time_s']:7.3f} {m['peak_during_deg']:9.3f} "
            f"{m['residual_deg']:9.3f} {m['peak_tilt_deg']:8.2f} {ok:>7s}"
        )
    return "\n".join([*lines, "", summary["verdict"]])


def run(args: argparse.Namespace) -> int:
    """Load and validate everything first (nothing is written on bad input), compare, then write outputs."""
    from sloshid.comparison.compare import compare, from_scenario
    from sloshid.model.pendulum import IdentifiedFrequency
    from sloshid.planning.scenario import load_scenario, resolve_liquid

    scenario = load_scenario(args.scenario)
    params = resolve_liquid(scenario, args.params)
    interval = IdentifiedFrequency.from_identify_json(args.params).ci95_hz if args.params else None
    inp = from_scenario(scenario, params, interval)
    if args.report is not None and (args.report.endswith((".html", ".htm")) or Path(args.report).is_file()):
        raise UserError(f"--report takes a directory (index.html is written inside it), got {args.report}.")
    comp = compare(inp, progress=sys.stderr.isatty())
    summary = comp.to_dict()
    if args.report is not None:
        from sloshid.comparison.report import save_report

        path = save_report(comp, args.report)
        print(f"report written to {path}", file=sys.stderr)
    print(json.dumps(summary, indent=2) if args.json else table_text(summary))
    return 0
