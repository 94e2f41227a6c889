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

Added in place when a store is opened (additive: older readers ignore them):
``rejections.kind`` (``layout``, ``unreadable``, ``invalid``, ``bad data``, ``out of order``,
``future``), ``rejections.params_hash`` (the monitor parameters the rejection was made under;
NULL when it does not depend on them, so it is retried when they change), ``rejections.transient``
(re-checked every run: unreadable files, future dates), ``rejections.acknowledged_at`` and
``changed_files.acknowledged_at`` (a standing problem someone has seen no longer sets exit 8),
and the table ``axis_activity`` (per axis: files seen, newest capture, when a new file was last
seen; an axis silent longer than ``--stale-after`` is *stale*).
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

#: Additive upgrades applied on open, each (table, column, declaration).
_ADDED_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("rejections", "kind", "TEXT"),
    ("rejections", "params_hash", "TEXT"),
    ("rejections", "transient", "INTEGER NOT NULL DEFAULT 0"),
    ("rejections", "acknowledged_at", "TEXT"),
    ("changed_files", "acknowledged_at", "TEXT"),
)
_AXIS_ACTIVITY = """
CREATE TABLE IF NOT EXISTS axis_activity (
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    n_files INTEGER NOT NULL,
    newest_capture TEXT NOT NULL,
    last_seen_at TEXT NOT NULL,
    PRIMARY KEY (robot, axis)
)
"""

