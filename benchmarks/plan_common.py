"""Shared bits of the planner benchmarks: load a bundled scenario, time a call, write JSON + Markdown."""

from __future__ import annotations

import dataclasses
import json

import matplotlib

matplotlib.use("Agg")
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sloshid.atomic import write_text  # noqa: E402
from sloshid.scenario import Scenario, load_scenario  # noqa: E402

OUT = ROOT / "reports" / "benchmarks"


def scenario(name: str, **solver_changes) -> Scenario:
    """A bundled scenario from data/scenarios/, with [solver] settings changed."""
    sc = load_scenario(ROOT / "data" / "scenarios" / f"{name}.toml")
    return dataclasses.replace(sc, solver=dataclasses.replace(sc.solver, **solver_changes)) if solver_changes else sc


def timed(fn, *args, **kwargs):
    """(result, wall seconds, process CPU seconds) of one call."""
    w, c = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - w, time.process_time() - c


def save_figure(fig, name: str) -> None:
    """reports/benchmarks/<name>.png, written atomically."""
    import matplotlib.pyplot as plt

    from sloshid.atomic import atomic_path

    with atomic_path(OUT / f"{name}.png") as tmp:
        fig.savefig(tmp, dpi=100, bbox_inches="tight")
    plt.close(fig)


def write(name: str, data: dict, header: list[str], rows: list[list], notes: list[str]) -> None:
    """reports/benchmarks/<name>.json (all numbers) and <name>.md (a short table and notes)."""
    import os

    data = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                        "load_avg_1min": os.getloadavg()[0]}, **data}  # fmt: skip
    write_text(OUT / f"{name}.json", json.dumps(data, indent=2, default=float) + "\n")
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)  # noqa: E731
    lines = [f"# {name}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in rows]
    lines += [""] + [f"- {n}" for n in notes] + [""]
    write_text(OUT / f"{name}.md", "\n".join(lines))
    print("\n".join(lines))
