"""The former default ``mechanics`` through the monitor: registered by the lab's entry point,
it alarms on a developing fault, explains its distance, and refuses what it cannot read."""

from __future__ import annotations

import json
import os
import re
import shutil
import sqlite3
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch.datasets as awd
from axiswatch.cli import app
from axiswatch.monitor import (
    MonitorConfig,
    SQLiteStore,
    fleet_results,
    methods,
    monitor_fleet,
)
from axiswatch_lab._mechanics import COLUMNS, MECHANICS_TASK_CHANGE_SCALE, MechanicsStage
from axiswatch_lab._product import QualityReference, data_quality_problem
from lab_data import SHARED_DATA

runner = CliRunner()


def settle(root: Path, age_s: float = 3600.0) -> None:
    """Date every capture file below ``root`` back: delivered and settled long ago."""
    then = time.time() - age_s
    for path in root.rglob("*"):
        if path.is_file():
            os.utime(path, (then, then))


@pytest.fixture(scope="module")
def short_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A healthy simulated fleet, 1 robot x 2 axes x 9 days of 0.5 s captures (copy before use)."""
    root = tmp_path_factory.mktemp("fleet") / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=2, n_days=9, task_change_days=(), faults=[], duration_s=0.5
    )
    settle(root)
    return root


@pytest.fixture
def fleet(short_fleet: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(short_fleet, tmp_path / "fleet"))


def store_params(path: Path) -> str:
    with sqlite3.connect(path) as connection:
        (text,) = connection.execute("SELECT params FROM baselines LIMIT 1").fetchone()
    return str(text)


def test_the_entry_point_registers_the_method() -> None:
    preset = methods()["mechanics"]
    assert preset.task_change_scale == MECHANICS_TASK_CHANGE_SCALE
    assert isinstance(MonitorConfig(method="mechanics").model().stage, MechanicsStage)


def test_mechanics_method_alarms_on_the_developing_fault_only(tmp_path: Path) -> None:
    # The former default: friction develops on axis2 from day 8 (severity
    # 0.2 on day 8, 1.0 on day 12); axis1 stays healthy. Captures of 3 s (a task cycle at least).
    root = tmp_path / "fleet"
    awd.simulate_fleet(
        root,
        n_robots=1,
        n_axes=2,
        n_days=12,
        task_change_days=(),
        faults=[awd.FleetFault("robot01", "axis2", "friction", onset_day=8)],
    )
    settle(root)
    with aw.Store(tmp_path / "s.db") as store:
        monitor_fleet(root, store, MonitorConfig(method="mechanics"))
        results = fleet_results(store)
    alarms = results[results.alarm].groupby("axis").capture.apply(list).to_dict()
    assert "axis1" not in alarms
    assert alarms["axis2"][-1] == "2026-03-12.parquet"
    assert min(alarms["axis2"]) >= "2026-03-08"  # no alarm before the fault
    params = json.loads(store_params(tmp_path / "s.db"))
    assert params["stage"]["name"] == "MechanicsStage"
    assert params["align_phase"] is False
    # Same-task calibration gives a threshold below what healthy task changes need: the floor.
    floor = MonitorConfig(method="mechanics").threshold_floor()
    assert floor == pytest.approx(MECHANICS_TASK_CHANGE_SCALE * np.log(100))
    assert (results.threshold.dropna() >= floor).all()
    # Every monitored capture carries its explanation; every reason names where its threshold
    # comes from (the floor, when the fit is lower) and, over it, the top indicator.
    with aw.Store(tmp_path / "s.db") as store:
        fits = {}
        for robot, axis in set(zip(results.robot, results.axis, strict=True)):
            latest = store.latest_baseline(robot, axis, "mechanics")
            assert latest is not None
            assert latest.fit is not None
            fits[robot + axis] = latest.fit
    monitored = results[results.role == "monitor"]
    for row in monitored.itertuples():
        details = json.loads(row.details)
        shares = [entry["share"] for entry in details["indicators"].values()]
        assert set(details["indicators"]) == set(COLUMNS)
        assert sum(shares) == pytest.approx(1.0 if row.distance > 0 else 0.0, abs=1e-9)
        fitted = fits[row.robot + row.axis].threshold(99.0)
        origin = "task-change allowance" if row.threshold > fitted else "99th pct of half"
        assert f"threshold {row.threshold:.4g} ({origin}" in row.reason, row.reason
        assert ("; top indicator " in row.reason) == bool(row.over or row.alarm), row.reason
    raised = monitored[monitored.alarm]
    assert "; top indicator viscous_friction +" in raised.reason.iloc[-1]
    assert "likely friction" in raised.reason.iloc[-1]
    assert raised.top_indicator.str.startswith("viscous_friction +").all()
    assert results.top_indicator[~(results.over | results.alarm)].isna().all()
    shown = CliRunner().invoke(
        app, ["results", "--store", str(tmp_path / "s.db"), "--axis", "axis2", "--indicators"]
    )
    header = shown.output.splitlines()[0].split()
    assert header[-7:] == ["top_indicator", *COLUMNS], header
    assert "2026-03-12.parquet mechanics" in shown.output


def test_mechanics_rejects_captures_too_short_for_a_baseline(fleet: Path, tmp_path: Path) -> None:
    # The fixture's captures last 0.5 s, less than a task cycle: the mechanics indicators cannot
    # read a move in both directions, so every baseline candidate is rejected with the reason.
    result = runner.invoke(
        app, ["monitor", str(fleet), "--store", str(tmp_path / "s.db"), "--method", "mechanics"]
    )
    assert result.exit_code == 8, result.output
    assert "No axis has a baseline yet." in result.output
    assert re.search(
        r"2026-03-01\.parquet( \(and \d+ more capture files with this reason\))?: the baseline "
        "must show a usable move in both directions",
        result.output,
    ), result.output


def test_a_configuration_error_stops_the_run_and_rejects_nothing(
    fleet: Path, tmp_path: Path
) -> None:
    # Before, jobs caught any ValueError: this error was stored as a rejection of every file.
    config = MonitorConfig(method="mechanics", stage=MechanicsStage(band_hz=(300.0, 40.0)))
    with aw.Store(tmp_path / "s.db") as store:
        with pytest.raises(ValueError, match=r"'band_hz' parameter of MechanicsStage must"):
            monitor_fleet(fleet, store, config)
        assert store.rejection_table().empty


def test_a_capture_too_slow_for_the_band_is_rejected_not_a_crash(
    fleet: Path, tmp_path: Path
) -> None:
    # At 250 Hz, with the speed derived from the position, the band (40-300 Hz) cannot be read:
    # one rejection per capture, and the run ends normally.
    for path in fleet.glob("*/*/*.parquet"):
        capture = aw.read_capture(path)
        slow = aw.Capture(
            {"position": capture.signals["position"], "torque": capture.signals["torque"][::8]},
            {"position": 250.0, "torque": 250.0},
        )
        aw.write_capture(slow, path)
    settle(fleet)
    args = ["monitor", str(fleet), "--store", str(tmp_path / "s.db"), "--method", "mechanics"]
    result = runner.invoke(app, args)
    assert result.exit_code == 8, result.output
    assert "Traceback" not in result.output
    assert "the 'band_hz' of MechanicsStage, (40.0, 300.0), needs a rate above 600 Hz" in (
        result.output
    )


# --- real data through the lab's readers (skipped when ../shared/data is absent) ---------------


def _real(name: str) -> Path:
    folder = SHARED_DATA / name
    if not folder.is_dir():
        pytest.skip(f"{folder} is absent")
    return folder


def _store(tmp_path: Path, name: str = "s") -> SQLiteStore:
    return SQLiteStore(tmp_path / f"{name}.sqlite")


def _write(capture: aw.Capture, root: Path, robot: str, axis: str, day: int) -> Path:
    folder = root / robot / axis
    folder.mkdir(parents=True, exist_ok=True)
    return aw.write_capture(capture, folder / f"2026-03-{day + 1:02d}.parquet")


def _readable(root: Path) -> int:
    """Captures after each axis's baseline that pass the monitor's data-quality rules."""
    count = 0
    for axis in {p.parent for p in root.rglob("*.parquet")}:
        captures = [aw.read_capture(f) for f in sorted(axis.glob("*.parquet"))]
        first = next(k for k, c in enumerate(captures) if data_quality_problem(c) is None)
        reference = QualityReference.of(captures[first])
        count += sum(data_quality_problem(c, reference) is None for c in captures[first + 1 :])
    return count


def test_real_hydraulic_actuators_are_scored(tmp_path: Path) -> None:
    from axiswatch_lab._transfer import hydraulic_captures

    index = pd.read_csv(_real("hydraulic_actuator") / "index.csv")
    starts = dict(zip(index["recording_id"], index["record_start"], strict=True))
    root = tmp_path / "fleet"
    kept: dict[str, int] = {}
    for actuator, _, capture in hydraulic_captures(SHARED_DATA / "hydraulic_actuator"):
        if kept.get(actuator, 0) >= 8:
            continue
        kept[actuator] = kept.get(actuator, 0) + 1
        folder = root / "hydraulic" / actuator
        folder.mkdir(parents=True, exist_ok=True)
        stamp = str(starts[capture.source]).replace(":", "-")
        aw.write_capture(capture, folder / f"{stamp}.parquet")
    settle(root)
    summary = monitor_fleet(root, _store(tmp_path), MonitorConfig(method="indicators"), settle_s=0)
    assert summary.new_baselines == len(kept)
    assert summary.scored == _readable(root) > 0
    assert all("bad data" in line for line in summary.rejected)
    mechanics = monitor_fleet(
        root, _store(tmp_path, "m"), MonitorConfig(method="mechanics"), settle_s=0
    )
    assert mechanics.scored == 0
    assert len(mechanics.rejected) == sum(kept.values())


def test_real_linear_axis_is_scored(tmp_path: Path) -> None:
    from axiswatch_lab._transfer import linear_axis_captures

    windows = linear_axis_captures(_real("genesis_linear_axis"))
    root = tmp_path / "fleet"
    for session in ("normal", "session2016_jam_labels"):
        for day, capture in enumerate(windows[session][:10]):
            _write(capture, root, "linear", session.split("_")[0], day)
    settle(root)
    summary = monitor_fleet(root, _store(tmp_path), MonitorConfig(method="indicators"), settle_s=0)
    assert summary.new_baselines == 2
    assert summary.scored == _readable(root) > 0
    assert all("bad data" in line for line in summary.rejected)