_REJECT = (
    "INSERT INTO rejections (robot, axis, method, capture, path, file_hash, error, rejected_at, "
    "kind, params_hash, transient) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
    "ON CONFLICT (method, path, file_hash) DO UPDATE SET error=excluded.error, "
    "rejected_at=excluded.rejected_at, kind=excluded.kind, params_hash=excluded.params_hash, "
    "transient=excluded.transient, acknowledged_at=CASE WHEN error=excluded.error "
    "THEN acknowledged_at END"
)


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
            self._upgrade()
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

    def _upgrade(self) -> None:
        with self.write() as connection:
            for table, column, declaration in _ADDED_COLUMNS:
                present = {row[1] for row in connection.execute(f"PRAGMA table_info({table})")}
                if column not in present:
                    connection.execute(f"ALTER TABLE {table} ADD COLUMN {column} {declaration}")
            connection.execute(_AXIS_ACTIVITY)

    @contextmanager
    def _errors(self) -> Iterator[None]:
        """SQLite failures (corrupt file, full disk, I/O error) as one-line StoreErrors."""
        try:
            yield
        except sqlite3.Error as exc:
            hint = ""
            if isinstance(exc, sqlite3.OperationalError) and ("disk" in str(exc)):
                hint = "; is the disk full or failing? Free space, then run again"
            elif isinstance(exc, sqlite3.DatabaseError) and "malformed" in str(exc):
                hint = "; the file is corrupt: restore a backup or start a new store"
            raise StoreError(f"store '{self.path}': {exc}{hint}.") from exc

    @contextmanager
    def write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (``BEGIN IMMEDIATE`` ... ``COMMIT``; rolled back on error)."""
        connection = self._connection
        with self._errors():
            connection.execute("BEGIN IMMEDIATE")
            try:
                yield connection
            except BaseException:
                if connection.in_transaction:
                    connection.execute("ROLLBACK")
                raise
            connection.execute("COMMIT")

    def rows(self, sql: str, parameters: Sequence[Any] = ()) -> list[sqlite3.Row]:
        """Rows of a read-only query."""
        with self._errors():
            return list(self._connection.execute(sql, parameters))

    def frame(self, sql: str, parameters: Sequence[Any] = ()) -> pd.DataFrame:
        """A read-only query as a DataFrame."""
        with self._errors():
            cursor = self._connection.execute(sql, parameters)
            columns = [d[0] for d in cursor.description]
            return pd.DataFrame([tuple(r) for r in cursor.fetchall()], columns=columns)

    # --- rejections and standing problems ------------------------------------------------------

    @staticmethod
    def record_rejection(
        connection: sqlite3.Connection,
        *,
        robot: str,
        axis: str,
        method: str,
        capture: str,
        path: str,
        file_hash: str,
        error: str,
        at: str,
        kind: str,
        params_hash: str | None = None,
        transient: bool = False,
    ) -> None:
        """Record (or refresh) a rejection inside an open write transaction. A rejection whose
        reason changed loses its acknowledgement: it is news again."""
        connection.execute(
            _REJECT,
            (robot, axis, method, capture, path, file_hash, error, at, kind, params_hash,
             int(transient)),
        )  # fmt: skip

    def reject(self, **fields: Any) -> None:
        """Record one rejection in its own transaction (fields as in :meth:`record_rejection`)."""
        with self.write() as connection:
            self.record_rejection(connection, **fields)

    def rejected_files(self, method: str, params_hash: str) -> set[tuple[str, str]]:
        """``(path, file_hash)`` of rejections that still hold: not transient, and made under
        ``params_hash`` or independent of the parameters."""
        return {
            (str(r["path"]), str(r["file_hash"]))
            for r in self.rows(
                "SELECT path, file_hash FROM rejections WHERE method=? AND transient=0 "
                "AND (params_hash IS NULL OR params_hash=?)",
                (method, params_hash),
            )
        }

    def rejections_of(self, method: str, params_hash: str) -> list[sqlite3.Row]:
        """Rejections that still hold (transient ones included), in the order they were made."""
        return self.rows(
            "SELECT path, file_hash, error, kind, transient, acknowledged_at FROM rejections "
            "WHERE method=? AND (params_hash IS NULL OR params_hash=?) ORDER BY id",
            (method, params_hash),
        )

    def resolve_transient(self, method: str, seen_before: str) -> None:
        """Forget transient rejections not seen again since ``seen_before`` (resolved)."""
        with self.write() as connection:
            connection.execute(
                "DELETE FROM rejections WHERE method=? AND transient=1 AND rejected_at<?",
                (method, seen_before),
            )

    def problems(self, method: str | None = None) -> pd.DataFrame:
        """Rejections and changed files: kind, method, path, error, since, acknowledged_at."""
        return self.frame(
            "SELECT coalesce(kind, 'invalid') AS kind, method, path, error, rejected_at AS since, "
            "acknowledged_at FROM rejections WHERE (? IS NULL OR method=?) "
            "UNION ALL SELECT 'changed', '', path, 'content changed after it was scored', "
            "detected_at, acknowledged_at FROM changed_files "
            "ORDER BY path, kind, method",
            (method, method),
        )

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        """Forget the rejections of ``paths`` (all when empty): the next run tries them again."""
        with self.write() as connection:
            return self._each_path(
                connection,
                "DELETE FROM rejections WHERE (? IS NULL OR method=?)",
                (method, method),
                paths,
            )

    def acknowledge_problems(self, paths: Sequence[str], at: str, method: str | None = None) -> int:
        """Mark the rejections and changed files of ``paths`` (all when empty) as seen."""
        with self.write() as connection:
            rejections = self._each_path(
                connection,
                "UPDATE rejections SET acknowledged_at=? WHERE acknowledged_at IS NULL "
                "AND (? IS NULL OR method=?)",
                (at, method, method),
                paths,
            )
            changed = self._each_path(
                connection,
                "UPDATE changed_files SET acknowledged_at=? WHERE acknowledged_at IS NULL",
                (at,),
                paths,
            )
        return rejections + changed

    @staticmethod
    def _each_path(
        connection: sqlite3.Connection, sql: str, parameters: tuple[Any, ...], paths: Sequence[str]
    ) -> int:
        if not paths:
            return int(connection.execute(sql, parameters).rowcount)
        return sum(
            int(connection.execute(sql + " AND path=?", (*parameters, path)).rowcount)
            for path in paths
        )

    def changed_file_acknowledged(self, path: str, scored_hash: str, current_hash: str) -> bool:
        """Whether someone acknowledged this change of this file."""
        return bool(
            self.rows(
                "SELECT 1 FROM changed_files WHERE path=? AND scored_hash=? AND current_hash=? "
                "AND acknowledged_at IS NOT NULL",
                (path, scored_hash, current_hash),
            )
        )

    def scored_captures(self, robot: str, axis: str, method: str) -> set[str]:
        """File names of the captures of an axis scored under any of its baselines."""
        return {
            str(r[0])
            for r in self.rows(
                "SELECT DISTINCT capture FROM scores WHERE robot=? AND axis=? AND method=?",
                (robot, axis, method),
            )
        }

    # --- axis activity -------------------------------------------------------------------------

    def record_axis_activity(self, seen: Sequence[tuple[str, str, int, str]], at: str) -> None:
        """Per ``(robot, axis, n_files, newest_capture)``: ``last_seen_at`` becomes ``at`` when
        the axis is new or has a file it did not have before."""
        with self.write() as connection:
            for robot, axis, n_files, newest in seen:
                connection.execute(
                    "INSERT INTO axis_activity (robot, axis, n_files, newest_capture, "
                    "last_seen_at) VALUES (?, ?, ?, ?, ?) ON CONFLICT (robot, axis) DO UPDATE "
                    "SET last_seen_at=CASE WHEN excluded.n_files>n_files OR "
                    "excluded.newest_capture>newest_capture THEN excluded.last_seen_at "
                    "ELSE last_seen_at END, n_files=excluded.n_files, "
                    "newest_capture=max(newest_capture, excluded.newest_capture)",
                    (robot, axis, n_files, newest, at),
                )

    def latest_bad_data(self) -> pd.DataFrame:
        """robot, axis, method, capture: the newest capture of each axis rejected as bad data."""
        return self.frame(
            "SELECT robot, axis, method, max(capture) AS bad_capture FROM rejections "
            "WHERE kind='bad data' GROUP BY robot, axis, method"
        )

    def axis_activity(self) -> pd.DataFrame:
        """robot, axis, n_files, newest_capture, last_seen_at (ISO, UTC) of every axis seen."""
        return self.frame(
            "SELECT robot, axis, n_files, newest_capture, last_seen_at FROM axis_activity "
            "ORDER BY robot, axis"
        )

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
