"""Alarm threshold from healthy distances: a half-Laplace fit (paper, end of "Proposed Method").

Pipeline stage 5. The paper models the distance of healthy captures by the positive half of a
Laplace distribution with location 0. That is the exponential distribution, whose maximum
likelihood scale is the mean distance; a threshold at percentile ``q`` is ``-b log(1 - q/100)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from axiswatch.exceptions import CalibrationError

__all__ = ["HalfLaplaceFit", "fit_half_laplace", "half_laplace_threshold"]


@dataclass(frozen=True)
class HalfLaplaceFit:
    """Half-Laplace (exponential) model of healthy distances.

    Attributes
    ----------
    scale : float
        Maximum-likelihood scale ``b`` (the mean healthy distance).
    n_distances : int
        How many healthy distances were fitted.
    ks_statistic, ks_pvalue : float
        Kolmogorov-Smirnov test against the fitted exponential. The scale is estimated from the
        same data, so the p-value is conservative (too large; Lilliefors' correction would lower
        it): read a small p-value as a clear misfit, a large one as "no evidence of misfit".
    """

    scale: float
    n_distances: int
    ks_statistic: float
    ks_pvalue: float

    def threshold(self, percentile: float | None = None, *, alpha: float | None = None) -> float:
        """Distance above which a capture is anomalous (:func:`half_laplace_threshold` of the
        fitted scale).

        Examples
        --------
        >>> fit = fit_half_laplace([1.0, 2.0, 3.0])
        >>> round(fit.threshold(50), 6), round(fit.threshold(alpha=0.5), 6)
        (1.386294, 1.386294)
        """
        return half_laplace_threshold(self.scale, percentile, alpha=alpha)

    def pvalue(self, distance: float) -> float:
        """Probability that a healthy capture has a distance at least this large."""
        return math.exp(-max(distance, 0.0) / self.scale)


def half_laplace_threshold(
    scale: float, percentile: float | None = None, *, alpha: float | None = None
) -> float:
    """Distance above which a capture is anomalous, for a half-Laplace scale (location 0).

    Parameters
    ----------
    scale : float
        ``b``, the mean healthy distance.
    percentile : float in (0, 100), optional
        For example 50, 75, 90, 95, 97.5 or 99.
    alpha : float in (0, 1), optional
        Significance level; equivalent to ``percentile = 100 (1 - alpha)``. Give one of the two.

    Examples
    --------
    >>> round(half_laplace_threshold(1.0, 99), 6)  # ln(100)
    4.60517
    """
    if (percentile is None) == (alpha is None):
        raise ValueError("Give exactly one of 'percentile' and 'alpha'.")
    if alpha is None:
        assert percentile is not None
        if not (isinstance(percentile, int | float) and 0.0 < percentile < 100.0):
            raise ValueError(
                f"The 'percentile' parameter must be a float in the range (0, 100). "
                f"Got {percentile!r} instead."
            )
        tail = 1.0 - percentile / 100.0
    else:
        if not (isinstance(alpha, int | float) and 0.0 < alpha < 1.0):
            raise ValueError(
                f"The 'alpha' parameter must be a float in the range (0, 1). Got {alpha!r} instead."
            )
        tail = float(alpha)
    return -scale * math.log(tail)


def fit_half_laplace(healthy_distances: ArrayLike | Sequence[float]) -> HalfLaplaceFit:
    """Fit the half-Laplace distribution (location 0) to healthy distances by maximum likelihood.

    Parameters
    ----------
    healthy_distances : array-like of shape (n,)
        Distances of captures known to be healthy; at least 2, finite, non-negative, not all 0.

    Returns
    -------
    HalfLaplaceFit

    Raises
    ------
    CalibrationError
        Fewer than two distances, a non-finite or negative one, or all zero.

    Examples
    --------
    >>> import numpy as np
    >>> sample = np.random.default_rng(0).exponential(2.0, size=20_000)
    >>> fit = fit_half_laplace(sample)
    >>> round(fit.scale, 1), round(fit.threshold(99), 1)
    (2.0, 9.2)
    """
    values = np.asarray(healthy_distances, dtype=np.float64).ravel()
    if values.size < 2:
        raise CalibrationError(
            f"Calibration needs at least 2 healthy distances; got {values.size}."
        )
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise CalibrationError(
            f"Healthy distances must be finite; distance {bad[0]} is {float(values[bad[0]])!r}."
        )
    if (values < 0).any():
        k = int(np.flatnonzero(values < 0)[0])
        raise CalibrationError(
            f"Healthy distances must be >= 0; distance {k} is {float(values[k])!r}."
        )
    scale = float(values.mean())
    if scale == 0.0:
        raise CalibrationError(
            "All healthy distances are 0: the half-Laplace scale cannot be estimated "
            "(were the calibration captures copies of the baseline?)."
        )
    ks = stats.kstest(values, stats.expon(scale=scale).cdf)
    return HalfLaplaceFit(scale, int(values.size), float(ks.statistic), float(ks.pvalue))
