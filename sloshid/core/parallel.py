"""The one parallel back-end: Dask. Local work (plan segments, robustness sweeps, a pipeline's videos) runs on
Dask's local process scheduler; a batch streams results from a `dask.distributed` cluster, local or remote."""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from sloshid.core.errors import SettingError, UserError

MAX_WORKERS_PER_CORE = 4
"""More local workers than this per core only queue up (and a huge number would hang starting them)."""


def check_workers(workers: int, what: str = "workers") -> int:
    """A local worker count this machine can start: at least 1, at most MAX_WORKERS_PER_CORE per core."""
    cores = os.cpu_count() or 1
    if workers < 1:
        raise SettingError(what, f"{{name}} must be at least 1, got {workers}.")
    if workers > MAX_WORKERS_PER_CORE * cores:
        raise SettingError(
            what,
            f"{{name}} {workers} is more than this machine can run ({cores} cores); use at most "
            f"{MAX_WORKERS_PER_CORE * cores}, or a Dask scheduler for a cluster.",
        )
    return workers


def dask_client(workers: int, scheduler: str | None = None):
    """A `dask.distributed` client: on a running scheduler, or on a local cluster of single-threaded processes."""
    from dask.distributed import Client

    if scheduler:
        try:
            return Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise UserError(f"could not reach the Dask scheduler at {scheduler} ({exc}).") from None
    check_workers(workers)
    # a client that starts its own local cluster also shuts it down when closed
    return Client(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR
    )


def parallel_map(
    fn: Callable[..., Any],
    jobs: Iterable[Sequence[Any]],
    workers: int = 1,
    progress: bool = False,
    desc: str = "",
) -> list[Any]:
    """fn(*job) for every job, results in job order: in this process when workers <= 1 (or one job), else on
    Dask's local process scheduler with `workers` processes. A tqdm bar counts finished jobs when `progress`."""
    import dask
    from dask.callbacks import Callback
    from tqdm import tqdm

    jobs = list(jobs)
    bar = tqdm(total=len(jobs), desc=desc, disable=None if progress else True, leave=False)
    if workers <= 1 or len(jobs) <= 1:
        out = []
        for job in jobs:
            out.append(fn(*job))
            bar.update()
        bar.close()
        return out

    class _Tick(Callback):
        def _posttask(self, key, result, dsk, state, worker_id) -> None:
            bar.update()

    tasks = [dask.delayed(fn, pure=False)(*job) for job in jobs]
    # fork where the platform has it: workers start in milliseconds and inherit the imported numerics
    context = "fork" if "fork" in multiprocessing.get_all_start_methods() else None
    with dask.config.set({"multiprocessing.context": context} if context else {}), _Tick():
        workers = min(check_workers(workers), len(jobs))
        # chunksize 1: jobs here are few and long, so batching them (dask's default) would leave a worker idle
        out = list(dask.compute(*tasks, scheduler="processes", num_workers=workers, chunksize=1))
    bar.close()
    return out
