"""The monitor's ``indicators`` method: low-rate axes scored, friction faults named (issue 13)."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch._capture import capture_to_frame
from axiswatch.cli import app
from axiswatch.datasets import Fault, draw_robot
from axiswatch.indicators._axis import (
    IndicatorBaseline,
    check_monitor_rate,
    fit_indicator_baseline,
)
from axiswatch.indicators._readings import Readings, read_indicators
from axiswatch.monitor import MonitorConfig, SQLiteStore
from axiswatch.monitor._fleet import FleetFile
from axiswatch.monitor._ledger import rebaseline
from axiswatch.monitor._methods import MethodPreset
from axiswatch.monitor._models import ModelRef
from axiswatch.monitor._monitor import MonitorSummary, monitor_fleet
from axiswatch.monitor._persist import dump_model, load_model
from axiswatch.monitor._quality import QualityReference, data_quality_problem
from axiswatch.monitor._scoring import ScoreJob, score_capture
from axiswatch.monitor.report.attention import AxisAttention, triage
from axiswatch.monitor.report.html import write_report
from axiswatch.monitor.report.results import fleet_rejections, fleet_results, fleet_summary
from tests.conftest import SHARED_DATA, settle
from tests.memory_store import MemoryStore

runner = CliRunner()

#: A development robot of the family (lab/docs/decision-log.md, "Transfer"): a 50 Hz wrist axis.
ROBOT_SEED = 4
AXES = 4
DAYS = 9
FAULTY_FROM = 7  # axis a0's captures from this day on have a developed friction fault


def _write(capture: aw.Capture, root: Path, robot: str, axis: str, day: int) -> Path:
    folder = root / robot / axis
    folder.mkdir(parents=True, exist_ok=True)
    return aw.write_capture(capture, folder / f"2026-03-{day + 1:02d}.parquet")


@pytest.fixture(scope="module")
def low_rate_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One robot model, four axes at four tasks, 50 Hz: healthy but for a0's last two days
    (friction fault), with a standing-still capture on a1's last day."""
    root = tmp_path_factory.mktemp("fleet") / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for a in range(AXES):
        for day in range(DAYS):
            fault = Fault("friction", 1.0) if a == 0 and day >= FAULTY_FROM else None
            capture = robot.capture(a, seed=day, fault=fault)
            if a == 1 and day == DAYS - 1:
                still = {name: np.zeros_like(v) for name, v in capture.signals.items()}
                still["position"] = np.full_like(capture.signals["position"], 0.3)
                still["torque"] = capture.signals["torque"].mean() + 0.01 * np.random.default_rng(
                    0
                ).normal(size=capture.signals["torque"].size)
                capture = aw.Capture(still, capture.rates_hz)
            _write(capture, root, "r1", f"a{a}", day)
    settle(root)
    return root


def _monitor(root: Path, store: Path, method: str) -> tuple[int, str]:
    result = runner.invoke(
        app, ["monitor", str(root), "--store", str(store), "--method", method, "--no-progress"]
    )
    return result.exit_code, result.output


def test_low_rate_axes_are_scored_by_indicators(low_rate_fleet: Path, tmp_path: Path) -> None:
    assert draw_robot(ROBOT_SEED).spec.fast_rate_hz < 100
    code, output = _monitor(low_rate_fleet, tmp_path / "i.sqlite", "indicators")
    assert f"{AXES} new baseline(s)" in output
    assert f"{AXES * DAYS - AXES - 1} capture(s) scored" in output  # all but the standing one
    with SQLiteStore(tmp_path / "i.sqlite") as store:
        rejected = store.problem_table()
    assert rejected["path"].tolist() == [f"r1/a1/2026-03-{DAYS:02d}.parquet"]
    assert rejected["kind"].tolist() == ["bad data"]  # recorded, with its reason, not an alarm
    assert "flat/stuck signal" in rejected["error"].iloc[0]
    assert code == 4 + 8  # the friction alarm, and the standing capture to look at


def _scores(root: Path, config: MonitorConfig) -> pd.DataFrame:
    store = MemoryStore()
    monitor_fleet(root, store, config, settle_s=0)
    return store.score_table()


def test_a_friction_fault_alarms_with_the_friction_indicator_named(low_rate_fleet: Path) -> None:
    scores = _scores(low_rate_fleet, MonitorConfig(method="indicators"))
    alarms = scores[scores["alarm"].fillna(False).astype(bool)]
    assert set(alarms["axis"]) == {"a0"}
    assert set(alarms["capture"]) == {f"2026-03-{d + 1:02d}.parquet" for d in (7, 8)}
    for reason in alarms["reason"]:
        assert "friction (friction)" in reason
        assert "spreads from its baseline" in reason
        assert "x its task-change allowance" in reason
    details = json.loads(alarms["details"].iloc[0])
    entries = details["indicators"]
    # A task change's distance is the largest shift in units of each indicator's allowance.
    top = max(entries, key=lambda n: entries[n]["spreads"] / entries[n]["allowance"])
    assert top.endswith("friction")
    assert set(entries[top]) == {"value", "baseline", "spreads", "share", "allowance"}
    assert details["spreads_distance"] == pytest.approx(
        entries[top]["spreads"] / entries[top]["allowance"], rel=1e-12
    )
    assert details["fleet_axes"] == AXES  # the prior pooled over the four axes


def test_with_the_task_envelope_a_same_task_fault_alarms_on_own_spreads(
    low_rate_fleet: Path,
) -> None:
    config = MonitorConfig(method="indicators", task_envelope=2.0)
    scores = _scores(low_rate_fleet, config)
    alarms = scores[scores["alarm"].fillna(False).astype(bool)]
    assert set(alarms["axis"]) == {"a0"}
    for reason in alarms["reason"]:
        assert "same task as the baseline: own spreads; " in reason
        assert "friction (friction)" in reason
    monitored = scores[(scores["role"] == "monitor") & scores["distance"].notna()]
    cases = {json.loads(d)["case"] for d in monitored["details"]}
    assert cases == {"same task as the baseline: own spreads"}  # every axis stays on its task
    assert set(scores["threshold"].dropna().round(12)) == {1.0}


