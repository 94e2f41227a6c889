"""Acknowledging alarms: the store's record, monitor's exit status, the ack command, re-baseline."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from axiswatch.cli import app
from axiswatch.exceptions import StoreError
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor._results import fleet_summary
from axiswatch.monitor._scoring import MonitorConfig
from axiswatch.monitor.store import SCHEMA_VERSION, Store
from tests.test_monitor import faulty_copy

runner = CliRunner()
PCA = MonitorConfig(method="pca")


@pytest.fixture
def alarmed(small_fleet: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A fleet whose robot01/axis1 is in alarm (pca) after its last capture, and its store."""
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    axis = fleet / "robot01/axis1"
    faulty_copy(axis / "2026-03-09.parquet", axis / "2026-03-10.parquet")
    store = tmp_path / "s.db"
    with Store(store) as opened:
        assert monitor_fleet(fleet, opened, PCA).exit_code == 4
    return fleet, store


def _monitor(fleet: Path, store: Path) -> object:
    return runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])


def test_monitor_says_why_each_axis_is_in_alarm(alarmed: tuple[Path, Path]) -> None:
    """The run's last lines name each axis in alarm with the report's reason (what the
    distance and threshold are), not only the axis."""
    fleet, store = alarmed
    again = _monitor(fleet, store)
    assert again.exit_code == 4, again.output
    tail = again.output.strip().splitlines()[-2:]
    assert tail[0] == "ALARM (pca) on robot01/axis1"
    assert tail[1].startswith("  robot01/axis1: ALARM since 2026-03-10 (1 capture in alarm): ")
    with Store(store) as opened:
        last = opened.score_table(robot="robot01", axis="axis1").iloc[-1]
    assert f"Distance {last.distance:.4g} > threshold {last.threshold:.4g} (99th pct" in tail[1]


def test_an_acknowledged_alarm_does_not_exit_4_until_it_is_raised_again(
    alarmed: tuple[Path, Path],
) -> None:
    fleet, store = alarmed
    args = ["ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1"]
    done = runner.invoke(app, [*args, "--by", "ana", "--note", "bearing noise heard; part ordered"])
    assert done.exit_code == 0, done.output
    assert "robot01/axis1: acknowledged (pca) by ana." in done.output
    seen = _monitor(fleet, store)
    assert seen.exit_code == 0, seen.output
    assert "robot01/axis1 since 2026-03-10.parquet: seen by ana at " in seen.output
    assert "ALARM (pca)" not in seen.output
    with Store(store) as opened:
        row = fleet_summary(opened).query("axis == 'axis1'").iloc[0]
    assert (row.state, row.alarm_since, row.acknowledged_by) == (
        "ALARM",
        "2026-03-10.parquet",
        "ana",
    )

    # A clean capture clears the alarm, a faulty one raises it anew: nobody has seen that one.
    axis = fleet / "robot01/axis1"
    shutil.copy(axis / "2026-03-02.parquet", axis / "2026-03-11.parquet")
    faulty_copy(axis / "2026-03-09.parquet", axis / "2026-03-12.parquet")
    raised = _monitor(fleet, store)
    assert raised.exit_code == 4, raised.output
    assert "ALARM (pca) on robot01/axis1" in raised.output
    with Store(store) as opened:
        (alarm,) = opened.alarms("pca")
        listed = opened.acknowledgements()
    assert (alarm.raised_capture, alarm.acknowledged) == ("2026-03-12.parquet", False)
    assert listed[["robot", "axis", "method", "capture", "acknowledged_by"]].values.tolist() == [
        ["robot01", "axis1", "pca", "2026-03-10.parquet", "ana"]
    ]
    shown = runner.invoke(app, ["ack", "--store", str(store), "--list"])
    assert "bearing noise heard; part ordered" in shown.output


def test_acknowledge_refuses_what_it_cannot_record(alarmed: tuple[Path, Path]) -> None:
    _, store = alarmed
    with Store(store) as opened:
        with pytest.raises(StoreError, match=r"robot 'robot01' axis 'axis2' is not in alarm: "):
            opened.acknowledge("robot01", "axis2", by="ana", note="x")
        with pytest.raises(StoreError, match=r"axis 'axis9' has no active baseline"):
            opened.acknowledge("robot01", "axis9", by="ana", note="x")
        with pytest.raises(StoreError, match=r"method 'lra' has no active baseline"):
            opened.acknowledge("robot01", "axis1", by="ana", note="x", method="lra")
        with pytest.raises(ValueError, match=r"The 'by' parameter must not be empty"):
            opened.acknowledge("robot01", "axis1", by=" ", note="x")
        with pytest.raises(ValueError, match=r"The 'note' parameter must not be empty"):
            opened.acknowledge("robot01", "axis1", by="ana", note="")
        assert opened.acknowledgements().empty
    base = ["ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1"]
    missing = runner.invoke(app, [*base, "--note", "x"])
    assert missing.exit_code == 2
    assert "'--by'" in missing.output
    stray = runner.invoke(app, [*base, "--by", "a", "--note", "x", "--from", "2026-03-02.parquet"])
    assert stray.exit_code == 2
    assert "only with --rebaseline" in " ".join(stray.output.replace("│", " ").split())
    failed = runner.invoke(
        app, [*base[:4], "robot01", "--axis", "axis2", "--by", "a", "--note", "x"]
    )
    assert failed.exit_code == 1
    assert "is not in alarm" in failed.output


def test_ack_rebaseline_after_maintenance(alarmed: tuple[Path, Path]) -> None:
    fleet, store = alarmed
    done = runner.invoke(
        app,
        [
            "ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1", "--by", "ben",
            "--note", "gearbox replaced", "--rebaseline", "--from", "2026-03-10.parquet",
        ],
    )  # fmt: skip
    assert done.exit_code == 1  # the alarmed capture cannot be the new baseline: nothing recorded
    assert "raised an alarm" in done.output
    done = runner.invoke(
        app,
        [
            "ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1", "--by", "ben",
            "--note", "gearbox replaced", "--rebaseline",
        ],
    )  # fmt: skip
    assert done.exit_code == 0, done.output
    assert "the next monitor run starts a new baseline at the next capture" in done.output
    with Store(store) as opened:
        listed = opened.acknowledgements()
        retired = opened.rebaseline_requests()
    assert listed[["capture", "rebaseline", "note"]].values.tolist() == [
        ["2026-03-10.parquet", True, "gearbox replaced"]
    ]
    assert retired[["robot", "axis", "method", "retired_epoch"]].values.tolist() == [
        ["robot01", "axis1", "pca", 1]
    ]
    assert _monitor(fleet, store).exit_code == 0  # no axis in alarm; axis1 waits for captures


def test_a_version_1_store_gains_the_acknowledgements_table(tmp_path: Path) -> None:
    path = tmp_path / "old.db"
    Store(path).close()
    with sqlite3.connect(path) as db:
        db.execute("DROP TABLE acknowledgements")
        db.execute("DELETE FROM schema_version")
        db.execute("INSERT INTO schema_version VALUES (1)")
        db.execute(
            "INSERT INTO rebaselines (robot, axis, method, retired_epoch, requested_at) "
            "VALUES ('r', 'a', 'pca', 1, 'then')"
        )
    with Store(path) as store:
        assert store.version == SCHEMA_VERSION == 2
        assert store.acknowledgements().empty
        assert len(store.rebaseline_requests()) == 1  # nothing stored is lost
    with sqlite3.connect(path) as connection:
        versions = [v for (v,) in connection.execute("SELECT version FROM schema_version")]
    assert versions == [1, 2]
