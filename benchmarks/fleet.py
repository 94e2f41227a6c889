"""Fleet-scale cases of ``benchmarks/run.py``: the fleet day, a year of history, the worker curve.

Fleets come from the project's robot simulator (``axiswatch.datasets.simulate_fleet``, 6 axes a
robot, 3 s captures, healthy). Simulating every capture of a large fleet would take longer than
the runs measured, so a few robots are simulated (``TEMPLATE_ROBOTS``) and every robot of the
fleet gets its own copy of one of them with independent noise of 0.1 % of each signal's
standard deviation added (every file, hence every fitted model, differs, as in a real fleet;
the scoring work per capture is that of the simulator's captures).

Every timed run is checked: the hash of its score rows must equal that of a serial run on a
fresh store (no stored model, no file index), or of the other runs of the same curve.
"""

from __future__ import annotations

import concurrent.futures
import csv
import datetime
import hashlib
import importlib
import os
import resource
import shutil
import sqlite3
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import scipy.fft

import axiswatch as aw
from axiswatch._profiles import FLEET_PROFILE
from axiswatch.datasets._robot_fleet import simulate_fleet
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.store import Store

#: Robots simulated; the others are noisy copies of them.
TEMPLATE_ROBOTS = 3
AXES = 6


def _noisy_copy(task: tuple[str, str, int]) -> None:
    source, target, seed = task
    capture = aw.read_capture(source)
    rng = np.random.default_rng(seed)
    signals = {
        name: values + 1e-3 * float(np.std(values)) * rng.normal(size=values.size)
        for name, values in capture.signals.items()
    }
    Path(target).parent.mkdir(parents=True, exist_ok=True)
    aw.write_capture(aw.Capture(signals, capture.rates_hz), target)


def build_fleet(root: Path, robots: int, days: int, *, processes: int | None = None) -> None:
    """``robots`` x 6 axes x ``days`` healthy captures of 3 s in ``root`` (see module docstring)."""
    templates = root.parent / f"{root.name}-templates"
    simulate_fleet(
        templates,
        n_robots=min(robots, TEMPLATE_ROBOTS),
        n_axes=AXES,
        n_days=days,
        task_change_days=(),
        faults=[],
    )
    tasks = []
    for robot in range(robots):
        template = templates / f"robot{robot % TEMPLATE_ROBOTS + 1:02d}"
        for source in sorted(template.glob("*/*.parquet")):
            target = root / f"robot{robot + 1:05d}" / source.parent.name / source.name
            tasks.append((str(source), str(target), len(tasks)))
    with concurrent.futures.ProcessPoolExecutor(processes or os.cpu_count()) as pool:
        list(pool.map(_noisy_copy, tasks, chunksize=32))
    # The axis profile the simulator writes (its kinematics): a fleet as a user runs it.
    shutil.copy(templates / FLEET_PROFILE, root / FLEET_PROFILE)
    shutil.rmtree(templates)


def score_hash(store: Store) -> str:
    """SHA-256 of every score row's identity and result (exact float reprs), in a fixed order."""
    digest = hashlib.sha256()
    columns = [
        "robot",
        "axis",
        "method",
        "capture",
        "role",
        "distance",
        "threshold",
        "over",
        "alarm",
    ]
    rows = store.score_table()[columns].sort_values(columns[:5])
    for row in rows.itertuples(index=False):
        digest.update(repr(tuple(row)).encode())
    return digest.hexdigest()


def floor_seconds(paths: list[Path]) -> float:
    """The physical floor of scoring these files, in CPU seconds of this process: read each
    file's columns (pyarrow) and one ``rfft`` per signal."""
    start = time.process_time()
    for path in paths:
        table = pq.read_table(path)
        for name in table.column_names:
            if name != "time":
                scipy.fft.rfft(table[name].to_numpy())
    return time.process_time() - start


