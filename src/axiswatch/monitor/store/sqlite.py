"""The SQLite store: :class:`SQLiteStore`, the product's store backend.

WAL mode, and one short ``BEGIN IMMEDIATE`` transaction per write: a killed process leaves the
store as it was after its last commit. The people's queries are in ``sqlite_tables``.
"""

from __future__ import annotations

import dataclasses
import json
import sqlite3
from collections.abc import Callable, Sequence
from contextlib import suppress
from datetime import datetime, timedelta
from pathlib import Path

from axiswatch.exceptions import StoreError
from axiswatch.monitor._decision import AxisHistory, Decision
from axiswatch.monitor.store.records import (
    AddedBaseline,
    Baseline,
    ChangedFile,
    IndexedFile,
    NewBaseline,
    NewScore,
    Rejection,
    SavedModel,
    ScoredFile,
    _alarmed_baseline,
    _no_active_baseline,
    now,
    now_us,
)
from axiswatch.monitor.store.sqlite_retention import RECENT_KEPT, Compaction, thin
from axiswatch.monitor.store.sqlite_tables import SQLiteTables, baseline_of, time_of
from axiswatch.monitor.store.upgrades import create_or_check, pack_score, upgrade

__all__ = ["SQLiteStore", "Store"]

_INSERT_SCORE = (
    "INSERT INTO scores (baseline_id, robot, axis, method, capture, captured_at, path, "
    "file_hash, file_size, file_mtime_ns, role, distance, threshold, over, alarm, "
    "packed, primed, scored_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
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

#: Every score, thinned ones included (file and axis only): what a run must not score again.
_EVERY_SCORE = (
    "(SELECT id, robot, axis, method, capture, path, file_hash, file_size, file_mtime_ns "
    "FROM scores UNION ALL SELECT t.id, b.robot, b.axis, b.method, t.capture, t.path, "
    "t.file_hash, t.file_size, t.file_mtime_ns FROM thinned_scores t "
    "JOIN baselines b ON b.id = t.baseline_id)"
)

#: A check, or the same check again (kept as it is), or another note of its kind (news again).
_INSERT_CHECK = (
    "INSERT INTO baseline_checks (baseline_id, kind, note, detected_at) VALUES (?, ?, ?, ?) "
    "ON CONFLICT (baseline_id, kind) DO UPDATE SET note=excluded.note, "
    "detected_at=CASE WHEN note=excluded.note THEN detected_at ELSE excluded.detected_at END, "
    "acknowledged_at=CASE WHEN note=excluded.note THEN acknowledged_at END"
)


class SQLiteStore(SQLiteTables):
    """The monitoring store in one SQLite file (created with the current schema when new).

    Implements :class:`StoreBackend`; also exported as ``Store``.

    Parameters
    ----------
    path : str or Path
        The SQLite file.
    timeout_s : float, default=60.0
        How long a writer waits for another process's transaction before giving up.
    read_only : bool, default=False
        Open an existing store for reading only; nothing is ever written to it. Works where the
        file or its folder is read-only; a store of an older layout is upgraded in memory.

    Raises
    ------
    StoreError
        If the file is not an SQLite database, or holds another schema version.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> store = SQLiteStore(pathlib.Path(tempfile.mkdtemp()) / "fleet.db")
    >>> store.version, len(store.score_table())
    (3, 0)
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
            if read_only:
                self._connection = _open_read_only(self.path, timeout_s)
                self.version = self._read_only_schema()
                return
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
                f"store '{self.path}': cannot be opened as an axiswatch SQLite store: {exc}."
            ) from None

    def _read_only_schema(self) -> int:
        """Check the schema of a store opened read-only; a store of an older layout is copied
        into memory and upgraded there (the file is never written)."""
        try:
            version = self._ensure_schema()
            self._upgrade()
            return version
        except StoreError as exc:
            if not isinstance(exc.__cause__, sqlite3.OperationalError) or "readonly" not in str(
                exc.__cause__
            ):
                raise
        memory = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
        memory.row_factory = sqlite3.Row
        self._connection.backup(memory)
        self._connection.close()
        self._connection = memory
        version = self._ensure_schema()
        self._upgrade()
        return version

    def __repr__(self) -> str:
        return f"axiswatch.monitor.SQLiteStore({str(self.path)!r})"

    def _ensure_schema(self) -> int:
        with self._write() as connection:
            return create_or_check(connection, self.path)

    def _upgrade(self) -> None:
        with self._write() as connection:
            upgrade(connection)

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

    def mode_library(self, baseline_id: int) -> bytes | None:
        row = self._connection.execute(
            "SELECT library FROM mode_libraries WHERE baseline_id=?", (baseline_id,)
        ).fetchone()
        return None if row is None else bytes(row[0])

    def save_mode_library(self, baseline_id: int, blob: bytes) -> None:
        with self._write() as db:
            db.execute(
                "INSERT OR REPLACE INTO mode_libraries (baseline_id, library, saved_at) "
                "VALUES (?, ?, ?)",
                (baseline_id, blob, now()),
            )

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
            f"SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns "
            f"FROM {_EVERY_SCORE} WHERE path=? ORDER BY id DESC LIMIT 1",
            (path,),
        ).fetchone()
        return None if row is None else ScoredFile(*row)

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        return (
            self._connection.execute(
                f"SELECT 1 FROM {_EVERY_SCORE} WHERE path=? AND file_hash=? AND method=? LIMIT 1",
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

    def compact(
        self, keep: timedelta, every: timedelta = timedelta(days=1), *, recent: int = RECENT_KEPT
    ) -> Compaction:
        """Thin the history older than ``keep`` to one score per baseline and ``every``, then
        return the space to the file system (``VACUUM``).

        Kept in full: the last ``keep`` before the newest capture, baseline and calibration
        scores, scores over the threshold or in alarm, the clean score before each alarm,
        acknowledged scores and each baseline's last ``recent`` monitored scores (at least its
        alarm rule's window). Of the rest, each period keeps its highest distance. A thinned
        capture is never scored again.

        Parameters
        ----------
        keep : timedelta
            The history kept in full, before the newest capture.
        every : timedelta, default=1 day
            The period older scores are thinned to one of.
        recent : int, default=RECENT_KEPT (100)
            The latest monitored scores of each baseline kept in full.

        Returns
        -------
        Compaction
            The scores thinned and kept.

        Raises
        ------
        StoreError
            If the store is opened read-only.
        ValueError
            If ``keep`` is negative or ``every`` is not positive.
        """
        if self._read_only:
            raise StoreError(f"store '{self.path}' is opened read-only; compacting writes it.")
        if keep < timedelta(0):
            raise ValueError(f"The 'keep' parameter must not be negative. Got {keep}.")
        if every <= timedelta(0):
            raise ValueError(f"The 'every' parameter must be positive. Got {every}.")
        if recent < 0:
            raise ValueError(f"The 'recent' parameter must not be negative. Got {recent}.")
        with self._write() as db:
            done = thin(db, keep, every, recent)
        with self._errors():
            self._connection.execute("VACUUM")
            self._connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        return done

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
            packed = pack_score(db, baseline_id, "baseline", b.reason, json.dumps(b.details))
            db.execute(
                _INSERT_SCORE,
                (
                    baseline_id, b.robot, b.axis, b.method, b.capture, b.captured_at.isoformat(),
                    b.path, b.file_hash, b.file_size, b.file_mtime_ns, "baseline", None, None,
                    0, 0, *packed, now(),
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
                "SELECT 1 FROM scores WHERE baseline_id=? AND capture=? UNION ALL "
                "SELECT 1 FROM thinned_scores WHERE baseline_id=? AND capture=?",
                (s.baseline_id, s.capture, s.baseline_id, s.capture),
            ).fetchone():
                return False
            baseline = baseline_of(
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
            details = json.dumps({**s.details, **decision.details}, sort_keys=True)
            packed = pack_score(db, s.baseline_id, decision.role, decision.reason, details)
            db.execute(
                _INSERT_SCORE,
                (
                    s.baseline_id, s.robot, s.axis, s.method, s.capture,
                    s.captured_at.isoformat(), s.path, s.file_hash, s.file_size,
                    s.file_mtime_ns, decision.role, s.distance, decision.threshold,
                    int(decision.over), int(decision.alarm), *packed, now(),
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

    def latest_baseline(self, robot: str, axis: str, method: str) -> Baseline | None:
        rows = self._rows(
            "SELECT * FROM baselines WHERE robot=? AND axis=? AND method=? ORDER BY epoch DESC "
            "LIMIT 1",
            (robot, axis, method),
        )
        return baseline_of(rows[0]) if rows else None

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
            "SELECT max(s.captured_at) FROM baselines b JOIN scores s ON s.baseline_id = b.id "
            "WHERE b.robot=? AND b.axis=? AND b.method=?",
            (robot, axis, method),
        )[0][0]
        return None if last is None else time_of(last)

    def scored_captures(self, baseline_id: int) -> set[str]:
        rows = self._rows(
            "SELECT capture FROM scores WHERE baseline_id=? "
            "UNION ALL SELECT capture FROM thinned_scores WHERE baseline_id=?",
            (baseline_id, baseline_id),
        )
        return {r["capture"] for r in rows}

    def scored_files(self) -> dict[str, ScoredFile]:
        rows = self._rows(
            f"SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns "
            f"FROM {_EVERY_SCORE} ORDER BY id"
        )
        return {r["path"]: ScoredFile(**dict(r)) for r in rows}

    def scored_contents(self, method: str) -> set[tuple[str, str]]:
        rows = self._rows(f"SELECT path, file_hash FROM {_EVERY_SCORE} WHERE method=?", (method,))
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

    # --- standing problems and axis activity ---------------------------------------------------

    def resolve_transient(self, method: str, seen_before: str) -> None:
        with self._write() as db:
            db.execute(
                "DELETE FROM rejections WHERE method=? AND transient=1 AND rejected_at<?",
                (method, seen_before),
            )

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


def _open_read_only(path: Path, timeout_s: float) -> sqlite3.Connection:
    """A read-only connection to an existing store (``mode=ro``); ``immutable`` where SQLite
    cannot open the shared-memory file a store in WAL mode needs (a read-only folder)."""
    for options in ("mode=ro", "immutable=1"):
        connection = sqlite3.connect(
            f"{path.absolute().as_uri()}?{options}",
            timeout=timeout_s,
            isolation_level=None,
            check_same_thread=False,
            uri=True,
        )
        connection.row_factory = sqlite3.Row
        connection.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
        try:
            connection.execute("SELECT count(*) FROM sqlite_master").fetchone()
        except sqlite3.OperationalError:
            connection.close()
            if options == "immutable=1":
                raise
            continue
        return connection
    raise AssertionError("unreachable")


#: The name users open a store by (``aw.Store("fleet.db")``): the product's SQLite backend.
Store = SQLiteStore
