"""LRA against a literal implementation of the paper's equations (tests/naive.py).

Acceptance: equal to 1e-8 relative wherever the eigengap at the cut exceeds 1e-6, on random
matrices and on real features; eigenvector signs never change a distance; degenerate cases have
a defined delta, equal between solvers.
"""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.paper._alignment
import axiswatch.paper._alignment as aw_alignment
from tests.naive import lra_delta

RTOL = 1e-8


def _random_pair(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float, int, float]:
    n, k = int(rng.integers(6, 50)), int(rng.integers(2, 10))
    scale = float(rng.uniform(0.3, 6.0))
    X_s = rng.normal(size=(n, k)) * scale
    X_t = X_s + rng.normal(size=(n, k)) * scale * rng.uniform(0.05, 1.5)
    return (
        X_s,
        X_t,
        float(rng.uniform(0.05, 0.95)),
        int(rng.integers(1, 4)),
        float(rng.choice([0.5, 1.0, 4.0])),
    )


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("solver", ["structured", "dense"])
def test_equals_literal_equations_on_random_matrices(seed: int, solver: str) -> None:
    rng = np.random.default_rng(seed)
    X_s, X_t, mu, d, lam = _random_pair(rng)
    result = aw.lra_embedding(X_s, X_t, mu=mu, n_components=d, noise_level=lam, solver=solver)  # type: ignore[arg-type]
    reference, values = lra_delta(X_s, X_t, mu, d, lam)
    assert result.eigengap == pytest.approx(
        min(values[1] - values[0], values[d + 1] - values[d]), abs=1e-9
    )
    np.testing.assert_allclose(result.eigenvalues, values[: d + 2], atol=1e-10)
    if result.eigengap > 1e-6:
        assert result.delta == pytest.approx(reference, rel=RTOL, abs=1e-12)


def test_equals_literal_equations_on_real_features(lab_features: list[np.ndarray]) -> None:
    checked = 0
    for X_t in lab_features[1:]:
        for mu, d, lam in [(0.5, 2, 1.0), (0.3, 3, 0.01), (0.8, 1, 1e-4)]:
            result = aw.lra_embedding(lab_features[0], X_t, mu=mu, n_components=d, noise_level=lam)
            reference, _ = lra_delta(lab_features[0], X_t, mu, d, lam)
            assert result.delta == pytest.approx(reference, rel=RTOL, abs=1e-12)
            checked += result.eigengap > 1e-6
    assert checked >= 5  # guard: several of these 27 comparisons have a clear gap (7 measured)


def test_structured_equals_dense_embedding_up_to_sign(rng: np.random.Generator) -> None:
    X_s = rng.normal(size=(40, 6)) * 3
    X_t = X_s + rng.normal(size=(40, 6))
    fast = aw.lra_embedding(X_s, X_t, n_components=3)
    dense = aw.lra_embedding(X_s, X_t, n_components=3, solver="dense")
    assert fast.eigengap > 1e-6
    np.testing.assert_allclose(fast.F_s, dense.F_s, atol=1e-8)
    np.testing.assert_allclose(fast.F_t, dense.F_t, atol=1e-8)


def test_sign_flips_do_not_change_delta(rng: np.random.Generator) -> None:
    X_s = rng.normal(size=(30, 5)) * 2
    X_t = rng.normal(size=(30, 5)) * 2
    result = aw.lra_embedding(X_s, X_t, n_components=3)
    for signs in ([1, -1, 1], [-1, -1, -1], [1, 1, -1]):
        flipped_s, flipped_t = result.F_s * signs, result.F_t * signs
        assert np.linalg.norm(flipped_s - flipped_t) == pytest.approx(result.delta, rel=1e-12)
    # and the solver itself is insensitive to a flip of the input features' SVD signs: negate X.
    assert aw.lra_embedding(-X_s, -X_t, n_components=3).delta == pytest.approx(
        result.delta, rel=1e-10
    )


