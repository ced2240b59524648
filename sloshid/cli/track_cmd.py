"""Measure the float's in-plane angle in every frame of a video and write one CSV row per frame.

The float is found by colour (an OpenCV HSV range or a named preset) and its angle is measured to a
fraction of a degree from the grey-level moments of a soft colour-membership map. With
--reference image the angle is against the image horizontal; with --reference container it is
relative to the container's side walls (static camera, moving container): measured in every frame while the
container moves, in every 6th while it stands still (the frames between interpolated).
Timestamps are the video's own presentation times. Angles are degrees, counter-clockwise positive as
seen. Columns: frame, t_s, angle_deg, float_angle_deg, container_angle_deg, x_px, y_px, quality (0..1),
valid (0/1), angle_smoothed_deg (Kalman + RTS smoother on the real timestamps, bridges valid = 0 rows),
key_frame (0/1: the video's key frames, where the encoder's hold restarts; identify uses them).

With --target surface the dyed liquid itself is measured: angle_deg is the surface's best-fit line across the
container's inner width, and left_wall_px/right_wall_px (left_wall_mm/right_wall_mm with
--container-diameter-m) its height at each inner wall above the rest level (surface_angle_deg replaces
float_angle_deg).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import textwrap
from pathlib import Path

from sloshid.cli.naming import as_typed
from sloshid.cli.settings_options import add_settings, settings_from
from sloshid.core.errors import NothingFound, UserError
from sloshid.core.outputs import Outputs
from sloshid.tracking.inspect import default_picture_path, inspect_video
from sloshid.tracking.tracker import LOST_NOTE, TrackSettings, track_video
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, PRESETS, format_hsv
from sloshid.video.frames import VIDEO_SUFFIXES

GROUPS = {"surface": "liquid surface (--target surface)"}
"""Titles of the help's groups of TrackSettings fields."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid track`: the input and outputs, then one per TrackSettings field (settings_options)."""
    parser.add_argument("video", type=Path, metavar="VIDEO", help="video file FFmpeg can decode")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="ANGLES.csv", help="CSV file to write")
    parser.add_argument(
        "--overlay",
        type=Path,
        metavar="OUT.mp4",
        help="also write the video with the detected float, the reference and the angle drawn on it",
    )
    add_settings(parser, TrackSettings, GROUPS)
    presets = ", ".join(f"{n} ({format_hsv(p.hsv.low)} .. {format_hsv(p.hsv.high)})" for n, p in PRESETS.items())
    parser.epilog = textwrap.fill(
        f"Colour presets (OpenCV HSV low .. high): {presets}; the float's default is {DEFAULT_FLOAT_COLOR}.", 100
    )


def _first_look(video: Path, roi: tuple[int, int, int, int] | None) -> Path | None:
    """Where nothing could be tracked: `sloshid inspect`'s picture of the first frame, written beside the video as
    VIDEO_inspect.png when no file is there (None when one is, or the picture cannot be made)."""
    picture = default_picture_path(video)
    if picture.exists() or picture.is_symlink():
        return None
    try:
        return inspect_video(video, None, roi).save_picture(picture)
    except UserError:
        return None


def run(args: argparse.Namespace) -> int:
    """Check the outputs, track, write the CSV (and overlay), report warnings; exit 1 when the video was truncated."""
    settings = settings_from(args, TrackSettings)
    outputs = Outputs([args.video])
    output = outputs.file(args.output, "-o", (".csv",))
    overlay = outputs.file(args.overlay, "--overlay", VIDEO_SUFFIXES) if args.overlay else None
    try:
        result = track_video(args.video, settings, overlay=overlay, progress=True)
    except NothingFound as err:
        picture = None if overlay else _first_look(args.video, settings.roi)
        if picture is None:
            raise
        raise err.with_hint(
            f"see {picture} (what each target finds in the video's first frame, drawn as `sloshid inspect` does)"
        ) from None
    result.to_csv(output)
    for warning in result.warnings:
        print(f"sloshid: warning: {as_typed(warning, args)}", file=sys.stderr)
    print(result.summary() + f"; wrote {output}" + (f" and {overlay}" if overlay else ""))
    print(next_step(result, output, overlay))
    return 1 if result.lost_share > LOST_NOTE else 0


def next_step(result, output: Path, overlay: Path | None) -> str:
    """The line a user needs next: identify the liquid from the trace, its parameters beside it (ANGLES_params.json:
    clips tracked in one folder do not share a name), unless nothing moved the angle (`still`, which the tracker
    warned of), where identify finds no mode."""
    if not result.still:
        params = output.with_name(output.stem + "_params.json")
        command = shlex.join(["sloshid", "identify", str(output), "-o", str(params)])  # runs as printed: quoted
        return f"next: {command} identifies the liquid from this angle trace."
    look = f"look at {shlex.quote(str(overlay))}" if overlay else "check what was tracked with --overlay OUT.mp4"
    return (
        f"next: nothing moved the {result.target}, so identify would find no mode: record a tap that sets the liquid "
        f"swinging, or {look}, then track again."
    )
