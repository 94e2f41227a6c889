"""A first run over a backlog of captures: what it raised and cleared is said."""

from __future__ import annotations

from pathlib import Path

import axiswatch as aw
from axiswatch import write_capture
from axiswatch.datasets import Fault, simulate_capture
from axiswatch.monitor.report.verdict import fleet_verdicts
from tests._cli import run


def test_an_alarm_raised_and_cleared_in_one_run_is_named(tmp_path: Path) -> None:
    # A healthy baseline and calibration, three worn captures, then two healthy again: the
    # state after the run is "ok" and the exit status 0, so only this line says it happened.
    axis = tmp_path / "fleet" / "cell1" / "J2"
    axis.mkdir(parents=True)
    faults = [None] * 6 + [Fault("friction", 0.9)] * 3 + [None] * 2
    for day, fault in enumerate(faults):
        capture = simulate_capture("short_fast", fault=fault, seed=day)
        write_capture(capture, axis / f"2026-03-{day + 1:02d}.parquet")
    shown = run("monitor", tmp_path / "fleet", "--store", tmp_path / "s.db", "--settle", "0")
    lines = shown.stdout.splitlines()
    assert "Alarms raised and cleared again in this run (1 axis); the state shows none:" in lines
    (named,) = [line for line in lines if line.startswith("  cell1/J2: ")]
    assert "capture(s) in alarm, the first 2026-03-07.parquet" in named
    assert named.endswith("axiswatch results --store " + str(tmp_path / "s.db") +
                          " --robot cell1 --axis J2")  # fmt: skip
    again = run("monitor", tmp_path / "fleet", "--store", tmp_path / "s.db", "--settle", "0")
    assert "Alarms raised and cleared" not in again.stdout  # said once, by the run that saw it


def test_captures_of_other_motion_are_not_called_a_file_to_fix(tmp_path: Path) -> None:
    # A lone axis refuses captures of another motion: a new task, or a drive fault that
    # changed the motion. "Fix the export" sent the engineer to the wrong place.
    axis = tmp_path / "fleet" / "cell1" / "J2"
    axis.mkdir(parents=True)
    for day, task in enumerate(["short_fast"] * 6 + ["heavy"] * 2):
        write_capture(simulate_capture(task, seed=day), axis / f"2026-03-{day + 1:02d}.parquet")
    with aw.Store(tmp_path / "s.db") as store:
        aw.monitor_fleet(tmp_path / "fleet", store, aw.MonitorConfig(), settle_s=0)
        (verdict,) = fleet_verdicts(store, "indicators")
    assert verdict.state == "bad data"
    assert verdict.fault == "captures not scored: the axis moved unlike its baseline"
    assert "If its task did not change, the motion did: check the drive" in verdict.action
    assert "Fix the export" not in verdict.action