def test_the_task_envelope_option_of_the_command_is_the_librarys(
    low_rate_fleet: Path, tmp_path: Path
) -> None:
    store = tmp_path / "e.sqlite"
    result = runner.invoke(
        app, ["monitor", str(low_rate_fleet), "--store", str(store), "--task-envelope", "2",
              "--no-progress", "--settle", "0"],
    )  # fmt: skip
    assert result.exit_code in (4, 12), result.output
    with SQLiteStore(store) as opened:
        by_command = opened.score_table()
    by_library = _scores(low_rate_fleet, MonitorConfig(task_envelope=2.0))
    columns = ["robot", "axis", "capture", "role", "distance", "alarm", "reason"]
    key = ["robot", "axis", "capture"]
    pd.testing.assert_frame_equal(
        by_command[columns].sort_values(key).reset_index(drop=True),
        by_library[columns].sort_values(key).reset_index(drop=True),
    )
    assert by_command["reason"].str.contains("same task as the baseline").any()
    refused = runner.invoke(
        app, ["monitor", str(low_rate_fleet), "--store", str(tmp_path / "x.sqlite"),
              "--method", "pca", "--task-envelope", "2"],
    )  # fmt: skip
    assert refused.exit_code == 2
    assert "for the method 'indicators' only" in refused.output
    assert not (tmp_path / "x.sqlite").exists()


def test_calibration_distances_are_leave_one_out_and_set_the_models_threshold(
    low_rate_fleet: Path,
) -> None:
    scores = _scores(low_rate_fleet, MonitorConfig(method="indicators"))
    axis = scores[(scores["axis"] == "a2") & scores["distance"].notna()]
    calibration = axis.iloc[:5]
    assert all(json.loads(d)["leave_one_out"] for d in calibration["details"])
    assert not any(json.loads(d)["leave_one_out"] for d in axis.iloc[5:]["details"])
    store = MemoryStore()
    monitor_fleet(low_rate_fleet, store, MonitorConfig(method="indicators"), settle_s=0)
    baseline = store.latest_baseline("r1", "a2", "indicators")
    assert baseline is not None
    fitted = json.loads(scores[scores["axis"] == "a2"]["details"].iloc[0])["indicator_model"]
    # Scores are in units of the threshold that applied: the monitor's own calibration rule on
    # the K leave-one-out scores (own spreads over the own threshold) gives exactly 1.
    assert axis["threshold"].iloc[-1] == pytest.approx(1.0, rel=1e-12)
    for _, row in axis.iterrows():
        details = json.loads(row["details"])
        assert row["distance"] == pytest.approx(
            details["spreads_distance"] / details["threshold_spreads"], rel=1e-12
        )
        own = details["case"] == "same task as the baseline: own spreads"
        assert details["threshold_spreads"] == pytest.approx(
            fitted["own_threshold"] if own else fitted["threshold"], rel=1e-12
        )
    assert all(
        json.loads(d)["case"] == "same task as the baseline: own spreads"
        for d in calibration["details"]
    )
    assert fitted["fitted_on"] == [f"r1/a2/2026-03-{d:02d}.parquet" for d in range(1, 7)]


def test_a_negative_friction_reading_is_scored(tmp_path: Path) -> None:
    root = tmp_path / "fleet"
    gen = np.random.default_rng(7)
    t = np.arange(0, 8, 1 / 50)  # 50 Hz
    for day in range(8):
        q = np.sin(np.pi * t / 2 + 0.3 * day)
        v = np.gradient(q, t)
        torque = -2.0 * np.sign(v) + 0.3 * v + 0.05 * gen.normal(size=t.size)
        capture = aw.Capture(
            {"position": q, "speed": v, "torque": torque},
            dict.fromkeys(("position", "speed", "torque"), 50.0),
        )
        _write(capture, root, "r1", "neg", day)
    settle(root)
    scores = _scores(root, MonitorConfig(method="indicators"))
    scored = scores[scores["distance"].notna()]
    assert len(scored) == 7
    readings = json.loads(scored["details"].iloc[-1])["indicators"]
    assert readings["coulomb_friction"]["value"] < 0
    assert not scored["alarm"].astype(bool).any()


def test_a_capture_without_any_of_the_models_indicators_is_not_scored(tmp_path: Path) -> None:
    # A model that scores only the impulsiveness, and a 50 Hz capture that cannot give it.
    read = [Readings({"impulsiveness": 3.0 + 0.1 * k}) for k in range(6)]
    fitted = fit_indicator_baseline(read, [str(k) for k in range(6)], [""] * 6, percentile=99.0)
    path = _write(draw_robot(ROBOT_SEED).capture(0, seed=0), tmp_path, "r1", "a1", 0)
    file = FleetFile("r1", "a1", path.name, path, pd.Timestamp("2026-03-01").to_pydatetime())
    job = ScoreJob(file, "r1/a1/" + path.name, 1, ModelRef("k", "", inline=fitted), {})
    outcome = score_capture(job)
    assert outcome.kind == "not scored"
    assert outcome.error is not None
    assert "impulsiveness needs a torque rate" in outcome.error
    assert math.isnan(outcome.distance)


def test_the_stored_model_round_trips_without_pickle(low_rate_fleet: Path) -> None:
    robot = draw_robot(ROBOT_SEED)
    read = [read_indicators(robot.capture(0, seed=k)) for k in range(6)]
    fitted = fit_indicator_baseline(
        read, [str(k) for k in range(6)], ["p"] * 6, percentile=99.0, task_envelope_factor=2.0
    )
    blob = dump_model(fitted)
    with np.load(io.BytesIO(blob), allow_pickle=False) as archive:
        assert all(archive[name].dtype != object for name in archive.files)
    back = load_model(blob)
    assert isinstance(back, IndicatorBaseline)
    test = read_indicators(robot.capture(0, seed=9, fault=Fault("friction", 0.5)))
    assert back.model.assess_readings(test) == fitted.model.assess_readings(test)
    assert back.model.loo_distances_ == fitted.model.loo_distances_
    # The task envelope comes back too: the capture is still recognised as the baseline's task.
    assert back.model.assess_readings(test).case == "same task as the baseline: own spreads"
    assert back.model.own_threshold_ == fitted.model.own_threshold_


