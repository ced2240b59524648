"""Run a declared pipeline: the stages of PIPELINE.toml ([track], [identify], [plan], [compare], [report])
under the settings of its [run] table (workers, on_error, output_dir).

Everything is validated before anything runs (unknown keys get a "did you mean", paths are checked).
Each run writes <output_dir>/<pipeline>/<run-id>/ with manifest.json (resolved settings, package version,
SHA-256 of every input file), each stage's outputs and an index.html that summarises and links them.
A stage whose settings slice, input files and upstream stages are unchanged is not re-run: its outputs
are reused from the pipeline's cache. Exit code 1 when a stage failed (finished stages are kept).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sloshid.cli.settings_options import add_settings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid run`."""
    parser.add_argument("pipeline", type=Path, metavar="PIPELINE.toml", help="pipeline file (see pipelines/)")
    from sloshid.workflow.pipeline import RunSettings

    add_settings(parser, RunSettings, only=("output_dir",), title="the pipeline's [run] table, overridden")
    parser.add_argument("--quiet", action="store_true", help="print only the path of index.html")


def run(args: argparse.Namespace) -> int:
    """Load and validate the pipeline, run it, name the file to send to the robot, print the index path."""
    from sloshid.tracking.tracker import LOST_NOTE
    from sloshid.workflow.index import next_step, write_index
    from sloshid.workflow.pipeline import Pipeline, run_pipeline
    from sloshid.workflow.stages import REGISTRY

    pipeline = Pipeline.load(args.pipeline, REGISTRY)
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    result = run_pipeline(
        pipeline, args.output_dir, lambda d, recs: write_index(d, recs, pipeline.report.title), log=log
    )
    truncated = False
    for rec in result.stages:
        if rec.status == "failed":
            print(f"sloshid: error: stage [{rec.name}] failed: {rec.error}", file=sys.stderr)
        videos = rec.summary.get("videos", []) if rec.name == "track" else []
        for video in videos:  # as `track` warns of them, named when the stage tracked several
            name = Path(video.get("video", "")).name
            for warning in video.get("warnings", []):
                named = f"{name}: {warning}" if len(videos) > 1 and name not in warning else warning
                print(f"sloshid: warning: {named}", file=sys.stderr)
            truncated |= video.get("lost_share", 0.0) > LOST_NOTE
    step = next_step(result.run_dir, result.stages)
    if step is not None and not args.quiet:  # stdout stays the index's path alone
        move, arm = result.run_dir / step.move, step.arm
        if arm is not None:  # the scenario's arm cannot follow it
            from sloshid.cli.plan_cmd import arm_clause, fit_command

            command = fit_command(arm["scenario"], arm["params"], arm["robust"], "TRAJ.csv")
            why = arm_clause(arm["reason"], arm["refit"], command)
            print(f"next: do not send {move} to the robot ({step.what}): {why}; open:", file=sys.stderr)
        else:
            joints = f" (or the joints, {result.run_dir / step.joints})" if step.joints else ""
            print(f"next: send {move}{joints} to the robot ({step.what}); open:", file=sys.stderr)
    print(result.index_html)
    return 0 if result.ok and not truncated else 1
