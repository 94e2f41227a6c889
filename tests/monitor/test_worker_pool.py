"""The worker pool: batches, one BLAS thread per worker set once, workers kept for a run."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Iterator

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from axiswatch.monitor._parallel import MAX_BATCH, WorkerPool, _batch_size, parallel_map


def blas_threads(_: object) -> tuple[int, int]:
    """(process id, most threads any BLAS/OpenMP pool of this process may use)."""
    return os.getpid(), max((pool["num_threads"] for pool in threadpool_info()), default=1)


def test_batches_amortise_tasks_but_leave_every_worker_several() -> None:
    assert _batch_size(list(range(10)), slots=2) == 2
    assert _batch_size(list(range(100_000)), slots=2) == MAX_BATCH
    assert _batch_size(iter(range(10)), slots=2) == 1


@pytest.mark.parametrize("workers", [1, 2])
def test_every_worker_runs_blas_on_one_thread(workers: int) -> None:
    # The suite runs on one BLAS thread (tests/conftest.py): the driver is given two here, as
    # an unlimited one has on a 2-core machine, so that a worker left at the driver's would fail.
    with threadpool_limits(2):
        assert blas_threads(None)[1] == 2
        results = [r for _, r in parallel_map(blas_threads, range(8), workers=workers)]
    assert {threads for _, threads in results} == {1}


def test_a_pool_keeps_its_worker_processes_across_maps() -> None:
    # Which worker takes which task is up to the scheduler (a worker still starting may take
    # none of the first map's tasks), so the check is on the processes, not on who ran what:
    # the second map runs on processes that were already up after the first one.
    with WorkerPool(workers=2) as pool:
        first = {pid for _, (pid, _) in pool.map(blas_threads, range(8))}
        up_after_first = {child.pid for child in multiprocessing.active_children()}
        second = {pid for _, (pid, _) in pool.map(blas_threads, range(8))}
    assert os.getpid() not in first | second
    assert first <= up_after_first
    assert second <= up_after_first
    assert len(first | second) <= 2


def test_results_come_back_in_item_order_of_their_indices() -> None:
    with WorkerPool(workers=2) as pool:
        results = dict(pool.map(abs, [-i for i in range(100)]))
    assert results == {i: i for i in range(100)}


@pytest.mark.parametrize("workers", [1, 2])
def test_groups_are_the_batches_and_an_expected_length_sizes_an_iterators(workers: int) -> None:
    consumed: list[int] = []

    def produced(n: int) -> Iterator[int]:
        for i in range(n):
            consumed.append(i)
            yield -i

    with WorkerPool(workers=workers) as pool:
        sized = list(pool.map_groups(abs, produced(40), expected=40))
        unsized = list(pool.map_groups(abs, produced(10)))
    pairs = sorted(pair for group in sized for pair in group)
    assert pairs == [(i, i) for i in range(40)]
    if workers == 1:  # serial: one item at a time, in order
        assert [len(g) for g in sized] == [1] * 40
    else:  # sized as a sequence of 40 would be: 40 / (2 workers x 4 in flight) = 5 a batch
        assert sorted({len(g) for g in sized}) == [_batch_size(range(40), slots=2)] == [5]
    assert [len(g) for g in unsized] == [1] * 10
    assert consumed == list(range(40)) + list(range(10))
