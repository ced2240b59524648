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
import sys
from pathlib import Path

from sloshid.cli.naming import as_typed
from sloshid.core.errors import UserError
from sloshid.core.outputs import Outputs
from sloshid.tracking.tracker import LOST_NOTE, TrackSettings, track_video
from sloshid.video.colors import DEFAULT_FLOAT_COLOR, PRESETS, format_hsv, parse_hsv
from sloshid.video.frames import VIDEO_SUFFIXES


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid track`, each with its unit."""
    parser.add_argument("video", type=Path, metavar="VIDEO", help="video file FFmpeg can decode")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="ANGLES.csv", help="CSV file to write")
    presets = ", ".join(f"{n} ({format_hsv(p.hsv.low)} .. {format_hsv(p.hsv.high)})" for n, p in PRESETS.items())
    parser.add_argument(
        "--float-color",
        metavar="NAME",
        help=f"named float colour preset (OpenCV HSV low .. high), default {DEFAULT_FLOAT_COLOR}: {presets}",
    )
    parser.add_argument(
        "--float-hsv-low",
        metavar="H,S,V",
        help="lower corner of the float colour in OpenCV HSV (H 0..179 hue, S and V 0..255); "
        "overrides --float-color; give with --float-hsv-high; H low > H high wraps through red",
    )
    parser.add_argument("--float-hsv-high", metavar="H,S,V", help="upper corner of the float colour in OpenCV HSV")
    parser.add_argument(
        "--roi",
        metavar="X,Y,W,H",
        help="search only this region: left x, top y, width, height in pixels (default: whole frame)",
    )
    parser.add_argument(
        "--reference",
        choices=("image", "container"),
        default="image",
        help="angle against the image horizontal, or against the container's side walls (measured in every frame "
        "while the container moves, in every 6th while it stands still)",
    )
    parser.add_argument(
        "--overlay",
        type=Path,
        metavar="OUT.mp4",
        help="also write the video with the detected float, the reference and the angle drawn on it",
    )
    parser.add_argument("--no-smooth", action="store_true", help="skip the Kalman/RTS angle_smoothed_deg column (NaN)")
    g = parser.add_argument_group("liquid surface (--target surface)")
    g.add_argument(
        "--target",
        choices=("float", "surface"),
        default="float",
        help="float: a coloured float's angle; surface: the dyed liquid's surface angle and its height at each wall",
    )
    g.add_argument(
        "--liquid-color", metavar="NAME", help="dye colour preset (default: the one covering most of frame 0)"
    )
    g.add_argument(
        "--liquid-hsv-low",
        metavar="H,S,V",
        help="lower corner of the dye colour in OpenCV HSV; overrides --liquid-color; give with --liquid-hsv-high",
    )
    g.add_argument("--liquid-hsv-high", metavar="H,S,V", help="upper corner of the dye colour in OpenCV HSV")
    g.add_argument(
        "--rest-frames", type=int, metavar="N", help="the first N frames define rest (default: first second)"
    )
    g.add_argument(
        "--container-diameter-m", type=float, metavar="D", help="inner diameter, m: adds the wall heights in mm"
    )
    g.add_argument(
        "--fov-deg",
        type=float,
        metavar="DEG",
        help="the camera's horizontal field of view, degrees: corrects the angle for the perspective of a camera "
        "above the liquid and a container off the picture's centre (up to a degree or two in a wide view)",
    )


def roi_from_args(text: str | None) -> tuple[int, int, int, int] | None:
    """Parse --roi X,Y,W,H (four whole numbers) or None (track and inspect)."""
    if text is None:
        return None
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise UserError(f"--roi must be four whole numbers X,Y,W,H in pixels, got '{text}'.")
    return values[0], values[1], values[2], values[3]


def run(args: argparse.Namespace) -> int:
    """Check the outputs, track, write the CSV (and overlay), report warnings; exit 1 when the video was truncated."""
    settings = TrackSettings(
        float_color=args.float_color,
        float_hsv_low=parse_hsv(args.float_hsv_low, "--float-hsv-low") if args.float_hsv_low else None,
        float_hsv_high=parse_hsv(args.float_hsv_high, "--float-hsv-high") if args.float_hsv_high else None,
        roi=roi_from_args(args.roi),
        reference=args.reference,
        smooth=not args.no_smooth,
        target=args.target,
        liquid_color=args.liquid_color,
        liquid_hsv_low=parse_hsv(args.liquid_hsv_low, "--liquid-hsv-low") if args.liquid_hsv_low else None,
        liquid_hsv_high=parse_hsv(args.liquid_hsv_high, "--liquid-hsv-high") if args.liquid_hsv_high else None,
        rest_frames=args.rest_frames,
        container_diameter_m=args.container_diameter_m,
        fov_deg=args.fov_deg,
    )
    outputs = Outputs([args.video])
    output = outputs.file(args.output, "-o", (".csv",))
    overlay = outputs.file(args.overlay, "--overlay", VIDEO_SUFFIXES) if args.overlay else None
    result = track_video(args.video, settings, overlay=overlay, progress=True)
    result.to_csv(output)
    for warning in result.warnings:
        print(f"sloshid: warning: {as_typed(warning, args)}", file=sys.stderr)
    print(result.summary() + f"; wrote {output}" + (f" and {overlay}" if overlay else ""))
    print(f"next: sloshid identify {output} -o params.json identifies the liquid from this angle trace.")
    return 1 if result.lost_share > LOST_NOTE else 0
