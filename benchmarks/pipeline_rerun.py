"""`sloshid run pipelines/demo.toml` twice, as a user runs it (a new process each time, Python start-up and
imports included): the second run finds every stage unchanged and only copies finished outputs (target:
under 10 % of the first run's time)."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_output import ROOT, write_results


def timed_run(output_dir: str) -> tuple[float, dict]:
    """One `sloshid run pipelines/demo.toml` in a new process into `output_dir`: (wall time in s, its manifest)."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "sloshid", "run", "pipelines/demo.toml", "--output-dir", output_dir, "--quiet"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - start
    return seconds, json.loads((Path(done.stdout.strip()).parent / "manifest.json").read_text())


def main() -> None:
    """Time a first and an unchanged second run of the demo pipeline; write reports/benchmarks/pipeline_rerun.*"""
    times, statuses = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(2):
            seconds, manifest = timed_run(tmp)
            times.append(seconds)
            statuses.append({s["name"]: s["status"] for s in manifest["stages"]})
    ratio = times[1] / times[0]
    write_results(
        "pipeline_rerun",
        {"pipeline": "pipelines/demo.toml", "seconds": times, "ratio": ratio, "stages": statuses},
        "sloshid run pipelines/demo.toml: first run vs unchanged re-run",
        ["run", "wall time (s)", "stages"],
        [
            [i + 1, f"{t:.2f}", ", ".join(f"{k}: {v}" for k, v in s.items())]
            for i, (t, s) in enumerate(zip(times, statuses))
        ],
        f"Re-run / first run = {100 * ratio:.1f} % (target < 10 %).",
    )


if __name__ == "__main__":
    main()
