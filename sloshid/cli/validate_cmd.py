"""Check a liquid model against measured moves: predict each trajectory, align the prediction with its measurement
by cross-correlation over the move (lag and correlation reported), and score it as system identification does:
NRMSE fit % = 100 (1 - |y - yhat| / |y - mean y|) and peak error %, over the record and per phase (during the move,
after it). Measured wall heights (mm, e.g. the antisloshing .mat files) lose the quiet lead-in's baseline and are
compared with the model's wall reading: R x the slope of the static surface plus wave_share x the first mode's wave,
with a crest term (an input-output `identify` fits both; else 1 and 0: the plane of the pendulum's surface); measured
angles (deg) with the arctangent of that slope. Several runs give a table and the
medians."""

from __future__ import annotations

import argparse
import json
import sys

from sloshid.cli.identify_cmd import add_column_arguments
from sloshid.cli.predict_cmd import add_geometry_arguments
from sloshid.core.errors import UserError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid validate`."""
    parser.add_argument(
        "--trajectory", required=True, action="append", metavar="T", help="trajectory or pose log (once per run)"
    )
    parser.add_argument(
        "--measured", required=True, action="append", metavar="M", help="measured signal, .mat or CSV (once per run)"
    )
    parser.add_argument("--params", required=True, metavar="PARAMS.json", help="parameters from `sloshid identify`")
    parser.add_argument("--report", metavar="DIR", help="write the HTML report to DIR/index.html")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON instead of the table")
    add_geometry_arguments(parser)
    add_column_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Load and check all inputs first (nothing is written on bad input), validate each run, print, report."""
    from sloshid.cli.settings_options import settings_from
    from sloshid.core.outputs import Outputs
    from sloshid.identification.signals import check_csv_options, load_signal
    from sloshid.model.pose import load_pose_log
    from sloshid.validation.predict import GeometrySettings, load_model
    from sloshid.validation.validate import validate

    geometry = settings_from(args, GeometrySettings)  # range-checked before any file is read
    outputs = Outputs([*args.trajectory, *args.measured, args.params])
    report_dir = outputs.report_dir(args.report, "--report") if args.report is not None else None
    model = load_model(args.params).with_geometry(
        geometry.container_radius_m, geometry.axis_offset_m, geometry.smooth_s
    )
    if len(args.trajectory) != len(args.measured):
        raise UserError(
            f"give one --trajectory per --measured, in the same order: {len(args.trajectory)} trajectories, "
            f"{len(args.measured)} measurements."
        )
    poses = [load_pose_log(t, geometry.pose_columns) for t in args.trajectory]
    check_csv_options(args.measured, args.time_col, args.value_col, args.time_var, args.value_var)
    columns = (args.time_col, args.value_col, args.time_var, args.value_var)
    result = validate(poses, [load_signal(m, *columns) for m in args.measured], model)
    for warning in result.warnings:
        print(f"sloshid: warning: {warning}", file=sys.stderr)
    page = result.report(report_dir) if report_dir is not None else None
    if page is not None:
        print(f"report written to {page}", file=sys.stderr)  # stdout: the table or JSON alone
    print(json.dumps(result.to_dict(), indent=2) if args.json else result.summary())
    step = (
        f"open {page} (each run against its 95 % band)"
        if page
        else "add --report DIR to draw each run against its band"
    )
    print(f"next: {step}.", file=sys.stderr if args.json else sys.stdout)
    return 0