def test_identical_inputs_give_zero() -> None:
    X = np.random.default_rng(0).normal(size=(25, 4)) * 3
    assert aw.lra_embedding(X, X).delta == pytest.approx(0.0, abs=1e-10)


@pytest.mark.parametrize("solver", ["structured", "dense"])
def test_no_singular_value_above_noise_level_gives_zero(solver: str) -> None:
    # R = 0: M = (1 - mu) I + 2 mu L, the smallest eigenvalue 1 - mu has multiplicity N and only
    # symmetric eigenvectors: every selected one has F_s = F_t.
    rng = np.random.default_rng(1)
    X_s, X_t = rng.normal(size=(2, 12, 3)) * 0.01
    result = aw.lra_embedding(X_s, X_t, n_components=3, solver=solver)  # type: ignore[arg-type]
    assert result.rank_source == result.rank_target == 0
    assert result.tie_broken
    assert result.delta == 0.0


@pytest.mark.parametrize("d", [1, 2, 3, 5])
def test_selection_degenerate_with_closed_form_part(d: int) -> None:
    # Rank-1 inputs: one small-block eigenvalue below 1 - mu, the rest of the selection falls in
    # the closed-form bulk; both solvers and the literal equations agree.
    rng = np.random.default_rng(2)
    X_s = rng.normal(size=(10, 1)) @ rng.normal(size=(1, 3)) * 5
    X_t = rng.normal(size=(10, 1)) @ rng.normal(size=(1, 3)) * 5
    fast = aw.lra_embedding(X_s, X_t, n_components=d)
    dense = aw.lra_embedding(X_s, X_t, n_components=d, solver="dense")
    reference, _ = lra_delta(X_s, X_t, 0.5, d)
    assert fast.delta == pytest.approx(dense.delta, rel=1e-9)
    assert fast.delta == pytest.approx(reference, rel=1e-9)
    if d >= 3:
        assert fast.tie_broken


def test_degenerate_cluster_with_antisymmetric_bulk() -> None:
    # mu = 1: M = 2L, eigenvalue 0 (N-fold, symmetric) then 4 (antisymmetric): selecting past N
    # eigenvectors reaches the antisymmetric bulk, each adding 2 to delta^2.
    rng = np.random.default_rng(3)
    X_s, X_t = rng.normal(size=(2, 3, 2)) * 4
    for solver in ("structured", "dense"):
        result = aw.lra_embedding(X_s, X_t, mu=1.0, n_components=3, solver=solver)  # type: ignore[arg-type]
        assert result.delta == pytest.approx(np.sqrt(2.0), rel=1e-9)


def test_low_rank_representation_minimises_objective(rng: np.random.Generator) -> None:
    X = rng.normal(size=(15, 4)) * 2
    lam = 1.5

    def objective(R: np.ndarray) -> float:
        return 0.5 * np.linalg.norm(X - R @ X) ** 2 + lam * np.linalg.norm(R, "nuc")

    R = aw.paper._alignment.low_rank_representation(X, lam)
    best = objective(R)
    for _ in range(50):
        perturbation = rng.normal(size=R.shape) * 1e-3
        assert objective(R + perturbation) >= best - 1e-12


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"mu": 1.5}, r"'mu' parameter must be a float in \[0, 1\]. Got 1.5"),
        ({"n_components": 0}, r"'n_components' parameter must be an int >= 1. Got 0"),
        ({"n_components": 30}, r"'n_components' parameter must be <= 2 \* n_rows - 2 = 18"),
        ({"noise_level": 0.0}, r"'noise_level' parameter must be a float > 0. Got 0.0"),
        ({"solver": "qr"}, r"'solver' parameter must be 'structured' or 'dense'. Got 'qr'"),
    ],
)
def test_bad_parameters(kwargs: dict[str, object], message: str) -> None:
    X = np.ones((10, 3))
    with pytest.raises(ValueError, match=message):
        aw.lra_embedding(X, X, **kwargs)  # type: ignore[arg-type]