def test_a_stored_indicators_run_resumes_with_its_stored_models(
    low_rate_fleet: Path, tmp_path: Path
) -> None:
    store_path = tmp_path / "s.sqlite"
    _monitor(low_rate_fleet, store_path, "indicators")
    code, output = _monitor(low_rate_fleet, store_path, "indicators")
    assert "0 new baseline(s), 0 capture(s) scored" in output
    assert code == 4 + 8


def test_an_axis_short_of_calibration_captures_waits(tmp_path: Path) -> None:
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for day in range(4):
        _write(robot.capture(0, seed=day), root, "r1", "a1", day)
    settle(root)
    store = MemoryStore()
    summary = monitor_fleet(root, store, MonitorConfig(method="indicators"), settle_s=0)
    assert summary.calibrating == [
        "r1/a1: calibrating, 3 of 5 captures after the baseline r1/a1/2026-03-01.parquet give "
        "a reading; the indicators baseline is set once all have arrived"
    ]
    assert summary.exit_code == 0
    assert summary.scored == 0
    for day in range(4, 7):
        _write(robot.capture(0, seed=day), root, "r1", "a1", day)
    summary = monitor_fleet(root, store, MonitorConfig(method="indicators"), settle_s=0)
    assert summary.calibrating == []
    assert summary.new_baselines == 1
    assert summary.scored == 6


def test_an_axis_whose_later_captures_cannot_be_used_says_why_it_waits(tmp_path: Path) -> None:
    # Before: "calibrating, 0 of 5 captures ... give a reading" and nothing else, run after run,
    # while six later captures sat in the folder at another rate than the baseline's.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    _write(robot.capture(0, seed=0), root, "r1", "a1", 0)
    for day in range(1, 7):
        capture = robot.capture(0, seed=day)
        halved = {name: values[::2] for name, values in capture.signals.items()}
        rates = {name: rate / 2 for name, rate in capture.rates_hz.items()}
        _write(aw.Capture(halved, rates), root, "r1", "a1", day)
    settle(root)
    summary = monitor_fleet(root, MemoryStore(), MonitorConfig(method="indicators"), settle_s=0)
    rate = robot.capture(0, seed=0).rates_hz["position"]
    assert summary.calibrating == [
        "r1/a1: calibrating, 0 of 5 captures after the baseline r1/a1/2026-03-01.parquet give "
        "a reading; the indicators baseline is set once all have arrived (6 could not be used; "
        f"the first: r1/a1/2026-03-02.parquet: column 'position' is sampled at {rate / 2:.6g} Hz; "
        f"expected {rate:.6g} Hz (the baseline's rate))"
    ]


def test_stamps_in_milliseconds_read_as_seconds_are_not_scored(tmp_path: Path) -> None:
    # Before: a 50 Hz log stamped 0, 20, 40 ... ms became a 0.05 Hz capture, and its friction
    # and drive loads were read and scored in wrong units, without a word.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for day in range(7):
        frame = capture_to_frame(robot.capture(0, seed=day))
        frame["time"] = (frame["time"] * 1000).round()
        folder = root / "r1" / "a1"
        folder.mkdir(parents=True, exist_ok=True)
        frame.to_csv(folder / f"2026-03-{day + 1:02d}.csv", index=False)
    settle(root)
    summary = monitor_fleet(root, MemoryStore(), MonitorConfig(method="indicators"), settle_s=0)
    assert summary.scored == 0
    assert summary.new_baselines == 0
    assert summary.rejected[0] == (
        "r1/a1/2026-03-01.csv: signals sampled at 0.05 Hz at most; the indicators need 20 Hz or "
        "more (stamps in milliseconds read as seconds? declare the unit in the axis profile: "
        '[units] time = "ms").'
    )
    just = aw.as_capture({"torque": [0.0, 1.0, 0.0]}, 20.0 * (1 - 1e-9))  # a 20 Hz log's stamps
    check_monitor_rate(just)


def test_a_faulty_first_capture_is_reported(tmp_path: Path) -> None:
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for day in range(8):
        fault = Fault("friction", 1.0) if day == 0 else None
        _write(robot.capture(0, seed=day, fault=fault), root, "r1", "a1", day)
    settle(root)
    summary = monitor_fleet(root, MemoryStore(), MonitorConfig(method="indicators"), settle_s=0)
    assert len(summary.baseline_checks) == 1
    assert summary.baseline_checks[0].startswith("r1/a1/2026-03-01.parquet: the baseline capture")
    assert summary.exit_code & 8


def _faulty_first(tmp_path: Path, days: int = 8) -> Path:
    """A fleet folder of one axis whose first capture (the baseline) has a friction fault."""
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for day in range(days):
        fault = Fault("friction", 1.0) if day == 0 else None
        _write(robot.capture(0, seed=day, fault=fault), root, "r1", "a1", day)
    settle(root)
    return root


