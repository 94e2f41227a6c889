"""The mechanics indicators: exact on constructed signals, task-invariant and fault-sensitive on
the simulator (the figures in the comments are measured, lab/docs/decision-log.md)."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch._mechanics
import axiswatch.datasets as awd
from axiswatch._mechanics import ENERGY_LEVELS
from axiswatch.exceptions import CaptureError
from axiswatch.indicators._signals import GRAM_MIN_RCOND
from tests import naive


def _moves_out_and_back(n_cycles: int = 3, rate_hz: float = 1000.0) -> tuple[np.ndarray, ...]:
    t = np.arange(0, 2.0 * n_cycles + 0.5, 1.0 / rate_hz)
    q = np.zeros_like(t)
    for c in range(n_cycles):
        for t0, sign in ((2.0 * c + 0.25, 1.0), (2.0 * c + 1.25, -1.0)):
            q += sign * 0.4 * (1 - np.cos(np.pi * np.clip((t - t0) / 0.6, 0, 1)))
    v = np.gradient(q, 1.0 / rate_hz)
    return t, q, v, np.gradient(v, 1.0 / rate_hz)


def test_viscous_friction_recovers_the_coefficient_whatever_coulomb_inertia_and_load() -> None:
    _, q, v, a = _moves_out_and_back()
    for inertia, coulomb, load in ((2.0, 7.0, 5.0), (9.0, 30.0, -40.0)):
        tau = inertia * a + 4.0 * v + coulomb * np.sign(v) + load
        # Exact up to rounding: the trapezoid rule makes the inertia's work telescope.
        assert aw._mechanics.viscous_friction(q, v, tau, 1000.0) == pytest.approx(4.0, rel=1e-9)


def test_viscous_friction_matches_the_loop_twin(rng: np.random.Generator) -> None:
    _, q, v, a = _moves_out_and_back()
    tau = 3.0 * a + 2.5 * v + 6.0 * np.sign(v) + 0.3 * rng.normal(size=v.size)
    assert aw._mechanics.viscous_friction(q, v, tau, 1000.0) == pytest.approx(
        naive.viscous_friction(q, v, tau, 1000.0, list(ENERGY_LEVELS)), rel=1e-9
    )


def test_a_move_cut_by_the_capture_keeps_the_windows_inside_it() -> None:
    # The first move runs from sample 250 to 850, peak at 550. Cut at 300 (speed 26 % of the
    # peak, rising): levels 0.3-0.75 remain; cut at 480 (94 %): no two levels remain, the move is
    # dropped; cut at 650 (after the peak): dropped. The estimate stays exact in each case.
    _, q, v, a = _moves_out_and_back()
    tau = 5.0 * a + 4.0 * v + 9.0 * np.sign(v)
    for cut in (300, 480, 650):
        assert aw._mechanics.viscous_friction(q[cut:], v[cut:], tau[cut:], 1000.0) == pytest.approx(
            4.0, rel=1e-9
        )
    # That move alone: usable when cut at 300, not at 480.
    alone = slice(300, 950)
    assert aw._mechanics.viscous_friction(q[alone], v[alone], tau[alone], 1000.0) == pytest.approx(
        4.0
    )
    assert np.isnan(aw._mechanics.viscous_friction(q[480:950], v[480:950], tau[480:950], 1000.0))


def test_viscous_friction_is_nan_without_a_complete_move() -> None:
    v = np.linspace(0.0, 1.0, 500)  # accelerating until the capture ends
    assert np.isnan(aw._mechanics.viscous_friction(np.cumsum(v) / 1000, v, v, 1000.0))


def test_moves_merges_noise_gaps_and_drops_blips() -> None:
    v = np.r_[np.zeros(50), np.ones(60), [0.0], np.ones(60), np.zeros(50), -np.ones(5), np.zeros(9)]
    assert aw._mechanics.moves(v, min_gap=10) == [(50, 171)]


def test_angle_locked_f_matches_the_hat_matrix_twin(rng: np.random.Generator) -> None:
    theta = np.sort(rng.uniform(0, 150, 1500))
    y = rng.normal(size=theta.size) + 0.3 * np.sin(5.43 * theta) + np.cos(2 * theta)
    fast = aw._mechanics.angle_locked_f(y, theta, [5.43, 6.43], nuisance_orders=[1, 2, 3])
    assert fast == pytest.approx(naive.angle_locked_f(y, theta, [5.43, 6.43], [1, 2, 3]), rel=1e-8)


def test_angle_locked_f_of_noise_follows_the_f_distribution() -> None:
    # Mean of F(p, n - k) is (n - k) / (n - k - 2) ~ 1.001; 200 draws give a standard error ~0.05.
    rng = np.random.default_rng(7)
    theta = np.linspace(0, 200, 2000)
    values = [
        aw._mechanics.angle_locked_f(rng.normal(size=theta.size), theta, [3.3, 4.7])
        for _ in range(200)
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
        < np.median([aw._mechanics.line_ratio(x, theta, orders, [-0.25, 0.25]) for x in draws])
        < 1.35
    )
    line = draws[0] + 0.5 * np.cos(5.43 * theta)
    assert aw._mechanics.line_ratio(line, theta, orders, [-0.25, 0.25]) > 3


@pytest.fixture(scope="module")
def stage() -> aw.MechanicsStage:
    return aw.MechanicsStage().fit(awd.simulate_capture("short_fast", seed=11))


def _shift(stage: aw.MechanicsStage, capture: aw.Capture) -> np.ndarray:
    assert stage.baseline_rows_ is not None
    return stage.transform(capture).X.mean(axis=0) - stage.baseline_rows_.mean(axis=0)


@pytest.mark.parametrize("task", ["short_fast", "long_slow", "palletize"])
def test_each_fault_raises_its_own_indicator_on_every_task(
    stage: aw.MechanicsStage, task: str
) -> None:
    # Shifts in units of the healthy cross-task spread, measured: friction 5.8-6.9 (viscous),
    # tooth 2.5-7.7 (the larger of impulsiveness and tooth lines), bearing 4.4-10.8 (bearing
    # lines); a healthy task change moves no column by more than 2.4.
    column = {name: j for j, name in enumerate(aw._mechanics.COLUMNS)}

    def shift(kind: str) -> np.ndarray:
        return _shift(stage, awd.simulate_capture(task, fault=awd.Fault(kind, 0.6), seed=21))  # type: ignore[arg-type]

    assert shift("friction")[column["viscous_friction"]] > 4.0
    tooth = shift("tooth")
    assert max(tooth[column["impulsiveness"]], tooth[column["tooth_lines"]]) > 2.0
    assert shift("bearing")[column["bearing_lines"]] > 3.5
    # Backlash is the weakest: the larger of impulsiveness and reversal bursts, measured
    # 4.1 (short_fast), 1.2 (long_slow), 1.8 (palletize).
    backlash = shift("backlash")
    assert max(backlash[column["impulsiveness"]], backlash[column["reversal_bursts"]]) > 1.0


def test_healthy_task_changes_stay_within_a_few_spreads(stage: aw.MechanicsStage) -> None:
    # Measured worst case over these tasks: +2.36 spreads (viscous friction, heavy: 10 kg payload).
    for task in ("long_slow", "heavy", "inspect", "palletize"):
        assert np.all(_shift(stage, awd.simulate_capture(task, seed=31)) < 3.0), task


def test_reversal_bursts_are_nan_where_the_torque_does_not_reverse() -> None:
    t = np.arange(0, 1, 1e-3)
    torque = 20 + np.sin(2 * np.pi * 3 * t)  # gravity holds one flank all the time
    assert np.isnan(aw._mechanics.reversal_bursts(torque, np.ones_like(t), 1000.0, t >= 0))


def test_reversal_bursts_only_count_the_selected_samples() -> None:
    t = np.arange(0, 2, 1e-3)
    torque = 50 * np.sin(2 * np.pi * t)
    band = np.zeros_like(t)
    band[[500, 1000, 1500]] = [3.0, 30.0, 3.0]
    late = t > 1.2  # only the reversal at 1.5 s
    expected = 3.0 / np.sqrt(2 * np.pi * 50)
    assert aw._mechanics.reversal_bursts(torque, band, 1000.0, late) == pytest.approx(
        expected, rel=1e-3
    )


def test_scales_of_the_wrong_length_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"'scales' parameter of MechanicsStage must be 5"):
        aw.MechanicsStage(scales=(1.0, 1.0)).fit(awd.simulate_capture("short_fast", seed=0))


def test_band_beyond_nyquist_is_rejected() -> None:
    with pytest.raises(CaptureError, match=r"'band_hz' of MechanicsStage, \(40.0, 1500.0\), needs"):
        aw.MechanicsStage(band_hz=(40.0, 1500.0)).fit(awd.simulate_capture("short_fast", seed=0))
    with pytest.raises(ValueError, match=r"'band_hz' parameter of MechanicsStage must satisfy"):
        aw.MechanicsStage(band_hz=(300.0, 40.0)).fit(awd.simulate_capture("short_fast", seed=0))


def test_too_short_capture_is_rejected() -> None:
    short = awd.simulate_capture("short_fast", duration_s=0.1, seed=0)
    with pytest.raises(aw.CaptureError, match="too short for the mechanics indicators"):
        aw.MechanicsStage().fit(short)


def test_baseline_without_motion_is_rejected() -> None:
    at_rest = aw.Capture(
        {"position": np.zeros(250), "speed": np.zeros(2000), "torque": np.ones(2000)},
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        source="rest.parquet",
    )
    with pytest.raises(
        aw.CaptureError,
        match=r"rest\.parquet: the baseline must show a usable move in both directions",
    ):
        aw.MechanicsStage().fit(at_rest)


def test_a_capture_missing_a_direction_takes_the_baselines_row(stage: aw.MechanicsStage) -> None:
    capture = awd.simulate_capture("long_slow", duration_s=0.9, phase_s=0.0, seed=3)  # forward only
    X = stage.transform(capture).X
    assert stage.baseline_rows_ is not None
    np.testing.assert_array_equal(X[1], stage.baseline_rows_[1])


def test_reversal_bursts_match_the_loop_twin() -> None:
    capture = awd.simulate_capture("long_fast", fault=awd.Fault("backlash", 0.6), seed=4)
    signals, rate = aw.resample_capture(capture, ("position", "speed", "torque"))
    speed, torque = signals[:, 1], signals[:, 2]
    from scipy.signal import butter, sosfiltfilt

    band = sosfiltfilt(butter(4, [40, 300], btype="bandpass", fs=rate, output="sos"), torque)
    where = np.abs(speed) > 0.1 * np.abs(speed).max()
    fast = aw._mechanics.reversal_bursts(torque, band, rate, where)
    assert np.isfinite(fast)
    assert fast == pytest.approx(naive.reversal_bursts(torque, band, rate, where, 10.0), rel=1e-12)


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
        aw._mechanics.running_rms(x, width), naive.running_rms(x, width), rtol=1e-9, atol=1e-12
    )


def test_running_rms_never_nan_after_a_burst() -> None:
    # A burst followed by near-silence: the running sum's cancellation gave a negative mean
    # (-5e-77) and a NaN envelope; the exact value is tiny and non-negative.
    x = np.concatenate([np.full(50, 1e-38), np.full(200, 1e-80), np.zeros(100)])
    rms = aw._mechanics.running_rms(x, 20)
    assert np.all(np.isfinite(rms))
    assert np.all(rms >= 0)
    exact = naive.running_rms(x, 20)
    # Clipping error bounded by the running sum's round-off: width * eps * max(x**2), under the root.
    assert np.max(np.abs(rms**2 - exact**2)) <= 20 * np.finfo(float).eps * np.max(x**2)


def test_pearson_kurtosis_matches_scipy() -> None:
    from scipy.stats import kurtosis

    rng = np.random.default_rng(11)
    for x in (rng.normal(size=500), rng.standard_t(3, size=2000), rng.uniform(size=7)):
        assert aw._mechanics.pearson_kurtosis(x) == pytest.approx(
            kurtosis(x, fisher=False), rel=1e-12
        )
    assert np.isnan(aw._mechanics.pearson_kurtosis(np.ones(10)))


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
    orders = aw._mechanics.bearing_orders(5.43)
    whole = list(aw._mechanics.WHOLE_ORDERS)
    expected = naive.angle_locked_f(y, theta, orders, whole) / np.mean(
        [naive.angle_locked_f(y, theta, [o + d for o in orders], whole) for d in (-0.25, 0.25)]
    )
    assert aw._mechanics.bearing_lines(y, theta, 5.43) == pytest.approx(expected, rel=1e-8)


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
    free = _NuisanceFree(y, theta, aw._mechanics.WHOLE_ORDERS, None)
    tooth = [k / 5 for k in range(15, 41) if k % 5]
    assert free.f_statistic(tooth) == pytest.approx(free.f_statistic(tooth, exact=True), rel=1e-9)
