"""The `sloshid` command line: one module per command under sloshid/commands, errors as one sentence."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from sloshid import __version__
from sloshid.core.errors import UserError

COMMANDS: dict[str, str] = {
    "synth": "render a synthetic float video with exact ground truth (for testing the tracker)",
    "track": "measure the float's angle in every frame of a video, relative to the image or container",
    "identify": "find the sloshing frequency, damping, pendulum length and damping constant of a signal",
    "plan": "plan a time-optimal, slosh-free container move (CasADi) and write a 1 kHz robot trajectory",
    "predict": "predict the liquid's response (angles, wall height) to any recorded container motion or pose log",
    "validate": "score a model's predictions against measured moves (alignment, NRMSE fit, peak error, report)",
    "compare": "score the plan against constant-acceleration, input shaping, jerk-limited and feedback moves",
    "run": "run a declared pipeline (track, identify, plan, compare, report) with caching",
    "batch": "track and identify many videos in parallel on Dask",
}


class _Formatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Show defaults and keep the description's line breaks."""


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The top-level parser; only the command module `only` is imported, which keeps start-up fast."""
    parser = argparse.ArgumentParser(
        prog="sloshid",
        description="Measure liquid sloshing from video, identify its pendulum model and plan slosh-free "
        "robot moves. Units are SI; angles in files are degrees, counter-clockwise positive as seen.",
        formatter_class=_Formatter,
    )
    parser.add_argument("--version", action="version", version=f"sloshid {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, help_text in COMMANDS.items():
        if name != only:
            sub.add_parser(name, help=help_text)
            continue
        module = importlib.import_module(f"sloshid.cli.{name}_cmd")
        p = sub.add_parser(name, help=help_text, description=module.__doc__, formatter_class=_Formatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: parse, dispatch, and turn UserError into one line on stderr with exit code 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    wanted = next((a for a in argv if a in COMMANDS), None)
    try:
        parser = build_parser(only=wanted)
        args = parser.parse_args(argv)
        if not getattr(args, "command", None):
            parser.print_help()
            return 2
        return int(args._run(args) or 0)
    except UserError as exc:
        print(f"sloshid: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("sloshid: interrupted; finished outputs are kept, nothing half-written was left.", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
