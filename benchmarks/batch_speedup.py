"""`sloshid batch` on 16 short synthetic videos with 1 and then 2 Dask workers, in one run (target: speed-up
>= 1.7 on 2 cores). Two figures per worker count: the batch on a running, warmed-up cluster (what a lab with
a scheduler sees; the speed-up the target means) and cold, end to end, with the local cluster's start-up
(a few seconds of fixed cost that no number of workers shortens). A fresh output folder each time, so
nothing is skipped as unchanged."""

from __future__ import annotations

import logging
import os
import tempfile
import time
from pathlib import Path

from bench_output import write_results
from dask.distributed import Client, LocalCluster

from sloshid.synthetic.render import SynthSettings, render_video
from sloshid.workflow.batch import run_batch
from sloshid.workflow.options import BatchConfig, IdentifyOptions, TrackOptions

N_VIDEOS = 16


def _warm_up() -> None:
    """Import the tracker and identifier on a worker (what its first video would otherwise pay for)."""
    import sloshid.identification.estimator
    import sloshid.tracking.tracker  # noqa: F401


def main() -> None:
    """Render the videos once, then time the batch with 1 and 2 workers; write reports/benchmarks/batch_speedup.*"""
    config = BatchConfig(TrackOptions(), IdentifyOptions(mass_kg=0.5))
    with tempfile.TemporaryDirectory() as tmp:
        videos = []
        for i in range(N_VIDEOS):
            path = Path(tmp) / f"tap_{i:02d}.mp4"
            render_video(
                path,
                SynthSettings(
                    duration_s=8.0,
                    fps=60,
                    f_hz=2.5 + 0.1 * i,
                    zeta=0.05,
                    noise_sigma=5,
                    blur_px=1.0,
                    quality=18,
                    seed=i,
                ),
            )
            videos.append(path)
        warm, cold = {}, {}
        for workers in (1, 2):
            with (
                LocalCluster(
                    n_workers=workers, threads_per_worker=1, dashboard_address=None, silence_logs=logging.ERROR
                ) as cluster,
                Client(cluster) as client,
            ):
                client.run(_warm_up)
                start = time.perf_counter()
                result = run_batch(
                    videos, config, Path(tmp) / f"warm_{workers}", scheduler=cluster.scheduler_address, progress=False
                )
                warm[workers] = time.perf_counter() - start
            assert not result.failures, result.failures
            start = time.perf_counter()
            run_batch(videos, config, Path(tmp) / f"cold_{workers}", workers=workers, progress=False)
            cold[workers] = time.perf_counter() - start
    speedup, speedup_cold = warm[1] / warm[2], cold[1] / cold[2]
    write_results(
        "batch_speedup",
        {
            "videos": N_VIDEOS,
            "video": "640x480, 60 fps, 8 s, H.264 CRF 18",
            "warm_seconds": warm,
            "cold_seconds": cold,
            "speedup": speedup,
            "speedup_cold": speedup_cold,
            "cpus": os.cpu_count(),
            "load_avg_1min": os.getloadavg()[0],
        },
        f"sloshid batch: {N_VIDEOS} videos, 1 vs 2 Dask workers",
        ["workers", "running cluster (s)", "videos/s", "cold incl. cluster start-up (s)"],
        [[w, f"{warm[w]:.1f}", f"{N_VIDEOS / warm[w]:.2f}", f"{cold[w]:.1f}"] for w in warm],
        f"Speed-up of 2 workers over 1 on a running cluster: {speedup:.2f} (target >= 1.7), on {os.cpu_count()} "
        f"cores; cold, with the local cluster's start-up: {speedup_cold:.2f}.",
    )


if __name__ == "__main__":
    main()
