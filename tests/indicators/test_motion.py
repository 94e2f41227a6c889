"""The motion of a capture: a signal on the torque's instants taken as it is, the acceleration
as SciPy's Savitzky-Golay derivative with its design kept."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator
from scipy.signal import savgol_filter

import axiswatch.datasets as awd
from axiswatch.indicators._motion import _derivative, _derivative_design, motion, pchip


def test_a_speed_on_the_torque_instants_is_the_logged_speed() -> None:
    capture = awd.simulate_capture("heavy", seed=2)  # speed and torque at 2 kHz, position 250 Hz
    assert capture.rates_hz["speed"] == capture.rates_hz["torque"]
    m = motion(capture)
    logged = capture.signals["speed"][: m.speed.size]
    np.testing.assert_array_equal(m.speed, logged)
    # What PCHIP through the same instants gives, to its rounding.
    own = capture.start_s + np.arange(logged.size) / capture.rates_hz["speed"]
    np.testing.assert_allclose(
        m.speed, PchipInterpolator(own, logged)(m.time_s), rtol=0, atol=1e-15
    )
    # The position, on its own 250 Hz instants, is still interpolated.
    assert m.position.size == m.speed.size > capture.signals["position"].size


@pytest.mark.parametrize(
    ("size", "window", "rate"), [(6000, 101, 2000.0), (300, 5, 100.0), (102, 101, 2000.0)]
)
def test_the_acceleration_is_scipys_savitzky_golay_derivative(
    rng: np.random.Generator, size: int, window: int, rate: float
) -> None:
    speed = np.cumsum(rng.normal(size=size)) + 50 * np.sin(np.arange(size) / 50)
    expected = savgol_filter(speed, window, 2, deriv=1, delta=1 / rate)
    np.testing.assert_allclose(
        _derivative(speed, window, rate), expected, rtol=0, atol=1e-12 * np.abs(expected).max()
    )
    assert _derivative_design(window, rate) is _derivative_design(window, rate)  # designed once


@pytest.mark.parametrize("case", range(6))
def test_pchip_is_scipys_bit_for_bit(rng: np.random.Generator, case: int) -> None:
    # Uniform knots of a 250 Hz position (from zero and from Unix seconds), uneven knots, flat
    # stretches and sign changes (slopes set to zero), a monotone ramp; points on the knots,
    # between them and beyond both ends.
    size = [750, 750, 40, 3, 25, 200][case]
    knots = (1.7e9 if case == 1 else 0.0) + np.arange(size) / 250.0
    if case in (2, 4):
        knots = np.cumsum(rng.uniform(0.1, 1.0, size))
    values = rng.normal(size=size)
    if case == 4:
        values = np.round(values, 0)  # repeated values: zero secants
    if case == 5:
        values = np.cumsum(np.abs(values))
    inside = np.linspace(knots[0], knots[-1], 8 * size)
    points = np.concatenate([[knots[0] - 0.3, knots[-1] + 0.3], knots, inside])
    expected = PchipInterpolator(knots, values, extrapolate=True)(points)
    assert np.array_equal(pchip(knots, values, points), expected)


def test_pchip_leaves_knots_that_do_not_increase_to_scipy() -> None:
    with pytest.raises(ValueError, match="strictly increasing"):
        pchip(np.array([0.0, 1.0, 1.0]), np.zeros(3), np.array([0.5]))
