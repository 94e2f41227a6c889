"""The SQLite store: schema, WAL, version check, files that are not a store.

The behaviour every backend shares (transactions, records, tables) is in test_store_contract.py.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from axiswatch.exceptions import StoreError
from axiswatch.monitor._store import SCHEMA_VERSION, SQLiteStore, Store


def _query(path: Path, sql: str) -> list[tuple[object, ...]]:
    with sqlite3.connect(path) as connection:
        return list(connection.execute(sql))


def test_new_store_has_the_schema_and_wal(tmp_path: Path) -> None:
    with Store(tmp_path / "s.db") as store:
        assert isinstance(store, SQLiteStore)
        assert store.version == SCHEMA_VERSION
    assert _query(tmp_path / "s.db", "PRAGMA journal_mode") == [("wal",)]
    tables = {r[0] for r in _query(tmp_path / "s.db", "SELECT name FROM sqlite_master")}
    assert {"schema_version", "baselines", "scores", "rejections", "changed_files"} <= tables
    with Store(tmp_path / "s.db") as again:  # reopening keeps it
        assert again.version == SCHEMA_VERSION
        assert repr(again) == f"axiswatch.monitor.SQLiteStore({str(tmp_path / 's.db')!r})"


def test_other_schema_version_is_refused(tmp_path: Path) -> None:
    Store(tmp_path / "s.db").close()
    with sqlite3.connect(tmp_path / "s.db") as connection:
        connection.execute("UPDATE schema_version SET version = 7")
    with pytest.raises(StoreError, match=r"has schema version 7; this axiswatch reads version 2"):
        Store(tmp_path / "s.db")


def test_foreign_sqlite_file_is_refused(tmp_path: Path) -> None:
    connection = sqlite3.connect(tmp_path / "other.db")
    connection.execute("CREATE TABLE t (x)")
    connection.commit()
    connection.close()
    with pytest.raises(StoreError, match=r"without an axiswatch schema \(tables \['t'\]\)"):
        Store(tmp_path / "other.db")


def test_non_sqlite_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "text.db").write_text("hello, this is not a database" * 10)
    with pytest.raises(StoreError, match=r"cannot be opened as an axiswatch SQLite store"):
        Store(tmp_path / "text.db")


def test_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match=r"exists but is not a file"):
        Store(tmp_path)


def test_a_write_that_fails_inside_a_batch_undoes_only_itself(tmp_path: Path) -> None:
    """In a batch each write is a savepoint: one that raises after writing is rolled back to it,
    and the batch's earlier writes stay (they commit with the batch)."""
    store = SQLiteStore(tmp_path / "s.db")
    with store.batch():
        with store._write() as db:
            db.execute("INSERT INTO runs (started_at) VALUES ('kept')")
        with pytest.raises(RuntimeError):
            _fail_after_a_write(store)
    store.close()
    with sqlite3.connect(tmp_path / "s.db") as connection:
        rows = [r[0] for r in connection.execute("SELECT started_at FROM runs")]
    assert rows == ["kept"]


def _fail_after_a_write(store: SQLiteStore) -> None:
    with store._write() as db:
        db.execute("INSERT INTO runs (started_at) VALUES ('undone')")
        raise RuntimeError
