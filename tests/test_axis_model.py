"""One interface for a model of an axis: both wings' models fit and assess the same way."""

from __future__ import annotations

import math

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._axis_model import Assessment
from axiswatch.datasets import draw_robot, simulate_capture
from axiswatch.indicators._fleet import pool_fleet, pool_fleet_without


def test_assessment_says_what_moved_or_why_nothing_was_scored() -> None:
    moved = Assessment(2.0, 1.0, True, leading="coulomb_friction")
    assert moved.scored
    assert moved.reason() == "coulomb_friction moved: distance 2 against a threshold of 1"
    nothing = Assessment(math.nan, 1.0, False, explanation="not scored: no motion")
    assert not nothing.scored
    assert nothing.reason() == "not scored: no motion"


def test_health_model_fits_and_calibrates_in_one_call() -> None:
    baseline = simulate_capture("heavy", seed=1, duration_s=1.0)
    healthy = [simulate_capture("heavy", seed=s, duration_s=1.0) for s in range(2, 6)]
    probe = simulate_capture("heavy", seed=9, duration_s=1.0)
    model = aw.HealthModel.paper("pca")
    both = model.fit(baseline, healthy)
    apart = aw.HealthModel.paper("pca").fit(baseline).calibrate(healthy)
    verdict = both.assess(probe)
    assert isinstance(verdict, aw.Assessment)
    assert verdict.threshold == apart.threshold_
    assert verdict == apart.assess(probe)
    # The baseline alone: assess still refuses, as before.
    with pytest.raises(aw.CalibrationError, match="not calibrated"):
        aw.HealthModel.paper("pca").fit(baseline).assess(probe)


def test_indicator_model_assessment_is_an_assessment() -> None:
    robot = draw_robot(0)
    model = aw.IndicatorModel().fit(
        robot.capture(0, seed=0), [robot.capture(0, seed=k) for k in range(1, 6)]
    )
    verdict = model.assess(robot.capture(0, seed=9))
    assert isinstance(verdict, aw.Assessment)
    assert verdict.scored
    assert verdict.leading == verdict.top is not None
    assert verdict.reason().startswith(f"{verdict.top} (")


def test_indicator_model_takes_its_fleet_in_fit() -> None:
    robot = draw_robot(0)

    def fitted(task: int) -> aw.IndicatorModel:
        captures = [robot.capture(task, seed=k) for k in range(6)]
        return aw.IndicatorModel().fit(captures[0], captures[1:])

    others = [fitted(task) for task in (1, 2, 3)]
    captures = [robot.capture(0, seed=k) for k in range(6)]
    with_fleet = aw.IndicatorModel().fit(captures[0], captures[1:], fleet=others)
    models = [*others, fitted(0)]
    by_hand = models[-1].use_fleet(pool_fleet(models), check_against=pool_fleet_without(models, 3))
    assert with_fleet.fleet is not None
    assert with_fleet.fleet.n_axes == 4
    assert with_fleet.allowances_ == by_hand.allowances_
    assert np.isclose(with_fleet.threshold_, by_hand.threshold_)
    # Fewer than 3 axes in all: no prior, as without a fleet.
    alone = aw.IndicatorModel().fit(captures[0], captures[1:], fleet=others[:1])
    assert alone.fleet is None


def test_the_top_namespace_lists_what_the_default_reads() -> None:
    robot = draw_robot(0)
    captures = [robot.capture(0, seed=k) for k in range(6)]
    model = aw.IndicatorModel().fit(captures[0], captures[1:])
    read = set(model.centre_) | set(model.reasons_)
    assert read == set(aw.INDICATORS)
