"""The drift test's self-starting CUSUM: its limit, its shifts, and what it finds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import kstest, norm
from scipy.stats import t as student_t

from axiswatch.indicators._drift import ReadingCusum, cusum_limit, cusum_run_length


def test_the_limit_inverts_the_run_length() -> None:
    for run_length in (50.0, 1000.0, 1e5):
        assert cusum_run_length(cusum_limit(run_length)) == pytest.approx(run_length, rel=1e-9)
    with pytest.raises(ValueError, match="more than 1 capture"):
        cusum_limit(1.0)


def test_siegmunds_run_length_matches_a_simulated_cusum() -> None:
    # The approximation against the exact process: 4,000 CUSUMs of N(0, 1) shifts.
    rng = np.random.default_rng(0)
    limit, k = cusum_limit(100.0), 0.5
    total, first = np.zeros(4000), np.zeros(4000)
    for step in range(1, 2000):
        total = np.maximum(0.0, total + rng.standard_normal(total.size) - k)
        first[(first == 0) & (total > limit)] = step
    assert (first > 0).all()
    assert first.mean() == pytest.approx(100.0, rel=0.1)


def test_the_shift_is_the_prediction_t_on_the_normal_scale() -> None:
    cusum = ReadingCusum(30, reference=[1.0, 2.0, 3.5, 2.2])
    mean, spread = np.mean(cusum.reference), np.std(cusum.reference, ddof=1)
    for value in (2.0, 5.0, 50.0, -10.0):
        t = (value - mean) / spread * math.sqrt(4 / 5)
        assert cusum.shift(value) == pytest.approx(norm.isf(student_t.sf(t, 3)), rel=1e-12)
    assert math.isnan(ReadingCusum(30, reference=[1.0, 2.0]).shift(3.0))
    assert math.isnan(ReadingCusum(30, reference=[1.0, 1.0, 1.0]).shift(3.0))


def test_healthy_shifts_are_standard_normal_whatever_the_level() -> None:
    # Self-starting: no spread is known in advance, yet each shift is N(0, 1), also once the
    # reference stops growing.
    rng = np.random.default_rng(1)
    shifts = []
    for _ in range(200):
        cusum = ReadingCusum(10)
        for value in 50.0 + 7.0 * rng.standard_normal(20):
            shift = cusum.shift(value)
            if math.isfinite(shift):
                shifts.append(shift)
            cusum.add(value)
        assert len(cusum.reference) == 10
    assert kstest(shifts, "norm").pvalue > 0.01


def test_a_rise_of_two_spreads_passes_the_limit_within_a_few_captures() -> None:
    rng = np.random.default_rng(2)
    cusum = ReadingCusum(30)
    for value in rng.standard_normal(30):
        cusum.add(value)
    limit = cusum_limit(1000.0)
    assert cusum.total < limit
    found = next(k for k in range(1, 50) if cusum.add(2.0 + rng.standard_normal()) > limit)
    assert found <= 8