def test_a_baseline_check_lasts_until_acknowledged_also_after_a_killed_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Before: the check was listed once, from the memory of the run that fitted the baseline;
    # a run killed right after the baseline's commit lost its exit status 8 for good.
    import axiswatch.monitor._run as monitor_module

    root = _faulty_first(tmp_path)
    path = tmp_path / "s.sqlite"
    config = MonitorConfig(method="indicators")

    def killed(*_: object) -> None:
        raise RuntimeError("killed after the baseline's commit")

    with monkeypatch.context() as kill, SQLiteStore(path) as store:
        kill.setattr(monitor_module.Run, "persist", killed)  # the step after insert_baseline
        with pytest.raises(RuntimeError, match="killed"):
            monitor_fleet(root, store, config, settle_s=0)
        assert store.latest_baseline("r1", "a1", "indicators") is not None  # committed
    with SQLiteStore(path) as store:
        again = monitor_fleet(root, store, config, settle_s=0)
        assert again.new_baselines == 0
        assert len(again.baseline_checks) == 1
        assert again.baseline_checks[0].startswith("r1/a1/2026-03-01.parquet: the baseline capture")
        assert again.exit_code == 8
        assert again.alarms == []
        # Every run, not once: also one that lists no folder (nothing new).
        third = monitor_fleet(root, store, config, settle_s=0)
        assert third.baseline_checks == again.baseline_checks
        assert third.unchanged_folders == 1
    listed = runner.invoke(app, ["rejections", "--store", str(path)])
    assert listed.exit_code == 0, listed.output
    (row,) = [line for line in listed.output.splitlines() if "r1/a1/2026-03-01.parquet" in line]
    assert row.split()[:2] == ["baseline", "check"]
    acked = runner.invoke(
        app, ["rejections", "--store", str(path), "--ack", "r1/a1/2026-03-01.parquet"]
    )
    assert acked.exit_code == 0, acked.output
    assert acked.output.startswith("1 problem(s) acknowledged")
    code, output = _monitor(root, path, "indicators")
    assert code == 0, output
    assert "Baselines to check" not in output
    assert "1 acknowledged problem(s) not shown" in output
    with SQLiteStore(path) as store:
        seen = monitor_fleet(root, store, config, settle_s=0)
        assert (seen.baseline_checks, seen.acknowledged, seen.exit_code) == ([], 1, 0)
        (check,) = store.baseline_checks("indicators")
        assert check.acknowledged_at is not None  # still listed by `rejections`, as seen


def test_a_rebaseline_clears_its_baseline_check(tmp_path: Path) -> None:
    root = _faulty_first(tmp_path)
    store = MemoryStore()
    config = MonitorConfig(method="indicators")
    first = monitor_fleet(root, store, config, settle_s=0)
    assert first.new_baselines == 1
    again = monitor_fleet(root, store, config, settle_s=0)  # before: listed by the first only
    assert again.baseline_checks == first.baseline_checks != []
    assert again.exit_code == 8
    rebaseline(store, "r1", "a1")
    after = monitor_fleet(root, store, config, settle_s=0)
    assert (after.baseline_checks, after.acknowledged, after.exit_code) == ([], 0, 0)


def test_a_store_from_before_the_baseline_checks_opens_and_lists_none(tmp_path: Path) -> None:
    root = _faulty_first(tmp_path)
    path = tmp_path / "s.sqlite"
    config = MonitorConfig(method="indicators")
    with SQLiteStore(path) as store:
        monitor_fleet(root, store, config, settle_s=0)
        before = store.score_table()
    with contextlib.closing(sqlite3.connect(path)) as db:
        db.execute("DROP TABLE baseline_checks")  # as a store made before the table
        db.commit()
    _write(draw_robot(ROBOT_SEED).capture(0, seed=8), root, "r1", "a1", 8)
    settle(root)
    with SQLiteStore(path) as store:
        summary = monitor_fleet(root, store, config, settle_s=0)
        # Its baseline's check was listed by the run that fitted it; none is stored for it.
        assert summary.baseline_checks == []
        assert (summary.new_baselines, summary.scored, summary.exit_code) == (0, 1, 0)
        assert store.baseline_checks() == []
        assert store.problem_table().empty
        after = store.score_table()
    pd.testing.assert_frame_equal(after.iloc[: len(before)], before)  # nothing stored is lost
    assert len(after) == len(before) + 1


def test_the_report_shows_a_baseline_check_until_acknowledged_or_rebaselined(
    tmp_path: Path,
) -> None:
    # Before: the report read the check from the last score's details only: it never made the
    # axis need attention, and still said "to check" after `rejections --ack`.
    root = _faulty_first(tmp_path)
    path = tmp_path / "s.sqlite"
    config = MonitorConfig(method="indicators")
    with SQLiteStore(path) as store:
        assert monitor_fleet(root, store, config, settle_s=0).exit_code == 8
        (item,) = _triage(store)
        page = write_report(store, tmp_path / "first").read_text(encoding="utf-8")
    assert (item.kind, item.needs_attention) == ("baseline check", True)
    assert item.line.startswith("ok: last capture 2026-03-08, distance ")
    assert "Baseline to check: the baseline capture " in item.line
    assert item.line.count("Baseline to check") == 1  # from the store, not again from the details
    urgent = _attention_list(page)
    assert "data-axis='r1/a1' data-kind='baseline check'" in urgent
    assert "Baseline to check: the baseline capture " in urgent
    assert "Needs attention now (1)" in page

    acked = runner.invoke(
        app, ["rejections", "--store", str(path), "--ack", "r1/a1/2026-03-01.parquet"]
    )
    assert acked.output.startswith("1 problem(s) acknowledged"), acked.output
    with SQLiteStore(path) as store:
        (item,) = _triage(store)
        page = write_report(store, tmp_path / "seen").read_text(encoding="utf-8")
    assert (item.kind, item.needs_attention) == ("ok", False)
    assert re.search(
        r"Baseline to check, seen on \d{4}-\d\d-\d\d: the baseline capture ", item.line
    )
    assert "Baseline to check:" not in item.line
    assert "Needs attention now (0)" in page
    assert "r1/a1" not in _attention_list(page)
    assert "Baseline to check, seen on " in page.split("<details id='healthy'>")[1]
    history = page.split("<section class='axis' id='r1-a1'>")[1]
    assert "baseline to check (indicators)</td><td class='text'>r1/a1/2026-03-01.parquet: " in (
        history
    )
    assert "baseline check acknowledged (indicators)" in history

    rebased = runner.invoke(
        app,
        ["rebaseline", "--store", str(path), "--robot", "r1", "--axis", "a1",
         "--from", "2026-03-02.parquet"],
    )  # fmt: skip
    assert rebased.exit_code == 0, rebased.output
    with SQLiteStore(path) as store:
        assert monitor_fleet(root, store, config, settle_s=0).exit_code == 0
        (item,) = _triage(store)
        page = write_report(store, tmp_path / "rebased").read_text(encoding="utf-8")
    assert (item.kind, item.needs_attention) == ("ok", False), item.line
    assert "Baseline to check" not in page


