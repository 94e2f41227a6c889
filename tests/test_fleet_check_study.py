"""The fleet-check study: its rows, the monitor's check, and the real hydraulic fleet when present."""

from __future__ import annotations

import math

import pytest

from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab._fleet_check import hydraulic_fleet_checks, robot_fleet_checks
from tests.conftest import SHARED_DATA


def _consistent(rows: list[dict[str, object]]) -> None:
    for row in rows:
        distance = float(row["distance"])  # type: ignore[arg-type]
        assert row["flagged"] == (math.isfinite(distance) and distance > 1.0)
        assert bool(row["check"]) == row["flagged"]


@pytest.mark.slow
def test_robot_rows_check_each_axis_both_ways() -> None:
    rows = robot_fleet_checks(DEVELOPMENT_ROBOTS[4], 4)
    assert len(rows) == 2 * 4 * 2  # scenarios x axes x rules
    _consistent(rows)
    worn = [r for r in rows if r["health"] == "worn"]
    assert [(r["scenario"], r["axis"]) for r in worn] == [("worn", "a0")] * 2
    for row in rows:
        if row["flagged"]:
            expected = "3 other axes" if row["rule"] == "leave-self-out" else "itself included"
            assert expected in str(row["check"])


@pytest.mark.skipif(
    not (SHARED_DATA / "hydraulic_actuator").is_dir(), reason="hydraulic data not present"
)
@pytest.mark.slow
def test_hydraulic_rows() -> None:
    rows = hydraulic_fleet_checks(SHARED_DATA)
    assert {(r["axis"], r["rule"]) for r in rows} == {
        (a, rule)
        for a in ("act1", "act2", "act3", "act5")
        for rule in ("itself included", "leave-self-out")
    }
    assert {r["health"] for r in rows if r["axis"] == "act3"} == {"faulty"}
    _consistent(rows)


def test_an_absent_data_set_gives_no_rows() -> None:
    assert hydraulic_fleet_checks(SHARED_DATA / "no such folder") == []
