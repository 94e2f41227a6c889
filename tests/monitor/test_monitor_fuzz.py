"""Fuzz: malformed and degenerate captures dropped into a small fleet never break the monitor.

Hypothesis writes random bad capture files (garbage bytes, truncated files, missing columns, NaN,
inf, absurd values, stuck or idle signals, backward time, another rate, text, header only) beside
the healthy captures of a tiny simulated fleet, then runs ``axiswatch monitor`` in-process. Every
file must end up scored, rejected with a reason naming it, or waiting; no exception may escape;
the store must pass SQLite's integrity check; and every healthy capture must get the distance it
gets in a clean run (the bad files never become its baseline: they are dated after it).
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch._capture
import axiswatch.datasets as awd
from axiswatch.cli import app
from tests.conftest import settle

AXIS = "robot01/axis1"
OPTIONS = ("--method", "pca", "--calibration", "2", "--settle", "0")
KINDS = (
    "garbage",
    "truncated",
    "drop column",
    "nan",
    "inf",
    "absurd",
    "stuck",
    "idle",
    "zero",
    "backward time",
    "half rate",
    "text",
    "header only",
    "healthy copy",
)


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, float]]:
    """The fleet, and the distance of each of its captures in a clean run."""
    folder = tmp_path_factory.mktemp("fuzz")
    root = folder / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=5, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / "labels.csv").unlink()
    settle(root)
    result = CliRunner().invoke(
        app, ["monitor", str(root), "--store", str(folder / "s.db"), *OPTIONS]
    )
    assert result.exit_code == 0, result.output
    return root, _distances(folder / "s.db")


def _distances(store: Path) -> dict[str, float]:
    connection = sqlite3.connect(store)
    rows = connection.execute("SELECT path, distance FROM scores WHERE role != 'baseline'")
    distances = {str(path): float(distance) for path, distance in rows}
    connection.close()
    return distances


def _write(axis: Path, name: str, kind: str, draw: st.DataObject) -> None:
    good = aw.read_capture(axis / "2026-03-03.parquet")
    frame = axiswatch._capture.capture_to_frame(good)
    path = axis / name
    signal = draw.draw(st.sampled_from(["position", "speed", "torque"]), label="signal")
    row = draw.draw(st.integers(0, len(frame) - 1), label="row")
    if kind == "garbage":
        path.write_bytes(draw.draw(st.binary(max_size=300), label="bytes"))
        return
    if kind == "truncated":
        whole = (axis / "2026-03-03.parquet").read_bytes()
        cut = draw.draw(st.integers(0, len(whole) - 1), label="cut")
        path.write_bytes(whole[:cut])
        return
    if kind == "header only":
        frame = frame.iloc[:0]
    elif kind == "drop column":
        frame = frame.drop(columns=draw.draw(st.sampled_from(list(frame.columns)), label="col"))
    elif kind in ("nan", "inf", "absurd"):
        rows = np.flatnonzero(frame[signal].notna().to_numpy())
        value = {"nan": np.nan, "inf": np.inf}.get(
            kind, draw.draw(st.sampled_from([1e300, -1e300, 1e7, -3e9]), label="value")
        )
        frame.loc[rows[row % rows.size], signal] = value
    elif kind == "stuck":
        present = frame[signal].notna()
        frame.loc[present, signal] = frame.loc[present, signal].iloc[0]
    elif kind == "idle":
        mean = frame["position"].mean()
        frame["position"] = mean + 1e-4 * (frame["position"] - mean)
    elif kind == "zero":
        frame[["position", "speed", "torque"]] = frame[["position", "speed", "torque"]].where(
            frame[["position", "speed", "torque"]].isna(), 0.0
        )
    elif kind == "backward time":
        frame.loc[max(row, 1), "time"] = frame.loc[max(row, 1) - 1, "time"]
    elif kind == "half rate":
        frame = frame.iloc[::2]
    elif kind == "text":
        frame[signal] = frame[signal].astype(str)
        frame.loc[row, signal] = "n/a"
    if path.suffix == ".csv":
        frame.to_csv(path, index=False, float_format="%.17g")
    else:
        frame.to_parquet(path, index=False)


@settings(
    max_examples=15,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_bad_captures_never_break_the_monitor(
    clean: tuple[Path, dict[str, float]],
    tmp_path_factory: pytest.TempPathFactory,
    data: st.DataObject,
) -> None:
    source, reference = clean
    folder = tmp_path_factory.mktemp("example")
    root = Path(shutil.copytree(source, folder / "fleet"))
    count = data.draw(st.integers(1, 4), label="files")
    names = []
    for index in range(count):
        kind = data.draw(st.sampled_from(KINDS), label="kind")
        day = data.draw(st.integers(1, 5), label="day")
        suffix = data.draw(st.sampled_from([".csv", ".parquet"]), label="suffix")
        name = f"2026-03-0{day}T12-00-0{index}_fuzz{suffix}"
        _write(root / AXIS, name, kind, data)
        names.append(f"{AXIS}/{name}")
    store = folder / "s.db"
    result = CliRunner().invoke(app, ["monitor", str(root), "--store", str(store), *OPTIONS])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.output
    assert result.exit_code in (0, 4, 8, 12), result.output
    assert "Traceback" not in result.output
    connection = sqlite3.connect(store)
    assert connection.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    scored = {str(p) for (p,) in connection.execute("SELECT path FROM scores")}
    rejected = dict(connection.execute("SELECT path, error FROM rejections"))
    connection.close()
    for name in names:
        assert name in scored or str(rejected.get(name, "")).startswith(name), (name, result.output)
        assert "\n" not in str(rejected.get(name, ""))
    distances = _distances(store)
    for path, distance in reference.items():
        assert distances.get(path) == pytest.approx(distance, rel=1e-12), path
