"""The monitor on a Dask cluster started as a user starts one: ``dask scheduler`` and ``dask worker``
as processes of their own, on 127.0.0.1, ended with the module (and by their own timeouts).

The monitor runs in a process of its own too: nothing in it has made a Dask client the default.
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import axiswatch.datasets as awd
from tests._cli import run
from tests.conftest import settle

FAST = ("--method", "pca", "--calibration", "2", "--settle", "0")
#: Seconds a command, or the cluster's start, may take before the test fails.
LIMIT_S = 120


def _bin(name: str) -> str:
    return str(Path(sys.executable).parent / name)


def _end(process: subprocess.Popen[bytes]) -> None:
    process.terminate()
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The address of a scheduler with one worker process (one thread)."""
    pytest.importorskip("distributed")
    folder = tmp_path_factory.mktemp("dask")
    address_file = folder / "scheduler.json"
    log = (folder / "cluster.log").open("wb")
    started = []
    try:
        started.append(
            subprocess.Popen(
                [_bin("dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
                 "--no-dashboard", "--scheduler-file", str(address_file),
                 "--idle-timeout", str(LIMIT_S * 3)],
                cwd=folder, stdout=log, stderr=log,
            )
        )  # fmt: skip
        started.append(
            subprocess.Popen(
                [_bin("dask"), "worker", "--scheduler-file", str(address_file),
                 "--host", "127.0.0.1", "--nworkers", "1", "--nthreads", "1", "--no-nanny",
                 "--no-dashboard", "--local-directory", str(folder), "--death-timeout", "30",
                 "--preload", "axiswatch.monitor._scoring"],  # imported while the test starts
                cwd=folder, stdout=log, stderr=log,
            )
        )  # fmt: skip
        deadline = time.monotonic() + LIMIT_S
        while not address_file.is_file() or not address_file.read_text().strip():
            assert time.monotonic() < deadline, (folder / "cluster.log").read_text()
            assert started[0].poll() is None, (folder / "cluster.log").read_text()
            time.sleep(0.1)
        yield str(json.loads(address_file.read_text())["address"])
    finally:
        for process in reversed(started):
            _end(process)
        log.close()


@pytest.fixture
def fleet(tmp_path: Path) -> Path:
    """1 robot x 2 axes x 5 captures of 0.5 s."""
    root = tmp_path / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=2, n_days=5, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / "labels.csv").unlink()
    settle(root)
    return root


def _axiswatch(*args: object) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        [sys.executable, "-m", "axiswatch", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=LIMIT_S,
    )
    assert "Traceback" not in result.stdout + result.stderr, result.stderr
    return result


def _scores(store: Path) -> list[tuple[object, ...]]:
    connection = sqlite3.connect(store)
    try:
        return list(
            connection.execute(
                "SELECT robot, axis, capture, role, distance, threshold, alarm FROM scores "
                "ORDER BY robot, axis, capture"
            )
        )
    finally:
        connection.close()


def test_monitor_scores_on_a_scheduler_and_its_workers_hold_no_store_open(
    scheduler: str, fleet: Path, tmp_path: Path
) -> None:
    later = {axis: fleet / "robot01" / axis / "2026-03-05.parquet" for axis in ("axis1", "axis2")}
    for axis, path in later.items():
        shutil.move(path, tmp_path / f"{axis}.parquet")
    store = tmp_path / "s.db"
    assert run("monitor", fleet, "--store", store, *FAST).returncode == 0  # models stored
    shutil.copyfile(store, tmp_path / "b.db")  # a backup, as a copy of the file
    # A capture of axis1 scored on the cluster: the worker reads axis1's model from the store.
    # Before: "No clients found", exit 1: the client made from the address was not the
    # default client that dask.distributed's wait() looks for.
    _arrive(tmp_path / "axis1.parquet", later["axis1"])
    first = _axiswatch("monitor", fleet, "--store", store, *FAST, "--dask", scheduler)
    assert first.returncode == 0, first.stderr
    assert "1 capture(s) scored" in first.stdout
    # Before: the worker kept its connection, and with it the store's write-ahead log: a backup
    # copied over the store then met the old file's log ("database disk image is malformed").
    assert sorted(p.name for p in tmp_path.glob("s.db*")) == ["s.db"]
    shutil.copyfile(tmp_path / "b.db", store)  # the backup restored in place
    _arrive(tmp_path / "axis2.parquet", later["axis2"])
    second = _axiswatch("monitor", fleet, "--store", store, *FAST, "--dask", scheduler)
    assert second.returncode == 0, second.stderr
    assert "2 capture(s) scored" in second.stdout  # axis2's model read from the restored file
    serial = tmp_path / "serial.db"
    assert run("monitor", fleet, "--store", serial, *FAST).returncode == 0
    assert _scores(store) == _scores(serial)


def _arrive(source: Path, target: Path) -> None:
    shutil.move(source, target)
    settle(target.parent)
