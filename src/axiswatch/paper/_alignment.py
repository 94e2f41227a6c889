"""Low Rank Alignment (LRA): a joint embedding of baseline and test features.

Paper, section "Proposed Method", eqs. (2)-(8), after Boucher et al., AAAI 2015. The exact
structured solver and its tie-break are derived in docs/internals.md, "LRA solvers".
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = [
    "LRAResult",
    "LowRankBasis",
    "low_rank_basis",
    "low_rank_representation",
    "lra_dense",
    "lra_embedding",
    "lra_structured",
]

#: Eigenvalues of M closer than this are one degenerate cluster (M's spectrum lies in [0, 1 + 3 mu]).
DEGENERACY_TOL = 1e-9
#: low_rank_basis's Gram route is used only when lambda >= GRAM_RCOND * s_max^2 (see its Notes).
GRAM_RCOND = 1e-10
#: Rows of ``X`` per step of the blocked QR in ``low_rank_basis(method="qr")``.
_QR_BLOCK_ROWS = 4096
#: Principal angles between span(V_s) and span(V_t) with a sine below this count as shared (W's basis).
_SPAN_RTOL = 1e-10
#: The joint basis reads the sines from the Gram of V_t's residual when all their squares exceed
#: this (relative error below about 1e-7); else from the R of its Householder QR.
_GRAM_SINE2 = 1e-8


@dataclass(frozen=True)
class LowRankBasis:
    """The part of ``X``'s SVD that enters the low-rank representation ``R``.

    Attributes
    ----------
    vectors : ndarray of shape (n_rows, rank)
        Left singular vectors of ``X`` whose singular value exceeds ``sqrt(noise_level)``.
    singular_values : ndarray of shape (rank,)
    noise_level : float
        The ``lambda`` of the objective.
    """

    vectors: NDArray[np.float64]
    singular_values: NDArray[np.float64]
    noise_level: float

    @property
    def rank(self) -> int:
        """Number of singular values kept."""
        return int(self.singular_values.size)

    @property
    def weights(self) -> NDArray[np.float64]:
        """``1 - lambda^2 / s^4``: the eigenvalues of ``U = I - (I - R)^T (I - R)`` on ``vectors``."""
        return 1.0 - (self.noise_level / self.singular_values**2) ** 2


@dataclass(frozen=True)
class LRAResult:
    """Outcome of one Low Rank Alignment.

    Attributes
    ----------
    delta : float
        ``||F_s - F_t||_F``, the paper's distance.
    F_s, F_t : ndarray of shape (n_rows, n_components)
        Embedding of source (baseline) and target (test) rows. Column signs are fixed so that the
        largest-magnitude entry of each column of ``[F_s; F_t]`` is positive.
    eigenvalues : ndarray of shape (n_components + 2,)
        The smallest eigenvalues of ``M``: the trivial one, the selected ones, the next one.
    eigengap : float
        ``min(nu_1 - nu_0, nu_{d+1} - nu_d)``: how well the selected span is determined.
    tie_broken : bool
        True when a cluster straddling a cut was resolved by the correspondence tie-break.
    rank_source, rank_target : int
        Singular values kept in ``R_s`` and ``R_t``.
    """

    delta: float
    F_s: NDArray[np.float64]
    F_t: NDArray[np.float64]
    eigenvalues: NDArray[np.float64]
    eigengap: float
    tie_broken: bool
    rank_source: int
    rank_target: int


def _check_features(X: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    array = np.asarray(X, dtype=np.float64)
    if array.ndim != 2 or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"{name} must have shape (n_rows, n_features); got shape {array.shape}.")
    # A finite sum is a finite matrix, and costs no mask as large as the features.
    if not np.isfinite(array.sum()) and not np.isfinite(array).all():
        raise ValueError(f"{name} contains NaN or inf; expected finite features.")
    return array


def _check_parameters(mu: float, n_components: int, noise_level: float, n_rows: int) -> None:
    if not (isinstance(mu, int | float | np.floating) and 0.0 <= float(mu) <= 1.0):
        raise ValueError(f"The 'mu' parameter must be a float in [0, 1]. Got {mu!r} instead.")
    if not (isinstance(n_components, int | np.integer) and n_components >= 1):
        raise ValueError(
            f"The 'n_components' parameter must be an int >= 1. Got {n_components!r} instead."
        )
    if 2 * n_rows < n_components + 2:
        raise ValueError(
            f"The 'n_components' parameter must be <= 2 * n_rows - 2 = {2 * n_rows - 2} "
            f"(one trivial and one following eigenvalue are needed). Got {n_components} instead."
        )
    if not (isinstance(noise_level, int | float | np.floating) and float(noise_level) > 0.0):
        raise ValueError(
            f"The 'noise_level' parameter must be a float > 0. Got {noise_level!r} instead."
        )


def _check_pair(
    X_s: NDArray[np.float64],
    X_t: NDArray[np.float64],
    mu: float,
    n_components: int,
    noise_level: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate a baseline/test pair of feature matrices and the LRA parameters."""
    X_s = _check_features(X_s, "X_s")
    X_t = _check_features(X_t, "X_t")
    if X_s.shape != X_t.shape:
        raise ValueError(
            f"X_s and X_t must have the same shape (rows are paired); got {X_s.shape} and "
            f"{X_t.shape}."
        )
    _check_parameters(mu, n_components, noise_level, X_s.shape[0])
    return X_s, X_t


