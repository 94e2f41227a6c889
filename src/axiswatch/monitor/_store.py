"""The monitoring store: one SQLite file holding baselines, scores, rejections and changed files.

Pipeline side-stage of the monitor (storage only; the decisions live in ``_monitor``).

Safety: the store runs in WAL mode with a busy timeout, and every write is one short transaction
opened with ``BEGIN IMMEDIATE`` (the writer takes the lock before it reads the state it builds
on). A process killed at any moment therefore leaves the store as it was after its last commit,
and two processes writing at once take turns instead of corrupting it.

Tables (schema version 1):

``baselines``
    one row per (robot, axis, method, epoch): the baseline capture, its file hash, the hash of
    its features, the monitor parameters (JSON), the library version, the calibrated threshold
    and half-Laplace fit (JSON, once calibration is complete), and when it was retired.
``rebaselines``
    requests to start a new epoch (``from_capture``: the new baseline, or NULL for "the next
    capture that arrives").
``scores``
    one row per capture and baseline: role (``baseline``, ``calibration``, ``monitor`` or
    ``excluded``), distance, threshold, whether it is over the threshold, the alarm state after
    it, a reason a service engineer can read and a JSON ``details`` column (phase lag, eigengap,
    ...). The row id is the scoring order.
``rejections``
    capture files that could not be used, with the error; keyed by file content hash, so a
    repaired file is tried again.
``changed_files``
    files whose content changed after they were scored (reported, never silently re-scored).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pandas as pd

from axiswatch.exceptions import StoreError

__all__ = ["SCHEMA_VERSION", "Store"]

SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE schema_version (version INTEGER NOT NULL);
CREATE TABLE baselines (
    id INTEGER PRIMARY KEY,
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    epoch INTEGER NOT NULL,
    capture TEXT NOT NULL,
    captured_at TEXT NOT NULL,
    path TEXT NOT NULL,
    file_hash TEXT NOT NULL,
    features_hash TEXT NOT NULL,
    params TEXT NOT NULL,
    library_version TEXT NOT NULL,
    threshold REAL,
    calibration TEXT,
    created_at TEXT NOT NULL,
    retired_at TEXT,
    UNIQUE (robot, axis, method, epoch)
);
CREATE TABLE rebaselines (
    id INTEGER PRIMARY KEY,
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    retired_epoch INTEGER NOT NULL,
    from_capture TEXT,
    requested_at TEXT NOT NULL
);
CREATE TABLE scores (
    id INTEGER PRIMARY KEY,
    baseline_id INTEGER NOT NULL REFERENCES baselines (id),
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    capture TEXT NOT NULL,
    captured_at TEXT NOT NULL,
    path TEXT NOT NULL,
    file_hash TEXT NOT NULL,
    file_size INTEGER NOT NULL,
    file_mtime_ns INTEGER NOT NULL,
    role TEXT NOT NULL CHECK (role IN ('baseline', 'calibration', 'monitor', 'excluded')),
    distance REAL,
    threshold REAL,
    over INTEGER NOT NULL,
    alarm INTEGER NOT NULL,
    reason TEXT NOT NULL,
    details TEXT NOT NULL,
    scored_at TEXT NOT NULL,
    UNIQUE (baseline_id, capture)
);
CREATE INDEX scores_axis ON scores (robot, axis, method);
CREATE TABLE rejections (
    id INTEGER PRIMARY KEY,
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    capture TEXT NOT NULL,
    path TEXT NOT NULL,
    file_hash TEXT NOT NULL,
    error TEXT NOT NULL,
    rejected_at TEXT NOT NULL,
    UNIQUE (method, path, file_hash)
);
CREATE TABLE changed_files (
    id INTEGER PRIMARY KEY,
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    capture TEXT NOT NULL,
    path TEXT NOT NULL,
    scored_hash TEXT NOT NULL,
    current_hash TEXT NOT NULL,
    detected_at TEXT NOT NULL,
    UNIQUE (path, scored_hash, current_hash)
);
"""


class Store:
    """An open monitoring store (created with the current schema when the file is new).

    Parameters
    ----------
    path : str or Path
        The SQLite file.
    timeout_s : float, default=60.0
        How long a writer waits for another process's transaction before giving up.

    Raises
    ------
    StoreError
        If the file is not an SQLite database, or holds another schema version.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> store = Store(pathlib.Path(tempfile.mkdtemp()) / "fleet.db")
    >>> store.version, store.rows("SELECT count(*) AS n FROM scores")[0]["n"]
    (1, 0)
    >>> store.close()
    """

    def __init__(self, path: str | Path, *, timeout_s: float = 60.0) -> None:
        self.path = Path(path)
        if self.path.exists() and not self.path.is_file():
            raise StoreError(f"store '{self.path}' exists but is not a file.")
        try:
            self._connection = sqlite3.connect(
                self.path, timeout=timeout_s, isolation_level=None, check_same_thread=False
            )
            self._connection.row_factory = sqlite3.Row
            self._connection.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
            self._connection.execute("PRAGMA journal_mode = WAL")
            self._connection.execute("PRAGMA synchronous = NORMAL")
            self._connection.execute("PRAGMA foreign_keys = ON")
            self.version = self._ensure_schema()
        except sqlite3.DatabaseError as exc:
            raise StoreError(
                f"store '{self.path}' cannot be opened as an axiswatch SQLite store: {exc}."
            ) from None

    def _ensure_schema(self) -> int:
        with self.write() as connection:
            tables = {
                row[0]
                for row in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")
            }
            if not tables:
                for statement in _SCHEMA.split(";"):
                    if statement.strip():
                        connection.execute(statement)
                connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
                return SCHEMA_VERSION
            if "schema_version" not in tables:
                raise StoreError(
                    f"store '{self.path}' is an SQLite file without an axiswatch schema "
                    f"(tables {sorted(tables)}); use a new file for the store."
                )
            version = connection.execute("SELECT max(version) FROM schema_version").fetchone()[0]
            if version != SCHEMA_VERSION:
                raise StoreError(
                    f"store '{self.path}' has schema version {version}; this axiswatch reads "
                    f"version {SCHEMA_VERSION}."
                )
            return int(version)

    @contextmanager
    def write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (``BEGIN IMMEDIATE`` ... ``COMMIT``; rolled back on error)."""
        connection = self._connection
        connection.execute("BEGIN IMMEDIATE")
        try:
            yield connection
        except BaseException:
            connection.execute("ROLLBACK")
            raise
        connection.execute("COMMIT")

    def rows(self, sql: str, parameters: Sequence[Any] = ()) -> list[sqlite3.Row]:
        """Rows of a read-only query."""
        return list(self._connection.execute(sql, parameters))

    def frame(self, sql: str, parameters: Sequence[Any] = ()) -> pd.DataFrame:
        """A read-only query as a DataFrame."""
        cursor = self._connection.execute(sql, parameters)
        columns = [d[0] for d in cursor.description]
        return pd.DataFrame([tuple(r) for r in cursor.fetchall()], columns=columns)

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
