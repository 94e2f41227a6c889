"""Incremental discovery: a run's cost follows the new files, not the history in the folder.

A file index, unchanged axis folders skipped, and kept files verified a slice per run.
docs/internals.md, "Incremental discovery", gives the budget.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from axiswatch.monitor._scoring import file_hash
from axiswatch.monitor.store import IndexedFile, RunCaches, SavedModel, ScoredFile, StoreWriter

__all__ = [
    "VERIFY_MIN",
    "VERIFY_PER_AXIS",
    "FileIndex",
    "MemoryCaches",
    "run_caches",
    "axis_folder_time",
    "unchanged_axes",
    "verify_budget",
]

#: Kept files compared with the disk per run and axis folder (a stat each, ~10 us).
VERIFY_PER_AXIS = 4
#: ... and at least this many per run (small fleets: all their files within a few runs).
VERIFY_MIN = 64


def verify_budget(n_axes: int) -> int:
    """Kept files a run compares with the disk: ``max(VERIFY_MIN, VERIFY_PER_AXIS * n_axes)``.

    Examples
    --------
    >>> verify_budget(10), verify_budget(60_000)
    (64, 240000)
    """
    return max(VERIFY_MIN, VERIFY_PER_AXIS * n_axes)


def axis_folder_time(root: Path, robot: str, axis: str) -> int | None:
    """Modification time (ns) of ``root/robot/axis``; None when it is not a folder."""
    try:
        stat = os.stat(root / robot / axis)
    except OSError:
        return None
    return stat.st_mtime_ns


def unchanged_axes(
    root: Path, folder_times: dict[tuple[str, str], int], dirty: Iterable[tuple[str, str]]
) -> set[tuple[str, str]]:
    """Axes whose folder still has the time recorded when a run finished it
    (``Store.axis_folder_times``: nothing added, removed or renamed since), except ``dirty``."""
    dirty = set(dirty)
    return {
        axis
        for axis, mtime_ns in folder_times.items()
        if axis not in dirty and axis_folder_time(root, *axis) == mtime_ns
    }


class MemoryCaches:
    """:class:`~axiswatch.monitor.store.RunCaches` for one run, in memory, for a store without
    its own: nothing is kept between runs (every baseline refitted, every folder listed), and
    the index starts from what the store says of every scored file, all verified each run (the
    behaviour before the caches existed). Models travel with the jobs."""

    def __init__(self, store: StoreWriter) -> None:
        self._store = store
        self._scored = store.scored_files()
        self._index = {
            path: IndexedFile(path, f.file_size, f.file_mtime_ns, f.file_hash)
            for path, f in self._scored.items()
        }
        self._verified: dict[str, int] = {}

    def model_source(self) -> str | None:
        return None

    def saved_model(self, baseline_id: int) -> SavedModel | None:
        return None

    def save_model(self, baseline_id: int, saved: SavedModel, blob: bytes) -> None:
        return None

    def model_blob(self, model_hash: str) -> bytes | None:
        return None

    def start_run(self) -> int:
        return 1

    def indexed_file(self, path: str) -> IndexedFile | None:
        return self._index.get(path)

    def index_file(self, entry: IndexedFile, run: int) -> None:
        self._index[entry.path] = entry
        self._verified[entry.path] = run

    def files_to_verify(self, run: int, limit: int) -> list[IndexedFile]:
        waiting = [e for p, e in sorted(self._index.items()) if self._verified.get(p, 0) < run]
        return waiting

    def mark_verified(self, paths: Iterable[str], run: int) -> None:
        self._verified.update(dict.fromkeys(paths, run))

    def last_scored(self, path: str) -> ScoredFile | None:
        return self._scored.get(path)

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        return (path, file_hash) in self._store.scored_contents(method)

    def axis_folder_times(self, method: str, params: str) -> dict[tuple[str, str], int]:
        return {}

    def finish_axis_folder(
        self, robot: str, axis: str, method: str, params: str, mtime_ns: int
    ) -> None:
        return None


def run_caches(store: StoreWriter) -> RunCaches:
    """The store's own caches, or :class:`MemoryCaches` for a store without them."""
    return store if isinstance(store, RunCaches) else MemoryCaches(store)


class FileIndex:
    """Hashes of the fleet's files, kept in the store and reused while a file is unchanged.

    Parameters
    ----------
    caches : RunCaches
    root : Path
        The fleet folder; paths in the index are relative to it.
    run : int
        This run's number (``Store.start_run``).
    """

    def __init__(self, caches: RunCaches, root: Path, run: int) -> None:
        self.caches, self.root, self.run = caches, root, run

    def digest(self, path: Path) -> str:
        """SHA-256 of a file, hashed only when its size or modification time changed."""
        relative = path.relative_to(self.root).as_posix()
        stat = path.stat()
        entry = self.caches.indexed_file(relative)
        if entry is not None and (entry.size, entry.mtime_ns) == (stat.st_size, stat.st_mtime_ns):
            return entry.hash
        digest = file_hash(path)
        self.caches.index_file(
            IndexedFile(relative, stat.st_size, stat.st_mtime_ns, digest), self.run
        )
        return digest

    def verify(self, limit: int) -> tuple[list[tuple[str, str, str]], set[tuple[str, str]]]:
        """Compare up to ``limit`` indexed files (least recently verified first) with the disk.

        Returns
        -------
        changed : list of (relative path, indexed hash, current hash)
            Files whose content differs from the index (the index is updated).
        dirty : set of (robot, axis)
            Axes with a changed or missing file: their folders must be listed again.
        """
        changed: list[tuple[str, str, str]] = []
        dirty: set[tuple[str, str]] = set()
        verified: list[str] = []
        for entry in self.caches.files_to_verify(self.run, limit):
            relative = entry.path
            verified.append(relative)
            parts = relative.split("/")
            axis = (parts[0], parts[1]) if len(parts) == 3 else None
            path = self.root / relative
            try:
                stat = path.stat()
            except OSError:
                if axis is not None:
                    dirty.add(axis)
                continue
            if (stat.st_size, stat.st_mtime_ns) == (entry.size, entry.mtime_ns):
                continue
            current = file_hash(path)
            self.caches.index_file(
                IndexedFile(relative, stat.st_size, stat.st_mtime_ns, current), self.run
            )
            if current != entry.hash:
                changed.append((relative, entry.hash, current))
                if axis is not None:
                    dirty.add(axis)
        self.caches.mark_verified(verified, self.run)
        return changed, dirty
