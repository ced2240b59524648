"""`sloshid identify --report` on ten million rows (issue 40): peak memory per row and wall time of the whole command.

Bytes per row = (peak RSS on ROWS rows - peak RSS of the same command on a 1,000-row file, measured in the same run)
/ ROWS: the small run's peak is the interpreter's fixed baseline (Python, NumPy, SciPy, matplotlib), which the
difference removes. The signal is a tracker CSV at 1 kHz (3 Hz mode, zeta 0.01, noise 0.05 deg, seeded), written in
chunks to a temporary directory that is deleted afterwards. Usage: python benchmarks/identify_rows.py [--rows N]."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_output import write_results

RATE_HZ, F_HZ, ZETA, NOISE_DEG = 1000.0, 3.0, 0.01, 0.05
TINY_ROWS = 1000
CHUNK_ROWS = 1_000_000
TARGET_B_PER_ROW = 60


def write_signal(path: Path, rows: int, rate_hz: float = RATE_HZ) -> None:
    """The tracker CSV: a free decay sampled at `rate_hz` with white noise, written CHUNK_ROWS rows at a time."""
    rng = np.random.default_rng(40)
    w = 2 * np.pi * F_HZ
    with open(path, "w") as fh:
        fh.write("t_s,angle_deg,valid,quality\n")
        for start in range(0, rows, CHUNK_ROWS):
            n = min(CHUNK_ROWS, rows - start)
            t = (start + np.arange(n)) / rate_hz
            y = 5 * np.exp(-ZETA * w * t) * np.cos(w * np.sqrt(1 - ZETA**2) * t) + rng.normal(0, NOISE_DEG, n)
            table = np.column_stack([t, y, np.ones(n), np.full(n, 0.9)])
            np.savetxt(fh, table, fmt=["%.6f", "%.6f", "%d", "%.3f"], delimiter=",")


def run(cmd: list[str]) -> tuple[float, float]:
    """Wall seconds and peak resident bytes of one command in its own process."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{cmd} failed:\n{err}")
    return wall, usage.ru_maxrss * 1024.0  # Linux reports kilobytes


def main() -> None:
    """Measure the tiny and the big file; write reports/benchmarks/identify_rows.{json,md}."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=10_000_000, help="rows of the big file (default 10,000,000)")
    rows = parser.parse_args().rows
    with tempfile.TemporaryDirectory() as tmp:
        tiny, big = Path(tmp) / "tiny.csv", Path(tmp) / "rows.csv"
        write_signal(tiny, TINY_ROWS, rate_hz=100.0)  # 10 s: long enough to identify, short enough to cost nothing
        write_signal(big, rows)
        size_mb = big.stat().st_size / 1e6

        def identify(csv: Path, name: str) -> tuple[float, float, dict]:
            out = Path(tmp) / f"{name}.json"
            cmd = [sys.executable, "-m", "sloshid.cli.app", "identify", str(csv), "-o", str(out)]
            wall, peak = run([*cmd, "--report", str(Path(tmp) / f"report_{name}")])
            return wall, peak, json.loads(out.read_text())["parameters"]

        tiny_s, tiny_peak, _ = identify(tiny, "tiny")
        big_s, big_peak, params = identify(big, "big")
    per_row = (big_peak - tiny_peak) / rows
    f_hz, zeta = params["f_hz"]["value"], params["zeta"]["value"]
    data = {
        "rows": rows,
        "file_mb": size_mb,
        "identify_s": big_s,
        "identify_peak_mb": big_peak / 1e6,
        "tiny_rows": TINY_ROWS,
        "tiny_identify_s": tiny_s,
        "tiny_peak_mb": tiny_peak / 1e6,
        "bytes_per_row": per_row,
        "target_bytes_per_row": TARGET_B_PER_ROW,
        "f_hz": f_hz,
        "zeta": zeta,
    }
    table = [
        [f"{rows:,} rows ({size_mb:.0f} MB)", f"{big_s:.1f}", f"{big_peak / 1e6:.0f}"],
        [f"{TINY_ROWS:,} rows (baseline)", f"{tiny_s:.1f}", f"{tiny_peak / 1e6:.0f}"],
    ]
    notes = (
        f"Bytes per row: (peak of the big run - peak of the {TINY_ROWS:,}-row run) / rows = {per_row:.1f} B "
        f"(target: at most {TARGET_B_PER_ROW}); the small run's peak is the interpreter's fixed baseline. Peaks are "
        f"resident set sizes (getrusage of the child), 1 MB = 10^6 B. Identified f = {f_hz:.6f} Hz (true {F_HZ}), "
        f"zeta = {zeta:.6f} (true {ZETA}). Before issue 40's changes the same 10 M-row run peaked at 1276 MB, 110 B a "
        "row, in 117 s on this machine (identical f and zeta): SciPy's Welch held all three 5 M-sample segments "
        "detrended, padded and transformed at once, SciPy's filters in the decay-window search buffer whole lines, "
        "every noise peak of the record's spectrum became an object, and the reader joined its chunks into a second "
        "matrix."
    )
    write_results(
        "identify_rows",
        data,
        f"identify --report on {rows:,} rows: peak memory per row",
        ["file", "wall s", "peak MB"],
        table,
        notes,
    )


if __name__ == "__main__":
    main()
