"""Products of angle-locked waves from sums of phasors, without the waves themselves.

``sum_n sin(a t_n) cos(b t_n)`` and its kin are half the real or imaginary part of
``S(a - b)`` and ``S(a + b)``, with ``S(f) = sum_n exp(1j f t_n)``. Frequencies on a few grids of
one step are summed by baby-step giant-step: one small complex matrix product per grid.
Which sums a set of orders needs, and where they fall, is planned once per set and process.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from axiswatch.indicators._workspace import scratch

__all__ = [
    "MAX_GRIDS",
    "MAX_POWER",
    "PhasorPlan",
    "Phasors",
    "cis",
    "phasor_base",
    "phasor_plan",
    "phasor_sums",
    "wave_products",
]

#: Most grids (classes of frequencies equal modulo the step) summed; beyond, the waves' own
#: products cost less.
MAX_GRIDS = 4

#: Highest power of a kept phasor that :class:`Phasors` takes for a multiple of its frequency
#: (a few squarings); the base :func:`phasor_base` seeds is at most its inverse.
MAX_POWER = 64


def cis(angle: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``exp(1j * angle)`` from NumPy's vectorised ``cos`` and ``sin`` (its complex ``exp`` is
    about 3x slower on the large angles of a motor's revolutions)."""
    out = np.empty(angle.shape, dtype=np.complex128)
    np.cos(angle, out=out.real)
    np.sin(angle, out=out.imag)
    return out


class Phasors:
    """``exp(1j * f * angle)`` of one angle, each frequency ``f`` computed once: a capture's
    lines share the whole orders' ``exp(1j * angle)``, and a shift and its opposite share one
    ``cis`` (the conjugate). Each ``cis`` costs about fifty complex products. A frequency
    twice a kept one plus a whole order (a bearing's double, ``2 f - 1 = 2 (f - 2) + 3``) is
    their product: four products instead of a ``cis``.

    The arrays are read-only: a caller that writes copies first.

    Examples
    --------
    >>> phasors = Phasors(np.linspace(0.0, 30.0, 500))
    >>> phasors(0.25) is phasors(0.25), bool(np.array_equal(phasors(-0.25), np.conj(phasors(0.25))))
    (True, True)
    """

    def __init__(self, angle: NDArray[np.float64]) -> None:
        self.angle = angle
        self._kept: dict[float, NDArray[np.complex128]] = {}

    def __call__(self, frequency: float) -> NDArray[np.complex128]:
        kept = self._kept.get(frequency)
        if kept is None:
            opposite = self._kept.get(-frequency)
            if opposite is not None:
                kept = np.conj(opposite)
            else:
                kept = self._power(frequency)
                if kept is None:
                    kept = self._doubled(frequency)
                if kept is None:
                    kept = cis(frequency * self.angle)
            kept.flags.writeable = False
            self._kept[frequency] = kept
        return kept

    def _power(self, frequency: float) -> NDArray[np.complex128] | None:
        """``exp(1j * g * angle) ** m`` for a kept ``g > 0`` of which ``frequency`` is a whole
        multiple ``m`` (2 to :data:`MAX_POWER`), by repeated squaring; None if none is. A
        capture's lines seed their base (:func:`phasor_base`): one ``cis`` for all. The
        multiple may differ from ``frequency`` by 1e-12 of it, as a tooth set's grid step
        found from its rounded orders does (0.09999999999999964 for 0.1): a tooth line is then
        nearer its exact value, not farther (tested)."""
        if frequency <= 0:
            return None
        for base, kept in self._kept.items():
            if base <= 0:
                continue
            m = round(frequency / base)
            if 2 <= m <= MAX_POWER and abs(m * base - frequency) <= 1e-12 * frequency:
                out, square = None, kept
                while True:  # binary powering: m's bits, lowest first
                    if m & 1:
                        out = square.copy() if out is None else np.multiply(out, square, out=out)
                    m >>= 1
                    if not m:
                        break
                    square = np.multiply(square, square)
                assert out is not None
                return out
        return None

    def _doubled(self, frequency: float) -> NDArray[np.complex128] | None:
        """``exp(1j * f * angle)`` as ``exp(1j * g * angle) ** 2 * exp(1j * angle) ** m`` for a
        kept ``g > 0`` with ``f = 2 g + m`` to rounding (``m`` whole, 1 to 8); None if none is.
        Its error is a few roundings, as ``cis`` of the rounded ``f * angle`` makes."""
        one = self._kept.get(1.0)
        if one is None or frequency <= 0:
            return None
        for base, kept in self._kept.items():
            whole = frequency - 2.0 * base
            m = round(whole)
            if base > 0 and 1 <= m <= 8 and abs(whole - m) <= 8e-16 * frequency:
                out = np.multiply(kept, kept)
                for _ in range(m):
                    np.multiply(out, one, out=out)
                return out
        return None