def low_rank_basis(
    X: NDArray[np.float64],
    noise_level: float = 1.0,
    *,
    method: Literal["auto", "gram", "qr", "svd"] = "auto",
    overwrite_x: bool = False,
) -> LowRankBasis:
    """Singular vectors and values of ``X`` that enter ``R`` (those above ``sqrt(noise_level)``).

    Parameters
    ----------
    X : ndarray of shape (n_rows, n_features)
    noise_level : float, default=1.0
        ``lambda`` of the objective ``1/2 ||X - R X||_F^2 + lambda ||R||_*``.
    method : {"auto", "gram", "qr", "svd"}, default="auto"
        ``"svd"``: the thin SVD of ``X``, ``O(N K^2)`` with a large constant. ``"gram"``: the
        eigenvectors of the ``K x K`` Gram matrix ``X^T X`` locate the subspace, and a thin SVD
        of ``X`` restricted to it (``N x r'``, a Rayleigh-Ritz step) gives orthonormal vectors
        and accurate singular values; it falls back to ``"svd"`` when ``X`` is too ill
        conditioned for it (``lambda < GRAM_RCOND * s_max^2``). ``"qr"``: the right singular
        vectors of the ``R`` factor of a blocked Householder QR of ``X`` (``Q`` never formed, a
        few thousand rows at a time) locate the subspace, then the same Rayleigh-Ritz step.
        ``"auto"``: for tall ``X`` (``N > K``) ``"gram"``, or ``"qr"`` where ``"gram"`` would
        fall back; else ``"svd"``. See Notes for the accuracy.
    overwrite_x : bool, default=False
        Let the Gram and QR routes build the vectors in ``X``'s memory (``X`` is destroyed): no
        ``N x r`` array is allocated, the vectors are a view of ``X``'s leading columns.

    Returns
    -------
    LowRankBasis

    Notes
    -----
    The Gram route squares the condition number: its eigenvectors are off by an angle of about
    ``eps s_max^2 / gap``. It keeps the subspace of ``X^T X``'s eigenvalues above
    ``lambda / 4``, so the gap between the directions that enter ``R`` (``s^2 > lambda``) and
    those left out (``s^2 < lambda / 4``) is at least ``3 lambda / 4``: the angle is below about
    ``2 eps s_max^2 / lambda``. Left-out directions leak into ``X``'s restriction with a weight
    below ``sqrt(lambda) / 2`` times that angle, so kept vectors and values move by less than it,
    relative, and the weights ``1 - lambda^2 / s^4`` of directions near the cut vanish, so the
    choice at the cut hardly matters. ``s_max^2`` grows with ``N`` (a 60 s capture's is ~400
    times a 300-row one's), so ``GRAM_RCOND = 1e-10`` is set from measurements rather than from
    this loose bound: with the lab features and ``lambda / s_max^2`` from ``8.5e-5`` down to
    ``8.5e-11``, forced Gram and direct SVD gave LRA distances within ``1.4e-3`` of the target
    tolerance ``1e-9 + 1e-6 delta``. Below ``GRAM_RCOND`` the direct SVD is used.

    The QR route does not square the condition number: Householder QR is backward stable, so
    ``R``'s right singular vectors are as accurate as ``X``'s own (an angle of about
    ``eps s_max / gap``). It costs about a third of the direct SVD (no ``N x K`` factor is
    formed) and holds no copy of ``X``. Tests compare every route on random, rank-deficient,
    clustered, ill-conditioned and real features.

    Examples
    --------
    >>> import numpy as np
    >>> basis = low_rank_basis(np.diag([3.0, 2.0, 0.5]))
    >>> basis.rank, basis.singular_values.tolist()
    (2, [3.0, 2.0])
    >>> X = np.random.default_rng(0).normal(size=(500, 8)) * 3
    >>> gram, svd = low_rank_basis(X, method="gram"), low_rank_basis(X, method="svd")
    >>> bool(np.allclose(gram.singular_values, svd.singular_values, rtol=1e-12))
    True
    """
    X = _check_features(X, "X")
    if not float(noise_level) > 0.0:
        raise ValueError(
            f"The 'noise_level' parameter must be a float > 0. Got {noise_level!r} instead."
        )
    if method not in ("auto", "gram", "qr", "svd"):
        raise ValueError(
            f"The 'method' parameter must be 'auto', 'gram', 'qr' or 'svd'. Got {method!r} instead."
        )
    noise_level = float(noise_level)
    tall = X.shape[0] > X.shape[1]
    if method == "gram" or (method == "auto" and tall):
        basis = _gram_basis(X, noise_level, overwrite_x)
        if basis is not None:
            return basis
    if method == "qr" or (method == "auto" and tall):
        return _qr_basis(X, noise_level, overwrite_x)
    left, singular, _ = scipy.linalg.svd(X, full_matrices=False, check_finite=False)
    keep = singular > np.sqrt(noise_level)
    return LowRankBasis(left[:, keep], singular[keep], noise_level)


