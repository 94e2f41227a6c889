"""Run one function over many items: serially, on local processes, or on a Dask cluster.

The fleet's scoring is embarrassingly parallel (one capture file at a time), so the layer is one
function, :func:`parallel_map`, that yields ``(index, result)`` pairs as results complete; the
caller (the monitor) keeps writing its store from the driver process only. ``fn`` and the items
must be picklable for processes and for a cluster (a module-level function, paths, small
objects): send file paths, not arrays, and let the workers read the files.
"""

from __future__ import annotations

import concurrent.futures
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

__all__ = ["parallel_map"]

T = TypeVar("T")
R = TypeVar("R")

#: Tasks kept in flight per worker: enough to hide scheduling latency, few enough that a long
#: item list is not materialised as futures all at once.
_IN_FLIGHT_PER_WORKER = 4


def parallel_map(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    workers: int = 1,
    dask: object | None = None,
) -> Iterator[tuple[int, R]]:
    """Apply ``fn`` to every item; yield ``(index, result)`` pairs as results complete.

    Parameters
    ----------
    fn : callable
        A function of one item. Picklable (module-level) when ``workers > 1`` or ``dask`` is set.
    items : iterable
        Consumed lazily: at most a few tasks per worker are in flight.
    workers : int, default=1
        ``1`` (and no ``dask``): serial, in order, in this process. ``> 1``: that many local
        processes (:class:`concurrent.futures.ProcessPoolExecutor`). Ignored with ``dask``.
    dask : str or distributed.Client, optional
        A Dask scheduler address (``"tcp://host:8786"``) or a ``distributed.Client``: the tasks
        run on that cluster. A client made from an address is closed at the end; a given client
        is left open. Needs ``dask.distributed`` (``pip install 'axiswatch[dask]'``).

    Yields
    ------
    index : int
        Position of the item in ``items``.
    result
        ``fn(item)``. An exception raised by ``fn`` is raised here, in the caller.

    Examples
    --------
    >>> sorted(parallel_map(abs, [-3, 1, -2]))
    [(0, 3), (1, 1), (2, 2)]
    """
    if not (isinstance(workers, int) and not isinstance(workers, bool) and workers >= 1):
        raise ValueError(f"The 'workers' parameter must be an int >= 1. Got {workers!r} instead.")
    if dask is not None:
        return _dask_map(fn, items, dask)
    if workers == 1:
        return ((index, fn(item)) for index, item in enumerate(items))
    return _process_map(fn, items, workers)


def _windowed(
    submit: Callable[[T], Any],
    wait_one: Callable[[set[Any]], Iterable[Any]],
    items: Iterable[T],
    window: int,
) -> Iterator[tuple[int, Any]]:
    """Keep ``window`` futures in flight; yield (index, future) as they complete."""
    pending: dict[Any, int] = {}
    iterator = enumerate(items)
    exhausted = False
    while True:
        while not exhausted and len(pending) < window:
            try:
                index, item = next(iterator)
            except StopIteration:
                exhausted = True
                break
            pending[submit(item)] = index
        if not pending:
            return
        for future in wait_one(set(pending)):
            yield pending.pop(future), future


def _process_map(fn: Callable[[T], R], items: Iterable[T], workers: int) -> Iterator[tuple[int, R]]:
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers) as pool:

        def wait_one(futures: set[Any]) -> Iterable[Any]:
            done, _ = concurrent.futures.wait(
                futures, return_when=concurrent.futures.FIRST_COMPLETED
            )
            return done

        try:
            for index, future in _windowed(
                lambda item: pool.submit(fn, item),
                wait_one,
                items,
                workers * _IN_FLIGHT_PER_WORKER,
            ):
                yield index, future.result()
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _dask_map(fn: Callable[[T], R], items: Iterable[T], dask: object) -> Iterator[tuple[int, R]]:
    try:
        import distributed
    except ImportError as error:
        raise ImportError(
            "The 'dask' option needs dask.distributed, which is not installed: "
            "pip install 'axiswatch[dask]' (or run with workers instead of dask)."
        ) from error
    if isinstance(dask, str):
        client = distributed.Client(dask)  # type: ignore[no-untyped-call]
        owned = True
    elif isinstance(dask, distributed.Client):
        client, owned = dask, False
    else:
        raise TypeError(
            "The 'dask' parameter must be a scheduler address (str) or a distributed.Client. "
            f"Got {type(dask).__name__} instead."
        )
    return _dask_results(client, owned, fn, items, distributed)


def _dask_results(
    client: Any, owned: bool, fn: Callable[[T], R], items: Iterable[T], distributed: Any
) -> Iterator[tuple[int, R]]:
    window = max(1, sum(client.nthreads().values())) * _IN_FLIGHT_PER_WORKER

    def wait_one(futures: set[Any]) -> Iterable[Any]:
        done = distributed.wait(list(futures), return_when="FIRST_COMPLETED").done
        return list(done)

    submitted: list[Any] = []

    def submit(item: T) -> Any:
        # pure=False: every item is a task of its own, even when two items are equal.
        future = client.submit(fn, item, pure=False)
        submitted.append(future)
        return future

    try:
        for index, future in _windowed(submit, wait_one, items, window):
            yield index, future.result()
            future.release()
    finally:
        client.cancel([f for f in submitted if not f.done()])
        if owned:
            client.close()
