"""Every method reads a capture of position and current alike: the speed from the position."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._capture import with_speed
from tests._cli import run
from tests.conftest import settle


@pytest.fixture(scope="module")
def no_speed_fleet(small_fleet: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small fleet exported without its speed column, as a drive's export often is."""
    root = Path(shutil.copytree(small_fleet, tmp_path_factory.mktemp("nospeed") / "fleet"))
    for path in root.glob("*/*/*.parquet"):
        capture = aw.read_capture(path)
        aw.write_capture(capture.select(["position", "torque"]), path)
    settle(root)
    return root


@pytest.mark.parametrize("method", ["lra", "pca"])
def test_a_method_scores_captures_without_a_speed_column(
    no_speed_fleet: Path, tmp_path: Path, method: str
) -> None:
    store = tmp_path / "store.db"
    done = run("monitor", no_speed_fleet, "--store", store, "--method", method, "--no-progress")
    assert "missing signal column" not in done.stdout + done.stderr
    assert done.returncode == 0, done.stdout + done.stderr
    with sqlite3.connect(store) as connection:
        (scored,) = connection.execute("SELECT COUNT(*) FROM scores").fetchone()
    assert scored == 18  # 2 axes x 9 days


def test_the_speed_is_the_position_derivative_at_its_rate() -> None:
    t = np.arange(0, 1, 1 / 250)
    capture = aw.Capture(
        {"position": np.sin(2 * np.pi * t), "torque": np.zeros(2000)},
        {"position": 250.0, "torque": 2000.0},
        source="c.csv",
    )
    derived = with_speed(capture)
    assert derived.rates_hz["speed"] == 250.0
    inner = slice(1, -1)
    expected = (np.sin(2 * np.pi * (t + 1 / 250)) - np.sin(2 * np.pi * (t - 1 / 250))) * 125.0
    np.testing.assert_allclose(derived.signals["speed"][inner], expected[inner], rtol=1e-12)
    assert with_speed(derived) is derived  # a speed of its own is kept
    no_position = capture.select(["torque"])
    assert with_speed(no_position) is no_position
