"""Every command that only reads a store works on a read-only store, and leaves it as it was.

A copy for analysis or a mounted backup: the file mode 0444 in a folder of mode 0555. Root ignores
file modes, so where the tests run as root the file and the folder are made immutable as well
(``chattr +i``: nobody, root included, may change them).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sqlite3
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

import axiswatch.datasets as awd
from tests._cli import Ran, run
from tests.conftest import settle


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A store written by a monitor run: scores and a rejected capture."""
    folder = tmp_path_factory.mktemp("written")
    root = folder / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=4, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / "robot01" / "axis1" / "2026-03-09.csv").write_text("time,speed\n0,oops\n")
    settle(root)
    store = folder / "s.db"
    result = run("monitor", root, "--store", store, "--method", "pca", "--calibration", "2")
    assert result.returncode == 8, result.stdout + result.stderr
    return store


@pytest.fixture
def folder(tmp_path: Path) -> Iterator[Path]:
    """A folder made read-only by :func:`_read_only_copy`, writable again at the end."""
    folder = tmp_path / "ro"
    folder.mkdir()
    yield folder
    if os.geteuid() == 0:
        subprocess.run(["chattr", "-i", *folder.iterdir(), folder], check=False)
    folder.chmod(0o755)


def _read_only_copy(store: Path, folder: Path) -> tuple[Path, str]:
    """A copy of ``store`` that no process of ours can change; its SHA-256."""
    copy = Path(shutil.copy(store, folder / "s.db"))
    copy.chmod(0o444)
    folder.chmod(0o555)
    if os.geteuid() == 0:
        if shutil.which("chattr") is None:
            pytest.skip("root ignores file modes, and chattr is not installed")
        made = subprocess.run(["chattr", "+i", copy, folder], capture_output=True, check=False)
        if made.returncode != 0:
            pytest.skip(f"root ignores file modes, and chattr +i fails: {made.stderr!r}")
    return copy, hashlib.sha256(copy.read_bytes()).hexdigest()


def _read(commands: list[list[object]]) -> list[Ran]:
    outcomes = [run(*args) for args in commands]
    for outcome in outcomes:
        assert (outcome.returncode, outcome.stderr) == (0, ""), outcome
    return outcomes


def _readers(store: Path, out: Path) -> list[list[object]]:
    return [
        ["results", "--store", store],
        ["report", "--store", store, "--out", out / "report"],
        ["backup", "--store", store, out / "b.db"],
        ["rejections", "--store", store],
        ["ack", "--list", "--store", store],
    ]


def test_every_reading_command_works_on_a_read_only_store(
    written: Path, folder: Path, tmp_path: Path
) -> None:
    # Before: results, report and backup opened the store for writing (WAL mode, schema
    # upgrades) and failed: "attempt to write a readonly database".
    store, digest = _read_only_copy(written, folder)
    outcomes = _read(_readers(store, tmp_path))
    results, _, backup, rejections, acks = (o.stdout for o in outcomes)
    assert "2026-03-04.parquet" in results
    assert (tmp_path / "report" / "index.html").is_file()
    assert "(4 score rows)" in backup
    assert "2026-03-09.csv" in rejections
    assert acks == "No acknowledgements.\n"
    assert hashlib.sha256(store.read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in folder.iterdir()) == ["s.db"]


def test_a_read_only_store_of_an_older_layout_is_read_without_upgrading_it(
    written: Path, folder: Path, tmp_path: Path
) -> None:
    # A store made before the rejections' removed_at column and the axis_activity table: on
    # open for writing they are added; read-only, the store is upgraded in memory only.
    older = tmp_path / "older.db"
    shutil.copy(written, older)
    connection = sqlite3.connect(older)
    connection.execute("ALTER TABLE rejections DROP COLUMN removed_at")
    connection.execute("DROP TABLE axis_activity")
    connection.commit()
    connection.close()
    store, digest = _read_only_copy(older, folder)
    outcomes = _read(_readers(store, tmp_path))
    assert "2026-03-09.csv" in outcomes[3].stdout
    assert hashlib.sha256(store.read_bytes()).hexdigest() == digest
