"""Shared, seeded fixtures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd

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
    """Real features: the lab dataset's ten days, as in the lab experiment."""
    from axiswatch_lab._experiments import LAB_FEATURES

    return [aw.extract_features(d.capture, LAB_FEATURES).X for d in awd.lab_dataset(seed=3)]


@pytest.fixture(scope="session")
def small_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A healthy simulated fleet, 1 robot x 2 axes x 9 days of 0.5 s captures (copy before use)."""
    from axiswatch.datasets._robot import simulate_fleet

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
