"""Predict the liquid's response to any recorded container motion: a sloshid trajectory CSV or a robot pose log
(time s, position m, orientation as a unit quaternion x,y,z,w or as roll/pitch/yaw; header or not; `,` or `;`).
The pendulums live in the world frame and are driven by the acceleration of their pivot, `--axis-offset-m` up the
container axis from the logged point (Savitzky-Golay, order 5, `--smooth-s` window); the output holds the pivot
acceleration, the surface angles relative to the container and the wall height (the static surface plus the wave
share of the first mode, with its crest, as `identify --trajectory` fitted them), each with a 95 % band
(`_lo`/`_hi` columns: the parameters' errors and a model error calibrated on held-out kinds); a move beyond the
fitted runs' range is named in a note and its band widened."""

from __future__ import annotations

import argparse
import sys

from sloshid.cli.settings_options import add_settings, settings_from


def add_geometry_arguments(parser: argparse.ArgumentParser) -> None:
    """The geometry and pose-log options shared by predict and validate: the GeometrySettings fields."""
    from sloshid.validation.predict import GeometrySettings

    add_settings(parser, GeometrySettings)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid predict`."""
    parser.add_argument("trajectory", metavar="TRAJECTORY", help="sloshid trajectory CSV or robot pose log")
    parser.add_argument("-o", "--output", required=True, metavar="PREDICTION.csv", help="prediction CSV to write")
    parser.add_argument("--params", required=True, metavar="PARAMS.json", help="parameters from `sloshid identify`")
    from sloshid.validation.predict import PredictSettings

    add_settings(parser, PredictSettings)
    add_geometry_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Load and check everything, predict, write the CSV atomically, print the peaks."""
    from sloshid.core.outputs import Outputs
    from sloshid.model.pose import load_pose_log
    from sloshid.validation.predict import (
        PredictSettings,
        forecast,
        load_model,
        pivot_for,
        wall_height,
        write_prediction,
    )

    settings = settings_from(args, PredictSettings)
    output = Outputs([args.trajectory, args.params]).file(args.output, "-o", (".csv",))
    model = load_model(args.params).with_geometry(args.container_radius_m, None, args.smooth_s)
    if model.radius_m is None:  # the angles need no radius: a tap test's model checks a plan without one
        print(
            "sloshid: note: no container radius (--container-radius-m, or one stored by identify): the angles are "
            "written, not wall_height_mm.",
            file=sys.stderr,
        )
    pose = load_pose_log(args.trajectory, args.pose_columns)
    model, note = pivot_for(pose, model, args.axis_offset_m)
    if note:
        print(f"sloshid: note: {note}", file=sys.stderr)
    fc = forecast(pose, model, settings.settle_s)
    for line in fc.notes:
        print(f"sloshid: note: {line}", file=sys.stderr)
    write_prediction(output, fc)
    resp = fc.resp
    move = resp.move_span_s
    during = (resp.t_s >= move[0]) & (resp.t_s <= move[1])
    wall = ""
    if model.radius_m is not None:
        lo, hi = (edge[during].max() for edge in fc.band(wall_height))
        wall = f"peak wall height {wall_height(resp, model)[during].max():.2f} mm (95 % band {lo:.2f}-{hi:.2f}); "
    print(
        f"move {move[0]:.3f}-{move[1]:.3f} s: peak relative angle {resp.rel_angle_deg[during].max():.2f} deg, "
        f"{wall}after it {resp.rel_angle_deg[~during & (resp.t_s > move[1])].max(initial=0):.2f} deg"
    )
    print(f"wrote {output}")
    return 0
