"""Track and identify many videos in parallel on Dask; per-video outputs are written as each finishes.

Each video gets `<out>/videos/<stem>-<hash>/` with angles.csv, params.json and result.json; result.json is
written last and records the hash of the video and of the settings, so a re-run skips finished videos and
an interrupted batch loses nothing that had finished. A failing video is recorded, never fatal.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sloshid.core.atomic import check_schema, remove_empty, write_json, write_text
from sloshid.core.errors import SettingError, SloshidWarning, UserError
from sloshid.core.hashing import file_sha256, json_sha256
from sloshid.core.outputs import is_sloshid_page, writable_folder
from sloshid.core.parallel import ClusterSettings, dask_client, wait_with_workers
from sloshid.core.tables import distinct_names
from sloshid.identification.estimates import shown_with_error
from sloshid.identification.estimator import Z95
from sloshid.report.html import Report
from sloshid.workflow.options import BatchConfig

SUMMARY_COLUMNS = (
    "file",
    "status",
    "frames",
    "valid_share",
    "f_hz",
    "f_lo_hz",
    "f_hi_hz",
    "zeta",
    "zeta_lo",
    "zeta_hi",
    "l_m",
    "l_lo_m",
    "l_hi_m",
    "d_ns_per_m",
    "d_lo_ns_per_m",
    "d_hi_ns_per_m",
    "quality",
    "reasons",
    "lost_share",
    "warnings",
    "outputs",
)


def config_hash(config: BatchConfig) -> str:
    """Hash of the settings that change a video's results."""
    return json_sha256(dataclasses.asdict(config))[:16]


def _interval(params: dict[str, Any], key: str) -> list[Any]:
    """[value, lo, hi] of a parameter from identify's JSON, blanks when absent."""
    p = params.get(key)
    return [p["value"], *p["ci95"]] if p else ["", "", ""]


def process_video(video: str, config: BatchConfig, out_root: str) -> dict[str, Any]:
    """Track one video and identify its mode; returns its summary row (status 'failed' with the reason on error).

    Runs on a Dask worker: imports are local.
    """
    import cv2

    from sloshid.identification.stage import identify_sources
    from sloshid.tracking.tracker import track_video

    cv2.setNumThreads(1)  # the batch is parallel over videos: each video gets one core
    row: dict[str, Any] = {c: "" for c in SUMMARY_COLUMNS}
    row["file"] = video
    try:
        video_hash = file_sha256(video)
    except OSError as exc:
        return {**row, "status": "failed", "reasons": f"cannot read the file ({exc.strerror or exc})."}
    settings = config_hash(config)
    # named by the video and the settings: a re-run with other settings writes beside the earlier results, not over
    out = Path(out_root) / "videos" / f"{Path(video).stem}-{video_hash[:10]}-{settings[:6]}"
    marker = out / "result.json"
    key = {"video_sha256": video_hash, "config": settings}
    if _finished(marker, key):
        done = json.loads(marker.read_text())  # checked by _finished
        # this run's names: the same video may sit in another folder, and the output folder may have been moved
        return {**done["row"], "file": video, "outputs": str(out), "status": "cached"}
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    row["outputs"] = str(out)
    table = "[track]"
    try:
        overlay = out / "overlay.mp4" if config.track.overlay else None
        with warnings.catch_warnings():  # on a worker they would reach no one: the row's `warnings` carries them
            warnings.simplefilter("ignore", SloshidWarning)
            tracked = track_video(video, config.track.track_settings(), overlay=overlay, multithreaded=False)
        tracked.to_csv(out / "angles.csv")
        row.update(
            frames=len(tracked.t_s),
            valid_share=round(float(tracked.valid.mean()), 4),
            lost_share=round(float(tracked.lost_share), 4),
            warnings=" ".join(tracked.warnings),  # a truncated video, repeated pictures, ...: as `track` says them
        )
        table = "[identify]"
        with warnings.catch_warnings():  # the skipped frames' note: the tracked rows' validity says it
            warnings.simplefilter("ignore", SloshidWarning)
            doc = identify_sources([tracked], config.identify.ident_settings(), config.identify.columns()).to_dict()
        write_json(out / "params.json", doc)
    except SettingError as exc:  # named as the config file's key, the place the user can change it
        return _failed(row, out, created, str(exc.named(lambda setting: f"{table}.{setting}")))
    except UserError as exc:
        return _failed(row, out, created, str(exc))
    except Exception as exc:
        detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return _failed(row, out, created, f"unexpected error: {detail}")
    p = doc["parameters"]
    row.update(
        zip(
            SUMMARY_COLUMNS[4:16],
            [*_interval(p, "f_hz"), *_interval(p, "zeta"), *_interval(p, "l_m"), *_interval(p, "d_ns_per_m")],
        )
    )
    row.update(status="ok", quality=doc["quality"], reasons=" ".join(doc["reasons"]))  # each a sentence
    written = {name: file_sha256(out / name) for name in OUTPUT_FILES if (out / name).exists()}
    write_json(marker, {"key": key, "settings": dataclasses.asdict(config), "outputs": written, "row": row})
    return row


