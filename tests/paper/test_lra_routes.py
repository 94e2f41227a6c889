"""The QR route of ``low_rank_basis`` and the joint basis against the direct SVD and the dense
reference: ill-conditioned features (the 60 s capture's case) and robot-simulator features."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
import axiswatch.paper._alignment as aw_alignment


def _delta_tolerance(delta: float) -> float:
    return 1e-9 + 1e-6 * delta


def _spectrum_matrix(rng: np.random.Generator, n: int, singular_values: np.ndarray) -> np.ndarray:
    left = np.linalg.qr(rng.normal(size=(n, singular_values.size)))[0]
    right = np.linalg.qr(rng.normal(size=(singular_values.size, singular_values.size)))[0]
    return np.asarray((left * singular_values) @ right)


def _projector_on(basis: aw.LowRankBasis, probe: np.ndarray) -> np.ndarray:
    """``V diag(w) V^T probe``: free of signs and rotations inside clusters."""
    return np.asarray(basis.vectors @ ((basis.vectors.T @ probe) * basis.weights[:, None]))


@pytest.mark.parametrize(
    "singular_values",
    [
        np.logspace(0, 3, 12)[::-1],  # well conditioned
        np.array([50, 50, 10, 1 + 1e-7, 1.0, 1 - 1e-7, 0.5, 1e-3, 0.0]),  # clusters, cut, zero
        np.array([1e6, 30.0, 2.0, 0.5]),  # lambda / s_max^2 = 1e-12: the Gram route refuses
        np.array([1e8, 3e3, 2.0, 1.01, 0.99, 0.5]),  # cond > 1e6: Householder in the Ritz step
    ],
)
@pytest.mark.parametrize("n_rows", [300, 9000])  # 9000 rows: three blocks of the blocked QR
def test_qr_route_equals_direct_svd(singular_values: np.ndarray, n_rows: int) -> None:
    rng = np.random.default_rng(n_rows)
    X_s = _spectrum_matrix(rng, n_rows, singular_values)
    X_t = X_s + rng.normal(size=X_s.shape) * 0.05
    probe = rng.normal(size=(n_rows, 3))
    qr = [aw.low_rank_basis(X, method="qr") for X in (X_s, X_t)]
    svd = [aw.low_rank_basis(X, method="svd") for X in (X_s, X_t)]
    for fast, reference in zip(qr, svd, strict=True):
        # Any backward-stable SVD is exact to about eps * s_max, absolute: the SVD too.
        clear = reference.singular_values**2 > 1 + 1e-6
        np.testing.assert_allclose(
            fast.singular_values[: clear.sum()],
            reference.singular_values[clear],
            rtol=1e-10,
            atol=10 * np.finfo(float).eps * singular_values.max(),
        )
        np.testing.assert_allclose(
            fast.vectors.T @ fast.vectors, np.eye(fast.rank), atol=1e-13, rtol=0
        )
        np.testing.assert_allclose(
            _projector_on(fast, probe), _projector_on(reference, probe), atol=1e-9
        )
    expected = aw_alignment.lra_structured(*svd).delta
    assert abs(aw_alignment.lra_structured(*qr).delta - expected) <= _delta_tolerance(expected)


def test_auto_takes_qr_route_when_gram_refuses(rng: np.random.Generator) -> None:
    X = _spectrum_matrix(rng, 400, np.array([1e6, 30.0, 2.0, 0.5]))
    auto, qr = aw.low_rank_basis(X), aw.low_rank_basis(X, method="qr")
    np.testing.assert_array_equal(auto.vectors, qr.vectors)
    np.testing.assert_array_equal(auto.singular_values, qr.singular_values)


def test_joint_basis_spans_both_and_is_orthogonal_to_source(rng: np.random.Generator) -> None:
    # Target shares two directions with the source, one of them up to an angle of 1e-8.
    source = np.linalg.qr(rng.normal(size=(5000, 6)))[0]
    extra = np.linalg.qr(
        rng.normal(size=(5000, 3)) - source @ (source.T @ rng.normal(size=(5000, 3)))
    )[0]
    tilted = source[:, 1] + 1e-8 * extra[:, 2]
    target = np.column_stack([source[:, 0], tilted / np.linalg.norm(tilted), extra[:, :2]])
    added, shared, coordinates = aw_alignment._joint_basis(source, target.copy())
    assert added.shape[1] == 3  # two new directions and the tilt (sine 1e-8 > _SPAN_RTOL)
    np.testing.assert_allclose(added.T @ added, np.eye(3), atol=1e-13, rtol=0)
    np.testing.assert_allclose(source.T @ added, 0.0, atol=1e-13)
    joint = np.hstack([source, added])
    np.testing.assert_allclose(joint @ (joint.T @ target), target, atol=1e-13)
    np.testing.assert_allclose(shared, source.T @ target, atol=1e-15)
    np.testing.assert_allclose(coordinates, added.T @ target, atol=1e-13)


@pytest.mark.parametrize(("task_s", "task_t"), [("heavy", "palletize"), ("heavy", "heavy")])
def test_structured_equals_dense_on_robot_features(task_s: str, task_t: str) -> None:
    X_s, X_t = (
        aw.extract_features(awd.simulate_capture(task, seed=seed, duration_s=0.4)).X[:600]
        for task, seed in ((task_s, 1), (task_t, 2))
    )
    for mu, d in [(0.5, 2), (0.2, 4)]:
        fast = aw.lra_embedding(X_s, X_t, mu=mu, n_components=d)
        dense = aw.lra_embedding(X_s, X_t, mu=mu, n_components=d, solver="dense")
        assert min(fast.rank_source, fast.rank_target) > 20  # not the synthetic low rank
        assert abs(fast.delta - dense.delta) <= _delta_tolerance(dense.delta)
        np.testing.assert_allclose(fast.eigenvalues, dense.eigenvalues, atol=1e-10)


@pytest.mark.parametrize("smallest", [1e-3, 1e-9])  # the Gram's sines, then the QR's
def test_residual_sines_equal_the_direct_svd(rng: np.random.Generator, smallest: float) -> None:
    sines = np.array([1.0, 0.5, 0.1, 0.01, smallest])
    E = _spectrum_matrix(rng, 3000, sines)
    fast, right = aw_alignment._residual_sines(E)
    _, reference, reference_right = np.linalg.svd(E, full_matrices=False)
    np.testing.assert_allclose(fast, reference, rtol=1e-7 if smallest > 1e-8 else 1e-6)
    # Right vectors up to sign: distinct sines, so each is determined.
    np.testing.assert_allclose(np.abs(right @ reference_right.T), np.eye(5), atol=1e-7)


def test_lowest_eigenpairs_widen_until_the_cut_is_clear(rng: np.random.Generator) -> None:
    # 20 equal eigenvalues straddle the first subset (13 pairs): all of them must come back.
    spectrum = np.concatenate([[0.0], np.full(20, 0.3), np.linspace(1.0, 2.0, 30)])
    rotation = np.linalg.qr(rng.normal(size=(51, 51)))[0]
    matrix = (rotation * spectrum) @ rotation.T
    values, vectors = aw_alignment._lowest_eigenpairs(matrix, np.array([0.5, 1.5]), 3, 1e-9)
    assert values.size >= 21
    np.testing.assert_allclose(values[:21], spectrum[:21], atol=1e-12)
    np.testing.assert_allclose(matrix @ vectors, vectors * values, atol=1e-12)
    few, _ = aw_alignment._lowest_eigenpairs(matrix, np.array([0.5, 1.5]), 1, 1e-9)
    assert few.size == 11  # wanted + 10: the cut at 0.0 is clear at once
