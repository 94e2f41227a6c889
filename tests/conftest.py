"""Shared, seeded fixtures; and one BLAS/OpenMP thread for the whole suite.

The suite's linear algebra is small (SVDs of a few hundred rows): a multi-threaded BLAS only
fights for the cores of a 2-core machine, and much harder under ``pytest -n 2``, where two test
processes share them (``select_default``: 15 s on one thread, 60-250 s on two threads of a
loaded machine). The variables are set before NumPy is first imported (here, and in every
subprocess a test starts: ``axiswatch demo``, ``benchmarks/run.py``), and the limit is set once
more at run time in case a plugin imported NumPy first. Tests that check a thread limit raise
the driver's limit themselves (tests/monitor/test_worker_pool.py), so that they can still fail.
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import axiswatch as aw  # noqa: E402
import axiswatch.datasets as awd  # noqa: E402

threadpool_limits(1)

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def robot_capture(rng: np.random.Generator) -> aw.Capture:
    """A 1 s capture with the paper's rates: position 250 Hz, speed and torque 2 kHz."""
    t_slow = np.arange(250) / 250.0
    t_fast = np.arange(2000) / 2000.0
    return aw.Capture(
        {
            "position": np.sin(2 * np.pi * 2 * t_slow) + 0.01 * rng.normal(size=250),
            "speed": np.cos(2 * np.pi * 2 * t_fast) + 0.01 * rng.normal(size=2000),
            "torque": 0.5 * np.cos(2 * np.pi * 2 * t_fast) + 0.01 * rng.normal(size=2000),
        },
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        metadata={"robot": "r1", "axis": "a4"},
    )


@pytest.fixture(scope="session")
def lab_features() -> list[np.ndarray]:
    """Real features: the lab dataset's ten days, with the lab experiment's |STFT| settings."""
    spec = aw.FeatureSpec(combinations="none", segment_length=128, padding="circular")
    return [aw.extract_features(d.capture, spec).X for d in awd.lab_dataset(seed=3)]


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A healthy simulated fleet, 1 robot x 2 axes x 9 days of 0.5 s captures (copy before use)."""
    from axiswatch.datasets._robot_fleet import simulate_fleet

    root = tmp_path_factory.mktemp("fleet") / "fleet"
    simulate_fleet(
        root, n_robots=1, n_axes=2, n_days=9, task_change_days=(), faults=[], duration_s=0.5
    )
    settle(root)
    return root


def settle(root: Path, age_s: float = 3600.0) -> None:
    """Date every capture file below ``root`` ``age_s`` seconds back: delivered and settled long
    ago, as the monitor expects before it scores a file (``settle_s``)."""
    import os
    import time

    then = time.time() - age_s
    for path in root.rglob("*"):
        if path.is_file():
            os.utime(path, (then, then))