def _gram_basis(
    X: NDArray[np.float64], noise_level: float, overwrite_x: bool = False
) -> LowRankBasis | None:
    """:func:`low_rank_basis` through ``X^T X``; None when ``X`` is too ill conditioned for it."""
    gram = X.T @ X
    # Divide and conquer: faster here than a subset by the default driver (8.9 -> 6.7 ms, K=390).
    eigenvalues, eigenvectors = scipy.linalg.eigh(gram, driver="evd", check_finite=False)
    largest = float(eigenvalues[-1])
    if noise_level < GRAM_RCOND * largest:
        return None
    guarded = eigenvalues > noise_level / 4.0
    return _ritz_basis(
        X, eigenvectors[:, guarded], np.sqrt(eigenvalues[guarded]), noise_level, overwrite_x
    )


def _qr_basis(
    X: NDArray[np.float64], noise_level: float, overwrite_x: bool = False
) -> LowRankBasis:
    """:func:`low_rank_basis` through the ``R`` of a blocked (TSQR) Householder QR of ``X``."""
    _, singular, right = scipy.linalg.svd(_tsqr_r(X), check_finite=False)
    count = int(np.sum(singular**2 > noise_level / 4.0))
    return _ritz_basis(X, right[:count].T, singular[:count], noise_level, overwrite_x)


def _tsqr_r(Y: NDArray[np.float64]) -> NDArray[np.float64]:
    """The ``R`` of ``Y = Q R`` (Householder, backward stable), a block of rows at a time.

    Tall-skinny QR: each block is stacked under the ``R`` so far and factored again, so no copy
    of ``Y`` and no ``Q`` are ever held.
    """
    n_columns = Y.shape[1]
    R = np.zeros((0, n_columns))
    for start in range(0, Y.shape[0], _QR_BLOCK_ROWS):
        stacked = np.vstack([R, Y[start : start + _QR_BLOCK_ROWS]])
        R = scipy.linalg.qr(stacked, mode="r", overwrite_a=True, check_finite=False)[0]
        R = R[: min(R.shape[0], n_columns)]
    return R


