"""Time stamps of a capture file: their unit, their order and the sampling period they give."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from axiswatch._quantiles import median
from axiswatch.exceptions import CaptureError

__all__ = [
    "LATEST_STAMP_S",
    "RATE_TOLERANCE",
    "check_increasing",
    "check_stamp_unit",
    "date_stamps",
    "rate_at_least",
    "sampling_period",
]


#: Stamps read as seconds beyond this (the year 5138) are in a smaller unit than the one read:
#: Unix milliseconds read as seconds start in the year 57,000.
LATEST_STAMP_S = 1e11

#: Relative tolerance of a rate read from time stamps: a capture's rate must match its
#: baseline's within it, and a rate within it of a floor (20 Hz, 100 Hz) reaches the floor.
RATE_TOLERANCE = 1e-3


def rate_at_least(rate_hz: float, floor_hz: float) -> bool:
    """Whether a rate read from time stamps reaches ``floor_hz``, within :data:`RATE_TOLERANCE`.

    A 100 Hz log's stamps give 99.9999999... Hz as often as 100.0000...1 Hz: compared exactly,
    an indicator that needs 100 Hz was read on one export of a capture and not on another.

    Examples
    --------
    >>> rate_at_least(100.0 * (1 - 1e-12), 100.0), rate_at_least(99.0, 100.0)
    (True, False)
    """
    return rate_hz >= floor_hz * (1.0 - RATE_TOLERANCE)


_ISO_DATE = re.compile(r"\s*\d{4}-\d{2}-\d{2}[T ]\d")


def date_stamps(stamps: pd.Series, path: Path) -> NDArray[np.float64] | None:
    """Seconds from the first stamp of date-time stamps: a datetime column (Parquet) or ISO-8601
    text (``2026-01-01T06:00:00.010``, with or without an offset); None for other stamps.

    Examples
    --------
    >>> date_stamps(pd.Series(["2026-01-01T06:00:00", "2026-01-01T06:00:00.25"]), Path("c.csv"))
    array([0.  , 0.25])
    >>> date_stamps(pd.Series([0.0, 0.25]), Path("c.csv")) is None
    True
    """
    if isinstance(stamps.dtype, np.dtype) and stamps.dtype.kind in "biuf":
        return None  # numbers: neither date-times nor text (pandas' checks cost more)
    if pd.api.types.is_datetime64_any_dtype(stamps):
        times = stamps
    else:
        first = stamps.iloc[0] if len(stamps) else None
        if not (isinstance(first, str) and _ISO_DATE.match(first)):
            return None
        try:
            times = pd.to_datetime(stamps, format="ISO8601", utc=True)
        except (ValueError, TypeError) as exc:
            message = str(exc).splitlines()[0]
            raise CaptureError(
                f"{path}: column 'time' starts with the ISO-8601 date-time {first!r} but not "
                f"every stamp is one: {message}"
            ) from exc
    if bool(times.isna().any()):
        raise CaptureError(f"{path}: column 'time' has a blank date-time; expected one per row.")
    nanoseconds = pd.DatetimeIndex(times).as_unit("ns").asi8
    return np.asarray((nanoseconds - nanoseconds[0]) / 1e9, dtype=np.float64)


def check_stamp_unit(first_s: float, unit: str, path: Path) -> None:
    """Refuse stamps that, read in ``unit``, lie after :data:`LATEST_STAMP_S` seconds: Unix
    milliseconds read as seconds would otherwise give a 100 Hz log a rate of 0.1 Hz, silently.

    Examples
    --------
    >>> check_stamp_unit(1.767e12, "s", Path("c.csv"))
    Traceback (most recent call last):
    ...
    axiswatch.exceptions.CaptureError: c.csv: column 'time' starts at 1.767e+12 s ...
    """
    if abs(first_s) <= LATEST_STAMP_S:
        return
    smaller = {"s": "ms", "ms": "us", "us": "ns"}.get(unit, "ns")
    raise CaptureError(
        f"{path}: column 'time' starts at {first_s:.4g} s (after the year 5000) when read in "
        f"{unit}; are the stamps in {smaller}? Declare the unit in the axis profile "
        f'([units] time = "{smaller}").'
    )


def check_increasing(time_s: NDArray[np.float64], path: Path) -> NDArray[np.float64]:
    """Refuse time stamps that repeat or go back, naming the first such row in plain seconds;
    return their steps (``np.diff(time_s)``) for a caller that needs them too.

    Examples
    --------
    >>> check_increasing(np.array([0.0, 0.01, 0.03]), Path("c.csv")).tolist()
    [0.01, 0.02]
    >>> check_increasing(np.array([0.0, 0.01, 0.01]), Path("c.csv"))
    Traceback (most recent call last):
    ...
    axiswatch.exceptions.CaptureError: c.csv: column 'time' must be strictly increasing; row 2 ...
    """
    steps = np.diff(time_s)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0])
        what = "repeats the time stamp" if steps[k] == 0 else "goes back in time:"
        raise CaptureError(
            f"{path}: column 'time' must be strictly increasing; row {k + 1} {what} "
            f"t={time_s[k + 1]:.9g} s after t={time_s[k]:.9g} s."
        )
    return steps


def sampling_period(
    stamps: NDArray[np.float64],
    *,
    steps: NDArray[np.float64] | None = None,
    median_step: float | None = None,
) -> float:
    """Sampling period of uniformly meant time stamps, in their unit.

    Exact stamps (every step within 1e-9 of their median) give their median step; jittered ones
    (a logger's clock) the least-squares slope of the stamps on the sample index. The median of
    jittered steps, or the mean step (set by the jitter of the two end stamps alone), moves from
    capture to capture by a share of the jitter, and every capture's rate is checked against its
    baseline's to 0.1 %; the slope's error falls as ``n ** -1.5``.

    Parameters
    ----------
    stamps : ndarray of shape (n_samples,)
        Increasing time stamps, at least 2.
    steps : ndarray of shape (n_samples - 1,), optional
        The stamps' steps, when the caller has them (``np.diff(stamps)``).
    median_step : float, optional
        Their median, when the caller has it.

    Returns
    -------
    float

    Examples
    --------
    >>> sampling_period(np.array([0.0, 0.5, 1.0, 1.5]))
    0.5
    >>> round(sampling_period(np.array([0.0, 0.11, 0.19, 0.31, 0.4])), 12)  # jittered 0.1 s
    0.1
    """
    steps = np.diff(stamps) if steps is None else steps
    middle = median(steps) if median_step is None else median_step
    if np.abs(steps - middle).max() <= 1e-9 * middle:
        return middle
    index = np.arange(stamps.size, dtype=np.float64)
    centred = index - index.mean()
    return float(np.dot(centred, stamps - stamps.mean()) / np.dot(centred, centred))