OUTPUT_FILES = ("angles.csv", "params.json", "overlay.mp4")
"""A video's outputs beside its result.json, which records their hashes: a re-run redoes a video whose outputs went
missing or changed."""


def _finished(marker: Path, key: dict[str, str]) -> bool:
    """The video's result.json holds this video's and these settings' key, and every output it lists is there, as
    written (a damaged result.json or output means: not finished). One written before the outputs were listed (an
    earlier sloshid) is finished when its tracked table and parameters are there: a whole batch was redone after an
    upgrade."""
    try:
        done = json.loads(marker.read_text())
        check_schema(done, marker)
        if "outputs" not in done:
            return done.get("key") == key and all((marker.parent / name).is_file() for name in OUTPUT_FILES[:2])
        return done.get("key") == key and all(
            file_sha256(marker.parent / name) == digest for name, digest in done["outputs"].items()
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def _failed(row: dict[str, Any], out: Path, created: bool, reasons: str) -> dict[str, Any]:
    """A failed video's row; the folder this run made for it goes again when nothing was written into it (a video
    that did not decode), and the row then names no outputs."""
    if created:
        remove_empty(out, out)  # only the video's own folder: another worker may be making its own beside it
    if not out.exists():
        row = {**row, "outputs": ""}
    return {**row, "status": "failed", "reasons": reasons}


@dataclass
class BatchResult:
    """Rows of the summary (one per video, in input order) and where they were written."""

    rows: list[dict[str, Any]]
    summary_csv: Path
    failures_csv: Path
    summary_html: Path

    @property
    def failures(self) -> list[dict[str, Any]]:
        """Rows of the videos that failed."""
        return [r for r in self.rows if r["status"] == "failed"]


def _write_csv(path: Path, columns: tuple[str, ...], rows: list[dict[str, Any]]) -> None:
    """Write rows as CSV atomically."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    write_text(path, buf.getvalue())


OWN_FILES = {"summary.csv": "file,status,", "failures.csv": "file,reasons"}
"""The batch's table files in its output folder and how their header starts: a file of that name that starts otherwise
is the user's, and the batch refuses the folder instead of replacing it (summary.html: sloshid's page mark)."""


def check_out_dir(out: Path) -> None:
    """Refuse an output folder holding a summary.csv, failures.csv or summary.html that a batch did not write."""
    for name, head in OWN_FILES.items():
        path = out / name
        if path.is_file():
            with open(path, encoding="utf-8", errors="replace") as fh:
                ours = fh.readline().startswith(head)
            if not ours:
                raise UserError(f"`out` {out} holds a {name} that sloshid batch did not write; choose another folder.")
    if (out / "summary.html").is_file() and not is_sloshid_page(out / "summary.html"):
        raise UserError(f"`out` {out} holds a summary.html that sloshid batch did not write; choose another folder.")
    writable_folder(out / "videos", "`out`", out)  # where every video's folder goes


def run_batch(
    videos: list[str | Path],
    config: BatchConfig,
    out_dir: str | Path,
    workers: int = ClusterSettings.workers,
    scheduler: str | None = None,
    progress: bool = True,
) -> BatchResult:
    """Process every video on Dask (finished ones skipped), then write summary.csv, failures.csv, summary.html."""
    from tqdm import tqdm

    names = [str(Path(v).resolve()) for v in videos]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise UserError(f"{twice[0]} is listed more than once; each video is processed once.")
    out = Path(out_dir)
    check_out_dir(out)
    rows: dict[str, dict[str, Any]] = {}
    with dask_client(workers, scheduler) as client:
        out.mkdir(parents=True, exist_ok=True)  # once the cluster is there: an unreachable scheduler leaves no folder
        futures = {client.submit(process_video, v, config, str(out.resolve()), pure=False): v for v in names}
        bar = tqdm(total=len(futures), desc="videos", unit="video", disable=None if progress else True)
        for fut in wait_with_workers(client, futures):
            video = futures[fut]
            try:
                rows[video] = fut.result()
            except Exception as exc:
                rows[video] = {"file": video, "status": "failed", "reasons": f"worker crashed: {exc}"}
            bar.set_postfix_str(Path(video).name)
            bar.update()
        bar.close()
    ordered = [rows[v] for v in names]
    result = BatchResult(ordered, out / "summary.csv", out / "failures.csv", out / "summary.html")
    _write_csv(result.summary_csv, SUMMARY_COLUMNS, ordered)
    _write_csv(result.failures_csv, ("file", "reasons"), result.failures)
    write_text(result.summary_html, batch_report(result).to_html())
    return result


def _with_interval(row: dict[str, Any], key: str, lo: str, hi: str) -> str:
    """'value [lo, hi]' with digits down to the interval's second significant one (as identify prints them: 1.2 [1.2,
    1.2] hid a 0.1 % interval), or '-' when the video has no estimate."""
    if row.get(key, "") == "":
        return "-"
    value, low, high = float(row[key]), float(row[lo]), float(row[hi])
    se = (high - low) / (2 * Z95)
    return f"{shown_with_error(value, se)} [{shown_with_error(low, se)}, {shown_with_error(high, se)}]"


def batch_report(result: BatchResult) -> Report:
    """Summary page: how many videos succeeded, the distribution of identified frequencies, the table."""
    ok = [r for r in result.rows if r["status"] != "failed" and r["f_hz"] != ""]
    labels = dict(zip((r["file"] for r in result.rows), distinct_names([r["file"] for r in result.rows])))
    report = Report("sloshid batch summary")
    report.add_text(
        f"{len(result.rows)} videos: {len(ok)} identified, {len(result.failures)} failed "
        f"({sum(r.get('quality') == 'good' for r in ok)} with verdict 'good')."
    )
    if ok:
        report.add_figure(
            _frequency_figure(ok, labels),
            "Left: how the identified frequencies spread over the batch. Right: each video's "
            "estimate with its 95 % interval; an interval far from the rest points at a bad video.",
        )
    report.add_heading("Per video")
    report.add_table(
        [
            "file",
            "status",
            "frames",
            "valid share",
            "f (Hz) [95 %]",
            "zeta [95 %]",
            "l (m) [95 %]",
            "d (N s/m) [95 %]",
            "quality",
            "reasons",
            "tracking warnings",
        ],
        [
            [
                labels[r["file"]],
                r["status"],
                r.get("frames", ""),
                r.get("valid_share", ""),
                _with_interval(r, "f_hz", "f_lo_hz", "f_hi_hz"),
                _with_interval(r, "zeta", "zeta_lo", "zeta_hi"),
                _with_interval(r, "l_m", "l_lo_m", "l_hi_m"),
                _with_interval(r, "d_ns_per_m", "d_lo_ns_per_m", "d_hi_ns_per_m"),
                r.get("quality", ""),
                r.get("reasons", ""),
                r.get("warnings", ""),
            ]
            for r in result.rows
        ],
    )
    return report


def _frequency_figure(ok: list[dict[str, Any]], labels: dict[str, str]):
    """The spread of identified frequencies (histogram) and each video's estimate with its 95 % interval."""
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import MaxNLocator

    f = np.array([float(r["f_hz"]) for r in ok])
    lo = np.array([float(r["f_lo_hz"]) for r in ok])
    hi = np.array([float(r["f_hi_hz"]) for r in ok])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.6))
    ax1.hist(f, bins=min(20, max(5, len(f) // 2)), color="#36c", alpha=0.8)
    ax1.set(xlabel="identified sloshing frequency f (Hz)", ylabel="videos", title="distribution of f")
    ax1.yaxis.set_major_locator(MaxNLocator(integer=True))  # a count of videos
    order = np.argsort(f)
    ax2.errorbar(
        np.arange(len(f)),
        f[order],
        yerr=[f[order] - lo[order], hi[order] - f[order]],
        fmt="o",
        color="#36c",
        ecolor="#999",
        capsize=2,
    )
    ax2.set(xlabel="video (sorted by f)", ylabel="f (Hz) with 95 % interval", title="per video")
    ax2.set_xticks(np.arange(len(f)), [labels[ok[i]["file"]] for i in order], rotation=60, ha="right")
    return fig
