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

Caches (created when missing, so a store made before them gains them when opened; deleting
their rows loses no result, only time):

``fitted_models``
    the fitted model of a baseline (``monitor._persist``: arrays and JSON, never pickle) with
    the baseline file's hash, the parameters and the library version it was fitted with; used
    only while all three still match.
``file_index``
    path, size, ``mtime_ns`` and SHA-256 of every capture file hashed: a file whose size and
    modification time are unchanged is never hashed again. ``verified_run`` is the run that
    last compared the file with the disk (kept files are verified a slice at a time).
``axis_folders``
    per axis folder and method, its modification time when a run last finished the axis: a
    folder whose time is unchanged holds no new, removed or renamed file, and is not listed.
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

_CACHES = """
CREATE TABLE IF NOT EXISTS fitted_models (
    baseline_id INTEGER PRIMARY KEY REFERENCES baselines (id),
    file_hash TEXT NOT NULL,
    params TEXT NOT NULL,
    library_version TEXT NOT NULL,
    model_hash TEXT NOT NULL,
    model BLOB NOT NULL,
    rates_hz TEXT NOT NULL,
    saved_at TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS fitted_models_hash ON fitted_models (model_hash);
CREATE TABLE IF NOT EXISTS file_index (
    path TEXT PRIMARY KEY,
    size INTEGER NOT NULL,
    mtime_ns INTEGER NOT NULL,
    hash TEXT NOT NULL,
    verified_run INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS file_index_verified ON file_index (verified_run);
CREATE TABLE IF NOT EXISTS axis_folders (
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    params TEXT NOT NULL,
    mtime_ns INTEGER NOT NULL,
    PRIMARY KEY (robot, axis, method)
);
CREATE INDEX IF NOT EXISTS scores_latest ON scores (baseline_id, role, id);
CREATE INDEX IF NOT EXISTS scores_path ON scores (path);
CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, started_at TEXT NOT NULL);
"""


