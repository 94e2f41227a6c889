"""``monitor --modes``: each axis learns its operating modes; every moving capture gets a verdict."""

from __future__ import annotations

import json
import pickle
import shutil
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch.cli import app
from axiswatch.datasets import Fault, draw_robot
from axiswatch.monitor import MonitorConfig, SQLiteStore
from axiswatch.monitor._mode_decision import AxisModes, teach_mode
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.results import fleet_results
from tests.conftest import settle

runner = CliRunner()

#: A development robot of the family: a 50 Hz wrist axis (fast to simulate and score).
ROBOT_SEED = 4
#: Task 0 up to this day, task 1 after.
CHANGE = 8
DAYS = 16
MODES = MonitorConfig(modes=True)


def _fleet(
    root: Path, days: int, *, fault_from: int | None = None, suffix: str = "", change: int = CHANGE
) -> Path:
    robot = draw_robot(ROBOT_SEED)
    folder = root / "r1" / "a0"
    folder.mkdir(parents=True, exist_ok=True)
    for day in range(days):
        task = 0 if day < change else 1
        fault = Fault("friction", 1.0) if fault_from is not None and day >= fault_from else None
        program = f"_prog{task}" if suffix else ""
        name = f"2026-03-{day + 1:02d}{program}.parquet"
        aw.write_capture(robot.capture(task, seed=day, fault=fault), folder / name)
    settle(root)
    return root


