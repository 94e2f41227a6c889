"""The kinematic lines: one projection per capture, bands designed once, long captures in blocks."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import scipy.signal._filter_design as filter_design

import axiswatch.datasets as awd
import axiswatch.indicators._readings as readings
import axiswatch.indicators._signals as mechanics
from axiswatch import Capture
from tests import naive

KINEMATICS: dict[str, Any] = {
    "gear_ratio": 100.0,
    "gear_stages": {"intermediate": 5.0},
    "bearing_orders": {"motor_inner_race": 5.43},
}
LINES = ("tooth_lines:intermediate", "bearing_lines:motor_inner_race")
TASKS = ("short_fast", "short_slow", "long_fast", "long_slow", "heavy", "light")


@pytest.fixture(scope="module")
def captures() -> list[Capture]:
    return [awd.simulate_capture(task, seed=seed) for task in TASKS for seed in (0, 1)]


def _twin(capture: Capture) -> dict[str, float]:
    m = readings.motion(capture)
    return naive.kinematic_lines(m.position, m.speed, m.torque, m.rate_hz, **KINEMATICS)


def test_lines_on_the_band_grid_stay_within_0_015_decades_of_the_exact_band(
    captures: list[Capture],
) -> None:
    for capture in captures:
        read = readings.read_indicators(capture, **KINEMATICS)
        exact = _twin(capture)
        assert set(exact) == set(LINES)
        for name in LINES:
            assert abs(math.log10(read.values[name] / exact[name])) < 0.015, name


def test_the_shared_projection_reads_as_one_projection_per_line(
    captures: list[Capture], monkeypatch: pytest.MonkeyPatch
) -> None:
    # With the exact band, sharing the whole orders' projection across lines changes nothing
    # but rounding: the difference left is the band grid's alone.
    monkeypatch.setattr(readings, "band_edges", lambda low, high, top: (low, min(high, top)))
    for capture in captures[:4]:
        read = readings.read_indicators(capture, **KINEMATICS)
        exact = _twin(capture)
        for name in LINES:
            assert read.values[name] == pytest.approx(exact[name], rel=1e-9)


@pytest.fixture
def designs(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[object]]:
    """Every Butterworth design made (SciPy's ``butter`` designs through ``iirfilter``)."""
    made: list[object] = []
    design = filter_design.iirfilter

    def counted(*args: object, **kwargs: object) -> object:
        made.append(args)
        return design(*args, **kwargs)

    monkeypatch.setattr(filter_design, "iirfilter", counted)
    mechanics.butter_sos.cache_clear()
    yield made
    mechanics.butter_sos.cache_clear()


def test_filters_are_designed_once_per_rate_and_band_cell_not_per_capture(
    designs: list[object],
) -> None:
    captures = [awd.simulate_capture("long_slow", seed=seed) for seed in range(12)]
    for capture in captures:
        readings.read_indicators(capture, **KINEMATICS, order_lines=True)
    first = len(designs)
    # The impulsive band, two ringing filters and the kinematic bands' cells (their edges follow
    # each capture's speeds): fewer than one a capture, against three a capture before.
    assert first < len(captures), designs
    for capture in captures:
        readings.read_indicators(capture, **KINEMATICS, order_lines=True)
    assert len(designs) == first  # every filter of these captures is designed already


def _stage_sized(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    theta = np.sort(rng.uniform(0, 400, n))
    white = rng.normal(size=n)
    coloured = np.convolve(white, np.ones(5) / 5, mode="same")
    return theta, coloured + 0.2 * np.cos(5.43 * theta) + np.sin(3 * theta)


def test_a_long_stretch_in_blocks_reads_as_one_block(
    monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator
) -> None:
    theta, y = _stage_sized(rng, 2500)
    tooth = [k / 5 for k in range(1, 41) if k % 5]
    direction = np.where(np.sin(theta / 7) > 0, 1.0, -1.0)
    one = (
        mechanics.bearing_lines(y, theta, 5.43),
        mechanics.line_ratio(y, theta, tooth, [0.1]),
        mechanics.angle_locked_f(y, theta, tooth, direction=direction),
    )
    monkeypatch.setattr(mechanics, "LINE_BLOCK_SAMPLES", 300)
    projection = mechanics.whole_orders(theta)
    assert projection.blocked  # summed in blocks
    assert len(projection.blocks) == 9
    blocked = (
        mechanics.bearing_lines(y, theta, 5.43, nuisance=projection),
        mechanics.line_ratio(y, theta, tooth, [0.1], nuisance=projection),
        mechanics.angle_locked_f(y, theta, tooth, direction=direction),
    )
    np.testing.assert_allclose(blocked, one, rtol=1e-9)


def test_ill_conditioned_waves_in_blocks_take_the_least_squares_solve(
    monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator
) -> None:
    theta = np.linspace(0, 6 * np.pi, 600)
    y = rng.normal(size=theta.size)
    orders = [10.0 + 0.01 * k for k in range(4)]
    exact = mechanics._NuisanceFree(y, theta, [1, 2, 3], None).f_statistic(orders, exact=True)
    monkeypatch.setattr(mechanics, "LINE_BLOCK_SAMPLES", 128)
    blocked = mechanics._NuisanceFree(y, theta, [1, 2, 3], None)
    assert blocked.nuisance.blocked
    assert blocked.f_statistic(orders) == pytest.approx(exact, rel=1e-6)


def test_the_waves_of_a_capture_lines_reuse_the_last_capture_memory(
    rng: np.random.Generator,
) -> None:
    # Fresh pages for a 3 s capture's waves cost as much as their products: a second capture
    # of the same size allocates well under one set of its tooth waves (64 x 3,000 doubles).
    import tracemalloc

    theta, y = _stage_sized(rng, 3000)
    tooth = [k / 5 for k in range(1, 41) if k % 5]
    one_set = 2 * len(tooth) * theta.size * 8
    projection = mechanics.whole_orders(theta)
    first = mechanics.line_ratio(y, theta, tooth, [0.1], nuisance=projection)
    tracemalloc.start()
    try:
        again = mechanics.line_ratio(y, theta, tooth, [0.1], nuisance=projection)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert again == first
    assert peak < one_set / 2, (peak, one_set)


def test_the_projection_by_cholesky_reads_as_the_qr(
    captures: list[Capture], monkeypatch: pytest.MonkeyPatch
) -> None:
    # The whole orders' Gram matrix is well conditioned on a capture's motor angle: its
    # Cholesky factor projects as the QR of the waves did, to rounding.
    for capture in captures:
        by_cholesky = readings.read_indicators(capture, **KINEMATICS)
        with monkeypatch.context() as patch:
            patch.setattr(mechanics, "PROJECTION_MIN_RCOND", math.inf)  # every Gram refused
            by_qr = readings.read_indicators(capture, **KINEMATICS)
        for name in LINES:
            assert by_cholesky.values[name] == pytest.approx(by_qr.values[name], rel=1e-12)
        assert by_cholesky.values == pytest.approx(by_qr.values, rel=1e-12, nan_ok=True)


def test_the_projection_takes_the_qr_where_the_waves_are_nearly_collinear(
    rng: np.random.Generator,
) -> None:
    long = np.sort(rng.uniform(0, 400, 3000))
    assert mechanics.whole_orders(long).basis is None  # Cholesky: no QR taken
    short = np.linspace(0.0, 0.5, 400)  # half a radian: the whole orders hardly differ
    projection = mechanics.whole_orders(short)
    assert projection.basis is not None
    assert projection.rows is None
    y = rng.normal(size=short.size)
    residual = projection.residual(y)
    np.testing.assert_allclose(projection.basis.T @ residual, 0.0, atol=1e-9)
