"""Distribution detectors, and domain-adaptation baselines from skada, behind the detector interface.

Pipeline stage 4 (beside :mod:`axiswatch.paper._detectors`). Three detectors, each a
:class:`~axiswatch.BaselineDetector` (``fit(X_baseline)``, ``distance(X_test)``):

* :class:`EnergyDetector` (this project's change to the paper's PCA distance): the *energy
  distance* between the baseline's rows and the test's rows, both projected on the baseline's
  principal components. The paper pairs rows by index (``||X_s P - X_t P||_F^2``), which suits its
  robots (one task cycle, phase-aligned captures) but not stationary vibration: two recordings of a
  gearbox have no row-to-row correspondence, so the paired distance of two healthy captures is
  dominated by the random fluctuation of |STFT| magnitudes, a floor proportional to the number of
  rows that the half-Laplace model (location 0) does not describe. The energy distance compares the
  two *distributions* of rows instead: it is 0 for identical distributions, has no tuning
  parameter, and grows with any difference of location, spread or shape.
* :class:`CORALDetector`: CORAL (Sun, Feng & Saenko 2016) maps the test capture's rows onto the
  baseline's domain (``skada.CORALAdapter``: centre, whiten by the test's covariance, re-colour by
  the baseline's, shift to the baseline's mean; Ledoit-Wolf shrinkage), then the energy distance
  as above. An operation change modelled as an affine change of the spectra (gains that differ per
  band and their correlations) is removed; what remains is a change of the rows' *shape* (for
  instance intermittent impulses, a mixture of states) - the fault evidence that survives.
* :class:`SubspaceAlignmentDetector`: Subspace Alignment (Fernando et al. 2013,
  ``skada.SubspaceAlignmentAdapter``) rotates the test's principal subspace onto the baseline's,
  then the energy distance between the aligned coordinates of test and baseline rows. It removes a
  change of *direction* of the main variations but keeps their sizes.

Each capture is its own target domain (as the paper's LRA embeds one test capture with the
baseline): nothing is fitted on other captures, no label is used. Parameters are fixed a priori:
the baseline subspace keeps 95 % of the baseline's variance (the PCA detector's default), CORAL
uses skada's default Ledoit-Wolf shrinkage. A full affine alignment per capture also removes a
fault's change of mean and covariance: that is the price of domain adaptation and is measured in
``docs/evaluation.md``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.distance import cdist
from sklearn.decomposition import PCA

from axiswatch import BaselineDetector

__all__ = ["CORALDetector", "EnergyDetector", "SubspaceAlignmentDetector", "energy_distance"]


def energy_distance(first: ArrayLike, second: ArrayLike) -> float:
    """Energy distance between two samples of row vectors (Szekely & Rizzo 2013, eq. 2.1).

    ``E = 2 mean ||a_i - b_j|| - mean ||a_i - a_k|| - mean ||b_j - b_l||`` (V-statistic: means over
    all pairs, the zero self-pairs included), which is never negative and is 0 when both samples
    hold the same rows.

    Parameters
    ----------
    first : array-like of shape (n_first, n_features)
    second : array-like of shape (n_second, n_features)

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> energy_distance([[0.0], [1.0]], [[0.0], [1.0]])
    0.0
    >>> energy_distance([[0.0]], [[3.0]])
    6.0
    """
    a = np.atleast_2d(np.asarray(first, dtype=np.float64))
    b = np.atleast_2d(np.asarray(second, dtype=np.float64))
    if a.shape[1] != b.shape[1]:
        raise ValueError(
            f"Both samples must have the same number of features; got {a.shape[1]} and "
            f"{b.shape[1]}."
        )
    across = cdist(a, b).mean()
    within_a = cdist(a, a).mean()
    within_b = cdist(b, b).mean()
    return float(max(2.0 * across - within_a - within_b, 0.0))


class EnergyDetector(BaselineDetector):
    """Energy distance of test rows to baseline rows in the baseline's principal subspace.

    Parameters
    ----------
    n_components : int or float, default=0.95
        Principal components of the (centred) baseline kept, or the share of its variance they
        must explain, as in :class:`sklearn.decomposition.PCA`.

    Attributes
    ----------
    pca_ : sklearn.decomposition.PCA
    baseline_scores_ : ndarray of shape (n_baseline_rows, n_kept)

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(200, 5))
    >>> det = EnergyDetector().fit(X)
    >>> det.distance(X)
    0.0
    >>> det.distance(rng.normal(size=(200, 5)) + 1.0) > det.distance(rng.normal(size=(200, 5)))
    True
    """

    def __init__(self, n_components: int | float = 0.95) -> None:
        self.n_components = n_components

    def _fit(self, X: NDArray[np.float64]) -> None:
        self.pca_ = PCA(n_components=self.n_components, svd_solver="full").fit(X)
        self.baseline_scores_ = self.pca_.transform(X)

    def _map(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Test rows in the baseline's domain (identity here; the adaptation in subclasses)."""
        return X

    def _distance(self, X: NDArray[np.float64]) -> float:
        return energy_distance(self.baseline_scores_, self.pca_.transform(self._map(X)))

    def distance(self, X: Any) -> float:
        # Every test row counts (rows are not paired with the baseline's, so none is dropped).
        return float(self._distance(self._check_test(X)))

    def transform(self, X: Any) -> NDArray[np.float64]:
        """Test rows, mapped onto the baseline's domain, in its principal subspace."""
        return np.asarray(self.pca_.transform(self._map(self._check_test(X))))


