"""The signal primitives of the indicators: angle-locked lines, running RMS and kurtosis, exact
on constructed signals and against their slow twins."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch.indicators._signals as signals
from axiswatch.indicators._signals import GRAM_MIN_RCOND
from tests import naive


def test_angle_locked_f_matches_the_hat_matrix_twin(rng: np.random.Generator) -> None:
    theta = np.sort(rng.uniform(0, 150, 1500))
    y = rng.normal(size=theta.size) + 0.3 * np.sin(5.43 * theta) + np.cos(2 * theta)
    fast = signals.angle_locked_f(y, theta, [5.43, 6.43], nuisance_orders=[1, 2, 3])
    assert fast == pytest.approx(naive.angle_locked_f(y, theta, [5.43, 6.43], [1, 2, 3]), rel=1e-8)


def test_angle_locked_f_of_noise_follows_the_f_distribution() -> None:
    # Mean of F(p, n - k) is (n - k) / (n - k - 2) ~ 1.001; 200 draws give a standard error ~0.05.
    rng = np.random.default_rng(7)
    theta = np.linspace(0, 200, 2000)
    values = [
        signals.angle_locked_f(rng.normal(size=theta.size), theta, [3.3, 4.7]) for _ in range(200)
    ]
    assert np.mean(values) == pytest.approx(1.0, abs=0.15)


def _ar1(rng: np.random.Generator, n: int, rho: float = 0.9) -> np.ndarray:
    white = rng.normal(size=n + 200)
    out = np.zeros(white.size)
    for k in range(1, white.size):  # a smooth, strongly coloured spectrum
        out[k] = rho * out[k - 1] + white[k]
    return out[200:]


def test_line_ratio_is_about_one_for_coloured_noise_and_large_for_a_line() -> None:
    # The stage's bearing set (8 orders): F has 16 degrees of freedom, so one draw's ratio
    # scatters by ~50 %; measured median over 21 draws 1.07 (the F statistic alone: 2.3, the
    # noise's colour), with the line 5.8.
    rng = np.random.default_rng(3)
    theta = np.linspace(0, 300, 6000)
    orders = [5.43 + k for k in (-2, -1, 0, 1, 2)] + [10.86 + k for k in (-1, 0, 1)]
    draws = [_ar1(rng, theta.size) for _ in range(21)]
    assert (
        0.75
        < np.median([signals.line_ratio(x, theta, orders, [-0.25, 0.25]) for x in draws])
        < 1.35
    )
    line = draws[0] + 0.5 * np.cos(5.43 * theta)
    assert signals.line_ratio(line, theta, orders, [-0.25, 0.25]) > 3


def test_waves_by_recurrence_match_the_trigonometric_functions() -> None:
    from axiswatch.indicators._signals import _harmonics

    theta = np.linspace(0, 3000, 4000)  # 480 motor revolutions
    orders = [k / 5 for k in range(15, 41) if k % 5]  # on a grid: built by recurrence
    phases = np.multiply.outer(theta, np.array(orders))
    expected = np.concatenate([np.sin(phases), np.cos(phases)], axis=1)
    np.testing.assert_allclose(_harmonics(theta, orders, None), expected, rtol=0, atol=1e-10)
    direction = np.sign(np.sin(theta))
    signed = _harmonics(theta, orders, direction)
    np.testing.assert_allclose(
        signed[:, expected.shape[1] :], expected * direction[:, None], atol=1e-10
    )


@pytest.mark.parametrize("width", [1, 2, 7, 40])
def test_running_rms_matches_exact_loop(width: int) -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=300) * np.exp(rng.normal(size=300))
    np.testing.assert_allclose(
        signals.running_rms(x, width), naive.running_rms(x, width), rtol=1e-9, atol=1e-12
    )


def test_running_rms_never_nan_after_a_burst() -> None:
    # A burst followed by near-silence: the running sum's cancellation gave a negative mean
    # (-5e-77) and a NaN envelope; the exact value is tiny and non-negative.
    x = np.concatenate([np.full(50, 1e-38), np.full(200, 1e-80), np.zeros(100)])
    rms = signals.running_rms(x, 20)
    assert np.all(np.isfinite(rms))
    assert np.all(rms >= 0)
    exact = naive.running_rms(x, 20)
    # Clipping error bounded by the running sum's round-off: width * eps * max(x**2), under the root.
    assert np.max(np.abs(rms**2 - exact**2)) <= 20 * np.finfo(float).eps * np.max(x**2)


def test_pearson_kurtosis_matches_scipy() -> None:
    from scipy.stats import kurtosis

    rng = np.random.default_rng(11)
    for x in (rng.normal(size=500), rng.standard_t(3, size=2000), rng.uniform(size=7)):
        assert signals.pearson_kurtosis(x) == pytest.approx(kurtosis(x, fisher=False), rel=1e-12)
    assert np.isnan(signals.pearson_kurtosis(np.ones(10)))


def test_bearing_waves_by_class_recurrence_match_the_trigonometric_functions() -> None:
    from axiswatch.indicators._signals import _harmonics, bearing_orders

    theta = np.linspace(0, 3000, 4000)
    orders = bearing_orders(5.43) + [o + 0.25 for o in bearing_orders(5.43)]  # not on one grid
    phases = np.multiply.outer(theta, np.array(orders))
    expected = np.concatenate([np.sin(phases), np.cos(phases)], axis=1)
    np.testing.assert_allclose(_harmonics(theta, orders, None), expected, rtol=0, atol=1e-10)


def test_line_ratio_matches_the_hat_matrix_twin(rng: np.random.Generator) -> None:
    # The fast path (Gram matrix and Cholesky, shifted waves by one product) against nested
    # regressions with pseudo-inverses, on band-limited noise with a bearing line.
    theta = np.sort(rng.uniform(0, 400, 2500))
    y = _ar1(rng, theta.size) + 0.2 * np.cos(5.43 * theta) + np.sin(3 * theta)
    orders = signals.bearing_orders(5.43)
    whole = list(signals.WHOLE_ORDERS)
    expected = naive.angle_locked_f(y, theta, orders, whole) / np.mean(
        [naive.angle_locked_f(y, theta, [o + d for o in orders], whole) for d in (-0.25, 0.25)]
    )
    assert signals.bearing_lines(y, theta, 5.43) == pytest.approx(expected, rel=1e-8)


def test_ill_conditioned_waves_take_the_qr_path(rng: np.random.Generator) -> None:
    # Over 3 motor revolutions, orders 0.01 apart are nearly the same wave: the Gram matrix's
    # reciprocal condition falls below GRAM_MIN_RCOND and the statistic is computed by QR; the
    # result matches the exact path and the hat-matrix twin.
    from axiswatch.indicators._signals import _harmonics, _NuisanceFree

    theta = np.linspace(0, 6 * np.pi, 600)
    y = rng.normal(size=theta.size)
    orders = [10.0 + 0.01 * k for k in range(4)]
    free = _NuisanceFree(y, theta, [1, 2, 3], None)
    tests = _harmonics(theta, orders, None)
    gram = tests.T @ tests
    assert 1.0 / np.linalg.cond(gram) < GRAM_MIN_RCOND
    fast = free.f_statistic(orders)
    assert fast == pytest.approx(free.f_statistic(orders, exact=True), rel=1e-12)
    assert fast == pytest.approx(naive.angle_locked_f(y, theta, orders, [1, 2, 3]), rel=1e-6)


def test_gram_path_matches_the_qr_path_on_stage_sized_waves(rng: np.random.Generator) -> None:
    from axiswatch.indicators._signals import _NuisanceFree

    theta = np.sort(rng.uniform(0, 600, 900))
    y = _ar1(rng, theta.size)
    free = _NuisanceFree(y, theta, signals.WHOLE_ORDERS, None)
    tooth = [k / 5 for k in range(15, 41) if k % 5]
    assert free.f_statistic(tooth) == pytest.approx(free.f_statistic(tooth, exact=True), rel=1e-9)


def test_stacked_shifts_give_each_block_its_own_statistic(rng: np.random.Generator) -> None:
    # The bearing's waves and their two shifts, one block of rows each, share one product with
    # the nuisance waves and one with the residual: each block's F as if computed alone.
    from axiswatch.indicators._signals import _NuisanceFree, _shifted_rows, _wave_rows

    theta = np.sort(rng.uniform(0, 400, 2500))
    y = _ar1(rng, theta.size) + 0.2 * np.cos(5.43 * theta) + np.sin(3 * theta)
    free = _NuisanceFree(y, theta, signals.WHOLE_ORDERS, None)
    rows = _wave_rows(theta, signals.bearing_orders(5.43))
    half = np.empty((rows.shape[0] // 2, theta.size))
    blocks = [rows] + [
        _shifted_rows(rows, theta, d, np.empty_like(rows), half).copy() for d in (-0.25, 0.25)
    ]
    stacked = free._f_stacked(np.concatenate(blocks), rows.shape[0])
    np.testing.assert_allclose(stacked, [free._f(b) for b in blocks], rtol=1e-12)
    # Orders 0.01 apart over 3 revolutions: each block takes the QR path, as alone.
    theta = np.linspace(0, 6 * np.pi, 600)
    free = _NuisanceFree(rng.normal(size=theta.size), theta, [1, 2, 3], None)
    rows = _wave_rows(theta, [10.0 + 0.01 * k for k in range(4)])
    stacked = free._f_stacked(np.concatenate([rows, rows[::-1].copy()]), rows.shape[0])
    alone = [free._f(rows, exact=True), free._f(rows[::-1].copy(), exact=True)]
    np.testing.assert_allclose(stacked, alone, rtol=1e-12)


def test_a_shift_and_its_opposite_from_one_set_of_products(rng: np.random.Generator) -> None:
    from axiswatch.indicators._signals import _shifted_pair, _shifted_rows, _wave_rows
    from axiswatch.indicators._wave_sums import Phasors

    theta = np.sort(rng.uniform(0, 400, 2500))
    rows = _wave_rows(theta, signals.bearing_orders(5.43))
    half = np.empty((rows.shape[0] // 2, theta.size))
    for phasors in (None, Phasors(theta)):
        up, down = np.empty_like(rows), np.empty_like(rows)
        _shifted_pair(rows, theta, 0.25, up, down, half, phasors)
        for d, moved in ((0.25, up), (-0.25, down)):
            alone = _shifted_rows(rows, theta, d, np.empty_like(rows), half, phasors)
            assert np.array_equal(moved, alone)
