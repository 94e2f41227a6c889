"""The monitor on a Dask cluster against the process pool, at the same number of workers.

The cluster is started as a user starts one: ``dask scheduler`` and one ``dask worker``
command per worker (``--nthreads 1 --nworkers 1``, a nanny each), as processes of their own.
Rounds are interleaved: in each, the pool and then the cluster score the same new day of a
fleet (``fleet.build_fleet``, with axis profiles) from a copy of the same commissioned store.

Every run's cost is the CPU time of all processes: the driver (and the pool's workers, its
children), the scheduler, the workers and the nannies. Each run's cluster CPU is also split
into what the cluster costs when idle for as long (its event loops) and the rest. Models are
dropped from every process before a run, so that both backends read each model once per worker.

``--tuned-cluster`` also times a second cluster started with :data:`TUNED_CLUSTER`;
``--allocator`` times serial scoring under the allocator settings a nanny gives its workers.

    .venv/bin/python benchmarks/bench_dask.py --robots 60 --rounds 5 --tuned-cluster --allocator
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager, nullcontext
from pathlib import Path
from typing import Any

import psutil

from axiswatch.monitor import _models
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor._parallel import connect_dask
from axiswatch.monitor.store import Store

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fleet

#: Seconds the cluster may take to start.
START_LIMIT_S = 120
#: What a nanny sets in its workers' environment (Dask's ``pre-spawn-environ``).
NANNY_MALLOC = {"MALLOC_TRIM_THRESHOLD_": "65536"}
#: A cluster started for the monitor alone: no statistical profiler, event loops checked and
#: memory read once a second instead of every 20 and 100 ms.
TUNED_CLUSTER = {
    "DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False",
    "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "1s",
    "DASK_DISTRIBUTED__WORKER__MEMORY__MONITOR_INTERVAL": "1s",
}


def _bin(name: str) -> str:
    return str(Path(sys.executable).parent / name)


def _forget_models() -> None:
    """Drop the models this process keeps (a worker starts a run as a fresh one would)."""
    _models._cache.clear()


@contextmanager
def cluster(folder: Path, workers: int, env: dict[str, str]) -> Iterator[dict[str, Any]]:
    """A scheduler and ``workers`` single-threaded workers, each with its nanny."""
    folder.mkdir(parents=True, exist_ok=True)
    address_file = folder / "scheduler.json"
    address_file.unlink(missing_ok=True)
    log = (folder / "cluster.log").open("ab")
    environ = {**os.environ, **env}
    common = ["--no-dashboard"]
    started = [
        subprocess.Popen(
            [_bin("dask"), "scheduler", "--host", "127.0.0.1", "--port", "0",
             "--scheduler-file", str(address_file), *common],
            cwd=folder, stdout=log, stderr=log, env=environ,
        )
    ]  # fmt: skip
    try:
        deadline = time.monotonic() + START_LIMIT_S
        while not address_file.is_file() or not address_file.read_text().strip():
            if time.monotonic() > deadline or started[0].poll() is not None:
                raise RuntimeError(f"no scheduler started: {folder / 'cluster.log'}")
            time.sleep(0.1)
        address = json.loads(address_file.read_text())["address"]
        for _ in range(workers):
            started.append(
                subprocess.Popen(
                    [_bin("dask"), "worker", address, "--host", "127.0.0.1",
                     "--nworkers", "1", "--nthreads", "1", "--local-directory", str(folder),
                     "--preload", "axiswatch.monitor._scoring", *common],
                    cwd=folder, stdout=log, stderr=log, env=environ,
                )
            )  # fmt: skip
        client = connect_dask(address)
        try:
            client.wait_for_workers(workers, timeout=START_LIMIT_S)
        finally:
            client.close()
        nannies = [psutil.Process(p.pid) for p in started[1:]]
        yield {
            "address": address,
            "scheduler": psutil.Process(started[0].pid),
            "nannies": nannies,
            "workers": [child for nanny in nannies for child in nanny.children()],
        }
    finally:
        for process in reversed(started):
            process.terminate()
        for process in started:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                process.kill()
        log.close()


def _cpu(processes: list[psutil.Process]) -> float:
    return sum(sum(p.cpu_times()[:2]) for p in processes)


def _task_threads_cpu(workers: list[psutil.Process]) -> float:
    """CPU of the thread that runs tasks in each worker (its busiest thread)."""
    return float(sum(max(t.user_time + t.system_time for t in p.threads()) for p in workers))


def _roles_cpu(where: dict[str, Any]) -> dict[str, float]:
    return {
        "scheduler": _cpu([where["scheduler"]]),
        "workers": _cpu(where["workers"]),
        "task_threads": _task_threads_cpu(where["workers"]),
        "nannies": _cpu(where["nannies"]),
    }


def _own_cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    return own.ru_utime + own.ru_stime


def _driver_threads() -> dict[int, float]:
    return {t.id: t.user_time + t.system_time for t in psutil.Process().threads()}


def timed_run(
    folder: Path, template: Path, root: Path, config: MonitorConfig, label: str,
    where: dict[str, Any] | None, workers: int,
) -> dict[str, Any]:  # fmt: skip
    """One monitor run from a copy of the commissioned store; CPU of every process."""
    path = folder / f"{label}.db"
    path.unlink(missing_ok=True)
    fleet._copy_store(template, path)
    _forget_models()
    client = None
    if where is not None:
        client = connect_dask(where["address"])
        client.run(_forget_models)
        roles = _roles_cpu(where)
    load = os.getloadavg()[0]
    threads = _driver_threads()
    driver, own = fleet.cpu_seconds(), _own_cpu()
    with Store(path) as store:
        start = time.perf_counter()
        if client is None:
            summary = monitor_fleet(root, store, config, workers=workers, settle_s=0.0)
        else:
            summary = monitor_fleet(root, store, config, dask=client, settle_s=0.0)
        wall = time.perf_counter() - start
        driver, own = fleet.cpu_seconds() - driver, _own_cpu() - own
        digest = fleet.score_hash(store)
    row: dict[str, Any] = {
        "backend": label,
        "workers": workers,
        "captures": summary.scored,
        "wall_s": round(wall, 3),
        "load": round(load, 2),
        "driver_cpu_s": round(driver, 3),
        "driver_own_cpu_s": round(own, 3),
    }
    if where is not None and client is not None:
        after = _roles_cpu(where)
        spent = {role: after[role] - roles[role] for role in roles}
        now = _driver_threads()
        main = os.getpid()  # the main thread's id on Linux
        row["driver_main_cpu_s"] = round(now[main] - threads.get(main, 0.0), 3)
        row["driver_other_threads_cpu_s"] = round(
            sum(now[t] - threads.get(t, 0.0) for t in now if t != main), 3
        )
        # The same cluster idle for as long: what its event loops cost in that time.
        idle_start = _roles_cpu(where)
        time.sleep(wall)
        idle_end = _roles_cpu(where)
        client.close()
        for role in spent:
            row[f"{role}_cpu_s"] = round(spent[role], 3)
            row[f"{role}_idle_cpu_s"] = round(idle_end[role] - idle_start[role], 3)
        row["all_cpu_s"] = round(
            driver + sum(v for role, v in spent.items() if role != "task_threads"), 3
        )
    else:
        row["all_cpu_s"] = round(driver, 3)
    row["hash"] = digest[:16]
    print("  " + ", ".join(f"{k} {v}" for k, v in row.items()), flush=True)
    return row


def _serial_child(folder: Path, reused: bool) -> None:
    """Score the new day serially in this process; print its CPU and minor page faults."""
    from axiswatch.monitor._malloc import arrays_reused

    path = folder / f"serial-{os.getpid()}.db"
    fleet._copy_store(folder / "commissioned.db", path)
    with Store(path) as store, arrays_reused() if reused else nullcontext():
        before = resource.getrusage(resource.RUSAGE_SELF)
        monitor_fleet(folder / "fleet", store, MonitorConfig(calibration_size=2), settle_s=0.0)
        after = resource.getrusage(resource.RUSAGE_SELF)
    path.unlink()
    print(json.dumps({
        "user_s": after.ru_utime - before.ru_utime,
        "system_s": after.ru_stime - before.ru_stime,
        "minor_faults": after.ru_minflt - before.ru_minflt,
    }))  # fmt: skip


def allocator_case(folder: Path, rounds: int) -> None:
    """The same serial run in fresh processes: as a plain process, with the environment a
    nanny gives its workers, and with that environment while freed arrays are reused."""
    variants = {
        "plain process": ({}, False),
        "nanny's environment": (NANNY_MALLOC, False),
        "nanny's environment, arrays_reused()": (NANNY_MALLOC, True),
    }
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in variants}
    for _ in range(rounds):
        for name, (env, reused) in variants.items():
            command = [sys.executable, __file__, "--serial-child", str(folder)]
            command += ["--reused"] if reused else []
            output = subprocess.run(
                command, env={**os.environ, **env}, check=True, capture_output=True, text=True
            ).stdout
            runs[name].append(json.loads(output.splitlines()[-1]))
    print(f"\nSerial scoring of the same day, median of {rounds} fresh processes:")
    for name, measured in runs.items():
        medians = {key: statistics.median(run[key] for run in measured) for key in measured[0]}
        print(
            f"  {name:<38} user {medians['user_s']:.2f} s, system {medians['system_s']:.2f} s, "
            f"{medians['minor_faults']:,.0f} minor page faults"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=60)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--method", default="indicators")
    parser.add_argument("--csv", type=Path, default=None)
    parser.add_argument(
        "--tuned-cluster", action="store_true",
        help="also time a second cluster, started with the settings of TUNED_CLUSTER",
    )  # fmt: skip
    parser.add_argument(
        "--allocator", action="store_true",
        help="also time serial runs under a nanny's allocator settings",
    )  # fmt: skip
    parser.add_argument("--serial-child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--reused", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serial_child:
        _serial_child(args.serial_child, args.reused)
        return
    clusters = {"dask": {}, "dask-tuned": TUNED_CLUSTER} if args.tuned_cluster else {"dask": {}}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        root = folder / "fleet"
        fleet.build_fleet(root, args.robots, 4)
        new_day = fleet._hold(root, folder / "held", 4)
        config = MonitorConfig(method=args.method, calibration_size=2)
        template = folder / "commissioned.db"
        with Store(template) as store:
            monitor_fleet(root, store, config, workers=args.workers, settle_s=0.0)
        fleet._release(root, folder / "held", new_day)
        with Store(folder / "serial.db") as store:
            monitor_fleet(root, store, config, workers=1, settle_s=0.0)
            serial = fleet.score_hash(store)[:16]
        rows = []
        with ExitStack() as stack:
            started = {
                name: stack.enter_context(cluster(folder / name, args.workers, env))
                for name, env in clusters.items()
            }
            for where in started.values():
                # A first run warms the workers (imports beyond the preload, filters' caches).
                timed_run(folder, template, root, config, "warm-up", where, args.workers)
            for _ in range(args.rounds):
                rows.append(
                    timed_run(folder, template, root, config, "processes", None, args.workers)
                )
                for name, where in started.items():
                    rows.append(
                        timed_run(folder, template, root, config, name, where, args.workers)
                    )
        if args.allocator:
            allocator_case(folder, args.rounds)
    for row in rows:
        row["identical_to_serial"] = row["hash"] == serial
    print(f"\n{len(new_day)} captures, {args.workers} workers, median of {args.rounds} rounds:")
    by_backend = {
        name: [r for r in rows if r["backend"] == name] for name in ("processes", *clusters)
    }
    pool = by_backend["processes"]
    for name in clusters:
        for key in ("all_cpu_s", "wall_s"):
            p = statistics.median(r[key] for r in pool)
            d = statistics.median(r[key] for r in by_backend[name])
            print(f"  {key}: processes {p:.3f}, {name} {d:.3f}, {name} / processes {d / p:.3f}")
    for name, runs in by_backend.items():
        for key in [k for k in runs[0] if k.endswith("_cpu_s") and k != "all_cpu_s"]:
            print(f"  {name} {key}: {statistics.median(r[key] for r in runs):.3f}")
    print(f"  every run identical to the serial run: {all(r['identical_to_serial'] for r in rows)}")
    if args.csv:
        with args.csv.open("w", newline="") as stream:
            writer = csv.DictWriter(stream, fieldnames=list(by_backend["dask"][0]))
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    main()