def test_shape_mismatch_and_nan() -> None:
    with pytest.raises(
        ValueError, match=r"same shape \(rows are paired\); got \(10, 3\) and \(9, 3\)"
    ):
        aw.lra_embedding(np.ones((10, 3)), np.ones((9, 3)))
    with pytest.raises(ValueError, match=r"same shape \(rows are paired\)"):
        aw.paper._alignment.lra_dense(np.ones((10, 3)), np.ones((9, 3)))
    with pytest.raises(ValueError, match=r"X_t contains NaN"):
        aw.lra_embedding(np.ones((10, 3)), np.full((10, 3), np.nan))
    with pytest.raises(ValueError, match=r"X_s must have shape \(n_rows, n_features\)"):
        aw.lra_embedding(np.ones(10), np.ones(10))


def test_structured_rejects_mismatched_bases() -> None:
    a = aw.low_rank_basis(np.eye(4) * 3)
    with pytest.raises(ValueError, match=r"same number of rows"):
        aw.paper._alignment.lra_structured(a, aw.low_rank_basis(np.eye(5) * 3))
    with pytest.raises(ValueError, match=r"different noise levels"):
        aw.paper._alignment.lra_structured(a, aw.low_rank_basis(np.eye(4) * 3, noise_level=2.0))
    with pytest.raises(ValueError, match=r"'noise_level' parameter must be a float > 0"):
        aw.low_rank_basis(np.eye(4), noise_level=-1.0)


def _delta_tolerance(delta: float) -> float:
    """The issue's target: the fast path's delta within 1e-9 + 1e-6 delta of the reference."""
    return 1e-9 + 1e-6 * delta


def _spectrum_matrix(rng: np.random.Generator, n: int, singular_values: np.ndarray) -> np.ndarray:
    left = np.linalg.qr(rng.normal(size=(n, singular_values.size)))[0]
    right = np.linalg.qr(rng.normal(size=(singular_values.size, singular_values.size)))[0]
    return np.asarray((left * singular_values) @ right)


@pytest.mark.parametrize(
    "singular_values",
    [
        np.logspace(0, 3, 12)[::-1],  # condition 1e3, all above the threshold
        np.array([50, 50, 50, 10, 10, 1 + 1e-7, 1.0, 1 - 1e-7, 0.5, 0.5, 1e-3, 0.0]),  # clusters
        np.array([40.0, 8.0, 3.0, 0, 0, 0, 0, 0]),  # rank-deficient
        np.array([3e4, 2.0, 1.5, 0.2]),  # lambda / s_max^2 = 1.1e-9, just above GRAM_RCOND
    ],
)
@pytest.mark.parametrize("seed", range(3))
def test_gram_basis_equals_direct_svd(singular_values: np.ndarray, seed: int) -> None:
    rng = np.random.default_rng(seed)
    X_s = _spectrum_matrix(rng, 300, singular_values)
    X_t = X_s + rng.normal(size=X_s.shape) * 0.05
    for lam, mu, d in [(1.0, 0.5, 2), (0.3, 0.2, 3)]:
        gram = [aw.low_rank_basis(X, lam, method="gram") for X in (X_s, X_t)]
        svd = [aw.low_rank_basis(X, lam, method="svd") for X in (X_s, X_t)]
        for fast, reference in zip(gram, svd, strict=True):
            # A singular value at the cut sqrt(lambda) may fall either side by a rounding error;
            # its weight 1 - lambda^2 / s^4 is ~0 there, so the projector below does not care.
            clear = reference.singular_values**2 > lam * (1 + 1e-6)
            np.testing.assert_allclose(
                fast.singular_values[: clear.sum()], reference.singular_values[clear], rtol=1e-10
            )
            # Same weighted projector U = V diag(w) V^T (signs and rotations inside clusters of
            # equal singular values are free), applied to a probe instead of formed as N x N.
            probe = rng.normal(size=(300, 3))
            np.testing.assert_allclose(
                fast.vectors @ ((fast.vectors.T @ probe) * fast.weights[:, None]),
                reference.vectors @ ((reference.vectors.T @ probe) * reference.weights[:, None]),
                atol=1e-9,
            )
        expected = aw.paper._alignment.lra_structured(*svd, mu=mu, n_components=d).delta
        got = aw.paper._alignment.lra_structured(*gram, mu=mu, n_components=d).delta
        assert abs(got - expected) <= _delta_tolerance(expected)


