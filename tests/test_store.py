"""The SQLite store: schema, version check, transactions."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from axiswatch.exceptions import StoreError
from axiswatch.monitor._store import SCHEMA_VERSION, Store


def test_new_store_has_the_schema_and_wal(tmp_path: Path) -> None:
    with Store(tmp_path / "s.db") as store:
        assert store.version == SCHEMA_VERSION
        assert store.rows("PRAGMA journal_mode")[0][0] == "wal"
        tables = {r[0] for r in store.rows("SELECT name FROM sqlite_master WHERE type='table'")}
    assert {"schema_version", "baselines", "scores", "rejections", "changed_files"} <= tables
    with Store(tmp_path / "s.db") as again:  # reopening keeps it
        assert again.version == SCHEMA_VERSION


def test_a_failed_transaction_is_rolled_back(tmp_path: Path) -> None:
    def failing(store: Store) -> None:
        with store.write() as db:
            db.execute("INSERT INTO schema_version VALUES (99)")
            raise RuntimeError("boom")

    with Store(tmp_path / "s.db") as store:
        with pytest.raises(RuntimeError, match="boom"):
            failing(store)
        assert store.rows("SELECT max(version) FROM schema_version")[0][0] == SCHEMA_VERSION


def test_other_schema_version_is_refused(tmp_path: Path) -> None:
    with Store(tmp_path / "s.db") as store, store.write() as db:
        db.execute("UPDATE schema_version SET version = 7")
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
