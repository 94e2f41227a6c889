"""The SQLite store's schema, and the upgrades a store made by an earlier version gets on open.

The tables and what each column holds: docs/internals.md, "The store".
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterable
from pathlib import Path

from axiswatch.exceptions import StoreError
from axiswatch.monitor._fleet import misnamed_folder_key
from axiswatch.monitor.store.packing import pack, text_of
from axiswatch.monitor.store.sqlite_retention import THINNED_SCORES

__all__ = ["SCHEMA_VERSION", "create_or_check", "dictionaries", "pack_score", "upgrade"]

SCHEMA_VERSION = 3

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
    scored_at TEXT NOT NULL,
    packed BLOB NOT NULL,
    primed INTEGER NOT NULL,
    UNIQUE (baseline_id, capture)
);
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

_SCORE_DICTIONARIES = """
CREATE TABLE IF NOT EXISTS score_dictionaries (
    baseline_id INTEGER PRIMARY KEY REFERENCES baselines (id),
    dictionary BLOB NOT NULL
)
"""

_FILE_INDEX = """
CREATE TABLE IF NOT EXISTS file_index (
    path TEXT PRIMARY KEY,
    size INTEGER NOT NULL,
    mtime_ns INTEGER NOT NULL,
    hash TEXT NOT NULL,
    verified_run INTEGER NOT NULL
) WITHOUT ROWID
"""

_CACHES = (
    """
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
"""
    + _FILE_INDEX
    + """;
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
CREATE TABLE IF NOT EXISTS mode_libraries (
    baseline_id INTEGER PRIMARY KEY REFERENCES baselines (id),
    library BLOB NOT NULL,
    saved_at TEXT NOT NULL
);
"""
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


def create_or_check(connection: sqlite3.Connection, location: Path) -> int:
    """Create the schema in an empty store, or check an existing store's version (a version-1
    store gains the acknowledgements table, a version-2 store's score texts are packed); add
    the caches it lacks. Returns the version."""
    tables = {
        row[0] for row in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")
    }
    if not tables:
        for statement in _SCHEMA.split(";"):
            if statement.strip():
                connection.execute(statement)
        connection.execute(_SCORE_DICTIONARIES)
        connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
        _ensure_caches(connection)
        return SCHEMA_VERSION
    if "schema_version" not in tables:
        raise StoreError(
            f"store '{location}' is an SQLite file without an axiswatch schema "
            f"(tables {sorted(tables)}); use a new file for the store."
        )
    version = connection.execute("SELECT max(version) FROM schema_version").fetchone()[0]
    if version == 1:  # version 2 only adds the acknowledgements table
        connection.execute(_ACKNOWLEDGEMENTS)
        connection.execute("INSERT INTO schema_version VALUES (2)")
        version = 2
    if version == 2:
        _pack_scores(connection)
        connection.execute("INSERT INTO schema_version VALUES (?)", (SCHEMA_VERSION,))
        version = SCHEMA_VERSION
    if version != SCHEMA_VERSION:
        raise StoreError(
            f"store '{location}' has schema version {version}; this axiswatch reads "
            f"version {SCHEMA_VERSION}."
        )
    _ensure_caches(connection)
    return int(version)


def _pack_scores(connection: sqlite3.Connection) -> None:
    """Version 2 to 3: each score's ``reason`` and ``details`` into ``packed``, in scoring order
    (so a baseline's dictionary is its first monitored score, as when written), then the two text
    columns dropped; the file index without a row id, and no index of scores by axis. Row ids
    and every value are kept."""
    connection.execute(_SCORE_DICTIONARIES)
    connection.execute("ALTER TABLE scores ADD COLUMN packed BLOB NOT NULL DEFAULT x''")
    connection.execute("ALTER TABLE scores ADD COLUMN primed INTEGER NOT NULL DEFAULT 0")
    rows = connection.execute(
        "SELECT id, baseline_id, role, reason, details FROM scores ORDER BY id"
    )
    for score_id, baseline_id, role, reason, details in rows.fetchall():
        packed, primed = pack_score(connection, baseline_id, role, reason, details)
        connection.execute(
            "UPDATE scores SET packed=?, primed=? WHERE id=?", (packed, primed, score_id)
        )
    connection.execute("ALTER TABLE scores DROP COLUMN reason")
    connection.execute("ALTER TABLE scores DROP COLUMN details")
    # Scores are found by baseline, path or alarm; the axis index only took space.
    connection.execute("DROP INDEX IF EXISTS scores_axis")
    # The file index keyed by path alone: the path is stored once, not twice.
    if connection.execute(
        "SELECT 1 FROM sqlite_master WHERE type='table' AND name='file_index'"
    ).fetchone():
        connection.execute("ALTER TABLE file_index RENAME TO file_index_rowid")
        connection.execute(_FILE_INDEX)
        connection.execute("INSERT INTO file_index SELECT * FROM file_index_rowid")
        connection.execute("DROP TABLE file_index_rowid")


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


def upgrade(connection: sqlite3.Connection) -> None:
    """The additive upgrades: columns and tables added since, and the keys they derive."""
    for table, column, declaration in _ADDED_COLUMNS:
        present = {row[1] for row in connection.execute(f"PRAGMA table_info({table})")}
        if column not in present:
            connection.execute(f"ALTER TABLE {table} ADD COLUMN {column} {declaration}")
    # A misnamed folder's rejection stored before its reason_key (the column is added
    # empty): the key from its line, in this transaction, so that an acknowledgement
    # made before the upgrade still holds when the next run stores the key.
    for row_id, error in connection.execute(
        "SELECT id, error FROM rejections WHERE reason_key IS NULL AND kind='layout' AND capture=''"
    ).fetchall():
        key = misnamed_folder_key(error)
        if key is not None:
            connection.execute("UPDATE rejections SET reason_key=? WHERE id=?", (key, row_id))
    connection.execute(_AXIS_ACTIVITY)
    connection.execute(_BASELINE_CHECKS)
    for statement in THINNED_SCORES.split(";"):
        connection.execute(statement)


def pack_score(
    db: sqlite3.Connection, baseline_id: int, role: str, reason: str, details: str
) -> tuple[bytes, int]:
    """The ``(packed, primed)`` columns of a score of ``baseline_id`` in ``role``.

    The first ``monitor`` score of a baseline becomes its dictionary: later monitored scores
    share its keys and wording. The few baseline and calibration scores before it are packed
    alone (their text differs from the monitored ones).
    """
    row = db.execute(
        "SELECT dictionary FROM score_dictionaries WHERE baseline_id=?", (baseline_id,)
    ).fetchone()
    dictionary = None if row is None else bytes(row[0])
    if dictionary is None and role == "monitor":
        dictionary = text_of(reason, details)
        db.execute(
            "INSERT INTO score_dictionaries (baseline_id, dictionary) VALUES (?, ?)",
            (baseline_id, dictionary),
        )
    return pack(reason, details, dictionary), int(dictionary is not None)


def dictionaries(db: sqlite3.Connection, baseline_ids: Iterable[int]) -> dict[int, bytes]:
    """The dictionaries of ``baseline_ids`` (those that have one)."""
    wanted = sorted(set(baseline_ids))
    found: dict[int, bytes] = {}
    for start in range(0, len(wanted), 500):
        chunk = wanted[start : start + 500]
        marks = ", ".join("?" * len(chunk))
        for baseline_id, dictionary in db.execute(
            f"SELECT baseline_id, dictionary FROM score_dictionaries WHERE baseline_id IN ({marks})",
            chunk,
        ):
            found[int(baseline_id)] = bytes(dictionary)
    return found
