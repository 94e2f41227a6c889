"""Half-Laplace threshold: the MLE against the analytic exponential quantile, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch import CalibrationError

from .naive import exponential_quantile


@pytest.mark.parametrize("percentile", [50, 75, 90, 95, 97.5, 99])
def test_threshold_of_large_sample_matches_analytic_percentile(percentile: float) -> None:
    # n = 200,000 draws: the MLE scale has relative standard error 1/sqrt(n) = 0.22 %, so a
    # tolerance of 1 % (4.5 standard errors) cannot fail by chance for this fixed seed or any other.
    sample = np.random.default_rng(7).exponential(3.0, size=200_000)
    fit = aw.fit_half_laplace(sample)
    assert fit.threshold(percentile) == pytest.approx(
        exponential_quantile(3.0, percentile / 100), rel=0.01
    )
    assert fit.threshold(alpha=1 - percentile / 100) == pytest.approx(
        fit.threshold(percentile), rel=1e-12
    )
    assert fit.ks_pvalue > 1e-3


def test_threshold_equals_empirical_quantile_of_the_fit() -> None:
    fit = aw.fit_half_laplace([1.0, 3.0])
    assert fit.scale == 2.0
    assert fit.threshold(99) == pytest.approx(exponential_quantile(2.0, 0.99), rel=1e-12)
    assert fit.pvalue(fit.threshold(99)) == pytest.approx(0.01, rel=1e-12)


def test_goodness_of_fit_flags_a_non_exponential_sample() -> None:
    sample = np.random.default_rng(8).uniform(9.0, 10.0, size=500)
    assert aw.fit_half_laplace(sample).ks_pvalue < 1e-6


@pytest.mark.parametrize(
    ("distances", "message"),
    [
        ([1.0], r"at least 2 healthy distances; got 1"),
        ([], r"at least 2 healthy distances; got 0"),
        ([1.0, np.nan], r"must be finite; distance 1 is nan"),
        ([1.0, np.inf], r"must be finite; distance 1 is inf"),
        ([1.0, -2.0], r"must be >= 0; distance 1 is -2.0"),
        ([0.0, 0.0], r"All healthy distances are 0"),
    ],
)
def test_bad_healthy_distances(distances: list[float], message: str) -> None:
    with pytest.raises(CalibrationError, match=message):
        aw.fit_half_laplace(distances)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"percentile": 100},
            r"'percentile' parameter must be a float in the range \(0, 100\). Got 100",
        ),
        (
            {"percentile": 0},
            r"'percentile' parameter must be a float in the range \(0, 100\). Got 0",
        ),
        ({"alpha": 1.0}, r"'alpha' parameter must be a float in the range \(0, 1\). Got 1.0"),
        ({}, r"exactly one of 'percentile' and 'alpha'"),
        ({"percentile": 90, "alpha": 0.1}, r"exactly one of 'percentile' and 'alpha'"),
    ],
)
def test_bad_threshold_arguments(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        aw.fit_half_laplace([1.0, 2.0]).threshold(**kwargs)
