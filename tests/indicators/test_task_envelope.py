"""The task envelope of the ``indicators`` method: own spreads for the baseline's task, the
fleet's allowance only when the task changed (issue 13)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._calibration import alarm_threshold
from axiswatch.datasets import Fault, draw_robot
from axiswatch.indicators._axis import (
    assess_capture,
    fit_indicator_baseline,
    read_axis_indicators,
    threshold_units,
    with_fleet,
)
from axiswatch.indicators._fleet import pool_fleet
from axiswatch.indicators._model import IndicatorModel
from axiswatch.indicators._readings import (
    motion,
    read_indicators,
    signature_distance,
    task_signature,
)
from axiswatch.indicators._spreads import TASK_ENVELOPE_FACTOR, task_envelope
from axiswatch.monitor import MonitorConfig
from tests import naive

#: A development robot of the family (lab/docs/decision-log.md, "Transfer"): a 50 Hz wrist axis.
ROBOT_SEED = 4
SAME = "same task as the baseline: own spreads"


@pytest.fixture(scope="module")
def fleet() -> list[IndicatorModel]:
    """Four axes of one robot model, axis ``a`` on task ``a``, with their fleet prior."""
    robot = draw_robot(ROBOT_SEED)
    models = [
        IndicatorModel(task_envelope_factor=TASK_ENVELOPE_FACTOR).fit_readings(
            [read_indicators(robot.capture(a, seed=k)) for k in range(6)]
        )
        for a in range(4)
    ]
    prior = pool_fleet(models)
    return [m.use_fleet(prior) for m in models]


@pytest.mark.parametrize("seed", [0, 5])  # a 500 Hz arm with a slower position; a 20 Hz axis
def test_task_signature_matches_the_naive_twin(seed: int) -> None:
    m = motion(draw_robot(seed).capture(1, seed=3))
    got = task_signature(m)
    want = naive.task_signature_naive(m.position.tolist(), m.speed.tolist())
    assert got == pytest.approx(want, rel=1e-12)


def test_the_signature_distance_is_free_of_the_units() -> None:
    robot = draw_robot(ROBOT_SEED)
    first, second = robot.capture(0, seed=1), robot.capture(1, seed=2)

    def degrees(capture: aw.Capture) -> aw.Capture:
        signals = {**capture.signals}
        for name in ("position", "speed"):
            signals[name] = np.degrees(signals[name])
        return aw.Capture(signals, capture.rates_hz)

    in_rad = signature_distance(task_signature(motion(second)), task_signature(motion(first)))
    in_degrees = signature_distance(
        task_signature(motion(degrees(second))), task_signature(motion(degrees(first)))
    )
    assert in_degrees == pytest.approx(in_rad, rel=1e-9)
    assert in_rad > 0.1


def test_a_still_axis_has_no_signature() -> None:
    capture = draw_robot(ROBOT_SEED).capture(0, seed=1)
    still = aw.Capture({**capture.signals, "speed": np.zeros_like(capture.signals["speed"])},
                       capture.rates_hz)  # fmt: skip
    assert np.isnan(task_signature(motion(still))).all()
    assert task_envelope([[math.nan] * 6] * 6) is None


def test_own_task_inside_the_envelope_other_tasks_outside(fleet: list[IndicatorModel]) -> None:
    robot = draw_robot(ROBOT_SEED)
    model = fleet[0]
    assert model.task_envelope_ == pytest.approx(2.0 * max(model.task_loo_distances_))
    for k in range(10, 14):
        assert model.assess(robot.capture(0, seed=k)).case == SAME
        for task in (1, 2, 3, 4):
            assert model.assess(robot.capture(task, seed=k)).case == "task changed: fleet allowance"


def test_a_same_task_friction_fault_is_scored_with_own_spreads_and_alarms(
    fleet: list[IndicatorModel],
) -> None:
    model = fleet[0]
    faulty = draw_robot(ROBOT_SEED).capture(0, seed=11, fault=Fault("friction", 0.6))
    verdict = model.assess(faulty)
    assert verdict.case == SAME
    assert verdict.threshold == model.own_threshold_
    assert verdict.alarm
    assert verdict.top is not None
    assert verdict.top.endswith("friction")
    assert verdict.reason().startswith(f"{SAME}; {verdict.top} (friction)")
    own_spreads = {n: model.within_[n] for n in verdict.indicators}
    shift = abs(verdict.indicators[verdict.top]["value"] - model.centre_[verdict.top])
    assert verdict.distance == pytest.approx(shift / own_spreads[verdict.top])


def test_a_task_change_is_scored_with_the_fleet_allowance(fleet: list[IndicatorModel]) -> None:
    model = fleet[0]
    assert model.fleet is not None
    verdict = model.assess(draw_robot(ROBOT_SEED).capture(2, seed=11))
    assert verdict.case == "task changed: fleet allowance"
    assert verdict.threshold == model.threshold_ >= 1.0  # in allowance units
    assert verdict.task_distance > verdict.task_envelope
    assert not verdict.alarm
    top = verdict.top
    assert top is not None
    entry = verdict.indicators[top]
    assert entry["spreads"] == pytest.approx(
        abs(entry["value"] - model.centre_[top]) / model.scales_[top]
    )
    assert entry["allowance"] == model.allowances_[top]
    assert verdict.distance == pytest.approx(entry["spreads"] / entry["allowance"])


def test_a_capture_whose_motion_cannot_be_read_is_scored_as_a_task_change(
    fleet: list[IndicatorModel],
) -> None:
    model = fleet[0]
    read = read_indicators(draw_robot(ROBOT_SEED).capture(0, seed=11))
    unread = dataclasses.replace(read, signature=())
    verdict = model.assess_readings(unread)
    assert verdict.case == "task not read from the motion: fleet allowance"
    assert verdict.threshold == model.threshold_
    assert math.isnan(verdict.task_distance)
    # A fault that would alarm against the own spreads does not, without the motion to tell.
    worn = dataclasses.replace(
        unread,
        values={
            **unread.values,
            "coulomb_friction": model.centre_["coulomb_friction"]
            + 1.1 * model.own_threshold_ * model.within_["coulomb_friction"],
        },
    )
    assert model.assess_readings(dataclasses.replace(worn, signature=read.signature)).alarm
    assert not model.assess_readings(worn).alarm


def test_fitting_captures_without_motion_give_no_envelope() -> None:
    robot = draw_robot(ROBOT_SEED)
    read = [
        dataclasses.replace(read_indicators(robot.capture(0, seed=k)), signature=())
        for k in range(6)
    ]
    model = IndicatorModel(task_envelope_factor=TASK_ENVELOPE_FACTOR).fit_readings(read)
    assert model.task_reference_ is None
    assert any("every capture is scored as a task change" in note for note in model.notes_)
    assert model.assess_readings(read_indicators(robot.capture(0, seed=9))).case.startswith(
        "task not read from the motion"
    )


def test_the_monitor_scores_in_thresholds_and_calibration_gives_exactly_one() -> None:
    robot = draw_robot(ROBOT_SEED)
    baselines = [
        fit_indicator_baseline(
            [read_axis_indicators(robot.capture(a, seed=k), None) for k in range(6)],
            [f"{a}/{k}" for k in range(6)],
            [""] * 6,
            percentile=99.0,
            task_envelope_factor=TASK_ENVELOPE_FACTOR,
        )
        for a in range(4)
    ]
    with pytest.raises(ValueError, match="'others' parameter of with_fleet must hold the models"):
        with_fleet(baselines, [baselines[0].model])
    pooled = with_fleet(baselines)[0]
    calibration = [
        threshold_units(assess_capture(pooled, robot.capture(0, seed=k), f"0/{k}", None))
        for k in range(1, 6)
    ]
    # The decision rule of the monitor (no floor: the allowance is inside the units).
    assert alarm_threshold(calibration, percentile=99.0).value == pytest.approx(1.0, rel=1e-12)
    changed = assess_capture(pooled, robot.capture(3, seed=20), "new", None)
    assert threshold_units(changed) == changed.distance / pooled.model.threshold_


def test_the_envelope_is_off_by_default(fleet: list[IndicatorModel]) -> None:
    robot = draw_robot(ROBOT_SEED)
    model = IndicatorModel().fit_readings(
        [read_indicators(robot.capture(0, seed=k)) for k in range(6)]
    )
    model.use_fleet(fleet[0].fleet)
    verdict = model.assess(robot.capture(0, seed=11, fault=Fault("friction", 0.6)))
    assert verdict.case == "no task envelope: fleet allowance"
    assert verdict.threshold == model.threshold_


def test_the_monitor_takes_the_envelope_for_the_indicators_method_only() -> None:
    assert MonitorConfig(method="indicators").model().model.task_envelope_factor is None
    config = MonitorConfig(method="indicators", task_envelope=TASK_ENVELOPE_FACTOR)
    assert config.model().model.task_envelope_factor == TASK_ENVELOPE_FACTOR
    assert config.params()["task_envelope"] == TASK_ENVELOPE_FACTOR
    assert "task_envelope" not in MonitorConfig(method="indicators").params()
    with pytest.raises(ValueError, match="'task_envelope' parameter must be None or a float > 0"):
        MonitorConfig(method="indicators", task_envelope=0.0)
    with pytest.raises(ValueError, match="for the method 'lra' instead"):
        MonitorConfig(method="lra", task_envelope=2.0)
