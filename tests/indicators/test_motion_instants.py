"""A signal logged on the torque's instants is taken as it is, not interpolated onto them."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator

import axiswatch.datasets as awd
from axiswatch.indicators._motion import motion


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
