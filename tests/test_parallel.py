"""The one parallel back-end: results come back in job order, in worker processes, and bad worker counts are
refused with one sentence."""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import time

import pytest

from sloshid.core.errors import UserError
from sloshid.core.parallel import check_workers, parallel_map, signals_held, solver_interruptible


def _square_and_pid(x: int) -> tuple[int, int]:
    return x * x, os.getpid()


def test_results_in_job_order_from_worker_processes():
    out = parallel_map(_square_and_pid, [(i,) for i in range(6)], workers=2)
    assert [v for v, _ in out] == [i * i for i in range(6)]
    assert os.getpid() not in {pid for _, pid in out}  # the work ran in worker processes
    serial = parallel_map(_square_and_pid, [(3,)], workers=2)  # one job stays in this process
    assert serial == [(9, os.getpid())]


@pytest.mark.parametrize("workers", [0, 10**6])
def test_worker_counts_a_machine_cannot_run_are_refused(workers):
    with pytest.raises(UserError, match="workers"):
        check_workers(workers)


@pytest.mark.parametrize("terminal", [True, False])
def test_progress_bar_draws_only_on_a_terminal(terminal, stderr_as):
    # a bar asked for is drawn on a terminal, and not into a log file or pipe that stderr was redirected to
    err = stderr_as(terminal)
    parallel_map(_square_and_pid, [(i,) for i in range(3)], workers=1, progress=True, desc="squares")
    assert ("squares" in err.getvalue()) is terminal


def test_signals_held_are_delivered_when_the_block_ends():
    # the decoding thread starts with SIGTERM held back, so the handler cannot interrupt Thread.start half-way;
    # a signal that arrives meanwhile must reach the handler afterwards, not be lost
    seen = []

    def handler(signum, frame):
        seen.append("handled")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        with signals_held():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)  # long enough for an unheld handler to run (Python runs it within microseconds)
            assert seen == []
        time.sleep(0.05)
        assert seen == ["handled"]
        assert signal.getsignal(signal.SIGTERM) is handler
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_an_ignored_ctrl_c_stays_ignored_during_a_solve():
    # a plan started where SIGINT is ignored (nohup, a script's background job): the solve took it over anyway, so a
    # SIGINT stopped IPOPT and plan printed "did not converge ... relax [limits]" with exit 2
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with solver_interruptible():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # a handler would have run (and raised KeyboardInterrupt) by now
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def _sleep_after(ready) -> None:
    """A forked child that has set no handler of its own: says it runs, then sleeps."""
    ready.set()
    time.sleep(60)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork")
def test_a_process_forked_while_signals_are_held_ends_on_sigterm():
    # a pool worker forked inside the block has not set its own handlers yet: SIGTERM (the pool's terminate) must end
    # it, not be held for a delivery that never comes there (the pool would wait for it forever)
    ctx = multiprocessing.get_context("fork")
    ready = ctx.Event()
    with signals_held():
        child = ctx.Process(target=_sleep_after, args=(ready,))
        child.start()
    assert ready.wait(30)
    child.terminate()
    child.join(10)
    assert child.exitcode == 128 + signal.SIGTERM, child.exitcode
