"""The one parallel back-end: results come back in job order, in worker processes, and bad worker counts are
refused with one sentence."""

from __future__ import annotations

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