@pytest.fixture(scope="module")
def task_change(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _fleet(tmp_path_factory.mktemp("modes") / "fleet", DAYS)


def _run(root: Path, store: Path, config: MonitorConfig = MODES) -> aw.monitor.MonitorSummary:
    with SQLiteStore(store) as opened:
        return monitor_fleet(root, opened, config)


def _results(store: Path) -> list[dict[str, object]]:
    with SQLiteStore(store, read_only=True) as opened:
        frame = fleet_results(opened)
    return frame[frame.role != "baseline"].to_dict("records")


def _verdicts(store: Path) -> list[dict[str, object]]:
    columns = ["capture", "distance", "over", "alarm", "reason", "mode"]
    return [{k: row[k] for k in columns} for row in _results(store)]


def test_every_capture_after_a_task_change_gets_a_verdict(
    task_change: Path, tmp_path: Path
) -> None:
    store = tmp_path / "s.db"
    summary = _run(task_change, store)
    assert summary.rejected == []
    rows = _results(store)
    # Every capture after the baseline is scored: none is left "not compared".
    assert len(rows) == DAYS - 1
    modes = [row["mode"] for row in rows]
    assert modes[:5] == [f"mode0 (learning {k} of 5)" for k in range(1, 6)]
    assert modes[5 : CHANGE - 1] == ["mode0"] * (CHANGE - 6)
    # The new task is a new mode, learned while a guard watches; no alarm for the change.
    assert modes[CHANGE - 1] == "mode1 (learning 1 of 5)"
    assert not any(row["alarm"] for row in rows[CHANGE - 1 : CHANGE + 4])
    assert all(row["threshold"] == 1.0 for row in rows)
    reason = str(rows[CHANGE - 1]["reason"])
    assert reason.startswith("mode mode1: learning new mode (1 of 5)")


def test_the_summary_says_an_axis_is_learning_a_new_mode(task_change: Path, tmp_path: Path) -> None:
    partial = tmp_path / "fleet"
    shutil.copytree(task_change, partial)
    for day in range(CHANGE + 2, DAYS):  # stop two captures into the new task
        (partial / "r1" / "a0" / f"2026-03-{day + 1:02d}.parquet").unlink()
    shown = runner.invoke(
        app, ["monitor", str(partial), "--store", str(tmp_path / "s.db"), "--modes"]
    )
    assert shown.exit_code == 0, shown.output
    assert "1 axis learning." in shown.output
    assert "r1/a0: Learning new mode mode1 (2 of 5 captures), no guard yet." in shown.output


def test_split_runs_reach_the_results_of_one_run(task_change: Path, tmp_path: Path) -> None:
    whole = tmp_path / "whole.db"
    _run(task_change, whole)
    split = tmp_path / "split"
    shutil.copytree(task_change, split)
    later = sorted((split / "r1" / "a0").glob("*.parquet"))[CHANGE + 2 :]
    held = tmp_path / "held"
    held.mkdir()
    for path in later:
        path.rename(held / path.name)
    store = tmp_path / "split.db"
    _run(split, store)
    for path in held.iterdir():
        path.rename(split / "r1" / "a0" / path.name)
    settle(split)
    _run(split, store)
    assert _verdicts(store) == _verdicts(whole)


def _alarmed(tmp_path: Path) -> tuple[Path, Any, AxisModes]:
    """A store whose one axis is in alarm (a fault in its known mode), the alarm, the library."""
    root = _fleet(tmp_path / "fleet", CHANGE + 3, fault_from=CHANGE, change=CHANGE + 3)
    store = tmp_path / "s.db"
    _run(root, store)
    with SQLiteStore(store, read_only=True) as opened:
        (alarm,) = opened.alarms()
    return store, alarm, _library(store, alarm.baseline_id)


def _library(store: Path, baseline_id: int) -> AxisModes:
    with SQLiteStore(store, read_only=True) as opened:
        modes: AxisModes = pickle.loads(opened.mode_library(baseline_id) or b"")
    return modes


def _ack(store: Path, verdict: str) -> Any:
    return runner.invoke(
        app,
        ["ack", "--store", str(store), "--robot", "r1", "--axis", "a0", "--by", "ana",
         "--note", "seen", f"--{verdict}"],
    )  # fmt: skip


def test_a_fault_in_a_known_mode_alarms_and_ack_task_changed_teaches_it(tmp_path: Path) -> None:
    store, alarm, before = _alarmed(tmp_path)
    assert alarm.raised_capture == f"2026-03-{CHANGE + 1:02d}.parquet"
    assert alarm.raised_capture in before.alarmed
    members = len(before.library.modes_["mode0"].members)
    said = _ack(store, "task-changed")
    assert said.exit_code == 0, said.output
    # The alarm was in a known mode, so what the engineer calls a change is another mode.
    assert f"{alarm.raised_capture}: learned as healthy, mode mode1." in said.output
    after = _library(store, alarm.baseline_id)
    assert len(after.library.modes_["mode0"].members) == members
    assert len(after.library.modes_["mode1"].members) == len(before.alarmed) >= 1
    assert after.alarmed == {}
    # Taught once: the same captures are not taught twice.
    assert teach_mode(SQLiteStore(store), alarm.baseline_id, alarm.raised_capture) == {}


def test_ack_false_alarm_teaches_the_alarm_to_its_own_mode(tmp_path: Path) -> None:
    store, alarm, before = _alarmed(tmp_path)
    members = len(before.library.modes_["mode0"].members)
    said = _ack(store, "false-alarm")
    assert said.exit_code == 0, said.output
    assert f"{alarm.raised_capture}: learned as healthy, mode mode0." in said.output
    after = _library(store, alarm.baseline_id)
    assert len(after.library.modes_["mode0"].members) == members + len(before.alarmed)
    assert sorted(after.library.modes_) == sorted(before.library.modes_)
    assert after.alarmed == {}


def test_a_declared_mode_names_the_mode(tmp_path: Path) -> None:
    root = _fleet(tmp_path / "fleet", CHANGE + 2, suffix="prog")
    (root / "axiswatch.toml").write_text(
        '[mode]\nfile_pattern = "_prog(?P<program>\\\\d+)"\n', encoding="utf-8"
    )
    settle(root)
    store = tmp_path / "s.db"
    _run(root, store)
    modes = [row["mode"] for row in _results(store)]
    assert modes[0] == "0 (learning 1 of 5)"
    assert modes[CHANGE - 1] == "1 (learning 1 of 5)"
    details = json.loads(str(_results(store)[-1]["details"]))
    assert details["mode"] == "1"


def test_a_declared_mode_that_is_not_found_is_a_one_line_rejection(tmp_path: Path) -> None:
    root = _fleet(tmp_path / "fleet", 7)
    (root / "axiswatch.toml").write_text('[mode]\nmetadata = "program"\n', encoding="utf-8")
    settle(root)
    summary = _run(root, tmp_path / "s.db")
    assert summary.rejected, "a capture without its declared mode is rejected, not scored"
    assert all("the mode's metadata key 'program' is missing" in line for line in summary.rejected)


def test_modes_need_the_indicators_method() -> None:
    with pytest.raises(ValueError, match="'modes' parameter is for the method 'indicators'"):
        MonitorConfig(method="pca", modes=True)


def test_modes_are_a_stored_parameter() -> None:
    # A store's baselines fitted without modes are refitted, not mixed with moded ones.
    assert MonitorConfig(modes=True).params() == {**MonitorConfig().params(), "modes": True}


def test_a_still_capture_is_not_scored(tmp_path: Path) -> None:
    root = _fleet(tmp_path / "fleet", 7)
    capture = draw_robot(ROBOT_SEED).capture(0, seed=9)
    still = {name: np.zeros_like(v) for name, v in capture.signals.items()}
    still["position"] = np.full_like(capture.signals["position"], 0.3)
    still["torque"] = 0.5 + 0.01 * np.random.default_rng(0).normal(size=still["torque"].size)
    aw.write_capture(aw.Capture(still, capture.rates_hz), root / "r1" / "a0" / "2026-03-09.parquet")
    settle(root)
    summary = _run(root, tmp_path / "s.db")
    assert any("2026-03-09.parquet" in line for line in summary.rejected)


def test_the_report_shows_a_new_mode_in_the_axis_history(task_change: Path, tmp_path: Path) -> None:
    from axiswatch.monitor.report.html import write_report

    store = tmp_path / "s.db"
    _run(task_change, store)
    with SQLiteStore(store, read_only=True) as opened:
        html = write_report(opened, tmp_path / "report").read_text(encoding="utf-8")
    assert "new operating mode mode1" in html
    assert "learned from its first 5 captures, under a guard" in html


def test_two_workers_reach_the_results_of_one(task_change: Path, tmp_path: Path) -> None:
    # The libraries learn in the driver, in each axis's capture order, whatever the workers.
    serial, pooled = tmp_path / "serial.db", tmp_path / "pooled.db"
    _run(task_change, serial)
    with SQLiteStore(pooled) as opened:
        monitor_fleet(task_change, opened, MODES, workers=2)
    assert _verdicts(pooled) == _verdicts(serial)


def test_an_unreadable_stored_library_is_learned_again_not_a_traceback(tmp_path: Path) -> None:
    store, _, _ = _alarmed(tmp_path)
    fleet = tmp_path / "fleet"
    with sqlite3.connect(store) as con:
        con.execute("UPDATE mode_libraries SET library = X'00112233'")
    ack = _ack(store, "task-changed")
    assert ack.exit_code == 0, ack.output
    assert "acknowledged" in ack.output
    assert "learned as healthy" not in ack.output
    capture = draw_robot(ROBOT_SEED).capture(0, seed=99)
    aw.write_capture(capture, fleet / "r1" / "a0" / "2026-03-30.parquet")
    settle(fleet)
    shown = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--modes"])
    assert shown.exit_code in (0, 4), shown.output
    last = _results(store)[-1]
    assert str(last["reason"]).startswith(
        "the stored mode library could not be read (UnpicklingError: invalid load key"
    )
    assert str(last["mode"]) == "mode0 (learning 1 of 5)"
