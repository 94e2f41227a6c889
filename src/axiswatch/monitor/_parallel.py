"""Run one function over many items: serially, on local processes, or on a Dask cluster.

The fleet's scoring is embarrassingly parallel (one capture file at a time), so the layer is one
function, :func:`parallel_map`, that yields ``(index, result)`` pairs as results complete; the
caller (the monitor) keeps writing its store from the driver process only. ``fn`` and the items
must be picklable for processes and for a cluster (a module-level function, paths, small
objects): send file paths, not arrays, and let the workers read the files.
"""

from __future__ import annotations

import concurrent.futures
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

__all__ = ["connect_dask", "parallel_map"]

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


def _process_map(fn: Callable[[T], R], items: Iterable[T], workers: int) -> Iterator[tuple[int, R]]:
    with concurrent.futures.ProcessPoolExecutor(
        max_workers=workers, initializer=_end_with_parent, initargs=(os.getpid(),)
    ) as pool:

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
        client = connect_dask(dask)
        owned = True
    elif isinstance(dask, distributed.Client):
        client, owned = dask, False
    else:
        raise TypeError(
            "The 'dask' parameter must be a scheduler address (str) or a distributed.Client. "
            f"Got {type(dask).__name__} instead."
        )
    return _dask_results(client, owned, fn, items, distributed)


#: Seconds a Dask scheduler has to answer before connecting counts as failed.
DASK_CONNECT_TIMEOUT_S = 10.0


def connect_dask(address: str, timeout_s: float = DASK_CONNECT_TIMEOUT_S) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, or a one-line error.

    Raises
    ------
    ConnectionError
        If no Dask scheduler answers at ``address`` within ``timeout_s`` seconds (nothing
        listens, a firewall drops the packets, or another service answers: its bytes read as a
        Dask message can ask for gigabytes, a ``MemoryError``).
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
    except Exception as exc:  # whatever answered, it is not a usable scheduler
        text = (str(exc).splitlines() or [""])[0] or type(exc).__name__
        raise ConnectionError(
            f"no Dask scheduler answered at '{address}' within {timeout_s:g} s: {text}"
        ) from None


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
