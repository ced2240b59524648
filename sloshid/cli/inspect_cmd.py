"""A first look at your own video: what each target would track in one frame, and the `sloshid track` command to run.

Reads one frame (the first, or the one shown at --at SECONDS) and writes a picture of it in two panels. VIDEO may
also be a still picture (a PNG or JPEG frame of it): then --at is left out, and the command printed names VIDEO for
the video the picture is a frame of, as track measures a video. Left, the surface target (a dyed liquid): the region
of every colour preset found, with its share of the picture, and what track measures there: the liquid's sides (the
container's inner walls, blue), the surface line (green when measured, red when not) and its height at each wall
(yellow). Right, the float target: every region of a preset colour as a float candidate (its elongation and angle;
track wants a bar, elongation 0.5 or more) and the one track would take. White on both: a suggested --roi around the
container (or the float).

Prints what it found for each target and the `sloshid track` command line to run next (target, colour preset,
--roi when it helps, --reference container when the container's walls were found). Of several colours measured as a
surface, the one between the container's walls is taken (track's automatic dye takes the largest, or, when that is
dark, a coloured one measured between walls). When no preset colour gives a liquid or a float, it says what it saw
(how coloured the picture is, its largest coloured regions) and measures the largest with an HSV range of its own,
which the command then gives (--liquid-hsv-low/high).

Looking at the first frame of a video, it tries the command on the video's first two seconds and says how many of
their frames it measured validly; where the command names a colour or an ROI of inspect's, it also tries track with
its own choices (your --roi kept), and prints that command instead when the suggested one measured under half the
frames and track's own at least a tenth of them more. With --float-color NAME the command tracks that float where
the frame shows it, with the preset's range relaxed as track relaxes it where the preset finds nothing (a thin float's
colour mixes with the liquid's under it).

Exit codes: 0 when the command printed measured at least half the frames tried (not tried, a still picture or a later
frame: when its target was measured in this frame), 1 when something was found that track would not measure so (the
text says why), 2 when nothing was found or the input is bad (a file that is neither a video nor a picture, --at
outside the video or with a picture, an output over the input): one sentence on stderr; no picture is written for bad
input.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

from sloshid.cli import track_cmd
from sloshid.cli.naming import as_typed, options_of
from sloshid.cli.settings_options import add_settings, comma_values
from sloshid.core.errors import UserError
from sloshid.core.outputs import Outputs
from sloshid.tracking.inspect import default_picture_path, inspect_video
from sloshid.tracking.tracker import TrackSettings


def track_options() -> dict[str, str]:
    """`sloshid track`'s options by setting: the suggestions and notes speak of them."""
    parser = argparse.ArgumentParser(add_help=False)
    track_cmd.add_arguments(parser)
    return options_of(parser)


def track_command(video: Path, settings: dict[str, Any], options: dict[str, str]) -> str:
    """The `sloshid track VIDEO -o STEM_angles.csv ...` line that tracks with `settings` (quoted where needed)."""
    words = ["sloshid", "track", str(video), "-o", str(video.with_name(f"{video.stem}_angles.csv"))]
    for name, value in settings.items():
        words += [options[name], ",".join(str(v) for v in value) if isinstance(value, tuple) else str(value)]
    return shlex.join(words)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid inspect`, each with its unit."""
    parser.add_argument(
        "video",
        type=Path,
        metavar="VIDEO",
        help="video file FFmpeg can decode, or a still picture of one of its frames (PNG, JPEG)",
    )
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="PICTURE.png",
        help="picture to write (default: VIDEO's name with _inspect.png beside it, only when no file is there yet)",
    )
    parser.add_argument(
        "--at",
        type=float,
        metavar="SECONDS",
        help="look at the frame shown at this presentation time, s from the video's start (default: the first; "
        "not with a still picture)",
    )
    parser.add_argument(
        "--roi",
        metavar="X,Y,W,H",
        help="look only inside this region: left x, top y, width, height in pixels (default: whole frame); one that "
        "cuts the container's walls is widened a tenth on each side, as track widens it",
    )
    title = "your float (not given: every preset looked at, a measured liquid's surface suggested first)"
    add_settings(parser, TrackSettings, only=("float_color",), title=title)


def _picture_path(args: argparse.Namespace) -> Path:
    """-o, checked; or VIDEO_inspect.png beside the video when no file is there (a default replaces nothing)."""
    outputs = Outputs([args.video])
    if args.output is not None:
        return outputs.file(args.output, "-o", (".png",))
    default = default_picture_path(args.video)
    if default.exists() or default.is_symlink():
        raise UserError(f"{default} already exists; give -o PICTURE.png to say where the picture goes.")
    return outputs.file(default, "the picture", (".png",))


def run(args: argparse.Namespace) -> int:
    """Check the output, look at the frame, write the picture, print what was found and the command to run."""
    picture = _picture_path(args)
    roi = comma_values(args.roi, int, 4, "--roi", "X,Y,W,H") if args.roi is not None else None
    result = inspect_video(args.video, args.at, roi, args.float_color)
    result.save_picture(picture)
    options = track_options()
    video = Path("VIDEO") if result.still else args.video  # track takes the video a picture is a frame of
    text = as_typed(result.summary(lambda settings: track_command(video, settings, options)), args, options)
    found, _, next_line = text.rpartition("\n") if text.rsplit("\n", 1)[-1].startswith("next: ") else (text, "", "")
    print(found)
    print(f"wrote {picture}")
    if next_line:  # the last line, as every command's: the one a user runs next
        print(next_line)
    if result.target is None:
        where = f"the picture {args.video}" if result.still else f"the frame at {result.t_s:.2f} s of {args.video}"
        print(
            f"sloshid: error: nothing track could follow was found in {where}: {result.saw}; see {picture}.",
            file=sys.stderr,
        )
        return 2
    return 0 if result.works else 1
