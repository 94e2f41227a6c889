"""Acknowledging alarms: the store's record, monitor's exit status, the ack command, re-baseline."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from axiswatch.cli import app
from axiswatch.exceptions import StoreError
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.html import write_report
from axiswatch.monitor.report.results import fleet_summary
from axiswatch.monitor.store import SCHEMA_VERSION, Store
from tests.conftest import settle
from tests.monitor.test_monitor import faulty_copy

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


def test_monitor_ends_with_the_verdict_of_each_axis_needing_attention(
    alarmed: tuple[Path, Path],
) -> None:
    """The run's last lines are the report's first screen: each axis needing attention with
    its verdict (state, fault, what to do, since when, how sure), then the calm ones counted."""
    fleet, store = alarmed
    again = _monitor(fleet, store)
    assert again.exit_code == 4, again.output
    tail = again.output.strip().split("\nNeeds attention (pca): 1 of 2 axes\n")[1]
    with Store(store) as opened:
        last = opened.score_table(robot="robot01", axis="axis1").iloc[-1]
    level = last.distance / last.threshold
    assert level >= 2.0  # one capture far over the alarm level: confirmed by its margin
    text = " ".join(tail.split())
    assert text.startswith("ACT NOW robot01/axis1 Signals unlike the baseline's. What to do: ")
    assert "Over the alarm level on its last capture only (2026-03-10)." in text
    shown = f"{level:.1f}" if level < 100 else f"{level:.0f}"
    assert f"How sure: {shown} times the alarm level, confirmed by a large margin." in text
    assert text.endswith("1 axis OK.")


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
    assert "  WATCH  robot01/axis1 " in seen.output  # seen: no longer act now
    assert "ana saw it on " in seen.output
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
    assert "  ACT NOW  robot01/axis1 " in raised.output
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
    shutil.copy(Path(__file__).parents[1] / "data" / "store-v2.db", path)  # one rebaseline
    with sqlite3.connect(path) as db:
        db.execute("DROP TABLE acknowledgements")
        db.execute("DELETE FROM schema_version")
        db.execute("INSERT INTO schema_version VALUES (1)")
        db.execute(
            "INSERT INTO rebaselines (robot, axis, method, retired_epoch, requested_at) "
            "VALUES ('r', 'a', 'pca', 1, 'then')"
        )
    with Store(path) as store:
        assert store.version == SCHEMA_VERSION == 3
        assert store.acknowledgements().empty
        assert len(store.rebaseline_requests()) == 2  # nothing stored is lost
    with sqlite3.connect(path) as connection:
        versions = [v for (v,) in connection.execute("SELECT version FROM schema_version")]
    assert versions == [1, 2, 3]


def test_ack_keeps_the_engineers_verdict_and_shows_it(
    alarmed: tuple[Path, Path], tmp_path: Path
) -> None:
    """`ack --false-alarm` (and its two siblings) is stored and shown by `ack --list`,
    `results`, the report and the monitor's summary; two verdicts at once are refused."""
    fleet, store = alarmed
    base = ["ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1", "--by", "ana"]
    both = runner.invoke(app, [*base, "--note", "x", "--false-alarm", "--task-changed"])
    assert both.exit_code == 2
    assert "give at most one verdict; got --false-alarm, --task-changed" in " ".join(
        both.output.replace("│", " ").split()
    )
    done = runner.invoke(app, [*base, "--note", "new gripper, heavier", "--false-alarm"])
    assert done.exit_code == 0, done.output
    assert "robot01/axis1: acknowledged (pca) by ana: false-alarm." in done.output
    listed = runner.invoke(app, ["ack", "--store", str(store), "--list"])
    assert "false-alarm" in listed.output
    shown = runner.invoke(app, ["results", "--store", str(store), "--axis", "axis1"])
    header, *rows = shown.output.splitlines()
    assert "feedback" in header.split()
    assert [r.split()[2] for r in rows if "false-alarm" in r] == ["2026-03-10.parquet"]
    seen = _monitor(fleet, store)
    assert "ana marked a false alarm on " in seen.output
    with Store(store) as opened:
        page = write_report(opened, tmp_path / "report").read_text(encoding="utf-8")
    attention = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    assert "ana marked a false alarm on " in attention
    assert "alarm acknowledged: marked a false alarm (pca)" in page  # the axis's history


def test_a_store_made_before_verdicts_gains_the_column_and_loses_nothing(
    alarmed: tuple[Path, Path],
) -> None:
    _, store = alarmed
    with Store(store) as opened:
        opened.acknowledge("robot01", "axis1", by="ana", note="seen")
    with sqlite3.connect(store) as db:
        db.execute("ALTER TABLE acknowledgements DROP COLUMN verdict")
    with Store(store, read_only=True) as old:  # read as it is, without the column
        assert old.acknowledgements()[["acknowledged_by", "verdict"]].values.tolist() == [
            ["ana", None]
        ]
        assert [a.verdict for a in old.alarms()] == [None]
    with Store(store) as opened:
        opened.acknowledge("robot01", "axis1", by="bo", note="worn", verdict="fault-confirmed")
        table = opened.acknowledgements()
    assert table.acknowledged_by.tolist() == ["ana", "bo"]
    assert table.verdict.isna().tolist() == [True, False]
    assert table.verdict.iloc[1] == "fault-confirmed"


def test_a_confirmed_fault_stays_act_now_after_clean_captures(
    alarmed: tuple[Path, Path],
) -> None:
    """A confirmed fault is not cleared by the captures after it: the axis stays "act now"
    until it is re-baselined (before: a clean capture read "1 axis OK", exit 0)."""
    fleet, store = alarmed
    args = ["ack", "--store", str(store), "--robot", "robot01", "--axis", "axis1"]
    done = runner.invoke(app, [*args, "--by", "bo", "--note", "worn", "--fault-confirmed"])
    assert done.exit_code == 0, done.output
    axis = fleet / "robot01/axis1"
    shutil.copy(axis / "2026-03-02.parquet", axis / "2026-03-11.parquet")
    settle(axis)
    clean = _monitor(fleet, store)
    assert clean.exit_code == 0, clean.output  # seen by a person: not news to exit on
    with Store(store) as opened:
        assert not opened.score_table(robot="robot01", axis="axis1").alarm.iloc[-1]
        (alarm,) = opened.alarms("pca")
    assert (alarm.raised_capture, alarm.verdict) == ("2026-03-10.parquet", "fault-confirmed")
    assert "  ACT NOW  robot01/axis1 " in clean.output
    assert "After the repair: axiswatch ack --rebaseline." in " ".join(clean.output.split())
    rebaselined = runner.invoke(
        app, [*args, "--by", "bo", "--note", "gear replaced", "--rebaseline"]
    )
    assert rebaselined.exit_code == 0, rebaselined.output
    with Store(store) as opened:
        assert opened.alarms("pca") == []