def test_the_report_of_a_store_from_before_the_baseline_checks_keeps_their_notes(
    tmp_path: Path,
) -> None:
    # Its baselines have no stored check: the note in the scores' details is shown as it was
    # before the table (on the axis's line; nothing can mark it seen, so it is not an attention).
    root = _faulty_first(tmp_path)
    path = tmp_path / "s.sqlite"
    with SQLiteStore(path) as store:
        monitor_fleet(root, store, MonitorConfig(method="indicators"), settle_s=0)
    with contextlib.closing(sqlite3.connect(path)) as db:
        db.execute("DROP TABLE baseline_checks")
        db.commit()
    with SQLiteStore(path) as store:
        (item,) = _triage(store)
        page = write_report(store, tmp_path / "r").read_text(encoding="utf-8")
    assert item.kind == "ok"
    assert "Baseline to check: the baseline capture " in item.line
    assert "Baseline to check: the baseline capture " in page


def _attention_list(page: str) -> str:
    """The report's *Needs attention now* list (empty when no axis needs attention)."""
    section = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    return section if "<ol class='attention'>" in section else ""


def test_indicators_has_no_detector_or_stage() -> None:
    with pytest.raises(ValueError, match="'detector' parameter is for the method 'lra', 'pca'"):
        MonitorConfig(method="indicators", detector=aw.PCADetector())
    with pytest.raises(ValueError, match="'stage' parameter is for the method 'lra'"):
        MonitorConfig(method="indicators", stage=aw.StftStage())
    with pytest.raises(ValueError, match="needs a 'model' factory or a 'detector' factory"):
        MethodPreset()
    with pytest.raises(ValueError, match="not both"):
        MethodPreset(model=lambda config: config.model(), detector=lambda config: aw.PCADetector())
    with pytest.raises(ValueError, match="one entry per capture"):
        fit_indicator_baseline([Readings({})], [], [], percentile=99.0)


# --- real data (skipped when ../shared/data is absent) ------------------------------------------


def _real(name: str) -> Path:
    folder = SHARED_DATA / name
    if not folder.is_dir():
        pytest.skip(f"{folder} is absent")
    return folder


def _readable(root: Path) -> int:
    """Captures after each axis's baseline (its first capture with usable data) that pass the
    monitor's data-quality rules: a window in which the axis stood still for half its samples
    is *stuck* there (monitor._quality), not readable."""
    count = 0
    for axis in {p.parent for p in root.rglob("*.parquet")}:
        captures = [aw.read_capture(f) for f in sorted(axis.glob("*.parquet"))]
        first = next(k for k, c in enumerate(captures) if data_quality_problem(c) is None)
        reference = QualityReference.of(captures[first])
        count += sum(data_quality_problem(c, reference) is None for c in captures[first + 1 :])
    return count


def test_the_report_names_the_indicators_alarms_top_indicator(
    low_rate_fleet: Path, tmp_path: Path
) -> None:
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        monitor_fleet(low_rate_fleet, store, MonitorConfig(method="indicators"), settle_s=0)
        items = _triage(store)
        alarmed = [i for i in items if i.kind == "alarm"]
        assert [i.axis for i in alarmed] == ["a0"]
        assert "friction (friction)" in alarmed[0].line
        assert "spreads from its baseline" in alarmed[0].line
        page = write_report(store, tmp_path / "report.html").read_text()
        results = fleet_results(store)
    assert "friction (friction)" in page
    assert "indicators (indicators): shift from the baseline" in page  # the per-indicator panel
    # The results' and the history's top indicator is the one that set the distance, in the
    # method's own words (not the largest share of the shifts in spreads).
    flagged = results[results["over"].astype(bool)]
    assert len(flagged) > 0
    for top, details in zip(flagged["top_indicator"], flagged["details"], strict=True):
        assert top == json.loads(details)["top_indicator"]
        assert "spreads from its baseline" in top


def _three_axes(tmp_path: Path) -> tuple[Path, Any]:
    """A fleet folder of one robot model's axes 0-2, 7 healthy days each, and the robot."""
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for a in range(3):
        for day in range(7):
            _write(robot.capture(a, seed=day), root, "r1", f"a{a}", day)
    settle(root)
    return root, robot


def test_a_new_axis_is_pooled_with_the_stored_axes_of_its_fleet(tmp_path: Path) -> None:
    root, robot = _three_axes(tmp_path)
    config = MonitorConfig(method="indicators")
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        monitor_fleet(root, store, config, settle_s=0)
        for day in range(7):
            _write(robot.capture(3, seed=day), root, "r1", "a3", day)
        settle(root)
        summary = monitor_fleet(root, store, config, settle_s=0)
        assert summary.new_baselines == 1
        scores = store.score_table()
    last = scores[(scores["axis"] == "a3") & scores["distance"].notna()].iloc[-1]
    assert json.loads(last["details"])["fleet_axes"] == 4
    first = scores[(scores["axis"] == "a0") & scores["distance"].notna()].iloc[-1]
    assert json.loads(first["details"])["fleet_axes"] == 3  # kept until re-baselined


