"""Attribution: the exact PCA decomposition, occlusion for every other detector, the plot."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.paper._attribution
import axiswatch.paper._features

_SPEC = aw.FeatureSpec(
    signals=("a", "b", "c"), combinations="none", segment_length=32, hop=32, padding="valid"
)
_RATE = 1000.0


def _signals(rng: np.random.Generator, *, burst: bool) -> np.ndarray:
    """Three noisy channels with their own tones; ``burst`` adds an intermittent 300 Hz tone to b."""
    t = np.arange(3200) / _RATE
    signals = np.column_stack(
        [np.sin(2 * np.pi * f * t) for f in (50.0, 80.0, 120.0)]
    ) + 0.3 * rng.normal(size=(t.size, 3))
    if burst:
        on = (np.arange(t.size) // 320) % 2 == 1
        signals[:, 1] += 1.5 * on * np.sin(2 * np.pi * 300.0 * t)
    return signals


@pytest.fixture(scope="module")
def disturbed() -> tuple[aw.Features, aw.Features]:
    rng = np.random.default_rng(7)
    baseline = aw.paper._features.features_from_signals(_signals(rng, burst=False), _RATE, _SPEC)
    test = aw.paper._features.features_from_signals(_signals(rng, burst=True), _RATE, _SPEC)
    return baseline, test


def test_exact_decomposition_sums_to_distance(disturbed: tuple[aw.Features, aw.Features]) -> None:
    baseline, test = disturbed
    detector = aw.PCADetector().fit(baseline.X)
    table = aw.attribute(detector, baseline, test, n_bands=4)
    assert table.attrs["method"] == "exact"
    assert table.attrs["distance"] == pytest.approx(detector.distance(test.X), rel=1e-12)
    # Float64 sums of ~1e3 terms: exact up to rounding.
    assert table.share.sum() == pytest.approx(1.0, abs=1e-10)
    assert len(table) == 3 * 4


def test_pca_contributions_match_the_quadratic_form(rng: np.random.Generator) -> None:
    P = np.linalg.qr(rng.normal(size=(6, 3)))[0]
    Xs, Xt = rng.normal(size=(2, 20, 6))
    difference = Xs - Xt
    by_hand = [
        sum(difference[r, j] * (difference[r] @ P @ P.T)[j] for r in range(20)) for j in range(6)
    ]
    np.testing.assert_allclose(
        aw.paper._attribution.pca_contributions(Xs, Xt, P), by_hand, rtol=1e-12
    )


@pytest.mark.parametrize(
    "detector",
    [
        aw.PCADetector(),
        aw.LRADetector(),
    ],
    ids=lambda d: type(d).__name__,
)
def test_disturbed_signal_and_band_come_out_on_top(
    detector: aw.BaselineDetector, disturbed: tuple[aw.Features, aw.Features]
) -> None:
    baseline, test = disturbed
    table = aw.attribute(detector, baseline, test, n_bands=4)
    top = table.iloc[0]
    assert top.channel == "b"
    assert top.band_lo_hz <= 300.0 <= top.band_hi_hz
    assert table.attrs["method"] == (
        "exact" if isinstance(detector, aw.PCADetector) else "occlusion"
    )


def test_mismatched_features_are_rejected(disturbed: tuple[aw.Features, aw.Features]) -> None:
    baseline, test = disturbed
    other = aw.Features(test.X[:, :34], ("a", "b"), test.frequencies_hz, test.rate_hz)
    with pytest.raises(
        ValueError, match=r"same channels and frequencies; got channels \['a', 'b', 'c'\]"
    ):
        aw.attribute(aw.PCADetector(), baseline, other)


def test_too_many_bands(disturbed: tuple[aw.Features, aw.Features]) -> None:
    baseline, test = disturbed
    with pytest.raises(
        ValueError, match=r"'n_bands' parameter must be an int in the range \[1, 17\] .*Got 18"
    ):
        aw.attribute(aw.PCADetector(), baseline, test, n_bands=18)


def test_difference_spectrogram_plot(disturbed: tuple[aw.Features, aw.Features]) -> None:
    baseline, test = disturbed
    cube = aw.paper._attribution.difference_spectrogram(baseline, test)
    assert cube.shape == (3, baseline.X.shape[0], 17)
    np.testing.assert_array_equal(cube[1, :, 3], test.X[:, 17 + 3] - baseline.X[:, 17 + 3])
    ax = aw.paper._attribution.plot_difference_spectrogram(baseline, test, hop_s=32 / _RATE)
    assert ax.get_xlabel() == "time (s)"
    assert [t.get_text().split("\n")[0] for t in ax.get_yticklabels()] == ["a", "b", "c"]


def test_non_spectral_features_are_rejected(disturbed: tuple[aw.Features, aw.Features]) -> None:
    baseline, test = disturbed
    named = aw.Features(test.X, test.channels, None, test.rate_hz, ("a",) * test.X.shape[1])
    with pytest.raises(ValueError, match=r"no frequency bins .* expected spectral features"):
        aw.attribute(aw.PCADetector().fit(baseline.X), baseline, named)
