"""The monitoring store: the :class:`StoreBackend` protocol in domain words, and :class:`SQLiteStore`.

Every SQL statement of axiswatch is here. WAL mode, and one short ``BEGIN IMMEDIATE`` transaction
per write. The tables are in the monitor manual's "The store" and docs/internals.md.
"""

from __future__ import annotations

import dataclasses
import json
import sqlite3
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager, suppress
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
import pandas as pd

from axiswatch._calibration import HalfLaplaceFit
from axiswatch.exceptions import StoreError
from axiswatch.monitor._decision import AxisHistory, Decision, DecisionRule, stored_threshold
from axiswatch.monitor._feedback import check_verdict
from axiswatch.monitor._fleet import misnamed_folder_key

__all__ = [
    "SCHEMA_VERSION",
    "AddedBaseline",
    "AlarmState",
    "Baseline",
    "BaselineCheck",
    "ChangedFile",
    "IndexedFile",
    "NewBaseline",
    "NewScore",
    "Rejection",
    "RunCaches",
    "SQLiteStore",
    "SavedModel",
    "ScoredFile",
    "Store",
    "StoreBackend",
    "now",
    "now_us",
]


def now() -> str:
    """The store's time stamp: UTC, ISO 8601, whole seconds."""
    return datetime.now(UTC).isoformat(timespec="seconds")


# --- records: what goes in and comes out, in domain words --------------------------------------


@dataclass(frozen=True)
class Baseline:
    """A stored baseline of one axis and method (one epoch).

    ``threshold`` and ``fit`` are None while it calibrates; ``retired`` once re-baselined.
    """

    id: int
    robot: str
    axis: str
    method: str
    epoch: int
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    features_hash: str
    params: str
    threshold: float | None
    fit: HalfLaplaceFit | None
    retired: bool


@dataclass(frozen=True)
class NewBaseline:
    """A baseline to add, with the score row of its capture (role ``baseline``)."""

    robot: str
    axis: str
    method: str
    epoch: int
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    features_hash: str
    params: str
    library_version: str
    file_size: int
    file_mtime_ns: int
    reason: str
    details: dict[str, Any]
    #: The checks of the baseline that need a person (kind -> note, as in
    #: :class:`BaselineCheck`), stored with it in one transaction.
    checks: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class BaselineCheck:
    """A note on an active baseline that needs a person until acknowledged or re-baselined.

    ``kind``: ``baseline`` (its capture disagrees with the calibration captures after it: a
    faulty first capture?) or ``fleet`` (it differs from its fleet's by more than a task-change
    allowance: worn already, or another task).
    """

    baseline_id: int
    robot: str
    axis: str
    method: str
    path: str
    kind: str
    note: str
    detected_at: str
    acknowledged_at: str | None = None


@dataclass(frozen=True)
class AddedBaseline:
    """The epoch's baseline after :meth:`StoreBackend.add_baseline`: its id, and whether this
    call added it (False: another process had added the same capture first, so that two runs
    on one store do not both count it as new)."""

    id: int
    added: bool


@dataclass(frozen=True)
class NewScore:
    """A scored capture of one baseline, before its decision (role, threshold, alarm)."""

    baseline_id: int
    robot: str
    axis: str
    method: str
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    file_size: int
    file_mtime_ns: int
    distance: float
    details: dict[str, Any]


@dataclass(frozen=True)
class Rejection:
    """A capture file that could not be used, and why (one line naming the file)."""

    robot: str
    axis: str
    method: str
    capture: str
    path: str
    file_hash: str
    error: str
    #: ``layout``, ``unreadable``, ``invalid``, ``bad data``, ``out of order`` or ``future``.
    kind: str = "invalid"
    #: The parameters the rejection was made under (None: it does not depend on them).
    params_hash: str | None = None
    #: Re-checked every run (an unreadable file, a future date); forgotten once resolved.
    transient: bool = False
    acknowledged_at: str | None = None
    #: What an acknowledgement of it is of, where ``error`` also says something that changes
    #: without being news (a misnamed folder's file count); None: the whole ``error``.
    reason_key: str | None = None
    #: When a run found the file gone from the fleet folder (deleted or moved away): kept as
    #: history, no longer a problem; None while the rejected content is there.
    removed_at: str | None = None


@dataclass(frozen=True)
class ScoredFile:
    """What a file was when it was last scored (to notice a later change of content)."""

    robot: str
    axis: str
    capture: str
    path: str
    file_hash: str
    file_size: int
    file_mtime_ns: int


@dataclass(frozen=True)
class ChangedFile:
    """A file whose content changed after it was scored."""

    robot: str
    axis: str
    capture: str
    path: str
    scored_hash: str
    current_hash: str


@dataclass(frozen=True)
class IndexedFile:
    """A fleet file as last hashed: path (relative to the fleet folder), size, ``mtime_ns``,
    SHA-256."""

    path: str
    size: int
    mtime_ns: int
    hash: str


@dataclass(frozen=True)
class SavedModel:
    """What a stored fitted model was made from (its blob is read by hash)."""

    file_hash: str
    params: str
    library_version: str
    model_hash: str
    rates_hz: dict[str, float]
    #: ``QualityReference.spans`` of the baseline capture (the no-motion check of later
    #: captures); None for a model saved before it was kept, which is then refitted.
    reference: dict[str, float] | None = None


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
    #: The engineer's verdict (:data:`~axiswatch.monitor._feedback.ACK_VERDICTS`), if any.
    verdict: str | None = None

    @property
    def acknowledged(self) -> bool:
        """An acknowledgement names this alarm (it was not cleared and raised again since)."""
        return self.acknowledged_by is not None


# --- the protocol ------------------------------------------------------------------------------


