"""Order lines against the baseline's own order spectrum, without kinematics.

A fault of a rotating part adds lines at fixed orders of the position. New or grown lines
become one indicator, ``order_lines``. Each step: docs/internals.md, "Order lines".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.fft import next_fast_len, rfft
from scipy.ndimage import median_filter
from scipy.signal import detrend, get_window

from axiswatch._capture import rate_at_least
from axiswatch.indicators._signals import bearing_orders

__all__ = [
    "OrderProfile",
    "OrderSpectrum",
    "component_at",
    "grown_lines",
    "most_grown_order",
    "order_profile",
    "order_reference",
    "order_spectrum",
]

#: Least torque rate for an order spectrum (Hz), as for the impulsive indicators.
MIN_RATE_HZ = 100.0
#: Share of the peak speed above which motion counts as steady (as the drive loads').
STEADY_FRACTION = 0.5
#: Least resolution cells of the median run in the order band.
MIN_CELLS = 32
#: Width of the running-median floor, in resolution cells of the median run.
FLOOR_CELLS = 8
#: Lowest order of the unfiltered band, in resolution cells of the median run (a Hann window's
#: leakage from a run's mean is below -62 dB there, from the curvature left after its straight
#: line is removed below -55 dB).
LOW_CELLS = 8
#: Cells of the common order grid per decade (each about 4.9 % of its order wide).
CELLS_PER_DECADE = 48
#: :func:`grown_lines` averages the growth of this many cells: a fault's comb of lines (a tooth
#: once per gear turn and its harmonics, a bearing's order and sidebands) grows several, one
#: noisy cell does not set it.
TOP_LINES = 5
#: Least cells a capture and the reference must share for :func:`grown_lines`.
MIN_COMMON_CELLS = 16


@dataclass(frozen=True)
class OrderSpectrum:
    """The averaged order spectrum of a capture's steady runs, in the order band.

    Attributes
    ----------
    orders, power, floor : ndarray
        Orders (cycles per ``2 pi`` of position), the averaged periodogram and its running
        median floor.
    cells : float
        Resolution cells of the median run in the band.
    bins_per_cell : float
        Bins of the zero-padded spectrum per resolution cell.
    """

    orders: NDArray[np.float64]
    power: NDArray[np.float64]
    floor: NDArray[np.float64]
    cells: float
    bins_per_cell: float


@dataclass(frozen=True, eq=False)
class OrderProfile:
    """A spectrum's power over its floor on the common order grid (:func:`order_profile`).

    Attributes
    ----------
    first_cell : int
        Grid index of ``values[0]``: cell ``k`` holds the orders
        ``[10 ** (k / CELLS_PER_DECADE), 10 ** ((k + 1) / CELLS_PER_DECADE))``.
    values : ndarray
        ``log10`` of the cell's power over its floor; NaN where the spectrum has no bin.
    """

    first_cell: int
    values: NDArray[np.float64]

    @property
    def cells(self) -> NDArray[np.int64]:
        """Grid index of every value."""
        return self.first_cell + np.arange(self.values.size, dtype=np.int64)


def _steady_runs(speed: NDArray[np.float64]) -> list[slice]:
    magnitude = np.abs(speed)
    peak = float(np.max(magnitude)) if magnitude.size else 0.0
    if not peak > 0:
        return []
    key = np.where(magnitude > STEADY_FRACTION * peak, np.sign(speed), 0.0)
    edges = np.flatnonzero(np.diff(key) != 0) + 1
    bounds = np.concatenate([[0], edges, [key.size]])
    return [
        slice(int(a), int(b)) for a, b in itertools.pairwise(bounds) if key[a] != 0 and b - a > 8
    ]


def order_spectrum(
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    torque: NDArray[np.float64],
    rate_hz: float,
    band_hz: tuple[float, float] | None = None,
) -> OrderSpectrum | str:
    """The order spectrum of a capture's steady runs (see the module docstring), or why none.

    Parameters
    ----------
    position, speed, torque : ndarray of shape (n,)
        On one time base (:func:`~axiswatch.indicators._readings.motion`), position in rad or m.
    rate_hz : float
    band_hz : (float, float), optional
        The frequency band the torque was filtered to: the order band is then the orders that
        stay inside it at every steady speed (10th-90th percentile). None (the product's): the
        torque unfiltered, each run's straight line removed, orders from :data:`LOW_CELLS`
        resolution cells of the median run up to ``0.4 x rate`` at the fast steady speed.

    Returns
    -------
    OrderSpectrum or str
        The spectrum, or why the capture cannot give one.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 6, 1e-3)  # strokes of 3 rad at 2 rad/s, a line at order 300
    >>> q = 3 * (1 - np.abs(2 * ((t / 3) % 1) - 1))
    >>> v = np.gradient(q, 1e-3)
    >>> noise = np.random.default_rng(0).normal(0, 0.05, t.size)
    >>> torque = np.sign(v) + 0.3 * np.sin(300 * q) + noise
    >>> spectrum = order_spectrum(q, v, torque, 1000.0)
    >>> top = float(spectrum.orders[np.argmax(spectrum.power / spectrum.floor)])
    >>> abs(top - 300) < 2  # within a resolution cell: a run of 3 rad resolves 2 pi / 3 orders
    True
    >>> order_spectrum(q[::20], v[::20], torque[::20], 50.0)
    'needs a torque rate >= 100 Hz (got 50 Hz)'
    """
    if not rate_at_least(rate_hz, MIN_RATE_HZ):
        return f"needs a torque rate >= {MIN_RATE_HZ:g} Hz (got {rate_hz:g} Hz)"
    runs = _steady_runs(speed)
    if not runs:
        return "needs steady motion"
    revs_per_s = np.concatenate([np.abs(speed[r]) for r in runs]) / (2 * math.pi)
    slow, fast = (float(np.quantile(revs_per_s, q)) for q in (0.1, 0.9))
    slowest = float(np.min(revs_per_s))
    high_hz = 0.4 * rate_hz if band_hz is None else band_hz[1]
    # Samples per unit of angle so that the highest frequency left in the torque (the band's top,
    # or the rate's Nyquist frequency) at the slowest steady speed is below the grid's Nyquist
    # order: nothing aliases into the order band.
    per_rev = 2.0 * (0.5 * rate_hz if band_hz is None else band_hz[1]) / slowest
    step = 2 * math.pi / per_rev
    grids = []
    for run in runs:
        theta = position[run] * np.sign(speed[run][0])
        order = np.argsort(theta, kind="stable")
        theta, x = theta[order], torque[run][order]
        n = int((theta[-1] - theta[0]) / step)
        if n >= 16:
            grid = np.interp(theta[0] + step * np.arange(n), theta, x)
            if band_hz is None:
                grid = detrend(grid, type="linear")
            grids.append(grid)
    if not grids:
        return "needs steady motion"
    lengths = np.asarray([g.size for g in grids])
    cell = per_rev / float(np.median(lengths))  # orders per resolution cell of the median run
    low_order = LOW_CELLS * cell if band_hz is None else band_hz[0] / slow
    high_order = high_hz / fast
    cells = max(high_order - low_order, 0.0) / cell
    if cells < MIN_CELLS:
        return (
            f"needs steady runs resolving {MIN_CELLS} order lines in its order band "
            f"(got {cells:.3g})"
        )
    nfft = next_fast_len(int(lengths.max()))
    power = np.zeros(nfft // 2 + 1)
    for g in grids:
        window = get_window("hann", g.size)
        power += np.abs(rfft(g * window, nfft)) ** 2 / float(np.sum(window**2)) * g.size
    power /= float(lengths.sum())
    orders = np.arange(power.size) * per_rev / nfft
    inside = (orders >= low_order) & (orders <= high_order)
    size = 2 * max(2, round(FLOOR_CELLS * cell / (per_rev / nfft) / 2)) + 1
    floor = median_filter(power[inside], size=size, mode="nearest")
    return OrderSpectrum(orders[inside], power[inside], floor, cells, nfft * cell / per_rev)


def order_profile(spectrum: OrderSpectrum) -> OrderProfile:
    """The spectrum's power over its floor per cell of the common order grid, in decades.

    Parameters
    ----------
    spectrum : OrderSpectrum

    Returns
    -------
    OrderProfile
        Cell ``k`` (orders ``[10 ** (k / 48), 10 ** ((k + 1) / 48))``) holds
        ``log10(sum(power) / sum(floor))`` over the spectrum's bins in it; NaN where it has no
        bin or its floor is 0.

    Examples
    --------
    >>> import numpy as np
    >>> orders = np.linspace(100.0, 200.0, 201)
    >>> power = np.ones_like(orders)
    >>> power[100] = 11.0  # a line at order 150 on a flat floor of 1
    >>> profile = order_profile(OrderSpectrum(orders, power, np.ones_like(orders), 50.0, 1.0))
    >>> cell = int(np.floor(48 * np.log10(150.0))) - profile.first_cell
    >>> # its cell (orders 146.8-154.0) holds 14 bins: log10((13 + 11) / 14)
    >>> round(float(profile.values[cell]), 3), round(float(np.nanmin(profile.values)), 3)
    (0.234, 0.0)
    """
    keep = (spectrum.orders > 0) & (spectrum.floor > 0)
    index = np.floor(CELLS_PER_DECADE * np.log10(spectrum.orders[keep])).astype(np.int64)
    if index.size == 0:
        return OrderProfile(0, np.zeros(0))
    first = int(index.min())
    local = index - first
    power = np.bincount(local, spectrum.power[keep])
    floor = np.bincount(local, spectrum.floor[keep])
    values = np.full(power.size, np.nan)
    filled = floor > 0
    values[filled] = np.log10(power[filled] / floor[filled])
    return OrderProfile(first, values)


def _on_cells(profiles: Sequence[OrderProfile], first: int, size: int) -> NDArray[np.float64]:
    out = np.full((len(profiles), size), np.nan)
    for row, profile in zip(out, profiles, strict=True):
        start = profile.first_cell - first
        row[start : start + profile.values.size] = profile.values
    return out


def order_reference(profiles: Sequence[OrderProfile]) -> OrderProfile | None:
    """The reference of captures of the baseline's task: the median profile over the captures
    that read a cell, each cell then the largest of itself and its two neighbours.

    Parameters
    ----------
    profiles : sequence of OrderProfile

    Returns
    -------
    OrderProfile or None
        None when no profile has a cell.

    Examples
    --------
    >>> import numpy as np
    >>> a = OrderProfile(10, np.array([0.0, 1.0, 0.0, 0.0]))
    >>> b = OrderProfile(11, np.array([3.0, 0.0, 0.0, 0.2]))
    >>> reference = order_reference([a, b])  # medians 0, 2, 0, 0, 0.2
    >>> reference.first_cell, reference.values.tolist()
    (10, [2.0, 2.0, 2.0, 0.2, 0.2])
    """
    present = [p for p in profiles if p.values.size and bool(np.isfinite(p.values).any())]
    if not present:
        return None
    first = min(p.first_cell for p in present)
    size = max(p.first_cell + p.values.size for p in present) - first
    stacked = _on_cells(present, first, size)
    read = np.isfinite(stacked).any(axis=0)
    median = np.full(size, np.nan)
    median[read] = np.nanmedian(stacked[:, read], axis=0)
    padded = np.pad(median, 1, constant_values=np.nan)
    neighbours = np.vstack([padded[:-2], padded[1:-1], padded[2:]])
    widened = np.full(size, np.nan)
    read = np.isfinite(neighbours).any(axis=0)
    widened[read] = np.nanmax(neighbours[:, read], axis=0)
    return OrderProfile(first, widened)


def _growth(profile: OrderProfile, reference: OrderProfile) -> OrderProfile | None:
    """``profile - reference`` on the cells both span; None when fewer than
    :data:`MIN_COMMON_CELLS` of them are read by both."""
    first = max(profile.first_cell, reference.first_cell)
    last = min(
        profile.first_cell + profile.values.size, reference.first_cell + reference.values.size
    )
    if last - first < MIN_COMMON_CELLS:
        return None
    mine = profile.values[first - profile.first_cell : last - profile.first_cell]
    theirs = reference.values[first - reference.first_cell : last - reference.first_cell]
    growth = mine - theirs
    if int(np.isfinite(growth).sum()) < MIN_COMMON_CELLS:
        return None
    return OrderProfile(first, growth)


def grown_lines(profile: OrderProfile, reference: OrderProfile) -> float:
    """How much the cells that grew most grew against the reference (decades).

    Parameters
    ----------
    profile : OrderProfile
        Of the capture.
    reference : OrderProfile
        :func:`order_reference` of the baseline's captures.

    Returns
    -------
    float
        The mean of the :data:`TOP_LINES` largest ``profile - reference`` over the cells both
        read; NaN when they share fewer than :data:`MIN_COMMON_CELLS`.

    Examples
    --------
    >>> import numpy as np
    >>> reference = OrderProfile(100, np.zeros(40))
    >>> capture = OrderProfile(110, np.r_[np.full(28, 0.1), 2.0, 2.0])  # two new lines
    >>> round(grown_lines(capture, reference), 3)  # (2 + 2 + 0.1 + 0.1 + 0.1) / 5
    0.86
    >>> grown_lines(OrderProfile(200, np.zeros(40)), reference)
    nan
    """
    growth = _growth(profile, reference)
    if growth is None:
        return math.nan
    finite = growth.values[np.isfinite(growth.values)]
    return float(np.mean(np.sort(finite)[-TOP_LINES:]))


def most_grown_order(profile: OrderProfile, reference: OrderProfile) -> float:
    """The order (geometric centre of the cell) that grew most against the reference.

    Examples
    --------
    >>> import numpy as np
    >>> reference = OrderProfile(100, np.zeros(40))
    >>> capture = OrderProfile(100, np.r_[np.zeros(20), 2.0, np.zeros(19)])
    >>> round(most_grown_order(capture, reference), 1)  # cell 120: orders 316.2-331.9
    323.9
    """
    growth = _growth(profile, reference)
    if growth is None:
        return math.nan
    cell = growth.first_cell + int(np.nanargmax(growth.values))
    return float(10 ** ((cell + 0.5) / CELLS_PER_DECADE))


def _cell(order: float) -> int:
    return math.floor(CELLS_PER_DECADE * math.log10(order))


def component_at(
    order: float,
    gear_ratio: float,
    gear_stages: Mapping[str, float],
    bearings: Mapping[str, float],
) -> str | None:
    """The component of an axis's kinematics with a line within a cell of ``order``.

    Parameters
    ----------
    order : float
        In orders of the position (cycles per ``2 pi``), as :func:`most_grown_order`'s.
    gear_ratio : float
        Motor revolutions per revolution of the position.
    gear_stages : mapping of str to float
        Name -> motor revolutions per revolution of a gear whose teeth are watched: a damaged
        tooth's lines are the harmonics of that gear's turn but the whole motor orders (a mesh
        or a ripple, healthy).
    bearings : mapping of str to float
        Name -> defect order of the motor speed; its lines are
        :func:`~axiswatch.indicators._signals.bearing_orders`.

    Returns
    -------
    str or None
        ``"gear stage <name>"`` or ``"bearing <name>"`` (the nearest, when several have a line
        that close), or None.

    Examples
    --------
    >>> component_at(100 * 5.43, 100.0, {"intermediate": 5.0}, {"motor": 5.43})
    'bearing motor'
    >>> component_at(100 * 1.2, 100.0, {"intermediate": 5.0}, {"motor": 5.43})
    'gear stage intermediate'
    >>> component_at(100.0, 100.0, {"intermediate": 5.0}, {}) is None  # a whole motor order
    True
    """
    if not (math.isfinite(order) and order > 0):
        return None
    lines: list[tuple[str, float]] = []
    for name, stage in gear_stages.items():
        harmonics = range(1, int(8 * stage) + 1)
        lines += [
            (f"gear stage {name}", gear_ratio * k / stage)
            for k in harmonics
            if abs(k / stage - round(k / stage)) > 1e-9
        ]
    for name, defect in bearings.items():
        lines += [(f"bearing {name}", gear_ratio * o) for o in bearing_orders(defect) if o > 0]
    near = [
        (abs(math.log(line / order)), name)
        for name, line in lines
        if abs(_cell(line) - _cell(order)) <= 1
    ]
    return min(near)[1] if near else None
