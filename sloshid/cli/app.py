"""The `sloshid` command line: one module per command (`sloshid/cli/<name>_cmd.py`), errors as one sentence."""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import re
import signal
import sys
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import NoReturn

from sloshid.cli.naming import as_typed, flag_for, options_of
from sloshid.core.errors import SettingError, SloshidWarning, UserError, pipes_read_once

COMMANDS: dict[str, str] = {
    "synth": "render a synthetic float or dyed-liquid video with exact ground truth (for testing the tracker)",
    "inspect": "look at one frame of your video: what each target would track there, and the track command to run",
    "track": "measure the float's (or the liquid surface's) angle in every frame, relative to image or container",
    "identify": "find the sloshing frequency, damping, pendulum length and damping constant of a signal",
    "plan": "plan a time-optimal, slosh-free container move (CasADi) and write a 1 kHz robot trajectory",
    "predict": "predict the liquid's response (angles, wall height) to any recorded container motion or pose log",
    "validate": "score a model's predictions against measured moves (alignment, NRMSE fit, peak error, report)",
    "compare": "score the plan against constant acceleration, input shaping, jerk-limited, TOPP-RA and feedback",
    "run": "run a declared pipeline (track, identify, plan, compare, report) with caching",
    "batch": "track and identify many videos in parallel on Dask",
}


class Terminated(BaseException):
    """SIGTERM as an exception, so that every `finally` runs and no half-written temporary file is left."""


class _Version(argparse.Action):
    """--version: the installed version, looked up only when asked for (the lookup slows every command's start)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        from sloshid import __version__

        print(f"sloshid {__version__}")
        parser.exit()


class _Parser(argparse.ArgumentParser):
    """argparse with a mistake reported as one line like every other error, not after the whole usage block."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"sloshid: error: {message} (`{self.prog} --help` lists the options).\n")


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Keep the description's line breaks; show a default only where there is one worth showing."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "%(default)" in text or action.default in (None, False, argparse.SUPPRESS) or action.required:
            return text
        if "default" in text:  # the help already says what happens by default
            return text
        return f"{text} (default: %(default)s)"


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The top-level parser; only the command module `only` is imported, which keeps start-up fast."""
    parser = _Parser(
        prog="sloshid",
        description="Measure liquid sloshing from video, identify its pendulum model and plan slosh-free "
        "robot moves. Units are SI; angles in files are degrees, counter-clockwise positive as seen.",
        formatter_class=_Formatter,
    )
    parser.add_argument("--version", action=_Version, help="show the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, help_text in COMMANDS.items():
        if name != only:
            sub.add_parser(name, help=help_text)
            continue
        module = importlib.import_module(f"sloshid.cli.{name}_cmd")
        p = sub.add_parser(name, help=help_text, description=module.__doc__, formatter_class=_Formatter)
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _options=options_of(p))
    return parser


def _subparser(parser: argparse.ArgumentParser, name: str | None) -> argparse.ArgumentParser | None:
    """The parser of command `name`, if one was named."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and name in action.choices:
            return action.choices[name]
    return None


def _join_negative_values(argv: list[str], sub: argparse.ArgumentParser | None) -> list[str]:
    """`--roi -5,0,10,10` as `--roi=-5,0,10,10`: argparse would take a value that starts with '-' for an option."""
    if sub is None:
        return argv
    takes_value = {o for a in sub._actions if a.nargs is None and a.option_strings for o in a.option_strings}
    out: list[str] = []
    skip = False
    for i, word in enumerate(argv):
        if skip:
            skip = False
            continue
        nxt = argv[i + 1] if i + 1 < len(argv) else ""
        if word in takes_value and re.match(r"-[\d.]", nxt):
            out.append(f"{word}={nxt}")
            skip = True
        else:
            out.append(word)
    return out


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated


def _fail(message: str) -> int:
    """Print one sentence on stderr; exit code 2."""
    print(f"sloshid: error: {message}", file=sys.stderr)
    return 2


_PATH_TROUBLE = {
    errno.ENAMETOOLONG: "a file or folder name in it is longer than the file system allows (255 bytes)",
    errno.ENOTDIR: "a part of it that should be a folder is a file",
    errno.ELOOP: "its symbolic links go round in a loop",
    errno.EROFS: "it is on a read-only file system",
    errno.ENOSPC: "the disk is full",
}
"""The file system's refusals of a path, in words: any other one is named by the system's own message."""


