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
``acknowledgements`` (schema version 2)
    who saw an alarm, when, and what they noted: the alarm is named by the score that raised
    it, so an alarm that clears and is raised again needs a new acknowledgement; a
    re-baseline after maintenance is recorded here too. A version-1 store gains the table when
    it is opened (nothing else changes).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from axiswatch.exceptions import StoreError

__all__ = ["SCHEMA_VERSION", "AlarmState", "Store"]

SCHEMA_VERSION = 2

_ACKNOWLEDGEMENTS = """
CREATE TABLE acknowledgements (
    id INTEGER PRIMARY KEY,
    robot TEXT NOT NULL,
    axis TEXT NOT NULL,
    method TEXT NOT NULL,
    baseline_id INTEGER NOT NULL REFERENCES baselines (id),
    score_id INTEGER REFERENCES scores (id),
    rebaseline INTEGER NOT NULL,
    acknowledged_by TEXT NOT NULL,
    note TEXT NOT NULL,
    acknowledged_at TEXT NOT NULL
)
"""

_SCHEMA = (
    """
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
    + _ACKNOWLEDGEMENTS
)

#: The alarm episode of every baseline chosen by ``{where}`` whose last monitored capture is in
#: alarm: the score that raised it (the first alarmed one after the last clean one) and its
#: latest acknowledgement.
_ALARMS = """
WITH last AS (
    SELECT b.id AS baseline_id, b.robot, b.axis, b.method,
        (SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor'
         ORDER BY s.id DESC LIMIT 1) AS alarm,
        (SELECT max(s.id) FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor'
         AND s.alarm=0) AS last_clean
    FROM baselines b {where}
)
SELECT l.robot, l.axis, l.method, l.baseline_id, r.id AS raised_score_id,
    r.capture AS raised_capture, r.captured_at AS raised_at, a.acknowledged_by, a.note,
    a.acknowledged_at
FROM last l
JOIN scores r ON r.id = (SELECT min(s.id) FROM scores s WHERE s.baseline_id=l.baseline_id
    AND s.role='monitor' AND s.alarm=1 AND s.id > coalesce(l.last_clean, 0))
LEFT JOIN acknowledgements a ON a.id = (SELECT max(k.id) FROM acknowledgements k
    WHERE k.score_id=r.id)
WHERE l.alarm=1
ORDER BY l.robot, l.axis, l.method
"""


@dataclass(frozen=True)
class AlarmState:
    """An axis in alarm (one method): since which capture, and whether someone saw it."""

    robot: str
    axis: str
    method: str
    baseline_id: int
    raised_score_id: int
    raised_capture: str
    raised_at: str
    acknowledged_by: str | None
    note: str | None
    acknowledged_at: str | None

    @property
    def acknowledged(self) -> bool:
        """An acknowledgement names this alarm (it was not cleared and raised again since)."""
        return self.acknowledged_by is not None


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
    (2, 0)
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
            if version == 1:  # version 2 only adds the acknowledgements table
                connection.execute(_ACKNOWLEDGEMENTS)
                connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
                version = SCHEMA_VERSION
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

    # --- alarms and the people who saw them ------------------------------------------------

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        """Axes in alarm after their last monitored capture (active baselines), acknowledged or
        not; one per axis and method."""
        where = "WHERE b.retired_at IS NULL AND (? IS NULL OR b.method=?)"
        rows = self.rows(_ALARMS.format(where=where), (method, method))
        return [AlarmState(**dict(row)) for row in rows]

    def acknowledge(
        self,
        robot: str,
        axis: str,
        *,
        by: str,
        note: str,
        method: str | None = None,
        rebaseline: bool = False,
    ) -> list[str]:
        """Record that someone saw the axis's alarm (or, ``rebaseline``, maintained the axis).

        Parameters
        ----------
        robot, axis : str
        by : str
            Who (not empty).
        note : str
            What they saw or did (not empty).
        method : str or None, default=None
            Only this method's alarm; default every method in alarm on the axis.
        rebaseline : bool, default=False
            The record of a re-baseline after maintenance: made for the latest baseline of each
            method whether or not it is in alarm (it names the alarm when there is one). The
            caller retires the baselines (``rebaseline`` of the ledger) before.

        Returns
        -------
        list of str
            The methods acknowledged.

        Raises
        ------
        ValueError
            If ``by`` or ``note`` is empty.
        StoreError
            If the axis has no baseline (for ``method``), or, without ``rebaseline``, is not in
            alarm.
        """
        for name, value in (("by", by), ("note", note)):
            if not value.strip():
                raise ValueError(f"The '{name}' parameter must not be empty. Got {value!r}.")
        label = f"robot '{robot}' axis '{axis}'" + (f" method '{method}'" if method else "")
        stamp = datetime.now(UTC).isoformat(timespec="seconds")
        with self.write() as db:
            baselines = db.execute(
                "SELECT b.id, b.method FROM baselines b WHERE b.robot=? AND b.axis=? "
                "AND (? IS NULL OR b.method=?) AND b.epoch=(SELECT max(o.epoch) FROM baselines o "
                "WHERE o.robot=b.robot AND o.axis=b.axis AND o.method=b.method) "
                + ("" if rebaseline else "AND b.retired_at IS NULL ")
                + "ORDER BY b.method",
                (robot, axis, method, method),
            ).fetchall()
            if not baselines:
                raise StoreError(f"{label} has no active baseline in store '{self.path}'.")
            alarms = {
                int(row["baseline_id"]): int(row["raised_score_id"])
                for row in db.execute(
                    _ALARMS.format(where="WHERE b.robot=? AND b.axis=?"), (robot, axis)
                )
            }
            chosen = [(r["id"], r["method"], alarms.get(r["id"])) for r in baselines]
            if not rebaseline:
                chosen = [c for c in chosen if c[2] is not None]
                if not chosen:
                    raise StoreError(
                        f"{label} is not in alarm: nothing to acknowledge (after maintenance, "
                        "re-baseline it: axiswatch ack --rebaseline)."
                    )
            for baseline_id, method_name, score_id in chosen:
                db.execute(
                    "INSERT INTO acknowledgements (robot, axis, method, baseline_id, score_id, "
                    "rebaseline, acknowledged_by, note, acknowledged_at) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        robot,
                        axis,
                        method_name,
                        baseline_id,
                        score_id,
                        int(rebaseline),
                        by,
                        note,
                        stamp,
                    ),
                )
        return [str(c[1]) for c in chosen]

    def acknowledgements(self, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """Every acknowledgement, oldest first: ``robot, axis, method, capture`` (the capture
        that raised the alarm seen; empty for a re-baseline without alarm), ``rebaseline``,
        ``acknowledged_by``, ``note``, ``acknowledged_at``."""
        frame = self.frame(
            "SELECT a.robot, a.axis, a.method, s.capture, a.rebaseline, a.acknowledged_by, "
            "a.note, a.acknowledged_at FROM acknowledgements a "
            "LEFT JOIN scores s ON s.id = a.score_id "
            "WHERE (? IS NULL OR a.robot=?) AND (? IS NULL OR a.axis=?) ORDER BY a.id",
            (robot, robot, axis, axis),
        )
        frame["rebaseline"] = frame["rebaseline"].astype(bool)
        return frame

    def rebaseline_requests(self) -> pd.DataFrame:
        """Every re-baseline: ``robot, axis, method, retired_epoch, from_capture, requested_at``."""
        return self.frame(
            "SELECT robot, axis, method, retired_epoch, from_capture, requested_at "
            "FROM rebaselines ORDER BY id"
        )

    def changed_files(self) -> pd.DataFrame:
        """Files whose content changed after they were scored: ``robot, axis, path, detected_at``."""
        return self.frame(
            "SELECT robot, axis, path, detected_at FROM changed_files ORDER BY path, id"
        )

    def close(self) -> None:
        """Close the connection."""
        self._connection.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
