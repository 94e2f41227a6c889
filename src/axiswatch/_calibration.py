"""Alarm threshold from healthy distances: a half-Laplace fit (paper, end of "Proposed Method").

A half-Laplace at location 0 is an exponential with scale ``b``, the mean distance. The
threshold at percentile ``q`` is ``-b log(1 - q/100)``, raised to a floor where one is given.
:func:`alarm_threshold` is the one rule every user of a threshold applies.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from axiswatch.exceptions import CalibrationError

__all__ = [
    "HalfLaplaceFit",
    "Threshold",
    "alarm_threshold",
    "fit_half_laplace",
    "half_laplace_threshold",
]


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

    def prediction_threshold(self, percentile: float) -> float:
        """The ``percentile`` of the *next* healthy distance, the scale being estimated from
        ``n_distances`` of them: ``n b ((1 - q)^(-1/n) - 1)`` with ``q = percentile / 100``.

        :meth:`threshold` puts the estimate ``b`` in the exponential's quantile ``-b ln(1 - q)``
        as if it were the true scale; with few distances that threshold is too low as often as
        not, and a new healthy capture exceeds it more often than ``1 - q``: for ``n = 5`` and
        the 99th percentile, 3.8 % of the time on average, not 1 %. For exponential distances
        ``X / b`` is ``F(2, 2n)``-distributed, so ``P(X > t) = (1 + t / (n b))^(-n)``, exactly
        ``1 - q`` at this threshold; it tends to :meth:`threshold` as ``n`` grows (5 % above it
        at ``n = 50``).

        Examples
        --------
        >>> fit = fit_half_laplace([1.0, 2.0, 3.0, 1.0, 3.0])  # b = 2, n = 5
        >>> round(fit.threshold(99), 3), round(fit.prediction_threshold(99), 3)
        (9.21, 15.119)
        """
        if not (isinstance(percentile, int | float) and 0.0 < percentile < 100.0):
            raise ValueError(
                f"The 'percentile' parameter must be a float in the range (0, 100). "
                f"Got {percentile!r} instead."
            )
        n = self.n_distances
        # expm1/log: accurate where (1 - q)^(-1/n) is close to 1 (large n).
        return n * self.scale * math.expm1(-math.log1p(-percentile / 100.0) / n)

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
    from scipy import stats  # on first fit: a run that fits nothing never imports SciPy

    ks = stats.kstest(values, stats.expon(scale=scale).cdf)
    return HalfLaplaceFit(scale, int(values.size), float(ks.statistic), float(ks.pvalue))


def _ordinal(percentile: float) -> str:
    text = f"{percentile:g}"
    if not text.isdigit():
        return f"{text}th"
    if 10 <= int(text) % 100 <= 20:
        return f"{text}th"
    return text + {"1": "st", "2": "nd", "3": "rd"}.get(text[-1], "th")


@dataclass(frozen=True)
class Threshold:
    """An alarm threshold and where it came from (:func:`alarm_threshold`).

    Attributes
    ----------
    value : float
        The threshold: a distance above it is over.
    fit : HalfLaplaceFit
        The half-Laplace fit of the healthy distances.
    percentile : float
        The fit's percentile that gave the fitted threshold.
    n_healthy : int
        How many healthy distances were fitted.
    floor : float or None
        The least threshold asked for (None: no floor).
    origin : {"fit", "floor"}
        ``"floor"`` when the floor exceeded the fitted threshold and became the value.
    prediction : bool
        Whether the fitted threshold is the percentile of the next healthy distance
        (:meth:`HalfLaplaceFit.prediction_threshold`) rather than of the fitted distribution
        (:meth:`HalfLaplaceFit.threshold`, the paper's).
    """

    value: float
    fit: HalfLaplaceFit
    percentile: float
    n_healthy: int
    floor: float | None
    origin: Literal["fit", "floor"]
    prediction: bool = False

    @property
    def fitted(self) -> float:
        """The fit's threshold at ``percentile``, before any floor."""
        if self.prediction:
            return self.fit.prediction_threshold(self.percentile)
        return self.fit.threshold(self.percentile)

    def describe(self) -> str:
        """Where the value came from, in words for a service engineer.

        Examples
        --------
        >>> alarm_threshold([1.0, 2.0, 3.0], percentile=99).describe()
        '99th pct of half-Laplace fit of 3 healthy captures'
        >>> alarm_threshold([1.0, 2.0, 3.0], percentile=99, floor=20.0).describe()
        'task-change allowance 20 (fitted 9.21 on 3 healthy captures)'
        >>> alarm_threshold([1.0, 2.0, 3.0], percentile=99, prediction=True).describe()
        '99th pct of the next healthy capture, half-Laplace fit of 3 healthy captures'
        """
        if self.origin == "floor":
            return (
                f"task-change allowance {self.value:.4g} "
                f"(fitted {self.fitted:.3g} on {self.n_healthy} healthy captures)"
            )
        if self.prediction:
            return (
                f"{_ordinal(self.percentile)} pct of the next healthy capture, half-Laplace fit "
                f"of {self.n_healthy} healthy captures"
            )
        return (
            f"{_ordinal(self.percentile)} pct of half-Laplace fit of "
            f"{self.n_healthy} healthy captures"
        )


def alarm_threshold(
    healthy_distances: ArrayLike | Sequence[float],
    *,
    percentile: float = 99.0,
    floor: float | None = None,
    prediction: bool = False,
) -> Threshold:
    """The alarm threshold: ``max(percentile of the half-Laplace fit, floor)``.

    The one threshold rule of axiswatch (paper, end of "Proposed Method", plus the product's
    floor): the ``percentile`` of :func:`fit_half_laplace` of the healthy distances; where a
    ``floor`` is given (for the product default, the same percentile of the half-Laplace fit of
    healthy *task changes* in development) and exceeds it, the floor. A tie keeps the fit.

    Parameters
    ----------
    healthy_distances : array-like of shape (n,)
        Distances of captures known to be healthy; see :func:`fit_half_laplace`.
    percentile : float in (0, 100), default=99.0
        Percentile of the fit.
    floor : float >= 0, optional
        Least threshold.
    prediction : bool, default=False
        Take the ``percentile`` of the *next* healthy distance, the scale being estimated from
        these (:meth:`HalfLaplaceFit.prediction_threshold`; the monitor's rule: with ``K = 5``
        calibration captures the fitted distribution's percentile is exceeded by 3.8 % of
        healthy captures, not 1 %), instead of the fitted distribution's (the paper's).

    Returns
    -------
    Threshold

    Raises
    ------
    CalibrationError
        From :func:`fit_half_laplace`.
    ValueError
        A percentile outside (0, 100), or a floor that is negative or not finite.

    Examples
    --------
    >>> threshold = alarm_threshold([1.0, 2.0, 3.0], percentile=99)
    >>> round(threshold.value, 4), threshold.origin  # 2 ln(100)
    (9.2103, 'fit')
    >>> alarm_threshold([1.0, 2.0, 3.0], floor=20.0).value
    20.0
    """
    if floor is not None and not (
        isinstance(floor, int | float) and math.isfinite(floor) and floor >= 0.0
    ):
        raise ValueError(
            f"The 'floor' parameter must be a finite float >= 0 or None. Got {floor!r} instead."
        )
    fit = fit_half_laplace(healthy_distances)
    fitted = fit.prediction_threshold(percentile) if prediction else fit.threshold(percentile)
    origin: Literal["fit", "floor"]
    if floor is not None and floor > fitted:
        value, origin = float(floor), "floor"
    else:
        value, origin = fitted, "fit"
    return Threshold(
        value=value,
        fit=fit,
        percentile=float(percentile),
        n_healthy=fit.n_distances,
        floor=None if floor is None else float(floor),
        origin=origin,
        prediction=prediction,
    )
