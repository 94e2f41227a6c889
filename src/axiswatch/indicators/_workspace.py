"""Scratch arrays of the line statistics, kept per thread from one capture to the next.

A 3 s capture's waves take a few megabytes; fresh pages for them cost as much as their products.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["WORKSPACE_MAX_BYTES", "scratch"]

#: Largest scratch array kept for the next capture (bytes); larger ones are new each time.
WORKSPACE_MAX_BYTES = 8 << 20

_kept = threading.local()


def scratch(name: str, shape: tuple[int, ...], dtype: Any = np.float64) -> NDArray[Any]:
    """An uninitialised array of ``shape`` kept per thread under ``name`` for the next call (up
    to :data:`WORKSPACE_MAX_BYTES`). Valid until the next call with the same ``name`` in this
    thread: the line statistics fill it, read it and let it go.

    Examples
    --------
    >>> scratch("example", (2, 3)).shape
    (2, 3)
    >>> scratch("example", (3,)).base is scratch("example", (2,)).base
    True
    """
    kind = np.dtype(dtype)
    size = int(np.prod(shape))
    if size * kind.itemsize > WORKSPACE_MAX_BYTES:
        return np.empty(shape, dtype=kind)
    arrays: dict[tuple[str, str], NDArray[Any]] = _kept.__dict__.setdefault("arrays", {})
    flat = arrays.get((name, kind.str))
    if flat is None or flat.size < size:
        flat = arrays[(name, kind.str)] = np.empty(max(size, 1), dtype=kind)
    return flat[:size].reshape(shape)
