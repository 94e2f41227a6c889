"""The line statistics from sums of phasors equal those from the waves' own products."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch.indicators._signals as signals
import axiswatch.indicators._wave_sums as wave_sums
from axiswatch.indicators._wave_sums import MAX_GRIDS, phasor_sums, wave_products


def _exact_sums(angle: np.ndarray, weights: np.ndarray, frequencies: np.ndarray) -> np.ndarray:
    return weights @ np.exp(1j * np.multiply.outer(angle, frequencies))


def test_phasor_sums_equal_the_direct_sums_on_grids_and_off(rng: np.random.Generator) -> None:
    angle = np.sort(rng.uniform(40.0, 400.0, 2000))  # 57 revolutions, as a 3 s capture
    weights = np.stack([np.ones(angle.size), rng.normal(size=angle.size)])
    # Two classes modulo 0.2 (whole and half steps), both signs, up to 90 steps.
    frequencies = np.concatenate([np.arange(-40, 91) * 0.2, np.arange(0, 60) * 0.2 + 0.1])
    sums = phasor_sums(angle, weights, frequencies, 0.2)
    assert sums is not None
    exact = _exact_sums(angle, weights, frequencies)
    np.testing.assert_allclose(sums, exact, rtol=0, atol=1e-10 * angle.size)
    spread = np.array([0.0, 0.03, 0.05, 0.07, 0.11])  # five classes: beyond MAX_GRIDS
    assert spread.size > MAX_GRIDS
    assert phasor_sums(angle, weights, spread, 0.2) is None


def test_wave_products_are_the_waves_products(rng: np.random.Generator) -> None:
    angle = np.sort(rng.uniform(0.0, 100.0, 700))
    a, b = np.array([1.0, 2.0, 5.5]), np.array([0.2, 0.4, 1.6, 7.0])
    ones = np.ones((1, angle.size))
    difference = _exact_sums(angle, ones, np.subtract.outer(a, b).ravel())[0].reshape(3, 4)
    total = _exact_sums(angle, ones, np.add.outer(a, b).ravel())[0].reshape(3, 4)
    expected = signals._wave_rows(angle, a) @ signals._wave_rows(angle, b).T
    np.testing.assert_allclose(wave_products(difference, total), expected, atol=1e-9)


def _stretch(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    # A motor angle going back and forth, as the fast samples of a capture, and a band-passed
    # torque with a tooth line and a whole-order ripple.
    theta = 60.0 + 45.0 * np.sin(np.linspace(0.0, 9.0, n)) + np.linspace(0.0, 40.0, n)
    noise = np.convolve(rng.normal(size=n), np.ones(4) / 4, mode="same")
    return theta, noise + 0.1 * np.cos(0.4 * theta) + 0.5 * np.sin(3 * theta)


@pytest.mark.parametrize("stage", [5.0, 4.0, 2.0])
def test_tooth_lines_by_sums_equal_the_waves_path(rng: np.random.Generator, stage: float) -> None:
    theta, y = _stretch(rng, 3000)
    orders = [k / stage for k in range(1, int(8 * stage) + 1) if k % stage]
    free = signals._NuisanceFree(y, theta, signals.WHOLE_ORDERS, None)
    by_sums = free._sums_f(orders, [0.5 / stage])
    assert by_sums is not None  # a tooth set on one grid, the whole orders on it
    rows = signals._wave_rows(theta, orders)
    shifted = signals._wave_rows(theta, [o + 0.5 / stage for o in orders])
    by_waves = [free._f(rows), free._f(shifted)]
    np.testing.assert_allclose(by_sums, by_waves, rtol=1e-11)
    exact = [free._f(rows, exact=True), free._f(shifted, exact=True)]  # the QR path
    np.testing.assert_allclose(by_sums, exact, rtol=1e-9)


@pytest.mark.parametrize("stage", [5.0, 4.0])
def test_tooth_sums_on_half_steps_equal_the_two_classes_of_whole_steps(
    rng: np.random.Generator, stage: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    # One grid of half steps holds the orders and the orders shifted by half a step: one
    # exponential and one product instead of two of each, with the same sums to rounding.
    theta, y = _stretch(rng, 3000)
    orders = [k / stage for k in range(1, int(8 * stage) + 1) if k % stage]
    free = signals._NuisanceFree(y, theta, signals.WHOLE_ORDERS, None)
    assert wave_sums.summing_step(1 / stage, [0.5 / stage]) == pytest.approx(0.5 / stage)
    on_half_steps = free._sums_f(orders, [0.5 / stage])
    monkeypatch.setattr(wave_sums, "summing_step", lambda step, offsets: step)
    wave_sums.sums_plan.cache_clear()  # the plan on half steps is kept
    try:
        in_two_classes = free._sums_f(orders, [0.5 / stage])
        two = wave_sums.sums_plan(tuple(orders), (0.5 / stage,), signals.WHOLE_ORDERS)
        assert two is not None
        assert len(two.phasors.classes) == 2
    finally:
        wave_sums.sums_plan.cache_clear()
    assert on_half_steps is not None
    assert in_two_classes is not None
    np.testing.assert_allclose(on_half_steps, in_two_classes, rtol=1e-12)


def test_orders_off_one_grid_take_the_waves_path(rng: np.random.Generator) -> None:
    theta, y = _stretch(rng, 2000)
    free = signals._NuisanceFree(y, theta, signals.WHOLE_ORDERS, None)
    assert free._sums_f(signals.bearing_orders(5.43), [-0.25, 0.25]) is None
    # A stage of 3.6 teeth: the whole orders fall in five classes of its grid. Its tooth set
    # leaves out the whole orders, as the readings do, and no shifted order is whole.
    odd_stage = [k / 3.6 for k in range(1, 29) if k % 18]
    assert free._sums_f(odd_stage, [0.5 / 3.6]) is None
    ratio = free.line_ratio(odd_stage, [0.5 / 3.6])
    rows = signals._wave_rows(theta, odd_stage)
    shifted = signals._wave_rows(theta, [o + 0.5 / 3.6 for o in odd_stage])
    assert ratio == pytest.approx(
        free._f(rows, exact=True) / free._f(shifted, exact=True), rel=1e-9
    )


def test_shared_phasors_give_the_same_waves_bit_for_bit(rng: np.random.Generator) -> None:
    from axiswatch.indicators._wave_sums import Phasors

    angle = np.sort(rng.uniform(40.0, 400.0, 2000))
    orders = signals.bearing_orders(5.43)
    phasors = Phasors(angle)
    signals._harmonics(angle, signals.WHOLE_ORDERS, None, phasors)  # keeps exp(1j angle)
    shared = signals._wave_rows(angle, orders, phasors=phasors)
    alone = signals._wave_rows(angle, orders)
    assert np.array_equal(shared, alone)
    for shift in (-0.25, 0.25):  # the second is the first's conjugate
        out, half = np.empty_like(alone), np.empty((alone.shape[0] // 2, angle.size))
        moved = signals._shifted_rows(shared, angle, shift, out, half, phasors).copy()
        assert np.array_equal(moved, signals._shifted_rows(alone, angle, shift, out, half))


@pytest.fixture
def cis_calls(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The sizes of the angles each ``cis`` call of the lines is given, as they come."""
    calls: list[int] = []
    cis = wave_sums.cis

    def counted(angle: np.ndarray) -> np.ndarray:
        calls.append(angle.size)
        return cis(angle)

    monkeypatch.setattr(wave_sums, "cis", counted)
    monkeypatch.setattr(signals, "cis", counted)
    return calls


