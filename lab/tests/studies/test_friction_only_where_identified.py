"""The friction-identifiability study (lab, i15e): the speed column's variance inflation is the
textbook one, a constant-speed task is declared not identified, a minimum-jerk one is read as the
product reads it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch import Capture
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._product import MOVING_FRACTION, Motion, motion, read_indicators
from axiswatch_lab.studies.friction_only_where_identified import (
    NOT_SEPARABLE,
    VIF_BOUND,
    _design,
    identified_friction,
    identified_readings,
    speed_inflation,
)

RATE = 100.0


def _moves(profile: np.ndarray, n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Back-and-forth moves of one speed profile, each followed by a pause of a fifth of it."""
    pause = np.zeros(profile.size // 5)
    v = np.concatenate([np.concatenate([d * profile, pause]) for d in [1.0, -1.0] * n])
    q = np.cumsum(v) / RATE
    return np.arange(v.size) / RATE, q, v


def _trapezoid(ramp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.arange(0.0, 1.0, 1 / RATE)
    return _moves(np.clip(np.minimum(s / ramp, (1 - s) / ramp), 0.0, 1.0))


def _minimum_jerk() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.arange(0.0, 1.0, 1 / RATE)
    return _moves(30 * s**2 * (1 - s) ** 2 / 1.875)


def _capture(t: np.ndarray, q: np.ndarray, v: np.ndarray, noise: float = 0.0) -> Capture:
    a = np.gradient(v, t)
    rng = np.random.default_rng(7)
    torque = 3 * np.sign(v) + 2 * v + 0.5 * a + 0.4 * q + rng.normal(scale=noise, size=t.size)
    rates = dict.fromkeys(("position", "speed", "torque"), RATE)
    return Capture({"position": q, "speed": v, "torque": torque}, rates)


def _inflation_naive(x: np.ndarray) -> float:
    """VIF from the inverse of the correlation matrix of the non-constant columns."""
    varying = [k for k in range(x.shape[1]) if np.std(x[:, k]) > 0]
    correlation = np.corrcoef(x[:, varying], rowvar=False)
    return float(np.linalg.inv(correlation)[varying.index(1), varying.index(1)])


@pytest.mark.parametrize("shape", ["trapezoid", "minimum jerk"])
def test_speed_inflation_is_the_inverse_correlation_diagonal(shape: str) -> None:
    t, q, v = _trapezoid(0.1) if shape == "trapezoid" else _minimum_jerk()
    m = motion(_capture(t, q, v, noise=0.1))
    moving = np.abs(m.speed) > MOVING_FRACTION * np.max(np.abs(m.speed))
    x = _design(m, moving)
    assert speed_inflation(x) == pytest.approx(_inflation_naive(x), rel=1e-8)


def test_constant_speed_moves_are_not_identified_though_the_product_reads_them() -> None:
    # 80 % of each move at one speed: the product's spread test (std|v| > 0.1 mean|v|) passes,
    # the speed column's VIF is above the textbook 10, so neither coefficient is read.
    cap = _capture(*_trapezoid(0.1), noise=0.1)
    m = motion(cap)
    moving = np.abs(m.speed) > MOVING_FRACTION * np.max(np.abs(m.speed))
    assert speed_inflation(_design(m, moving)) > VIF_BOUND
    product = read_indicators(cap)
    assert math.isfinite(product.values["viscous_friction"])
    r = identified_readings(cap, product)
    assert math.isnan(r.values["coulomb_friction"])
    assert math.isnan(r.values["viscous_friction"])
    assert r.reasons["coulomb_friction"] == r.reasons["viscous_friction"] == NOT_SEPARABLE
    assert r.values["load_forward"] == product.values["load_forward"]


def test_at_speed_reads_the_friction_at_the_cruise_speed() -> None:
    # v dropped: the sign(v) coefficient takes F_c + F_v |v| near the cruise speed (1 here),
    # less the ramps' share: between F_c + 0.8 F_v and F_c + F_v.
    t, q, v = _trapezoid(0.1)
    a = np.gradient(v, t)
    m = Motion(t, q, v, a, 3 * np.sign(v) + 2 * v + 0.5 * a, RATE)
    coulomb, viscous, why = identified_friction(m, at_speed=True)
    assert 3 + 0.8 * 2 < coulomb < 3 + 2
    assert math.isnan(viscous)
    assert why == NOT_SEPARABLE


def test_minimum_jerk_moves_are_read_as_the_product_reads_them() -> None:
    cap = _capture(*_minimum_jerk(), noise=0.1)
    product = read_indicators(cap)
    r = identified_readings(cap, product)
    assert r == product
    assert r.values["coulomb_friction"] == pytest.approx(3.0, abs=0.05)
    assert r.values["viscous_friction"] == pytest.approx(2.0, abs=0.05)


def test_one_way_capture_keeps_the_products_reason() -> None:
    t = np.arange(0, 2, 1 / RATE)
    q = 0.5 * (1 - np.cos(np.pi * t / 2))
    cap = _capture(t, q, np.gradient(q, t))
    product = read_indicators(cap)
    assert identified_readings(cap, product) == product
    assert "both directions" in product.reasons["coulomb_friction"]


def test_development_robot_4s_constant_speed_task_is_the_one_not_identified() -> None:
    # Task 1 moves at constant speed for 80 % of each move, task 0 is minimum-jerk (i15a's
    # diagnosis of Robot A's friction days): only task 1 is over the textbook bound.
    robot = draw_robot(DEVELOPMENT_ROBOTS[4])
    for task, over in ((0, False), (1, True)):
        for seed in ("vif-a", "vif-b"):
            m = motion(robot.capture(task, seed=seed))
            moving = np.abs(m.speed) > MOVING_FRACTION * np.max(np.abs(m.speed))
            assert (speed_inflation(_design(m, moving)) > VIF_BOUND) is over
