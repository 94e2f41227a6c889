"""CPU of ``axiswatch report`` per axis at two fleet sizes, in one run: linear in axes.

Run: ``.venv/bin/python benchmarks/bench_report.py [robots,...]`` (default 8,67: 48 and 402
axes). One robot of 6 axes x 8 days is simulated with the simulator's default faults and axis
profiles; every other robot is a copy of it, so each axis's history and verdict are those of a
real monitored axis. Each fleet is monitored with the default method into a fresh store. The
figures are CPU seconds: the verdicts alone (the triage of every axis, the part that filtered
the whole results per axis) and the whole page (:func:`write_report`, charts included).
"""

from __future__ import annotations

import functools
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from axiswatch.datasets import simulate_fleet
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._methods import DEFAULT_METHOD
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.html import write_report
from axiswatch.monitor.report.verdict import fleet_verdicts
from axiswatch.monitor.store import Store


def _cpu(fn: Callable[[], object], repeats: int = 3) -> float:
    """The smallest CPU time of ``repeats`` calls of ``fn``."""
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        fn()
        best = min(best, time.process_time() - start)
    return best


def main(sizes: tuple[int, ...] = (8, 67)) -> None:
    folder = Path(tempfile.mkdtemp())
    template = folder / "template"
    simulate_fleet(template, n_robots=1, n_axes=6, n_days=8, duration_s=0.5)
    robot = next(p for p in template.iterdir() if p.is_dir())
    print("axes  verdicts s  per axis ms  page s  per axis ms  page MB  needing attention")
    for robots in sizes:
        fleet = folder / f"fleet{robots}"
        fleet.mkdir()
        for kept in template.iterdir():  # the fleet's settings and axis profiles
            if kept.is_file():
                shutil.copy2(kept, fleet)
        for k in range(robots):
            shutil.copytree(robot, fleet / f"robot{k:03d}")
        with Store(folder / f"fleet{robots}.db") as store:
            monitor_fleet(fleet, store, MonitorConfig(), settle_s=0.0)
            verdicts = fleet_verdicts(store, DEFAULT_METHOD)
            axes = len(verdicts)
            urgent = sum(v.needs_attention for v in verdicts)
            judged = _cpu(functools.partial(fleet_verdicts, store, DEFAULT_METHOD))
            out = folder / f"report{robots}"
            page = _cpu(functools.partial(write_report, store, out))
        size = (out / "index.html").stat().st_size / 1e6
        print(
            f"{axes:4d}  {judged:10.2f}  {1e3 * judged / axes:11.2f}  {page:6.2f}  "
            f"{1e3 * page / axes:11.2f}  {size:7.1f}  {urgent}"
        )
    shutil.rmtree(folder)


if __name__ == "__main__":
    main(tuple(int(n) for n in sys.argv[1].split(",")) if len(sys.argv) > 1 else (8, 67))