def _ritz_basis(
    X: NDArray[np.float64],
    guarded: NDArray[np.float64],
    scales: NDArray[np.float64],
    noise_level: float,
    overwrite_x: bool = False,
) -> LowRankBasis:
    """Rayleigh-Ritz: the SVD of ``X`` restricted to the orthonormal columns of ``guarded``
    (``K x r``), as ``(N x r) Q`` times ``(r x r) R``.

    ``scales`` are ``X``'s singular values along those columns, all above ``sqrt(lambda) / 2``,
    as the Gram or QR route computed them. ``X @ guarded / scales`` then has orthonormal columns
    up to about ``4 eps s_max^2 / lambda`` (Gram route, at most ``1e-5`` above ``GRAM_RCOND``)
    or ``2 eps s_max / sqrt(lambda)`` (QR route), so one Cholesky QR pass makes ``Q``
    orthonormal to rounding. ``Q`` is rotated onto the singular vectors in place: the vectors
    are a view of its leading columns, and no second ``N x r`` array is made. With
    ``overwrite_x``, ``Q`` itself is built in ``X``'s leading columns.
    """
    scaled = guarded / scales
    Q, R = _cholesky_qr(_times_in_place(X, scaled) if overwrite_x else X @ scaled, passes=1)
    left, singular, _ = scipy.linalg.svd(R * scales, check_finite=False)
    keep = singular > np.sqrt(noise_level)
    return LowRankBasis(_times_in_place(Q, left[:, keep]), singular[keep], noise_level)


def _row_blocks(n_rows: int) -> list[slice]:
    return [slice(start, start + _QR_BLOCK_ROWS) for start in range(0, n_rows, _QR_BLOCK_ROWS)]


def _times_in_place(Y: NDArray[np.float64], right: NDArray[np.float64]) -> NDArray[np.float64]:
    """``Y @ right`` written over ``Y``'s leading columns, a block of rows at a time (rows do
    not mix); ``right`` has at most as many columns as ``Y``. Returns the view."""
    width = right.shape[1]
    for rows in _row_blocks(Y.shape[0]):
        Y[rows, :width] = Y[rows] @ right
    return Y[:, :width]


def _project_out(
    Y: NDArray[np.float64], V: NDArray[np.float64], coefficients: NDArray[np.float64]
) -> None:
    """``Y -= V @ coefficients`` in place, a block of rows at a time (no ``N x r`` temporary)."""
    for rows in _row_blocks(Y.shape[0]):
        Y[rows] -= V[rows] @ coefficients


