"""Run one function over many items: serially, on local processes, or on a Dask cluster.

:func:`parallel_map` yields ``(index, result)`` pairs as they complete. ``fn`` and the items must
pickle: send file paths, not arrays, and let the workers read the files.
"""

from __future__ import annotations

import concurrent.futures
import itertools
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import ExitStack
from typing import Any, TypeVar

from threadpoolctl import threadpool_limits

from axiswatch.monitor._malloc import arrays_reused, reuse_freed_arrays

__all__ = ["WorkerPool", "connect_dask", "parallel_map"]

T = TypeVar("T")
R = TypeVar("R")

#: Tasks kept in flight per worker: enough to hide scheduling latency, few enough that a long
#: item list is not materialised as futures all at once.
_IN_FLIGHT_PER_WORKER = 4
#: Most items in one task. A task carries a batch of items so that the per-task cost of the
#: driver (pickling, IPC; a Dask scheduler spends milliseconds of CPU per task) is paid once per
#: batch; batches stay small enough that every worker gets several.
MAX_BATCH = 32

_limited = False


def _one_blas_thread() -> None:
    """Limit BLAS/OpenMP to one thread in this worker process, once (idempotent).

    Parallelism is across items; a multi-threaded BLAS inside each only fights for the same
    cores (a 750 x 390 SVD took 30 s instead of 0.3 s on a loaded 2-core machine). Entering
    ``threadpool_limits`` costs milliseconds, so it is done once per worker, not per item.
    """
    global _limited
    if not _limited:
        threadpool_limits(1)
        _limited = True


#: How often a worker without ``prctl`` checks that its driver still lives, in seconds.
_PARENT_POLL_S = 1.0


def _end_with_parent(parent: int) -> None:
    """Worker initializer: end this worker when the driver process ends, however it ends.

    A driver killed by SIGTERM or SIGKILL (``timeout``, systemd, Kubernetes) runs no clean-up
    code, and its pool's workers would live on as orphans. On Linux the kernel sends the worker
    SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread sees
    the parent change. Either way a parent already gone before this ran ends the worker now.
    """
    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    else:  # pragma: no cover - exercised on macOS and Windows only

        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(_PARENT_POLL_S)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent:
        os._exit(1)


def _start_worker(parent: int) -> None:
    """Worker initializer: end with the driver (:func:`_end_with_parent`), one BLAS thread, and
    Ctrl-C left to the driver: a terminal sends SIGINT to the whole process group, and a worker
    interrupted while it waits for work would print a traceback; the driver stops the run, its
    pool cancels what has not started and the workers end with it."""
    global _limited
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _end_with_parent(parent)
    # A forked worker inherits the driver's flag but not necessarily its limits (a serial map
    # in the driver sets both, and its ``threadpool_limits`` context restores the limits).
    _limited = False
    _one_blas_thread()
    reuse_freed_arrays()


def _run_batch(fn: Callable[[T], R], batch: Sequence[T]) -> list[R]:
    _one_blas_thread()
    return [fn(item) for item in batch]


def _run_dask_batch(fn: Callable[[T], R], batch: Sequence[T]) -> list[R]:
    """:func:`_run_batch` on a Dask worker: freed arrays reused while it runs (``_malloc``)."""
    with arrays_reused():
        return _run_batch(fn, batch)


def _batch_size(items: Iterable[Any], slots: int) -> int:
    if not isinstance(items, Sequence):
        return 1
    return max(1, min(MAX_BATCH, math.ceil(len(items) / (slots * _IN_FLIGHT_PER_WORKER))))


def _batches(items: Iterable[T], size: int) -> Iterator[list[tuple[int, T]]]:
    iterator = enumerate(items)
    while batch := list(itertools.islice(iterator, size)):
        yield batch