def _domains(n_test: int, n_baseline: int) -> NDArray[np.int64]:
    # skada's convention: non-negative sample_domain = source (mapped), negative = target.
    return np.concatenate([np.ones(n_test, np.int64), -np.ones(n_baseline, np.int64)])


class CORALDetector(EnergyDetector):
    """CORAL-map the test rows onto the baseline's domain, then the energy distance.

    Parameters
    ----------
    n_components : int or float, default=0.95
        As in :class:`EnergyDetector`.
    reg : "auto" or float, default="auto"
        Covariance shrinkage (skada's ``CORALAdapter(reg=...)``): Ledoit-Wolf, or a fixed
        shrinkage in [0, 1].

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(300, 3))
    >>> det = CORALDetector().fit(X)
    >>> gain = det.distance(3.0 * rng.normal(size=(300, 3)) + 5.0)   # affine change: aligned away
    >>> shape = det.distance(rng.exponential(size=(300, 3)))          # skewed rows: remains
    >>> bool(gain < shape)
    True
    """

    def __init__(self, n_components: int | float = 0.95, reg: str | float = "auto") -> None:
        self.n_components = n_components
        self.reg = reg

    def _map(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        from skada import CORALAdapter

        adapter = CORALAdapter(reg=self.reg).fit(
            np.vstack([X, self.baseline_]), sample_domain=_domains(len(X), len(self.baseline_))
        )
        mapped = adapter.transform(X, sample_domain=np.ones(len(X), np.int64), allow_source=True)
        shift: NDArray[np.float64] = np.asarray(adapter.mean_target_, dtype=np.float64)
        return np.asarray(mapped, dtype=np.float64) + shift


class SubspaceAlignmentDetector(EnergyDetector):
    """Align the test's principal subspace onto the baseline's, then the energy distance.

    Parameters
    ----------
    n_components : int or float, default=0.95
        Subspace dimension, or the share of the baseline's variance it must explain (the number
        of components is then fixed at ``fit`` and used for both domains).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(300, 4)) * [3.0, 2.0, 0.1, 0.1]
    >>> det = SubspaceAlignmentDetector().fit(X)
    >>> same = det.distance(rng.normal(size=(300, 4)) * [3.0, 2.0, 0.1, 0.1])
    >>> louder = det.distance(rng.normal(size=(300, 4)) * [9.0, 6.0, 0.1, 0.1])
    >>> bool(same < louder)
    True
    """

    def _fit(self, X: NDArray[np.float64]) -> None:
        super()._fit(X)
        self.n_components_ = int(self.pca_.n_components_)

    def _aligned(self, X: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Baseline rows in their own subspace, and test rows aligned onto it."""
        from skada import SubspaceAlignmentAdapter

        adapter = SubspaceAlignmentAdapter(n_components=self.n_components_, random_state=0)
        adapter.fit(
            np.vstack([X, self.baseline_]), sample_domain=_domains(len(X), len(self.baseline_))
        )
        aligned = adapter.transform(X, sample_domain=np.ones(len(X), np.int64), allow_source=True)
        # skada's own PCA of the target domain (the baseline) gives the coordinates the aligned
        # test rows live in; the PCA fitted in ``fit`` only fixes the dimension.
        baseline_scores = adapter.pca_target_.transform(self.baseline_)
        return np.asarray(baseline_scores, np.float64), np.asarray(aligned, np.float64)

    def _distance(self, X: NDArray[np.float64]) -> float:
        return energy_distance(*self._aligned(X))

    def transform(self, X: Any) -> NDArray[np.float64]:
        """Test rows in the baseline's principal subspace after Subspace Alignment."""
        return self._aligned(self._check_test(X))[1]
