"""The lone-axis study (research package): its variants on a small design."""

from __future__ import annotations

import math

import pytest
from threadpoolctl import threadpool_limits

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._transfer import TransferDesign
from axiswatch_lab.studies.lone_axis_task_envelope import VARIANTS, lone_axis_robot, lone_scores

TINY = TransferDesign(n_per_cell=1, n_calibration=5, robot_a_days=40)


def test_the_product_variant_is_the_models_and_the_old_one_scores_every_capture() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    model = IndicatorModel().fit(
        robot.capture(0, seed=0), [robot.capture(0, seed=k) for k in range(1, 6)]
    )
    scores = lone_scores(model)
    same, other = (
        model.readings(robot.capture(0, seed=20)),
        model.readings(robot.capture(2, seed=20)),
    )
    product = model.assess_readings(same)
    assert scores["not compared beyond the envelope"](same) == (
        product.distance / product.threshold,
        product.alarm,
    )
    # The baseline's task: all variants agree; another task: only the old rule compares it.
    assert len({scores[v](same) for v in VARIANTS}) == 1
    assert math.isnan(scores["not compared beyond the envelope"](other)[0])
    assert math.isfinite(scores["compare every capture"](other)[0])


def test_a_model_with_a_fleet_is_refused() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    fleet = [
        IndicatorModel().fit(
            robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)]
        )
        for t in range(3)
    ]
    with pytest.raises(ValueError, match="no fleet prior"):
        lone_scores(fleet[0].use_fleet(IndicatorModel.pool(fleet)))


@pytest.mark.slow
def test_rows_of_a_robot() -> None:
    with threadpool_limits(1):
        rows = lone_axis_robot(DEVELOPMENT_ROBOTS[4], TINY)
    assert [r["variant"] for r in rows] == list(VARIANTS)
    for row in rows:
        assert row["robot_a_test_days"] == 40 - 6
        assert 0 <= int(row["robot_a_false_alarms"]) <= 34  # type: ignore[call-overload]
        for fault in ("backlash", "friction", "tooth", "bearing"):
            assert 0.0 <= float(row[f"auroc_{fault}"]) <= 1.0  # type: ignore[arg-type]
    before, after = rows[0], rows[1]
    # Robot A changes task on days 10, 20 and 30 of 40: the product compares none of days 10-40
    # (robot 4's tasks are told apart by their motion), the old rule every one.
    assert int(after["robot_a_not_scored"]) == 31  # type: ignore[call-overload]
    assert int(before["robot_a_not_scored"]) == 0  # type: ignore[call-overload]
    assert float(after["far_other"]) == 0.0  # type: ignore[arg-type]