def cpu_seconds() -> float:
    """CPU time (user + system) of this process and of its children that have ended.

    On a shared machine the wall time of a run says how many cores it was given; its CPU time
    says what it cost. The monitor's worker processes end with the run, so their time is in."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _hold(root: Path, held: Path, day: int) -> list[Path]:
    new_day = sorted(root.glob(f"*/*/*-{day:02d}.parquet"))
    for path in new_day:
        target = held / path.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        path.rename(target)
    return new_day


def _release(root: Path, held: Path, new_day: list[Path]) -> None:
    for path in new_day:
        (held / path.relative_to(root)).rename(path)


def case_fleet_day(
    folder: Path, robots: int, method: str, *, workers: int = 2, check: bool = True
) -> dict[str, Any]:
    """One fleet day, as the daily job runs it, after a commissioning run (not timed)."""
    root = folder / "fleet"
    build_fleet(root, robots, 7)
    new_day = _hold(root, folder / "held", 7)
    config = MonitorConfig(method=method)  # type: ignore[arg-type]
    with Store(folder / "fleet.db") as store:
        monitor_fleet(root, store, config, workers=workers, settle_s=0.0)
        _release(root, folder / "held", new_day)
        floor = floor_seconds(new_day)  # also brings the new files into the page cache
        start, cpu_start = time.perf_counter(), cpu_seconds()
        summary = monitor_fleet(root, store, config, workers=workers, settle_s=0.0)
        elapsed, cpu = time.perf_counter() - start, cpu_seconds() - cpu_start
        timed_hash = score_hash(store)
    assert summary.scored == len(new_day) == robots * AXES, summary
    result: dict[str, Any] = {
        "case": f"fleet day: {robots} robots x 6 axes, --workers {workers} ({method})",
        "fast_s": elapsed,
        "floor_s": floor,
        "cpu_s": cpu,
        "ratio_to_floor": cpu / floor,
        "per_capture_ms": cpu / len(new_day) * 1e3,
        "robots": robots,
    }
    if check:
        with Store(folder / "serial.db") as fresh:
            monitor_fleet(root, fresh, config, workers=1, settle_s=0.0)
            result["identical_to_serial_uncached"] = score_hash(fresh) == timed_hash
    return result


def _history_fleet(root: Path, days: int) -> None:
    """1 robot x 6 axes with ``days`` daily captures: 7 simulated days, hard-linked under the
    names of the other days (the file count is what a history costs; contents repeat)."""
    # Dated so that the last day is yesterday: the monitor holds back captures dated in the
    # future (a logger clock), which a year from a fixed date would soon be.
    start = np.datetime64(datetime.date.today()) - np.timedelta64(days + 1, "D")
    simulate_fleet(
        root, n_robots=1, n_axes=AXES, n_days=7, task_change_days=(), faults=[],
        start_date=str(start),
    )  # fmt: skip
    for folder in sorted(root.glob("*/*")):
        week = sorted(folder.glob("*.parquet"))
        for day in range(7, days):
            name = f"{start + np.timedelta64(day, 'D')}.parquet"
            os.link(week[day % 7], folder / name)


def case_history(folder: Path, days: int, method: str, repeats: int = 21) -> dict[str, Any]:
    """A day's run and a run with nothing new, after ``days`` days of kept files."""
    root = folder / "fleet"
    _history_fleet(root, days + 1)
    last = sorted(root.glob("*/*/*.parquet"))[-1].name
    new_day = sorted(root.glob(f"*/*/{last}"))
    held = folder / "held"
    for path in new_day:
        target = held / path.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        path.rename(target)
    config = MonitorConfig(method=method)  # type: ignore[arg-type]
    with Store(folder / "fleet.db") as store:
        monitor_fleet(root, store, config, workers=2, settle_s=0.0)
        _release(root, held, new_day)
        start = time.perf_counter()
        summary = monitor_fleet(root, store, config, workers=2, settle_s=0.0)
        day_s = time.perf_counter() - start
        assert summary.scored == AXES, summary
        idle = []
        for _ in range(repeats):
            start = time.perf_counter()
            again = monitor_fleet(root, store, config, workers=2, settle_s=0.0)
            idle.append(time.perf_counter() - start)
            assert again.scored == 0
    nothing_new = statistics.median(idle)
    return {
        "case": f"history: 1 robot x 6 axes, {days} days kept ({method})",
        "fast_s": day_s,
        "nothing_new_s": nothing_new,
        "ratio": nothing_new / day_s,
        "note": f"day's run {day_s:.3f} s; nothing new {nothing_new:.4f} s "
        f"(median of {repeats}) = {100 * nothing_new / day_s:.2f} % of it",
    }


def _copy_store(source: Path, target: Path) -> None:
    """A consistent copy of a store (SQLite's backup: the file alone may miss its WAL, which a
    process holding a read-only connection keeps open)."""
    with sqlite3.connect(source) as reader, sqlite3.connect(target) as writer:
        reader.backup(writer)
    reader.close()
    writer.close()


def _write_curve(rows: list[dict[str, Any]], csv_path: Path, machine: str) -> None:
    """(Re)write the curve's CSV, so that a run cut short keeps what it measured."""
    serial = rows[0]["seconds"]  # 1 process (serial in the driver) comes first
    for row in rows:
        row["speedup"] = round(serial / row["seconds"], 2)
        row["efficiency"] = round(serial / row["seconds"] / row["workers"], 3)
        row["identical"] = row["hash"] == rows[0]["hash"]
        row["machine"] = machine
    with csv_path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


#: Dask configuration of the curve's "dask-quiet" runs.
_QUIET_DASK = {"distributed.worker.profile.enabled": False}


