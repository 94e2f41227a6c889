"""The Marchenko-Pastur default for lambda, against a Monte Carlo reference."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import axiswatch as aw
from axiswatch.paper._noise import marchenko_pastur_median, mp_noise_level
from tests import naive


@pytest.mark.parametrize("beta", [0.25, 0.5, 1.0])
def test_median_matches_monte_carlo(beta: float) -> None:
    # Monte Carlo standard error of the median at n=800 is ~0.02; tolerance 0.05 (2.5 SE).
    with threadpool_limits(limits=1, user_api="blas"):
        reference = naive.marchenko_pastur_median(beta, n=800, seed=0)
    assert marchenko_pastur_median(beta) == pytest.approx(reference, abs=0.05)


def test_noise_level_of_pure_noise_is_its_top_singular_value() -> None:
    noise = 0.5 * np.random.default_rng(1).normal(size=(600, 150))
    top = np.linalg.svd(noise, compute_uv=False)[0]
    # The edge sigma (sqrt(N) + sqrt(K)) and the largest singular value agree within 3 %.
    assert np.sqrt(mp_noise_level(noise)) == pytest.approx(top, rel=0.03)


def test_auto_keeps_structure_above_noise() -> None:
    rng = np.random.default_rng(2)
    structure = 5.0 * np.outer(np.sin(np.arange(300) / 7), np.cos(np.arange(60) / 5))
    detector = aw.LRADetector(noise_level="auto").fit(structure + 0.01 * rng.normal(size=(300, 60)))
    assert detector.basis_.rank == 1
    assert detector.noise_level_ < 1.0


def test_bad_inputs() -> None:
    with pytest.raises(ValueError, match=r"'beta' parameter must be a float in \(0, 1\]"):
        marchenko_pastur_median(1.5)
    with pytest.raises(ValueError, match="X must be a finite matrix"):
        mp_noise_level(np.ones((1, 5)))
    with pytest.raises(ValueError, match="zero median singular value"):
        mp_noise_level(np.eye(10, 6) * np.eye(10, 6)[0, :6][None, :])
    with pytest.raises(ValueError, match="must be a float > 0 or 'auto'"):
        aw.LRADetector(noise_level="guess").fit(np.ones((5, 3)))  # type: ignore[arg-type]
