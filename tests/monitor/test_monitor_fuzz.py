"""Fuzz: hostile capture files dropped into a small fleet never break the monitor.

Hypothesis writes capture files beside the healthy captures of a tiny simulated fleet of two
axes (garbage bytes, cut files, missing columns, NaN, inf, absurd values, stuck or idle signals,
backward time, another rate, text, header only, glitches, a torque in another unit, Windows
and UTF-16 text, a few samples, a capture several times as long), then runs ``axiswatch
monitor`` in-process: on a new store (the files among the baseline and its calibration) or on
the clean run's store (the files after it). Every file must end up scored, rejected with a
reason naming it, or waiting; no exception may escape; the store must pass SQLite's integrity
check; nothing the clean run stored may be lost or changed; every healthy capture, of either
axis, must get the distance it gets in a clean run; and bad data is never over the threshold.
All of it with ``--method pca`` and with ``--modes`` (there, a mode library learns from every
capture, so the other files' distances are not compared).

``make fuzz`` runs many more examples (``AXISWATCH_FUZZ_EXAMPLES``); the seed is fixed.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
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
OTHER = "robot01/axis2"
OPTIONS = ("--method", "pca", "--calibration", "2", "--settle", "0")
#: The default with its mode libraries: every capture a verdict, learned from as it comes.
MODES = ("--modes", "--calibration", "3", "--settle", "0")
EXAMPLES = int(os.environ.get("AXISWATCH_FUZZ_EXAMPLES", "30"))
#: Healthy data in another form: scored (on a baseline's axis) whatever else happens.
READABLE = ("healthy copy", "windows text", "utf-16 text")
#: Data no mechanics can make: a data-quality verdict, or a score under the threshold.
BAD_DATA = ("nan", "inf", "absurd", "stuck", "idle", "zero", "glitch", "unit")
KINDS = (
    "garbage",
    "truncated",
    "csv cut",
    "drop column",
    "backward time",
    "half rate",
    "text",
    "header only",
    "few samples",
    "long",
    *READABLE,
    *BAD_DATA,
)
SIGNALS = ("position", "speed", "torque")
#: What a run stores about a score; none of it may change in a later run.
STORED = "SELECT path, role, distance, threshold, over, alarm, baseline_id FROM scores"


@pytest.fixture(scope="module", params=[OPTIONS, MODES], ids=["pca", "modes"])
def clean(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, Path, dict[str, float], tuple[str, ...]]:
    """The fleet, the store of a clean run, the distance of each capture in it, the options."""
    options: tuple[str, ...] = request.param
    folder = tmp_path_factory.mktemp("fuzz")
    root = folder / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=2, n_days=5, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / "labels.csv").unlink()
    settle(root)
    result = CliRunner().invoke(
        app, ["monitor", str(root), "--store", str(folder / "s.db"), *options]
    )
    assert result.exit_code == 0, result.output
    return root, folder / "s.db", _distances(folder / "s.db"), options


def _rows(store: Path, sql: str) -> list[tuple[object, ...]]:
    connection = sqlite3.connect(store)
    try:
        return list(connection.execute(sql))
    finally:
        connection.close()


def _distances(store: Path) -> dict[str, float]:
    rows = _rows(store, "SELECT path, distance FROM scores WHERE role != 'baseline'")
    return {str(path): float(distance) for path, distance in rows}  # type: ignore[arg-type]


def _windows(frame: pd.DataFrame, path: Path, encoding: str) -> None:
    """A German controller's export: ';' and decimal commas, a header with 'ü' and '°C'."""
    table = frame.assign(**{"Temperatur Gehäuse [°C]": 40.5})
    text = table.to_csv(index=False, sep=";", decimal=",", float_format="%.17g")
    path.write_bytes(text.replace("\n", "\r\n").encode(encoding))


