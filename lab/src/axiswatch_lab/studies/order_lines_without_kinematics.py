"""Order lines without kinematics: candidates and their study.

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
faults add Robot-A false alarms, ``line_share`` is 0 in health and so not scored by the model.
:func:`baseline_relative_study` compares the product's ``order_lines`` instead (each capture's
lines against its baseline's own order spectrum, :mod:`axiswatch.indicators._order_lines`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd
from scipy.signal import find_peaks
from threadpoolctl import threadpool_limits

from axiswatch import Capture
from axiswatch.datasets import SimulatedRobot
from axiswatch_lab._product import (
    BAND_FRACTION,
    INDICATORS,
    MIN_BAND_RATE_HZ,
    Indicator,
    Motion,
    OrderSpectrum,
    Readings,
    _band,
    indicator_model,
    motion,
    read_indicators,
)
from axiswatch_lab._product import order_spectrum as product_order_spectrum
from axiswatch_lab._transfer import TransferDesign, robot_transfer

__all__ = [
    "CANDIDATES",
    "OrderSpectrum",
    "order_lines_study",
    "order_spectrum",
    "order_statistics",
]

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


def order_spectrum(m: Motion, band: str = "rate") -> OrderSpectrum | str:
    """:func:`axiswatch.indicators._order_lines.order_spectrum` of a capture's motion, or why there is none.

    ``band="rate"``: the torque's band ``[0.04, 0.4] x`` the rate, orders that stay in it at every
    steady speed; ``band="wide"``: the torque unfiltered (the product's).

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(0, 6, 1e-3)
    >>> q = 3 * (1 - np.abs(2 * ((t / 3) % 1) - 1))
    >>> torque = np.sign(np.gradient(q)) + 0.3 * np.sin(300 * q)
    >>> slow = Capture({"position": q[::20], "torque": torque[::20]}, {"position": 50.0,
    ...                                                               "torque": 50.0})
    >>> order_spectrum(motion(slow))
    'needs a torque rate >= 100 Hz (got 50 Hz)'
    """
    if band == "wide":
        return product_order_spectrum(m.position, m.speed, m.torque, m.rate_hz)
    low_hz, high_hz = (f * m.rate_hz for f in BAND_FRACTION)
    torque = _band(m.torque, m.rate_hz) if m.rate_hz >= MIN_BAND_RATE_HZ else m.torque
    return product_order_spectrum(m.position, m.speed, torque, m.rate_hz, (low_hz, high_hz))


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


def baseline_relative_study(seeds: Sequence[int], design: TransferDesign) -> pd.DataFrame:
    """:func:`~axiswatch_lab._transfer.robot_transfer` per seed without and with the product's
    ``order_lines`` (against each baseline's own order spectrum), on the same captures."""
    rows = []
    for seed in seeds:
        with _simulated_once():
            for chosen in (False, True):
                variant = dataclasses.replace(design, order_lines=chosen)
                record = robot_transfer(seed, variant)
                rows.append({"candidate": "order_lines" if chosen else "none", **record})
                print(rows[-1], flush=True)
    return pd.DataFrame(rows)


def main(out: str, *args: str) -> None:
    """``python -m axiswatch_lab.studies.order_lines_without_kinematics OUT [--fast] [--kinematics] [--baseline]
    [--candidates=A,B] SEED ...``: the study (development robots only while choosing), without
    kinematics unless ``--kinematics``; ``--baseline``: the product's ``order_lines`` against
    each baseline's own order spectrum instead of the candidates."""
    with threadpool_limits(1):  # as transfer_study: a multi-threaded BLAS fights for the cores
        _main(out, *args)


def _main(out: str, *args: str) -> None:
    from axiswatch_lab._transfer import FAST_DESIGN

    fast = "--fast" in args
    if "--baseline" in args:
        design = dataclasses.replace(
            FAST_DESIGN if fast else TransferDesign(), kinematics="--kinematics" in args
        )
        table = baseline_relative_study([int(a) for a in args if not a.startswith("--")], design)
        Path(out).mkdir(parents=True, exist_ok=True)
        name = "baseline_relative" + ("_kinematics" if design.kinematics else "")
        table.to_csv(Path(out) / f"{name}.csv", index=False)
        print(summary(table).to_string())
        return
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