class Store:
    """An open monitoring store (created with the current schema when the file is new).

    Parameters
    ----------
    path : str or Path
        The SQLite file.
    timeout_s : float, default=60.0
        How long a writer waits for another process's transaction before giving up.
    read_only : bool, default=False
        Open an existing store for reading only (a worker fetching fitted models).

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

    def __init__(
        self, path: str | Path, *, timeout_s: float = 60.0, read_only: bool = False
    ) -> None:
        self.path = Path(path)
        if self.path.exists() and not self.path.is_file():
            raise StoreError(f"store '{self.path}' exists but is not a file.")
        try:
            target = f"file:{self.path}?mode=ro" if read_only else str(self.path)
            self._connection = sqlite3.connect(
                target,
                timeout=timeout_s,
                isolation_level=None,
                check_same_thread=False,
                uri=read_only,
            )
            self._connection.row_factory = sqlite3.Row
            self._connection.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
            if read_only:
                # A worker reading fitted models: the driver made the schema.
                self.version = SCHEMA_VERSION
                return
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
                self._ensure_caches(connection)
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
            self._ensure_caches(connection)
            return int(version)

    @staticmethod
    def _ensure_caches(connection: sqlite3.Connection) -> None:
        indexed = connection.execute(
            "SELECT 1 FROM sqlite_master WHERE type='table' AND name='file_index'"
        ).fetchone()
        for statement in _CACHES.split(";"):
            if statement.strip():
                connection.execute(statement)
        if indexed is None:
            # A store made before the index: its scored files enter it as they were scored,
            # so that a later change in place is still found.
            connection.execute(
                "INSERT OR IGNORE INTO file_index (path, size, mtime_ns, hash, verified_run) "
                "SELECT path, file_size, file_mtime_ns, file_hash, 0 FROM scores ORDER BY id"
            )

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

    # --- fitted models (monitor._persist blobs) ------------------------------------------------

    def saved_model(self, baseline_id: int) -> sqlite3.Row | None:
        """The stored model of a baseline (file_hash, params, library_version, model_hash,
        rates_hz as JSON), without its blob."""
        return self._connection.execute(  # type: ignore[no-any-return]
            "SELECT file_hash, params, library_version, model_hash, rates_hz FROM fitted_models "
            "WHERE baseline_id=?",
            (baseline_id,),
        ).fetchone()

    def save_model(
        self,
        baseline_id: int,
        *,
        file_hash: str,
        params: str,
        library_version: str,
        model_hash: str,
        blob: bytes,
        rates_hz: str,
        saved_at: str,
    ) -> None:
        """Keep (or replace) the fitted model of a baseline."""
        with self.write() as db:
            db.execute(
                "INSERT OR REPLACE INTO fitted_models (baseline_id, file_hash, params, "
                "library_version, model_hash, model, rates_hz, saved_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    baseline_id, file_hash, params, library_version, model_hash, blob,
                    rates_hz, saved_at,
                ),
            )  # fmt: skip

    def model_blob(self, model_hash: str) -> bytes | None:
        """The blob of a stored model, by its hash."""
        row = self._connection.execute(
            "SELECT model FROM fitted_models WHERE model_hash=? LIMIT 1", (model_hash,)
        ).fetchone()
        return None if row is None else bytes(row[0])

    # --- file index and axis folders (monitor._index) -------------------------------------------

    def start_run(self, started_at: str) -> int:
        """Number a new monitor run (the file index records which run verified a file)."""
        with self.write() as db:
            return int(
                db.execute("INSERT INTO runs (started_at) VALUES (?)", (started_at,)).lastrowid or 0
            )

    def indexed_file(self, path: str) -> sqlite3.Row | None:
        """The index entry of a file (size, mtime_ns, hash), by path relative to the root."""
        return self._connection.execute(  # type: ignore[no-any-return]
            "SELECT size, mtime_ns, hash FROM file_index WHERE path=?", (path,)
        ).fetchone()

    def index_file(self, path: str, size: int, mtime_ns: int, digest: str, run: int) -> None:
        """Record (or update) a file's size, modification time and hash."""
        with self.write() as db:
            db.execute(
                "INSERT OR REPLACE INTO file_index (path, size, mtime_ns, hash, verified_run) "
                "VALUES (?, ?, ?, ?, ?)",
                (path, size, mtime_ns, digest, run),
            )

    def files_to_verify(self, run: int, limit: int) -> list[sqlite3.Row]:
        """Indexed files not verified in this run, least recently verified first."""
        return self.rows(
            "SELECT path, size, mtime_ns, hash FROM file_index WHERE verified_run < ? "
            "ORDER BY verified_run, path LIMIT ?",
            (run, limit),
        )

    def mark_verified(self, paths: Sequence[str], run: int) -> None:
        """Record that these files were compared with the disk in this run."""
        with self.write() as db:
            db.executemany(
                "UPDATE file_index SET verified_run=? WHERE path=?", [(run, p) for p in paths]
            )

    def scored_hash(self, path: str) -> sqlite3.Row | None:
        """The first score of a file (robot, axis, capture, file_hash), if it was scored."""
        return self._connection.execute(  # type: ignore[no-any-return]
            "SELECT robot, axis, capture, file_hash FROM scores WHERE path=? ORDER BY id LIMIT 1",
            (path,),
        ).fetchone()

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        """Whether this content of a file has a score (a point query: the run's cost must not
        follow the history)."""
        return (
            self._connection.execute(
                "SELECT 1 FROM scores WHERE path=? AND file_hash=? AND method=? LIMIT 1",
                (path, file_hash, method),
            ).fetchone()
            is not None
        )

    def axis_folder_times(self, method: str, params: str) -> dict[tuple[str, str], int]:
        """Modification time of every axis folder when a run with these parameters finished it."""
        return {
            (row["robot"], row["axis"]): int(row["mtime_ns"])
            for row in self.rows(
                "SELECT robot, axis, mtime_ns FROM axis_folders WHERE method=? AND params=?",
                (method, params),
            )
        }

    def finish_axis_folder(
        self, robot: str, axis: str, method: str, params: str, mtime_ns: int
    ) -> None:
        """Record that a run handled every file of an axis folder with this modification time."""
        with self.write() as db:
            db.execute(
                "INSERT OR REPLACE INTO axis_folders (robot, axis, method, params, mtime_ns) "
                "VALUES (?, ?, ?, ?, ?)",
                (robot, axis, method, params, mtime_ns),
            )

    def forget_axis_folder(self, db: sqlite3.Connection, robot: str, axis: str) -> None:
        """Inside a write transaction: the axis's folder must be listed again by the next run."""
        db.execute("DELETE FROM axis_folders WHERE robot=? AND axis=?", (robot, axis))

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