def workers_curve(
    folder: Path,
    robots: int,
    counts: list[int],
    method: str,
    csv_path: Path,
    machine: str,
    repeats: int = 1,
) -> list[dict[str, Any]]:
    """Time one fleet day (``robots`` x 6 new captures) on 1..N local processes and on a Dask
    LocalCluster of as many single-threaded worker processes; write a CSV.

    The fleet is commissioned once (baseline + 2 calibration captures per axis, not timed);
    every timed run starts from a copy of that store, so each scores the same new captures with
    the stored models (workers start cold: each reads the models it needs once).
    """
    root = folder / "fleet"
    build_fleet(root, robots, 4)
    new_day = _hold(root, folder / "held", 4)
    config = MonitorConfig(method=method, calibration_size=2)  # type: ignore[arg-type]
    template = folder / "commissioned.db"
    with Store(template) as store:
        monitor_fleet(root, store, config, workers=os.cpu_count() or 1, settle_s=0.0)
    _release(root, folder / "held", new_day)
    floor = floor_seconds(new_day)
    rows: list[dict[str, Any]] = []

    def timed(backend: str, count: int, worker_pids: tuple[int, ...] = (), **where: Any) -> None:
        """One run; its CPU is the driver's (with a LocalCluster's scheduler, which runs in
        the driver), plus the pool's workers (children ended with the run) or the Dask
        workers' and nannies' (``worker_pids``, read with psutil)."""
        import psutil

        path = folder / f"{backend}-{count}.db"
        _copy_store(template, path)
        load = os.getloadavg()[0]
        marks: list[float] = []
        others = [psutil.Process(pid) for pid in worker_pids]

        def others_cpu() -> float:
            return sum(sum(p.cpu_times()[:2]) for p in others)

        total = cpu_seconds() + others_cpu()

        def progress(stage: str, done: int, total: int) -> None:
            if stage == "captures":
                marks.append(time.perf_counter())

        with Store(path) as store:
            cpu = time.process_time()
            start = time.perf_counter()
            summary = monitor_fleet(root, store, config, settle_s=0.0, progress=progress, **where)
            elapsed = time.perf_counter() - start
            cpu = time.process_time() - cpu
            total = cpu_seconds() + others_cpu() - total
            digest = score_hash(store)
        assert summary.scored == len(new_day), summary
        rows.append(
            {
                "backend": backend,
                "workers": count,
                "captures": len(new_day),
                "seconds": round(elapsed, 3),
                "load_before": round(load, 2),
                "floor_s": round(floor, 3),
                # The timeline: first and last result committed, and the driver's own CPU.
                "first_result_s": round(marks[0] - start, 3),
                "last_result_s": round(marks[-1] - start, 3),
                "driver_cpu_s": round(cpu, 3),
                "all_cpu_s": round(total, 3),
                "hash": digest[:16],
            }
        )
        print(
            f"  {backend:<9} {count:>2} workers: {elapsed:8.2f} s (load {load:.1f}; first result "
            f"{marks[0] - start:.2f} s, last {marks[-1] - start:.2f} s, driver CPU {cpu:.2f} s, "
            f"all processes {total:.2f} s CPU)",
            flush=True,
        )
        _write_curve(rows, csv_path, machine)

    try:
        import dask
        import distributed
        import psutil
    except ImportError:
        distributed = None
    for _ in range(repeats):  # rounds, interleaved, so that a change of load hits every backend
        for workers in counts:
            timed("processes", workers, workers=workers)
        if distributed is None:
            continue
        # Dask as installed, then with the workers' statistical profiler off (it samples the
        # task thread's stack every 10 ms, taking the GIL from it).
        for backend, settings in (("dask", {}), ("dask-quiet", _QUIET_DASK)):
            for workers in counts:
                with (
                    dask.config.set(settings),
                    distributed.LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=":0",
                    ) as cluster,
                    distributed.Client(cluster) as client,
                ):
                    # Warm, as a long-lived cluster's workers are: the pool's forked workers
                    # inherit the driver's imports, spawned Dask workers import on first use
                    # (1.3 s of CPU each; ``dask worker --preload`` does it at start).
                    client.run(importlib.import_module, "axiswatch.monitor._scoring")
                    pids = list(client.run(os.getpid).values())
                    nannies = {psutil.Process(pid).ppid() for pid in pids} - {os.getpid()}
                    timed(backend, workers, (*pids, *nannies), dask=client)
    # Every run against a serial one on a fresh store: no stored model, no file index.
    with Store(folder / "uncached.db") as fresh:
        monitor_fleet(root, fresh, config, workers=1, settle_s=0.0)
        uncached = score_hash(fresh)[:16]
    for row in rows:
        row["identical_to_uncached_serial"] = row["hash"] == uncached
    _write_curve(rows, csv_path, machine)
    return rows
