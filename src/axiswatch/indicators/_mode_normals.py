"""The statistics of a mode library's normals, as arrays: spreads and leave-one-out distances.

Each known mode gives a block: its recent captures' readings (one row per capture, NaN where a
reading was not read) and their torque spectra. A mode's spread of a reading is its own
variance, raised towards the variance pooled over the modes. The thresholds are fitted on
leave-one-out distances: each capture against its mode's other captures, in spreads estimated
without it. Computed for every capture at once; equal to the capture-by-capture computation
to rounding (tested).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm
from scipy.stats import t as student_t

__all__ = ["ModeBlock", "NormalStats", "centre_error", "nan_median", "normal_shift", "other_rows"]

Array = NDArray[np.float64]


def normal_shift(z: Array | float, dof: int | Array) -> Array:
    """A Student-t shift with ``dof`` degrees of freedom, as the normal shift of equal tail
    probability; 0 where ``z`` is not positive.

    Examples
    --------
    >>> normal_shift([-1.0, 0.0, 2.0], 1000).round(3).tolist()
    [0.0, 0.0, 1.997]
    """
    z = np.asarray(z, np.float64)
    out = np.where(z > 0, norm.isf(student_t.sf(np.maximum(z, 0.0), dof)), 0.0)
    return np.asarray(np.where(np.isnan(z), np.nan, out), np.float64)


def centre_error(n: int | Array) -> Array | float:
    """A capture's spread about a median of ``n`` captures, in the captures' spread:
    ``sqrt(1 + pi / (2 n))`` (the median's large-sample variance, normal captures)."""
    return np.sqrt(1.0 + np.pi / (2.0 * np.asarray(n, np.float64)))


def other_rows(x: Array) -> Array:
    """Shape ``(m, m - 1, ...)``: for each row, the other rows, in order."""
    m = x.shape[0]
    keep = ~np.eye(m, dtype=bool)
    return x[np.nonzero(keep)[1].reshape(m, m - 1)]


def _count_var(x: Array, axis: int) -> tuple[Array, Array]:
    """Finite values along ``axis`` and their variance (``ddof=1``; NaN under 2 values)."""
    finite = np.isfinite(x)
    count = finite.sum(axis)
    values = np.where(finite, x, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = values.sum(axis) / count
        deviation = np.where(finite, x - np.expand_dims(mean, axis), 0.0)
        var = (deviation**2).sum(axis) / (count - 1)
    return count.astype(np.float64), np.where(count >= 2, var, np.nan)


def nan_median(x: Array, axis: int) -> Array:
    """The median of the values along ``axis`` that are not NaN (NaN where there is none):
    :func:`numpy.nanmedian`'s, from one sort (``nanmedian`` on small stacks is many times
    slower). Equal to it bit for bit (tested)."""
    ordered = np.sort(np.moveaxis(np.asarray(x, np.float64), axis, -1), axis=-1)  # NaN last
    count = (~np.isnan(ordered)).sum(-1, keepdims=True)
    low = np.take_along_axis(ordered, np.maximum(count - 1, 0) // 2, -1)
    high = np.take_along_axis(ordered, count // 2 - (count == 0), -1)
    with np.errstate(invalid="ignore"):  # -inf and inf in the middle: NaN, as NumPy's
        middle = np.mean(np.concatenate([low, high], -1), -1)
    return np.where(count[..., 0] > 0, middle, np.nan)


class ModeBlock:
    """One known mode's recent captures: ``readings`` (m x p) and ``spectra`` (m x bands)."""

    def __init__(self, readings: Array, spectra: Array) -> None:
        self.readings = np.where(np.isfinite(readings), readings, np.nan)
        self.spectra = spectra
        count, var = _count_var(self.readings, 0)
        # What the mode adds to the pooled variance: a reading with 3 values or more.
        self.dof = np.where(count >= 3, count - 1, 0.0)
        self.weighted = np.where(count >= 3, (count - 1) * var, 0.0)
        self.count, self.var = count, var


class NormalStats:
    """The normals' statistics of a library's known modes.

    Parameters
    ----------
    blocks : sequence of ModeBlock
        One per known mode, in the library's order.
    both : ndarray of bool, shape (p,)
        Readings where a change either way is abnormal (else only a rise).
    n_fit : int
        The pooled variance's weight in a mode's spread, in degrees of freedom plus one.
    names : sequence of str, default=()
        The readings' names, in the columns' order.
    """

    def __init__(
        self,
        blocks: Sequence[ModeBlock],
        both: NDArray[np.bool_],
        n_fit: int,
        names: Sequence[str] = (),
    ) -> None:
        self.names = list(names)
        self.blocks = list(blocks)
        self.both = both
        self.n_fit = n_fit

    def _pooled(self, replace: tuple[int, Array, Array] | None = None) -> Array:
        """Pooled variance (NaN where no mode has 3 values); ``replace``: block ``k``'s degrees
        of freedom and weighted variance replaced by those given."""
        total_w: Array | float = 0.0
        total_d: Array | float = 0.0
        for j, block in enumerate(self.blocks):
            dof, weighted = block.dof, block.weighted
            if replace is not None and j == replace[0]:
                dof, weighted = replace[1], replace[2]
            total_w, total_d = total_w + weighted, total_d + dof
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(np.asarray(total_d) > 0, total_w / total_d, np.nan)

    def pooled_variance(self) -> Array:
        """Each reading's within-mode variance pooled over the modes (NaN where unknown)."""
        return np.asarray(self._pooled(), np.float64)

    def _spread(self, prior: Array, count: Array, own: Array) -> Array:
        dof = count - 1
        shrunk = (dof * own + (self.n_fit - 1) * prior) / (dof + self.n_fit - 1)
        # Never below its own: modes differ in spread (one task's friction reading spread 10x
        # another's on development robots) and a quiet mode's pooled spread would make a
        # noisy mode alarm.
        variance = np.where(count >= 3, np.maximum(own, shrunk), prior)
        variance = np.where(np.isfinite(prior), variance, np.nan)
        with np.errstate(invalid="ignore"):
            return np.where(variance > 0, np.sqrt(variance), np.nan)

    def spreads(self, k: int) -> Array:
        """Mode ``k``'s spread of each reading: its own variance, raised towards the pooled
        variance (``n_fit - 1`` degrees of weight) when lower; NaN where none."""
        block = self.blocks[k]
        return self._spread(self._pooled(), block.count, block.var)

    def spectrum_spread(
        self, k: int | None = None, spectra: Array | None = None
    ) -> tuple[Array, int]:
        """The spectrum's spread pooled over the modes, and its degrees of freedom; with
        ``k``, mode ``k``'s spectra replaced by ``spectra`` (each of shape (r, bands) or a
        stack of them, (m, r, bands))."""
        weighted: Array | float = 0.0
        dof = 0
        for j, block in enumerate(self.blocks):
            rows = block.spectra if j != k or spectra is None else spectra
            n = rows.shape[-2]
            if n >= 2:
                weighted = weighted + (n - 1) * np.var(rows, axis=-2, ddof=1)
                dof += n - 1
        variance = np.asarray(weighted, np.float64) / dof
        return np.sqrt(np.maximum(variance, np.finfo(np.float64).tiny)), max(dof, 1)

    def leave_one_out(self) -> tuple[list[float], list[float]]:
        """Every capture's distance from its mode's other captures, in spreads estimated
        without it: the readings' (finite ones only) and the spectrum's, mode by mode."""
        readings: list[float] = []
        spectra: list[float] = []
        for k, block in enumerate(self.blocks):
            m = block.readings.shape[0]
            if m < 2:
                continue
            others = other_rows(block.readings)  # (m, m - 1, p)
            count, var = _count_var(others, 1)
            dof = np.where(count >= 3, count - 1, 0.0)
            weighted = np.where(count >= 3, (count - 1) * var, 0.0)
            prior = self._pooled((k, dof, weighted))
            spread = self._spread(prior, count, var)
            centre = nan_median(others, 1)
            z = (block.readings - centre) / (spread * centre_error(m - 1))
            z = np.where(self.both, np.abs(z), np.maximum(z, 0.0))
            z = np.where(np.isfinite(z), z, -np.inf)
            best = z.max(1)
            found = best > -np.inf
            shifts = normal_shift(best[found], max(m - 2, 1))
            readings.extend(float(s) for s in shifts)
            other_spectra = other_rows(block.spectra)  # (m, m - 1, bands)
            band, band_dof = self.spectrum_spread(k, other_spectra)
            rise = (block.spectra - np.median(other_spectra, 1)) / (band * centre_error(m - 1))
            spectra.extend(float(s) for s in normal_shift(np.maximum(rise.max(1), 0.0), band_dof))
        return readings, spectra