class WorkerPool:
    """Workers that stay up for several :meth:`map` calls (a monitor run), so that what a worker
    keeps between tasks (fitted models, its one-thread BLAS set-up) is kept for the whole run.

    Parameters
    ----------
    workers, dask
        As in :func:`parallel_map`.

    Examples
    --------
    >>> with WorkerPool() as pool:
    ...     sorted(pool.map(abs, [-3, 1]))
    [(0, 3), (1, 1)]
    """

    def __init__(self, workers: int = 1, dask: object | None = None) -> None:
        if not (isinstance(workers, int) and not isinstance(workers, bool) and workers >= 1):
            raise ValueError(
                f"The 'workers' parameter must be an int >= 1. Got {workers!r} instead."
            )
        self.workers, self.dask = workers, dask
        self._stack = ExitStack()
        self._executor: concurrent.futures.ProcessPoolExecutor | None = None
        self._client: Any = None
        self._distributed: Any = None

    def __enter__(self) -> WorkerPool:
        if self.dask is not None:
            self._distributed, self._client, owned = _dask_client(self.dask)
            if owned:
                self._stack.callback(self._client.close)
        elif self.workers > 1:
            self._executor = concurrent.futures.ProcessPoolExecutor(
                max_workers=self.workers, initializer=_start_worker, initargs=(os.getpid(),)
            )
            self._stack.callback(self._executor.shutdown, wait=True, cancel_futures=True)
        else:
            self._stack.enter_context(threadpool_limits(1))
        return self

    def __exit__(self, *exc: object) -> None:
        self._stack.close()

    def map(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[tuple[int, R]]:
        """Apply ``fn`` to every item; yield ``(index, result)`` as results complete."""
        return (pair for group in self.map_groups(fn, items) for pair in group)

    def map_groups(
        self, fn: Callable[[T], R], items: Iterable[T], *, expected: int | None = None
    ) -> Iterator[list[tuple[int, R]]]:
        """As :meth:`map`, the results that arrive together in one list: a worker's batch (one
        item at a time when serial), so that the caller can store them in one transaction.

        ``expected``: how many items an iterator (consumed as batches are sent, so that the
        caller can go on producing them while the first ones run) will give, to size the
        batches as for a sequence of that length; without it an iterator goes item by item.

        Examples
        --------
        >>> with WorkerPool() as pool:
        ...     list(pool.map_groups(abs, [-3, 1]))
        [[(0, 3)], [(1, 1)]]
        """
        if self._client is not None:
            return self._dask_map(fn, items, expected)
        if self._executor is not None:
            return self._process_map(fn, items, expected)
        return ([(index, fn(item))] for index, item in enumerate(items))

    def _process_map(
        self, fn: Callable[[T], R], items: Iterable[T], expected: int | None
    ) -> Iterator[list[tuple[int, R]]]:
        executor = self._executor
        assert executor is not None

        def wait_one(futures: set[Any]) -> Iterable[Any]:
            done, _ = concurrent.futures.wait(
                futures, return_when=concurrent.futures.FIRST_COMPLETED
            )
            return done

        submitted: list[Any] = []

        def submit(batch: list[tuple[int, T]]) -> Any:
            future = executor.submit(_run_batch, fn, [item for _, item in batch])
            submitted.append(future)
            return future

        try:
            yield from _collect(
                submit, wait_one, items, self.workers, lambda future: future.result(), expected
            )
        finally:
            for future in submitted:
                future.cancel()

    def _dask_map(
        self, fn: Callable[[T], R], items: Iterable[T], expected: int | None
    ) -> Iterator[list[tuple[int, R]]]:
        client, distributed = self._client, self._distributed
        slots = max(1, sum(client.nthreads().values()))

        def wait_one(futures: set[Any]) -> Iterable[Any]:
            # wait() looks for the current client: a client made from an address is not the
            # default one (set_as_default=False), so it is made current for the call.
            with client.as_current():
                return list(distributed.wait(list(futures), return_when="FIRST_COMPLETED").done)

        submitted: list[Any] = []

        def submit(batch: list[tuple[int, T]]) -> Any:
            # pure=False: every batch is a task of its own, even when two batches are equal.
            future = client.submit(_run_dask_batch, fn, [item for _, item in batch], pure=False)
            submitted.append(future)
            return future

        def result(future: Any) -> list[R]:
            values: list[R] = future.result()
            future.release()
            return values

        try:
            yield from _collect(submit, wait_one, items, slots, result, expected)
        finally:
            client.cancel([f for f in submitted if not f.done()])


def _collect(
    submit: Callable[[list[tuple[int, T]]], Any],
    wait_one: Callable[[set[Any]], Iterable[Any]],
    items: Iterable[T],
    slots: int,
    result: Callable[[Any], list[R]],
    expected: int | None = None,
) -> Iterator[list[tuple[int, R]]]:
    """Keep ``slots * _IN_FLIGHT_PER_WORKER`` batches in flight; yield each batch's results
    (``(index, result)`` pairs) as it completes."""
    window = slots * _IN_FLIGHT_PER_WORKER
    pending: dict[Any, list[int]] = {}
    sized = items if expected is None else range(expected)
    batches = _batches(items, _batch_size(sized, slots))
    exhausted = False
    while True:
        while not exhausted and len(pending) < window:
            batch = next(batches, None)
            if batch is None:
                exhausted = True
                break
            pending[submit(batch)] = [index for index, _ in batch]
        if not pending:
            return
        for future in wait_one(set(pending)):
            yield list(zip(pending.pop(future), result(future), strict=True))


def parallel_map(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    workers: int = 1,
    dask: object | None = None,
) -> Iterator[tuple[int, R]]:
    """Apply ``fn`` to every item; yield ``(index, result)`` pairs as results complete.

    Items are sent to the workers in batches (a sequence is cut into batches of up to
    ``MAX_BATCH`` items, several per worker; an iterator item by item), and every worker runs
    BLAS on one thread, set once when it starts.

    Parameters
    ----------
    fn : callable
        A function of one item. Picklable (module-level) when ``workers > 1`` or ``dask`` is set.
    items : iterable
        Consumed lazily: at most a few batches per worker are in flight.
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
    pool = WorkerPool(workers, dask)
    if dask is not None:
        _dask_client_check(dask)
    return _pooled(pool, fn, items)


def _pooled(pool: WorkerPool, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[tuple[int, R]]:
    with pool:
        yield from pool.map(fn, items)


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError as error:
        raise ImportError(
            "The 'dask' option needs dask.distributed, which is not installed: "
            "pip install 'axiswatch[dask]' (or run with workers instead of dask)."
        ) from error
    return distributed


def _dask_client_check(dask: object) -> None:
    distributed = _import_distributed()
    if not isinstance(dask, str | distributed.Client):
        raise TypeError(
            "The 'dask' parameter must be a scheduler address (str) or a distributed.Client. "
            f"Got {type(dask).__name__} instead."
        )


def _dask_client(dask: object) -> tuple[Any, Any, bool]:
    """(distributed module, client, whether the client was made here and must be closed)."""
    _dask_client_check(dask)
    distributed = _import_distributed()
    if isinstance(dask, str):
        return distributed, connect_dask(dask), True
    return distributed, dask, False


#: Seconds a Dask scheduler has to answer before connecting counts as failed.
DASK_CONNECT_TIMEOUT_S = 10.0


def connect_dask(address: str, timeout_s: float = DASK_CONNECT_TIMEOUT_S) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or a one-line error.

    Raises
    ------
    ConnectionError
        If no Dask scheduler answers at ``address`` within ``timeout_s`` seconds (nothing
        listens, a firewall drops the packets), or another service answers there.
    ImportError
        If ``dask.distributed`` is not installed.
    """
    try:
        import distributed
    except ImportError as error:
        raise ImportError(
            "The 'dask' option needs dask.distributed, which is not installed: "
            "pip install 'axiswatch[dask]' (or run with workers instead of dask)."
        ) from error
    import asyncio

    async def probe() -> None:
        # The handshake alone, on a private event loop: a Client that fails half-way leaves a
        # background loop whose clean-up prints a traceback at exit.
        # With the client's connection arguments from Dask's configuration (TLS certificates).
        from distributed.comm.core import connect

        security = distributed.security.Security()  # type: ignore[no-untyped-call]
        arguments = security.get_connection_args("client")  # type: ignore[no-untyped-call]
        comm = await connect(address, timeout=timeout_s, **arguments)  # type: ignore[no-untyped-call]
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(probe(), timeout_s))
        return distributed.Client(  # type: ignore[no-untyped-call]
            address, timeout=timeout_s, set_as_default=False
        )
    except OSError as exc:  # nothing answered in time, or the connection was refused or reset
        text = (str(exc).splitlines() or [""])[0] or type(exc).__name__
        raise ConnectionError(
            f"no Dask scheduler answered at '{address}' within {timeout_s:g} s: {text}"
        ) from None
    except Exception:  # its bytes read as a Dask message: any error, none of them useful
        # The decoding error says nothing to a user: an HTTP answer read as a frame length
        # asked for "3.07 EiB".
        raise ConnectionError(
            f"no Dask scheduler answered at '{address}': another service answers there "
            "(its answer is no Dask message); check the host and port of the scheduler."
        ) from None