def test_a_captures_lines_share_their_exponentials(
    rng: np.random.Generator, cis_calls: list[int]
) -> None:
    # exp(1j f angle) costs about fifty complex products: the whole orders' exp(1j angle) serves
    # the bearing's grid of step 1, and the shifts -0.25 and 0.25 share one. Was 8 a capture.
    calls = cis_calls
    angle = np.sort(rng.uniform(40.0, 400.0, 2000))
    torque = rng.normal(size=angle.size)
    shared = signals.whole_orders(angle)
    tooth = [k / 5.0 for k in range(1, 41) if k % 5]
    signals.line_ratio(torque, angle, tooth, [0.1], nuisance=shared)
    signals.bearing_lines(torque, angle, 5.43, nuisance=shared)
    # Whole orders 1; the tooth's sums 1 (on the grid of half steps, which holds the orders
    # and their shifts); the bearing's first grid start and one shift: its second start,
    # 2 f - 1 = 2 (f - 2) + 3, is the first's square times exp(3j angle). Was 8, 6, then 5.
    assert len(calls) == 4


@pytest.mark.parametrize("bearing", [5.43, 3.17, 12.345])
def test_a_bearings_double_from_products_equals_its_cis(
    rng: np.random.Generator, bearing: float
) -> None:
    from axiswatch.indicators._wave_sums import Phasors, cis

    angle = np.sort(rng.uniform(40.0, 700.0, 3000))  # a 3 s capture's motor angle
    phasors = Phasors(angle)
    phasors(1.0)
    first, double = bearing - 2, 2 * bearing - 1
    phasors(first)
    assert phasors._doubled(double) is not None  # built from the kept two
    # cis rounds its argument (up to 16,000 rad: a spacing of 4e-12); the products do not.
    atol = 2 * np.spacing(double * angle.max()) + 1e-14
    np.testing.assert_allclose(phasors(double), cis(double * angle), rtol=0, atol=atol)
    assert phasors._doubled(double + 0.25) is None  # not a whole order off


