"""A capture longer than the monitor's limit is refused from its header, and the fleet goes on."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
from axiswatch._capture_length import capture_rows, check_capture_length
from axiswatch.exceptions import CaptureError
from tests._cli import run
from tests.conftest import settle


def _scored(store: Path) -> set[tuple[str, str]]:
    with sqlite3.connect(store) as connection:
        rows = connection.execute("SELECT axis, capture FROM scores").fetchall()
    return {(str(a), str(c)) for a, c in rows}


def test_a_long_capture_is_rejected_in_one_line_and_the_other_axes_are_scored(
    small_fleet: Path, tmp_path: Path
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    # A day-10 capture of 2 s (4,000 rows at 2 kHz) on axis2; a usual one on axis1 (its day 9's
    # signals with a little noise).
    aw.write_capture(
        awd.simulate_capture("heavy", seed=10, duration_s=2.0),
        fleet / "robot01/axis2/2026-03-10.parquet",
    )
    usual = aw.read_capture(fleet / "robot01/axis1/2026-03-09.parquet")
    rng = np.random.default_rng(0)
    noisy = {k: v + 1e-3 * np.std(v) * rng.normal(size=v.size) for k, v in usual.signals.items()}
    aw.write_capture(aw.Capture(noisy, usual.rates_hz), fleet / "robot01/axis1/2026-03-10.parquet")
    settle(fleet)
    store = tmp_path / "store.db"
    for _ in range(2):  # the next run is not stopped by the same file either
        done = run("monitor", fleet, "--store", store, "--no-progress", "--max-capture-rows", 3000)
        assert done.returncode == 8, done.stdout + done.stderr
        assert "Traceback" not in done.stdout + done.stderr
        lines = [
            line for line in done.stdout.splitlines() if "2026-03-10" in line and "rows" in line
        ]
        assert len(lines) == 1
        assert "robot01/axis2/2026-03-10.parquet: 4,000 rows, more than the 3,000 rows" in lines[0]
        assert "--max-capture-rows" in lines[0]
        assert ("axis1", "2026-03-10.parquet") in _scored(store), done.stdout
        assert ("axis2", "2026-03-10.parquet") not in _scored(store)
    assert run("rejections", "--store", store, "--retry").returncode == 0
    done = run("monitor", fleet, "--store", store, "--no-progress", "--max-capture-rows", 5000)
    assert "4,000 rows" not in done.stdout
    assert ("axis2", "2026-03-10.parquet") in _scored(store), done.stdout


def test_the_limit_is_checked_on_a_baseline_too(small_fleet: Path, tmp_path: Path) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    store = tmp_path / "store.db"
    done = run("monitor", fleet, "--store", store, "--no-progress", "--max-capture-rows", 999)
    assert done.returncode == 8
    assert "robot01/axis1/2026-03-01.parquet" in done.stdout
    assert "1,000 rows, more than the 999 rows a capture may hold (0.499 s at 2 kHz" in done.stdout
    assert not _scored(store)


def test_max_capture_rows_must_be_positive(small_fleet: Path, tmp_path: Path) -> None:
    done = run("monitor", small_fleet, "--store", tmp_path / "s.db", "--max-capture-rows", 0)
    assert done.returncode == 2
    with pytest.raises(ValueError, match="'max_capture_rows' parameter must be an int >= 1"):
        aw.monitor.MonitorConfig(max_capture_rows=0)


def test_rows_are_read_from_each_format_without_loading_it(tmp_path: Path) -> None:
    capture = aw.Capture(
        {"speed": np.arange(40.0), "position": np.arange(5.0)}, {"speed": 2000.0, "position": 250.0}
    )
    for suffix in (".parquet", ".csv", ".npz"):
        one_rate = capture.select(["speed"]) if suffix == ".npz" else capture
        path = aw.write_capture(one_rate, tmp_path / f"c{suffix}")
        assert capture_rows(path) == 40
    units = tmp_path / "units.csv"
    units.write_text("time;torque\ns;A\n0;1\n0,5;2\n1;3")  # a units row, no final line break
    assert capture_rows(units) == 4  # the units row counts: the limit is far from one row
    assert capture_rows(tmp_path / "c.feather") is None
    broken = tmp_path / "broken.parquet"
    broken.write_bytes(b"PAR1 cut short")
    assert capture_rows(broken) is None  # the reader says why, not the length check
    check_capture_length(broken, 1)
    with pytest.raises(CaptureError, match=r"^c\.csv: 40 rows, more than the 39 rows a capture"):
        check_capture_length(tmp_path / "c.csv", 39, "c.csv")


def test_a_capture_out_of_memory_is_one_rejection_and_the_rest_is_scored(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from axiswatch.indicators._axis import IndicatorBaseline

    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    score = IndicatorBaseline.score

    def short_of_memory(model: IndicatorBaseline, capture: aw.Capture, *args: Any) -> Any:
        if capture.source.endswith("axis1/2026-03-08.parquet"):
            raise MemoryError
        return score(model, capture, *args)

    monkeypatch.setattr(IndicatorBaseline, "score", short_of_memory)
    store = tmp_path / "store.db"
    for _ in range(2):
        done = run("monitor", fleet, "--store", store, "--no-progress")
        assert done.returncode == 8, done.stdout + done.stderr
        assert "Traceback" not in done.stdout + done.stderr
        assert "robot01/axis1/2026-03-08.parquet: not enough memory to read and score it" in (
            done.stdout
        )
        scored = _scored(store)
        assert ("axis1", "2026-03-09.parquet") in scored
        assert ("axis1", "2026-03-08.parquet") not in scored
