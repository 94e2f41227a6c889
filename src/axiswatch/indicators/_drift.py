"""A mode's drift test: a self-starting CUSUM of each reading that grows with a fault.

Each new value of a reading is put in units of the spread of the values before it (Hawkins'
self-starting standardisation: a Student t, taken to the normal scale), so the test needs no
spread estimated in advance. The first ``reference`` values set the in-control level; later
values are compared with them only, so a slow fault is not learned into the reference. The
upper CUSUM of those shifts alarms when it passes the limit whose in-control run length is
stated (Siegmund's approximation, checked against simulation in the tests).

Reference: D. M. Hawkins, "Self-starting CUSUM charts for location and scale", The
Statistician 36 (1987) 299-316; D. Siegmund, Sequential Analysis (1985), eq. 2.56.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

from scipy.optimize import brentq
from scipy.special import ndtri, stdtr

__all__ = ["CUSUM_REFERENCE_SHIFT", "ReadingCusum", "cusum_limit", "cusum_run_length"]

#: The CUSUM's reference value ``k``, in spreads: half the shift it is tuned to (one spread),
#: the textbook choice.
CUSUM_REFERENCE_SHIFT = 0.5


def cusum_run_length(limit: float, k: float = CUSUM_REFERENCE_SHIFT) -> float:
    """The in-control average run length of an upper CUSUM of N(0, 1) shifts with reference
    ``k`` and decision limit ``limit`` (Siegmund's approximation).

    Examples
    --------
    >>> round(cusum_run_length(4.0, 0.5))
    338
    """
    b = limit + 1.166
    return (math.exp(2.0 * k * b) - 2.0 * k * b - 1.0) / (2.0 * k * k)


@lru_cache(maxsize=64)
def cusum_limit(run_length: float, k: float = CUSUM_REFERENCE_SHIFT) -> float:
    """The decision limit whose in-control run length is ``run_length`` captures.

    Examples
    --------
    >>> round(cusum_limit(338.0), 2)
    4.0
    """
    if not run_length > 1.0:
        raise ValueError(f"The run length must be more than 1 capture. Got {run_length!r}.")
    return float(brentq(lambda h: cusum_run_length(h, k) - run_length, 0.0, 100.0))


@dataclass
class ReadingCusum:
    """One reading's self-starting CUSUM within one mode.

    Attributes
    ----------
    reference : list of float
        The first values, up to ``size``: the in-control level and spread.
    size : int
        How many values the reference keeps.
    total : float
        The upper CUSUM of the standardised shifts.
    """

    size: int
    reference: list[float] = field(default_factory=list)
    total: float = 0.0

    def shift(self, value: float) -> float:
        """The value's shift from the reference, in the reference's spread, on the normal
        scale: the prediction t with ``n - 1`` degrees of freedom taken to the normal shift of
        equal tail probability. NaN with fewer than 3 values, or none spread, before it."""
        n = len(self.reference)
        if n < 3:
            return math.nan
        mean = math.fsum(self.reference) / n
        variance = math.fsum((x - mean) ** 2 for x in self.reference) / (n - 1)
        if not variance > 0:
            return math.nan
        t = (value - mean) / math.sqrt(variance) * math.sqrt(n / (n + 1))
        # The upper tail from its own side: exact where the shift is large.
        return float(-ndtri(stdtr(n - 1, -t)))

    def add(self, value: float, k: float = CUSUM_REFERENCE_SHIFT) -> float:
        """Take the next value; return the CUSUM after it. A value without a shift
        (:meth:`shift`) only joins the reference, while it has fewer than ``size``."""
        shift = self.shift(value)
        if math.isfinite(shift) or shift == math.inf:
            self.total = max(0.0, self.total + shift - k)
        if len(self.reference) < self.size:
            self.reference.append(value)
        return self.total