def _write(axis: Path, name: str, kind: str, draw: st.DataObject) -> None:
    good = aw.read_capture(axis / "2026-03-03.parquet")
    frame = axiswatch._capture.capture_to_frame(good)
    path = axis / name
    signal = draw.draw(st.sampled_from(SIGNALS), label="signal")
    row = draw.draw(st.integers(0, len(frame) - 1), label="row")
    present = np.flatnonzero(frame[signal].notna().to_numpy())
    at = present[row % present.size]  # a row where the signal has a sample
    if kind == "garbage":
        path.write_bytes(draw.draw(st.binary(max_size=300), label="bytes"))
        return
    if kind == "truncated":
        whole = (axis / "2026-03-03.parquet").read_bytes()
        cut = draw.draw(st.integers(0, len(whole) - 1), label="cut")
        path.write_bytes(whole[:cut])
        return
    if kind == "csv cut":
        whole = frame.to_csv(index=False, float_format="%.17g").encode()
        path.write_bytes(whole[: draw.draw(st.integers(0, len(whole) - 1), label="cut")])
        return
    if kind in ("windows text", "utf-16 text"):
        _windows(frame, path.with_suffix(".csv"), "cp1252" if kind[0] == "w" else "utf-16")
        return
    if kind == "header only":
        frame = frame.iloc[:0]
    elif kind == "few samples":
        frame = frame.iloc[: draw.draw(st.sampled_from([1, 2, 3, 9, 40]), label="rows")]
    elif kind == "long":
        copies = draw.draw(st.integers(2, 8), label="copies")
        step = float(frame["time"].iloc[1] - frame["time"].iloc[0])
        span = float(frame["time"].iloc[-1] - frame["time"].iloc[0]) + step
        frame = pd.concat(
            [frame.assign(time=frame["time"] + k * span) for k in range(copies)], ignore_index=True
        )
    elif kind == "drop column":
        frame = frame.drop(columns=draw.draw(st.sampled_from(list(frame.columns)), label="col"))
    elif kind in ("nan", "inf", "absurd"):
        value = {"nan": np.nan, "inf": np.inf}.get(
            kind, draw.draw(st.sampled_from([1e300, -1e300, 1e7, -3e9]), label="value")
        )
        frame.loc[at, signal] = value
    elif kind == "glitch":  # a sample far outside its neighbours (monitor._quality's rule)
        values = frame[signal].dropna()
        spread = float(np.percentile(values, 99) - np.percentile(values, 1))
        jump = draw.draw(st.sampled_from([-300.0, -2.5, 2.5, 30.0]), label="ranges")
        frame.loc[at, signal] = float(values.max() if jump > 0 else values.min()) + jump * spread
    elif kind == "unit":  # N m to mN m or N cm, rad/s to deg/s, and back
        name = draw.draw(st.sampled_from(["torque", "speed"]), label="unit of")
        factor = draw.draw(st.sampled_from([1e3, 1e-3, 100.0, 0.01, 57.3, 1 / 57.3]), label="by")
        frame[name] = frame[name] * factor
    elif kind == "stuck":
        frame.loc[present, signal] = frame.loc[present, signal].iloc[0]
    elif kind == "idle":
        mean = frame["position"].mean()
        frame["position"] = mean + 1e-4 * (frame["position"] - mean)
    elif kind == "zero":
        frame[list(SIGNALS)] = frame[list(SIGNALS)].where(frame[list(SIGNALS)].isna(), 0.0)
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
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_hostile_captures_never_break_the_monitor(
    clean: tuple[Path, Path, dict[str, float], tuple[str, ...]],
    tmp_path_factory: pytest.TempPathFactory,
    data: st.DataObject,
) -> None:
    source, clean_store, reference, options = clean
    folder = tmp_path_factory.mktemp("example")
    root = Path(shutil.copytree(source, folder / "fleet"))
    store = folder / "s.db"
    # After the clean run (on its store: the files are scored against its baselines), or in a
    # fresh run (the files among the baseline and the calibration captures).
    later = data.draw(st.booleans(), label="after the clean run")
    if later:
        shutil.copy2(clean_store, store)
        # The other axis's new capture, to be scored in the same run as the hostile files.
        shutil.copy2(root / OTHER / "2026-03-03.parquet", root / OTHER / "2026-03-06.parquet")
    count = data.draw(st.integers(1, 4), label="files")
    files: dict[str, str] = {}
    for index in range(count):
        kind = data.draw(st.sampled_from(KINDS), label="kind")
        day = data.draw(st.integers(6, 9) if later else st.integers(1, 5), label="day")
        suffix = data.draw(st.sampled_from([".csv", ".parquet"]), label="suffix")
        if kind in ("windows text", "utf-16 text"):
            suffix = ".csv"
        name = f"2026-03-0{day}T12-00-0{index}_fuzz{suffix}"
        _write(root / AXIS, name, kind, data)
        files[f"{AXIS}/{name}"] = kind
    result = CliRunner().invoke(app, ["monitor", str(root), "--store", str(store), *options])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.output
    assert result.exit_code in (0, 4, 8, 12), result.output
    assert "Traceback" not in result.output
    assert _rows(store, "PRAGMA integrity_check") == [("ok",)]
    scored = {str(p) for (p,) in _rows(store, "SELECT path FROM scores")}
    over = {str(p) for (p,) in _rows(store, "SELECT path FROM scores WHERE over=1 OR alarm=1")}
    rejected = {str(p): str(e) for p, e in _rows(store, "SELECT path, error FROM rejections")}
    for name, kind in files.items():
        assert name in scored or rejected.get(name, "").startswith(name), (kind, result.output)
        assert "\n" not in rejected.get(name, "")
        if kind in READABLE:
            assert name in scored, (kind, rejected.get(name))
        if kind in BAD_DATA:
            assert name not in over, (kind, result.output)
    if later:
        assert set(_rows(clean_store, STORED)) <= set(_rows(store, STORED))
        assert f"{OTHER}/2026-03-06.parquet" in scored, result.output
    if options == MODES:
        return  # a mode library learns from each capture: a file among the first moves the rest
    distances = _distances(store)
    for path, distance in reference.items():
        assert distances.get(path) == pytest.approx(distance, rel=1e-12), path
