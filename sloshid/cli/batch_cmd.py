"""Track and identify many videos in parallel with Dask (a local cluster, or an existing scheduler).

Every video gets its own folder under OUT/videos/ (angles.csv, params.json, result.json) written as soon as
it finishes, so an interrupted batch loses nothing finished and a re-run skips videos whose outputs match
the video's content hash and the settings. A failing video is listed in OUT/failures.csv and never stops the
batch. OUT/summary.csv has one row per video (frames, valid share, f, zeta, l, d with 95 % intervals,
verdict) and OUT/summary.html shows the distribution of identified frequencies. Exit code 1 when any video
failed. With --scheduler the workers must see the same file paths (shared file system).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sloshid.cli.settings_options import add_settings, settings_from
from sloshid.core.parallel import ClusterSettings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `sloshid batch`."""
    parser.add_argument("videos", nargs="+", type=Path, metavar="VIDEO", help="video files to process")
    parser.add_argument(
        "--config",
        type=Path,
        metavar="TRACK.toml",
        help="TOML with a [track] table (float_color or float_hsv_low/high, roi, reference, overlay) "
        "and an [identify] table (mass_kg, f_range_hz, min_fit_percent, ...); without it, the settings "
        "`sloshid track` and `sloshid identify` use by themselves",
    )
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if needed)")
    add_settings(parser, ClusterSettings)


def run(args: argparse.Namespace) -> int:
    """Validate everything first, then run the batch and print where the summary is."""
    from sloshid.core.errors import UserError
    from sloshid.core.outputs import Outputs
    from sloshid.tracking.tracker import LOST_NOTE
    from sloshid.workflow.batch import run_batch
    from sloshid.workflow.options import BatchConfig, IdentifyOptions, TrackOptions

    cluster = settings_from(args, ClusterSettings)
    folders = [str(v) for v in args.videos if v.is_dir()]
    if folders:
        raise UserError(f"{folders[0]} is a folder, not a video; give the videos in it (e.g. {folders[0]}/*.mp4).")
    missing = [str(v) for v in args.videos if not v.exists()]
    if missing:
        raise UserError(f"{len(missing)} video(s) do not exist: {', '.join(missing[:5])}.")
    odd = [str(v) for v in args.videos if not v.is_file()]  # a FIFO or device: batch hashes a video, then tracks it
    if odd:
        raise UserError(f"{len(odd)} video(s) are not regular files (a pipe or a device): {', '.join(odd[:5])}.")
    if args.out.exists() and not args.out.is_dir():
        raise UserError(f"--out {args.out} exists and is not a folder.")
    outputs = Outputs(args.videos)
    for name in ("summary.csv", "failures.csv", "summary.html"):
        outputs.file(args.out / name, "--out")
    config = BatchConfig.load(args.config) if args.config else BatchConfig(TrackOptions(), IdentifyOptions())
    result = run_batch(args.videos, config, args.out, workers=cluster.workers, scheduler=cluster.scheduler)
    done = sum(r["status"] in ("ok", "cached") for r in result.rows)
    cached = sum(r["status"] == "cached" for r in result.rows)
    print(f"{done} of {len(result.rows)} videos done ({cached} unchanged, skipped), {len(result.failures)} failed.")
    for row in result.failures:  # the file once: most reasons start with it
        reason = row["reasons"]
        print(f"  failed: {reason}" if row["file"] in reason else f"  failed: {row['file']}: {reason}")
    # a video that decoded only in part was tracked as far as it went: said, and the exit code is 1, as for `track`
    truncated = [r for r in result.rows if r["status"] != "failed" and float(r.get("lost_share") or 0) > LOST_NOTE]
    for row in truncated:
        print(f"  truncated: {row['file']}: {100 * float(row['lost_share']):.1f} % of its frames did not decode")
    print(f"summary: {result.summary_csv}\nopen: {result.summary_html}")
    return 1 if result.failures or truncated else 0