def test_the_grids_of_a_set_of_orders_are_found_once_and_kept_read_only() -> None:
    # A capture's lines ask for the grids of the same few sets of orders four times.
    tooth = np.array([k / 5 for k in range(1, 41) if k % 5])
    bearing = np.array(signals.bearing_orders(5.43))
    grids = wave_sums.order_grids(bearing)
    assert wave_sums.order_grids(bearing.copy()) is grids
    assert [(start, step) for _, start, step in grids] == [
        pytest.approx((3.43, 1.0)),
        pytest.approx((9.86, 1.0)),
    ]
    assert [members.tolist() for members, _, _ in grids] == [[0, 1, 2, 3, 4], [5, 6, 7]]
    ((members, start, step),) = wave_sums.order_grids(tooth)
    assert (start, step) == (pytest.approx(0.2), pytest.approx(0.2))
    assert members.tolist() == list(range(32))
    for members, _, _ in (*grids, *wave_sums.order_grids(tooth)):
        with pytest.raises(ValueError, match="read-only"):
            members[0] = 1


def test_a_tooth_sets_plan_finds_each_sum_at_its_frequency() -> None:
    # The plan is made once per set of orders and offsets; each of its columns is the sum the
    # line statistics read there: differences and totals of two orders, a whole order less or
    # plus an order, and the orders themselves, for the orders and their shift.
    orders = tuple(k / 5 for k in range(1, 41) if k % 5)
    plan = wave_sums.sums_plan(orders, (0.1,), signals.WHOLE_ORDERS)
    assert plan is not None
    assert wave_sums.sums_plan(orders, (0.1,), signals.WHOLE_ORDERS) is plan
    assert len(plan.phasors.classes) == 1  # one grid of half steps
    o = np.array(orders)
    whole = np.array(signals.WHOLE_ORDERS, dtype=float)[:, None]
    f = np.where(plan.phasors.negative, -1.0, 1.0) * np.abs(plan.frequencies)
    difference = np.where(plan.conjugated, -1.0, 1.0) * f[plan.difference]
    np.testing.assert_allclose(difference, np.subtract.outer(o, o), atol=1e-12)
    assert len(plan.shifts) == 2
    for shift, (total, minus, plus, at_orders) in zip((0.0, 0.1), plan.shifts, strict=True):
        np.testing.assert_allclose(f[total], np.add.outer(o, o) + 2 * shift, atol=1e-12)
        np.testing.assert_allclose(f[minus], whole - (o + shift), atol=1e-12)
        np.testing.assert_allclose(f[plus], whole + o + shift, atol=1e-12)
        np.testing.assert_allclose(f[at_orders], o + shift, atol=1e-12)
    with pytest.raises(ValueError, match="read-only"):
        plan.shifts[0][0][0, 0] = 0
    assert wave_sums.sums_plan(tuple(signals.bearing_orders(5.43)), (0.25,), (1.0,)) is None


def test_a_weight_row_summed_over_part_of_its_grid_gives_those_sums(
    rng: np.random.Generator,
) -> None:
    # The residual is read at the orders only: its giant rows stop where they end.
    angle = np.sort(rng.uniform(40.0, 400.0, 2000))
    weights = np.stack([np.ones(angle.size), rng.normal(size=angle.size)])
    frequencies = np.concatenate([np.arange(0, 160) * 0.1, np.arange(0, 30) * 0.1 + 0.05])
    plan = wave_sums.phasor_plan(frequencies, 0.1)
    assert plan is not None
    extents = np.array([[160, 75], [30, 0]])
    sums = phasor_sums(angle, weights, frequencies, 0.1, plan, extents)
    full = phasor_sums(angle, weights, frequencies, 0.1, plan)
    assert sums is not None
    assert full is not None
    exact = _exact_sums(angle, weights, frequencies)
    np.testing.assert_allclose(sums[0], exact[0], rtol=0, atol=1e-10 * angle.size)
    # The same rows; BLAS may sum a product of fewer rows in another order.
    np.testing.assert_allclose(sums[0], full[0], rtol=0, atol=1e-13 * angle.size)
    # The residual's grid of 160 steps in giant rows of 13: 78 steps summed for 75 asked.
    kept = np.zeros(frequencies.size, dtype=bool)
    kept[:78] = True
    np.testing.assert_allclose(sums[1][kept], exact[1][kept], rtol=0, atol=1e-10 * angle.size)
    assert np.isnan(sums[1][~kept]).all()