def _cholesky_qr(
    Y: NDArray[np.float64], passes: int = 2
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``Y = Q R`` with orthonormal ``Q`` (to rounding), by Cholesky QR done ``passes`` times.

    Two passes give ``Q``'s columns orthonormal to machine precision when ``cond(Y)`` is below
    about ``1e7`` (Yamamoto et al., "Roundoff error analysis of the CholeskyQR2 algorithm", 2015);
    one pass when ``Y``'s columns are orthonormal up to ``1e-5`` or so (its error is about
    ``eps cond(Y)^2``). It is BLAS-3 and several times faster than Householder QR or an SVD of a
    tall ``Y``. ``Y`` is overwritten by ``Q`` (also where it is a view of wider rows).
    """
    R = np.eye(Y.shape[1])
    contiguous = Y.flags.c_contiguous
    for _ in range(passes):
        factor = scipy.linalg.cholesky(Y.T @ Y, lower=False, check_finite=False)
        if contiguous:
            # Y.T is Fortran-ordered: the triangular solve writes into Y's memory.
            Y = scipy.linalg.solve_triangular(
                factor, Y.T, trans="T", overwrite_b=True, check_finite=False
            ).T
        else:
            for rows in _row_blocks(Y.shape[0]):
                Y[rows] = scipy.linalg.solve_triangular(
                    factor, Y[rows].T, trans="T", check_finite=False
                ).T
        R = factor @ R
    return (np.ascontiguousarray(Y) if contiguous else Y), R


def _joint_basis(
    V_s: NDArray[np.float64], work: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """What ``V_t`` adds to ``span(V_s)``, computed in ``work`` (``V_t`` on entry, overwritten).

    Returns ``A``, ``V_s^T V_t`` and ``A^T V_t``, where ``A`` is orthonormal with ``[V_s, A]`` a
    basis of ``span(V_s) + span(V_t)``; ``A`` is a view of ``work``'s leading columns.
    ``O(N r^2)``, with no ``N x r`` temporary. The part ``E`` of ``V_t`` outside ``span(V_s)``
    (projected out twice: "twice is enough") has singular values ``sin(theta)``, the principal
    angles between the two spans (:func:`_residual_sines`). Directions with ``sin(theta) <=
    _SPAN_RTOL`` are taken as shared, which moves ``V_t`` by at most that much. The kept
    directions ``E W`` (``W = right / sines``) are orthonormal up to about ``eps / sin(theta)``
    (at most ``2e-6``): projected out once more and orthonormalised by one Cholesky QR pass,
    ``E W = A R_A``. ``A`` is orthogonal to ``V_s``, so ``A^T V_t = A^T E = R_A^{-T} (E W)^T
    E``; the product is taken block by block, before ``E W`` overwrites ``E``.
    """
    n_rows, n_target = work.shape
    shared = V_s.T @ work
    if n_target == 0:
        return np.zeros((n_rows, 0)), shared, np.zeros((0, 0))
    _project_out(work, V_s, shared)
    _project_out(work, V_s, V_s.T @ work)
    sines, right = _residual_sines(work)
    count = int(np.sum(sines > _SPAN_RTOL))
    if count == 0:
        return np.zeros((n_rows, 0)), shared, np.zeros((0, n_target))
    scaled = right[:count].T / sines[:count]
    products = np.zeros((count, n_target))  # (E W)^T E, as E W is computed
    for rows in _row_blocks(n_rows):
        block = work[rows] @ scaled
        products += block.T @ work[rows]
        work[rows, :count] = block
    added = work[:, :count]
    _project_out(added, V_s, V_s.T @ added)
    added, factor = _cholesky_qr(added, passes=1)
    coordinates = scipy.linalg.solve_triangular(factor, products, trans="T", check_finite=False)
    return added, shared, coordinates


def _residual_sines(E: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Singular values (descending) and right singular vectors (rows) of ``E``.

    The eigenvalues of ``E^T E`` when they all exceed ``_GRAM_SINE2``: ``E`` is then well
    conditioned, and this is ten times faster than a QR. Else the SVD of the ``R`` of its
    Householder QR, accurate for sines down to ``eps``.
    """
    squares, vectors = scipy.linalg.eigh(E.T @ E, check_finite=False)
    if squares[0] > _GRAM_SINE2:
        return np.sqrt(squares[::-1]), vectors[:, ::-1].T
    _, sines, right = scipy.linalg.svd(_tsqr_r(E), check_finite=False)
    return sines, right


def low_rank_representation(
    X: NDArray[np.float64], noise_level: float = 1.0
) -> NDArray[np.float64]:
    """The ``N x N`` reconstruction matrix ``R = V (I - lambda S^-2) V^T`` (paper eqs. 3-4).

    Dense; for inspection and tests. The solvers use :func:`low_rank_basis` instead.

    Examples
    --------
    >>> import numpy as np
    >>> R = low_rank_representation(np.diag([2.0, 0.5]))
    >>> np.round(R, 3)
    array([[0.75, 0.  ],
           [0.  , 0.  ]])
    """
    basis = low_rank_basis(X, noise_level)
    shrink = 1.0 - noise_level / basis.singular_values**2
    return (basis.vectors * shrink) @ basis.vectors.T


def _clusters(values: NDArray[np.float64], tol: float) -> list[tuple[int, int]]:
    """Half-open index ranges of runs of sorted values whose neighbours differ by <= tol."""
    bounds = [0, *(np.flatnonzero(np.diff(values) > tol) + 1).tolist(), values.size]
    return list(itertools.pairwise(bounds))


def _fix_signs(F: NDArray[np.float64]) -> NDArray[np.float64]:
    pivot = np.abs(F).argmax(axis=0)
    signs = np.sign(F[pivot, np.arange(F.shape[1])])
    signs[signs == 0] = 1.0
    return np.asarray(F * signs, dtype=np.float64)


