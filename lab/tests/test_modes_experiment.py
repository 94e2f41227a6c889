"""``axiswatch experiment modes`` on one development robot, its runs cut to the smallest."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from lab_cli import run

#: Robot A's days, a growing run's days.
ROBOT_A_DAYS, GROWING_DAYS = 20, 21


def test_modes_prints_and_writes_one_row_per_scenario_and_method(tmp_path: Path) -> None:
    result = run(
        *("experiment", "modes", "--out", tmp_path, "--robots", "0"),
        *("--robot-a-days", ROBOT_A_DAYS, "--growing-days", GROWING_DAYS),
        *("--faults", "friction", "--monitor-faults", "friction"),
        *("--cases", "robot-a,growing,fault-at-change,monitor,real-data"),
        *("--data", tmp_path / "absent"),
    )
    assert result.returncode == 0, result.stderr
    assert f"no real data under {tmp_path / 'absent'}: skipped" in result.stdout
    table = pd.read_csv(tmp_path / "modes.csv")
    assert list(zip(table["scenario"], table["method"], strict=True)) == [
        ("robot A", "modes"),
        ("robot A", "default"),
        ("growing friction", "modes"),
        ("fault at change friction", "modes"),
        ("monitor healthy", "default"),
        ("monitor healthy", "modes"),
        ("monitor friction", "default"),
        ("monitor friction", "modes"),
    ]
    assert "fault at change friction" in result.stdout
    assert (table["robots"] == 1).all()
    for rate in ("detection", "false_alarm_rate"):
        assert table[rate].dropna().between(0, 1).all()
    assert (table["detected"] <= table["faulty"]).all()
    assert (table["false_alarms"] <= table["healthy"]).all()
    quiet = (table["false_alarms"] == 0).astype(int)
    assert (table["robots_quiet"] == quiet).all()
    rows = table.set_index(["scenario", "method"])
    # The library gives every day a verdict; the default, fitted on 6 days, one or none.
    assert rows.loc[("robot A", "modes"), ["healthy", "no_verdict"]].tolist() == [ROBOT_A_DAYS, 0]
    default = rows.loc[("robot A", "default")]
    assert default["healthy"] + default["no_verdict"] == ROBOT_A_DAYS - 6
    # Onset on day 9 (3/7 of 21; the change on day 6 plus 3): days 0-9 healthy, severity
    # (day - 9) / 11 past 0.3 from day 13.
    for scenario in ("growing friction", "fault at change friction"):
        assert rows.loc[(scenario, "modes"), ["faulty", "healthy"]].tolist() == [8, 10]
    for method in ("default", "modes"):  # 4 axes: 12 captures each after calibration, then 8
        assert rows.loc[("monitor healthy", method), "healthy"] == 48
        assert rows.loc[("monitor friction", method), ["faulty", "healthy"]].tolist() == [8, 24]
    robots = pd.read_csv(tmp_path / "robots.csv")
    assert (robots["robot"] == "robot0").all()
    sums = robots.groupby(["scenario", "method"], sort=False)[["detected", "false_alarms"]].sum()
    assert sums.reset_index().equals(table[["scenario", "method", "detected", "false_alarms"]])
    before = (robots["first_alarm_severity"] < 1.0).groupby(
        [robots["scenario"], robots["method"]], sort=False
    )
    assert before.sum().tolist() == table["alarmed_before_breakdown"].tolist()


def test_modes_rejects_an_unknown_case_in_one_line(tmp_path: Path) -> None:
    result = run("experiment", "modes", "--out", tmp_path, "--cases", "robot-a,robot-b")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "error: --cases takes some of robot-a, growing, fault-at-change, within, cross-task, "
        "monitor, real-data; got 'robot-b'."
    ]


def test_modes_measures_separation_within_a_mode_and_across_tasks(tmp_path: Path) -> None:
    result = run(
        *("experiment", "modes", "--out", tmp_path, "--robots", "0"),
        *("--faults", "friction", "--cases", "within,cross-task", "--test-captures", 3),
    )
    assert result.returncode == 0, result.stderr
    table = pd.read_csv(tmp_path / "modes.csv").set_index("scenario")
    assert list(table.index) == [
        "within mode friction",
        "within mode healthy",
        "cross-task friction",
        "cross-task healthy",
    ]
    # Within a mode: 4 tasks x 3 captures; across tasks: 3 other tasks x 3, one replay a fault.
    assert list(table["faulty"]) == [12, 0, 9, 0]
    assert list(table["healthy"]) == [0, 12, 0, 9]
    assert table["auroc"].iloc[[0, 2]].between(0, 1).all()
    assert table["auroc"].iloc[[1, 3]].isna().all()
    assert (table["detected"] <= table["faulty"]).all()
    assert (table["false_alarms"] <= table["healthy"]).all()
