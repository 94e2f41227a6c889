"""Where scoring jobs run: ``parallel_map`` is the one hook the monitor calls.

This is the serial implementation only (the Dask/process version is another issue's work and
replaces this module with the same signature). ``fn`` must be a top-level, picklable function of
one self-contained job that returns a result or an error record and never raises for bad input.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

__all__ = ["parallel_map"]

T = TypeVar("T")
R = TypeVar("R")


def parallel_map(
    fn: Callable[[T], R],
    items: Iterable[T],
    *,
    workers: int = 1,
    dask: object | None = None,
) -> Iterator[tuple[int, R]]:
    """Apply ``fn`` to every item; yield ``(index, result)`` as results complete.

    Parameters
    ----------
    fn : callable
        Top-level (picklable) function of one job.
    items : iterable
        The jobs.
    workers : int, default=1
        Number of local worker processes. This serial implementation accepts only 1.
    dask : object or None, default=None
        A Dask scheduler address or client. Not supported by this serial implementation.

    Yields
    ------
    (int, result)
        Index of the job in ``items`` and ``fn(job)``; in index order here, in completion order
        in a parallel implementation.

    Examples
    --------
    >>> list(parallel_map(abs, [-2, 3]))
    [(0, 2), (1, 3)]
    """
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"The 'workers' parameter must be an int >= 1. Got {workers!r} instead.")
    if workers != 1 or dask is not None:
        raise NotImplementedError(
            "This build of axiswatch runs scoring serially only: got "
            f"workers={workers!r}, dask={dask!r}; use workers=1 and no dask address."
        )
    for index, item in enumerate(items):
        yield index, fn(item)