@pytest.mark.parametrize("n_axes", [6, 4])
def test_a_worn_axis_is_reported_against_its_fleet(tmp_path: Path, n_axes: int) -> None:
    # Axes on one task, one worn from its first capture: its baseline agrees with its own
    # calibration captures, but not with its fleet's. It is checked against the other axes: with
    # 4, pooled with them it would be in 3 of the 6 pairs and set the allowances itself.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for a in range(n_axes):
        fault = Fault("friction", 1.0) if a == 0 else None
        for day in range(7):
            _write(robot.capture(0, seed=f"{a}/{day}", fault=fault), root, "r1", f"a{a}", day)
    settle(root)
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        summary = monitor_fleet(root, store, MonitorConfig(method="indicators"), settle_s=0)
        assert len(summary.baseline_checks) == 1
        assert summary.baseline_checks[0].startswith(
            "r1/a0/2026-03-01.parquet: this axis's baseline differs from its fleet's: "
        )
        items = _triage(store)
    lines = {i.axis: i.line for i in items}
    assert items[0].axis == "a0"  # ranked first, its report line under Needs attention now
    assert (items[0].kind, items[0].needs_attention) == ("baseline check", True)
    assert "Baseline to check: this axis's baseline differs from its fleet's" in lines["a0"]
    assert f"checked against the {n_axes - 1} other axes of its profile" in lines["a0"]
    assert not any("Baseline to check" in lines[f"a{a}"] for a in range(1, n_axes))


def _triage(store: SQLiteStore) -> list[AxisAttention]:
    return triage(
        fleet_summary(store),
        fleet_results(store),
        fleet_rejections(store),
        store.changed_file_table(),
        store.alarms(),
        method="indicators",
        checks=store.baseline_checks(),
    )


def test_axes_fitted_before_their_fleet_had_three_get_its_prior_later(tmp_path: Path) -> None:
    # Commissioned one at a time: a0 and a1 are fitted with no fleet prior (2 axes); when a2
    # arrives, the three are a fleet, and a0 and a1 get its allowances from the next run on,
    # while the scores already stored keep what they were scored with.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for a in range(2):
        for day in range(7):
            _write(robot.capture(a, seed=f"{a}/{day}"), root, "r1", f"a{a}", day)
    settle(root)

    def run() -> list[str]:
        with SQLiteStore(tmp_path / "s.sqlite") as store:
            return monitor_fleet(root, store, MonitorConfig(), settle_s=0).fleet_priors

    assert run() == []
    for day in range(8):
        _write(robot.capture(2, seed=f"2/{day}"), root, "r1", "a2", day)
    _write(robot.capture(0, seed="0/7"), root, "r1", "a0", 7)
    settle(root)
    given = run()
    assert [line.split(":")[0] for line in given] == ["r1/a0", "r1/a1"]
    assert all("task-change allowances from 3 axes of its fleet" in line for line in given)
    for a in range(2):
        _write(robot.capture(a, seed=f"{a}/8"), root, "r1", f"a{a}", 8)
    settle(root)
    assert run() == []  # nothing new to give
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        scores = store.score_table()
    monitored = scores[(scores["role"] == "monitor") & scores["distance"].notna()]
    axes = {
        (row.axis, row.capture[-10:-8]): json.loads(row.details)["fleet_axes"]
        for row in monitored.itertuples()
    }
    # a0's capture of the second run was scored before a2 was fitted: kept as it was.
    assert axes[("a0", "08")] == 0
    assert axes[("a0", "09")] == axes[("a1", "09")] == axes[("a2", "08")] == 3


def test_a_fleet_check_given_with_a_later_prior_is_stored_with_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a0 (worn from its first capture) and a1 are fitted without a fleet; a2 and a3 make it 4
    # axes, and a0's stored model gets the prior and its fleet check. The prior is stored once:
    # before, its check was listed by that run only and lost when the run was killed after it.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)

    def axis(a: int) -> None:
        fault = Fault("friction", 1.0) if a == 0 else None
        for day in range(7):
            _write(robot.capture(0, seed=f"{a}/{day}", fault=fault), root, "r1", f"a{a}", day)

    def run() -> MonitorSummary:
        with SQLiteStore(tmp_path / "s.sqlite") as store:
            return monitor_fleet(root, store, MonitorConfig(), settle_s=0)

    for a in range(2):
        axis(a)
    settle(root)
    assert run().baseline_checks == []
    for a in range(2, 4):
        axis(a)
    settle(root)

    def killed(*_: object) -> None:
        raise RuntimeError("killed")

    with monkeypatch.context() as kill:  # between the prior's and its check's write
        kill.setattr(SQLiteStore, "record_baseline_check", killed)
        with pytest.raises(RuntimeError, match="killed"):
            run()
    given = run()  # the prior was not stored without its check: given now, with it
    assert [line.split(":")[0] for line in given.fleet_priors] == ["r1/a0", "r1/a1"]
    assert len(given.baseline_checks) == 1
    later = run()
    assert later.fleet_priors == []  # given once
    assert later.baseline_checks == given.baseline_checks  # before: []
    assert later.exit_code == 8
    # Named by its baseline's path, as every stored check (before: "r1/a0: ...").
    assert given.baseline_checks[0].startswith(
        "r1/a0/2026-03-01.parquet: this axis's baseline differs from its fleet's: "
    )


def test_an_axis_without_a_fleet_does_not_compare_another_task(tmp_path: Path) -> None:
    # One axis, no fleet: its baseline on task 0, then three days of task 2 and one of task 0.
    # A task change is not compared (nothing says what it does to the indicators), so it is no
    # alarm; the baseline's task is still scored.
    root = tmp_path / "fleet"
    robot = draw_robot(ROBOT_SEED)
    for day in range(6):
        _write(robot.capture(0, seed=day), root, "r1", "a1", day)
    for day in range(6, 9):
        _write(robot.capture(2, seed=day), root, "r1", "a1", day)
    _write(robot.capture(0, seed=9), root, "r1", "a1", 9)
    settle(root)
    store = MemoryStore()
    summary = monitor_fleet(root, store, MonitorConfig(), settle_s=0)
    assert summary.new_baselines == 1
    errors = {r.capture: r.error for r in store.rejections("indicators")}
    assert sorted(errors) == [f"2026-03-{d:02d}.parquet" for d in (7, 8, 9)]
    assert all(": not scored: motion unlike the baseline's task" in e for e in errors.values())
    assert all("rebaseline the axis on its new task" in e for e in errors.values())
    assert all("--modes, which learns each task" in e for e in errors.values())
    scores = store.score_table()
    monitored = scores[(scores["role"] == "monitor") & scores["distance"].notna()]
    assert list(monitored["capture"]) == ["2026-03-10.parquet"]
    assert summary.exit_code == 8  # no alarm; the captures not compared are listed


