"""PCA and LRA detectors: the scikit-learn contract and the paper's distances."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

import axiswatch as aw
import axiswatch.paper._alignment
from tests.naive import lra_delta, pca_distance

# Rows are paired by index: a distance (and LRA's embedding) is a property of the whole matrix,
# so computing it on a subset or a permutation of rows cannot give the same per-row result.
_ROW_PAIRED = {
    "check_methods_subset_invariance": "rows are paired with the baseline's by index",
    "check_methods_sample_order_invariance": "rows are paired with the baseline's by index",
}


@parametrize_with_checks(
    [aw.PCADetector(n_components=2), aw.LRADetector(), aw.IndicatorDetector()],
    expected_failed_checks=lambda est: _ROW_PAIRED if isinstance(est, aw.LRADetector) else {},
)
def test_scikit_learn_contract(estimator, check) -> None:  # type: ignore[no-untyped-def]
    check(estimator)


def test_pca_distance_matches_reference(rng: np.random.Generator) -> None:
    X_s, X_t = rng.normal(size=(2, 60, 8))
    det = aw.PCADetector(n_components=3).fit(X_s)
    assert det.distance(X_t) == pytest.approx(pca_distance(X_s, X_t, 3), rel=1e-10)


def test_lra_distance_matches_reference(lab_features: list[np.ndarray]) -> None:
    det = aw.LRADetector(mu=0.3, n_components=3, noise_level=0.01).fit(lab_features[0])
    for X_t in lab_features[1:4]:
        assert det.distance(X_t) == pytest.approx(
            lra_delta(lab_features[0], X_t, 0.3, 3, 0.01)[0], rel=1e-8
        )
        assert det.align(X_t).eigenvalues.shape == (5,)


def test_dense_solver_gives_same_distance(lab_features: list[np.ndarray]) -> None:
    fast = aw.LRADetector(noise_level=0.01).fit(lab_features[0])
    dense = aw.LRADetector(noise_level=0.01, solver="dense").fit(lab_features[0])
    assert fast.distance(lab_features[3]) == pytest.approx(
        dense.distance(lab_features[3]), rel=1e-9
    )


def test_shorter_test_matrix_compares_leading_rows(rng: np.random.Generator) -> None:
    X_s, X_t = rng.normal(size=(2, 50, 4)) * 3
    det = aw.LRADetector().fit(X_s)
    assert det.distance(X_t[:40]) == pytest.approx(
        lra_delta(X_s[:40], X_t[:40], 0.5, 2)[0], rel=1e-8
    )
    assert det.distance(np.vstack([X_t, X_t[:5]])) == pytest.approx(det.distance(X_t), rel=1e-12)
    pca = aw.PCADetector(n_components=2).fit(X_s)
    assert pca.distance(X_t[:40]) == pytest.approx(
        float(np.sum(((X_s[:40] - X_t[:40]) @ pca.components_) ** 2))
    )


def test_wrong_feature_width(rng: np.random.Generator) -> None:
    det = aw.LRADetector().fit(rng.normal(size=(20, 4)))
    with pytest.raises(
        ValueError, match=r"X has 3 features, but LRADetector is expecting 4 features"
    ):
        det.distance(rng.normal(size=(20, 3)))


def test_unknown_solver(rng: np.random.Generator) -> None:
    with pytest.raises(
        ValueError,
        match=r"'solver' parameter of LRADetector must be 'structured' or 'dense'. Got 'svd'",
    ):
        aw.LRADetector(solver="svd").fit(rng.normal(size=(20, 4)))  # type: ignore[arg-type]


def test_not_fitted() -> None:
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError, match=r"This PCADetector instance is not fitted yet"):
        aw.PCADetector().distance(np.ones((4, 2)))


def test_baseline_basis_is_computed_once(
    rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    import axiswatch.paper._detectors as detectors

    calls: list[int] = []
    real = detectors.low_rank_basis

    def counting(
        X: np.ndarray, noise_level: float = 1.0, **options: Any
    ) -> aw.paper._alignment.LowRankBasis:
        calls.append(X.shape[0])
        return real(X, noise_level, **options)

    monkeypatch.setattr(detectors, "low_rank_basis", counting)
    X_s = rng.normal(size=(50, 4)) * 3
    det = aw.LRADetector().fit(X_s)
    assert len(calls) == 1
    for _ in range(3):
        det.distance(X_s + rng.normal(size=X_s.shape))
    assert len(calls) == 4  # one per test capture, none for the baseline


def test_row_policy_pairs_rows_or_keeps_them_all(rng: np.random.Generator) -> None:
    baseline, test = rng.normal(size=(40, 3)), rng.normal(size=(25, 3)) + 1.0
    assert (aw.PCADetector.row_policy, aw.LRADetector.row_policy) == ("paired", "paired")
    assert aw.IndicatorDetector.row_policy == "set"
    pca = aw.PCADetector(n_components=2).fit(baseline)
    _, _, vh = np.linalg.svd(baseline - baseline.mean(axis=0), full_matrices=False)
    paired = (baseline[:25] - test) @ vh[:2].T  # the first 25 rows of both, row by row
    assert pca.distance(test) == pytest.approx(float(np.sum(paired**2)), rel=1e-10)
    indicator = aw.IndicatorDetector(one_sided=False).fit(baseline)
    shift = test.mean(axis=0) - baseline.mean(axis=0)  # all 25 test rows, all 40 baseline rows
    assert indicator.distance(test) == pytest.approx(float(shift @ shift), rel=1e-12)


def test_diagnostics_hook(lab_features: list[np.ndarray]) -> None:
    lra = aw.LRADetector().fit(lab_features[0])
    result = lra.align(lab_features[1])
    distance, diagnostics = lra.distance_and_diagnostics(lab_features[1])
    assert distance == result.delta == lra.distance(lab_features[1])
    assert diagnostics == {
        "lra_eigengap": result.eigengap,
        "lra_tie_broken": result.tie_broken,
    }
    assert lra.diagnostics(lab_features[1]) == diagnostics
    pca = aw.PCADetector().fit(lab_features[0])
    assert pca.distance_and_diagnostics(lab_features[1]) == (pca.distance(lab_features[1]), {})


def test_a_score_holds_one_basis_beyond_the_test_features() -> None:
    """Working memory of ``distance``: the test basis, computed and used in place."""
    import tracemalloc

    rng = np.random.default_rng(3)
    X_s = rng.normal(size=(40_000, 40)) * 3  # full rank: each basis is as large as X
    X_t = X_s + rng.normal(size=X_s.shape)
    det = aw.LRADetector().fit(X_s)
    tracemalloc.start()
    try:
        det.distance(X_t)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Measured 1.5x: the basis, a finiteness mask and blocks of rows (4.0x when the target
    # basis, the joint basis and their temporaries were separate N x r arrays).
    assert peak < 2 * X_t.nbytes
