"""Incremental discovery: a run's cost follows the new files, not the history kept in the folder.

Pipeline side-stage of the monitor, a layer over ``_fleet`` (which knows the layout rules):

* **File index** (:class:`FileIndex`): the store keeps each hashed file's size, ``mtime_ns`` and
  SHA-256; a file whose size and modification time are unchanged is never hashed again.
* **Axis folders**: when a run has handled every file of an axis folder, the store keeps the
  folder's modification time. Adding, removing or renaming a file changes it; a folder whose
  time is unchanged is not listed again (:func:`unchanged_axes`), so a run with nothing new
  costs one ``stat`` per axis, whatever the history.
* **Verification of kept files** (:meth:`FileIndex.verify`): a file rewritten in place leaves
  its folder's time alone, so each run compares a slice of the indexed files with the disk
  (size and modification time; the hash only where they differ), least recently verified
  first: :func:`verify_budget` files a run (``VERIFY_PER_AXIS`` per axis folder, at least
  ``VERIFY_MIN``), so every kept file is checked once every ``ceil(n_files / budget)`` runs
  (a year of daily captures: every ~90 runs) at a cost that grows with the fleet, like a day's
  run, and not with its history. A changed file that was scored
  is reported (``changed_files``), and its axis folder is listed again.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from axiswatch.monitor._scoring import file_hash
from axiswatch.monitor._store import Store

__all__ = [
    "VERIFY_MIN",
    "VERIFY_PER_AXIS",
    "FileIndex",
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


class FileIndex:
    """Hashes of the fleet's files, kept in the store and reused while a file is unchanged.

    Parameters
    ----------
    store : Store
    root : Path
        The fleet folder; paths in the index are relative to it.
    run : int
        This run's number (``Store.start_run``).
    """

    def __init__(self, store: Store, root: Path, run: int) -> None:
        self.store, self.root, self.run = store, root, run

    def digest(self, path: Path) -> str:
        """SHA-256 of a file, hashed only when its size or modification time changed."""
        relative = path.relative_to(self.root).as_posix()
        stat = path.stat()
        entry = self.store.indexed_file(relative)
        if entry is not None and (entry["size"], entry["mtime_ns"]) == (
            stat.st_size,
            stat.st_mtime_ns,
        ):
            return str(entry["hash"])
        digest = file_hash(path)
        self.store.index_file(relative, stat.st_size, stat.st_mtime_ns, digest, self.run)
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
        for row in self.store.files_to_verify(self.run, limit):
            relative = str(row["path"])
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
            if (stat.st_size, stat.st_mtime_ns) == (row["size"], row["mtime_ns"]):
                continue
            current = file_hash(path)
            self.store.index_file(relative, stat.st_size, stat.st_mtime_ns, current, self.run)
            if current != row["hash"]:
                changed.append((relative, str(row["hash"]), current))
                if axis is not None:
                    dirty.add(axis)
        self.store.mark_verified(verified, self.run)
        return changed, dirty
