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


def main() -> None:
    """Time a first and an unchanged second run of the demo pipeline; write reports/benchmarks/pipeline_rerun.*"""
    times, statuses = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(2):
            start = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-m", "sloshid", "run", "pipelines/demo.toml", "--output-dir", tmp, "--quiet"],
                cwd=ROOT,
                check=True,
                capture_output=True,
                text=True,
            )
            times.append(time.perf_counter() - start)
            manifest = json.loads((Path(done.stdout.strip()).parent / "manifest.json").read_text())
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
