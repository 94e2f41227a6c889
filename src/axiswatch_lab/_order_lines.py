"""Order lines without kinematics (issue 13, item 3; i13e): candidates and their study.

Research code. Without an :class:`~axiswatch.AxisProfile`'s kinematics no line indicator is read
(the ``tooth_lines:*`` / ``bearing_lines:*`` need the gear ratio and the components' orders).
The candidates here need none: they read the torque's order spectrum against the *measured
position* (orders per unit of position angle, ``2 pi`` rad: per revolution of the position on a
rotary axis), where any angle-locked line (a gear mesh, a damaged tooth once per gear turn, a
bearing defect) stays at its order whatever the speed.

:func:`order_spectrum`: the torque band ``[0.04, 0.4] x`` the rate (the impulsive indicators'
band) over each run of steady motion (``|speed|`` above half its peak, one direction), resampled
onto a uniform grid of the position angle fine enough that the band's top frequency at the
slowest steady speed is below the grid's Nyquist order (no aliasing), Hann-windowed, its
periodogram zero-padded to the longest run's grid and averaged over the runs (weighted by
length). The order band is where an order stays inside the frequency band at every steady speed
(the 10th to 90th percentile of the steady speeds); its floor is a running median over
:data:`FLOOR_CELLS` resolution cells of the median run, so a line is what stands above its
neighbours, not above the band's colour. Needs a rate >= 100 Hz and steady runs that resolve
:data:`MIN_CELLS` cells in the order band.

The model (:class:`~axiswatch.IndicatorModel`) takes one scalar per capture, centred and scaled by
the baseline, the calibration captures and the fleet; the scalar summarises how much of the band
is lines, whatever orders they are at (kinematics-free):

* ``line_share``: the share of the band's power in bins at least :data:`LINE_PROMINENCE` times
  their floor (10 dB: a chance of 1e-3 per bin for a plain periodogram of noise);
* ``peakiness``: arithmetic over geometric mean of the prominence ``P / floor`` in the band
  (inverse spectral flatness; 1 for a flat spectrum, larger with lines), compared in decades;
* ``top_prominence``: the 99th percentile of the prominence in the band, in decades;
* ``third_line``: the prominence of the third strongest line (:data:`THIRD`), in decades;
* ``lines_3_to_10``: the geometric mean prominence of the third to the tenth strongest lines
  (less noisy than one line), in decades.

Compared on the development robots with the transfer design *without kinematics*
(:func:`order_lines_study`): each candidate added to the readings against the readings alone.
None passed (docs/evaluation.md, "Order lines without kinematics"): the summaries that find the
faults add Robot-A false alarms, ``line_share`` is 0 in health and so not scored by the model;
the product reads no line without kinematics.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.fft import next_fast_len, rfft
from scipy.ndimage import median_filter
from scipy.signal import detrend, find_peaks, get_window

import axiswatch._indicator_model as indicator_model
from axiswatch._capture import Capture
from axiswatch._readings import (
    BAND_FRACTION,
    INDICATORS,
    MIN_BAND_RATE_HZ,
    Indicator,
    Motion,
    Readings,
    _band,
    motion,
    read_indicators,
)
from axiswatch.datasets._family import SimulatedRobot
from axiswatch_lab._transfer import TransferDesign, robot_transfer

__all__ = [
    "CANDIDATES",
    "OrderSpectrum",
    "order_lines_study",
    "order_spectrum",
    "order_statistics",
]

#: Share of the peak speed above which motion counts as steady (as the drive loads').
STEADY_FRACTION = 0.5
#: Least resolution cells of the median run in the order band.
MIN_CELLS = 32
#: Width of the running-median floor, in resolution cells of the median run.
FLOOR_CELLS = 8
#: Lowest order of the wide band, in resolution cells of the median run (a Hann window's
#: leakage from a run's mean is below -62 dB there, from the curvature left after its straight
#: line is removed below -55 dB).
LOW_CELLS = 8
#: A bin is a line when its power is this many times its floor (10 dB).
LINE_PROMINENCE = 10.0

#: ``third_line`` reads the prominence of the third strongest line (peaks a resolution cell
#: apart): a healthy axis's few angle-locked lines (a mesh, a ripple) do not set it, a fault's
#: comb of lines (a tooth once per gear turn, a bearing's defect order and sidebands) does.
THIRD = 3

#: What :func:`order_statistics` reads of a spectrum.
STATISTICS: tuple[str, ...] = (
    "line_share",
    "peakiness",
    "top_prominence",
    "third_line",
    "lines_3_to_10",
)
#: Statistic ``@`` band, as :func:`reader` takes them.
CANDIDATES: tuple[str, ...] = tuple(
    f"{statistic}@{band}" for band in ("rate", "wide") for statistic in STATISTICS
)


@dataclasses.dataclass(frozen=True)
class OrderSpectrum:
    """The averaged order spectrum of a capture's steady runs, in the order band."""

    orders: NDArray[np.float64]
    power: NDArray[np.float64]
    floor: NDArray[np.float64]
    cells: float
    bins_per_cell: float


