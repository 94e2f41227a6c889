"""The few quantiles of the readings and checks equal NumPy's, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from axiswatch._quantiles import median, quantiles

QS = [(0.98,), (0.5, 0.9), (0.02, 0.98), (0.1, 0.9), (0.01, 0.99), (0.0, 1.0), (0.3333, 0.75)]


@pytest.mark.parametrize("size", [1, 2, 3, 10, 751, 6000])
def test_quantiles_equal_numpys_bit_for_bit(rng: np.random.Generator, size: int) -> None:
    for trial in range(20):
        values = rng.normal(size=size) * 10.0 ** rng.uniform(-6, 6)
        if trial % 2:
            values[: size // 3] = values[-1]  # ties
        for q in QS:
            expected = np.quantile(values, q)
            assert np.array_equal(quantiles(values, q), expected), (size, q)


def test_percentiles_of_the_checks_equal_numpys(rng: np.random.Generator) -> None:
    values = rng.standard_cauchy(size=6000)
    assert quantiles(values, (0.01, 0.99)) == list(np.percentile(values, [1.0, 99.0]))


def test_nan_or_inf_reads_as_numpy_reads_it(rng: np.random.Generator) -> None:
    values = rng.normal(size=100)
    values[40] = np.nan
    assert np.array_equal(quantiles(values, (0.1, 0.9)), np.quantile(values, (0.1, 0.9)), True)
    values[40] = np.inf
    with np.errstate(invalid="ignore"):  # NumPy's inf - inf at the top
        expected = np.quantile(values, (0.5, 1.0))
    assert np.array_equal(quantiles(values, (0.5, 1.0)), expected, True)
    original = values.copy()
    quantiles(values, (0.5,))
    assert np.array_equal(values, original)  # the caller's array is not reordered


def test_no_values_is_numpys_error() -> None:
    with pytest.raises(IndexError):
        quantiles(np.array([]), (0.5,))


@pytest.mark.parametrize("size", [1, 2, 3, 4, 7, 750, 751, 6000])
def test_median_equals_numpys_bit_for_bit(rng: np.random.Generator, size: int) -> None:
    for trial in range(30):
        values = rng.normal(size=size) * 10.0 ** rng.uniform(-6, 6)
        if trial % 3 == 1:
            values[: size // 2] = values[-1]  # ties
        if trial % 3 == 2:
            values = np.round(values, 1)  # the steps of time stamps: few distinct values
        assert median(values) == np.median(values) or size == 0
        assert np.float64(median(values)).tobytes() == np.median(values).tobytes()
    with_nan = rng.normal(size=size)
    with_nan[0] = np.nan
    assert np.isnan(median(with_nan))
