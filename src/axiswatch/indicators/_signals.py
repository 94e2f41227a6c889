"""Signal primitives of the indicators: angle-locked line statistics, filters, running RMS."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter

__all__ = [
    "BEARING_OFFSETS",
    "GRAM_MIN_RCOND",
    "WHOLE_ORDERS",
    "angle_locked_f",
    "bearing_lines",
    "bearing_orders",
    "butter_sos",
    "line_ratio",
    "pearson_kurtosis",
    "running_rms",
    "whole_samples",
]


def _cis(angle: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``exp(1j * angle)`` from NumPy's vectorised ``cos`` and ``sin`` (its complex ``exp`` is
    about 3x slower on the large angles of a motor's revolutions)."""
    out = np.empty(angle.shape, dtype=np.complex128)
    np.cos(angle, out=out.real)
    np.sin(angle, out=out.imag)
    return out


def _grid_phasors(
    angle: NDArray[np.float64], values: NDArray[np.float64], step: float
) -> NDArray[np.complex128] | None:
    """``exp(1j * o * angle)`` for orders ``values`` on a grid of ``step`` (None if they are not),
    by repeated multiplication from the smallest."""
    steps = np.rint((values - values.min()) / step).astype(np.int64)
    if float(np.max(np.abs(values - (values.min() + steps * step)))) > 1e-9:
        return None
    rotation = _cis(step * angle)
    waves = np.empty((angle.size, int(steps.max()) + 1), dtype=np.complex128)
    waves[:, 0] = _cis(values.min() * angle)
    for k in range(1, waves.shape[1]):
        np.multiply(waves[:, k - 1], rotation, out=waves[:, k])
    return waves[:, steps]


def _phasors(angle: NDArray[np.float64], orders: Sequence[float]) -> NDArray[np.complex128]:
    """``exp(1j * o * angle)`` for every order ``o``, shape ``(n, len(orders))``.

    Orders on a common grid (multiples of their smallest spacing, as the tooth sets are) are
    powers of one complex exponential, built by repeated multiplication: one ``exp`` instead of
    two trigonometric functions per order (the stage's hot spot). Orders that are not (a bearing
    order and its double, each with whole-order sidebands) are built the same way per class of
    equal fractional part, each class a grid of whole orders. The recurrence's rounding error
    grows by about one ulp per step, far below the signals' noise; tested against
    ``np.sin``/``np.cos`` to 1e-10.
    """
    values = np.asarray(orders, dtype=np.float64)
    step = float(np.min(np.diff(np.sort(values)))) if values.size > 1 else 0.0
    phasors = _grid_phasors(angle, values, step) if step > 0 else None
    if phasors is None:
        phasors = np.empty((angle.size, values.size), dtype=np.complex128)
        fraction = np.round(values - np.floor(values), 9) % 1.0
        for value in np.unique(fraction):
            members = np.flatnonzero(fraction == value)
            grid = _grid_phasors(angle, values[members], 1.0)
            if grid is None:  # a whole-order class is on the grid of 1 by construction
                grid = _cis(np.multiply.outer(angle, values[members]))
            phasors[:, members] = grid
    return phasors


