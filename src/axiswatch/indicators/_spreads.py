"""Spreads of an axis's own readings: centre, robust spread, leave-one-out distances, task envelope."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from axiswatch.indicators._minimums import MIN_READINGS
from axiswatch.indicators._order_lines import (
    OrderProfile,
    grown_lines,
    order_reference,
)
from axiswatch.indicators._readings import (
    FRICTION,
    INDICATORS,
    Indicator,
    Readings,
    signature_distance,
)

__all__ = [
    "MAD_TO_SD",
    "MIN_READINGS",
    "ORDER_LINES",
    "TASK_ENVELOPE_FACTOR",
    "leave_one_out_distances",
    "reference_errors",
    "robust_spread",
    "task_envelope",
]

#: ``1 / Phi^-1(3/4)``: MAD -> standard deviation for Gaussian data.
MAD_TO_SD = 1.4826


#: The task envelope in units of the largest leave-one-out signature distance of the fitting
#: captures (:func:`task_envelope`); chosen on the development robots (docs/evaluation.md,
#: "Through the monitor").
TASK_ENVELOPE_FACTOR = 2.0


#: The order lines read against the baseline's own order spectrum (``order_lines=True``): in
#: decades already (:func:`~axiswatch.indicators._order_lines.grown_lines`), only growth is abnormal.
ORDER_LINES = Indicator(
    "order_lines",
    "a torque rate >= 100 Hz and steady runs resolving order lines, as the baseline's",
    "up",
    "order lines (new or grown against the baseline)",
)


def _declared(name: str) -> Indicator:
    if name == ORDER_LINES.name:
        return ORDER_LINES
    for indicator in INDICATORS:
        if indicator.name == name:
            return indicator
    if name.startswith("tooth_lines:"):
        return Indicator(name, "kinematics", "up", f"gear stage {name.split(':', 1)[1]}", True)
    if name.startswith("bearing_lines:"):
        return Indicator(name, "kinematics", "up", f"bearing {name.split(':', 1)[1]}", True)
    raise KeyError(name)


def _transformed(readings: Readings) -> dict[str, float]:
    """Readings on the scale they are compared in: decades for ratios, own units otherwise."""
    out = {}
    for name, value in readings.values.items():
        if _declared(name).log:
            out[name] = math.log10(value) if math.isfinite(value) and value > 0 else math.nan
        else:
            out[name] = value
    return out


def robust_spread(values: Sequence[float]) -> float:
    """``1.4826 x`` the median absolute deviation of the finite values; NaN with fewer than 3.

    Examples
    --------
    >>> round(robust_spread([1.0, 2.0, 3.0, 4.0, 100.0]), 4)
    1.4826
    """
    finite = np.asarray([v for v in values if math.isfinite(v)], dtype=np.float64)
    if finite.size < MIN_READINGS:
        return math.nan
    return float(MAD_TO_SD * np.median(np.abs(finite - np.median(finite))))


def _shift(name: str, value: float, centre: float, scale: float) -> float:
    z = (value - centre) / scale
    return abs(z) if _declared(name).sided == "both" else max(z, 0.0)


def _distance(
    values: Mapping[str, float], centre: Mapping[str, float], scales: Mapping[str, float]
) -> tuple[float, dict[str, float]]:
    shifts = {
        name: _shift(name, values[name], centre[name], scales[name])
        for name in scales
        if math.isfinite(values.get(name, math.nan)) and math.isfinite(centre.get(name, math.nan))
    }
    return (max(shifts.values()) if shifts else math.nan), shifts


def _centre_without(
    rows: Sequence[Mapping[str, float]], k: int, names: Sequence[str]
) -> dict[str, float]:
    others = [*rows[:k], *rows[k + 1 :]]
    return {n: float(np.nanmedian([o.get(n, math.nan) for o in others])) for n in names}


def leave_one_out_distances(
    rows: Sequence[Mapping[str, float]], scales: Mapping[str, float]
) -> list[float]:
    """Distance of each row from the median of the other rows, in ``scales``.

    The calibration distances of :class:`IndicatorModel`: a capture used to estimate the centre
    would otherwise be scored against a centre it pulled towards itself.

    Parameters
    ----------
    rows : sequence of mapping of str to float
        Readings on the compared scale (one per capture; NaN where not read).
    scales : mapping of str to float
        Spread of each scored indicator; each needs a finite reading in at least one other row.

    Returns
    -------
    list of float
        One per row, in order: the largest shift over the indicators the row and the others
        give (one-sided for indicators that only grow with a fault); NaN when there is none.

    Examples
    --------
    >>> rows = [{"coulomb_friction": v} for v in (1.0, 1.2, 0.8, 1.1, 3.0)]
    >>> [round(d, 2) for d in leave_one_out_distances(rows, {"coulomb_friction": 0.5})]
    [0.3, 0.3, 0.7, 0.0, 3.9]
    """
    return [
        _distance(row, _centre_without(rows, k, list(scales)), scales)[0]
        for k, row in enumerate(rows)
    ]


def _signature_median(signatures: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    return np.asarray(np.median(np.stack(signatures), axis=0), dtype=np.float64)


def task_envelope(
    signatures: Sequence[Sequence[float]], factor: float = TASK_ENVELOPE_FACTOR
) -> tuple[NDArray[np.float64], float, list[float]] | None:
    """The baseline task's reference signature and envelope, from captures of that task.

    Parameters
    ----------
    signatures : sequence of sequence of float
        :func:`~axiswatch.indicators._readings.task_signature` of the baseline and calibration captures
        (empty or NaN where the motion could not be read).
    factor : float > 0, default=TASK_ENVELOPE_FACTOR
        Envelope in units of the largest leave-one-out distance.

    Returns
    -------
    (ndarray of shape (6,), float, list of float) or None
        The median signature; ``factor`` x the largest leave-one-out distance; and each
        capture's leave-one-out distance: its signature's from the median of the others'
        (:func:`~axiswatch.indicators._readings.signature_distance`; NaN where not read). None with fewer
        than 3 readable signatures.

    Examples
    --------
    >>> same = [[4.0 + 0.1 * k, 2.0, 3.0, -1.0, 1.0, 0.5] for k in range(4)]
    >>> reference, envelope, distances = task_envelope(same, factor=2.0)
    >>> float(reference[0]), [round(d, 4) for d in distances], round(envelope, 4)
    (4.15, [0.0476, 0.0238, 0.0244, 0.0488], 0.0976)
    """
    arrays = [np.asarray(s, dtype=np.float64) for s in signatures]
    readable = [k for k, a in enumerate(arrays) if a.size and bool(np.isfinite(a).all())]
    if len(readable) < MIN_READINGS:
        return None
    distances = [math.nan] * len(arrays)
    for k in readable:
        others = _signature_median([arrays[j] for j in readable if j != k])
        distances[k] = signature_distance(arrays[k], others)
    largest = max(distances[k] for k in readable)
    if not math.isfinite(largest):
        return None
    return _signature_median([arrays[k] for k in readable]), factor * largest, distances


def _fitting_order_lines(read: Sequence[Readings]) -> tuple[OrderProfile | None, list[float]]:
    """The order reference of the captures a model is fitted on, and each one's ``order_lines``
    against the reference of the others (leave-one-out, as the calibration distances are)."""
    profiles = [r.order_profile for r in read]
    values = []
    for k, profile in enumerate(profiles):
        others = order_reference([p for j, p in enumerate(profiles) if j != k and p is not None])
        values.append(
            grown_lines(profile, others) if profile is not None and others is not None else math.nan
        )
    return order_reference([p for p in profiles if p is not None]), values


def reference_errors(read: Sequence[Readings]) -> dict[str, float]:
    """``se_ref`` per friction indicator: the median least-squares standard error of the
    captures a model is fitted on (:attr:`~axiswatch.indicators._readings.Readings.errors`; NaN where none
    has one).

    Examples
    --------
    >>> from axiswatch.indicators._readings import Readings
    >>> read = [Readings({}, errors={"coulomb_friction": e, "viscous_friction": math.nan})
    ...         for e in (0.1, 0.3, 0.2)]
    >>> reference_errors(read)
    {'coulomb_friction': 0.2, 'viscous_friction': nan}
    """
    out = {}
    for name in FRICTION:
        finite = [e for r in read if math.isfinite(e := r.errors.get(name, math.nan))]
        out[name] = float(np.median(finite)) if finite else math.nan
    return out
