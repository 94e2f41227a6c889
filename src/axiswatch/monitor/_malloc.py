"""The C allocator of a Dask worker, set to reuse freed arrays while it scores a batch.

A nanny starts its worker with ``MALLOC_TRIM_THRESHOLD_=65536``, which pins glibc's mmap
threshold at 128 kB: every larger array is mapped and faulted in afresh, a quarter more CPU per
job (docs/performance.md). Processes whose environment sets no threshold are left alone. A
process pool's worker keeps freed arrays from its start (:func:`reuse_freed_arrays`).
"""

from __future__ import annotations

import ctypes
import functools
import os
import platform
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["arrays_reused", "reuse_freed_arrays"]

#: ``mallopt`` parameters (glibc's malloc.h), with the variables that set them at start.
_THRESHOLDS = {"MALLOC_TRIM_THRESHOLD_": -1, "MALLOC_MMAP_THRESHOLD_": -3}
#: The thresholds of an untuned glibc process once it has freed a large array: its adaptive
#: mmap threshold's ceiling on 64-bit systems, and twice that for trimming.
REUSED = {"MALLOC_MMAP_THRESHOLD_": 32 * 1024 * 1024, "MALLOC_TRIM_THRESHOLD_": 64 * 1024 * 1024}
#: glibc's default of a threshold the environment does not set.
_GLIBC_DEFAULT = 128 * 1024


@functools.cache
def _glibc() -> ctypes.CDLL | None:
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    return ctypes.CDLL(None)


def _from_environment() -> dict[str, int] | None:
    """The thresholds this process's environment sets, or None if it sets none (or no glibc)."""
    if _glibc() is None or not any(variable in os.environ for variable in _THRESHOLDS):
        return None
    settings = {}
    for variable in _THRESHOLDS:
        try:
            settings[variable] = int(os.environ.get(variable, _GLIBC_DEFAULT))
        except ValueError:
            settings[variable] = _GLIBC_DEFAULT
    return settings


def _apply(settings: dict[str, int]) -> None:
    libc = _glibc()
    assert libc is not None
    for variable, value in settings.items():
        libc.mallopt(_THRESHOLDS[variable], value)


def reuse_freed_arrays() -> None:
    """Keep freed arrays for reuse for the rest of this process (a pool's worker): glibc's
    thresholds at the ceiling an untuned process reaches only after it freed a large array."""
    if _glibc() is not None:
        _apply(REUSED)


_lock = threading.Lock()
_blocks = 0


@contextmanager
def arrays_reused() -> Iterator[None]:
    """Freed arrays kept for reuse while the block runs, where the environment pins glibc's
    thresholds; the environment's thresholds, and freed memory returned, when the last such
    block of the process ends. Elsewhere nothing is changed."""
    global _blocks
    settings = _from_environment()
    if settings is None:
        yield
        return
    with _lock:
        _blocks += 1
        if _blocks == 1:
            _apply(REUSED)
    try:
        yield
    finally:
        with _lock:
            _blocks -= 1
            if _blocks == 0:
                _apply(settings)
                _glibc().malloc_trim(0)  # type: ignore[union-attr]