def _result(
    values: NDArray[np.float64],
    F: NDArray[np.float64],
    l_forms: NDArray[np.float64],
    n_components: int,
    tol: float,
    ranks: tuple[int, int],
) -> LRAResult:
    n_rows = F.shape[0] // 2
    d = n_components
    gap = float(min(values[1] - values[0], values[d + 1] - values[d]))
    selected = slice(1, d + 1)
    F = _fix_signs(F[:, selected])
    return LRAResult(
        delta=float(np.sqrt(max(float(l_forms[selected].sum()), 0.0))),
        F_s=F[:n_rows],
        F_t=F[n_rows:],
        eigenvalues=values[: d + 2].copy(),
        eigengap=gap,
        tie_broken=gap <= tol,
        rank_source=ranks[0],
        rank_target=ranks[1],
    )


def lra_dense(
    X_s: NDArray[np.float64],
    X_t: NDArray[np.float64],
    *,
    mu: float = 0.5,
    n_components: int = 2,
    noise_level: float = 1.0,
    degeneracy_tol: float = DEGENERACY_TOL,
) -> LRAResult:
    """LRA by the literal dense eigenproblem of size ``2N x 2N``: the reference solver.

    ``O(N^3)`` time and ``O(N^2)`` memory; see :func:`lra_structured` for the exact fast form.
    Parameters and result as in :func:`lra_embedding`.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(40, 6))
    >>> round(lra_dense(X, X).delta, 12)
    0.0
    """
    X_s, X_t = _check_pair(X_s, X_t, mu, n_components, noise_level)
    n_rows = X_s.shape[0]
    identity = np.eye(n_rows)
    R = scipy.linalg.block_diag(
        low_rank_representation(X_s, noise_level), low_rank_representation(X_t, noise_level)
    )
    residual = np.eye(2 * n_rows) - R
    laplacian = np.block([[identity, -identity], [-identity, identity]])
    M = (1.0 - mu) * residual.T @ residual + 2.0 * mu * laplacian
    # Enough eigenpairs to see every cluster that touches the cuts; widened until the last cluster
    # ends inside the computed range.
    count = min(2 * n_rows, n_components + 10)
    while True:
        values, vectors = scipy.linalg.eigh(M, subset_by_index=[0, count - 1])
        runs = _clusters(values, degeneracy_tol)
        if count == 2 * n_rows or runs[-1][0] > n_components + 1:
            break
        count = min(2 * n_rows, 2 * count)
    l_forms = np.einsum("ij,ij->j", vectors, laplacian @ vectors)
    for start, stop in runs:
        if stop - start > 1:
            block = vectors[:, start:stop]
            l_forms[start:stop], rotation = np.linalg.eigh(block.T @ laplacian @ block)
            vectors[:, start:stop] = block @ rotation
    basis_ranks = (
        low_rank_basis(X_s, noise_level).rank,
        low_rank_basis(X_t, noise_level).rank,
    )
    return _result(values, vectors, l_forms, n_components, degeneracy_tol, basis_ranks)


