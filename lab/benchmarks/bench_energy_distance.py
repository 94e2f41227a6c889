"""Speed of axiswatch_lab.energy_distance (cdist) against the obvious double loop, same process.

Run: .venv/bin/python lab/benchmarks/bench_energy_distance.py
"""

from __future__ import annotations

import time

import numpy as np

import axiswatch_lab as lab


def _loop(first: np.ndarray, second: np.ndarray) -> float:
    def mean_norm(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.mean([np.linalg.norm(x - y) for x in a for y in b]))

    return 2 * mean_norm(first, second) - mean_norm(first, first) - mean_norm(second, second)


def main() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 150, 40))
    start = time.perf_counter()
    fast = lab.energy_distance(a, b)
    fast_s = time.perf_counter() - start
    start = time.perf_counter()
    slow = _loop(a, b)
    slow_s = time.perf_counter() - start
    print(
        f"energy_distance 150x150 rows: {fast_s * 1e3:.2f} ms, loop {slow_s * 1e3:.0f} ms, "
        f"ratio {slow_s / fast_s:.0f}x, difference {abs(fast - slow):.2e}"
    )


if __name__ == "__main__":
    main()
