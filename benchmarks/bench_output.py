"""Write a benchmark's numbers as reports/benchmarks/<name>.json and a short Markdown table beside it."""

from __future__ import annotations

import json
import os
import platform
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sloshid.core.atomic import write_text  # noqa: E402

OUT = ROOT / "reports" / "benchmarks"


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
    }
    data = {**data, "machine": machine}
    write_text(OUT / f"{name}.json", json.dumps(data, indent=2, default=float) + "\n")
    lines = [f"# {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    if notes:
        lines += ["", notes]
    write_text(OUT / f"{name}.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
