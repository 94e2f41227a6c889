"""Half-Laplace threshold: the MLE against the analytic exponential quantile, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import axiswatch as aw
from axiswatch import CalibrationError

from . import naive
from .naive import alarm_threshold_naive, exponential_quantile


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


@pytest.mark.parametrize("percentile", [50.0, 95.0, 99.0])
@pytest.mark.parametrize("floor", [None, 0.0, 1.0, 50.0])
def test_alarm_threshold_is_the_larger_of_fit_and_floor(
    percentile: float, floor: float | None
) -> None:
    distances = np.random.default_rng(3).exponential(2.0, size=7).tolist()
    threshold = aw.alarm_threshold(distances, percentile=percentile, floor=floor)
    # The exact formula: -mean * ln(1 - q / 100), raised to the floor.
    fitted = -float(np.mean(distances)) * np.log(1.0 - percentile / 100.0)
    assert threshold.fitted == pytest.approx(fitted, rel=1e-12)
    assert threshold.value == pytest.approx(
        alarm_threshold_naive(distances, percentile, floor), rel=1e-12
    )
    assert threshold.origin == ("floor" if floor is not None and floor > fitted else "fit")
    assert (threshold.n_healthy, threshold.percentile, threshold.floor) == (7, percentile, floor)
    assert threshold.fit == aw.fit_half_laplace(distances)


def test_alarm_threshold_tie_keeps_the_fit() -> None:
    fitted = aw.fit_half_laplace([1.0, 3.0]).threshold(99)
    threshold = aw.alarm_threshold([1.0, 3.0], floor=fitted)
    assert (threshold.value, threshold.origin) == (fitted, "fit")


def test_alarm_threshold_describes_its_origin() -> None:
    assert (
        aw.alarm_threshold([1.0, 2.0, 3.0, 4.0, 5.0], percentile=95).describe()
        == "95th pct of half-Laplace fit of 5 healthy captures"
    )
    assert (
        aw.alarm_threshold([1.0, 2.0], percentile=97.5).describe()
        == "97.5th pct of half-Laplace fit of 2 healthy captures"
    )
    assert (
        aw.alarm_threshold([1.0, 2.0], percentile=92).describe()
        == "92nd pct of half-Laplace fit of 2 healthy captures"
    )
    floored = aw.alarm_threshold([1.0, 1.0, 1.0, 1.0, 1.0], floor=12.9)
    assert floored.describe() == "task-change allowance 12.9 (fitted 4.61 on 5 healthy captures)"


@pytest.mark.parametrize("floor", [-1.0, float("nan"), float("inf"), "1"])
def test_alarm_threshold_rejects_a_bad_floor(floor: object) -> None:
    with pytest.raises(ValueError, match=r"'floor' parameter must be a finite float >= 0 or None"):
        aw.alarm_threshold([1.0, 2.0], floor=floor)  # type: ignore[arg-type]


def test_alarm_threshold_rejects_a_bad_percentile() -> None:
    with pytest.raises(ValueError, match=r"'percentile' parameter must be a float"):
        aw.alarm_threshold([1.0, 2.0], percentile=100.0)


@pytest.mark.parametrize("n", [3, 5, 20, 200])
def test_prediction_threshold_matches_the_f_quantile_of_the_loop_twin(n: int) -> None:
    distances = np.random.default_rng(n).exponential(1.7, size=n).tolist()
    fit = aw.fit_half_laplace(distances)
    assert fit.prediction_threshold(99) == pytest.approx(
        naive.prediction_threshold_naive(distances, 99), rel=1e-9
    )
    # The same as SciPy's F(2, 2n) quantile times the mean.
    assert fit.prediction_threshold(95) == pytest.approx(
        fit.scale * stats.f.ppf(0.95, 2, 2 * n), rel=1e-9
    )
    assert fit.prediction_threshold(99) > fit.threshold(99)


def test_prediction_threshold_is_exceeded_by_one_in_a_hundred_next_healthy_distances() -> None:
    # Monte Carlo over 40,000 calibrations of 5 exponential distances, one new distance each:
    # the binomial standard error of a 1 % rate is 0.05 %; the plug-in threshold's rate is
    # (1 + ln(100) / 5)^-5 = 3.8 %.
    rng = np.random.default_rng(0)
    samples = rng.exponential(1.0, size=(40_000, 6))
    calibration, new = samples[:, :5], samples[:, 5]
    scale = calibration.mean(axis=1)
    plug_in = scale * np.log(100)
    predictive = 5 * scale * np.expm1(np.log(100) / 5)
    assert np.mean(new > predictive) == pytest.approx(0.01, abs=0.002)
    assert np.mean(new > plug_in) == pytest.approx((1 + np.log(100) / 5) ** -5, abs=0.003)
    fit = aw.fit_half_laplace(calibration[0])
    assert fit.prediction_threshold(99) == pytest.approx(predictive[0], rel=1e-12)


@pytest.mark.parametrize("floor", [None, 1.0, 40.0])
def test_alarm_threshold_for_the_next_capture_matches_the_loop_twin(floor: float | None) -> None:
    distances = [1.0, 2.5, 0.7, 3.1, 1.9]
    got = aw.alarm_threshold(distances, percentile=99, floor=floor, prediction=True)
    assert got.value == pytest.approx(
        naive.alarm_threshold_naive(distances, 99, floor, prediction=True), rel=1e-9
    )
    assert got.prediction
    assert got.fitted == pytest.approx(got.fit.prediction_threshold(99), rel=1e-12)
    assert got.origin == ("floor" if floor == 40.0 else "fit")
    if got.origin == "fit":
        assert got.describe() == (
            "99th pct of the next healthy capture, half-Laplace fit of 5 healthy captures"
        )


def test_prediction_threshold_rejects_a_bad_percentile() -> None:
    with pytest.raises(ValueError, match="'percentile' parameter"):
        aw.fit_half_laplace([1.0, 2.0]).prediction_threshold(100)
