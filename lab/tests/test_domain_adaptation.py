"""Energy, CORAL and Subspace Alignment detectors."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

import axiswatch as aw
import axiswatch_lab as lab
from lab_naive import energy_distance


@parametrize_with_checks([lab.EnergyDetector(n_components=2)])
def test_scikit_learn_contract(estimator, check) -> None:  # type: ignore[no-untyped-def]
    check(estimator)


def test_energy_distance_matches_reference(rng: np.random.Generator) -> None:
    a, b = rng.normal(size=(30, 4)), rng.normal(size=(25, 4)) + 0.5
    assert lab.energy_distance(a, b) == pytest.approx(energy_distance(a, b), rel=1e-10)
    assert lab.energy_distance(a, a) == 0.0


def test_energy_distance_width_mismatch(rng: np.random.Generator) -> None:
    with pytest.raises(ValueError, match=r"same number of features; got 4 and 3"):
        lab.energy_distance(rng.normal(size=(5, 4)), rng.normal(size=(5, 3)))


def test_energy_detector_is_energy_distance_in_the_baseline_subspace(
    rng: np.random.Generator,
) -> None:
    X_s, X_t = rng.normal(size=(80, 5)), rng.normal(size=(60, 5)) + 0.3
    det = lab.EnergyDetector(n_components=3).fit(X_s)
    mean = X_s.mean(axis=0)
    P = det.pca_.components_.T
    expected = energy_distance((X_s - mean) @ P, (X_t - mean) @ P)
    assert det.distance(X_t) == pytest.approx(expected, rel=1e-9)


def test_coral_aligns_an_affine_change_but_not_a_change_of_shape(
    rng: np.random.Generator,
) -> None:
    X = rng.normal(size=(400, 4))
    coral = lab.CORALDetector().fit(X)
    energy = lab.EnergyDetector().fit(X)
    affine = rng.normal(size=(400, 4)) @ np.diag([3.0, 0.5, 2.0, 1.0]) + 4.0
    skewed = rng.exponential(size=(400, 4))
    assert coral.distance(affine) < 0.2 * energy.distance(affine)
    assert coral.distance(skewed) > 3 * coral.distance(affine)
    # The mapped test rows take the baseline's mean exactly and its variances up to the
    # Ledoit-Wolf shrinkage of both covariances (which also pulls correlations toward 0).
    mapped = coral._map(affine)
    np.testing.assert_allclose(mapped.mean(axis=0), X.mean(axis=0), atol=1e-10)
    np.testing.assert_allclose(np.var(mapped, axis=0), np.var(X, axis=0), rtol=0.15)


def test_subspace_alignment_keeps_the_spread(rng: np.random.Generator) -> None:
    scales = np.array([3.0, 2.0, 0.1, 0.1])
    X = rng.normal(size=(300, 4)) * scales
    det = lab.SubspaceAlignmentDetector().fit(X)
    assert det.n_components_ == 2
    rotated = (rng.normal(size=(300, 4)) * scales)[:, [1, 0, 2, 3]]
    louder = rng.normal(size=(300, 4)) * scales * 3.0
    assert det.transform(rotated).shape == (300, 2)
    assert det.distance(louder) > 10 * det.distance(rotated)


def _disturbed_signals(rng: np.random.Generator, *, burst: bool) -> aw.Capture:
    """Three noisy channels with their own tones; ``burst`` adds an intermittent 300 Hz tone to b."""
    t = np.arange(3200) / 1000.0
    signals = np.column_stack(
        [np.sin(2 * np.pi * f * t) for f in (50.0, 80.0, 120.0)]
    ) + 0.3 * rng.normal(size=(t.size, 3))
    if burst:
        on = (np.arange(t.size) // 320) % 2 == 1
        signals[:, 1] += 1.5 * on * np.sin(2 * np.pi * 300.0 * t)
    names = ("a", "b", "c")
    return aw.Capture(dict(zip(names, signals.T, strict=True)), dict.fromkeys(names, 1000.0))


@pytest.mark.parametrize(
    "detector",
    [lab.EnergyDetector(), lab.CORALDetector(), lab.SubspaceAlignmentDetector()],
    ids=lambda d: type(d).__name__,
)
def test_occlusion_puts_the_disturbed_signal_and_band_on_top(
    detector: aw.BaselineDetector,
) -> None:
    spec = aw.FeatureSpec(
        signals=("a", "b", "c"), combinations="none", segment_length=32, hop=32, padding="valid"
    )
    rng = np.random.default_rng(7)
    baseline = aw.extract_features(_disturbed_signals(rng, burst=False), spec)
    test = aw.extract_features(_disturbed_signals(rng, burst=True), spec)
    table = aw.attribute(detector, baseline, test, n_bands=4)
    top = table.iloc[0]
    assert top.channel == "b"
    assert top.band_lo_hz <= 300.0 <= top.band_hi_hz
    assert table.attrs["method"] == "occlusion"