def test_with_a_fleet_another_task_is_scored_against_its_allowances() -> None:
    robot = draw_robot(ROBOT_SEED)
    fleet = [
        aw.IndicatorModel().fit(
            robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)]
        )
        for t in range(4)
    ]
    lone = aw.IndicatorModel().fit(
        robot.capture(0, seed=0), [robot.capture(0, seed=k) for k in range(1, 6)]
    )
    other_task = robot.capture(2, seed=30)
    alone = lone.assess(other_task)
    assert not alone.scored
    assert not alone.alarm
    assert alone.case == "task changed: no fleet prior"
    assert alone.task_distance > alone.task_envelope
    assert "not compared" in alone.reason()
    assert lone.assess(robot.capture(0, seed=30)).scored
    lone.use_fleet(aw.IndicatorModel.pool(fleet))
    scored = lone.assess(other_task)
    assert scored.scored
    assert scored.case == "no task envelope: fleet allowance"


def test_the_fleet_pool_does_not_depend_on_which_worker_finishes_first(
    low_rate_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Baselines returned by the workers in the reverse order give the scores of the in-order
    run, bit for bit. The monitor pools them in (robot, axis) order (a608273: a pair's task shift
    was read in its first axis's spreads, so the prior depended on the order); since i17a the
    prior reads every pair both ways and does not depend on it
    (``test_indicator_model.py::test_the_fleet_prior_does_not_depend_on_the_order_of_the_axes``)."""
    from axiswatch.monitor._parallel import WorkerPool

    def scores(name: str) -> pd.DataFrame:
        with SQLiteStore(tmp_path / name) as store:
            monitor_fleet(low_rate_fleet, store, MonitorConfig(method="indicators"), settle_s=0)
            table = store.score_table()
        return table.sort_values(["axis", "capture"]).reset_index(drop=True)[
            ["axis", "capture", "role", "distance", "threshold", "over", "alarm"]
        ]

    in_order = scores("in_order.sqlite")
    forward = WorkerPool.map

    def last_first(self: WorkerPool, fn: Any, items: Any) -> Any:
        return iter(list(forward(self, fn, items))[::-1])

    monkeypatch.setattr(WorkerPool, "map", last_first)
    pd.testing.assert_frame_equal(scores("last_first.sqlite"), in_order)


def test_a_store_of_an_older_model_format_is_refitted_not_a_crash(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """After an upgrade that changes the stored model format, the axes refit one at a time (a
    chunk each) and the fleet pool leaves out the models not refitted yet instead of reading
    them ('stored model has format N')."""
    import axiswatch.monitor._models
    import axiswatch.monitor._monitor
    import axiswatch.monitor._persist

    root, robot = _three_axes(tmp_path)
    config = MonitorConfig(method="indicators")
    current = axiswatch.monitor._persist.PERSIST_FORMAT
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        monkeypatch.setattr(axiswatch.monitor._persist, "PERSIST_FORMAT", current - 1)
        monitor_fleet(root, store, config, settle_s=0)  # written by the older version
        monkeypatch.setattr(axiswatch.monitor._persist, "PERSIST_FORMAT", current)
        monkeypatch.setattr(axiswatch.monitor._monitor, "_AXES_PER_CHUNK", 1)
        axiswatch.monitor._models._cache.clear()  # the upgraded version runs in a new process
        for a in range(3):
            _write(robot.capture(a, seed=7), root, "r1", f"a{a}", 7)
        settle(root)
        summary = monitor_fleet(root, store, config, settle_s=0)
    assert summary.new_baselines == 0  # refitted, the same baselines
    assert summary.scored == 3


def _slow_capture_writer(root: Path) -> Callable[[int], None]:
    """Writes day ``k``'s capture of ``r1/a1`` with its stamps in milliseconds, read as seconds
    (0.05 Hz): a baseline fitted before the 20 Hz floor of new baselines."""
    folder = root / "r1" / "a1"
    folder.mkdir(parents=True)
    robot = draw_robot(ROBOT_SEED)

    def day(k: int) -> None:
        frame = capture_to_frame(robot.capture(0, seed=k))
        frame["time"] = (frame["time"] * 1000).round()
        frame.to_csv(folder / f"2026-03-{k + 1:02d}.csv", index=False)
        settle(root)

    return day


def _slow_baseline_before_an_upgrade(
    root: Path, store: SQLiteStore, day: Callable[[int], None], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Store r1/a1's baseline from 7 slow captures (``day``: :func:`_slow_capture_writer`) as a
    version from before the 20 Hz floor did, in an older model format: the next run refits it
    (an upgrade, run in a new process)."""
    import axiswatch.indicators._axis as indicators
    import axiswatch.monitor._models
    import axiswatch.monitor._persist

    for k in range(7):
        day(k)
    current = axiswatch.monitor._persist.PERSIST_FORMAT
    with monkeypatch.context() as before:
        before.setattr(indicators, "MIN_MONITOR_RATE_HZ", 0.01)  # no floor yet
        before.setattr(axiswatch.monitor._persist, "PERSIST_FORMAT", current - 1)
        config = MonitorConfig(method="indicators")
        assert monitor_fleet(root, store, config, settle_s=0).new_baselines == 1
    axiswatch.monitor._models._cache.clear()


def test_a_stored_baseline_below_20_hz_is_kept_and_reported_every_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A store from before the 20 Hz floor of new baselines: its axis was fitted on stamps in
    # milliseconds read as seconds (0.05 Hz). Its model is kept; every run says to rebaseline.
    import axiswatch.indicators._axis as indicators

    root = tmp_path / "fleet"
    day = _slow_capture_writer(root)
    for k in range(7):
        day(k)
    config = MonitorConfig(method="indicators")
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        with monkeypatch.context() as before:
            before.setattr(indicators, "MIN_MONITOR_RATE_HZ", 0.01)  # no floor yet
            first = monitor_fleet(root, store, config, settle_s=0)
        assert first.new_baselines == 1
        assert first.baseline_checks == []
        day(7)
        note = (
            "r1/a1/2026-03-01.csv: baseline at 0.05 Hz, below the 20 Hz the indicators need: "
            "rebaseline"
        )
        second = monitor_fleet(root, store, config, settle_s=0)
        assert second.scored == 1  # the stored model is kept
        assert second.baseline_checks == [note]
        assert second.alarms == []
        third = monitor_fleet(root, store, config, settle_s=0)  # nothing new: said again, once
        assert third.baseline_checks == [note]
        items = _triage(store)
    assert [i.kind for i in items] != ["alarm"]
    assert "Baseline to check: baseline at 0.05 Hz, below the 20 Hz" in items[0].line


def test_a_stored_baseline_below_20_hz_is_refitted_after_an_upgrade_and_still_only_noted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Before: an upgrade that bumps the stored model format refits every baseline, and the refit
    # of a slow one met the 20 Hz floor of new baselines: "...; the stored baseline cannot be
    # refitted", an axis not scored, instead of the rebaseline note of a kept slow baseline.
    root = tmp_path / "fleet"
    day = _slow_capture_writer(root)
    config = MonitorConfig(method="indicators")
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        _slow_baseline_before_an_upgrade(root, store, day, monkeypatch)
        day(7)
        upgraded = monitor_fleet(root, store, config, settle_s=0)
        assert upgraded.axis_problems == []
        assert upgraded.new_baselines == 0  # refitted: the same baseline
        assert upgraded.scored == 1
        assert upgraded.baseline_checks == [
            "r1/a1/2026-03-01.csv: baseline at 0.05 Hz, below the 20 Hz the indicators need: "
            "rebaseline"
        ]
        assert upgraded.alarms == []
        assert upgraded.exit_code == 8  # a baseline to check, never an alarm
        assert monitor_fleet(root, store, config, settle_s=0).baseline_checks == (
            upgraded.baseline_checks
        )  # the refitted model is stored and still noted on the next run


def test_a_stored_baseline_below_20_hz_that_cannot_be_refitted_says_why_and_to_rebaseline(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Before: a slow stored baseline whose refit failed for another reason was one line, "...;
    # the stored baseline cannot be refitted", without the note that the baseline is below
    # 20 Hz and to rebaseline: the one thing that mends it (the note came only from a model).
    root = tmp_path / "fleet"
    day = _slow_capture_writer(root)
    config = MonitorConfig(method="indicators")
    folder = root / "r1" / "a1"
    slow = "(baseline at 0.05 Hz, below the 20 Hz the indicators need: rebaseline)"
    with SQLiteStore(tmp_path / "s.sqlite") as store:
        _slow_baseline_before_an_upgrade(root, store, day, monkeypatch)
        # A profile that cannot be read: the refit fails before it reads the baseline.
        (folder / "axis.toml").write_text("[units]\ntime = 3\n")
        broken = monitor_fleet(root, store, config, settle_s=0)
        (folder / "axis.toml").unlink()
        # The logger is fixed (seconds, 50 Hz) and the old calibration captures are archived.
        for k in range(1, 7):
            (folder / f"2026-03-{k + 1:02d}.csv").unlink()
        robot = draw_robot(ROBOT_SEED)
        for k in (7, 8):
            frame = capture_to_frame(robot.capture(0, seed=k))
            frame.to_csv(folder / f"2026-03-{k + 1:02d}.csv", index=False)
        settle(root)
        archived = monitor_fleet(root, store, config, settle_s=0)
    (line,) = broken.axis_problems
    assert line.startswith("r1/a1/2026-03-01.csv: ")
    assert "[units]: 'time' must be a quoted string; got 3 (int); the stored baseline " in line
    assert line.endswith(f"cannot be refitted {slow}")
    (line,) = archived.axis_problems
    assert line.startswith("r1/a1: calibrating, 0 of 5 captures after the baseline ")
    assert "the first: r1/a1/2026-03-08.csv: column 'position' is sampled at 50 Hz" in line
    assert line.endswith(f"; the stored baseline cannot be refitted {slow}")
    for run in (broken, archived):  # never an alarm, not scored, exit status 8
        assert (run.alarms, run.scored, run.baseline_checks, run.exit_code) == ([], 0, [], 8)


def test_one_glitched_torque_sample_is_no_alarm_and_the_faulty_axis_still_alarms(
    tmp_path: Path,
) -> None:
    # Before: one torque sample half the torque's range above its top, too small for the data
    # quality check (twice the range), made the impulsiveness of a healthy axis an ALARM.
    import axiswatch.datasets as awd
    from axiswatch.monitor._quality import signal_range

    root = tmp_path / "fleet"
    awd.simulate_fleet(
        root,
        n_robots=1,
        n_axes=3,
        n_days=10,
        task_change_days=(),
        faults=[awd.FleetFault("robot01", "axis1", "friction", onset_day=8)],
    )
    (root / "labels.csv").unlink()
    path = root / "robot01" / "axis2" / "2026-03-10.parquet"
    capture = aw.read_capture(path)
    torque = np.array(capture.signals["torque"])
    torque[torque.size // 2] = torque.max() + 0.5 * signal_range(torque)
    aw.write_capture(aw.Capture({**capture.signals, "torque": torque}, capture.rates_hz), path)
    settle(root)
    assert data_quality_problem(aw.read_capture(path)) is None  # not bad data: scored
    scores = _scores(root, MonitorConfig(method="indicators"))
    alarms = scores[scores["alarm"].fillna(False).astype(bool)]
    assert set(alarms["axis"]) == {"axis1"}
    glitched = scores[(scores["axis"] == "axis2") & (scores["capture"] == path.name)]
    assert glitched["distance"].iloc[0] < 0.5
