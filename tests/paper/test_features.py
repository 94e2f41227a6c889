"""|STFT| features against a frame-by-frame DFT, and their parameters."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch import CaptureError
from tests.naive import stft_magnitude


@pytest.mark.parametrize("padding", ["circular", "zeros", "valid"])
@pytest.mark.parametrize("hop", [1, 3])
def test_matches_frame_by_frame_dft(rng: np.random.Generator, padding: str, hop: int) -> None:
    x = rng.normal(size=(90, 2))
    X = aw.stft_features(x, 100.0, segment_length=16, hop=hop, padding=padding)  # type: ignore[arg-type]
    reference = np.hstack([stft_magnitude(x[:, c], 16, hop, padding) for c in range(2)])
    assert X.shape == reference.shape
    np.testing.assert_allclose(X, reference, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("padding", ["circular", "zeros"])
@pytest.mark.parametrize(("n_samples", "hop"), [(64, 3), (64, 7), (65, 64), (70, 1)])
def test_short_captures_match_frame_by_frame_dft(
    rng: np.random.Generator, padding: str, n_samples: int, hop: int
) -> None:
    # Windows wider than what is left after the hop: the wrap-around reaches across the capture.
    x = rng.normal(size=(n_samples, 1))
    X = aw.stft_features(x, 1.0, segment_length=64, hop=hop, padding=padding)  # type: ignore[arg-type]
    np.testing.assert_allclose(X, stft_magnitude(x[:, 0], 64, hop, padding), atol=1e-12)


@pytest.mark.parametrize("scaling", ["magnitude", "psd", "none"])
@pytest.mark.parametrize("padding", ["circular", "zeros", "valid"])
@pytest.mark.parametrize(("segment_length", "hop"), [(16, 1), (17, 2), (32, 5)])
def test_matches_scipy_short_time_fft(
    rng: np.random.Generator, scaling: str, padding: str, segment_length: int, hop: int
) -> None:
    """Same values as the former ShortTimeFFT-based code (1e-12 relative to the largest)."""
    from scipy.signal import ShortTimeFFT, get_window

    x = rng.normal(size=(200, 2)) * 3
    X = aw.stft_features(
        x,
        500.0,
        segment_length=segment_length,
        hop=hop,
        padding=padding,  # type: ignore[arg-type]
        scaling=scaling,  # type: ignore[arg-type]
    )
    stft = ShortTimeFFT(
        get_window("hann", segment_length),
        hop=hop,
        fs=500.0,
        scale_to=None if scaling == "none" else scaling,  # type: ignore[arg-type]
    )
    n, half = x.shape[0], segment_length // 2
    blocks = []
    for channel in x.T:
        if padding == "circular":
            # Slice p of three copies is centred on sample p * hop - n of the capture (every hop
            # used here divides n = 200).
            wrapped = np.concatenate([channel, channel, channel])
            spectrum = stft.stft(wrapped, p0=n // hop, p1=n // hop + -(-n // hop))
        elif padding == "zeros":
            spectrum = stft.stft(channel, p0=0, p1=-(-n // hop))
        else:
            spectrum = stft.stft(
                channel, p0=-(-half // hop), p1=(n - segment_length + half) // hop + 1
            )
        blocks.append(np.abs(spectrum).T)
    reference = np.hstack(blocks)
    np.testing.assert_allclose(X, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_valid_padding_without_a_slice(rng: np.random.Generator) -> None:
    with pytest.raises(
        CaptureError, match=r"no STFT slice fits inside the capture with padding='valid'"
    ):
        aw.stft_features(rng.normal(size=(64, 1)), 1.0, segment_length=64, hop=3, padding="valid")


def test_one_row_per_sample_and_valid_rows(rng: np.random.Generator) -> None:
    x = rng.normal(size=(300, 3))
    assert aw.stft_features(x, 2000.0, segment_length=64).shape == (300, 3 * 33)
    assert aw.stft_features(x, 2000.0, segment_length=64, padding="valid").shape == (
        300 - 64 + 1,
        99,
    )


def test_circular_padding_is_shift_equivariant(rng: np.random.Generator) -> None:
    x = rng.normal(size=(128, 1))
    X = aw.stft_features(x, 1.0, segment_length=32)
    np.testing.assert_allclose(
        aw.stft_features(np.roll(x, 5, axis=0), 1.0, segment_length=32),
        np.roll(X, 5, axis=0),
        atol=1e-12,
    )


def test_extract_features_layout(robot_capture: aw.Capture) -> None:
    feats = aw.extract_features(robot_capture, aw.FeatureSpec(segment_length=32))
    assert feats.channels == (
        "position",
        "speed",
        "torque",
        "position*speed",
        "position*torque",
        "speed*torque",
    )
    assert feats.X.shape == (1993, 6 * 17)
    assert feats.column_channel[17] == "speed"
    assert feats.column_frequency_hz[18] == pytest.approx(2000.0 / 32)


def test_explicit_combinations(robot_capture: aw.Capture) -> None:
    spec = aw.FeatureSpec(combinations=(("speed", "torque"),), segment_length=32)
    assert aw.extract_features(robot_capture, spec).channels[-1] == "speed*torque"


def test_unknown_combination_name() -> None:
    with pytest.raises(
        ValueError, match=r"Combination \('speed', 'force'\) must name two of the channels"
    ):
        aw.FeatureSpec(combinations=(("speed", "force"),)).channel_names()


def test_unknown_combination_keyword() -> None:
    with pytest.raises(ValueError, match=r"'combinations' parameter must be 'products', 'none'"):
        aw.FeatureSpec(combinations="sums").channel_names()  # type: ignore[arg-type]


def test_too_short_for_one_window(robot_capture: aw.Capture) -> None:
    with pytest.raises(
        CaptureError,
        match=r"capture too short for one STFT window: 1993 samples at 2000 Hz, expected at least segment_length=4096",
    ):
        aw.extract_features(robot_capture, aw.FeatureSpec(segment_length=4096))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"segment_length": 1}, r"'segment_length' parameter must be an int >= 2. Got 1"),
        ({"hop": 0}, r"'hop' parameter must be an int >= 1. Got 0"),
        ({"padding": "mirror"}, r"'padding' parameter must be one of"),
        ({"scaling": "db"}, r"'scaling' parameter must be one of"),
    ],
)
def test_bad_parameters(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        aw.stft_features(np.zeros((64, 1)), 1.0, **kwargs)  # type: ignore[arg-type]


def test_bad_signal_arrays() -> None:
    with pytest.raises(CaptureError, match=r"shape \(n_samples, n_channels\); got shape \(64,\)"):
        aw.stft_features(np.zeros(64), 1.0)
    with pytest.raises(CaptureError, match=r"signals contain NaN"):
        aw.stft_features(np.full((64, 1), np.nan), 1.0)


def test_peak_memory_is_the_result_plus_a_block(rng: np.random.Generator) -> None:
    """No complex spectrum or frame matrix of the whole capture is held (hop=1, 6 channels)."""
    import tracemalloc

    x = rng.normal(size=(20_000, 6))
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        X = aw.stft_features(x, 2000.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Measured X + 9 MB; one channel's complex spectrum alone would add 21 MB, its frames 20 MB.
    assert peak < X.nbytes + 14e6


def test_non_spectral_stages_name_their_columns_instead_of_zero_frequencies() -> None:
    # As a physical-indicator stage gives them: one channel, named columns, no frequencies.
    names = ("viscous_friction", "impulsiveness", "bearing_lines")
    features = aw.Features(np.ones((2, 3)), ("mechanics",), None, 2000.0, names)
    assert features.frequencies_hz is None
    assert features.column_names is not None
    assert len(features.column_names) == features.X.shape[1]
    assert set(features.column_channel) == {"mechanics"}
    with pytest.raises(ValueError, match=r"no frequency bins \(channels \['mechanics'\], columns"):
        _ = features.column_frequency_hz


def test_leading_rows_alone_equal_the_whole_matrix_s(rng: np.random.Generator) -> None:
    signals = rng.normal(size=(5000, 2))
    whole = aw.stft_features(signals, 2000.0, segment_length=64)
    for rows in (1, 1234, 2048, 4097, 6000):
        np.testing.assert_array_equal(
            aw.stft_features(signals, 2000.0, segment_length=64, max_rows=rows), whole[:rows]
        )


def test_recomputed_features_give_the_leading_rows(robot_capture: aw.Capture) -> None:
    stage = aw.StftStage(aw.FeatureSpec(hop=2))
    X = stage.fit_transform(robot_capture).X
    rows = stage.baseline_rows_
    assert rows.shape == X.shape
    np.testing.assert_array_equal(rows[:300], X[:300])
    np.testing.assert_array_equal(rows[10:20], X[10:20])
    with pytest.raises(TypeError, match=r"RecomputedFeatures takes a slice of rows; got 3"):
        rows[3]  # type: ignore[index]
