"""Shared bits of the planner benchmarks: load a bundled scenario, time a call, write JSON + Markdown."""

from __future__ import annotations

import dataclasses
import time

import matplotlib

matplotlib.use("Agg")

from bench_output import OUT, ROOT, write_results

from sloshid.planning.scenario import Scenario, load_scenario


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

    from sloshid.core.atomic import atomic_path

    with atomic_path(OUT / f"{name}.png") as tmp:
        fig.savefig(tmp, dpi=100, bbox_inches="tight")
    plt.close(fig)


def write(name: str, data: dict, header: list[str], rows: list[list], notes: list[str]) -> None:
    """reports/benchmarks/<name>.json and .md, with the notes as a bullet list under the table."""
    write_results(name, data, name, header, rows, "\n".join(f"- {n}" for n in notes))
