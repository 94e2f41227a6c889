"""Time ``axiswatch monitor`` on a simulated fleet: seconds per capture, per method.

Run: ``.venv/bin/python benchmarks/bench_monitor.py [n_robots n_axes n_days]``. Prints the time of
simulating the fleet, of a first monitoring run (baselines, calibration and scoring) and of a
second run with nothing new (the cost of discovering and hashing the fleet), for LRA and PCA.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from axiswatch import MonitorConfig, Store, monitor_fleet
from axiswatch.datasets._robot_fleet import simulate_fleet


def main(n_robots: int = 2, n_axes: int = 2, n_days: int = 10) -> None:
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder) / "fleet"
        start = time.perf_counter()
        labels = simulate_fleet(root, n_robots=n_robots, n_axes=n_axes, n_days=n_days)
        print(f"simulate {len(labels)} captures of 3 s: {time.perf_counter() - start:.2f} s")
        with Store(Path(folder) / "fleet.db") as store:
            for method in ("lra", "pca"):
                config = MonitorConfig(method=method)  # type: ignore[arg-type]
                start = time.perf_counter()
                summary = monitor_fleet(root, store, config, settle_s=0.0)
                first = time.perf_counter() - start
                start = time.perf_counter()
                monitor_fleet(root, store, config, settle_s=0.0)
                again = time.perf_counter() - start
                per = first / max(1, summary.scored + summary.new_baselines)
                print(
                    f"{method}: first run {first:.2f} s ({per * 1000:.0f} ms per capture), "
                    f"re-run with nothing new {again:.2f} s"
                )


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
