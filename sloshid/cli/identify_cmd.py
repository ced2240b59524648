"""Identify the sloshing mode of one or more recorded signals: free-decay window, Welch PSD, damped PT2 least-squares
fit with honest 95 % intervals. Writes frequency, damping ratio, pendulum length l (m) and, with --mass, damping
constant d (N s/m) to a JSON file, prints a summary with a good/uncertain verdict, and optionally an HTML report.
Several signals give one joint estimate (shared frequency and damping, own amplitude per signal)."""

from __future__ import annotations

import argparse
import shlex
import sys

from sloshid.cli.naming import as_typed
from sloshid.cli.settings_options import add_settings, given_settings, options_of_settings, settings_from
from sloshid.core.errors import UserError
from sloshid.core.results import TableResult

GROUPS = {"io": "input-output identification (with --trajectory)"}
"""Titles of the help's groups of settings fields."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid identify`: inputs and outputs, then one per IdentSettings, SignalColumns and IOSettings
    field (settings_options)."""
    from sloshid.identification.estimator import IdentSettings
    from sloshid.validation.iofit import IOSettings

    parser.add_argument(
        "signals",
        nargs="+",
        metavar="SIGNAL",
        help="signal files: a `sloshid track` CSV (angle_deg of frames with valid = 1), any CSV with "
        "a time column in seconds, or a MATLAB .mat file",
    )
    parser.add_argument("-o", "--output", required=True, metavar="PARAMS.json", help="parameter JSON to write")
    parser.add_argument("--report", metavar="DIR", help="write a self-contained HTML report to DIR/index.html")
    add_settings(parser, IdentSettings)
    add_column_arguments(parser)
    parser.add_argument(
        "--trajectory",
        action="append",
        metavar="TRAJECTORY",
        help="input-output identification: the trajectory or pose log that caused each signal (once per signal, same "
        "order); fits f, zeta, the breaking drag, the wall's wave share and crest coefficient, the reading's rest "
        "tilts along x and y and, with --views-deg, the views' arc (each toward its physical prior and within its "
        "physical range: the mode from --container-radius-m and --fill-height-m when given) and each run's lag and "
        "offset to the whole records (see `sloshid predict` for the pose options)",
    )
    add_settings(parser, IOSettings, GROUPS)


def add_column_arguments(parser: argparse.ArgumentParser) -> None:
    """Which column (CSV) or variable (.mat) of a signal file holds the time and the signal: identify's and
    validate's measured files (the SignalColumns fields)."""
    from sloshid.identification.stage import SignalColumns

    add_settings(parser, SignalColumns)


def run(args: argparse.Namespace) -> int:
    """Check the outputs, identify, print the summary, write JSON (and report) atomically."""
    from sloshid.core.atomic import write_json
    from sloshid.core.outputs import Outputs
    from sloshid.identification.estimator import IdentSettings
    from sloshid.identification.stage import SignalColumns, identify_sources, to_signal
    from sloshid.validation.iofit import IOSettings

    # the input-output fit needs the radius alone (for wall heights); the prior needs it with the fill height
    prior_radius = args.container_radius_m if args.trajectory is None or args.fill_height_m else None
    settings = settings_from(args, IdentSettings, container_radius_m=prior_radius)
    io_settings = settings_from(args, IOSettings)  # range-checked before any file is read
    io_options = options_of_settings(IOSettings)
    given = [io_options[name] for name in given_settings(args, IOSettings)]
    if args.trajectory is None and given:
        verb = "applies" if len(given) == 1 else "apply"
        raise UserError(f"{' and '.join(given)} {verb} only with --trajectory (input-output identification).")
    outputs = Outputs([*args.signals, *(args.trajectory or [])])
    output = outputs.file(args.output, "-o", (".json",))
    report_dir = outputs.report_dir(args.report, "--report") if args.report else None
    columns = settings_from(args, SignalColumns)

    def warn(text: str) -> None:
        print(f"sloshid: warning: {as_typed(text, args)}", file=sys.stderr)

    result: TableResult  # an IOFit or an IdentResult: the same contract
    if args.trajectory is not None:  # input-output: the whole record, forced response and free decay
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
            io_settings,
        )
    else:
        result = identify_sources(args.signals, settings, columns, warn=warn, progress=True)
    doc = result.to_dict()
    if report_dir is not None:
        result.report(report_dir)
    write_json(output, doc)
    print(as_typed(result.summary(), args))
    print(f"wrote {output}" + (f" and {report_dir / 'index.html'}" if report_dir else ""))
    print(
        f"next: sloshid plan SCENARIO.toml --params {shlex.quote(str(output))} -o TRAJ.csv plans a slosh-free move "
        "for this liquid."
    )
    return 0
