"""The transfer study: its records on a tiny design, and the real data sets when present."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from axiswatch import Capture
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._product import Readings
from axiswatch_lab._transfer import (
    FAST_DESIGN,
    TransferDesign,
    fleet_readings,
    fleet_units,
    real_data_transfer,
    robot_transfer,
)
from lab_data import SHARED_DATA

TINY = TransferDesign(n_per_cell=1, n_calibration=2, robot_a_days=8, degradation_days=3)


@pytest.fixture(scope="module")
def tiny_record() -> dict[str, object]:
    """Robot 1's record on the tiny design: computed once for the tests that read it."""
    with threadpool_limits(1):
        return robot_transfer(DEVELOPMENT_ROBOTS[1], TINY)


@pytest.mark.slow
def test_robot_record_has_every_measure(tiny_record: dict[str, object]) -> None:
    record = tiny_record
    for fault in ("backlash", "friction", "tooth", "bearing"):
        assert 0.0 <= float(record[f"auroc_{fault}"]) <= 1.0  # type: ignore[arg-type]
        assert 0.0 <= float(record[f"oracle_{fault}"]) <= 1.0  # type: ignore[arg-type]
        alarmed = float(record[f"ramp_alarmed_{fault}"])  # type: ignore[arg-type]
        assert 0.0 <= alarmed <= 1.0
        # First alarms are at the two severities before the breakdown (1/3, 2/3), or none is.
        severity = float(record[f"ramp_severity_{fault}"])  # type: ignore[arg-type]
        assert (alarmed == 0.0 and math.isnan(severity)) or 1 / 3 <= severity <= 2 / 3
    assert record["robot_a_test_days"] == 8 - 3
    assert 0.0 < float(record["share_scored"]) <= 1.0  # type: ignore[arg-type]
    assert not math.isnan(float(record["far99"]))  # type: ignore[arg-type]


def test_no_unit_spread_is_the_one_unit_study() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[1])
    units = fleet_units(robot, FAST_DESIGN)
    assert len(units) == 7
    assert all(u == robot for u in units)

    def read(capture: Capture) -> Readings:  # the raw torque stands in for the readings
        return capture.signals["torque"]  # type: ignore[return-value]

    same = fleet_readings(robot, read, FAST_DESIGN, units=units)
    before = fleet_readings(robot, read, FAST_DESIGN)
    for t in before:
        for x, y in zip(same[t], before[t], strict=True):
            np.testing.assert_array_equal(x, y)
    spread = dataclasses.replace(FAST_DESIGN, unit_spread=0.1)
    apart = fleet_readings(robot, read, spread, units=fleet_units(robot, spread))
    assert not np.array_equal(apart[0][0], before[0][0])


@pytest.mark.slow
def test_unit_spread_changes_the_record_not_its_layout(tiny_record: dict[str, object]) -> None:
    one = tiny_record
    with threadpool_limits(1):
        many = robot_transfer(DEVELOPMENT_ROBOTS[1], dataclasses.replace(TINY, unit_spread=0.2))
    assert one.keys() == many.keys()
    assert one["robot"] == many["robot"]
    assert one["robot_a_test_days"] == many["robot_a_test_days"]
    assert any(one[k] != many[k] for k in one if k.startswith(("auroc", "oracle")))


@pytest.mark.slow
def test_every_capture_goes_through_the_given_read() -> None:
    from axiswatch import IndicatorModel

    model = IndicatorModel()
    sources: list[str] = []

    def read(capture: Capture) -> Readings:
        sources.append(str(capture.metadata["task"]))
        return model.readings(capture)

    design = dataclasses.replace(TINY, kinematics=False)
    with threadpool_limits(1):
        robot_transfer(DEVELOPMENT_ROBOTS[1], design, read=read)
    # Six tasks: the fleet's (baseline + 2) and one per health (5) each, at most 2 days of
    # each fault's degradation run before the breakdown (it stops at the first alarm), and
    # Robot A's 8 days.
    ramps = len(sources) - (6 * 3 + 6 * 5 + 8)
    assert 6 * 4 <= ramps <= 6 * 4 * 2
    assert len(set(sources)) == 6


@pytest.mark.slow
@pytest.mark.skipif(
    not (SHARED_DATA / "genesis_linear_axis" / "normal.npz").is_file(), reason="no shared data"
)
def test_real_data_rows() -> None:
    table = real_data_transfer(SHARED_DATA, datasets=("genesis_linear_axis",))
    assert set(table.dataset) == {"genesis_linear_axis"}
    assert (table.share_scored > 0.9).all()
    assert table.auroc.between(0, 1).all()


@pytest.fixture(scope="module")
def monitor_rows(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[dict[str, object]], Path]:
    """Robot 5's monitor study, every variant, friction and backlash faults: computed once for
    the two tests that read it (its scratch folder with it)."""
    from axiswatch_lab.studies.through_the_monitor import monitor_robot

    scratch = tmp_path_factory.mktemp("monitor")
    return monitor_robot(DEVELOPMENT_ROBOTS[5], scratch, faults=("friction", "backlash")), scratch


@pytest.mark.slow
def test_monitor_study_rows_of_a_low_rate_robot(
    monitor_rows: tuple[list[dict[str, object]], Path],
) -> None:
    from axiswatch_lab.studies.through_the_monitor import VARIANTS

    taken, scratch = monitor_rows
    rows = {(r["scenario"], r["method"]): r for r in taken}
    assert len(rows) == len(taken) == 12  # 3 scenarios of 4 methods, below
    assert VARIANTS == ("indicators", "indicators-envelope", "indicators-own", "mechanics")
    for scenario, files in (("healthy", 72), ("fault", 56), ("fault:backlash", 56)):
        for variant in ("indicators", "indicators-envelope"):
            indicators = rows[(scenario, variant)]
            assert indicators["files"] == files
            assert indicators["scored"] == files - 4  # every capture but the 4 baselines
        # A 20 Hz robot: the band needs 600 Hz, so every capture is rejected; the run goes on.
        mechanics = rows[(scenario, "mechanics")]
        assert (mechanics["stopped"], mechanics["scored"], mechanics["baselines"]) == ("", 0, 0)
        assert mechanics["rejected"] > 0
    assert rows[("fault", "indicators")]["faulty_monitored"] == 8
    assert list(scratch.iterdir()) == []  # the scratch folders are removed


@pytest.mark.slow
def test_monitor_study_runs_one_fault_scenario_per_kind(
    monitor_rows: tuple[list[dict[str, object]], Path],
) -> None:
    # Every method's rows, scenario by scenario; the indicators' in the order of the faults.
    taken, _ = monitor_rows
    assert [r["scenario"] for r in taken] == [
        s for s in ("healthy", "fault", "fault:backlash") for _ in range(4)
    ]
    rows = [r for r in taken if r["method"] == "indicators"]
    assert [r["scenario"] for r in rows] == ["healthy", "fault", "fault:backlash"]
    backlash = rows[2]
    assert backlash["faulty_monitored"] == 8  # axis a0's eight captures after calibration
    assert 0 <= int(backlash["detected"]) <= 8  # type: ignore[call-overload]
    assert backlash["healthy_monitored"] == 3 * 8
