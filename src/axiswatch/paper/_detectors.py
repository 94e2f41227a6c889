"""Detectors: the distance between a test capture's features and the healthy baseline's.

Each detector is a scikit-learn estimator: ``fit(X)``, ``distance(X)``, ``transform(X)``. A new
method subclasses :class:`BaselineDetector`. Row policies: docs/internals.md, "Detectors".
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.decomposition import PCA
from sklearn.utils.validation import check_is_fitted, validate_data

from axiswatch.paper._alignment import (
    LowRankBasis,
    LRAResult,
    low_rank_basis,
    lra_dense,
    lra_structured,
)
from axiswatch.paper._noise import mp_noise_level

__all__ = ["BaselineDetector", "IndicatorDetector", "LRADetector", "PCADetector"]


#: How a detector compares test rows with baseline rows.
RowPolicy = Literal["paired", "set"]


class BaselineDetector(TransformerMixin, BaseEstimator):  # type: ignore[misc]
    """Base class: fit on baseline features, measure the distance of test features to them.

    Attributes
    ----------
    row_policy : {"paired", "set"}
        ``"paired"`` (default): row ``i`` of a test matrix is compared with row ``i`` of the
        baseline, the first ``min(n_baseline, n_test)`` rows of both. ``"set"``: the rows are
        readings of the same quantities, all kept.
    baseline_ : ndarray of shape (n_rows, n_features)
        The baseline's features; or, where they are not kept in memory (see
        :attr:`reads_baseline_rows`), an object with their ``shape`` that computes their leading
        rows ``baseline_[:n]`` (:class:`~axiswatch.paper._stages.RecomputedFeatures`).
    """

    row_policy: ClassVar[RowPolicy] = "paired"

    @property
    def reads_baseline_rows(self) -> bool:
        """Whether every distance reads the baseline's rows (``baseline_``), not only the
        fitted state: then they are better kept in memory than recomputed."""
        return True

    def fit(self, X: Any, y: Any = None) -> BaselineDetector:
        """Store the healthy baseline's features.

        Parameters
        ----------
        X : array-like of shape (n_rows, n_features)
            Baseline features, one row per STFT time slice.
        y : ignored

        Returns
        -------
        self
        """
        X = validate_data(self, X, dtype=np.float64, ensure_min_samples=2)
        self.baseline_ = X
        self._fit(X)
        return self

    def _check_test(self, X: Any) -> NDArray[np.float64]:
        check_is_fitted(self)
        return np.asarray(validate_data(self, X, dtype=np.float64, reset=False))

    def _rows(self, X: NDArray[np.float64]) -> int:
        if self.row_policy == "set":
            return int(X.shape[0])
        return int(min(self.baseline_.shape[0], X.shape[0]))

    def distance(self, X: Any) -> float:
        """Distance of test features ``X`` to the baseline (larger = less like the baseline).

        Parameters
        ----------
        X : array-like of shape (n_rows, n_features)

        Returns
        -------
        float
        """
        X = self._check_test(X)
        return float(self._distance(X[: self._rows(X)]))

    def distance_and_diagnostics(self, X: Any) -> tuple[float, dict[str, float | bool]]:
        """:meth:`distance` of test features ``X`` and what the detector can say about it.

        One computation gives both (LRA's eigenproblem is solved once). The diagnostics' keys
        name the method (``lra_eigengap``); a detector with nothing to add returns ``{}``.

        Examples
        --------
        >>> import numpy as np
        >>> PCADetector(n_components=1).fit([[0.0, 1.0], [1.0, 0.0]]).distance_and_diagnostics(
        ...     [[0.0, 1.0], [1.0, 0.0]])
        (0.0, {})
        """
        return self.distance(X), {}

    def diagnostics(self, X: Any) -> dict[str, float | bool]:
        """Diagnostics of test features ``X`` (see :meth:`distance_and_diagnostics`)."""
        return self.distance_and_diagnostics(X)[1]

    @abstractmethod
    def _fit(self, X: NDArray[np.float64]) -> None: ...

    @abstractmethod
    def _distance(self, X: NDArray[np.float64]) -> float: ...

    def __sklearn_tags__(self) -> Any:
        tags = super().__sklearn_tags__()
        tags.transformer_tags.preserves_dtype = ["float64"]
        return tags


class PCADetector(BaselineDetector):
    """The classic detector: distance in the baseline's principal subspace (paper, "Detection").

    ``d = ||X_s P - X_t P||_F^2`` where the columns of ``P`` are the principal components of the
    baseline features ``X_s``.

    Parameters
    ----------
    n_components : int or float, default=0.95
        Number of principal components, or (float in (0, 1)) the share of the baseline's variance
        they must explain, as in :class:`sklearn.decomposition.PCA`. The paper does not say.

    Attributes
    ----------
    components_ : ndarray of shape (n_features, n_kept)
        ``P``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(100, 6))
    >>> det = PCADetector(n_components=3).fit(X)
    >>> det.distance(X)
    0.0
    >>> det.distance(X + 1.0) > 0
    True
    """

    def __init__(self, n_components: int | float = 0.95) -> None:
        self.n_components = n_components

    def _fit(self, X: NDArray[np.float64]) -> None:
        pca = PCA(n_components=self.n_components, svd_solver="full").fit(X)
        self.components_ = pca.components_.T
        self.explained_variance_ratio_ = pca.explained_variance_ratio_

    def _distance(self, X: NDArray[np.float64]) -> float:
        n = X.shape[0]
        projected = (self.baseline_[:n] - X) @ self.components_
        return float(np.sum(projected**2))

    def transform(self, X: Any) -> NDArray[np.float64]:
        """Project ``X`` on the baseline's principal components (uncentred, as ``X P``)."""
        X = self._check_test(X)
        return np.asarray(X @ self.components_)


