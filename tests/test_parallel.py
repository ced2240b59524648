"""The one parallel back-end: results come back in job order, in worker processes, and bad worker counts are
refused with one sentence."""

from __future__ import annotations

import io
import os

import pytest

from sloshid.core.errors import UserError
from sloshid.core.parallel import check_workers, parallel_map


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


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal (tqdm draws only on one)."""

    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("terminal", [True, False])
def test_progress_bar_draws_only_on_a_terminal(terminal, monkeypatch):
    # a bar asked for is drawn on a terminal, and not into a log file or pipe that stderr was redirected to
    err = _Terminal() if terminal else io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    parallel_map(_square_and_pid, [(i,) for i in range(3)], workers=1, progress=True, desc="squares")
    assert ("squares" in err.getvalue()) is terminal