class StoreBackend(Protocol):
    """What the monitor needs from a store, in domain words; :class:`SQLiteStore` is the product's.

    Every write is atomic: it happens whole or not at all, also when the process is killed, and
    two processes writing one store take turns. Paths are relative to the fleet folder (POSIX).
    A new backend passes ``tests/test_store_contract.py``.
    """

    @property
    def location(self) -> str:
        """Where the store is, for messages (a file path, a URL)."""
        ...

    def close(self) -> None:
        """Release the store."""
        ...

    def batch(self) -> AbstractContextManager[None]:
        """Group the writes made inside into one transaction: when the block ends they are all
        kept, and when it is left by an exception (or the process dies in it) none of them is.

        Each write inside stays atomic on its own (one that raises changes nothing); a batch
        inside a batch is part of the outer one. The monitor stores the scores of the captures
        a worker returns together in one batch: fewer commits for the one process that writes.
        """
        ...

    # writes

    def add_baseline(self, baseline: NewBaseline) -> AddedBaseline | None:
        """Add the baseline of an epoch, its capture's score row and its checks; return the
        baseline's id, ``added``.

        If the epoch already has a baseline (another process added it), return its id, not
        added, when it is the same capture, None when it is another one.
        """
        ...

    def record_score(
        self, score: NewScore, decide: Callable[[AxisHistory], Decision], *, window: int
    ) -> bool:
        """Decide and write one capture's score in one transaction; False if nothing was written.

        Nothing is written when the capture is already scored under the baseline or the baseline
        is retired. Otherwise ``decide`` gets the baseline's :class:`AxisHistory` (``window``
        recent monitored captures) and its :class:`Decision` is written; a decision that
        completes the calibration also sets the baseline's threshold and fit and gives the
        threshold to every calibration capture of the baseline. If ``decide`` raises, nothing is
        written.
        """
        ...

    def reject_capture(self, rejection: Rejection, *, baseline_id: int | None = None) -> bool:
        """Record a rejected file (once per method, path and content); False if not recorded.

        With ``baseline_id``, only while that baseline is active and the capture is not scored
        under it.
        """
        ...

    def mark_rejection_removed(self, rejection: Rejection, at: str | None) -> None:
        """Record that the file of a (not transient) rejection is gone from the fleet folder
        since ``at``, or, ``at`` None, that its rejected content is back. The rejection is
        named by its method, path and file hash; it is kept either way (history)."""
        ...

    def record_changed_file(self, change: ChangedFile) -> None:
        """Record that a scored file's content changed (once per path and pair of hashes)."""
        ...

    def record_baseline_check(self, baseline_id: int, kind: str, note: str) -> None:
        """Record a check of a baseline (one per baseline and kind): the same note again
        changes nothing; another note replaces it and is news again (not acknowledged)."""
        ...

    def retire_baselines(
        self,
        robot: str,
        axis: str,
        *,
        method: str | None = None,
        from_capture: str | None = None,
    ) -> list[str]:
        """Retire the axis's active baselines (of ``method``, or all) and record the request.

        Returns the methods retired, sorted. Raises :class:`~axiswatch.StoreError` when the axis
        has no active baseline (the message lists the axes that have one), or when
        ``from_capture`` raised an alarm under any method.
        """
        ...

    # reads

    def baseline(self, baseline_id: int) -> Baseline:
        """The baseline with this id."""
        ...

    def latest_baseline(self, robot: str, axis: str, method: str) -> Baseline | None:
        """The axis's baseline of the highest epoch (retired or not), or None."""
        ...

    def requested_baseline(
        self, robot: str, axis: str, method: str, retired_epoch: int
    ) -> str | None:
        """The capture asked for as the next baseline when ``retired_epoch`` was retired."""
        ...

    def last_captured_at(self, robot: str, axis: str, method: str) -> datetime | None:
        """Capture time of the latest capture scored on the axis under any baseline."""
        ...

    def scored_captures(self, baseline_id: int) -> set[str]:
        """File names of the captures scored under a baseline (its own included)."""
        ...

    def scored_files(self) -> dict[str, ScoredFile]:
        """Per path, the file as it was when last scored (by any method)."""
        ...

    def scored_contents(self, method: str) -> set[tuple[str, str]]:
        """``(path, file hash)`` of every capture scored by ``method``."""
        ...

    def rejections(self, method: str) -> list[Rejection]:
        """Rejected files of ``method``, in the order they were rejected."""
        ...

    def alarmed_captures(self, method: str) -> set[tuple[str, str, str]]:
        """``(robot, axis, capture)`` of every capture that raised or kept an alarm."""
        ...

    def axes_in_alarm(self, method: str) -> list[tuple[str, str]]:
        """``(robot, axis)`` whose active baseline's last monitored capture is in alarm, sorted."""
        ...

    # standing problems and axis activity

    def resolve_transient(self, method: str, seen_before: str) -> None:
        """Forget transient rejections of ``method`` not seen again since ``seen_before``."""
        ...

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        """Forget the rejections of ``paths`` (all when empty): the next run tries them again."""
        ...

    def acknowledge_problems(self, paths: Sequence[str], at: str, method: str | None = None) -> int:
        """Mark the rejections, changed files and checks of active baselines (by the baseline
        capture's path) of ``paths`` (all when empty) as seen; how many were not seen before."""
        ...

    def baseline_checks(self, method: str | None = None) -> list[BaselineCheck]:
        """The checks of the active baselines (of ``method``), acknowledged or not; ordered by
        robot, axis, method and kind."""
        ...

    def changed_file_acknowledged(self, change: ChangedFile) -> bool:
        """Whether someone acknowledged this change of this file."""
        ...

    def record_axis_activity(self, seen: Sequence[tuple[str, str, int, str]], at: str) -> None:
        """Per ``(robot, axis, n_files, newest_capture)``: ``last_seen_at`` becomes ``at`` when
        the axis is new or has a file it did not have before."""
        ...

    def axis_activity(self) -> pd.DataFrame:
        """robot, axis, n_files, newest_capture, last_seen_at (ISO, UTC); by robot, axis."""
        ...

    def latest_bad_data(self) -> pd.DataFrame:
        """robot, axis, method, bad_capture, seen_capture, seen_at: per axis with a capture
        rejected as bad data whose file is still there (not removed), the newest such capture
        nobody acknowledged (None if none), the newest acknowledged one (None if none) and the
        latest acknowledgement of those (ISO, UTC)."""
        ...

    def problem_table(self, method: str | None = None) -> pd.DataFrame:
        """Rejections, changed files and checks of active baselines (kind ``baseline check``):
        kind, method, path, error, since, acknowledged_at, removed_at (a rejection whose file is
        gone; None otherwise); ordered by path, kind, method."""
        ...

    # acknowledgements (who saw an alarm)

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        """Axes in alarm after their last monitored capture (active baselines), acknowledged or
        not; one per axis and method, ordered by robot, axis, method."""
        ...

    def acknowledge(
        self,
        robot: str,
        axis: str,
        *,
        by: str,
        note: str,
        method: str | None = None,
        rebaseline: bool = False,
        verdict: str | None = None,
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
        verdict : str or None, default=None
            What they concluded: one of :data:`~axiswatch.monitor._feedback.ACK_VERDICTS`.

        Returns
        -------
        list of str
            The methods acknowledged.

        Raises
        ------
        ValueError
            If ``by`` or ``note`` is empty, or ``verdict`` is unknown.
        StoreError
            If the axis has no baseline (for ``method``), or, without ``rebaseline``, is not in
            alarm.
        """
        ...

    def acknowledgements(self, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """Every acknowledgement, oldest first: ``robot, axis, method, capture`` (the capture
        that raised the alarm seen; None for a re-baseline without alarm), ``rebaseline``,
        ``acknowledged_by``, ``note``, ``acknowledged_at``, ``verdict`` (None without one)."""
        ...

    def rebaseline_requests(self) -> pd.DataFrame:
        """Every re-baseline: ``robot, axis, method, retired_epoch, from_capture, requested_at``."""
        ...

    # tables for people (results, summary, report)

    def score_table(self, *, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """One row per score: robot, axis, capture, method, distance, threshold, alarm,
        captured_at, epoch, role, over, reason, details, path; ordered by robot, axis, method,
        capture time, capture and epoch."""
        ...

    def summary_table(self) -> pd.DataFrame:
        """One row per active baseline: robot, axis, method, epoch, baseline, threshold, scored,
        over, alarms (raised), last_capture, last_distance, last_alarm, rejected,
        threshold_origin (:meth:`~axiswatch._calibration.Threshold.describe`; None while
        calibrating), alarm_since (the capture that raised the alarm in force) and
        acknowledged_by (who saw it, if anyone); ordered by robot, axis, method."""
        ...

    def rejection_table(self) -> pd.DataFrame:
        """Rejections: robot, axis, capture, method, path, error, rejected_at, acknowledged_at
        (None until ``rejections --ack``), removed_at (None while the file is there); ordered by
        robot, axis, path, method and then as recorded."""
        ...

    def changed_file_table(self) -> pd.DataFrame:
        """Changed files: robot, axis, path, detected_at, acknowledged_at (None until
        ``rejections --ack``); ordered by path, then as recorded."""
        ...


# --- SQLite ------------------------------------------------------------------------------------

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
    a.acknowledged_at, {verdict} AS verdict
FROM last l
JOIN scores r ON r.id = (SELECT min(s.id) FROM scores s WHERE s.baseline_id=l.baseline_id
    AND s.role='monitor' AND s.alarm=1 AND s.id > coalesce(l.last_clean, 0))
LEFT JOIN acknowledgements a ON a.id = (SELECT max(k.id) FROM acknowledgements k
    WHERE k.score_id=r.id)
WHERE l.alarm=1
ORDER BY l.robot, l.axis, l.method
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
    saved_at TEXT NOT NULL,
    reference TEXT
);
CREATE INDEX IF NOT EXISTS fitted_models_hash ON fitted_models (model_hash);
CREATE TABLE IF NOT EXISTS file_index (
    path TEXT PRIMARY KEY,
    size INTEGER NOT NULL,
    mtime_ns INTEGER NOT NULL,
    hash TEXT NOT NULL,
    verified_run INTEGER NOT NULL
);
DROP INDEX IF EXISTS file_index_verified;
CREATE INDEX IF NOT EXISTS file_index_verified_path ON file_index (verified_run, path);
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
CREATE INDEX IF NOT EXISTS scores_alarmed ON scores (method) WHERE alarm=1;
CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, started_at TEXT NOT NULL);
"""


def _time(text: str) -> datetime:
    return datetime.fromisoformat(text)


def _baseline(row: sqlite3.Row) -> Baseline:
    calibration = row["calibration"]
    return Baseline(
        id=int(row["id"]),
        robot=row["robot"],
        axis=row["axis"],
        method=row["method"],
        epoch=int(row["epoch"]),
        capture=row["capture"],
        captured_at=_time(row["captured_at"]),
        path=row["path"],
        file_hash=row["file_hash"],
        features_hash=row["features_hash"],
        params=row["params"],
        threshold=row["threshold"],
        fit=None if calibration is None else HalfLaplaceFit(**json.loads(calibration)),
        retired=row["retired_at"] is not None,
    )


_INSERT_SCORE = (
    "INSERT INTO scores (baseline_id, robot, axis, method, capture, captured_at, path, "
    "file_hash, file_size, file_mtime_ns, role, distance, threshold, over, alarm, "
    "reason, details, scored_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
)
#: A rejection, or a refreshed one: a rejection whose reason changed (its ``reason_key``, else
#: its error line) loses its acknowledgement (it is news again); one refreshed is there again
#: (not removed). The right-hand sides read the row as it was before the update.
_INSERT_REJECTION = (
    "INSERT INTO rejections (robot, axis, method, capture, path, file_hash, error, rejected_at, "
    "kind, params_hash, transient, reason_key) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
    "ON CONFLICT (method, path, file_hash) DO UPDATE SET error=excluded.error, "
    "rejected_at=excluded.rejected_at, kind=excluded.kind, params_hash=excluded.params_hash, "
    "transient=excluded.transient, reason_key=excluded.reason_key, removed_at=NULL, "
    "acknowledged_at=CASE WHEN coalesce(reason_key, error)="
    "coalesce(excluded.reason_key, excluded.error) THEN acknowledged_at END"
)

#: Additive upgrades applied on open, each (table, column, declaration): older readers ignore
#: them, so the schema version stays.
_ADDED_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("rejections", "kind", "TEXT"),
    ("rejections", "params_hash", "TEXT"),
    ("rejections", "transient", "INTEGER NOT NULL DEFAULT 0"),
    ("rejections", "acknowledged_at", "TEXT"),
    ("changed_files", "acknowledged_at", "TEXT"),
    ("rejections", "reason_key", "TEXT"),
    ("rejections", "removed_at", "TEXT"),
    ("acknowledgements", "verdict", "TEXT"),
)
#: Tables added on open to a store made before them (empty: nothing before is lost).
_BASELINE_CHECKS = """
CREATE TABLE IF NOT EXISTS baseline_checks (
    id INTEGER PRIMARY KEY,
    baseline_id INTEGER NOT NULL REFERENCES baselines (id),
    kind TEXT NOT NULL,
    note TEXT NOT NULL,
    detected_at TEXT NOT NULL,
    acknowledged_at TEXT,
    UNIQUE (baseline_id, kind)
)
"""
#: A check, or the same check again (kept as it is), or another note of its kind (news again).
_INSERT_CHECK = (
    "INSERT INTO baseline_checks (baseline_id, kind, note, detected_at) VALUES (?, ?, ?, ?) "
    "ON CONFLICT (baseline_id, kind) DO UPDATE SET note=excluded.note, "
    "detected_at=CASE WHEN note=excluded.note THEN detected_at ELSE excluded.detected_at END, "
    "acknowledged_at=CASE WHEN note=excluded.note THEN acknowledged_at END"
)
#: The checks of active baselines, with the baseline's axis, method and path.
_ACTIVE_CHECKS = (
    "SELECT c.baseline_id, b.robot, b.axis, b.method, b.path, c.kind, c.note, c.detected_at, "
    "c.acknowledged_at FROM baseline_checks c JOIN baselines b ON b.id=c.baseline_id "
    "WHERE b.retired_at IS NULL AND (? IS NULL OR b.method=?)"
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


def now_us() -> str:
    """UTC to the microsecond: orders the rejections seen again within one run."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


@runtime_checkable
class RunCaches(Protocol):
    """What lets a run skip the work earlier runs did (optional for a backend; a store without
    it gets per-run caches in memory, ``monitor._index.MemoryCaches``): fitted models, the file
    index and the times of finished axis folders. Losing any of it loses time, no result."""

    def model_source(self) -> str | None:
        """Path of the store workers read fitted models from (None: models travel with jobs)."""
        ...

    def saved_model(self, baseline_id: int) -> SavedModel | None:
        """The stored fitted model of a baseline, without its blob."""
        ...

    def save_model(self, baseline_id: int, saved: SavedModel, blob: bytes) -> None:
        """Keep (or replace) the fitted model of a baseline."""
        ...

    def model_blob(self, model_hash: str) -> bytes | None:
        """The blob of a stored model, by its content hash."""
        ...

    def start_run(self) -> int:
        """Number a new run (the index records which run last verified a file)."""
        ...

    def indexed_file(self, path: str) -> IndexedFile | None:
        """A file's index entry."""
        ...

    def index_file(self, entry: IndexedFile, run: int) -> None:
        """Record (or update) a file's entry, verified in ``run``."""
        ...

    def files_to_verify(self, run: int, limit: int) -> list[IndexedFile]:
        """Up to ``limit`` entries not verified in ``run``, least recently verified first."""
        ...

    def mark_verified(self, paths: Sequence[str], run: int) -> None:
        """Record that these files were compared with the disk in ``run``."""
        ...

    def last_scored(self, path: str) -> ScoredFile | None:
        """The file as it was when last scored, if it was."""
        ...

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        """Whether this content of a file has a score by ``method``."""
        ...

    def axis_folder_times(self, method: str, params: str) -> dict[tuple[str, str], int]:
        """Modification time of each axis folder when a run with these parameters finished it."""
        ...

    def finish_axis_folder(
        self, robot: str, axis: str, method: str, params: str, mtime_ns: int
    ) -> None:
        """Record that a run handled every file of an axis folder with this modification time."""
        ...


class SQLiteStore:
    """The monitoring store in one SQLite file (created with the current schema when new).

    Implements :class:`StoreBackend`; also exported as ``Store``.

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
    >>> store = SQLiteStore(pathlib.Path(tempfile.mkdtemp()) / "fleet.db")
    >>> store.version, len(store.score_table())
    (2, 0)
    >>> store.close()
    """

    def __init__(
        self, path: str | Path, *, timeout_s: float = 60.0, read_only: bool = False
    ) -> None:
        self.path = Path(path)
        self._batched = False
        self._read_only = read_only
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
            self._upgrade()
        except sqlite3.DatabaseError as exc:
            raise StoreError(
                f"store '{self.path}': cannot be opened as an axiswatch SQLite store: {exc}."
            ) from None

    def __repr__(self) -> str:
        return f"axiswatch.monitor.SQLiteStore({str(self.path)!r})"

    @property
    def location(self) -> str:
        return str(self.path)

    def _ensure_schema(self) -> int:
        with self._write() as connection:
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
            if version == 1:  # version 2 only adds the acknowledgements table
                connection.execute(_ACKNOWLEDGEMENTS)
                connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
                version = SCHEMA_VERSION
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
        present = {row[1] for row in connection.execute("PRAGMA table_info(fitted_models)")}
        if "reference" not in present:  # a store made before the column: refitted once
            connection.execute("ALTER TABLE fitted_models ADD COLUMN reference TEXT")
        if indexed is None:
            # A store made before the index: its scored files enter it as they were scored,
            # so that a later change in place is still found.
            connection.execute(
                "INSERT OR IGNORE INTO file_index (path, size, mtime_ns, hash, verified_run) "
                "SELECT path, file_size, file_mtime_ns, file_hash, 0 FROM scores ORDER BY id"
            )

    def _upgrade(self) -> None:
        with self._write() as connection:
            for table, column, declaration in _ADDED_COLUMNS:
                present = {row[1] for row in connection.execute(f"PRAGMA table_info({table})")}
                if column not in present:
                    connection.execute(f"ALTER TABLE {table} ADD COLUMN {column} {declaration}")
            # A misnamed folder's rejection stored before its reason_key (the column is added
            # empty): the key from its line, in this transaction, so that an acknowledgement
            # made before the upgrade still holds when the next run stores the key.
            for row_id, error in connection.execute(
                "SELECT id, error FROM rejections WHERE reason_key IS NULL AND kind='layout' "
                "AND capture=''"
            ).fetchall():
                key = misnamed_folder_key(error)
                if key is not None:
                    connection.execute(
                        "UPDATE rejections SET reason_key=? WHERE id=?", (key, row_id)
                    )
            connection.execute(_AXIS_ACTIVITY)
            connection.execute(_BASELINE_CHECKS)

    @contextmanager
    def _errors(self) -> Iterator[None]:
        """SQLite failures (corrupt file, full disk, I/O error) as one-line StoreErrors."""
        try:
            yield
        except sqlite3.Error as exc:
            hint = ""
            if isinstance(exc, sqlite3.OperationalError) and "disk" in str(exc):
                hint = "; is the disk full or failing? Free space, then run again"
            elif isinstance(exc, sqlite3.DatabaseError) and "malformed" in str(exc):
                hint = "; the file is corrupt: restore a backup or start a new store"
            raise StoreError(f"store '{self.path}': {exc}{hint}.") from exc

    @contextmanager
    def batch(self) -> Iterator[None]:
        if self._batched:
            yield
            return
        connection = self._connection
        with self._errors():
            connection.execute("BEGIN IMMEDIATE")
        self._batched = True
        try:
            yield
        except BaseException:
            self._batched = False
            with self._errors():
                if connection.in_transaction:
                    connection.execute("ROLLBACK")
            raise
        self._batched = False
        with self._errors():
            connection.execute("COMMIT")

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction (``BEGIN IMMEDIATE`` ... ``COMMIT``; rolled back on error); in a
        :meth:`batch`, a savepoint of the batch's transaction."""
        connection = self._connection
        if self._batched:
            with self._errors():
                connection.execute("SAVEPOINT write")
                try:
                    yield connection
                except BaseException:
                    connection.execute("ROLLBACK TO write")
                    connection.execute("RELEASE write")
                    raise
                connection.execute("RELEASE write")
            return
        with self._errors():
            connection.execute("BEGIN IMMEDIATE")
            try:
                yield connection
            except BaseException:
                if connection.in_transaction:
                    connection.execute("ROLLBACK")
                raise
            connection.execute("COMMIT")

    def _verdict_column(self) -> str:
        """``a.verdict``, or NULL in a store opened read-only before the column was added."""
        present = {row[1] for row in self._rows("PRAGMA table_info(acknowledgements)")}
        return "a.verdict" if "verdict" in present else "NULL"

    def _rows(self, sql: str, parameters: tuple[Any, ...] = ()) -> list[sqlite3.Row]:
        with self._errors():
            return list(self._connection.execute(sql, parameters))

    def _frame(self, sql: str, parameters: tuple[Any, ...] = ()) -> pd.DataFrame:
        with self._errors():
            cursor = self._connection.execute(sql, parameters)
            columns = [d[0] for d in cursor.description]
            return pd.DataFrame([tuple(r) for r in cursor.fetchall()], columns=columns)

    # --- fitted models (monitor._persist blobs) ------------------------------------------------

    # --- caches (RunCaches: monitor._index, monitor._models) -----------------------------------

    def model_source(self) -> str | None:
        return str(self.path.resolve())

    def saved_model(self, baseline_id: int) -> SavedModel | None:
        row = self._connection.execute(
            "SELECT file_hash, params, library_version, model_hash, rates_hz, reference "
            "FROM fitted_models WHERE baseline_id=?",
            (baseline_id,),
        ).fetchone()
        if row is None:
            return None
        return SavedModel(
            row["file_hash"], row["params"], row["library_version"], row["model_hash"],
            json.loads(row["rates_hz"]),
            None if row["reference"] is None else json.loads(row["reference"]),
        )  # fmt: skip

    def save_model(self, baseline_id: int, saved: SavedModel, blob: bytes) -> None:
        with self._write() as db:
            db.execute(
                "INSERT OR REPLACE INTO fitted_models (baseline_id, file_hash, params, "
                "library_version, model_hash, model, rates_hz, saved_at, reference) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    baseline_id, saved.file_hash, saved.params, saved.library_version,
                    saved.model_hash, blob, json.dumps(saved.rates_hz), now(),
                    None if saved.reference is None else json.dumps(saved.reference),
                ),
            )  # fmt: skip

    def model_blob(self, model_hash: str) -> bytes | None:
        row = self._connection.execute(
            "SELECT model FROM fitted_models WHERE model_hash=? LIMIT 1", (model_hash,)
        ).fetchone()
        return None if row is None else bytes(row[0])

    def start_run(self) -> int:
        with self._write() as db:
            cursor = db.execute("INSERT INTO runs (started_at) VALUES (?)", (now(),))
            return int(cursor.lastrowid or 0)

    def indexed_file(self, path: str) -> IndexedFile | None:
        row = self._connection.execute(
            "SELECT path, size, mtime_ns, hash FROM file_index WHERE path=?", (path,)
        ).fetchone()
        return None if row is None else IndexedFile(*row)

    def index_file(self, entry: IndexedFile, run: int) -> None:
        with self._write() as db:
            db.execute(
                "INSERT OR REPLACE INTO file_index (path, size, mtime_ns, hash, verified_run) "
                "VALUES (?, ?, ?, ?, ?)",
                (entry.path, entry.size, entry.mtime_ns, entry.hash, run),
            )

    def files_to_verify(self, run: int, limit: int) -> list[IndexedFile]:
        return [
            IndexedFile(*row)
            for row in self._rows(
                "SELECT path, size, mtime_ns, hash FROM file_index WHERE verified_run < ? "
                "ORDER BY verified_run, path LIMIT ?",
                (run, limit),
            )
        ]

    def mark_verified(self, paths: Sequence[str], run: int) -> None:
        with self._write() as db:
            db.executemany(
                "UPDATE file_index SET verified_run=? WHERE path=?", [(run, p) for p in paths]
            )

    def last_scored(self, path: str) -> ScoredFile | None:
        row = self._connection.execute(
            "SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns FROM scores "
            "WHERE path=? ORDER BY id DESC LIMIT 1",
            (path,),
        ).fetchone()
        return None if row is None else ScoredFile(*row)

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        return (
            self._connection.execute(
                "SELECT 1 FROM scores WHERE path=? AND file_hash=? AND method=? LIMIT 1",
                (path, file_hash, method),
            ).fetchone()
            is not None
        )

    def axis_folder_times(self, method: str, params: str) -> dict[tuple[str, str], int]:
        return {
            (row["robot"], row["axis"]): int(row["mtime_ns"])
            for row in self._rows(
                "SELECT robot, axis, mtime_ns FROM axis_folders WHERE method=? AND params=?",
                (method, params),
            )
        }

    def finish_axis_folder(
        self, robot: str, axis: str, method: str, params: str, mtime_ns: int
    ) -> None:
        with self._write() as db:
            db.execute(
                "INSERT OR REPLACE INTO axis_folders (robot, axis, method, params, mtime_ns) "
                "VALUES (?, ?, ?, ?, ?)",
                (robot, axis, method, params, mtime_ns),
            )

    def close(self) -> None:
        """Close the connection, first moving the write-ahead log into the store file.

        SQLite moves the log into the file when the last connection closes; a process that still
        holds a read-only connection (a worker, a notebook) would otherwise keep the latest
        commits in ``<store>-wal`` only, and a copy of the store file alone would miss them.
        The checkpoint does not wait for others: frames a busy reader or writer still needs stay
        in the log (nothing is lost). :meth:`backup` is the safe copy in every case.
        """
        if not self._read_only:
            # PASSIVE never waits: what a busy reader or writer still needs stays in the log
            # (nothing is lost), and is moved by a later checkpoint.
            with suppress(sqlite3.Error):
                self._connection.execute("PRAGMA wal_checkpoint(PASSIVE)")
        self._connection.close()

    def backup(self, destination: str | Path) -> Path:
        """Write a consistent copy of the store to a new file, also while others write to it.

        SQLite's online backup: the copy holds every commit made before it started, the
        write-ahead log's included, in one self-contained file (copying the store file alone can
        miss the commits still in ``<store>-wal``). It is written next to ``destination`` and
        renamed into place once its integrity is checked, so a failed backup leaves no file.

        Parameters
        ----------
        destination : str or Path
            The new file; it must not exist (a backup never overwrites).

        Returns
        -------
        Path
            ``destination``.

        Raises
        ------
        StoreError
            When ``destination`` exists, its folder does not, or the copy fails its check.

        Examples
        --------
        >>> import tempfile, pathlib
        >>> folder = pathlib.Path(tempfile.mkdtemp())
        >>> with SQLiteStore(folder / "fleet.db") as store:
        ...     copy = store.backup(folder / "fleet-backup.db")
        >>> with SQLiteStore(copy) as restored:
        ...     restored.version
        2
        """
        target = Path(destination)
        if target.exists():
            raise StoreError(f"backup '{target}' already exists; a backup never overwrites.")
        if not target.parent.is_dir():
            raise StoreError(f"backup '{target}': folder '{target.parent}' does not exist.")
        partial = target.with_name(f".{target.name}.partial")
        partial.unlink(missing_ok=True)
        try:
            copy = sqlite3.connect(partial)
            try:
                self._connection.backup(copy)
                copy.execute("PRAGMA journal_mode = DELETE")  # one self-contained file
                check = copy.execute("PRAGMA integrity_check").fetchone()[0]
            finally:
                copy.close()
            if check != "ok":
                raise StoreError(f"backup '{target}': the copy fails SQLite's check: {check}.")
            partial.replace(target)
        except sqlite3.Error as exc:
            raise StoreError(f"backup '{target}': {exc}.") from None
        finally:
            partial.unlink(missing_ok=True)
        return target

    def __enter__(self) -> SQLiteStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- writes --------------------------------------------------------------------------------

    def add_baseline(self, baseline: NewBaseline) -> AddedBaseline | None:
        b = baseline
        with self._write() as db:
            row = db.execute(
                "SELECT id, capture FROM baselines WHERE robot=? AND axis=? AND method=? "
                "AND epoch=?",
                (b.robot, b.axis, b.method, b.epoch),
            ).fetchone()
            if row is not None:
                return AddedBaseline(int(row["id"]), False) if row["capture"] == b.capture else None
            cursor = db.execute(
                "INSERT INTO baselines (robot, axis, method, epoch, capture, captured_at, path, "
                "file_hash, features_hash, params, library_version, created_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    b.robot, b.axis, b.method, b.epoch, b.capture, b.captured_at.isoformat(),
                    b.path, b.file_hash, b.features_hash, b.params, b.library_version, now(),
                ),
            )  # fmt: skip
            baseline_id = int(cursor.lastrowid or 0)
            db.execute(
                _INSERT_SCORE,
                (
                    baseline_id, b.robot, b.axis, b.method, b.capture, b.captured_at.isoformat(),
                    b.path, b.file_hash, b.file_size, b.file_mtime_ns, "baseline", None, None,
                    0, 0, b.reason, json.dumps(b.details), now(),
                ),
            )  # fmt: skip
            for kind, note in sorted(b.checks.items()):
                db.execute(_INSERT_CHECK, (baseline_id, kind, note, now()))
        return AddedBaseline(baseline_id, True)

    def record_score(
        self, score: NewScore, decide: Callable[[AxisHistory], Decision], *, window: int
    ) -> bool:
        s = score
        with self._write() as db:
            if db.execute(
                "SELECT 1 FROM scores WHERE baseline_id=? AND capture=?",
                (s.baseline_id, s.capture),
            ).fetchone():
                return False
            baseline = _baseline(
                db.execute("SELECT * FROM baselines WHERE id=?", (s.baseline_id,)).fetchone()
            )
            if baseline.retired:
                return False
            decision = decide(self._history(db, s, baseline, window))
            if decision.calibrated is not None:
                db.execute(
                    "UPDATE baselines SET threshold=?, calibration=? WHERE id=?",
                    (
                        decision.calibrated.value,
                        json.dumps(dataclasses.asdict(decision.calibrated.fit)),
                        s.baseline_id,
                    ),
                )
                db.execute(
                    "UPDATE scores SET threshold=? WHERE baseline_id=? AND role='calibration'",
                    (decision.calibrated.value, s.baseline_id),
                )
            db.execute(
                _INSERT_SCORE,
                (
                    s.baseline_id, s.robot, s.axis, s.method, s.capture,
                    s.captured_at.isoformat(), s.path, s.file_hash, s.file_size,
                    s.file_mtime_ns, decision.role, s.distance, decision.threshold,
                    int(decision.over), int(decision.alarm), decision.reason,
                    json.dumps({**s.details, **decision.details}, sort_keys=True), now(),
                ),
            )  # fmt: skip
        return True

    @staticmethod
    def _history(
        db: sqlite3.Connection, score: NewScore, baseline: Baseline, window: int
    ) -> AxisHistory:
        if baseline.threshold is not None:
            recent = db.execute(
                "SELECT over, alarm FROM scores WHERE baseline_id=? AND role='monitor' "
                "ORDER BY id DESC LIMIT ?",
                (score.baseline_id, window),
            ).fetchall()[::-1]
            return AxisHistory(
                threshold=baseline.threshold,
                fit=baseline.fit,
                recent=tuple((bool(r["over"]), bool(r["alarm"])) for r in recent),
            )
        alarmed = db.execute(
            "SELECT 1 FROM scores WHERE robot=? AND axis=? AND method=? AND capture=? AND alarm=1",
            (score.robot, score.axis, score.method, score.capture),
        ).fetchone()
        distances = db.execute(
            "SELECT distance FROM scores WHERE baseline_id=? AND role='calibration' ORDER BY id",
            (score.baseline_id,),
        )
        return AxisHistory(
            calibration_distances=tuple(float(r[0]) for r in distances),
            alarmed_before=alarmed is not None,
        )

    def reject_capture(self, rejection: Rejection, *, baseline_id: int | None = None) -> bool:
        r = rejection
        with self._write() as db:
            if baseline_id is not None:
                if db.execute(
                    "SELECT 1 FROM scores WHERE baseline_id=? AND capture=?",
                    (baseline_id, r.capture),
                ).fetchone():
                    return False
                retired = db.execute(
                    "SELECT retired_at FROM baselines WHERE id=?", (baseline_id,)
                ).fetchone()[0]
                if retired is not None:
                    return False
            existed = db.execute(
                "SELECT 1 FROM rejections WHERE method=? AND path=? AND file_hash=?",
                (r.method, r.path, r.file_hash),
            ).fetchone()
            db.execute(
                _INSERT_REJECTION,
                (
                    r.robot, r.axis, r.method, r.capture, r.path, r.file_hash, r.error, now_us(),
                    r.kind, r.params_hash, int(r.transient), r.reason_key,
                ),
            )  # fmt: skip
        return existed is None

    def mark_rejection_removed(self, rejection: Rejection, at: str | None) -> None:
        r = rejection
        with self._write() as db:
            db.execute(
                "UPDATE rejections SET removed_at=? WHERE method=? AND path=? AND file_hash=?",
                (at, r.method, r.path, r.file_hash),
            )

    def record_changed_file(self, change: ChangedFile) -> None:
        c = change
        with self._write() as db:
            db.execute(
                "INSERT OR IGNORE INTO changed_files (robot, axis, capture, path, scored_hash, "
                "current_hash, detected_at) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (c.robot, c.axis, c.capture, c.path, c.scored_hash, c.current_hash, now()),
            )

    def record_baseline_check(self, baseline_id: int, kind: str, note: str) -> None:
        with self._write() as db:
            db.execute(_INSERT_CHECK, (baseline_id, kind, note, now()))

    def retire_baselines(
        self,
        robot: str,
        axis: str,
        *,
        method: str | None = None,
        from_capture: str | None = None,
    ) -> list[str]:
        retired = []
        with self._write() as db:
            rows = db.execute(
                "SELECT id, method, epoch FROM baselines WHERE robot=? AND axis=? "
                "AND retired_at IS NULL AND (? IS NULL OR method=?) ORDER BY method",
                (robot, axis, method, method),
            ).fetchall()
            if not rows:
                active = db.execute(
                    "SELECT robot, axis, method FROM baselines WHERE retired_at IS NULL"
                )
                raise StoreError(_no_active_baseline(self.location, robot, axis, method, active))
            if from_capture is not None:
                alarmed = db.execute(
                    "SELECT method FROM scores WHERE robot=? AND axis=? AND capture=? AND alarm=1",
                    (robot, axis, from_capture),
                ).fetchone()
                if alarmed:
                    raise StoreError(_alarmed_baseline(robot, axis, from_capture, alarmed[0]))
            stamp = now()
            # The axis's folder must be listed again by the next run (monitor._index).
            db.execute("DELETE FROM axis_folders WHERE robot=? AND axis=?", (robot, axis))
            for row in rows:
                db.execute("UPDATE baselines SET retired_at=? WHERE id=?", (stamp, row["id"]))
                db.execute(
                    "INSERT INTO rebaselines (robot, axis, method, retired_epoch, from_capture, "
                    "requested_at) VALUES (?, ?, ?, ?, ?, ?)",
                    (robot, axis, row["method"], row["epoch"], from_capture, stamp),
                )
                retired.append(str(row["method"]))
        return retired

    # --- reads ---------------------------------------------------------------------------------

    def baseline(self, baseline_id: int) -> Baseline:
        rows = self._rows("SELECT * FROM baselines WHERE id=?", (baseline_id,))
        if not rows:
            raise StoreError(f"store '{self.path}' has no baseline with id {baseline_id}.")
        return _baseline(rows[0])

    def latest_baseline(self, robot: str, axis: str, method: str) -> Baseline | None:
        rows = self._rows(
            "SELECT * FROM baselines WHERE robot=? AND axis=? AND method=? ORDER BY epoch DESC "
            "LIMIT 1",
            (robot, axis, method),
        )
        return _baseline(rows[0]) if rows else None

    def requested_baseline(
        self, robot: str, axis: str, method: str, retired_epoch: int
    ) -> str | None:
        rows = self._rows(
            "SELECT from_capture FROM rebaselines WHERE robot=? AND axis=? AND method=? "
            "AND retired_epoch=? ORDER BY id DESC LIMIT 1",
            (robot, axis, method, retired_epoch),
        )
        return rows[0]["from_capture"] if rows else None

    def last_captured_at(self, robot: str, axis: str, method: str) -> datetime | None:
        last = self._rows(
            "SELECT max(captured_at) FROM scores WHERE robot=? AND axis=? AND method=?",
            (robot, axis, method),
        )[0][0]
        return None if last is None else _time(last)

    def scored_captures(self, baseline_id: int) -> set[str]:
        rows = self._rows("SELECT capture FROM scores WHERE baseline_id=?", (baseline_id,))
        return {r["capture"] for r in rows}

    def scored_files(self) -> dict[str, ScoredFile]:
        rows = self._rows(
            "SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns FROM scores "
            "ORDER BY id"
        )
        return {r["path"]: ScoredFile(**dict(r)) for r in rows}

    def scored_contents(self, method: str) -> set[tuple[str, str]]:
        rows = self._rows("SELECT path, file_hash FROM scores WHERE method=?", (method,))
        return {(r["path"], r["file_hash"]) for r in rows}

    def rejections(self, method: str) -> list[Rejection]:
        rows = self._rows(
            "SELECT robot, axis, method, capture, path, file_hash, error, "
            "coalesce(kind, 'invalid') AS kind, params_hash, transient, acknowledged_at, "
            "reason_key, removed_at FROM rejections WHERE method=? ORDER BY id",
            (method,),
        )
        return [Rejection(**{**dict(r), "transient": bool(r["transient"])}) for r in rows]

    def alarmed_captures(self, method: str) -> set[tuple[str, str, str]]:
        rows = self._rows(
            "SELECT robot, axis, capture FROM scores WHERE method=? AND alarm=1", (method,)
        )
        return {(r["robot"], r["axis"], r["capture"]) for r in rows}

    def axes_in_alarm(self, method: str) -> list[tuple[str, str]]:
        rows = self._rows(
            "SELECT b.robot, b.axis, (SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id "
            "AND s.role='monitor' ORDER BY s.id DESC LIMIT 1) AS alarm FROM baselines b "
            "WHERE b.method=? AND b.retired_at IS NULL ORDER BY b.robot, b.axis",
            (method,),
        )
        return [(r["robot"], r["axis"]) for r in rows if r["alarm"]]

    # --- alarms and the people who saw them ------------------------------------------------

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        """Axes in alarm after their last monitored capture (active baselines), acknowledged or
        not; one per axis and method."""
        where = "WHERE b.retired_at IS NULL AND (? IS NULL OR b.method=?)"
        rows = self._rows(
            _ALARMS.format(where=where, verdict=self._verdict_column()), (method, method)
        )
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
        verdict: str | None = None,
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
        verdict : str or None, default=None
            What they concluded: one of :data:`~axiswatch.monitor._feedback.ACK_VERDICTS`.

        Returns
        -------
        list of str
            The methods acknowledged.

        Raises
        ------
        ValueError
            If ``by`` or ``note`` is empty, or ``verdict`` is unknown.
        StoreError
            If the axis has no baseline (for ``method``), or, without ``rebaseline``, is not in
            alarm.
        """
        for name, value in (("by", by), ("note", note)):
            if not value.strip():
                raise ValueError(f"The '{name}' parameter must not be empty. Got {value!r}.")
        check_verdict(verdict)
        label = f"robot '{robot}' axis '{axis}'" + (f" method '{method}'" if method else "")
        stamp = datetime.now(UTC).isoformat(timespec="seconds")
        with self._write() as db:
            baselines = db.execute(
                "SELECT b.id, b.method FROM baselines b WHERE b.robot=? AND b.axis=? "
                "AND (? IS NULL OR b.method=?) AND b.epoch=(SELECT max(o.epoch) FROM baselines o "
                "WHERE o.robot=b.robot AND o.axis=b.axis AND o.method=b.method) "
                + ("" if rebaseline else "AND b.retired_at IS NULL ")
                + "ORDER BY b.method",
                (robot, axis, method, method),
            ).fetchall()
            if not baselines:
                raise StoreError(f"{label} has no active baseline in store '{self.location}'.")
            alarms = {
                int(row["baseline_id"]): int(row["raised_score_id"])
                for row in db.execute(
                    _ALARMS.format(where="WHERE b.robot=? AND b.axis=?", verdict="a.verdict"),
                    (robot, axis),
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
                    "rebaseline, acknowledged_by, note, acknowledged_at, verdict) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
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
                        verdict,
                    ),
                )
        return [str(c[1]) for c in chosen]

    def acknowledgements(self, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """Every acknowledgement, oldest first: ``robot, axis, method, capture`` (the capture
        that raised the alarm seen; empty for a re-baseline without alarm), ``rebaseline``,
        ``acknowledged_by``, ``note``, ``acknowledged_at``, ``verdict`` (None without one)."""
        frame = self._frame(
            "SELECT a.robot, a.axis, a.method, s.capture, a.rebaseline, a.acknowledged_by, "
            f"a.note, a.acknowledged_at, {self._verdict_column()} AS verdict "
            "FROM acknowledgements a "
            "LEFT JOIN scores s ON s.id = a.score_id "
            "WHERE (? IS NULL OR a.robot=?) AND (? IS NULL OR a.axis=?) ORDER BY a.id",
            (robot, robot, axis, axis),
        )
        frame["rebaseline"] = frame["rebaseline"].astype(bool)
        return frame

    def rebaseline_requests(self) -> pd.DataFrame:
        """Every re-baseline: ``robot, axis, method, retired_epoch, from_capture, requested_at``."""
        return self._frame(
            "SELECT robot, axis, method, retired_epoch, from_capture, requested_at "
            "FROM rebaselines ORDER BY id"
        )

    # --- tables --------------------------------------------------------------------------------

    def score_table(self, *, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        frame = self._frame(
            "SELECT s.robot, s.axis, s.capture, s.method, s.distance, s.threshold, s.alarm, "
            "s.captured_at, b.epoch, s.role, s.over, s.reason, s.details, s.path FROM scores s "
            "JOIN baselines b ON b.id = s.baseline_id "
            "WHERE (? IS NULL OR s.robot=?) AND (? IS NULL OR s.axis=?) "
            "ORDER BY s.robot, s.axis, s.method, s.captured_at, s.capture, b.epoch",
            (robot, robot, axis, axis),
        )
        frame["alarm"] = frame["alarm"].astype(bool)
        frame["over"] = frame["over"].astype(bool)
        frame["distance"] = frame["distance"].astype(np.float64)
        frame["threshold"] = frame["threshold"].astype(np.float64)
        return frame

    def summary_table(self) -> pd.DataFrame:
        frame = self._frame(
            "SELECT b.id AS baseline_id, b.robot, b.axis, b.method, b.epoch, "
            "b.capture AS baseline, b.threshold, "
            "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.role!='baseline') "
            "AS scored, "
            "(SELECT coalesce(sum(s.over), 0) FROM scores s WHERE s.baseline_id=b.id) AS over, "
            "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.alarm=1 AND NOT "
            "coalesce((SELECT p.alarm FROM scores p WHERE p.baseline_id=b.id "
            "AND p.role='monitor' AND p.id<s.id ORDER BY p.id DESC LIMIT 1), 0)) AS alarms, "
            "(SELECT s.capture FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC "
            "LIMIT 1) AS last_capture, "
            "(SELECT s.distance FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC "
            "LIMIT 1) AS last_distance, "
            "(SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor' "
            "ORDER BY s.id DESC LIMIT 1) AS last_alarm, "
            "(SELECT count(*) FROM rejections r WHERE r.robot=b.robot AND r.axis=b.axis "
            "AND r.method=b.method) AS rejected "
            "FROM baselines b WHERE b.retired_at IS NULL ORDER BY b.robot, b.axis, b.method"
        )
        baselines = [self.baseline(int(i)) for i in frame.pop("baseline_id")]
        return summary_extras(frame, baselines, self.alarms())

    def rejection_table(self) -> pd.DataFrame:
        return self._frame(
            "SELECT robot, axis, capture, method, path, error, rejected_at, acknowledged_at, "
            "removed_at FROM rejections ORDER BY robot, axis, path, method, id"
        )

    def changed_file_table(self) -> pd.DataFrame:
        return self._frame(
            "SELECT robot, axis, path, detected_at, acknowledged_at FROM changed_files "
            "ORDER BY path, id"
        )

    # --- standing problems and axis activity ---------------------------------------------------

    def resolve_transient(self, method: str, seen_before: str) -> None:
        with self._write() as db:
            db.execute(
                "DELETE FROM rejections WHERE method=? AND transient=1 AND rejected_at<?",
                (method, seen_before),
            )

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        with self._write() as db:
            return _each_path(
                db, "DELETE FROM rejections WHERE (? IS NULL OR method=?)", (method, method), paths
            )

    def acknowledge_problems(self, paths: Sequence[str], at: str, method: str | None = None) -> int:
        with self._write() as db:
            rejections = _each_path(
                db,
                "UPDATE rejections SET acknowledged_at=? WHERE acknowledged_at IS NULL "
                "AND (? IS NULL OR method=?)",
                (at, method, method),
                paths,
            )
            changed = _each_path(
                db,
                "UPDATE changed_files SET acknowledged_at=? WHERE acknowledged_at IS NULL",
                (at,),
                paths,
            )
            checks = _each_path(
                db,
                "UPDATE baseline_checks SET acknowledged_at=? WHERE acknowledged_at IS NULL "
                "AND baseline_id IN (SELECT id FROM baselines WHERE retired_at IS NULL "
                "AND (? IS NULL OR method=?)",
                (at, method, method),
                paths,
                end=")",
            )
        return rejections + changed + checks

    def baseline_checks(self, method: str | None = None) -> list[BaselineCheck]:
        rows = self._rows(
            _ACTIVE_CHECKS + " ORDER BY b.robot, b.axis, b.method, c.kind", (method, method)
        )
        return [BaselineCheck(**dict(r)) for r in rows]

    def changed_file_acknowledged(self, change: ChangedFile) -> bool:
        return bool(
            self._rows(
                "SELECT 1 FROM changed_files WHERE path=? AND scored_hash=? AND current_hash=? "
                "AND acknowledged_at IS NOT NULL",
                (change.path, change.scored_hash, change.current_hash),
            )
        )

    def record_axis_activity(self, seen: Sequence[tuple[str, str, int, str]], at: str) -> None:
        with self._write() as db:
            for robot, axis, n_files, newest in seen:
                db.execute(
                    "INSERT INTO axis_activity (robot, axis, n_files, newest_capture, "
                    "last_seen_at) VALUES (?, ?, ?, ?, ?) ON CONFLICT (robot, axis) DO UPDATE "
                    "SET last_seen_at=CASE WHEN excluded.n_files>n_files OR "
                    "excluded.newest_capture>newest_capture THEN excluded.last_seen_at "
                    "ELSE last_seen_at END, n_files=excluded.n_files, "
                    "newest_capture=max(newest_capture, excluded.newest_capture)",
                    (robot, axis, n_files, newest, at),
                )

    def axis_activity(self) -> pd.DataFrame:
        return self._frame(
            "SELECT robot, axis, n_files, newest_capture, last_seen_at FROM axis_activity "
            "ORDER BY robot, axis"
        )

    def latest_bad_data(self) -> pd.DataFrame:
        return self._frame(
            "SELECT robot, axis, method, "
            "max(CASE WHEN acknowledged_at IS NULL THEN capture END) AS bad_capture, "
            "max(CASE WHEN acknowledged_at IS NOT NULL THEN capture END) AS seen_capture, "
            "max(acknowledged_at) AS seen_at FROM rejections "
            "WHERE kind='bad data' AND removed_at IS NULL GROUP BY robot, axis, method "
            "ORDER BY robot, axis, method"
        )

    def problem_table(self, method: str | None = None) -> pd.DataFrame:
        return self._frame(
            "SELECT coalesce(kind, 'invalid') AS kind, method, path, error, rejected_at AS since, "
            "acknowledged_at, removed_at FROM rejections WHERE (? IS NULL OR method=?) "
            "UNION ALL SELECT 'changed', '', path, 'content changed after it was scored', "
            "detected_at, acknowledged_at, NULL FROM changed_files "
            "UNION ALL SELECT 'baseline check', method, path, note, detected_at, "
            f"acknowledged_at, NULL FROM ({_ACTIVE_CHECKS}) "
            "ORDER BY path, kind, method",
            (method, method, method, method),
        )


def _each_path(
    db: sqlite3.Connection,
    sql: str,
    parameters: tuple[Any, ...],
    paths: Sequence[str],
    *,
    end: str = "",
) -> int:
    """Run ``sql`` + ``end`` once (no paths) or once per path (``sql AND path=? end``: ``end``
    closes a subquery the path is of); rows changed."""
    if not paths:
        return int(db.execute(sql + end, parameters).rowcount)
    return sum(int(db.execute(f"{sql} AND path=?{end}", (*parameters, p)).rowcount) for p in paths)


#: The name users open a store by (``aw.Store("fleet.db")``): the product's SQLite backend.
Store = SQLiteStore


def summary_extras(
    frame: pd.DataFrame, baselines: list[Baseline], alarms: list[AlarmState]
) -> pd.DataFrame:
    """Add ``threshold_origin``, ``alarm_since`` and ``acknowledged_by`` to a summary table
    whose rows are ``baselines`` (in order); shared by the backends."""
    frame["threshold_origin"] = [_threshold_origin(b) for b in baselines]
    by_key = {(a.robot, a.axis, a.method): a for a in alarms}
    keys = [(b.robot, b.axis, b.method) for b in baselines]
    frame["alarm_since"] = [getattr(by_key.get(k), "raised_capture", None) for k in keys]
    frame["acknowledged_by"] = [getattr(by_key.get(k), "acknowledged_by", None) for k in keys]
    return frame


def _threshold_origin(baseline: Baseline) -> str | None:
    """Where a baseline's threshold comes from, in words (None while it calibrates)."""
    if baseline.threshold is None or baseline.fit is None:
        return None
    params = json.loads(baseline.params)
    rule = DecisionRule(percentile=float(params.get("percentile", 99.0)))
    return stored_threshold(baseline.threshold, baseline.fit, rule).describe()


def _no_active_baseline(
    location: str, robot: str, axis: str, method: str | None, active: Any
) -> str:
    """The message of :meth:`StoreBackend.retire_baselines` for an axis without a baseline."""
    known = sorted(f"{r[0]}/{r[1]} ({r[2]})" for r in active)
    return (
        f"robot '{robot}' axis '{axis}'"
        + (f" method '{method}'" if method else "")
        + f" has no active baseline in store '{location}'; axes with one: "
        + (", ".join(known) or "none")
        + "."
    )


def _alarmed_baseline(robot: str, axis: str, capture: str, method: str) -> str:
    return (
        f"capture '{capture}' of robot '{robot}' axis '{axis}' raised an alarm "
        f"({method}); an alarmed capture cannot be a baseline. Choose a capture "
        "recorded after the maintenance."
    )
