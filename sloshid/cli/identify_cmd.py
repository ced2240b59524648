"""Identify the sloshing mode of one or more recorded signals: free-decay window, Welch PSD, damped PT2 least-squares
fit with honest 95 % intervals. Writes frequency, damping ratio, pendulum length l (m) and, with --mass, damping
constant d (N s/m) to a JSON file, prints a summary with a good/uncertain verdict, and optionally an HTML report.
Several signals give one joint estimate (shared frequency and damping, own amplitude per signal)."""

from __future__ import annotations

import argparse
import sys

from sloshid.cli.naming import as_typed
from sloshid.core.errors import UserError
from sloshid.core.results import TableResult

TRAJECTORY_ONLY = {
    "--axis-offset-m": "axis_offset_m",
    "--pose-columns": "pose_columns",
    "--smooth-s": "smooth_s",
    "--views-deg": "views_deg",
}
"""Options of input-output identification, refused without --trajectory (they would be ignored)."""
FLAGS = {"mass_kg": "--mass", "window_s": "--window", "f_range_hz": "--f-range", "min_fit_percent": "--min-fit"}
"""Library setting -> option name, where they differ (errors name the option the user typed)."""


def _pair(text: str) -> tuple[float, float]:
    """Parse 'A,B' into two floats."""
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two numbers A,B, got {text!r}") from None
    return a, b


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid identify`."""
    parser.add_argument(
        "signals",
        nargs="+",
        metavar="SIGNAL",
        help="signal files: a `sloshid track` CSV (angle_deg of frames with valid = 1), any CSV with "
        "a time column in seconds, or a MATLAB .mat file",
    )
    parser.add_argument("-o", "--output", required=True, metavar="PARAMS.json", help="parameter JSON to write")
    parser.add_argument("--mass", type=float, metavar="KG", help="liquid mass in kg; needed for the damping constant d")
    parser.add_argument("--report", metavar="DIR", help="write a self-contained HTML report to DIR/index.html")
    parser.add_argument(
        "--window",
        type=_pair,
        metavar="T0,T1",
        help="fit window in seconds of the signals' own time axis; without it the free decay is found automatically",
    )
    parser.add_argument(
        "--f-range",
        type=_pair,
        metavar="LO,HI",
        help="frequency band in Hz searched for the sloshing mode (0.5,30 when not given)",
    )
    parser.add_argument("--drift", action="store_true", help="also fit a slow linear drift of the signal's zero")
    parser.add_argument(
        "--min-fit",
        type=float,
        default=15.0,
        metavar="PERCENT",
        help="NRMSE fit %% below which the verdict is 'uncertain'",
    )
    add_column_arguments(parser)
    parser.add_argument("--container-radius-m", type=float, metavar="M", help="cylinder radius in m (geometric prior)")
    parser.add_argument("--fill-height-m", type=float, metavar="M", help="liquid fill height in m (geometric prior)")
    parser.add_argument(
        "--trajectory",
        action="append",
        metavar="TRAJECTORY",
        help="input-output identification: the trajectory or pose log that caused each signal (once per signal, same "
        "order); fits f, zeta, the wall's wave share and crest coefficient (each toward its physical prior: the "
        "mode from --container-radius-m and --fill-height-m when given) and each run's lag and offset to the whole "
        "records (see `sloshid predict` for the pose options)",
    )
    parser.add_argument(
        "--axis-offset-m",
        type=float,
        metavar="M",
        help="with --trajectory: distance in m along the container axis from the logged point up to the pendulum "
        "pivot (about the liquid surface at rest; default 0)",
    )
    parser.add_argument(
        "--pose-columns",
        metavar="NAMES",
        help="with --trajectory: a headerless log's column names in order (see `sloshid predict --help`)",
    )
    parser.add_argument(
        "--smooth-s",
        type=float,
        metavar="S",
        help="with --trajectory: Savitzky-Golay window in s for the pose log's accelerations (default 0.1)",
    )
    parser.add_argument(
        "--views-deg",
        type=float,
        metavar="DEG",
        help="with --trajectory: the wall height is seen in two planes 90 deg apart fixed to the container, the first "
        "at this azimuth from its x axis (two cameras on the end-effector, as in the shared antisloshing runs: 0); "
        "default: the whole wall's peak",
    )


def add_column_arguments(parser: argparse.ArgumentParser) -> None:
    """Which column (CSV) or variable (.mat) of a signal file holds the time and the signal: identify's and
    validate's measured files."""
    parser.add_argument(
        "--time-col",
        metavar="NAME|INDEX",
        help="CSV time column in seconds (name or 0-based index; default: the column named t_s, time_s, t, time, "
        "times or timestamp, else the first)",
    )
    parser.add_argument(
        "--value-col",
        metavar="NAME|INDEX",
        help="CSV signal column (name or 0-based index; default: a track CSV's angle_deg, of two columns the one "
        "that is not the time; needed for more)",
    )
    parser.add_argument("--time-var", metavar="NAME", help=".mat variable holding the time in seconds")
    parser.add_argument("--value-var", metavar="NAME", help=".mat variable holding the signal")


def run(args: argparse.Namespace) -> int:
    """Check the outputs, identify, print the summary, write JSON (and report) atomically."""
    from sloshid.core.atomic import write_json
    from sloshid.core.outputs import Outputs
    from sloshid.identification.estimator import IdentSettings
    from sloshid.identification.stage import SignalColumns, identify_sources, to_signal

    settings = IdentSettings(
        mass_kg=args.mass,
        window_s=args.window,
        f_range_hz=args.f_range or IdentSettings.f_range_hz,
        drift=args.drift,
        min_fit_percent=args.min_fit,
        # the input-output fit needs the radius alone (for wall heights); the prior needs it with the fill height
        container_radius_m=args.container_radius_m if args.trajectory is None or args.fill_height_m else None,
        fill_height_m=args.fill_height_m,
    )
    given = [f for f, v in TRAJECTORY_ONLY.items() if getattr(args, v) is not None]
    if args.trajectory is None and given:
        verb = "applies" if len(given) == 1 else "apply"
        raise UserError(f"{' and '.join(given)} {verb} only with --trajectory (input-output identification).")
    outputs = Outputs([*args.signals, *(args.trajectory or [])])
    output = outputs.file(args.output, "-o", (".json",))
    report_dir = outputs.report_dir(args.report, "--report") if args.report else None
    columns = SignalColumns(args.time_col, args.value_col, args.time_var, args.value_var)

    def warn(text: str) -> None:
        print(f"sloshid: warning: {as_typed(text, args)}", file=sys.stderr)

    result: TableResult  # an IOFit or an IdentResult: the same contract
    if args.trajectory is not None:  # input-output: the whole record, forced response and free decay
        from sloshid.model.pose import SMOOTH_S
        from sloshid.validation.iofit import fit_io_files

        signals = [to_signal(p, columns, progress=True) for p in args.signals]
        for sig in signals:
            for w in sig.warnings:
                warn(w)
        result = fit_io_files(
            args.trajectory,
            signals,
            settings,
            args.container_radius_m,
            args.axis_offset_m or 0.0,
            SMOOTH_S if args.smooth_s is None else args.smooth_s,
            args.pose_columns,
            args.views_deg,
        )
    else:
        result = identify_sources(args.signals, settings, columns, warn=warn, progress=True)
    doc = result.to_dict()
    if report_dir is not None:
        result.report(report_dir)
    write_json(output, doc)
    print(as_typed(result.summary(), args))
    print(f"wrote {output}" + (f" and {report_dir / 'index.html'}" if report_dir else ""))
    print(f"next: sloshid plan SCENARIO.toml --params {output} -o TRAJ.csv plans a slosh-free move for this liquid.")
    return 0
