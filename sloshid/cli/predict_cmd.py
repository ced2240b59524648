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
import shlex
import sys
import threading

from sloshid.cli.naming import as_typed
from sloshid.cli.settings_options import add_settings, settings_from

PHASES_DELAY_S = 2.0
"""A prediction that lasts longer than this shows its phases on a bar (on a terminal)."""


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
        GeometrySettings,
        PredictSettings,
        forecast,
        load_model,
        pivot_for,
        wall_height,
        write_prediction,
    )

    settings = settings_from(args, PredictSettings)
    geometry = settings_from(args, GeometrySettings)  # range-checked before any file is read
    output = Outputs([args.trajectory, args.params]).file(args.output, "-o", (".csv",))
    model = load_model(args.params).with_geometry(geometry.container_radius_m, None, geometry.smooth_s)
    if model.radius_m is None:  # the angles need no radius: a tap test's model checks a plan without one
        print(
            "sloshid: note: no container radius (--container-radius-m, or one stored by identify): the angles are "
            "written, not wall_height_mm.",
            file=sys.stderr,
        )
    with _Phases("read the log") as phases:  # a 1,000 s log at 1 kHz takes a minute: its phases and the time on a bar
        pose = load_pose_log(args.trajectory, geometry.pose_columns)
        model, note = pivot_for(pose, model, geometry.axis_offset_m)
        phases.next(f"simulate {pose.t_s.size:,} samples")
        fc = forecast(pose, model, settings.settle_s)
        phases.next("write the CSV")
        write_prediction(output, fc)
    for line in ([note] if note else []) + list(fc.notes):
        print(f"sloshid: note: {as_typed(line, args)}", file=sys.stderr)
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
    print(
        f"next: sloshid validate --trajectory {shlex.quote(args.trajectory)} --measured MEASURED.csv "
        f"--params {shlex.quote(args.params)} "
        "scores this prediction against a measured run of the move."
    )
    return 0


class _Phases:
    """A bar of predict's three phases on a terminal, shown once they last PHASES_DELAY_S, its clock ticking each
    second (a simulation is one compiled call that reports nothing while it runs)."""

    def __init__(self, first: str) -> None:
        from tqdm import tqdm

        self.bar = tqdm(
            total=3,
            desc=f"predict: {first}",
            bar_format="{desc}phase {n_fmt} of {total_fmt} done [{elapsed}]",  # no ETA: the phases differ in length
            disable=None,
            leave=False,
            delay=PHASES_DELAY_S,
        )
        self.done = threading.Event()
        self.ticker = threading.Thread(target=self._tick, daemon=True)

    def _tick(self) -> None:
        if not self.done.wait(PHASES_DELAY_S):
            while not self.done.wait(1.0):
                self.bar.refresh()

    def next(self, what: str) -> None:
        self.bar.update()
        self.bar.set_description(f"predict: {what}")

    def __enter__(self) -> _Phases:
        self.ticker.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        self.ticker.join()
        self.bar.close()