def _steady_runs(m: Motion) -> list[slice]:
    speed = np.abs(m.speed)
    peak = float(np.max(speed)) if speed.size else 0.0
    key = np.where(speed > STEADY_FRACTION * peak, np.sign(m.speed), 0.0) if peak > 0 else speed
    edges = np.flatnonzero(np.diff(key) != 0) + 1
    bounds = np.concatenate([[0], edges, [key.size]])
    return [
        slice(int(a), int(b)) for a, b in itertools.pairwise(bounds) if key[a] != 0 and b - a > 8
    ]


def order_spectrum(m: Motion, band: str = "rate") -> OrderSpectrum | str:
    """The order spectrum of the steady runs (see the module docstring), or why there is none.

    ``band="rate"``: the torque's band ``[0.04, 0.4] x`` the rate, orders that stay in it at every
    steady speed; ``band="wide"``: the torque unfiltered, each run's straight line (in the angle)
    removed, orders from :data:`LOW_CELLS` resolution cells of the median run up to ``0.4 x``
    the rate at the fast steady speed.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(0, 6, 1e-3)  # strokes of 3 rad at 2 rad/s, a line at order 300
    >>> q = 3 * (1 - np.abs(2 * ((t / 3) % 1) - 1))
    >>> noise = np.random.default_rng(0).normal(0, 0.05, t.size)
    >>> torque = np.sign(np.gradient(q)) + 0.3 * np.sin(300 * q) + noise
    >>> capture = Capture({"position": q, "torque": torque}, {"position": 1e3, "torque": 1e3})
    >>> spectrum = order_spectrum(motion(capture), "wide")
    >>> top = float(spectrum.orders[np.argmax(spectrum.power / spectrum.floor)])
    >>> abs(top - 300) < 2  # within a resolution cell: a run of 3 rad resolves 2 pi / 3 orders
    True
    >>> slow = Capture({"position": q[::20], "torque": torque[::20]}, {"position": 50.0,
    ...                                                               "torque": 50.0})
    >>> order_spectrum(motion(slow))
    'needs a torque rate >= 100 Hz (got 50 Hz)'
    """
    if m.rate_hz < MIN_BAND_RATE_HZ:
        return f"needs a torque rate >= {MIN_BAND_RATE_HZ:g} Hz (got {m.rate_hz:g} Hz)"
    runs = _steady_runs(m)
    if not runs:
        return "needs steady motion"
    low_hz, high_hz = (f * m.rate_hz for f in BAND_FRACTION)
    torque = _band(m) if band == "rate" else m.torque
    revs_per_s = np.concatenate([np.abs(m.speed[r]) for r in runs]) / (2 * math.pi)
    slow, fast = (float(np.quantile(revs_per_s, q)) for q in (0.1, 0.9))
    slowest = float(np.min(revs_per_s))
    # Samples per unit of angle so that the highest frequency left in the torque (the band's top,
    # or the rate's Nyquist frequency) at the slowest steady speed is below the grid's Nyquist
    # order: nothing aliases into the order band.
    per_rev = 2.0 * (high_hz if band == "rate" else 0.5 * m.rate_hz) / slowest
    step = 2 * math.pi / per_rev
    grids = []
    for run in runs:
        theta = m.position[run] * np.sign(m.speed[run][0])
        order = np.argsort(theta, kind="stable")
        theta, x = theta[order], torque[run][order]
        n = int((theta[-1] - theta[0]) / step)
        if n >= 16:
            grid = np.interp(theta[0] + step * np.arange(n), theta, x)
            if band != "rate":
                grid = detrend(grid, type="linear")
            grids.append(grid)
    if not grids:
        return "needs steady motion"
    lengths = np.asarray([g.size for g in grids])
    cell = per_rev / float(np.median(lengths))  # orders per resolution cell of the median run
    low_order = low_hz / slow if band == "rate" else LOW_CELLS * cell
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


def order_statistics(spectrum: OrderSpectrum) -> dict[str, float]:
    """The candidates' values of one spectrum (``NaN`` where the floor is 0)."""
    good = spectrum.floor > 0
    if not good.any():
        return dict.fromkeys(STATISTICS, math.nan)
    power, floor = spectrum.power[good], spectrum.floor[good]
    prominence = power / floor
    lines = prominence >= LINE_PROMINENCE
    positive = prominence > 0
    log_mean = float(np.mean(np.log(prominence[positive]))) if positive.any() else math.nan
    peaks, _ = find_peaks(prominence, distance=max(1.0, spectrum.bins_per_cell))
    heights = np.sort(prominence[peaks])[::-1]
    return {
        "third_line": float(heights[THIRD - 1]) if heights.size >= THIRD else 1.0,
        "lines_3_to_10": (
            math.exp(float(np.mean(np.log(heights[THIRD - 1 : 10]))))
            if heights.size >= THIRD
            else 1.0
        ),
        "line_share": float(np.sum(power[lines]) / np.sum(power)),
        "peakiness": float(np.mean(prominence)) / math.exp(log_mean),
        "top_prominence": float(np.quantile(prominence, 0.99)),
    }


