"""Render a synthetic side-view video of a float on sloshing liquid, plus its exact ground truth as CSV.

The float's angle relative to the container follows a known pendulum trace: a tap-test free decay
(--motion decay, liquid from --f-hz/--zeta or --l-m/--d-ns-per-m/--m-kg, seed Table I by default) or
the response to a constant-acceleration move (--motion move). Camera effects (noise, blur, flicker,
compression, roll, VFR timing) and a container travelling and tilting in the picture make it realistic.
The truth CSV (default: OUT with suffix _truth.csv) has t_s, rel_angle_deg, container_angle_deg,
float_angle_deg, float_x_px, float_y_px, container_x_px, container_y_px, accel_m_s2. With --scene surface the
liquid is dyed and has no float; the truth then has surface_angle_deg instead of float_angle_deg, and
left_wall_px, right_wall_px, left_wall_mm, right_wall_mm (surface height at each inner wall above rest).
--renderer pbr path-traces a random scene drawn from --scene-seed (Mitsuba 3) with the same truth columns, measured
on the scene's geometry through the camera and its lens distortion, plus the container's image box (box_x0_px ..
box_y1_px); the draw is written to OUT_scene.json.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sloshid.core.errors import UserError
from sloshid.model.pendulum import TABLE_I
from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.video.colors import PRESETS

_DEFAULTS = SynthSettings()


FLAGS = {
    "duration_s": "--duration",
    "amplitude_deg": "--amplitude",
    "tap_s": "--tap",
    "accel_m_s2": "--accel",
    "move_start_s": "--move-start",
    "move_duration_s": "--move-duration",
    "travel_px": "--travel",
    "container_tilt_deg": "--tilt",
    "container_tilt_hz": "--tilt-hz",
    "camera_roll_deg": "--roll",
    "float_length_frac": "--float-length",
    "noise_sigma": "--noise",
    "blur_px": "--blur",
    "float_bend_px": "--float-bend",
    "elevation_deg": "--elevation",
    "meniscus_px": "--meniscus",
    "container_diameter_m": "--container-diameter",
}
"""SynthSettings fields whose option is not --field-with-hyphens: how the command line names them in errors."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid synth`, each with its unit (one argparse call per option: long, but read one entry
    at a time, so it is not split)."""
    d = _DEFAULTS
    parser.add_argument("output", type=Path, metavar="OUT.mp4", help="video file to write (.mp4)")
    parser.add_argument("--truth", type=Path, help="ground-truth CSV to write (default: OUT_truth.csv)")
    g = parser.add_argument_group("timing")
    g.add_argument("--width", type=int, default=d.width, help="frame width, pixels")
    g.add_argument("--height", type=int, default=d.height, help="frame height, pixels")
    g.add_argument("--fps", type=float, default=d.fps, help="nominal frame rate, frames/s")
    g.add_argument("--duration", type=float, default=d.duration_s, help="video length, s")
    g.add_argument(
        "--vfr-jitter",
        type=float,
        default=d.vfr_jitter,
        help="variable frame rate: jitter each timestamp by up to this fraction of a frame interval (0..0.45)",
    )
    g = parser.add_argument_group("liquid motion")
    g.add_argument(
        "--motion",
        choices=("decay", "move"),
        default=d.motion,
        help="decay: tap-test free decay; move: constant-acceleration move to the image right",
    )
    g.add_argument("--f-hz", type=float, help="natural frequency, Hz (give with --zeta; overrides --l-m/--d-ns-per-m)")
    g.add_argument("--zeta", type=float, help="damping ratio, dimensionless (give with --f-hz)")
    g.add_argument("--m-kg", type=float, default=d.m_kg, help=f"liquid mass, kg (Table I: {TABLE_I.m_kg})")
    g.add_argument("--l-m", type=float, default=d.l_m, help=f"pendulum length, m (Table I: {TABLE_I.l_m})")
    g.add_argument(
        "--d-ns-per-m",
        type=float,
        default=d.d_ns_per_m,
        help=f"damping constant, N s/m (Table I: {TABLE_I.d_ns_per_m})",
    )
    g.add_argument("--amplitude", type=float, default=d.amplitude_deg, help="decay: first peak after the tap, degrees")
    g.add_argument("--tap", type=float, default=d.tap_s, help="decay: time of the tap, s (at rest before)")
    g.add_argument("--accel", type=float, default=d.accel_m_s2, help="move: acceleration magnitude, m/s^2")
    g.add_argument("--move-start", type=float, default=d.move_start_s, help="move: start time, s")
    g.add_argument(
        "--move-duration",
        type=float,
        default=d.move_duration_s,
        help="move: total duration (half accelerating, half braking), s",
    )
    g.add_argument(
        "--px-per-m", type=float, default=d.px_per_m, help="move: image scale of the container's travel, pixels/m"
    )
    g = parser.add_argument_group("scene and camera")
    g.add_argument(
        "--travel", type=float, default=d.travel_px, help="decay: container crosses this distance to the right, pixels"
    )
    g.add_argument(
        "--tilt", type=float, default=d.container_tilt_deg, help="container tilt amplitude in the picture, degrees"
    )
    g.add_argument("--tilt-hz", type=float, default=d.container_tilt_hz, help="container tilt frequency, Hz")
    g.add_argument(
        "--roll",
        type=float,
        default=d.camera_roll_deg,
        help="camera not level: scene rotated by this angle, degrees CCW",
    )
    g.add_argument("--float-color", choices=sorted(PRESETS), help=f"float colour (default: {d.float_color})")
    g.add_argument(
        "--float-length", type=float, default=d.float_length_frac, help="float length, fraction of the frame height"
    )
    g.add_argument(
        "--noise", type=float, default=d.noise_sigma, help="sensor noise standard deviation, grey levels (0..255)"
    )
    g.add_argument("--blur", type=float, default=d.blur_px, help="optical blur, Gaussian sigma in pixels")
    g.add_argument(
        "--flicker", type=float, default=d.flicker, help="lighting flicker, relative brightness swing (0.05 = 5 %%)"
    )
    g.add_argument("--codec", choices=("h264", "mpeg4"), default=d.codec, help="compression codec")
    g.add_argument(
        "--quality",
        type=float,
        help="codec quality: H.264 CRF 0..51 (default 23), MPEG-4 qscale 1..31 (default 4); lower is better",
    )
    g.add_argument("--seed", type=int, default=d.seed, help="seed of all random draws (noise, flicker, jitter)")
    g.add_argument("--float-rounded", action="store_true", help="rounded float ends (a capsule)")
    g.add_argument("--float-bend", type=float, default=d.float_bend_px, help="float ends sag by this much, pixels")
    g.add_argument("--float-specular", type=float, default=d.float_specular, help="specular spot opacity, 0..1")
    g.add_argument(
        "--float-submerged", type=float, default=d.float_submerged, help="share of the float under the liquid, 0..1"
    )
    g.add_argument(
        "--motion-blur", type=float, default=d.motion_blur, help="exposure, share of the frame interval (0..1)"
    )
    g = parser.add_argument_group("renderer")
    g.add_argument(
        "--renderer",
        choices=("painted", "pbr"),
        default=d.renderer,
        help="painted: analytic shapes, exact edges, fast; pbr: a path-traced random scene (Mitsuba 3): glass with "
        "thickness, refraction, meniscus, reflections, caustics, glare, lens distortion (a 640x480 frame: about 2.6 s on two free cores)",
    )
    g.add_argument(
        "--scene-seed",
        type=int,
        default=d.scene_seed,
        help="pbr: seed of the scene's random draw (container, liquid, background, camera, lens, light, noise, "
        "float); written to OUT_scene.json",
    )
    g.add_argument("--spp", type=int, default=d.spp, help="pbr: path-tracing samples per pixel")
    g = parser.add_argument_group("dyed-liquid scene (--scene surface)")
    g.add_argument(
        "--scene",
        choices=("float", "surface"),
        default=d.scene,
        help="float: a float on pale liquid; surface: dyed liquid whose surface is measured (truth: wall heights too)",
    )
    g.add_argument("--liquid-color", choices=sorted(PRESETS), help=f"dye colour (default: {d.liquid_color})")
    g.add_argument("--elevation", type=float, default=d.elevation_deg, help="camera above the surface plane, degrees")
    g.add_argument("--meniscus", type=float, default=d.meniscus_px, help="meniscus band thickness, pixels")
    g.add_argument("--meniscus-dark", action="store_true", help="a dark meniscus band instead of a bright one")
    g.add_argument("--specular", type=float, default=d.specular, help="opacity of highlight stripes on the glass, 0..1")
    g.add_argument("--reflection", type=float, default=d.reflection, help="opacity of the surface's image on the wall")
    g.add_argument(
        "--second-mode", type=float, default=d.second_mode, help="second mode's wall height relative to the first's"
    )
    g.add_argument(
        "--container-diameter", type=float, default=d.container_diameter_m, help="inner diameter, m (mm truth scale)"
    )


def settings_from_args(args: argparse.Namespace) -> SynthSettings:
    """The SynthSettings the command line describes (validated by the dataclass; a colour of the other scene is
    refused here, where it is known to be given: its default is a colour too)."""
    for option, scene in (("float_color", "float"), ("liquid_color", "surface")):
        if getattr(args, option) is not None and args.scene != scene:
            flag = "--" + option.replace("_", "-")
            raise UserError(f"{flag} applies only to the {scene} scene (--scene {scene}), not the {args.scene} one.")
    return SynthSettings(
        width=args.width,
        height=args.height,
        fps=args.fps,
        duration_s=args.duration,
        vfr_jitter=args.vfr_jitter,
        motion=args.motion,
        f_hz=args.f_hz,
        zeta=args.zeta,
        m_kg=args.m_kg,
        l_m=args.l_m,
        d_ns_per_m=args.d_ns_per_m,
        amplitude_deg=args.amplitude,
        tap_s=args.tap,
        accel_m_s2=args.accel,
        move_start_s=args.move_start,
        move_duration_s=args.move_duration,
        px_per_m=args.px_per_m,
        travel_px=args.travel,
        container_tilt_deg=args.tilt,
        container_tilt_hz=args.tilt_hz,
        camera_roll_deg=args.roll,
        float_color=args.float_color or _DEFAULTS.float_color,
        float_length_frac=args.float_length,
        noise_sigma=args.noise,
        blur_px=args.blur,
        flicker=args.flicker,
        codec=args.codec,
        quality=args.quality,
        seed=args.seed,
        float_rounded=args.float_rounded,
        float_bend_px=args.float_bend,
        float_specular=args.float_specular,
        float_submerged=args.float_submerged,
        motion_blur=args.motion_blur,
        scene=args.scene,
        liquid_color=args.liquid_color or _DEFAULTS.liquid_color,
        elevation_deg=args.elevation,
        meniscus_px=args.meniscus,
        meniscus_dark=args.meniscus_dark,
        specular=args.specular,
        reflection=args.reflection,
        second_mode=args.second_mode,
        container_diameter_m=args.container_diameter,
        renderer=args.renderer,
        scene_seed=args.scene_seed,
        spp=args.spp,
    )


def run(args: argparse.Namespace) -> int:
    """Render the video and its truth CSV; print where they went and the liquid's modal values."""
    from sloshid.core.outputs import Outputs
    from sloshid.video.frames import VIDEO_SUFFIXES

    settings = settings_from_args(args)
    outputs = Outputs()
    video = outputs.file(args.output, "the video", VIDEO_SUFFIXES)
    truth_path = outputs.file(args.truth or video.with_name(video.stem + "_truth.csv"), "--truth", (".csv",))
    scene_json = None
    if settings.renderer == "pbr":
        scene_json = outputs.file(video.with_name(video.stem + "_scene.json"), "the scene's draw", (".json",))
    truth = render_video(video, settings, truth_path, progress=True, scene_json=scene_json)
    p = settings.params
    print(
        f"wrote {args.output} ({len(truth)} frames, {settings.width}x{settings.height}, {settings.codec}) "
        f"and {truth_path}{f' and {scene_json}' if scene_json else ''}; liquid f = {p.f_hz:.3f} Hz, "
        f"zeta = {p.zeta:.4f}"
    )
    if settings.at_rest:
        print(f"sloshid: warning: {settings.at_rest}.", file=sys.stderr)
    return 0
