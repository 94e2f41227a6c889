"""The SQLite store's transactions, and its answers to people: tables, alarms and the people
who saw them, standing problems (:class:`~axiswatch.monitor.store.StoreReader`,
:class:`~axiswatch.monitor.store.StoreOperator`)."""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from axiswatch._calibration import HalfLaplaceFit
from axiswatch.exceptions import StoreError
from axiswatch.monitor._feedback import check_verdict
from axiswatch.monitor.store.packing import unpack
from axiswatch.monitor.store.records import AlarmState, Baseline, BaselineCheck, summary_extras
from axiswatch.monitor.store.upgrades import dictionaries

__all__ = ["SQLiteTables"]

#: The alarm episode of every baseline chosen by ``{where}`` whose last monitored capture is in
#: alarm: the score that raised it (the first alarmed one after the last clean one) and its
#: latest acknowledgement.
_ALARMS = """
WITH last AS (
    SELECT b.id AS baseline_id, b.robot, b.axis, b.method,
        (SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor'
         ORDER BY s.id DESC LIMIT 1) AS alarm,
        (SELECT max(s.id) FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor'
         AND s.alarm=0) AS last_clean,
        (SELECT max(k.score_id) FROM acknowledgements k WHERE k.baseline_id=b.id
         AND k.verdict='fault-confirmed' AND k.id=(SELECT max(o.id) FROM acknowledgements o
         WHERE o.score_id=k.score_id)) AS confirmed
    FROM baselines b {where}
)
SELECT l.robot, l.axis, l.method, l.baseline_id, r.id AS raised_score_id,
    r.capture AS raised_capture, r.captured_at AS raised_at, a.acknowledged_by, a.note,
    a.acknowledged_at, a.verdict
FROM last l
JOIN scores r ON r.id = CASE WHEN l.alarm=1 THEN (SELECT min(s.id) FROM scores s
    WHERE s.baseline_id=l.baseline_id AND s.role='monitor' AND s.alarm=1
    AND s.id > coalesce(l.last_clean, 0)) ELSE l.confirmed END
LEFT JOIN acknowledgements a ON a.id = (SELECT max(k.id) FROM acknowledgements k
    WHERE k.score_id=r.id)
WHERE l.alarm=1 OR l.confirmed IS NOT NULL
ORDER BY l.robot, l.axis, l.method
"""

#: The checks of active baselines, with the baseline's axis, method and path.
_ACTIVE_CHECKS = (
    "SELECT c.baseline_id, b.robot, b.axis, b.method, b.path, c.kind, c.note, c.detected_at, "
    "c.acknowledged_at FROM baseline_checks c JOIN baselines b ON b.id=c.baseline_id "
    "WHERE b.retired_at IS NULL AND (? IS NULL OR b.method=?)"
)


def time_of(text: str) -> datetime:
    return datetime.fromisoformat(text)


def baseline_of(row: sqlite3.Row) -> Baseline:
    calibration = row["calibration"]
    return Baseline(
        id=int(row["id"]),
        robot=row["robot"],
        axis=row["axis"],
        method=row["method"],
        epoch=int(row["epoch"]),
        capture=row["capture"],
        captured_at=time_of(row["captured_at"]),
        path=row["path"],
        file_hash=row["file_hash"],
        features_hash=row["features_hash"],
        params=row["params"],
        threshold=row["threshold"],
        fit=None if calibration is None else HalfLaplaceFit(**json.loads(calibration)),
        retired=row["retired_at"] is not None,
    )


class SQLiteTables:
    """The transactions and the people's queries of :class:`~axiswatch.monitor.store.SQLiteStore`."""

    path: Path
    _connection: sqlite3.Connection
    _batched: bool

    @property
    def location(self) -> str:
        return str(self.path)

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
        >>> from axiswatch.monitor.store import SQLiteStore
        >>> folder = pathlib.Path(tempfile.mkdtemp())
        >>> with SQLiteStore(folder / "fleet.db") as store:
        ...     copy = store.backup(folder / "fleet-backup.db")
        >>> with SQLiteStore(copy) as restored:
        ...     restored.version
        3
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

    def _rows(self, sql: str, parameters: tuple[Any, ...] = ()) -> list[sqlite3.Row]:
        with self._errors():
            return list(self._connection.execute(sql, parameters))

    def _frame(self, sql: str, parameters: tuple[Any, ...] = ()) -> pd.DataFrame:
        with self._errors():
            cursor = self._connection.execute(sql, parameters)
            columns = [d[0] for d in cursor.description]
            return pd.DataFrame([tuple(r) for r in cursor.fetchall()], columns=columns)

    # --- reads ---------------------------------------------------------------------------------

    def baseline(self, baseline_id: int) -> Baseline:
        rows = self._rows("SELECT * FROM baselines WHERE id=?", (baseline_id,))
        if not rows:
            raise StoreError(f"store '{self.path}' has no baseline with id {baseline_id}.")
        return baseline_of(rows[0])

    # --- alarms and the people who saw them ------------------------------------------------

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        """Axes in alarm after their last monitored capture (active baselines), acknowledged or
        not, and axes whose fault was confirmed until they are re-baselined; one per axis and
        method."""
        where = "WHERE b.retired_at IS NULL AND (? IS NULL OR b.method=?)"
        rows = self._rows(_ALARMS.format(where=where), (method, method))
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
            "a.note, a.acknowledged_at, a.verdict FROM acknowledgements a "
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
            "s.captured_at, b.epoch, s.role, s.over, s.baseline_id, s.packed, s.primed, s.path "
            "FROM scores s JOIN baselines b ON b.id = s.baseline_id "
            "WHERE (? IS NULL OR s.robot=?) AND (? IS NULL OR s.axis=?) "
            "ORDER BY s.robot, s.axis, s.method, s.captured_at, s.capture, b.epoch",
            (robot, robot, axis, axis),
        )
        with self._errors():
            primers = dictionaries(self._connection, frame["baseline_id"])
        texts = [
            unpack(bytes(packed), primers[int(baseline_id)] if primed else None)
            for baseline_id, packed, primed in zip(
                frame.pop("baseline_id"), frame.pop("packed"), frame.pop("primed"), strict=True
            )
        ]
        frame.insert(11, "reason", [reason for reason, _ in texts])
        frame.insert(12, "details", [details for _, details in texts])
        frame["alarm"] = frame["alarm"].astype(bool)
        frame["over"] = frame["over"].astype(bool)
        frame["distance"] = frame["distance"].astype(np.float64)
        frame["threshold"] = frame["threshold"].astype(np.float64)
        return frame

    def summary_table(self) -> pd.DataFrame:
        frame = self._frame(
            "SELECT b.id AS baseline_id, b.robot, b.axis, b.method, b.epoch, "
            "b.capture AS baseline, "
            # A baseline whose modes decide has no fitted threshold: its scores are in
            # threshold units, compared with 1.
            "coalesce(b.threshold, (SELECT s.threshold FROM scores s WHERE s.baseline_id=b.id "
            "AND s.role='monitor' ORDER BY s.id DESC LIMIT 1)) AS threshold, "
            "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.role!='baseline') "
            "+ (SELECT count(*) FROM thinned_scores t WHERE t.baseline_id=b.id) AS scored, "
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