def _lowest_eigenpairs(
    matrix: NDArray[np.float64], others: NDArray[np.float64], wanted: int, tol: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The lowest eigenpairs of the symmetric ``matrix``, enough of them that no value left out
    can reach a cluster (``tol``) that touches the ``wanted`` lowest of them and ``others``.

    A subset costs half the full eigendecomposition here; widened until the cut is clear.
    """
    size = matrix.shape[0]
    count = min(size, wanted + 10)
    while True:
        if count == 0:
            return np.zeros(0), np.zeros((0, 0))
        values, vectors = scipy.linalg.eigh(
            matrix, subset_by_index=[0, count - 1], driver="evr", check_finite=False
        )
        if count == size:
            return values, vectors
        union = np.sort(np.concatenate([values, others]))
        _, stop = next(run for run in _clusters(union, tol) if run[0] < wanted <= run[1])
        if values[-1] > union[stop - 1] + tol:
            return values, vectors
        count = min(size, 2 * count)


def _complement_vectors(
    blocks: tuple[NDArray[np.float64], ...], n_rows: int, count: int
) -> NDArray[np.float64]:
    """``count`` orthonormal vectors orthogonal to the columns of the orthonormal ``blocks``
    (together orthonormal): canonical, from e_0, e_1, ..."""
    if count == 0:
        return np.zeros((n_rows, 0))
    width = min(n_rows, count + sum(block.shape[1] for block in blocks))
    candidates = np.eye(n_rows, width)
    for block in blocks:
        candidates -= block @ block[:width].T
    q, r = np.linalg.qr(candidates)
    good = np.abs(np.diag(r)) > 1e-8
    return q[:, good][:, :count]


def lra_structured(
    source: LowRankBasis,
    target: LowRankBasis,
    *,
    mu: float = 0.5,
    n_components: int = 2,
    degeneracy_tol: float = DEGENERACY_TOL,
    overwrite_target: bool = False,
) -> LRAResult:
    """Exact LRA from the two low-rank bases, in ``O(N k^2 + k^3)`` (see the module docstring).

    Parameters
    ----------
    source, target : LowRankBasis
        From :func:`low_rank_basis` of ``X_s`` and ``X_t`` (same ``noise_level`` and row count).
        The source basis can be computed once per baseline and reused for every test capture.
    mu, n_components, degeneracy_tol
        As in :func:`lra_embedding`.
    overwrite_target : bool, default=False
        Work in ``target.vectors`` (destroyed) instead of a copy: saves an ``N x r`` array.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X_s, X_t = rng.normal(size=(2, 50, 8)) * 3
    >>> fast = lra_structured(low_rank_basis(X_s), low_rank_basis(X_t))
    >>> bool(np.isclose(fast.delta, lra_dense(X_s, X_t).delta, rtol=1e-8))
    True
    """
    if source.vectors.shape[0] != target.vectors.shape[0]:
        raise ValueError(
            "source and target must have the same number of rows (rows are paired); got "
            f"{source.vectors.shape[0]} and {target.vectors.shape[0]}."
        )
    if source.noise_level != target.noise_level:
        raise ValueError(
            f"source and target were computed with different noise levels "
            f"({source.noise_level} and {target.noise_level})."
        )
    n_rows = source.vectors.shape[0]
    _check_parameters(mu, n_components, source.noise_level, n_rows)
    # The joint basis B = [V_s, A], never formed: in it V_s is [I; 0] and V_t is P_t.
    V_s = source.vectors
    work = target.vectors if overwrite_target else target.vectors.copy()
    A, shared, added = _joint_basis(V_s, work)
    r_s, k = V_s.shape[1], V_s.shape[1] + A.shape[1]
    P_t = np.vstack([shared, added])
    G_s = np.zeros((k, k))
    G_s[np.arange(r_s), np.arange(r_s)] = source.weights
    G_t = (P_t * target.weights) @ P_t.T
    small = np.eye(2 * k) * (1.0 - mu)
    small[k:, k:] += 4.0 * mu * np.eye(k)
    small -= 0.5 * (1.0 - mu) * np.block([[G_s + G_t, G_s - G_t], [G_s - G_t, G_s + G_t]])
    # Closed-form part: only the first few copies of each bulk eigenvalue can reach the cuts.
    n_bulk = min(n_rows - k, n_components + 2)
    bulk = np.concatenate([np.full(n_bulk, 1.0 - mu), np.full(n_bulk, 1.0 + 3.0 * mu)])
    small_values, Z = _lowest_eigenpairs(small, bulk, n_components + 2, degeneracy_tol)
    n_small = small_values.size
    values = np.concatenate([small_values, bulk])
    kind = np.concatenate([np.zeros(n_small, int), np.ones(n_bulk, int), np.full(n_bulk, 2)])
    l_forms = np.concatenate(
        [2.0 * np.einsum("ij,ij->j", Z[k:], Z[k:]), np.zeros(n_bulk), np.full(n_bulk, 2.0)]
    )
    column = np.concatenate([np.arange(n_small), np.arange(n_bulk), np.arange(n_bulk)])
    # Sort by eigenvalue, then by correspondence cost inside exact ties (bulk copies are identical).
    order = np.lexsort((l_forms, values))
    values, kind, l_forms, column = values[order], kind[order], l_forms[order], column[order]
    Z = Z.copy()
    for start, stop in _clusters(values, degeneracy_tol):
        members = np.arange(start, stop)[kind[start:stop] == 0]
        if members.size > 1:
            cols = column[members]
            block = Z[:, cols]
            forms, rotation = np.linalg.eigh(2.0 * block[k:].T @ block[k:])
            Z[:, cols] = block @ rotation
            l_forms[members] = forms
        if stop - start > 1:
            inner = np.argsort(l_forms[start:stop], kind="stable") + start
            kind[start:stop], l_forms[start:stop], column[start:stop] = (
                kind[inner],
                l_forms[inner],
                column[inner],
            )
    # Embedding vectors, only for the columns we return (indices 0 .. d).
    wanted = n_components + 1
    n_sym = int((kind[:wanted] == 1).sum())
    n_anti = int((kind[:wanted] == 2).sum())
    complement = _complement_vectors((V_s, A), n_rows, n_sym + n_anti)
    F = np.zeros((2 * n_rows, n_components + 2))
    used_sym, used_anti = 0, 0
    for j in range(wanted):
        if kind[j] == 0:
            y1 = V_s @ Z[:r_s, column[j]] + A @ Z[r_s:k, column[j]]
            y2 = V_s @ Z[k : k + r_s, column[j]] + A @ Z[k + r_s :, column[j]]
        elif kind[j] == 1:
            y1, y2 = complement[:, used_sym], np.zeros(n_rows)
            used_sym += 1
        else:
            y1, y2 = np.zeros(n_rows), complement[:, n_sym + used_anti]
            used_anti += 1
        F[:n_rows, j] = (y1 + y2) / np.sqrt(2.0)
        F[n_rows:, j] = (y1 - y2) / np.sqrt(2.0)
    return _result(values, F, l_forms, n_components, degeneracy_tol, (source.rank, target.rank))


def lra_embedding(
    X_s: NDArray[np.float64],
    X_t: NDArray[np.float64],
    *,
    mu: float = 0.5,
    n_components: int = 2,
    noise_level: float = 1.0,
    solver: Literal["structured", "dense"] = "structured",
    degeneracy_tol: float = DEGENERACY_TOL,
) -> LRAResult:
    """Embed baseline and test features in a common subspace and measure their distance.

    Paper eqs. (2)-(8). Rows of ``X_s`` and ``X_t`` are paired by index (the correspondence
    ``C = [[0, I], [I, 0]]``).

    Parameters
    ----------
    X_s : ndarray of shape (n_rows, n_features)
        Baseline (source) features.
    X_t : ndarray of shape (n_rows, n_features)
        Test (target) features.
    mu : float in [0, 1], default=0.5
        Weight of the correspondence term against the local geometry.
    n_components : int, default=2
        Embedding dimension ``d``; eigenvectors ``1 .. d`` (0-based) are used, the smallest one
        being the trivial one.
    noise_level : float, default=1.0
        ``lambda``: only singular values above ``sqrt(lambda)`` enter ``R``.
    solver : {"structured", "dense"}, default="structured"
        The exact fast reduction or the literal ``2N x 2N`` eigenproblem.
    degeneracy_tol : float, default=1e-9
        Eigenvalues of ``M`` closer than this are treated as one degenerate cluster.

    Returns
    -------
    LRAResult

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X_s = rng.normal(size=(60, 5)) * 2
    >>> res = lra_embedding(X_s, X_s + rng.normal(scale=0.5, size=X_s.shape))
    >>> res.F_s.shape, res.delta > 0, res.eigengap > 0
    ((60, 2), True, True)
    """
    if solver == "dense":
        return lra_dense(
            X_s,
            X_t,
            mu=mu,
            n_components=n_components,
            noise_level=noise_level,
            degeneracy_tol=degeneracy_tol,
        )
    if solver != "structured":
        raise ValueError(
            f"The 'solver' parameter must be 'structured' or 'dense'. Got {solver!r} instead."
        )
    X_s, X_t = _check_pair(X_s, X_t, mu, n_components, noise_level)
    return lra_structured(
        low_rank_basis(X_s, noise_level),
        low_rank_basis(X_t, noise_level),
        mu=mu,
        n_components=n_components,
        degeneracy_tol=degeneracy_tol,
    )
