"""Render a synthetic side-view video of a float on sloshing liquid, plus its exact ground truth as CSV.

The float's angle relative to the container follows a known pendulum trace: a tap-test free decay
(--motion decay, liquid from --f-hz/--zeta or --l-m/--d-ns-per-m/--m-kg, seed Table I by default) or
the response to a constant-acceleration move (--motion move). Camera effects (noise, blur, flicker,
compression, roll, VFR timing) and a container travelling and tilting in the picture make it realistic.
The truth CSV (default: OUT with suffix _truth.csv) has frame, t_s, rel_angle_deg, container_angle_deg,
float_angle_deg, float_x_px, float_y_px, container_x_px, container_y_px, accel_m_s2. With --scene surface the
liquid is dyed and has no float; the truth then has surface_angle_deg instead of float_angle_deg, and
left_wall_px, right_wall_px, left_wall_mm, right_wall_mm (surface height at each inner wall above rest).
--renderer pbr path-traces a random scene drawn from --scene-seed (Mitsuba 3) with the same truth columns, measured
on the scene's geometry through the camera and its lens distortion, plus the container's image box (box_x0_px ..
box_y1_px); the draw is written to OUT_scene.json.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from sloshid.cli.inspect_cmd import track_command, track_options
from sloshid.cli.settings_options import add_settings, settings_from
from sloshid.core.errors import UserError
from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.video.colors import PRESETS

GROUPS = {
    "timing": "timing",
    "motion": "liquid motion",
    "camera": "scene and camera",
    "renderer": "renderer",
    "surface": "dyed-liquid scene (--scene surface)",
}
"""Titles of the help's groups of SynthSettings fields."""

TRUTH_MARK = "frame,t_s,rel_angle_deg,"
"""How every truth CSV's header starts: a file at OUT_truth.csv without it is a user's, and synth refuses it."""
SCENE_MARK = '"renderer": "pbr"'
"""What every OUT_scene.json holds: a file there without it is a user's, and synth refuses it."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid synth`: the outputs, then one per SynthSettings field (settings_options)."""
    parser.add_argument("output", type=Path, metavar="OUT.mp4", help="video file to write (.mp4)")
    parser.add_argument("--truth", type=Path, help="ground-truth CSV to write (default: OUT_truth.csv)")
    add_settings(parser, SynthSettings, GROUPS)
    parser.epilog = f"Colour presets: {', '.join(sorted(PRESETS))}."


def settings_from_args(args: argparse.Namespace) -> SynthSettings:
    """The SynthSettings the command line describes (validated by the dataclass; a colour of the other scene is
    refused here, where it is known to be given: its default is a colour too)."""
    scene = args.scene or SynthSettings.scene
    for option, only in (("float_color", "float"), ("liquid_color", "surface")):
        flag = "--" + option.replace("_", "-")
        if getattr(args, option) is not None and args.renderer == "pbr":  # --scene would not help: say what does
            raise UserError(
                f"{flag} is not an option of the pbr renderer (it draws the scene from --scene-seed); leave it out or "
                "use --renderer painted."
            )
        if getattr(args, option) is not None and scene != only:
            raise UserError(f"{flag} applies only to the {only} scene (--scene {only}), not the {scene} one.")
    return settings_from(args, SynthSettings)


def run(args: argparse.Namespace) -> int:
    """Render the video and its truth CSV; print where they went and the liquid's modal values."""
    from sloshid.core.outputs import Outputs
    from sloshid.video.frames import VIDEO_SUFFIXES, encoded_size

    settings = settings_from_args(args)
    outputs = Outputs()
    video = outputs.file(args.output, "the video", VIDEO_SUFFIXES)
    how = "choose another OUT (or --truth), or move that file away"  # for the names synth chooses, not the user
    if args.truth:
        truth_path = outputs.file(args.truth, "--truth", (".csv",))
    else:
        truth_path = outputs.file(
            video.with_name(video.stem + "_truth.csv"), "the truth CSV", (".csv",), (TRUTH_MARK, how)
        )
    scene_json = None
    if settings.renderer == "pbr":
        scene_json = outputs.file(
            video.with_name(video.stem + "_scene.json"), "the scene's draw", (".json",), (SCENE_MARK, how)
        )
    truth = render_video(video, settings, truth_path, progress=True, scene_json=scene_json)
    p = settings.params
    width, height = encoded_size(settings.width, settings.height)
    size = f"{width}x{height}, {settings.codec}"
    if (width, height) != (settings.width, settings.height):  # the codecs' half-size chroma takes even sizes
        size += f"; {settings.width}x{settings.height} less its odd last column or row: the codec takes even sizes"
    print(
        f"wrote {args.output} ({len(truth)} frames, {size}) "
        f"and {truth_path}{f' and {scene_json}' if scene_json else ''}; liquid f = {p.f_hz:.3f} Hz, "
        f"zeta = {p.zeta:.4f}"
    )
    if settings.at_rest:
        print(f"sloshid: warning: {settings.at_rest}.", file=sys.stderr)
    print(_next_step(video, settings))
    return 0


def _next_step(video: Path, settings: SynthSettings) -> str:
    """The line a user needs next: track the video as its scene asks (a drawn scene: look at it with inspect)."""
    if settings.renderer == "pbr":  # the dye and the float's colour are the scene draw's
        command = shlex.join(["sloshid", "inspect", str(video)])  # runs as printed: quoted, as the track command
        return f"next: {command} shows what each target finds and the track command for this scene."
    what = {"target": "surface"} if settings.scene == "surface" else {"float_color": settings.float_color}
    return f"next: {track_command(video, what, track_options())} measures it."
