"""The one parallel back-end: Dask. Local work (plan segments, robustness sweeps, a pipeline's videos) runs on Dask's
local process scheduler; a batch streams results from a `dask.distributed` cluster, local or remote. The tracker's
own forked helpers (span workers, the smoother) end with the process that forked them and leave its objects alone
(`forked_helper`)."""

from __future__ import annotations

import contextlib
import ctypes
import gc
import logging
import multiprocessing
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from sloshid.core.errors import SettingError, UserError
from sloshid.core.settings import setting_field

MAX_WORKERS_PER_CORE = 4
"""More local workers than this per core only queue up (and a huge number would hang starting them)."""


PR_SET_PDEATHSIG = 1
"""Linux prctl option: the signal the kernel sends a process when the thread that forked it ends."""


def forked_helper(parent_pid: int) -> None:
    """First thing in a forked helper: leave every object fork copied from the caller to the caller, and (Linux) be
    killed as soon as the forking thread ends, ending now if the parent `parent_pid` already has.

    The garbage collector must not free the caller's objects here: a video decoder the caller had left to it (its
    frame threads exist only in the caller) waits forever in FFmpeg for threads that were not copied, and so did the
    helper and the caller waiting for its answer. Without the second, a helper can outlive a killed or interrupted
    command (a pool worker started again while the pool was being stopped was seen waiting for tasks forever),
    holding the command's output pipes open."""
    gc.freeze()
    if not sys.platform.startswith("linux"):
        return
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
    if os.getppid() != parent_pid:
        os._exit(0)


@contextlib.contextmanager
def _stop_signals_handled_by(handler: Callable[[int, object], None]) -> Iterator[None]:
    """SIGINT and SIGTERM go to `handler` within the block, and back to the handlers they had after it; left alone
    outside the main thread, or where a handler set outside Python could not be put back. A signal the process ignores
    stays ignored (a command started with nohup, or in the background by a script): a solve that ended on it reported
    "did not converge" and carried on, where an interruption was never asked for."""
    wanted: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)
    if threading.current_thread() is not threading.main_thread() or None in map(signal.getsignal, wanted):
        yield
        return
    wanted = tuple(s for s in wanted if signal.getsignal(s) is not signal.SIG_IGN)
    previous = {s: signal.signal(s, handler) for s in wanted}
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back until the block ends, then deliver them to the handlers they had (main thread).

    Their handlers raise in the main thread wherever it is: starting a thread or a pool of processes, that leaves a
    thread that `is_alive` does not report or a pool that nothing stops. The handlers are swapped, not the signal
    mask: a masked signal still reaches FFmpeg's own threads, whose C handler makes Python run the handler here
    anyway. A process forked inside the block ends on them, as with no handler (it has not set its own yet)."""
    caught: list[int] = []
    here = os.getpid()

    def hold(signum: int, frame: object) -> None:
        if os.getpid() != here:
            os._exit(128 + signum)
        caught.append(signum)

    try:
        with _stop_signals_handled_by(hold):
            yield
    finally:
        for signum in caught:
            signal.raise_signal(signum)


@contextlib.contextmanager
def solver_interruptible() -> Iterator[None]:
    """Ctrl-C (or SIGTERM) during a CasADi solve, raised again once the solver has returned (main thread).

    CasADi stops IPOPT on the exception a signal handler raises, but swallows it and reports a failed solve
    (NonIpopt_Exception_Thrown), which a command would blame on the limits; the signal is delivered again to the
    handler it had when the block ends."""
    caught: list[int] = []

    def stop(signum: int, frame: object) -> None:
        caught.append(signum)
        raise KeyboardInterrupt  # what makes CasADi end the solve

    with _stop_signals_handled_by(stop):
        yield
    if caught:
        signal.raise_signal(caught[0])


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


@dataclass(frozen=True)
class ClusterSettings:
    """Where a batch's work runs (`sloshid batch`): local Dask worker processes, or a running Dask scheduler."""

    workers: int = setting_field(2, metavar="N")
    """Local Dask worker processes (one thread each); ignored with `scheduler`."""
    scheduler: str | None = setting_field(None, metavar="ADDRESS")
    """Address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786, instead of a local cluster; its workers must
    see the same file paths (a shared file system)."""

    def __post_init__(self) -> None:
        if self.scheduler is None:
            check_workers(self.workers)


