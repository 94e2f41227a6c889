"""Filters designed once per parameters: the cached design is SciPy's, unchanged."""

from __future__ import annotations

import numpy as np
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
