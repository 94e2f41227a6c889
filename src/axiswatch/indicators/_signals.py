"""Signal primitives of the indicators: angle-locked line statistics, running RMS, spikes.

The zero-phase filters live in :mod:`._filters` and are imported from here too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d

from axiswatch._quantiles import median
from axiswatch.indicators._filters import butter_sos, zero_phase
from axiswatch.indicators._wave_sums import (
    Phasors,
    cis,
    order_grids,
    phasor_sums,
    sums_plan,
    wave_products,
)
from axiswatch.indicators._workspace import scratch

__all__ = [
    "BEARING_OFFSETS",
    "LONE_SPIKE_FACTOR",
    "LONE_SPIKE_NEIGHBOURS",
    "GRAM_MIN_RCOND",
    "NuisanceProjection",
    "WHOLE_ORDERS",
    "angle_locked_f",
    "bearing_lines",
    "bearing_orders",
    "butter_sos",
    "line_ratio",
    "pearson_kurtosis",
    "repair_lone_spikes",
    "running_rms",
    "whole_orders",
    "whole_samples",
    "zero_phase",
]

#: Neighbours on each side of a sample that :func:`repair_lone_spikes` compares it with.
LONE_SPIKE_NEIGHBOURS = 3
#: A lone spike departs from its neighbours' median by more than this many times their range
#: and the noise. Gaussian noise departs 8 sigma (7.1 times the departure's own 1.12 sigma)
#: once in 1e12 samples, 15 years of a 2 kHz torque, before the range is counted. An impact
#: whose next samples reach an eighth of its height is kept. Simulated faults (backlash,
#: bearing, tooth, friction) at 100 Hz or more have no sample this far out.
LONE_SPIKE_FACTOR = 8.0


def _wave_rows(
    angle: NDArray[np.float64],
    orders: Sequence[float],
    out: NDArray[np.float64] | None = None,
    phasors: Phasors | None = None,
) -> NDArray[np.float64]:
    """``sin(o angle)`` for every order ``o``, then ``cos(o angle)``: shape ``(2 p, n)``, a row a
    wave (the products with the waves read whole rows); written in ``out`` when given; the
    exponentials from ``phasors`` when given (the angle's, kept for its other lines).

    Orders on a grid (:func:`._wave_sums.order_grids`) are powers of one complex exponential,
    built by repeated multiplication of one row: one ``exp`` per grid instead of two
    trigonometric functions per order (the stage's hot spot), and no wave of the grid kept
    that is not an order. The
    recurrence's rounding error grows by about one ulp per step, far below the signals' noise;
    tested against ``np.sin``/``np.cos`` to 1e-10.
    """
    phasor = Phasors(angle) if phasors is None else phasors
    values = np.asarray(orders, dtype=np.float64)
    count = values.size
    rows = np.empty((2 * count, angle.size)) if out is None else out
    for members, start, step in order_grids(values):
        steps = np.rint((values[members] - start) / step).astype(np.int64)
        wave = phasor(start).copy()  # multiplied in place below
        done = 0
        for index in np.argsort(steps, kind="stable"):
            while done < steps[index]:
                np.multiply(wave, phasor(step), out=wave)  # kept by Phasors: one cis a step
                done += 1
            rows[members[index]] = wave.imag
            rows[count + members[index]] = wave.real
    return rows


def _signed_rows(
    rows: NDArray[np.float64], direction: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """The wave rows, then the same times ``direction`` (a load opposing the motion)."""
    if direction is None:
        return rows
    return np.concatenate([rows, rows * direction])


def _shifted_rows(
    rows: NDArray[np.float64],
    angle: NDArray[np.float64],
    shift: float,
    out: NDArray[np.float64],
    half: NDArray[np.float64],
    phasors: Phasors | None = None,
) -> NDArray[np.float64]:
    """:func:`_wave_rows` of the orders plus ``shift``, from the rows of the orders: the waves
    times ``exp(1j * shift * angle)`` (from ``phasors`` when given), written in ``out``
    (``half``: scratch of half its rows). One complex product, the same rounding as the
    recurrence; no new set of waves, no new memory."""
    count = rows.shape[0] // 2
    sines, cosines = rows[:count], rows[count:]
    rotation = cis(shift * angle) if phasors is None else phasors(shift)
    np.multiply(sines, rotation.real, out=out[:count])
    out[:count] += np.multiply(cosines, rotation.imag, out=half)
    np.multiply(cosines, rotation.real, out=out[count:])
    out[count:] -= np.multiply(sines, rotation.imag, out=half)
    return out


def _shifted_pair(
    rows: NDArray[np.float64],
    angle: NDArray[np.float64],
    shift: float,
    up: NDArray[np.float64],
    down: NDArray[np.float64],
    half: NDArray[np.float64],
    phasors: Phasors | None = None,
) -> None:
    """:func:`_shifted_rows` by ``shift`` into ``up`` and by ``-shift`` into ``down``, from
    the same four products: the opposite rotation is the conjugate, so each product serves
    both with the other sign. Bit for bit the two calls' rows (tested)."""
    count = rows.shape[0] // 2
    sines, cosines = rows[:count], rows[count:]
    rotation = cis(shift * angle) if phasors is None else phasors(shift)
    np.multiply(sines, rotation.real, out=up[:count])
    np.multiply(cosines, rotation.imag, out=half)
    np.subtract(up[:count], half, out=down[:count])
    up[:count] += half
    np.multiply(cosines, rotation.real, out=up[count:])
    np.multiply(sines, rotation.imag, out=half)
    np.add(up[count:], half, out=down[count:])
    up[count:] -= half


def _harmonics(
    angle: NDArray[np.float64],
    orders: Sequence[float],
    direction: NDArray[np.float64] | None,
    phasors: Phasors | None = None,
) -> NDArray[np.float64]:
    """Columns ``sin(o angle)`` then ``cos(o angle)`` for every order ``o`` (then the same times
    ``direction``): :func:`_wave_rows` as columns."""
    return _signed_rows(_wave_rows(angle, orders, phasors=phasors), direction).T


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

#: Least reciprocal condition number of the nuisance waves' Gram matrix for which
#: :class:`NuisanceProjection` projects by its Cholesky factor instead of a QR of the waves. The
#: projection's relative error is then about ``eps / rcond <= 2e-10``; whole orders over a few
#: revolutions have a condition of 1-100, and a stretch too short for that takes the QR.
PROJECTION_MIN_RCOND = 1e-6

#: Samples of angle whose waves the line statistics hold at a time. A longer stretch is summed
#: block by block (normal equations, every wave built per block), so memory does not grow with
#: a capture's length; a stretch of one block is computed by QR as before.
LINE_BLOCK_SAMPLES = 1 << 16


def _cholesky(gram: NDArray[np.float64], min_rcond: float) -> NDArray[np.float64] | None:
    """The upper Cholesky factor of ``gram``; None when ``gram`` is not positive definite or its
    reciprocal condition is below ``min_rcond``. LAPACK is called directly: SciPy's wrappers of
    these small solves cost more than the solves (several a capture)."""
    factor, info = scipy.linalg.lapack.dpotrf(gram, lower=0, clean=1)
    if info != 0:
        return None
    # LAPACK's estimate of the reciprocal 1-norm condition number from the factor.
    rcond, _ = scipy.linalg.lapack.dpocon(factor, np.abs(gram).sum(axis=0).max())
    return None if rcond < min_rcond else np.asarray(factor, dtype=np.float64)


def _gram_explained(gram: NDArray[np.float64], right: NDArray[np.float64]) -> float | None:
    """``right' gram^-1 right`` by Cholesky; None when ``gram`` is not positive definite or its
    reciprocal condition is below :data:`GRAM_MIN_RCOND`."""
    factor = _cholesky(gram, GRAM_MIN_RCOND)
    if factor is None:
        return None
    half, _ = scipy.linalg.lapack.dtrtrs(factor, right[:, None], lower=0, trans=1)
    return float(half[:, 0] @ half[:, 0])


class NuisanceProjection:
    """The nuisance waves of one stretch of angle, projected out of every signal on it.

    Computed once per stretch and shared by every line read on it (a capture's tooth and
    bearing lines filter the torque in their own bands, on the same motor angle). Up to
    :data:`LINE_BLOCK_SAMPLES` samples it is the Cholesky factor of the waves' Gram matrix, or
    a QR of the waves where that matrix is ill-conditioned (:data:`PROJECTION_MIN_RCOND`); a
    QR of 3,000 x 16 waves cost ten times their Gram matrix. Beyond, the Cholesky factor of
    their Gram matrix summed block by block (whole orders over many revolutions are nearly
    orthogonal: condition 1-10), and every product with the waves is made a block at a time.
    """

    def __init__(
        self,
        angle: NDArray[np.float64],
        nuisance_orders: Sequence[float],
        direction: NDArray[np.float64] | None,
        phasors: Phasors | None = None,
    ) -> None:
        if direction is not None and np.all(direction == direction[0]):
            direction = None  # one direction only: the signed waves would repeat the plain ones
        self.angle, self.direction = angle, direction
        self.orders = tuple(nuisance_orders)
        size = LINE_BLOCK_SAMPLES
        self.blocks = [slice(i, i + size) for i in range(0, max(angle.size, 1), size)]
        self.basis: NDArray[np.float64] | None = None  # of the QR, when taken
        #: One block: waves = basis @ triangle, so ``triangle' triangle`` is their Gram matrix.
        self.triangle: NDArray[np.float64] | None = None
        self.rows: NDArray[np.float64] | None = None  # the waves, a row each (Cholesky)
        self.factor: NDArray[np.float64] | None = None
        #: The angle's exponentials, shared by the lines read on it (one block only: a longer
        #: stretch builds its waves a block at a time, and keeps none).
        self.phasors: Phasors | None = None
        if len(self.blocks) > 1:
            gram = sum(w.T @ w for w in map(self.waves, self.blocks))
            try:
                self.factor = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
            except np.linalg.LinAlgError:
                self.blocks = [slice(0, angle.size)]  # degenerate waves: the exact QR
        if self.factor is None:
            if angle.size <= LINE_BLOCK_SAMPLES:
                self.phasors = Phasors(angle) if phasors is None else phasors
            rows = _signed_rows(_wave_rows(angle, nuisance_orders, phasors=self.phasors), direction)
            self.triangle = _cholesky(rows @ rows.T, PROJECTION_MIN_RCOND)
            if self.triangle is None:
                self.basis, self.triangle = scipy.linalg.qr(
                    rows.T, mode="economic", check_finite=False
                )
            else:
                self.rows = rows
        self.k = 2 * len(self.orders) * (1 if direction is None else 2)

    @property
    def blocked(self) -> bool:
        """Whether the stretch is summed block by block (no waves kept)."""
        return self.factor is not None

    def coordinates(self, tests: NDArray[np.float64]) -> NDArray[np.float64]:
        """``Q' T``: the waves ``tests`` (``p x n``, a row each) on an orthonormal basis ``Q`` of
        the nuisance waves (one block), shape ``(k, p)``. By Cholesky, ``R^-T N' T``."""
        if self.rows is None:
            assert self.basis is not None
            return (tests @ self.basis).T
        half, _ = scipy.linalg.lapack.dtrtrs(self.triangle, self.rows @ tests.T, lower=0, trans=1)
        return np.asarray(half, dtype=np.float64)

    def orthonormal(self) -> NDArray[np.float64]:
        """``Q``, an orthonormal basis of the nuisance waves (one block): the QR's, taken here
        when the projection was made by Cholesky (only the exact path needs it)."""
        if self.basis is None:
            assert self.rows is not None
            self.basis = scipy.linalg.qr(self.rows.T, mode="economic", check_finite=False)[0]
        return self.basis

    def waves(self, block: slice) -> NDArray[np.float64]:
        """The nuisance waves of the samples ``block``."""
        direction = None if self.direction is None else self.direction[block]
        return _harmonics(self.angle[block], self.orders, direction)

    def residual(self, signal: NDArray[np.float64]) -> NDArray[np.float64]:
        """``signal`` less its projection on the nuisance waves."""
        if self.rows is not None:
            solved, _ = scipy.linalg.lapack.dpotrs(self.triangle, self.rows @ signal, lower=0)
            return np.asarray(signal - solved @ self.rows, dtype=np.float64)
        if self.basis is not None:
            return signal - self.basis @ (self.basis.T @ signal)
        assert self.factor is not None
        right = sum(self.waves(b).T @ signal[b] for b in self.blocks)
        coefficients = scipy.linalg.cho_solve((self.factor, False), right, check_finite=False)
        out = np.empty_like(signal)
        for b in self.blocks:
            out[b] = signal[b] - self.waves(b) @ coefficients
        return out


def whole_orders(angle: NDArray[np.float64], phasors: Phasors | None = None) -> NuisanceProjection:
    """The projection of the whole orders (:data:`WHOLE_ORDERS`) of ``angle``, shared by every
    :func:`line_ratio` read on it (``nuisance=``); ``phasors``: the angle's, when seeded."""
    return NuisanceProjection(angle, WHOLE_ORDERS, None, phasors)


class _NuisanceFree:
    """The signal with the nuisance waves projected out (Frisch-Waugh-Lovell), shared by every
    set of test orders of one stretch of signal.

    Regressing ``y`` on ``[N, T]`` and comparing with ``N`` alone is regressing ``y``'s
    nuisance-free part ``r`` on ``T``'s nuisance-free part ``T_p``; the projection is computed
    once (:class:`NuisanceProjection`, a QR of ``N``) and shared by every set of test orders
    (the tooth lines, the bearing lines and their neighbours: ten sets per direction of a
    capture).

    The explained sum of squares ``r' T_p (T_p' T_p)^-1 T_p' r`` is computed from the Gram
    matrix ``T_p' T_p = T' T - (Q' T)' (Q' T)`` and ``T_p' r = T' r`` (``r`` is orthogonal to
    ``N``), solved by Cholesky: three matrix products instead of a projection and a QR of the
    ``n x p`` waves (4x fewer operations at the stage's sizes). Normal equations square the
    condition number; waves of distinct orders over many revolutions are nearly orthogonal
    (condition 1-10), and where the Cholesky factor shows a reciprocal condition below
    :data:`GRAM_MIN_RCOND` the QR path is taken. Both are tested against the hat-matrix twin.
    A stretch longer than :data:`LINE_BLOCK_SAMPLES` sums the same products block by block
    (``Q' T`` as ``R^-T N' T``), with a least-squares solve where the Gram matrix is
    ill-conditioned; tested against the one-block path.
    """

    def __init__(
        self,
        signal: NDArray[np.float64],
        angle: NDArray[np.float64],
        nuisance_orders: Sequence[float],
        direction: NDArray[np.float64] | None,
        *,
        nuisance: NuisanceProjection | None = None,
    ) -> None:
        if nuisance is None:
            nuisance = NuisanceProjection(angle, nuisance_orders, direction)
        self.nuisance = nuisance
        self.angle, self.direction = nuisance.angle, nuisance.direction
        self.k = nuisance.k
        y = np.asarray(signal, dtype=np.float64)
        self.residual = nuisance.residual(y)
        self.rss0 = float(self.residual @ self.residual)

    def explained(self, rows: NDArray[np.float64], *, exact: bool = False) -> float:
        """Sum of squares of the residual explained by the waves ``rows`` (``p x n``, a row a
        wave, not yet projected); ``exact`` forces the QR path."""
        if not exact:
            cross = self.nuisance.coordinates(rows)
            gram = rows @ rows.T - cross.T @ cross
            explained = _gram_explained(gram, rows @ self.residual)
            if explained is not None:
                return explained
        tests = rows.T
        basis = self.nuisance.orthonormal()
        projected = tests - basis @ (basis.T @ tests)
        q = scipy.linalg.qr(projected, mode="economic", check_finite=False)[0]
        return float(np.sum((q.T @ self.residual) ** 2))

    def f_statistic(self, orders: Sequence[float], *, exact: bool = False) -> float:
        if self.nuisance.blocked:
            return self._blocked(orders, [None])[0]
        return self._f(_wave_rows(self.angle, orders), exact=exact)

    def _ratio(self, explained: float, p: int) -> float:
        """The F statistic of ``explained`` by ``p`` columns (NaN without the degrees)."""
        n = self.residual.size
        if n <= self.k + p + 1:
            return float("nan")
        rss1 = self.rss0 - explained
        return float(max(explained, 0.0) / p / (rss1 / (n - self.k - p)))

    def _f(self, rows: NDArray[np.float64], *, exact: bool = False) -> float:
        tests = _signed_rows(rows, self.direction)
        p = tests.shape[0]
        if self.residual.size <= self.k + p + 1:
            return float("nan")
        return self._ratio(self.explained(tests, exact=exact), p)

    def _blocked(self, orders: Sequence[float], shifts: Sequence[float | None]) -> list[float]:
        """F statistics of the waves at ``orders``, each shifted by ``shifts`` (None: as they
        are), summed a block of samples at a time."""
        factor = self.nuisance.factor
        assert factor is not None
        p = 2 * len(orders) * (1 if self.direction is None else 2)
        sums = [(np.zeros((p, self.k)), np.zeros((p, p)), np.zeros(p)) for _ in shifts]
        for b in self.nuisance.blocks:
            angle = self.angle[b]
            direction = None if self.direction is None else self.direction[b]
            rows = _wave_rows(angle, orders)
            shifted, half = np.empty_like(rows), np.empty((rows.shape[0] // 2, angle.size))
            waves = self.nuisance.waves(b)
            for (cross, gram, right), shift in zip(sums, shifts, strict=True):
                moved = rows if shift is None else _shifted_rows(rows, angle, shift, shifted, half)
                tests = _signed_rows(moved, direction)
                cross += tests @ waves
                gram += tests @ tests.T
                right += tests @ self.residual[b]
        out = []
        for cross, gram, right in sums:
            projected = scipy.linalg.solve_triangular(
                factor, cross.T, trans="T", check_finite=False
            )
            gram -= projected.T @ projected
            explained = _gram_explained(gram, right)
            if explained is None:  # nearly collinear waves: the least-squares solve
                solution = scipy.linalg.lstsq(gram, right, check_finite=False)[0]
                explained = float(right @ solution)
            out.append(self._ratio(explained, p))
        return out

    def _sums_f(self, orders: Sequence[float], offsets: Sequence[float]) -> list[float] | None:
        """F statistics at ``orders`` and at the orders shifted by each of ``offsets``, from
        sums of phasors (:mod:`._wave_sums`) instead of the waves; None where that does not
        apply (orders on no single grid, more than a few classes of frequencies, signed waves,
        ill-conditioned waves) and the waves' products are computed instead.

        The Gram matrix of the waves and their products with the nuisance waves are sums of
        phasors at the orders' sums and differences, ``T' r`` the residual's phasor sums at
        the orders: for a tooth set (32 orders) a few small complex products instead of
        ``n x 64 x 64`` multiplications. Equal to the waves' path to about 1e-12 (tested).
        """
        if self.nuisance.blocked or self.direction is not None:
            return None
        plan = sums_plan(
            tuple(map(float, orders)), tuple(map(float, offsets)), self.nuisance.orders
        )
        p = 2 * len(orders)
        if plan is None or self.residual.size <= self.k + p + 1:
            return None
        weights = np.stack([np.ones(self.angle.size), self.residual])
        sums = phasor_sums(
            self.angle,
            weights,
            plan.frequencies,
            plan.phasors.step,
            plan.phasors,
            plan.extents,
            self.nuisance.phasors,
        )
        assert sums is not None  # the plan is the frequencies'
        ones, residual = sums
        difference = ones[plan.difference]
        difference[plan.conjugated] = np.conj(difference[plan.conjugated])
        out = []
        for total, minus, plus, at_orders in plan.shifts:
            gram = wave_products(difference, ones[total])
            cross = wave_products(ones[minus], ones[plus])
            # The projected waves' Gram matrix: T'T - (Q'T)'(Q'T), Q'T = R^-T N'T.
            projected, _ = scipy.linalg.lapack.dtrtrs(self.nuisance.triangle, cross, trans=1)
            gram -= projected.T @ projected
            residual_sums = residual[at_orders]
            right = np.concatenate([residual_sums.imag, residual_sums.real])
            explained = _gram_explained(gram, right)
            if explained is None:
                return None
            out.append(self._ratio(explained, p))
        return out

    def line_ratio(self, orders: Sequence[float], offsets: Sequence[float]) -> float:
        """:func:`line_ratio` of this stretch of signal.

        The waves at the shifted orders are the waves at ``orders`` times ``exp(1j * d * angle)``
        (:func:`_shifted_rows`: one product instead of a new set of waves). The waves are
        written in arrays kept for the next capture (:func:`._workspace.scratch`): fresh pages
        for a capture's few megabytes of waves cost as much as their products. A tooth set is
        read from sums of phasors instead (:meth:`_sums_f`).
        """
        if self.nuisance.blocked:
            main, *shifted = self._blocked(orders, [None, *offsets])
            return main / float(np.mean(shifted))
        by_sums = self._sums_f(orders, offsets)
        if by_sums is not None:
            return by_sums[0] / float(np.mean(by_sums[1:]))
        n, p = self.angle.size, 2 * len(orders)
        phasors = self.nuisance.phasors
        # The orders' waves, then those of each shift, one block of rows after another.
        waves = scratch("waves", ((1 + len(offsets)) * p, n))
        rows, half = (
            _wave_rows(self.angle, orders, waves[:p], phasors),
            scratch("half", (p // 2, n)),
        )
        block = {d: waves[k * p : (k + 1) * p] for k, d in enumerate(offsets, start=1)}
        for d in offsets:
            if d > 0 and -d in block:  # a shift and its opposite (a bearing's): one set of products
                _shifted_pair(rows, self.angle, d, block[d], block[-d], half, phasors)
            elif not (d < 0 and -d in block):
                _shifted_rows(rows, self.angle, d, block[d], half, phasors)
        main, *shifted = self._f_stacked(waves, p)
        return main / float(np.mean(shifted))

    def _f_stacked(self, waves: NDArray[np.float64], p: int) -> list[float]:
        """:meth:`_f` of each block of ``p`` rows of ``waves``: the products with the nuisance
        waves and the residual made for every block at once (one matrix product each instead
        of one per block; the same sums to rounding)."""
        blocks = [waves[k : k + p] for k in range(0, waves.shape[0], p)]
        if self.direction is not None or self.nuisance.rows is None:
            return [self._f(block) for block in blocks]
        if self.residual.size <= self.k + p + 1:
            return [float("nan")] * len(blocks)
        cross, _ = scipy.linalg.lapack.dtrtrs(
            self.nuisance.triangle, self.nuisance.rows @ waves.T, lower=0, trans=1
        )
        rights = waves @ self.residual
        out = []
        for k, block in enumerate(blocks):
            columns = cross[:, k * p : (k + 1) * p]
            gram = block @ block.T - columns.T @ columns
            explained = _gram_explained(gram, rights[k * p : (k + 1) * p])
            if explained is None:
                explained = self.explained(block, exact=True)
            out.append(self._ratio(explained, p))
        return out


#: Nuisance orders of the line statistics: the whole orders (gear mesh, ripple).
WHOLE_ORDERS: tuple[float, ...] = (1, 2, 3, 4, 5, 6, 7, 8)


def line_ratio(
    signal: NDArray[np.float64],
    angle: NDArray[np.float64],
    orders: Sequence[float],
    offsets: Sequence[float],
    *,
    nuisance: NuisanceProjection | None = None,
) -> float:
    """:func:`angle_locked_f` at ``orders`` over its mean at the same orders shifted by ``offsets``.

    The band-passed noise is not white, and where an order falls in the band depends on the
    speed, so the F statistic alone moves with the task; its neighbours at the shifted orders (no
    fault excites them) see the same noise, and the ratio is about 1 on every task for a healthy
    axis. ``nuisance``: :func:`whole_orders` of ``angle``, when several lines share it.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> theta = np.linspace(0, 300, 6000)
    >>> line = 0.5 * np.cos(5.43 * theta)
    >>> line_ratio(rng.normal(size=theta.size) + line, theta, [5.43], [-0.25, 0.25]) > 10
    True
    """
    free = _NuisanceFree(signal, angle, WHOLE_ORDERS, None, nuisance=nuisance)
    return free.line_ratio(orders, offsets)


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
    signal: NDArray[np.float64],
    angle: NDArray[np.float64],
    bearing_order: float,
    *,
    nuisance: NuisanceProjection | None = None,
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
    return line_ratio(
        signal, angle, bearing_orders(bearing_order), BEARING_OFFSETS, nuisance=nuisance
    )


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


def repair_lone_spikes(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """``values`` with each lone one-sample spike replaced by its neighbours' median.

    A Hampel-type repair made one sample wide. Sample ``i`` is a lone spike when it departs
    from the median of its :data:`LONE_SPIKE_NEIGHBOURS` neighbours on each side by more than
    :data:`LONE_SPIKE_FACTOR` times the larger of their range and the noise (the robust
    standard deviation of the first difference over ``sqrt(2)``, at least its smallest step).
    Two samples out together widen each other's neighbours' range, so an impact of two or more
    samples is kept; a glitch of a logger or a transmission is one sample. The input is never
    changed; without a lone spike it is returned as it is (the same object).

    Parameters
    ----------
    values : ndarray of shape (n,)

    Returns
    -------
    ndarray of shape (n,)

    Examples
    --------
    >>> x = np.sin(np.arange(100) / 10.0)
    >>> x[40] += 5.0
    >>> bool(np.abs(repair_lone_spikes(x)[40] - np.sin(4.0)) < 0.1)
    True
    """
    x = np.asarray(values, dtype=np.float64)
    w = LONE_SPIKE_NEIGHBOURS
    if x.size < 2 * w + 1:
        return x
    step = np.abs(np.diff(x))
    moving = step[step > 0]
    if not moving.size:
        return x
    noise = max(1.4826 * median(step) / math.sqrt(2.0), float(np.min(moving)))
    # Candidates first, with temporaries of the capture's length only: a lone spike departs
    # from both next samples, in one direction, by more than (factor - 1) x noise.
    limit = (LONE_SPIKE_FACTOR - 1.0) * noise
    ahead, behind = x[1:-1] - x[:-2], x[1:-1] - x[2:]
    candidates = np.flatnonzero(
        ((ahead > limit) & (behind > limit)) | ((ahead < -limit) & (behind < -limit))
    )
    candidates = candidates[(candidates + 1 >= w) & (candidates + 1 < x.size - w)] + 1
    repaired = x
    for i in candidates.tolist():
        neighbours = np.concatenate([x[i - w : i], x[i + 1 : i + 1 + w]])
        centre = float(np.median(neighbours))
        if abs(x[i] - centre) > LONE_SPIKE_FACTOR * max(float(np.ptp(neighbours)), noise):
            if repaired is x:
                repaired = x.copy()
            repaired[i] = centre
    return repaired