def test_gram_basis_equals_direct_svd_on_real_features(lab_features: list[np.ndarray]) -> None:
    for lam in (1.0, 1e-4):
        source = aw.low_rank_basis(lab_features[0], lam, method="svd")
        fast_source = aw.low_rank_basis(lab_features[0], lam, method="gram")
        for X_t in lab_features[1:5]:
            expected = aw.paper._alignment.lra_structured(
                source, aw.low_rank_basis(X_t, lam, method="svd")
            ).delta
            got = aw.paper._alignment.lra_structured(
                fast_source, aw.low_rank_basis(X_t, lam, method="gram")
            ).delta
            assert abs(got - expected) <= _delta_tolerance(expected)


def test_gram_route_falls_back_to_svd_when_ill_conditioned(rng: np.random.Generator) -> None:
    # lambda / s_max^2 = 1e-12 < GRAM_RCOND: the direct SVD's result, bit for bit.
    X = _spectrum_matrix(rng, 200, np.array([1e6, 30.0, 2.0, 0.5]))
    assert aw_alignment.GRAM_RCOND * 1e12 > 1.0
    gram, svd = aw.low_rank_basis(X, method="gram"), aw.low_rank_basis(X, method="svd")
    np.testing.assert_array_equal(gram.vectors, svd.vectors)
    np.testing.assert_array_equal(gram.singular_values, svd.singular_values)


def test_joint_basis_with_shared_and_nearly_shared_directions(rng: np.random.Generator) -> None:
    # Target spans share one direction exactly and one up to an angle of 1e-7 with the source:
    # both solvers and the literal equations agree.
    X_s = _spectrum_matrix(rng, 60, np.array([20.0, 9.0, 4.0, 0.1]))
    left = np.linalg.svd(X_s, full_matrices=False)[0]
    tilted = left[:, 1] + 1e-7 * left[:, 3]
    X_t = np.column_stack([left[:, 0] * 15, tilted / np.linalg.norm(tilted) * 6, left[:, 2] * 0])
    X_t = X_t + np.outer(rng.normal(size=60), [0, 0, 3.0]) / 8
    for d in (1, 2, 3):
        fast = aw.lra_embedding(X_s[:, :3], X_t, n_components=d)
        reference, _ = lra_delta(X_s[:, :3], X_t, 0.5, d)
        dense = aw.lra_embedding(X_s[:, :3], X_t, n_components=d, solver="dense")
        assert abs(fast.delta - dense.delta) <= _delta_tolerance(dense.delta)
        assert abs(fast.delta - reference) <= _delta_tolerance(reference)


def test_unknown_basis_method() -> None:
    with pytest.raises(
        ValueError, match=r"'method' parameter must be 'auto', 'gram', 'qr' or 'svd'"
    ):
        aw.low_rank_basis(np.eye(3), method="lu")  # type: ignore[arg-type]


def test_memory_grows_linearly_no_n_by_n_matrix() -> None:
    """Peak memory of the fast path at N = 40,000: far below one N x N float64 (12.8 GB)."""
    import tracemalloc

    rng = np.random.default_rng(7)
    n_rows, n_features = 40_000, 24
    t = np.arange(n_rows)[:, None] / 500.0
    X_s = np.abs(np.sin(t * rng.uniform(1, 40, n_features))) * 3 + rng.normal(size=(1, 24))
    X_t = X_s + 0.1 * rng.normal(size=X_s.shape)
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        aw.lra_embedding(X_s, X_t, n_components=3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    input_bytes = X_s.nbytes
    # Measured 8x one input (full rank: V_s, V_t, B and their temporaries are 48 columns wide);
    # a single N x N matrix would be 1,667 times one input.
    assert peak < 20 * input_bytes < n_rows**2 * 8 / 80
