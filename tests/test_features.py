"""|STFT| features against a frame-by-frame DFT, and their parameters."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch import CaptureError

from .naive import stft_magnitude


@pytest.mark.parametrize("padding", ["circular", "zeros", "valid"])
@pytest.mark.parametrize("hop", [1, 3])
def test_matches_frame_by_frame_dft(rng: np.random.Generator, padding: str, hop: int) -> None:
    x = rng.normal(size=(90, 2))
    X = aw.stft_features(x, 100.0, segment_length=16, hop=hop, padding=padding)  # type: ignore[arg-type]
    reference = np.hstack([stft_magnitude(x[:, c], 16, hop, padding) for c in range(2)])
    assert X.shape == reference.shape
    np.testing.assert_allclose(X, reference, rtol=1e-10, atol=1e-12)


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