@lru_cache(maxsize=64)
def phasor_base(frequencies: tuple[float, ...]) -> float | None:
    """The largest ``1 / N`` (``N`` up to :data:`MAX_POWER`) of which every frequency is a whole
    multiple: a capture's lines (the whole orders, a tooth set's half step, a bearing's shift of
    a quarter) then take one ``cis`` of it and their phasors as its powers; None if there is
    none, or it is one of the frequencies (nothing to share).

    Examples
    --------
    >>> phasor_base((1.0, 0.1, 0.25)), phasor_base((1.0, 0.25)), phasor_base((1.0, 0.43))
    (0.05, 0.25, None)

    Found once per set of frequencies and process (a fleet's captures share a few).
    """
    values = [f for f in frequencies if f > 0]
    for count in range(1, MAX_POWER + 1):
        if all(abs(f * count - round(f * count)) <= 1e-9 for f in values):
            base = 1.0 / count
            return None if count == 1 or all(f == base for f in values) else base
    return None


@dataclass(frozen=True)
class PhasorPlan:
    """Where :func:`phasor_sums` finds each frequency: per class of frequencies equal modulo
    the step, its members (positions among the frequencies), its offset and each member's
    index on the class's grid; and which frequencies are negative (conjugated). A pure
    function of the frequencies and the step (:func:`phasor_plan`): a caller that sums the
    same frequencies for every capture keeps it (read-only arrays)."""

    step: float
    classes: tuple[tuple[NDArray[np.intp], float, NDArray[np.int64]], ...]
    negative: NDArray[np.bool_]


def phasor_plan(frequencies: NDArray[np.float64], step: float) -> PhasorPlan | None:
    """The :class:`PhasorPlan` of ``frequencies`` on grids of ``step``; None when they fall in
    more than :data:`MAX_GRIDS` classes, or a class is not a grid after all.

    Examples
    --------
    >>> plan = phasor_plan(np.array([0.4, 1.2, -2.0, 3.1]), 0.4)
    >>> [(members.tolist(), round(offset, 6)) for members, offset, _ in plan.classes]
    [([0, 1, 2], 0.0), ([3], 0.3)]
    """
    flat = np.abs(frequencies)
    whole = np.floor(flat / step + 1e-7)
    fraction = flat / step - whole
    wrap = fraction > 1 - 1e-7
    whole[wrap] += 1
    fraction[wrap] -= 1
    keys = np.rint(fraction * 1e6).astype(np.int64)
    found = np.unique(keys)
    if found.size > MAX_GRIDS:
        return None
    classes = []
    for key in found:
        members = np.flatnonzero(keys == key)
        offset = float(flat[members[0]] - whole[members[0]] * step)
        if abs(offset) <= 1e-12 * step:
            offset = 0.0
        index = np.rint((flat[members] - offset) / step).astype(np.int64)
        off_grid = np.abs(flat[members] - (offset + index * step))
        if np.any(off_grid > 1e-12 * np.maximum(1.0, flat[members])):
            return None  # not a grid after all: summed at the wrong frequencies
        members.flags.writeable = index.flags.writeable = False
        classes.append((members, offset, index))
    negative = frequencies < 0
    negative.flags.writeable = False
    return PhasorPlan(step, tuple(classes), negative)


