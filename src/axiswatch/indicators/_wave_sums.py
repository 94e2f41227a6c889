"""Products of angle-locked waves from sums of phasors, without the waves themselves.

``sum_n sin(a t_n) cos(b t_n)`` and its kin are half the real or imaginary part of
``S(a - b)`` and ``S(a + b)``, with ``S(f) = sum_n exp(1j f t_n)``. Frequencies on a few grids of
one step are summed by baby-step giant-step: one small complex matrix product per grid.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from axiswatch.indicators._workspace import scratch

__all__ = ["MAX_GRIDS", "Phasors", "cis", "phasor_sums", "wave_products"]

#: Most grids (classes of frequencies equal modulo the step) summed; beyond, the waves' own
#: products cost less.
MAX_GRIDS = 4


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
    ``cis`` (the conjugate). Each ``cis`` costs about fifty complex products.

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
            kept = cis(frequency * self.angle) if opposite is None else np.conj(opposite)
            kept.flags.writeable = False
            self._kept[frequency] = kept
        return kept


def phasor_sums(
    angle: NDArray[np.float64],
    weights: NDArray[np.float64],
    frequencies: NDArray[np.float64],
    step: float,
) -> NDArray[np.complex128] | None:
    """``sum_n weights[w, n] * exp(1j * f * angle[n])`` for every weight row ``w`` and frequency
    ``f`` (1-D): shape ``(len(weights), len(frequencies))``; None when the frequencies fall in
    more than :data:`MAX_GRIDS` classes modulo ``step``.

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
    flat = np.abs(frequencies)
    whole = np.floor(flat / step + 1e-7)
    fraction = flat / step - whole
    wrap = fraction > 1 - 1e-7
    whole[wrap] += 1
    fraction[wrap] -= 1
    keys = np.rint(fraction * 1e6).astype(np.int64)
    classes = np.unique(keys)
    if classes.size > MAX_GRIDS:
        return None
    n, count_weights = angle.size, weights.shape[0]
    out = np.empty((count_weights, flat.size), dtype=np.complex128)
    rotation = cis(step * angle)
    for key in classes:
        members = np.flatnonzero(keys == key)
        offset = flat[members[0]] - whole[members[0]] * step
        if abs(offset) <= 1e-12 * step:
            offset = 0.0
        index = np.rint((flat[members] - offset) / step).astype(np.int64)
        off_grid = np.abs(flat[members] - (offset + index * step))
        if np.any(off_grid > 1e-12 * np.maximum(1.0, flat[members])):
            return None  # not a grid after all: summed at the wrong frequencies
        count = int(index.max()) + 1
        baby_count = math.isqrt(count - 1) + 1
        giant_count = -(-count // baby_count)
        baby = scratch("baby", (baby_count, n), np.complex128)
        baby[0] = 1.0
        for j in range(1, baby_count):
            np.multiply(baby[j - 1], rotation, out=baby[j])
        leap = baby[-1] * rotation
        giant = scratch("giant", (count_weights, giant_count, n), np.complex128)
        if offset == 0.0:  # exp(0j): the weights themselves
            giant.real[:, 0], giant.imag[:, 0] = weights, 0.0
        else:
            start = cis(offset * angle)
            np.multiply(start.real, weights, out=giant.real[:, 0])
            np.multiply(start.imag, weights, out=giant.imag[:, 0])
        for g in range(1, giant_count):
            np.multiply(giant[:, g - 1], leap, out=giant[:, g])
        table = (giant.reshape(-1, n) @ baby.T).reshape(count_weights, -1)
        out[:, members] = table[:, index]
    negative = frequencies < 0
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