CONNECT_WAIT_S = 10.0
"""How long a Dask scheduler may take to answer a new client."""
WORKER_WAIT_S = 30.0
"""How long a cluster may be without a worker (none joined yet, or the last one stopped) before a batch gives up."""


def _remote_client(scheduler: str):
    """A client of the scheduler at `scheduler` with at least one worker, or the one-sentence UserError: Dask's own
    connect timeout does not cover a port that takes the connection and never answers, so it runs in a thread
    that is left behind when it overstays."""
    from dask.distributed import Client

    box: dict[str, Any] = {}

    def connect() -> None:
        try:
            box["client"] = Client(scheduler, timeout=f"{CONNECT_WAIT_S:g}s")
        except Exception as exc:  # handed to the caller's thread
            box["error"] = exc

    thread = threading.Thread(target=connect, name="sloshid-dask-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_WAIT_S + 5)
    if thread.is_alive():
        raise UserError(
            f"the Dask scheduler at {scheduler} took the connection but did not answer in {CONNECT_WAIT_S + 5:.0f} s: "
            "is a Dask scheduler listening there?"
        )
    error = box.get("error")
    if isinstance(error, (OSError, TimeoutError, ValueError, TypeError)):
        raise UserError(f"could not reach the Dask scheduler at {scheduler} ({error}).")
    if error is not None:
        raise error
    client = box["client"]
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except TimeoutError:
        client.close()
        raise UserError(
            f"the Dask scheduler at {scheduler} has no worker (none joined in {WORKER_WAIT_S:.0f} s): start one with "
            f"`dask worker {scheduler}`."
        ) from None
    return client


def wait_with_workers(client, futures: Iterable, poll_s: float = 2.0) -> Iterator:
    """The futures as they finish, like `as_completed`, but a cluster left with no worker for WORKER_WAIT_S (the last
    one stopped) is the one-sentence UserError instead of a wait for ever."""
    from dask.distributed import wait

    pending, idle_s = set(futures), 0.0
    while pending:
        try:
            done, pending = wait(pending, timeout=poll_s, return_when="FIRST_COMPLETED")
        except TimeoutError:
            idle_s = idle_s + poll_s if not client.scheduler_info().get("workers") else 0.0
            if idle_s >= WORKER_WAIT_S:
                raise UserError(
                    f"the Dask cluster has had no worker for {WORKER_WAIT_S:.0f} s (the last one stopped) with "
                    f"{len(pending)} job(s) left: what finished is kept; run the same command again once workers are "
                    "back to do the rest."
                ) from None
            continue
        idle_s = 0.0
        yield from done


def dask_client(workers: int, scheduler: str | None = None):
    """A `dask.distributed` client: on a running scheduler, or on a local cluster of single-threaded processes."""
    from dask.distributed import Client

    if scheduler:
        return _remote_client(scheduler)
    check_workers(workers)
    # a client that starts its own local cluster also shuts it down when closed. Its worker processes start with
    # Ctrl-C ignored (a new Python keeps an ignored SIGINT): a terminal's Ctrl-C reaches the whole process group, and
    # each worker printed its own KeyboardInterrupt traceback while this process stopped the batch and the cluster
    # (a Ctrl-C in the second the cluster takes to start is lost: press it again)
    owned = threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is not None
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if owned else None
    try:
        return Client(
            # the workers' own log is silent: a failing video is the batch's row, and a stop (Ctrl-C, SIGTERM) made
            # them log tracebacks of the scheduler going away before them
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            # no dashboard; the scheduler's HTTP server (health, metrics) starts all the same: on a free local port,
            # not on 8787, where another cluster's made Dask warn on stderr
            dashboard_address="127.0.0.1:0",
            scheduler_kwargs={"dashboard": False},
            silence_logs=logging.CRITICAL,
        )
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


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