def phasor_sums(
    angle: NDArray[np.float64],
    weights: NDArray[np.float64],
    frequencies: NDArray[np.float64],
    step: float,
    plan: PhasorPlan | None = None,
    extents: NDArray[np.int64] | None = None,
    phasors: Phasors | None = None,
) -> NDArray[np.complex128] | None:
    """``sum_n weights[w, n] * exp(1j * f * angle[n])`` for every weight row ``w`` and frequency
    ``f`` (1-D): shape ``(len(weights), len(frequencies))``; None when the frequencies fall in
    more than :data:`MAX_GRIDS` classes modulo ``step``. ``plan``: their :func:`phasor_plan`,
    when kept. ``extents``, shape ``(classes, len(weights))``: the steps of each class's grid a
    weight row is summed over, when fewer than the class's (a residual read at the orders
    only); its sums beyond are NaN. ``phasors``: the angle's, whose exponentials are shared.

    A class ``c + m step`` (``m = 0..M``) is summed as ``G @ B.T``: baby rows ``B_j = z^j`` and
    giant rows ``G_l = w exp(1j c angle) z^(J l)``, ``z = exp(1j step angle)``, ``J ~ sqrt(M)``,
    each power built by repeated multiplication (about ``sqrt(M)`` roundings, where the waves'
    recurrence makes ``M``). A negative frequency is the conjugate of its opposite.

    Examples
    --------
    >>> angle = np.linspace(0.0, 30.0, 500)
    >>> f = np.array([0.4, 1.2, -2.0, 3.1])
    >>> sums = phasor_sums(angle, np.ones((1, angle.size)), f, 0.4)
    >>> bool(np.allclose(sums[0], np.exp(1j * np.multiply.outer(f, angle)).sum(axis=1)))
    True
    """
    plan = phasor_plan(frequencies, step) if plan is None else plan
    if plan is None:
        return None
    n, count_weights = angle.size, weights.shape[0]
    out = np.empty((count_weights, frequencies.size), dtype=np.complex128)
    rotation = cis(step * angle) if phasors is None else phasors(step)
    for c, (members, offset, index) in enumerate(plan.classes):
        count = int(index.max()) + 1
        baby_count = math.isqrt(count - 1) + 1
        baby = scratch("baby", (baby_count, n), np.complex128)
        baby[0] = 1.0
        for j in range(1, baby_count):
            np.multiply(baby[j - 1], rotation, out=baby[j])
        leap = baby[-1] * rotation
        # Giant rows of each weight row: as many as its extent needs, one block after another.
        wanted = [count] * count_weights if extents is None else extents[c].tolist()
        giants = [-(-min(extent, count) // baby_count) for extent in wanted]
        firsts = np.cumsum([0, *giants]).tolist()
        giant = scratch("giant", (firsts[-1], n), np.complex128)
        if offset == 0.0:
            start = None
        else:
            start = cis(offset * angle) if phasors is None else phasors(offset)
        for w, first in enumerate(firsts[:-1]):
            if not giants[w]:
                continue
            if start is None:  # exp(0j): the weights themselves
                giant.real[first], giant.imag[first] = weights[w], 0.0
            else:
                np.multiply(start.real, weights[w], out=giant.real[first])
                np.multiply(start.imag, weights[w], out=giant.imag[first])
            for g in range(first + 1, first + giants[w]):
                np.multiply(giant[g - 1], leap, out=giant[g])
        table = giant @ baby.T
        for w, (first, last) in enumerate(itertools.pairwise(firsts)):
            sums = table[first:last].ravel()
            if sums.size >= count:
                out[w, members] = sums[index]
            else:
                inside = index < sums.size
                out[w, members] = np.nan
                out[w, members[inside]] = sums[index[inside]]
    negative = plan.negative
    out[:, negative] = np.conj(out[:, negative])
    return out


def wave_products(
    difference: NDArray[np.complex128], total: NDArray[np.complex128]
) -> NDArray[np.float64]:
    """``X @ Y.T`` of the waves ``X = [sin(a t); cos(a t)]`` and ``Y = [sin(b t); cos(b t)]``
    from the sums of phasors at ``a - b`` (``difference``) and ``a + b`` (``total``), each of
    shape ``(len(a), len(b))``.

    ``sin a sin b = (cos(a-b) - cos(a+b)) / 2``, ``sin a cos b = (sin(a+b) + sin(a-b)) / 2``,
    ``cos a sin b = (sin(a+b) - sin(a-b)) / 2``, ``cos a cos b = (cos(a-b) + cos(a+b)) / 2``.

    Examples
    --------
    >>> t = np.linspace(0.0, 20.0, 300)
    >>> a, b = np.array([1.0, 2.5]), np.array([0.5])
    >>> s = lambda f: np.exp(1j * np.multiply.outer(f, t)).sum(axis=-1)
    >>> waves = lambda f: np.concatenate([np.sin(np.outer(f, t)), np.cos(np.outer(f, t))])
    >>> products = wave_products(s(np.subtract.outer(a, b)), s(np.add.outer(a, b)))
    >>> bool(np.allclose(products, waves(a) @ waves(b).T))
    True
    """
    rows, columns = difference.shape
    out = np.empty((2 * rows, 2 * columns))
    plus, minus = difference + total, difference - total
    np.multiply(minus.real, 0.5, out=out[:rows, :columns])
    np.multiply(plus.imag, 0.5, out=out[:rows, columns:])
    np.multiply(minus.imag, -0.5, out=out[rows:, :columns])
    np.multiply(plus.real, 0.5, out=out[rows:, columns:])
    return out


def order_grids(values: NDArray[np.float64]) -> tuple[tuple[NDArray[np.int64], float, float], ...]:
    """The orders ``values`` as grids: ``(members, start, step)``, each member at a whole number
    of steps from ``start``. One grid when they are multiples of their smallest spacing (the
    tooth sets); else one per class of equal fractional part, of step 1 (a bearing order and its
    double, each with whole-order sidebands). Found once per set of orders and process (a
    capture's lines ask four times; each costs as much as a wave's product): the arrays are
    read-only."""
    return _order_grids_of(tuple(values.tolist()))


@lru_cache(maxsize=256)
def _order_grids_of(
    orders: tuple[float, ...],
) -> tuple[tuple[NDArray[np.int64], float, float], ...]:
    values = np.asarray(orders, dtype=np.float64)
    step = float(np.min(np.diff(np.sort(values)))) if values.size > 1 else 0.0
    every = np.arange(values.size)
    grids = [(every, float(values.min()), step)]
    on_one_grid = False
    if step > 0:
        steps = np.rint((values - values.min()) / step)
        on_one_grid = float(np.max(np.abs(values - (values.min() + steps * step)))) <= 1e-9
    if not on_one_grid:
        fraction = np.round(values - np.floor(values), 9) % 1.0
        grids = [
            (every[fraction == value], float(values[fraction == value].min()), 1.0)
            for value in np.unique(fraction)
        ]
    for members, _, _ in grids:
        members.flags.writeable = False  # kept for the next capture
    return tuple(grids)


def summing_step(step: float, offsets: Sequence[float]) -> float:
    """The step whose grid holds the orders (a grid of ``step``) shifted by every offset:
    ``step`` when the offsets are whole steps, half of it when they are half steps (a tooth
    set's), else ``step`` (the phasor sums then sum a few classes of frequencies).

    One grid of half steps costs one exponential and one product; two classes cost two each.

    Examples
    --------
    >>> summing_step(0.2, [0.1]), summing_step(0.2, [0.4]), summing_step(0.2, [0.03])
    (0.1, 0.2, 0.2)
    """
    for divisor in (1, 2):
        multiples = [divisor * shift / step for shift in offsets]
        if all(abs(m - round(m)) <= 1e-9 for m in multiples):
            return step / divisor
    return step


@dataclass(frozen=True)
class SumsPlan:
    """The phasor sums the line statistics read for a set of orders and offsets (a tooth set):
    the frequencies summed and their :class:`PhasorPlan`; where among them lie the sums at the
    differences of two orders (and which are conjugated); and per set of orders (shifted by
    each offset) the sums at the totals of two orders, at a whole order less and plus an
    order, and at the orders. Every index is a column of the sums."""

    frequencies: NDArray[np.float64]
    phasors: PhasorPlan
    difference: NDArray[np.intp]
    conjugated: NDArray[np.bool_]
    shifts: tuple[tuple[NDArray[np.intp], ...], ...]
    #: :func:`phasor_sums`'s extents of the weights ones and the residual: the residual is
    #: read at the orders only, the lower part of each grid.
    extents: NDArray[np.int64]


@lru_cache(maxsize=64)
def sums_plan(
    orders: tuple[float, ...], offsets: tuple[float, ...], whole_orders: tuple[float, ...]
) -> SumsPlan | None:
    """The :class:`SumsPlan` of a set of orders on one grid, kept per process (a capture's
    tooth lines read the same sets); None for orders on no single grid or frequencies in too
    many classes."""
    values = np.asarray(orders, dtype=np.float64)
    grids = order_grids(values)
    if len(grids) != 1:
        return None
    _, start, step = grids[0]
    steps = np.rint((values - start) / step).astype(np.intp)
    top = int(steps.max())
    grid = np.arange(2 * top + 1) * step
    whole = np.asarray(whole_orders, dtype=np.float64)[:, None]
    # Per set of orders (shifted by d): the sums at the differences of two orders (the same
    # for every d), at their totals, at a whole order plus or minus an order, and the
    # residual's sums at the orders; each on the grid of the orders' steps.
    parts = [grid[: top + 1]]
    for shift in (0.0, *offsets):
        first = start + shift
        parts += [2 * first + grid, whole + first + grid[: top + 1]]
        parts += [whole - first - grid[: top + 1], first + grid[: top + 1]]
    frequencies = np.concatenate([part.ravel() for part in parts])
    phasors = phasor_plan(frequencies, summing_step(step, offsets))
    if phasors is None:
        return None
    begins = np.cumsum([0, *(part.size for part in parts)])
    apart = steps[:, None] - steps[None, :]
    # A whole order k and an order: column begins + k * (top + 1) + the order's step.
    rows = np.arange(whole.size)[:, None] * (top + 1) + steps[None, :]
    shifts = tuple(
        (
            begins[k] + steps[:, None] + steps[None, :],
            begins[k + 2] + rows,
            begins[k + 1] + rows,
            begins[k + 3] + steps,
        )
        for k in range(1, len(parts), 4)
    )
    difference, conjugated = np.abs(apart), apart < 0
    at_orders = np.concatenate([shift[3] for shift in shifts])
    extents = np.array(
        [
            (int(index.max()) + 1, int(index[np.isin(members, at_orders)].max(initial=-1)) + 1)
            for members, _, index in phasors.classes
        ],
        dtype=np.int64,
    )
    kept = (frequencies, difference, conjugated, extents, *(a for s in shifts for a in s))
    for array in kept:
        array.flags.writeable = False
    return SumsPlan(frequencies, phasors, difference, conjugated, shifts, extents)