class LRADetector(BaselineDetector):
    """The paper's detector: distance in the common subspace found by Low Rank Alignment.

    ``delta = ||F_s - F_t||_F`` (paper eq. 8) where ``[F_s; F_t]`` is the joint embedding of
    baseline and test rows (see :func:`axiswatch.lra_embedding`). The baseline's SVD is computed
    once, in ``fit``.

    Parameters
    ----------
    mu : float in [0, 1], default=0.5
        Weight of the row correspondence against the local geometry.
    n_components : int, default=2
        Embedding dimension ``d``.
    noise_level : float or "auto", default=1.0
        ``lambda``; only singular values above ``sqrt(lambda)`` enter ``R``. 1 is the paper's form.
        ``"auto"`` sets it in ``fit`` from the baseline's own noise: ``sqrt(lambda)`` is the
        Marchenko-Pastur edge of a robust noise estimate (:func:`axiswatch.mp_noise_level`).
    solver : {"structured", "dense"}, default="structured"
        Exact fast reduction or the literal ``2N x 2N`` eigenproblem (same result).

    Attributes
    ----------
    basis_ : LowRankBasis
        The baseline's low-rank basis.
    noise_level_ : float
        The ``lambda`` used (``noise_level`` or its estimate).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(80, 6)) * 3
    >>> det = LRADetector().fit(X)
    >>> round(det.distance(X), 12)
    0.0
    >>> det.distance(rng.normal(size=(80, 6)) * 3) > 0
    True
    """

    def __init__(
        self,
        mu: float = 0.5,
        n_components: int = 2,
        noise_level: float | Literal["auto"] = 1.0,
        solver: Literal["structured", "dense"] = "structured",
    ) -> None:
        self.mu = mu
        self.n_components = n_components
        self.noise_level = noise_level
        self.solver = solver

    def _fit(self, X: NDArray[np.float64]) -> None:
        if self.solver not in ("structured", "dense"):
            raise ValueError(
                f"The 'solver' parameter of LRADetector must be 'structured' or 'dense'. "
                f"Got {self.solver!r} instead."
            )
        if isinstance(self.noise_level, str):
            if self.noise_level != "auto":
                raise ValueError(
                    "The 'noise_level' parameter of LRADetector must be a float > 0 or 'auto'. "
                    f"Got {self.noise_level!r} instead."
                )
            self.noise_level_ = mp_noise_level(X)
        else:
            self.noise_level_ = float(self.noise_level)
        self.basis_ = low_rank_basis(X, self.noise_level_)

    @property
    def reads_baseline_rows(self) -> bool:
        """Only the dense solver: the structured one reads them for a shorter test alone."""
        return self.solver == "dense"

    def _source_basis(self, n_rows: int) -> LowRankBasis:
        # Computed once in fit; a shorter test capture needs the SVD of the baseline's leading rows.
        if n_rows == self.basis_.vectors.shape[0]:
            return self.basis_
        return low_rank_basis(self.baseline_[:n_rows], self.noise_level_)

    def align(self, X: Any, *, overwrite_x: bool = False) -> LRAResult:
        """Full LRA outcome (embedding, eigenvalues, eigengap) of test features ``X``.

        With ``overwrite_x`` the test basis is built in ``X``'s memory (``X`` is destroyed): a
        caller that owns the features and does not read them again saves an ``N x r`` array.
        """
        X = self._check_test(X)
        n = self._rows(X)
        if self.solver == "dense":
            result = lra_dense(
                self.baseline_[:n],
                X[:n],
                mu=self.mu,
                n_components=self.n_components,
                noise_level=self.noise_level_,
            )
        else:
            result = lra_structured(
                self._source_basis(n),
                low_rank_basis(X[:n], self.noise_level_, overwrite_x=overwrite_x),
                mu=self.mu,
                n_components=self.n_components,
                overwrite_target=True,
            )
        return result

    def distance(self, X: Any, *, overwrite_x: bool = False) -> float:
        return self.align(X, overwrite_x=overwrite_x).delta

    def distance_and_diagnostics(
        self, X: Any, *, overwrite_x: bool = False
    ) -> tuple[float, dict[str, float | bool]]:
        """The LRA distance, the eigengap of its eigenproblem and whether a tie was broken
        (:class:`~axiswatch.paper._alignment.LRAResult`); ``overwrite_x`` as in :meth:`align`."""
        result = self.align(X, overwrite_x=overwrite_x)
        return float(result.delta), {
            "lra_eigengap": float(result.eigengap),
            "lra_tie_broken": bool(result.tie_broken),
        }

    def _distance(self, X: NDArray[np.float64]) -> float:  # pragma: no cover - distance overrides
        return self.align(X).delta

    def transform(self, X: Any) -> NDArray[np.float64]:
        """Embedding ``F_t`` of the test rows in the common subspace, shape (n_rows, d)."""
        return self.align(X).F_t