def _columns(
    phasors: NDArray[np.complex128], direction: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """Regression columns of phasors: the sines, then the cosines (then the same times
    ``direction``)."""
    result = np.concatenate([phasors.imag, phasors.real], axis=1)
    if direction is not None:
        result = np.concatenate([result, result * direction[:, None]], axis=1)
    return result


def _harmonics(
    angle: NDArray[np.float64], orders: Sequence[float], direction: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """Columns ``sin(o angle)`` then ``cos(o angle)`` for every order ``o`` (then the same times
    ``direction``): :func:`_columns` of :func:`_phasors`."""
    return _columns(_phasors(angle, orders), direction)


def angle_locked_f(
    signal: NDArray[np.float64],
    angle: NDArray[np.float64],
    orders: Sequence[float],
    *,
    nuisance_orders: Sequence[float] = (1, 2, 3, 4, 5, 6, 7, 8),
    direction: NDArray[np.float64] | None = None,
) -> float:
    """F statistic of the lines of ``signal`` at ``orders`` of ``angle``, beyond ``nuisance_orders``.

    Nested least squares: the signal is regressed on sines and cosines of ``nuisance_orders``
    (and, with ``direction``, the same times the direction of motion, since a load opposing the
    motion changes sign with it), then on those plus the ``orders``' waves. ``F = (drop in
    residual sum of squares / p) / (residual sum of squares / (n - k))``: about 1 when the
    ``orders`` carry no more than noise, large when the signal has lines there.

    Parameters
    ----------
    signal, angle : ndarray of shape (n_samples,)
        ``angle`` in radians of the shaft the orders refer to.
    orders : sequence of float
    nuisance_orders : sequence of float, default=(1, ..., 8)
    direction : ndarray of shape (n_samples,), optional
        Sign of the motion, +1 or -1.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> theta = np.linspace(0, 200, 4000)
    >>> noise = rng.normal(size=theta.size)
    >>> round(angle_locked_f(noise, theta, [5.43]), 1) < 3
    True
    >>> angle_locked_f(noise + np.cos(5.43 * theta), theta, [5.43]) > 100
    True
    """
    return _NuisanceFree(signal, angle, nuisance_orders, direction).f_statistic(orders)


#: Least reciprocal condition number (LAPACK's ``dpocon`` estimate, 1-norm) of the projected
#: test waves' Gram matrix for which :class:`_NuisanceFree` solves the normal equations: the
#: explained sum of squares then has a relative error of about ``eps / rcond <= 2e-8`` (tested
#: against the QR path); below it the statistic is computed by QR instead.
GRAM_MIN_RCOND = 1e-8


class _NuisanceFree:
    """The signal with the nuisance waves projected out (Frisch-Waugh-Lovell), shared by every
    set of test orders of one stretch of signal.

    Regressing ``y`` on ``[N, T]`` and comparing with ``N`` alone is regressing ``y``'s
    nuisance-free part ``r`` on ``T``'s nuisance-free part ``T_p``; the projection is computed
    once (a QR of ``N``) and shared by every set of test orders (the tooth lines, the bearing
    lines and their neighbours: ten sets per direction of a capture).

    The explained sum of squares ``r' T_p (T_p' T_p)^-1 T_p' r`` is computed from the Gram
    matrix ``T_p' T_p = T' T - (Q' T)' (Q' T)`` and ``T_p' r = T' r`` (``r`` is orthogonal to
    ``N``), solved by Cholesky: three matrix products instead of a projection and a QR of the
    ``n x p`` waves (4x fewer operations at the stage's sizes). Normal equations square the
    condition number; waves of distinct orders over many revolutions are nearly orthogonal
    (condition 1-10), and where the Cholesky factor shows a reciprocal condition below
    :data:`GRAM_MIN_RCOND` the QR path is taken. Both are tested against the hat-matrix twin.
    """

    def __init__(
        self,
        signal: NDArray[np.float64],
        angle: NDArray[np.float64],
        nuisance_orders: Sequence[float],
        direction: NDArray[np.float64] | None,
    ) -> None:
        if direction is not None and np.all(direction == direction[0]):
            direction = None  # one direction only: the signed waves would repeat the plain ones
        self.angle, self.direction = angle, direction
        nuisance = _harmonics(angle, nuisance_orders, direction)
        self.basis = scipy.linalg.qr(nuisance, mode="economic", check_finite=False)[0]
        self.k = nuisance.shape[1]
        y = np.asarray(signal, dtype=np.float64)
        self.residual = y - self.basis @ (self.basis.T @ y)
        self.rss0 = float(self.residual @ self.residual)

    def explained(self, tests: NDArray[np.float64], *, exact: bool = False) -> float:
        """Sum of squares of the residual explained by the columns ``tests`` (``n x p``, not
        yet projected); ``exact`` forces the QR path."""
        if not exact:
            cross = self.basis.T @ tests
            gram = tests.T @ tests - cross.T @ cross
            right = tests.T @ self.residual
            try:
                factor = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
            except np.linalg.LinAlgError:
                factor = None
            if factor is not None:
                # LAPACK's estimate of the reciprocal 1-norm condition number from the factor.
                rcond, _ = scipy.linalg.lapack.dpocon(factor, np.abs(gram).sum(axis=0).max())
                if rcond >= GRAM_MIN_RCOND:
                    half = scipy.linalg.solve_triangular(
                        factor, right, trans="T", check_finite=False
                    )
                    return float(half @ half)
        projected = tests - self.basis @ (self.basis.T @ tests)
        q = scipy.linalg.qr(projected, mode="economic", check_finite=False)[0]
        return float(np.sum((q.T @ self.residual) ** 2))

    def f_statistic(self, orders: Sequence[float], *, exact: bool = False) -> float:
        return self._f(_phasors(self.angle, orders), exact=exact)

    def _f(self, phasors: NDArray[np.complex128], *, exact: bool = False) -> float:
        tests = _columns(phasors, self.direction)
        n, p = self.residual.size, tests.shape[1]
        if n <= self.k + p + 1:
            return float("nan")
        explained = self.explained(tests, exact=exact)
        rss1 = self.rss0 - explained
        return float(max(explained, 0.0) / p / (rss1 / (n - self.k - p)))

    def line_ratio(self, orders: Sequence[float], offsets: Sequence[float]) -> float:
        """:func:`line_ratio` of this stretch of signal.

        The waves at the shifted orders are the waves at ``orders`` times ``exp(1j * d * angle)``
        (one product instead of a new set of waves; the same rounding as the recurrence).
        """
        phasors = _phasors(self.angle, orders)
        reference = np.mean([self._f(phasors * _cis(d * self.angle)[:, None]) for d in offsets])
        return self._f(phasors) / float(reference)


#: Nuisance orders of the line statistics: the whole orders (gear mesh, ripple).
WHOLE_ORDERS: tuple[float, ...] = (1, 2, 3, 4, 5, 6, 7, 8)


def line_ratio(
    signal: NDArray[np.float64],
    angle: NDArray[np.float64],
    orders: Sequence[float],
    offsets: Sequence[float],
) -> float:
    """:func:`angle_locked_f` at ``orders`` over its mean at the same orders shifted by ``offsets``.

    The band-passed noise is not white, and where an order falls in the band depends on the
    speed, so the F statistic alone moves with the task; its neighbours at the shifted orders (no
    fault excites them) see the same noise, and the ratio is about 1 on every task for a healthy
    axis.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> theta = np.linspace(0, 300, 6000)
    >>> line = 0.5 * np.cos(5.43 * theta)
    >>> line_ratio(rng.normal(size=theta.size) + line, theta, [5.43], [-0.25, 0.25]) > 10
    True
    """
    return _NuisanceFree(signal, angle, WHOLE_ORDERS, None).line_ratio(orders, offsets)


def bearing_orders(bearing_order: float) -> list[float]:
    """The orders of a bearing defect's lines: ``bearing_order`` with sidebands +-1 and +-2 (the
    defect passes the load zone once a revolution) and its double with sidebands +-1.

    Examples
    --------
    >>> bearing_orders(5.5)
    [3.5, 4.5, 5.5, 6.5, 7.5, 10.0, 11.0, 12.0]
    """
    orders = [bearing_order + k for k in (-2, -1, 0, 1, 2)]
    return orders + [2 * bearing_order + k for k in (-1, 0, 1)]


#: Offsets of the neighbouring orders a bearing's lines are compared with.
BEARING_OFFSETS: tuple[float, ...] = (-0.25, 0.25)


def bearing_lines(
    signal: NDArray[np.float64], angle: NDArray[np.float64], bearing_order: float
) -> float:
    """:func:`line_ratio` of a bearing defect: :func:`bearing_orders` over the orders +-0.25
    beside them.

    Examples
    --------
    >>> import numpy as np
    >>> theta = np.linspace(0, 300, 6000)
    >>> noise = np.random.default_rng(2).normal(size=theta.size)
    >>> bearing_lines(noise + 0.5 * np.cos(5.43 * theta), theta, 5.43) > 3
    True
    """
    return line_ratio(signal, angle, bearing_orders(bearing_order), BEARING_OFFSETS)


@lru_cache(maxsize=64)
def butter_sos(
    order: int, cutoff_hz: float | tuple[float, float], rate_hz: float
) -> NDArray[np.float64]:
    """Butterworth low-pass (one cutoff) or band-pass (two) sections, designed once per
    parameters and process (a design costs about as much as filtering a 3 s capture; every
    capture of a fleet uses the same few). Shared by the callers, which must not modify it
    (SciPy's filters need a writeable array, so it cannot be marked read-only).

    Examples
    --------
    >>> butter_sos(2, 10.0, 1000.0).shape
    (1, 6)
    >>> butter_sos(2, 10.0, 1000.0) is butter_sos(2, 10.0, 1000.0)
    True
    """
    btype = "bandpass" if isinstance(cutoff_hz, tuple) else "lowpass"
    return np.asarray(butter(order, cutoff_hz, btype=btype, fs=rate_hz, output="sos"))


def whole_samples(seconds: float, rate_hz: float) -> int:
    """The nearest whole number of samples to ``seconds`` at ``rate_hz``, halves up.

    Immune to the last bits of the rate: a rate read from time stamps is exact only to about
    1e-12 (stamps written as text or as Unix seconds), and Python's ``round`` of a product that
    should be a whole number or a half (0.05 s at 50 Hz: 2.5 samples) flipped between two
    window lengths with it. The product is rounded down after adding ``0.5 + 1e-6``: a product
    within 1e-6 of a sample below a half counts as the half (a rate 1e-9 off moves 0.05 s at
    50 Hz by 2.5e-9 samples), and no other value changes its count.

    Examples
    --------
    >>> whole_samples(0.05, 50.0), whole_samples(0.05, 50.0 * (1 - 1e-12)), round(0.05 * 50.0)
    (3, 3, 2)
    >>> whole_samples(0.3, 100.0), whole_samples(0.3, 100.0 * (1 - 1e-12))
    (30, 30)
    """
    return math.floor(seconds * rate_hz + 0.5 + 1e-6)


def running_rms(values: NDArray[np.float64], width: int) -> NDArray[np.float64]:
    """Root of the centred running mean of ``values**2`` over ``width`` samples (reflected ends).

    The running mean is SciPy's ``uniform_filter1d``, a running sum: where the signal falls from
    large to small values its subtraction cancels and a mean of non-negative numbers can come out
    slightly negative (seen: -5e-77 after a burst of 1e-38). The true value is never negative, so
    the mean is clipped at 0 before the root; the clipped error is at most the running sum's
    round-off, ``width * eps * max(values**2)``, and is tested against the exact loop.

    Examples
    --------
    >>> running_rms(np.array([3.0, -3.0, 3.0, -3.0]), 2)
    array([3., 3., 3., 3.])
    """
    mean_square = uniform_filter1d(np.square(values), max(1, int(width)))
    return np.asarray(np.sqrt(np.maximum(mean_square, 0.0)), dtype=np.float64)


def pearson_kurtosis(values: NDArray[np.float64]) -> float:
    """Pearson's kurtosis ``m4 / m2**2`` (3 for a Gaussian), the biased moment estimator.

    The same number as ``scipy.stats.kurtosis(values, fisher=False)`` (tested to 1e-12), without
    its input handling, which costs ten times the computation on the stage's few thousand
    samples. NaN for fewer than 2 values or a constant signal.

    Examples
    --------
    >>> pearson_kurtosis(np.array([-1.0, 1.0, -1.0, 1.0]))
    1.0
    """
    x = np.asarray(values, dtype=np.float64)
    if x.size < 2:
        return float("nan")
    squares = np.square(x - x.mean())
    m2 = float(squares.mean())
    return float(np.mean(np.square(squares)) / m2**2) if m2 > 0 else float("nan")
