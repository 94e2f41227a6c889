"""The threshold study (research package): its rules against the model's own threshold."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_limits

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._transfer import TransferDesign
from axiswatch_lab.studies.fitted_percentile_kept import RULES, robot_thresholds, thresholds


def test_the_fitted_rule_is_the_models_threshold_and_the_next_capture_is_higher() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    fleet = [
        IndicatorModel().fit(
            robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)]
        )
        for t in range(4)
    ]
    lone = fleet[0]
    limits = thresholds(lone)
    assert limits[RULES[0]] == pytest.approx(lone.threshold_, rel=1e-12)
    # 5 calibration distances: the next capture's 99th percentile is 5 (100^(1/5) - 1) / ln(100)
    # = 1.64 times the fitted one.
    assert limits[RULES[1]] / limits[RULES[0]] == pytest.approx(1.6414, rel=1e-4)
    pooled = fleet[1].use_fleet(IndicatorModel.pool(fleet))
    assert thresholds(pooled)[RULES[0]] == pytest.approx(pooled.threshold_, rel=1e-12)
    assert thresholds(pooled)[RULES[1]] >= 1.0


@pytest.mark.slow
def test_a_robots_record() -> None:
    design = TransferDesign(n_per_cell=1, n_calibration=5, robot_a_days=24)
    with threadpool_limits(1):
        record = robot_thresholds(DEVELOPMENT_ROBOTS[4], design)
    for rule in RULES:
        assert 0 <= int(record[f"{rule}: robot_a_days_over"]) <= 24 - 6  # type: ignore[call-overload]
        assert 0.0 <= float(record[f"{rule}: lone_far_same"]) <= 1.0  # type: ignore[arg-type]
    # A higher threshold never raises more alarms on the same distances.
    for key in ("robot_a_days_over", "far99", "dr99_friction", "lone_dr_same_friction"):
        assert float(record[f"{RULES[1]}: {key}"]) <= float(record[f"{RULES[0]}: {key}"])  # type: ignore[arg-type]