class IndicatorDetector(BaselineDetector):
    """Shift of the test's mean row from the baseline's: ``d = ||mean(X_t) - mean(X_s)||^2``.

    Meant for compact indicator stages (the lab's ``MechanicsStage``) whose rows are
    repeated readings of the same quantities and whose columns are already on a common scale;
    rows are averaged, not paired, so a capture with fewer rows is compared all the same.

    Parameters
    ----------
    one_sided : bool, default=True
        Count only increases (``max(shift, 0)``): the mechanics indicators (friction,
        impulsiveness, fault lines) grow with every fault they watch, while a healthy axis on a
        gentler task reads lower than at commissioning, which is no reason to alarm.

    Examples
    --------
    >>> import numpy as np
    >>> det = IndicatorDetector().fit(np.array([[1.0, 2.0], [1.0, 4.0]]))
    >>> det.distance(np.array([[3.0, 1.0], [3.0, 1.0]]))  # only the increase counts
    4.0
    >>> IndicatorDetector(one_sided=False).fit([[1.0, 2.0], [1.0, 4.0]]).distance([[3.0, 1.0]])
    8.0
    """

    row_policy: ClassVar[RowPolicy] = "set"  # rows are averaged, not paired: keep them all

    @property
    def reads_baseline_rows(self) -> bool:
        """Never: the baseline's mean row is its fitted state."""
        return False

    def __init__(self, one_sided: bool = True) -> None:
        self.one_sided = one_sided

    def _fit(self, X: NDArray[np.float64]) -> None:
        self.centre_ = X.mean(axis=0)

    def _distance(self, X: NDArray[np.float64]) -> float:
        return float(np.sum(self._terms(X)))

    def _terms(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        shift = X.mean(axis=0) - self.centre_
        return np.asarray(np.maximum(shift, 0.0) ** 2 if self.one_sided else shift**2)

    def contributions(self, X: Any) -> NDArray[np.float64]:
        """Each column's term of :meth:`distance`; they add up to it exactly.

        Parameters
        ----------
        X : array-like of shape (n_rows, n_features)

        Returns
        -------
        ndarray of shape (n_features,)
            ``max(mean(X_t[:, j]) - mean(X_s[:, j]), 0)**2`` (the square of the shift when
            ``one_sided=False``).

        Examples
        --------
        >>> import numpy as np
        >>> det = IndicatorDetector().fit(np.array([[1.0, 2.0], [1.0, 4.0]]))
        >>> det.contributions(np.array([[3.0, 1.0], [3.0, 1.0]]))
        array([4., 0.])
        """
        return self._terms(self._check_test(X))

    def transform(self, X: Any) -> NDArray[np.float64]:
        """Each test row's shift from the baseline's mean row."""
        X = self._check_test(X)
        return np.asarray(X - self.centre_)
