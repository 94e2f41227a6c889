"""Peak memory of ``axiswatch monitor`` against the length of one capture (``run.py --memory``).

A simulated robot of 3 axes with the axis profile ``axiswatch simulate fleet`` writes (its
kinematics: the tooth and bearing lines are read), 7 days of 3 s captures at 2 kHz, fitted by a
first run. Day 8 brings one capture of the length measured on axis 1 and a 3 s capture on the
other two; the second run's peak resident memory (``wait4``: the monitor's own process, its
workers included) is printed, with what became of the long capture and whether the other axes'
captures were scored in the same run.

Captures up to 10 minutes are simulated whole. Longer ones are 60 s of simulation repeated
(the position jumps where a copy ends, which the length check does not read), written a copy at
a time, so that building a 4 h file takes little memory itself.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

import axiswatch as aw
import axiswatch.datasets as awd
from axiswatch._capture import capture_to_frame
from axiswatch.datasets._robot_fleet import simulate_fleet

#: Lengths measured (s), and those of ``--quick``.
LENGTHS_S: tuple[float, ...] = (3.0, 60.0, 600.0, 3600.0, 4 * 3600.0)
QUICK_LENGTHS_S: tuple[float, ...] = (3.0, 60.0)
#: Longer captures are this much simulation repeated.
SIMULATED_MAX_S = 600.0
TILE_S = 60.0
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _task(root: Path) -> str:
    """The task of robot01/axis1 in a simulated fleet (its labels)."""
    with (root / "labels.csv").open() as labels:
        return next(row["task"] for row in csv.DictReader(labels) if row["axis"] == "axis1")


def _tiled(path: Path, task: str, seconds: float) -> None:
    """A Parquet capture of ``seconds``: :data:`TILE_S` of simulation, repeated."""
    frame = capture_to_frame(awd.simulate_capture(task, seed=8, duration_s=TILE_S))
    table = pa.Table.from_pandas(frame, preserve_index=False)
    time_s = frame["time"].to_numpy()
    with pq.ParquetWriter(path, table.schema) as writer:
        for copy in range(round(seconds / TILE_S)):
            shifted = table.set_column(0, "time", pa.array(time_s + copy * TILE_S))
            writer.write_table(shifted)


def _long_capture(path: Path, task: str, seconds: float) -> None:
    if seconds <= SIMULATED_MAX_S:
        aw.write_capture(awd.simulate_capture(task, seed=8, duration_s=seconds), path)
    else:
        _tiled(path, task, seconds)


#: Runs a command and prints its exit status and peak resident KiB (``wait4``) last. The monitor
#: is started from this small process: a child forked from the benchmark itself would start with
#: the benchmark's resident memory as its high-water mark.
_PEAK = (
    "import json, os, subprocess, sys\n"
    "child = subprocess.Popen(sys.argv[1:])\n"
    "_, status, usage = os.wait4(child.pid, 0)\n"
    "print(json.dumps([os.waitstatus_to_exitcode(status), usage.ru_maxrss]))\n"
)


def _monitor(root: Path, store: Path, *extra: str) -> tuple[int, float, str]:
    """Exit status, peak resident MB and stdout of ``axiswatch monitor`` in a process of its
    own."""
    command = [sys.executable, "-m", "axiswatch", "monitor", str(root), "--store", str(store)]
    command += ["--settle", "0", "--no-progress", "--stale-after", "off", *extra]
    done = subprocess.run(
        [sys.executable, "-c", _PEAK, *command],
        capture_output=True,
        text=True,
        env={**os.environ, **ONE_THREAD},
        check=True,
    )
    *output, last = done.stdout.splitlines()
    status, peak_kib = json.loads(last)
    return int(status), peak_kib / 1024, "\n".join(output)  # KiB on Linux


def memory_curve(
    folder: Path, lengths: tuple[float, ...], extra: tuple[str, ...] = ()
) -> list[dict[str, Any]]:
    """One row per length: peak MB of the day-8 run, the long capture's fate, the others'."""
    base = folder / "fleet"
    simulate_fleet(base, n_robots=1, n_axes=3, n_days=8, task_change_days=(), faults=[])
    held = {axis: base / f"robot01/axis{axis}/2026-03-08.parquet" for axis in (1, 2, 3)}
    day8 = folder / "day8"
    day8.mkdir()
    for axis, path in held.items():
        path.rename(day8 / f"axis{axis}.parquet")
    store = folder / "fitted.db"
    status, _, output = _monitor(base, store, *extra)
    assert status == 0, output
    rows = []
    for seconds in lengths:
        root = folder / f"fleet-{seconds:g}"
        shutil.copytree(base, root)
        run_store = folder / f"s-{seconds:g}.db"
        shutil.copy(store, run_store)
        long_path = root / "robot01/axis1/2026-03-08.parquet"
        _long_capture(long_path, _task(base), seconds)
        for axis in (2, 3):
            shutil.copy(
                day8 / f"axis{axis}.parquet", root / f"robot01/axis{axis}/2026-03-08.parquet"
            )
        start = time.perf_counter()
        status, peak_mb, output = _monitor(root, run_store, *extra)
        wall_s = time.perf_counter() - start
        with sqlite3.connect(run_store) as connection:
            scored = {
                str(axis)
                for (axis,) in connection.execute(
                    "SELECT axis FROM scores WHERE capture = '2026-03-08.parquet'"
                )
            }
        fate = "scored" if "axis1" in scored else "rejected" if "rows, more than" in output else "?"
        rows.append(
            {
                "seconds": seconds,
                "rows": pq.ParquetFile(long_path).metadata.num_rows,
                "file_mb": long_path.stat().st_size / 1e6,
                "peak_mb": peak_mb,
                "wall_s": wall_s,
                "long": fate,
                "others_scored": {"axis2", "axis3"} <= scored,
                "status": status,
            }
        )
        shutil.rmtree(root)
    return rows


def csv_row(folder: Path, seconds: float) -> dict[str, Any]:
    """Peak MB of reading and scoring one CSV capture of ``seconds`` (the 10-minute export)."""
    root = folder / "csv"
    simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=7, task_change_days=(), faults=[], file_format="csv"
    )
    path = root / "robot01/axis1/2026-03-08.csv"
    aw.write_capture(awd.simulate_capture(_task(root), seed=8, duration_s=seconds), path)
    status, peak_mb, _ = _monitor(root, folder / "csv.db")
    with sqlite3.connect(folder / "csv.db") as connection:
        scored = connection.execute(
            "SELECT COUNT(*) FROM scores WHERE capture = '2026-03-08.csv'"
        ).fetchone()[0]
    return {"seconds": seconds, "file_mb": path.stat().st_size / 1e6, "peak_mb": peak_mb,
            "status": status, "scored": bool(scored)}  # fmt: skip
