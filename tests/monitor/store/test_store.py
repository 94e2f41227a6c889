"""The SQLite store: schema, WAL, version check, files that are not a store.

The behaviour every backend shares (transactions, records, tables) is in test_store_contract.py.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from axiswatch.exceptions import StoreError
from axiswatch.monitor.store import SCHEMA_VERSION, SQLiteStore, Store


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
    with pytest.raises(StoreError, match=r"has schema version 7; this axiswatch reads version 3"):
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


def _runs(path: Path) -> list[str]:
    return [str(r[0]) for r in _query(path, "SELECT started_at FROM runs ORDER BY rowid")]


def _add_runs(store: SQLiteStore, names: list[str]) -> None:
    for name in names:
        with store._write() as db:
            db.execute("INSERT INTO runs (started_at) VALUES (?)", (name,))


def test_closing_the_writer_moves_the_log_into_the_file_while_a_reader_stays(
    tmp_path: Path,
) -> None:
    """A worker or notebook that keeps a read-only connection keeps the WAL alive after the
    writer closes; the writer's close checkpoints it, so the store file alone holds every
    commit (a naive copy of ``fleet.db`` misses none). Fails without the checkpoint in
    ``close``: the copy then has no runs."""
    path = tmp_path / "fleet.db"
    writer = SQLiteStore(path)
    reader = SQLiteStore(path, read_only=True)
    assert reader.score_table().empty  # the reader has used its connection
    _add_runs(writer, ["a", "b", "c"])
    writer.close()
    assert (tmp_path / "fleet.db-wal").exists()  # the reader keeps the log file
    alone = tmp_path / "alone" / "fleet.db"
    alone.parent.mkdir()
    alone.write_bytes(path.read_bytes())  # the store file only, as a naive backup copies it
    reader.close()
    assert _runs(alone) == ["a", "b", "c"]


def test_backup_is_one_file_with_every_commit_while_the_writer_is_open(tmp_path: Path) -> None:
    path = tmp_path / "fleet.db"
    with SQLiteStore(path) as store:
        _add_runs(store, ["a", "b"])
        assert (tmp_path / "fleet.db-wal").stat().st_size > 0  # the commits are in the log
        copy = store.backup(tmp_path / "copy.db")
        _add_runs(store, ["after"])  # not in the copy: it was made before
    assert copy == tmp_path / "copy.db"
    assert not (tmp_path / "copy.db-wal").exists()
    assert _query(copy, "PRAGMA journal_mode") == [("delete",)]
    assert _runs(copy) == ["a", "b"]
    assert _runs(path) == ["a", "b", "after"]
    with Store(copy) as restored:  # a backup opens as a store
        assert restored.version == SCHEMA_VERSION


def test_backup_never_overwrites_and_leaves_nothing_when_it_fails(tmp_path: Path) -> None:
    (tmp_path / "taken.db").write_bytes(b"precious")
    with SQLiteStore(tmp_path / "fleet.db") as store:
        with pytest.raises(StoreError, match=r"backup '.*taken.db' already exists; a backup"):
            store.backup(tmp_path / "taken.db")
        with pytest.raises(StoreError, match=r"folder '.*missing' does not exist"):
            store.backup(tmp_path / "missing" / "copy.db")
    assert (tmp_path / "taken.db").read_bytes() == b"precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fleet.db", "taken.db"]
