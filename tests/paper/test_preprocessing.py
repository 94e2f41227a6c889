"""PCHIP upsampling (paper, "Pre-processing") and phase alignment."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import axiswatch as aw
import axiswatch.paper._preprocessing
from axiswatch import CaptureError
from tests.naive import pchip_upsample

# Subnormal samples overflow the harmonic-mean slopes inside SciPy (a RuntimeWarning); a
# logged robot signal never holds them, so they are left out.
finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False, allow_subnormal=False)


@settings(max_examples=200, deadline=None)
@given(values=arrays(np.float64, st.integers(2, 40), elements=finite), factor=st.integers(1, 10))
def test_original_samples_are_reproduced_exactly(values: np.ndarray, factor: int) -> None:
    out = aw.upsample_pchip(values, factor)
    assert out.size == (values.size - 1) * factor + 1
    np.testing.assert_array_equal(out[::factor], values)


@settings(max_examples=200, deadline=None)
@given(
    # Steps of 0 or at least 1e-100: steps near the smallest normal float (2.2e-308) make
    # SciPy's PCHIP slopes overflow (a RuntimeWarning, an error here), a float limit, not a bug.
    steps=arrays(
        np.float64, st.integers(1, 30), elements=st.one_of(st.just(0.0), st.floats(1e-100, 1e3))
    ),
    factor=st.integers(2, 9),
    start=finite,
)
def test_monotone_between_monotone_samples(steps: np.ndarray, factor: int, start: float) -> None:
    increasing = start + np.concatenate([[0.0], np.cumsum(steps)])
    for values in (increasing, increasing[::-1]):
        out = aw.upsample_pchip(values, factor)
        diffs = np.diff(out) * (1 if values is increasing else -1)
        assert (diffs >= -1e-9 * (1 + np.abs(out[1:]))).all()


@settings(max_examples=100, deadline=None)
@given(
    values=arrays(
        np.float64, st.integers(2, 25), elements=st.floats(-100, 100, allow_subnormal=False)
    ),
    factor=st.integers(1, 8),
)
def test_matches_written_out_fritsch_carlson(values: np.ndarray, factor: int) -> None:
    np.testing.assert_allclose(
        aw.upsample_pchip(values, factor), pchip_upsample(values, factor), rtol=1e-9, atol=1e-9
    )


def test_paper_factor_inserts_seven_points() -> None:
    out = aw.upsample_pchip(np.arange(4.0), aw.paper._preprocessing.integer_factor(250.0, 2000.0))
    assert out.size == 25
    np.testing.assert_allclose(out, np.arange(25) / 8)


def test_irregular_time_spreads_points_inside_each_interval() -> None:
    from scipy.interpolate import PchipInterpolator

    out = aw.upsample_pchip([0.0, 1.0, 2.0], 2, time_s=[0.0, 1.0, 3.0])
    expected = PchipInterpolator([0.0, 1.0, 3.0], [0.0, 1.0, 2.0])([0.0, 0.5, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(out, expected, rtol=1e-12)


def test_rate_that_does_not_divide() -> None:
    with pytest.raises(CaptureError, match=r"rate 300 Hz does not divide the target rate 2000 Hz"):
        aw.paper._preprocessing.integer_factor(300.0, 2000.0)


def test_non_positive_rate() -> None:
    with pytest.raises(CaptureError, match=r"rates must be positive"):
        aw.paper._preprocessing.integer_factor(0.0, 2000.0)


def test_non_increasing_time() -> None:
    with pytest.raises(
        CaptureError,
        match=r"time must be finite and strictly increasing; t\[2\]=1.0 follows t\[1\]=1.0",
    ):
        aw.upsample_pchip([0.0, 1.0, 2.0], 2, time_s=[0.0, 1.0, 1.0])


def test_time_of_other_shape() -> None:
    with pytest.raises(CaptureError, match=r"time has shape \(2,\) but values have shape \(3,\)"):
        aw.upsample_pchip([0.0, 1.0, 2.0], 2, time_s=[0.0, 1.0])


def test_nan_inside_signal() -> None:
    with pytest.raises(CaptureError, match=r"NaN or inf inside the signal at sample 1"):
        aw.upsample_pchip([0.0, np.nan, 2.0], 8)


def test_too_short_and_bad_factor() -> None:
    with pytest.raises(CaptureError, match=r"at least 2 samples"):
        aw.upsample_pchip([1.0], 8)
    with pytest.raises(CaptureError, match=r"factor must be a positive integer; got 2.5"):
        aw.upsample_pchip([1.0, 2.0], 2.5)  # type: ignore[arg-type]


def test_resample_capture_stacks_to_common_length(robot_capture: aw.Capture) -> None:
    signals, rate = aw.resample_capture(robot_capture)
    assert rate == 2000.0
    assert signals.shape == (249 * 8 + 1, 3)
    np.testing.assert_array_equal(signals[::8, 0], robot_capture.signals["position"])


def test_mismatched_durations() -> None:
    cap = aw.Capture(
        {"position": np.zeros(250), "speed": np.zeros(4000)},
        {"position": 250.0, "speed": 2000.0},
        source="f.parquet",
    )
    with pytest.raises(
        CaptureError,
        match=r"f\.parquet: signals have mismatched durations \(position=1 s, speed=2 s\)",
    ):
        aw.resample_capture(cap)


def test_resample_rate_that_does_not_divide() -> None:
    cap = aw.Capture({"a": np.zeros(300), "b": np.zeros(2000)}, {"a": 300.0, "b": 2000.0})
    with pytest.raises(CaptureError, match=r"signal 'a': rate 300 Hz does not divide"):
        aw.resample_capture(cap)


@pytest.mark.parametrize("lag", [0, 1, 37, 199])
def test_phase_lag_recovers_a_circular_shift(rng: np.random.Generator, lag: int) -> None:
    x = np.column_stack([np.sin(2 * np.pi * np.arange(200) / 40.0), rng.normal(size=200)])
    assert aw.phase_lag(x, np.roll(x, lag, axis=0)) == lag
    np.testing.assert_array_equal(aw.align_phase(x, np.roll(x, lag, axis=0)), x)


def test_phase_lag_shape_mismatch() -> None:
    with pytest.raises(CaptureError, match=r"same shape"):
        aw.phase_lag(np.zeros((10, 2)), np.zeros((9, 2)))
