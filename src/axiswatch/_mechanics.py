"""Compact physical health indicators of an axis, each meant to read the same whatever the task.

Pipeline stage 2c (beside the |STFT| features of ``_features`` and the per-state stages of
``_indicators``). A capture becomes a few numbers with a physical meaning, chosen so that a healthy
axis gives the same value on every task while the fault they watch moves them:

* **viscous friction** (:func:`viscous_friction`): the energy the motor puts into a move,
  ``W = integral of torque * speed dt``, between two instants of equal speed, goes into gravity,
  friction and nothing else (the kinetic and spring energies are the same at both ends):
  ``W = c * |dq| + F_v * integral of speed^2 dt``. Nested windows of one move (speed above
  2 %, 15 %, ..., 75 % of its peak) share the move's constant force ``c`` (Coulomb friction plus
  gravity and payload, which differ from move to move and are not needed) and every move shares
  ``F_v``, solved by least squares. Energy integrals are immune to the link's resonance and to
  the payload, which defeat a sample-by-sample torque model (docs/evaluation.md).
* **impulsiveness**: the kurtosis, while moving, of the torque's 40-300 Hz band divided by its own
  RMS envelope over 100 ms (backlash and tooth impacts last a few ms). Without the envelope the
  kurtosis reads the task: a band whose level follows the speed along a move is heavy-tailed
  even if Gaussian at every instant (healthy kurtosis 3.8 on a slow task, 10 on fast ones; with
  the envelope 3.1-3.5 on the three simulator tasks of the development design).
* **reversal bursts** (:func:`reversal_bursts`): the torque's 40-300 Hz burst where the torque
  changes sign while moving (where a gearbox's backlash is crossed), over the square root of the
  rate at which the torque turns there.
* **angle-locked lines** (:func:`angle_locked_f`): the torque's 40-300 Hz band is regressed on
  sines and cosines of the motor angle at the orders a fault would excite (a damaged tooth of a
  gear turning once every ``tooth_period_revs`` motor revolutions: orders ``k / tooth_period_revs``
  that are not whole orders; an inner-race bearing defect: ``bearing_order`` and its sidebands),
  after the whole orders (gear mesh, ripple, whose presence is healthy) are regressed out; the
  indicator is the F statistic of that regression, the share of the band the fault's orders
  explain relative to what chance would give them, divided by the same statistic at neighbouring
  orders that no fault excites (:func:`line_ratio`), which see the same coloured noise. A line at
  a fixed order stays at that order whatever the speed, so the ratio does not move with the task.

These need the axis's kinematics (gear ratio, the period of the gear stage that could lose a
tooth, the bearing's defect order), which a service engineer takes from the datasheets as any
vibration monitoring system does; defaults are those of the project's simulator.

:class:`MechanicsStage` turns a capture into a ``(2, 6)`` matrix (rows: the two directions of
motion; columns :data:`COLUMNS`: ``log10`` of the five indicators, each divided by the spread it
shows across healthy tasks in the development protocol of ``_paired``, the viscous friction
also negated as the second column), usable by any detector. Larger means worse in every column:
the viscous friction is abnormal both ways (more friction; less apparent friction when lost
motion such as backlash breaks the energy balance, measured 3-9 spreads lower), the other four
only upwards (a quieter task lowers them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, sosfilt, sosfilt_zi, sosfiltfilt
from scipy.signal._arraytools import odd_ext

from axiswatch._capture import Capture
from axiswatch._features import Features
from axiswatch._preprocessing import resample_capture
from axiswatch._stages import FeatureStage
from axiswatch.exceptions import CaptureError

__all__ = [
    "COLUMNS",
    "INDICATORS",
    "LIKELY_FAULTS",
    "MECHANICS_SCALES",
    "MECHANICS_TASK_CHANGE_SCALE",
    "MechanicsStage",
    "NuisanceProjection",
    "angle_locked_f",
    "bearing_lines",
    "bearing_orders",
    "line_ratio",
    "moves",
    "pearson_kurtosis",
    "reversal_bursts",
    "running_rms",
    "viscous_friction",
    "whole_orders",
    "whole_samples",
    "zero_phase",
]

#: The indicators, in the order of :meth:`MechanicsStage.indicators` and of ``MECHANICS_SCALES``.
INDICATORS: tuple[str, ...] = (
    "viscous_friction",
    "impulsiveness",
    "reversal_bursts",
    "tooth_lines",
    "bearing_lines",
)

#: Columns of :class:`MechanicsStage`'s features, in order.
COLUMNS: tuple[str, ...] = (
    "viscous_friction",
    "viscous_friction_deficit",
    "impulsiveness",
    "reversal_bursts",
    "tooth_lines",
    "bearing_lines",
)

#: What a rise of each column most likely means: the fault its indicator watches
#: (docs/evaluation.md, "Beyond the paper"), for the monitor's reasons and report.
LIKELY_FAULTS: dict[str, str] = {
    "viscous_friction": "friction (lubrication, seals, wear)",
    "viscous_friction_deficit": "lost motion (backlash) breaking the energy balance",
    "impulsiveness": "impacts (backlash or a damaged gear tooth)",
    "reversal_bursts": "backlash in the gearbox",
    "tooth_lines": "a damaged gear tooth",
    "bearing_lines": "a bearing defect",
}

#: Speed levels (fractions of a move's peak) of the nested energy windows.
ENERGY_LEVELS: tuple[float, ...] = (0.02, 0.15, 0.3, 0.45, 0.6, 0.75)

#: Spread (root mean square of the shift from the baseline, in decades) of each indicator over
#: healthy captures of tasks other than the baseline's, measured by
#: :func:`axiswatch.development_scales` on the development design (tasks and seeds never used in
#: any reported result). Recomputed and checked by tests/test_paired.py.
MECHANICS_SCALES: tuple[float, ...] = (0.0600, 0.0740, 0.219, 0.0996, 0.181)

#: Half-Laplace scale (mean) of the :class:`~axiswatch.IndicatorDetector` distance between
#: healthy captures of different tasks, measured by :func:`axiswatch.development_task_change_scale`
#: on the development design: what a healthy task change does to the product default's distance,
#: which calibration captures of the baseline's own task cannot show. Checked by tests.
MECHANICS_TASK_CHANGE_SCALE: float = 2.81


def moves(
    speed: NDArray[np.float64], fraction: float = 0.02, min_gap: int = 40
) -> list[tuple[int, int]]:
    """Stretches of motion: ``[start, stop)`` index pairs where ``|speed|`` exceeds a fraction of
    the capture's peak.

    Stretches in one direction separated by fewer than ``min_gap`` samples (sensor noise around
    the threshold) are one move; a stretch shorter than ``min_gap`` on its own is dropped.

    Examples
    --------
    >>> import numpy as np
    >>> moves(np.array([0.0, 0.5, 1.0, 0.5, 0.0, -1.0, -1.0, 0.0]), min_gap=2)
    [(1, 4), (5, 7)]
    """
    v = np.asarray(speed, dtype=np.float64)
    moving = np.abs(v) > fraction * (float(np.max(np.abs(v))) if v.size else 0.0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(np.int8), [0]])))
    merged: list[list[int]] = []
    for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        if merged and a - merged[-1][1] < min_gap and np.sign(v[a]) == np.sign(v[merged[-1][0]]):
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged if b - a >= min_gap]


def viscous_friction(
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    torque: NDArray[np.float64],
    rate_hz: float,
    *,
    levels: Sequence[float] = ENERGY_LEVELS,
    direction: float | None = None,
) -> float:
    """Viscous friction coefficient from the energy balance of whole moves.

    For every move (from rest to rest; a move cut by the capture's edge keeps the levels above
    its speed at the cut, if its peak is inside) and every level ``x`` of ``levels``, the window
    runs from the first to the last sample whose ``|speed|``
    exceeds ``x`` times the move's peak, so speed, hence kinetic energy, is the same at both ends.
    The motor's work over the window is ``c_move * |dq| + F_v * integral(speed^2 dt)``; ``c_move``
    is free per move (Coulomb friction, gravity and payload), ``F_v`` is shared and returned.
    Gravity thus enters as its mean torque over the move; its variation along a long move is not
    modelled and biases ``F_v`` somewhat (docs/evaluation.md).

    Parameters
    ----------
    position, speed, torque : ndarray of shape (n_samples,)
        On one time base (rad, rad/s, N m, or any consistent units).
    rate_hz : float
    levels : sequence of float in [0, 1), default=ENERGY_LEVELS
    direction : {1.0, -1.0}, optional
        Only moves in that direction; both when None.

    Returns
    -------
    float
        ``F_v`` (torque per speed), NaN when the capture holds no usable move.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 4, 1e-3)
    >>> ramp = lambda t0: 0.5 * (1 - np.cos(np.pi * np.clip(t - t0, 0, 1)))
    >>> q = ramp(0.5) - ramp(2.5)  # out and back, at rest in between
    >>> v, a = np.gradient(q, 1e-3), np.gradient(np.gradient(q, 1e-3), 1e-3)
    >>> tau = 2.0 * a + 3.0 * v + 7.0 * np.sign(v) + 5.0  # inertia, viscous 3, Coulomb, load
    >>> round(viscous_friction(q, v, tau, 1000.0), 2)
    3.0
    """
    dt = 1.0 / rate_hz
    per_move: list[list[float]] = []
    shared: list[float] = []
    work: list[float] = []
    for start, stop in moves(speed):
        magnitude = np.abs(speed[start:stop])
        middle = int(np.argmax(magnitude))
        if direction is not None and np.sign(speed[start + middle]) != direction:
            continue
        if middle in (0, magnitude.size - 1):
            continue  # cut by the capture's edge before or after its peak: the peak is unknown
        # A move cut by the capture's edge keeps the windows whose both ends lie inside it: the
        # levels above its speed at the cut.
        edge = max(
            float(magnitude[0]) if start == 0 else 0.0,
            float(magnitude[-1]) if stop >= speed.size else 0.0,
        )
        usable = [level for level in levels if level * magnitude[middle] > edge]
        if len(usable) < 2:
            continue
        distances = []
        for level in usable:
            above = np.flatnonzero(magnitude > level * magnitude[middle])
            i, j = start + int(above[0]), start + int(above[-1])
            distances.append(abs(float(position[j] - position[i])))
            shared.append(float(np.trapezoid(speed[i : j + 1] ** 2, dx=dt)))
            work.append(float(np.trapezoid(torque[i : j + 1] * speed[i : j + 1], dx=dt)))
        per_move.append(distances)
    if not per_move:
        return float("nan")
    design = np.zeros((len(work), len(per_move) + 1))
    row = 0
    for m, distances in enumerate(per_move):
        design[row : row + len(distances), m] = distances
        row += len(distances)
    design[:, -1] = shared
    coefficients, *_ = scipy.linalg.lstsq(design, np.asarray(work))
    return float(coefficients[-1])


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

#: Samples of angle whose waves the line statistics hold at a time. A longer stretch is summed
#: block by block (normal equations, every wave built per block), so memory does not grow with
#: a capture's length; a stretch of one block is computed by QR as before.
LINE_BLOCK_SAMPLES = 1 << 16


def _gram_explained(gram: NDArray[np.float64], right: NDArray[np.float64]) -> float | None:
    """``right' gram^-1 right`` by Cholesky; None when ``gram`` is not positive definite or its
    reciprocal condition is below :data:`GRAM_MIN_RCOND`."""
    try:
        factor = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    # LAPACK's estimate of the reciprocal 1-norm condition number from the factor.
    rcond, _ = scipy.linalg.lapack.dpocon(factor, np.abs(gram).sum(axis=0).max())
    if rcond < GRAM_MIN_RCOND:
        return None
    half = scipy.linalg.solve_triangular(factor, right, trans="T", check_finite=False)
    return float(half @ half)


class NuisanceProjection:
    """The nuisance waves of one stretch of angle, projected out of every signal on it.

    Computed once per stretch and shared by every line read on it (a capture's tooth and
    bearing lines filter the torque in their own bands, on the same motor angle). Up to
    :data:`LINE_BLOCK_SAMPLES` samples it is a QR of the waves; beyond, the Cholesky factor of
    their Gram matrix summed block by block (whole orders over many revolutions are nearly
    orthogonal: condition 1-10), and every product with the waves is made a block at a time.
    """

    def __init__(
        self,
        angle: NDArray[np.float64],
        nuisance_orders: Sequence[float],
        direction: NDArray[np.float64] | None,
    ) -> None:
        if direction is not None and np.all(direction == direction[0]):
            direction = None  # one direction only: the signed waves would repeat the plain ones
        self.angle, self.direction = angle, direction
        self.orders = tuple(nuisance_orders)
        size = LINE_BLOCK_SAMPLES
        self.blocks = [slice(i, i + size) for i in range(0, max(angle.size, 1), size)]
        self.basis: NDArray[np.float64] | None = None
        self.factor: NDArray[np.float64] | None = None
        if len(self.blocks) > 1:
            gram = sum(w.T @ w for w in map(self.waves, self.blocks))
            try:
                self.factor = scipy.linalg.cholesky(gram, lower=False, check_finite=False)
            except np.linalg.LinAlgError:
                self.blocks = [slice(0, angle.size)]  # degenerate waves: the exact QR
        if self.factor is None:
            nuisance = _harmonics(angle, nuisance_orders, direction)
            self.basis = scipy.linalg.qr(nuisance, mode="economic", check_finite=False)[0]
        self.k = 2 * len(self.orders) * (1 if direction is None else 2)

    def waves(self, block: slice) -> NDArray[np.float64]:
        """The nuisance waves of the samples ``block``."""
        direction = None if self.direction is None else self.direction[block]
        return _harmonics(self.angle[block], self.orders, direction)

    def residual(self, signal: NDArray[np.float64]) -> NDArray[np.float64]:
        """``signal`` less its projection on the nuisance waves."""
        if self.basis is not None:
            return signal - self.basis @ (self.basis.T @ signal)
        assert self.factor is not None
        right = sum(self.waves(b).T @ signal[b] for b in self.blocks)
        coefficients = scipy.linalg.cho_solve((self.factor, False), right, check_finite=False)
        out = np.empty_like(signal)
        for b in self.blocks:
            out[b] = signal[b] - self.waves(b) @ coefficients
        return out


def whole_orders(angle: NDArray[np.float64]) -> NuisanceProjection:
    """The projection of the whole orders (:data:`WHOLE_ORDERS`) of ``angle``, shared by every
    :func:`line_ratio` read on it (``nuisance=``)."""
    return NuisanceProjection(angle, WHOLE_ORDERS, None)


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
        self.basis = nuisance.basis
        self.k = nuisance.k
        y = np.asarray(signal, dtype=np.float64)
        self.residual = nuisance.residual(y)
        self.rss0 = float(self.residual @ self.residual)

    def explained(self, tests: NDArray[np.float64], *, exact: bool = False) -> float:
        """Sum of squares of the residual explained by the columns ``tests`` (``n x p``, not
        yet projected); ``exact`` forces the QR path."""
        assert self.basis is not None
        if not exact:
            cross = self.basis.T @ tests
            gram = tests.T @ tests - cross.T @ cross
            explained = _gram_explained(gram, tests.T @ self.residual)
            if explained is not None:
                return explained
        projected = tests - self.basis @ (self.basis.T @ tests)
        q = scipy.linalg.qr(projected, mode="economic", check_finite=False)[0]
        return float(np.sum((q.T @ self.residual) ** 2))

    def f_statistic(self, orders: Sequence[float], *, exact: bool = False) -> float:
        if self.basis is None:
            return self._blocked(orders, [None])[0]
        return self._f(_phasors(self.angle, orders), exact=exact)

    def _ratio(self, explained: float, p: int) -> float:
        """The F statistic of ``explained`` by ``p`` columns (NaN without the degrees)."""
        n = self.residual.size
        if n <= self.k + p + 1:
            return float("nan")
        rss1 = self.rss0 - explained
        return float(max(explained, 0.0) / p / (rss1 / (n - self.k - p)))

    def _f(self, phasors: NDArray[np.complex128], *, exact: bool = False) -> float:
        tests = _columns(phasors, self.direction)
        p = tests.shape[1]
        if self.residual.size <= self.k + p + 1:
            return float("nan")
        return self._ratio(self.explained(tests, exact=exact), p)

    def _blocked(self, orders: Sequence[float], shifts: Sequence[float | None]) -> list[float]:
        """F statistics of the waves at ``orders``, each shifted by ``shifts`` (None: as they
        are), summed a block of samples at a time."""
        factor = self.nuisance.factor
        assert factor is not None
        p = 2 * len(orders) * (1 if self.direction is None else 2)
        sums = [(np.zeros((self.k, p)), np.zeros((p, p)), np.zeros(p)) for _ in shifts]
        for b in self.nuisance.blocks:
            angle = self.angle[b]
            direction = None if self.direction is None else self.direction[b]
            phasors = _phasors(angle, orders)
            waves = self.nuisance.waves(b)
            for (cross, gram, right), shift in zip(sums, shifts, strict=True):
                shifted = phasors if shift is None else phasors * _cis(shift * angle)[:, None]
                tests = _columns(shifted, direction)
                cross += waves.T @ tests
                gram += tests.T @ tests
                right += tests.T @ self.residual[b]
        out = []
        for cross, gram, right in sums:
            projected = scipy.linalg.solve_triangular(factor, cross, trans="T", check_finite=False)
            gram -= projected.T @ projected
            explained = _gram_explained(gram, right)
            if explained is None:  # nearly collinear waves: the least-squares solve
                solution = scipy.linalg.lstsq(gram, right, check_finite=False)[0]
                explained = float(right @ solution)
            out.append(self._ratio(explained, p))
        return out

    def line_ratio(self, orders: Sequence[float], offsets: Sequence[float]) -> float:
        """:func:`line_ratio` of this stretch of signal.

        The waves at the shifted orders are the waves at ``orders`` times ``exp(1j * d * angle)``
        (one product instead of a new set of waves; the same rounding as the recurrence).
        """
        if self.basis is None:
            main, *shifted = self._blocked(orders, [None, *offsets])
            return main / float(np.mean(shifted))
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


def reversal_bursts(
    torque: NDArray[np.float64],
    band: NDArray[np.float64],
    rate_hz: float,
    where: NDArray[np.bool_],
    *,
    smoothing_hz: float = 10.0,
    window_s: float = 0.02,
) -> float:
    """Mean burst of ``band`` where the torque reverses, over the root of how fast it turns.

    Backlash is crossed when the torque transmitted by the gearbox changes sign: the motor runs
    free through the gap and strikes the other flank. At every sign change of the torque
    low-passed at ``smoothing_hz`` (samples in ``where`` only), the burst is the largest
    ``|band|`` within ``window_s``; the faster the torque turns (``|d torque / dt|``), the faster
    the gap is crossed and the harder it is struck, so each burst is divided by the square root
    of that rate (the exponent chosen on the development design among 0, 1/2 and 1: the healthy
    range over its five tasks was 0.44, 0.36 and 0.41 decades).

    Parameters
    ----------
    torque, band : ndarray of shape (n_samples,)
        The torque and its band-passed version.
    rate_hz : float
    where : ndarray of bool, shape (n_samples,)
        Samples whose reversals count (e.g. one direction of motion).
    smoothing_hz : float, default=10.0
    window_s : float, default=0.02
        Half-width of the window searched for the burst.

    Returns
    -------
    float
        NaN when the torque does not reverse in ``where``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 2, 1e-3)
    >>> torque = 50 * np.sin(2 * np.pi * t)
    >>> band = np.zeros_like(t); band[[500, 1000, 1500]] = 3.0  # a knock at each reversal
    >>> everywhere = np.ones_like(t, dtype=bool)
    >>> round(reversal_bursts(torque, band, 1000.0, everywhere), 3)  # 3 / sqrt(2 pi 50)
    0.169
    """
    smooth = sosfiltfilt(butter_sos(2, smoothing_hz, rate_hz), torque)
    return _bursts(smooth, band, rate_hz, where, window_s)


def _bursts(
    smooth: NDArray[np.float64],
    band: NDArray[np.float64],
    rate_hz: float,
    where: NDArray[np.bool_],
    window_s: float = 0.02,
) -> float:
    """:func:`reversal_bursts` from the low-passed torque (one filter serves both directions)."""
    crossings = np.flatnonzero(np.diff(np.sign(smooth)) != 0)
    crossings = crossings[where[crossings]]
    if crossings.size == 0:
        return float("nan")
    half = max(1, whole_samples(window_s, rate_hz))
    slope = np.abs(np.gradient(smooth, 1.0 / rate_hz))
    magnitude = np.abs(band)
    bursts = [
        magnitude[max(0, c - half) : c + half].max() / np.sqrt(max(slope[c], 1e-12))
        for c in crossings
    ]
    return float(np.mean(bursts))


@lru_cache(maxsize=1024)
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


@lru_cache(maxsize=1024)
def _initial_state(sections: bytes, count: int) -> NDArray[np.float64]:
    """``sosfilt_zi`` of the sections whose bytes are ``sections`` (``count`` rows), once."""
    return np.asarray(sosfilt_zi(np.frombuffer(sections).reshape(count, 6)))


def zero_phase(
    sos: NDArray[np.float64], x: NDArray[np.float64], padlen: int | None = None
) -> NDArray[np.float64]:
    """``scipy.signal.sosfiltfilt(sos, x, padlen=padlen)`` of a 1-D ``x``, the filter's initial
    state computed once per filter (:func:`butter_sos`'s designs are few; solving for the state
    cost as much as the filtering of a 3 s capture). Bit-identical to SciPy's (tested).

    Examples
    --------
    >>> x = np.sin(np.arange(200) / 5.0)
    >>> sos = butter_sos(2, 10.0, 1000.0)
    >>> bool(np.array_equal(zero_phase(sos, x), sosfiltfilt(sos, x)))
    True
    """
    count = sos.shape[0]
    zi = _initial_state(np.ascontiguousarray(sos, dtype=np.float64).tobytes(), count)
    if padlen is None:
        taps = 2 * count + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
        padlen = 3 * taps
    if x.size <= padlen:
        raise ValueError(f"The length of the input vector x must be greater than padlen, {padlen}.")
    ext = odd_ext(x, padlen) if padlen > 0 else x
    y, _ = sosfilt(sos, ext, zi=zi * ext[:1])
    y, _ = sosfilt(sos, y[::-1], zi=zi * y[-1:])
    y = y[::-1]
    return np.asarray(y[padlen:-padlen] if padlen > 0 else y, dtype=np.float64)


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


def _log10(raw: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(np.log10(np.where(raw > 0, raw, np.nan)))


class MechanicsStage(FeatureStage):
    """The five indicators of this module as a feature stage (rows: directions of motion).

    Parameters
    ----------
    gear_ratio : float, default=100.0
        Motor revolutions per revolution of the measured position.
    tooth_period_revs : float, default=5.0
        Motor revolutions per revolution of the gear whose teeth are watched.
    bearing_order : float, default=5.43
        Defect frequency of the watched bearing, in orders of the motor speed.
    min_tooth_order : float, default=3.0
        Lowest order of the tooth lines (up to 8): lower orders fall near the band's lower edge
        at the axis's speeds, where the link's resonance and the control loop leak in (chosen on
        the development design among 2, 3 and 4: tooth-line spread 0.107, 0.100, 0.148 decades).
    band_hz : (float, float), default=(40.0, 300.0)
        Band of the torque in which impacts and lines are looked for (above the control loop and
        the link's resonance, below the sensors' noise).
    moving_fraction : float, default=0.2
        Samples with ``|speed|`` above this fraction of the peak count as moving.
    envelope_s : float, default=0.1
        Length of the moving RMS that normalises the band before its kurtosis.
    scales : sequence of 5 floats, default=MECHANICS_SCALES
        Each indicator's column is ``log10(indicator) / scale``.

    Attributes
    ----------
    baseline_readings_ : ndarray of shape (2, 5)
        :meth:`readings` of the baseline.
    unobserved_ : ndarray of bool, shape (5,)
        Indicators the baseline gives in neither direction.
    baseline_rows_ : ndarray of shape (2, 6)

    Examples
    --------
    >>> from axiswatch.datasets import simulate_capture
    >>> stage = MechanicsStage().fit(simulate_capture("short_fast", seed=0))
    >>> stage.transform(simulate_capture("heavy", seed=1)).X.shape
    (2, 6)
    """

    def __init__(
        self,
        gear_ratio: float = 100.0,
        tooth_period_revs: float = 5.0,
        bearing_order: float = 5.43,
        min_tooth_order: float = 3.0,
        band_hz: tuple[float, float] = (40.0, 300.0),
        moving_fraction: float = 0.2,
        envelope_s: float = 0.1,
        scales: Sequence[float] = MECHANICS_SCALES,
    ) -> None:
        self.envelope_s = envelope_s
        self.gear_ratio = gear_ratio
        self.tooth_period_revs = tooth_period_revs
        self.bearing_order = bearing_order
        self.min_tooth_order = min_tooth_order
        self.band_hz = band_hz
        self.moving_fraction = moving_fraction
        self.scales = scales

    def fit(self, baseline: Capture) -> MechanicsStage:
        logged = _log10(self.indicators(baseline))
        missing = ~np.isfinite(logged)
        if missing[:, 0].any():
            raise CaptureError(
                f"{baseline.source}: the baseline must show a usable move in both directions "
                "(the viscous friction could not be read in direction "
                f"{' and '.join(d for d, m in zip('+-', missing[:, 0], strict=True) if m)}); "
                "expected a capture of at least one task cycle."
            )
        for j in range(1, logged.shape[1]):
            if missing[:, j].any() and not missing[:, j].all():
                logged[missing[:, j], j] = logged[~missing[:, j], j]
        self.unobserved_ = missing.all(axis=0)
        logged[:, self.unobserved_] = 0.0
        self.baseline_readings_ = logged
        self.baseline_rows_ = self._rows(logged)
        return self

    def indicators(self, capture: Capture) -> NDArray[np.float64]:
        """The raw indicators (not logged, not scaled), shape (2, 5); NaN where not measurable."""
        signals, rate = resample_capture(capture, ("position", "speed", "torque"))
        position, speed, torque = signals.T
        low, high = self.band_hz
        if not 0 < low < high < rate / 2:
            # A CaptureError: a capture too slow for the band is one bad capture to the monitor,
            # not a configuration error that stops the run.
            raise CaptureError(
                f"The 'band_hz' parameter of MechanicsStage must satisfy 0 < low < high < "
                f"{rate / 2:g} Hz (half the rate of {capture.source}). Got {self.band_hz!r} instead."
            )
        if signals.shape[0] < 4 * rate / low:
            raise CaptureError(
                f"{capture.source}: capture too short for the mechanics indicators: "
                f"{signals.shape[0]} samples at {rate:g} Hz, expected at least {4 * rate / low:g}."
            )
        band = sosfiltfilt(butter_sos(4, (low, high), rate), torque)
        envelope = running_rms(band, whole_samples(self.envelope_s, rate))
        normalised = band / np.where(envelope > 0, envelope, 1.0)
        angle = self.gear_ratio * position
        sign = np.sign(speed)
        peak = float(np.max(np.abs(speed))) or 1.0
        tooth = [
            k / self.tooth_period_revs
            for k in range(1, int(8 * self.tooth_period_revs) + 1)
            if k / self.tooth_period_revs >= self.min_tooth_order
            and k % round(self.tooth_period_revs)
        ]
        rows = np.full((2, len(INDICATORS)), np.nan)
        smooth = sosfiltfilt(butter_sos(2, 10.0, rate), torque)  # reversal_bursts' default
        for r, direction in enumerate((1.0, -1.0)):
            moving = (sign == direction) & (np.abs(speed) > self.moving_fraction * peak)
            if moving.sum() < 8 * (len(tooth) + 8):
                continue
            # One projection of the whole orders serves the tooth and the bearing lines.
            free = _NuisanceFree(band[moving], angle[moving], WHOLE_ORDERS, None)
            rows[r] = [
                viscous_friction(position, speed, torque, rate, direction=direction),
                pearson_kurtosis(normalised[moving]),
                _bursts(smooth, band, rate, (sign == direction) & (np.abs(speed) > 0.1 * peak)),
                # Tooth orders are 1 / tooth_period_revs apart: the neighbours sit half-way.
                free.line_ratio(tooth, [0.5 / self.tooth_period_revs]),
                free.line_ratio(bearing_orders(self.bearing_order), BEARING_OFFSETS),
            ]
        return rows

    def readings(self, capture: Capture) -> NDArray[np.float64]:
        """``log10`` of :meth:`indicators`, shape (2, 5), unscaled.

        A reading that cannot be taken (a direction without a usable move, a direction in which
        the torque never reverses) is the baseline's: no evidence either way. The baseline
        itself must give the viscous friction in both directions; another indicator it gives in
        one direction only is taken for both, one it gives in neither (``unobserved_``) reads
        the same on every capture.
        """
        logged = _log10(self.indicators(capture))
        missing = ~np.isfinite(logged) | self.unobserved_
        logged[missing] = self.baseline_readings_[missing]
        return logged

    def _rows(self, readings: NDArray[np.float64]) -> NDArray[np.float64]:
        """Feature rows of :meth:`readings`: scaled, the viscous friction also negated."""
        scales = np.asarray(self.scales, dtype=np.float64)
        if scales.shape != (len(INDICATORS),) or not np.all(scales > 0):
            raise ValueError(
                f"The 'scales' parameter of MechanicsStage must be {len(INDICATORS)} positive "
                f"floats, one per indicator {INDICATORS}. Got {self.scales!r} instead."
            )
        scaled = readings / scales
        return np.column_stack([scaled[:, :1], -scaled[:, :1], scaled[:, 1:]])

    def transform(self, capture: Capture) -> Features:
        return self._features(self._rows(self.readings(capture)), capture)

    def fit_transform(self, baseline: Capture) -> Features:
        """Fit on the baseline and return its features (``baseline_rows_``, not read again)."""
        return self._features(self.fit(baseline).baseline_rows_, baseline)

    @staticmethod
    def _features(X: NDArray[np.float64], capture: Capture) -> Features:
        return Features(X, ("mechanics",), None, float(capture.rates_hz["speed"]), COLUMNS)