def _indicator(candidate: str) -> Indicator:
    statistic = candidate.split("@")[0]
    return Indicator(
        candidate,
        "steady runs resolving order lines",
        "up",
        "order lines",
        statistic != "line_share",
    )


def reader(
    candidate: str | None, cache: dict[int, dict[str, object]] | None = None
) -> Callable[[Capture], Readings]:
    """The product's readings (no kinematics), with ``candidate`` added when given; ``cache``
    (keyed by the capture's ``id``, so the captures must outlive it) shares the work between
    candidates."""
    memo: dict[int, dict[str, object]] = {} if cache is None else cache

    def read(capture: Capture) -> Readings:
        mine = memo.setdefault(id(capture), {})
        if "readings" not in mine:
            mine["readings"] = read_indicators(capture)
        readings = mine["readings"]
        assert isinstance(readings, Readings)
        if candidate is None:
            return readings
        statistic, band = candidate.split("@")
        if band not in mine:
            spectrum = order_spectrum(motion(capture), band)
            mine[band] = spectrum if isinstance(spectrum, str) else order_statistics(spectrum)
        found = mine[band]
        values, reasons = dict(readings.values), dict(readings.reasons)
        if isinstance(found, str):
            values[candidate], reasons[candidate] = math.nan, found
        else:
            assert isinstance(found, dict)
            values[candidate] = found[statistic]
        return dataclasses.replace(readings, values=values, reasons=reasons)

    return read


@contextlib.contextmanager
def _declared(candidate: str | None) -> Iterator[None]:
    """The model's table of indicators with the candidate in it, for the study's process."""
    table = INDICATORS if candidate is None else (*INDICATORS, _indicator(candidate))
    with mock.patch.object(indicator_model, "INDICATORS", table):
        yield


@contextlib.contextmanager
def _simulated_once() -> Iterator[None]:
    """Every candidate sees the same captures, simulated once (the robot's captures are a pure
    function of their arguments)."""
    original = SimulatedRobot.capture
    captures: dict[tuple[object, ...], Capture] = {}

    def capture(self: SimulatedRobot, task: int | str, **kwargs: object) -> Capture:
        key = (self.seed, task, *sorted((k, repr(v)) for k, v in kwargs.items()))
        if key not in captures:
            captures[key] = original(self, task, **kwargs)  # type: ignore[arg-type]
        return captures[key]

    SimulatedRobot.capture = capture  # type: ignore[method-assign]
    try:
        yield
    finally:
        SimulatedRobot.capture = original  # type: ignore[method-assign]


def order_lines_study(
    seeds: Sequence[int], design: TransferDesign, candidates: Sequence[str | None]
) -> pd.DataFrame:
    """:func:`~axiswatch_lab._transfer.robot_transfer` per seed and candidate (None: the
    readings alone) on the same captures, one row each, in this process."""
    rows = []
    for seed in seeds:
        with _simulated_once():
            cache: dict[int, dict[str, object]] = {}
            for candidate in candidates:
                with _declared(candidate):
                    record = robot_transfer(seed, design, read=reader(candidate, cache))
                rows.append({"candidate": candidate or "none", **record})
                print(rows[-1], flush=True)
    return pd.DataFrame(rows)


def main(out: str, *args: str) -> None:
    """``python -m axiswatch_lab._order_lines OUT [--fast] [--candidates=A,B] SEED ...``: the
    study without kinematics (development robots only while choosing)."""
    from axiswatch_lab._transfer import FAST_DESIGN

    fast = "--fast" in args
    chosen: Sequence[str] = CANDIDATES
    for arg in args:
        if arg.startswith("--candidates="):
            chosen = arg.split("=", 1)[1].split(",")
    seeds = [int(a) for a in args if not a.startswith("--")]
    design = dataclasses.replace(FAST_DESIGN if fast else TransferDesign(), kinematics=False)
    table = order_lines_study(seeds, design, [None, *chosen])
    Path(out).mkdir(parents=True, exist_ok=True)
    table.to_csv(Path(out) / "order_lines.csv", index=False)
    print(summary(table).to_string())


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per candidate: Robot A's false alarms (sum, robots with none), ``far99`` and the mean
    AUROC, oracle and ``dr99`` per fault over the robots."""
    grouped = table.groupby("candidate", sort=False)
    out = grouped.mean(numeric_only=True)
    out["robot_a_false_alarms"] = grouped["robot_a_false_alarms"].sum()
    out["robots_without_false_alarm"] = grouped["robot_a_false_alarms"].apply(
        lambda v: int((v == 0).sum())
    )
    keep = ["robot_a_false_alarms", "robots_without_false_alarm", "far99", "share_scored"]
    for kind in ("backlash", "friction", "tooth", "bearing"):
        keep += [f"auroc_{kind}", f"dr99_{kind}"]
    return out[keep].T


if __name__ == "__main__":
    import sys

    main(*sys.argv[1:])
