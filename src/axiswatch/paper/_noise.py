"""A default for LRA's ``lambda`` from the baseline's own noise (Marchenko-Pastur edge).

Paper eqs. 3-4 keep singular values above ``sqrt(lambda)``. The noise ``sigma`` follows Gavish &
Donoho (2014), eq. 10. The derivation and its caveat are in docs/internals.md, "LRA solvers".
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy import integrate, optimize

__all__ = ["marchenko_pastur_median", "mp_noise_level"]


def marchenko_pastur_median(beta: float) -> float:
    """Median of the Marchenko-Pastur law of aspect ratio ``beta`` in (0, 1] and unit variance.

    The law of the eigenvalues of ``Y^T Y / n`` for an ``n x m`` matrix ``Y`` of i.i.d. unit
    variance entries, ``beta = m / n``, as ``n`` grows.

    Examples
    --------
    >>> round(marchenko_pastur_median(1.0), 4)
    0.6528
    """
    if not (isinstance(beta, int | float | np.floating) and 0.0 < beta <= 1.0):
        raise ValueError(f"The 'beta' parameter must be a float in (0, 1]. Got {beta!r} instead.")
    lower, upper = (1 - math.sqrt(beta)) ** 2, (1 + math.sqrt(beta)) ** 2

    def density(x: float) -> float:
        return math.sqrt(max((upper - x) * (x - lower), 0.0)) / (2 * math.pi * beta * x)

    def cdf(x: float) -> float:
        return float(integrate.quad(density, lower, x, limit=200)[0])

    return float(optimize.brentq(lambda x: cdf(x) - 0.5, lower, upper, xtol=1e-12))


def mp_noise_level(X: NDArray[np.float64]) -> float:
    """``lambda`` such that ``sqrt(lambda)`` is the Marchenko-Pastur edge of ``X``'s noise.

    Parameters
    ----------
    X : ndarray of shape (n_rows, n_features)
        Baseline features.

    Returns
    -------
    float
        ``(sigma (sqrt(n_rows) + sqrt(n_features)))^2`` with ``sigma`` estimated from the median
        singular value (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> noise = 0.1 * rng.normal(size=(400, 100))
    >>> edge = np.sqrt(mp_noise_level(noise))
    >>> round(float(edge), 2), round(0.1 * (20 + 10), 2)
    (3.0, 3.0)
    """
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or min(X.shape) < 2 or not np.isfinite(X).all():
        raise ValueError(
            f"X must be a finite matrix of shape (n_rows, n_features) with both >= 2; "
            f"got shape {X.shape}."
        )
    singular = scipy.linalg.svdvals(X, check_finite=False)
    n_large, n_small = max(X.shape), min(X.shape)
    sigma = float(np.median(singular)) / math.sqrt(
        n_large * marchenko_pastur_median(n_small / n_large)
    )
    if sigma == 0.0:
        raise ValueError(
            "X has a zero median singular value (rank below half its smaller dimension): no noise "
            "level can be estimated; give a numeric noise_level instead."
        )
    return (sigma * (math.sqrt(X.shape[0]) + math.sqrt(X.shape[1]))) ** 2
