"""Write a benchmark's numbers as reports/benchmarks/<name>.json and a short Markdown table beside it."""

from __future__ import annotations

import json
import os
import platform
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sloshid.core.atomic import write_text  # noqa: E402

OUT = ROOT / "reports" / "benchmarks"
LIBRARIES = ("numpy", "scipy", "opencv-python-headless", "av", "mitsuba", "casadi", "control")
"""Recorded with every result: the pbr scenes rendered and coded again from the same seeds in a fresh install moved the
tracker's figures (2026-12-07; OpenCV 5.0 against 5.1 moved none), so a result names the libraries that made it."""


def _version(name: str) -> str | None:
    """The installed version of a distribution, None when it is not installed."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def _cell(v) -> str:
    """Markdown cell text: floats with 4 significant digits."""
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def write_results(name: str, data: dict, title: str, header: list[str], rows: list[list], notes: str = "") -> None:
    """Save `data` as JSON and `rows` as a Markdown table (with the machine noted) in reports/benchmarks/."""
    machine = {
        "python": platform.python_version(),
        "cpu": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "load_avg_1min": os.getloadavg()[0],
        "libraries": {lib: _version(lib) for lib in LIBRARIES},
    }
    data = {**data, "machine": machine}
    write_text(OUT / f"{name}.json", json.dumps(data, indent=2, default=float) + "\n")
    lines = [f"# {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    if notes:
        lines += ["", notes]
    write_text(OUT / f"{name}.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
