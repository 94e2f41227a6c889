"""Filters designed once per parameters: the cached design is SciPy's, unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter

from axiswatch.indicators._signals import butter_sos


def test_cached_designs_equal_scipys_and_are_shared() -> None:
    np.testing.assert_array_equal(
        butter_sos(4, (40.0, 300.0), 2000.0),
        butter(4, [40.0, 300.0], btype="bandpass", fs=2000.0, output="sos"),
    )
    np.testing.assert_array_equal(
        butter_sos(2, 10.0, 2000.0), butter(2, 10.0, fs=2000.0, output="sos")
    )
    assert butter_sos(2, 10.0, 2000.0) is butter_sos(2, 10.0, 2000.0)
    assert butter_sos(2, 10.0, 1000.0) is not butter_sos(2, 10.0, 2000.0)


def test_zero_phase_is_scipys_filtfilt_bit_for_bit() -> None:
    from scipy.signal import sosfiltfilt

    from axiswatch.indicators._signals import zero_phase

    x = np.random.default_rng(0).normal(size=3001).cumsum()
    for sos in (butter_sos(4, (40.0, 300.0), 2000.0), butter_sos(2, 10.0, 2000.0)):
        assert np.array_equal(zero_phase(sos, x), sosfiltfilt(sos, x))
        assert np.array_equal(zero_phase(sos, x, 7), sosfiltfilt(sos, x, padlen=7))
        assert np.array_equal(zero_phase(sos, x, 0), sosfiltfilt(sos, x, padlen=0))
        short = x[:30]  # the longest pad a signal allows: its length less one
        assert np.array_equal(zero_phase(sos, short, 29), sosfiltfilt(sos, short, padlen=29))
    with pytest.raises(ValueError, match="must be greater than padlen, 27"):
        zero_phase(butter_sos(4, (40.0, 300.0), 2000.0), x[:27])
