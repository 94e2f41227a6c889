"""The friction-errors study (lab, i15a): its standard errors are those of the textbook formula,
its ``current`` variant scores as the product, and a looser friction reading is never further."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lab_naive as naive
from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._product import MOVING_FRACTION, Motion, motion
from axiswatch_lab.studies.allowance_per_indicator import _models
from axiswatch_lab.studies.friction_standard_errors import (
    Taken,
    _reference_errors,
    _take,
    error_distance,
    friction_standard_errors,
)


def _standard_errors_naive(m: Motion) -> tuple[float, float]:
    return naive.friction_standard_errors_naive(
        m.position.tolist(),
        m.speed.tolist(),
        m.acceleration.tolist(),
        m.torque.tolist(),
        MOVING_FRACTION,
    )


@pytest.mark.parametrize("task", [0, 1])
def test_standard_errors_match_the_normal_equations(task: int) -> None:
    m = motion(draw_robot(DEVELOPMENT_ROBOTS[4]).capture(task, seed="se"))
    se = friction_standard_errors(m)
    coulomb, viscous = _standard_errors_naive(m)
    assert se["coulomb_friction"] == pytest.approx(coulomb, rel=1e-6)
    assert se["viscous_friction"] == pytest.approx(viscous, rel=1e-6)


def test_constant_speed_moves_give_looser_friction_readings() -> None:
    # Development robot 4's task 1 moves at constant speed for 80 % of each move, task 0 not:
    # the viscous coefficient is far less determined there, and its standard error says so.
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    se = {
        t: np.median(
            [
                friction_standard_errors(motion(robot.capture(t, seed=k)))["viscous_friction"]
                for k in range(4)
            ]
        )
        for t in (0, 1)
    }
    assert se[1] > 5 * se[0]


def test_one_way_capture_has_no_friction_errors() -> None:
    t = np.arange(0, 2, 0.01)
    q = 0.5 * (1 - np.cos(np.pi * t / 2))
    v = np.gradient(q, 0.01)
    se = friction_standard_errors(Motion(t, q, v, np.gradient(v, 0.01), 3 + 2 * v, 100.0))
    assert math.isnan(se["coulomb_friction"])
    assert math.isnan(se["viscous_friction"])


@pytest.mark.slow
def test_current_scores_as_the_product_and_errors_only_lower_distances() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    take = _take(IndicatorModel().readings)
    fits = {t: [take(robot.capture(t, seed=f"fit{k}")) for k in range(5)] for t in range(4)}
    models, _ = _models({t: [x[0] for x in f] for t, f in fits.items()}, None, 99.0)
    tests: list[Taken] = [
        take(robot.capture(t, seed=f"test{t}", fault=fault))
        for t in range(4)
        for fault in (None, Fault("friction", 0.8))
    ]
    compared = 0
    for b, model in models.items():
        ref = _reference_errors(fits[b])
        for x in tests:
            product = model.assess_readings(x[0])
            current = error_distance(model, ref, x, "current")
            loose = error_distance(model, ref, x, "friction errors")
            if math.isfinite(product.distance):
                assert current == pytest.approx(product.distance / product.threshold, rel=1e-12)
                assert loose <= current + 1e-12
                compared += 1
    assert compared >= 24