def _matplotlib_folder() -> None:
    """Matplotlib's settings and font cache in a private folder of the temporary directory when its own folder cannot
    be written (a read-only or odd HOME): it said so in two lines on stderr before every report command's output."""
    if "MPLCONFIGDIR" in os.environ:
        return
    probe = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config") / "matplotlib"
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if probe.is_dir() and os.access(probe, os.W_OK | os.X_OK):
        return
    private = Path(tempfile.gettempdir()) / f"sloshid-matplotlib-{os.getuid()}"
    with contextlib.suppress(OSError):
        private.mkdir(mode=0o700, exist_ok=True)
        os.environ["MPLCONFIGDIR"] = str(private)


def _reopen_closed_streams() -> None:
    """Standard output or error closed by the caller (`cmd >&-`): /dev/null in its place, so that printing works and no
    file this run opens is given its descriptor (where a library's writes to it would land)."""
    for fd, name in ((1, "stdout"), (2, "stderr")):
        try:
            os.fstat(fd)
        except OSError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), fd)
            setattr(sys, name, open(fd, "w", closefd=False))  # noqa: SIM115 - the stream lives as long as the process


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: parse, dispatch, and turn a UserError into one line on stderr with exit code 2."""
    with warnings.catch_warnings(), pipes_read_once():  # a pipe (`--params <(...)`) is read once, by every step
        # a command prints the warnings its results collect, in its own words: Python's copy would repeat each one
        warnings.simplefilter("ignore", SloshidWarning)
        return _main(argv)


def _main(argv: Sequence[str] | None) -> int:
    """main's work, with the library's warnings left to the command to print."""
    argv = list(sys.argv[1:] if argv is None else argv)
    _reopen_closed_streams()
    os.environ.setdefault("MPLBACKEND", "Agg")  # a command draws figures into files, never into windows
    _matplotlib_folder()
    wanted = next((a for a in argv if a in COMMANDS), None)
    args = None
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    smooth: ModuleType | None = None
    if wanted == "track" and not {"-h", "--help", "--no-smooth"} & set(argv):
        smooth = importlib.import_module("sloshid.tracking.smooth")  # NumPy only; forks early (see start_early)
        smooth.start_early()
    try:
        parser = build_parser(only=wanted)
        sub = _subparser(parser, wanted)
        argv = _join_negative_values(argv, sub)
        args, extra = parser.parse_known_args(argv)
        if extra:  # reported by the command's own parser, so the usage shown is the command's
            (sub or parser).error(f"unrecognized arguments: {' '.join(extra)}")
        if not getattr(args, "command", None):
            parser.print_help()
            return 2
        code = int(args._run(args) or 0)
        sys.stdout.flush()
        return code
    except SettingError as exc:
        options = getattr(args, "_options", {})
        return _fail(as_typed(str(exc.named(lambda setting: flag_for(setting, options))), args))
    except UserError as exc:
        return _fail(as_typed(str(exc), args))
    except PermissionError as exc:  # a file or folder of the user's that this user may not read or enter
        what = f" {exc.filename}" if exc.filename else ""
        return _fail(f"permission denied for{what}: this user may not read or write it, or enter its folder.")
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EPIPE, errno.EIO) and exc.filename is None:  # standard output failed
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so the exit-time flush cannot fail
            return _fail(f"could not write to standard output ({exc.strerror}).")
        if exc.filename is None:
            raise
        return _fail(
            f"could not use {exc.filename}: {_PATH_TROUBLE.get(exc.errno or 0, exc.strerror or 'unknown error')}."
        )
    except ValueError as exc:
        if "null byte" not in str(exc):
            raise
        return _fail("a path holds a NUL byte, which no file system takes.")  # a TOML string's \u0000 reaches os calls
    except (KeyboardInterrupt, Terminated):
        print("sloshid: interrupted; finished outputs are kept, nothing half-written was left.", file=sys.stderr)
        return 130 if not isinstance(sys.exc_info()[1], Terminated) else 143
    finally:
        if smooth is not None:
            smooth.discard_early()
        signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