def test_a_tooth_sets_plan_sums_the_residual_up_to_its_orders() -> None:
    orders = tuple(k / 5 for k in range(1, 41) if k % 5)
    plan = wave_sums.sums_plan(orders, (0.1,), signals.WHOLE_ORDERS)
    assert plan is not None
    ((members, _, index),) = plan.phasors.classes
    at_orders = np.concatenate([shift[3] for shift in plan.shifts])
    on_grid = dict(zip(members.tolist(), index.tolist(), strict=True))
    assert plan.extents.tolist() == [[index.max() + 1, max(on_grid[i] for i in at_orders) + 1]]
    assert plan.extents[0, 1] < plan.extents[0, 0] / 2 + 2  # the orders: half the grid


def test_a_seeded_base_gives_its_multiples_as_powers(rng: np.random.Generator) -> None:
    from axiswatch.indicators._wave_sums import Phasors, cis, phasor_base

    angle = np.sort(rng.uniform(40.0, 700.0, 3000))
    assert phasor_base((1.0, 0.1, 0.25)) == pytest.approx(0.05)
    assert phasor_base((1.0, 1 / 7.2)) == pytest.approx(1 / 36)  # a stage of 3.6 teeth
    assert phasor_base((1.0, 0.43)) is None
    assert phasor_base((1.0,)) is None
    phasors = Phasors(angle)
    phasors(0.05)
    # The whole orders, a tooth set's grid step as its orders round it, a bearing's shift.
    # Each is the base's multiple (0.1 for the step: what the rounded orders stand for).
    for frequency in (1.0, 0.09999999999999964, 0.25):
        power = phasors._power(frequency)
        assert power is not None
        multiple = round(frequency / 0.05) * 0.05
        atol = 4 * np.spacing(multiple * angle.max()) + 1e-13
        np.testing.assert_allclose(power, cis(multiple * angle), rtol=0, atol=atol)
    assert phasors._power(0.1 + 1e-9) is None  # not a multiple: its own cis


def test_a_captures_kinematic_lines_take_one_cis_and_the_bearings_own(
    cis_calls: list[int],
) -> None:
    # The whole orders, the tooth set's half step and the bearing's shift are multiples of
    # 0.05: one cis of it, their phasors as its powers. The bearing's start (3.43) takes its own.
    import axiswatch.datasets as awd
    from axiswatch.indicators._readings import read_indicators

    calls = cis_calls
    read = read_indicators(
        awd.simulate_capture("heavy", seed=2),
        gear_ratio=100.0,
        gear_stages={"i": 5.0},
        bearing_orders={"b": 5.43},
    )
    assert np.isfinite([read.values["tooth_lines:i"], read.values["bearing_lines:b"]]).all()
    assert len(calls) == 2  # was 4, before that 5


def test_a_tooth_set_on_a_seeded_base_is_nearer_its_exact_statistic(
    rng: np.random.Generator,
) -> None:
    # The grid's step found from the rounded orders is 0.09999999999999964: the base's double
    # (0.1) stands for the orders' sums as they are meant, the exact waves' (QR path) within
    # 1e-13; the step itself strayed to 8e-13 over 400 revolutions.
    from axiswatch.indicators._wave_sums import Phasors

    n = 3000
    theta = 60.0 + 45.0 * np.sin(np.linspace(0.0, 9.0, n)) + np.linspace(0.0, 400.0, n)
    y = np.convolve(rng.normal(size=n), np.ones(4) / 4, mode="same") + 0.1 * np.cos(0.4 * theta)
    orders = np.array([k / 5 for k in range(1, 41) if k % 5])
    phasors = Phasors(theta)
    phasors(0.05)
    free = signals._NuisanceFree(
        y, theta, signals.WHOLE_ORDERS, None, nuisance=signals.whole_orders(theta, phasors)
    )
    by_sums = free._sums_f(orders.tolist(), [0.1])
    assert by_sums is not None
    exact = [
        free._f(
            np.concatenate([np.sin(np.outer(o, theta)), np.cos(np.outer(o, theta))]), exact=True
        )
        for o in (orders, orders + 0.1)
    ]
    np.testing.assert_allclose(by_sums, exact, rtol=1e-13)
