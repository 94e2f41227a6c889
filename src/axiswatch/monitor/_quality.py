"""Data quality of a capture: a verdict of its own, judged before any mechanical one.

Bad data is never an alarm nor a healthy score. Rules, first match wins: ``out of range``,
``flat/stuck signal``, ``no motion``. Each is in docs/internals.md, "Data quality".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from axiswatch._capture import Capture

__all__ = [
    "MIN_MOTION_SHARE",
    "OUT_OF_RANGE",
    "STUCK_SHARE",
    "QualityReference",
    "data_quality_problem",
    "longest_run",
]

OUT_OF_RANGE = 1e6
STUCK_SHARE = 0.5
MIN_MOTION_SHARE = 0.05


@dataclass(frozen=True)
class QualityReference:
    """What the baseline capture showed: the peak-to-peak span of each signal."""

    spans: dict[str, float]

    @classmethod
    def of(cls, capture: Capture) -> QualityReference:
        """The reference of a (baseline) capture."""
        return cls({name: float(np.ptp(v)) for name, v in capture.signals.items()})


def longest_run(values: NDArray[np.float64]) -> tuple[int, int]:
    """Length and start of the longest run of one repeated value (the first such run).

    Examples
    --------
    >>> longest_run(np.array([1.0, 2.0, 2.0, 2.0, 3.0, 3.0]))
    (3, 1)
    """
    changes = np.flatnonzero(values[1:] != values[:-1]) + 1
    starts = np.concatenate([[0], changes])
    lengths = np.diff(np.concatenate([starts, [values.size]]))
    best = int(np.argmax(lengths))
    return int(lengths[best]), int(starts[best])


def _standstill(capture: Capture, name: str, start: int, run: int) -> bool:
    """Whether a run of one value in ``name`` is the axis standing still (see the rules)."""
    motion = {"position", "speed"}
    if name not in motion:
        return False
    values = capture.signals[name]
    others = [other for other in motion - {name} if other in capture.signals]
    if not others:
        return name == "speed" and values[start] == 0.0
    other = others[0]
    rate, other_rate = capture.rates_hz[name], capture.rates_hz[other]
    first = round(start / rate * other_rate)
    last = round((start + run - 1) / rate * other_rate)
    span = capture.signals[other][first : last + 1]
    if span.size == 0:
        return False
    speed_span = span if other == "speed" else values[start : start + run]
    position_span = span if other == "position" else values[start : start + run]
    return bool(np.all(speed_span == 0.0) and np.ptp(position_span) == 0.0)


def data_quality_problem(capture: Capture, reference: QualityReference | None = None) -> str | None:
    """The data-quality verdict of a capture and its reason, or None when the data are usable.

    Parameters
    ----------
    capture : Capture
    reference : QualityReference, optional
        The baseline's; without it (a baseline candidate) ``no motion`` is not judged.

    Returns
    -------
    str or None
        ``"<verdict>: <reason>"`` with the verdict ``out of range``, ``flat/stuck signal`` or
        ``no motion``.

    Examples
    --------
    >>> import axiswatch as aw
    >>> t = np.arange(2000) / 2000.0
    >>> moving = aw.as_capture({"position": np.sin(6 * t), "torque": np.cos(6 * t)}, 2000.0)
    >>> data_quality_problem(moving) is None
    True
    >>> idle = aw.as_capture({"position": 0.001 * np.sin(6 * t), "torque": np.cos(6 * t)}, 2000.0)
    >>> data_quality_problem(idle, QualityReference.of(moving))[:9]
    'no motion'
    """
    for name, values in capture.signals.items():
        peak = int(np.argmax(np.abs(values)))
        if abs(values[peak]) > OUT_OF_RANGE:
            return (
                f"out of range: signal '{name}' reads {values[peak]:.4g} at sample {peak} (no "
                f"axis signal exceeds {OUT_OF_RANGE:g} in magnitude; a logger glitch?)"
            )
    for name, values in capture.signals.items():
        run, start = longest_run(values)
        if run == values.size:
            return f"flat/stuck signal: '{name}' is {values[0]:.6g} throughout ({run} samples)"
    if reference is not None and "position" in capture.signals:
        span = float(np.ptp(capture.signals["position"]))
        expected = reference.spans.get("position", 0.0)
        if expected > 0 and span < MIN_MOTION_SHARE * expected:
            return (
                f"no motion: position spans {span:.4g}, {100 * span / expected:.2g} % of the "
                f"baseline's {expected:.4g} (the robot was idle during the capture?)"
            )
    for name, values in capture.signals.items():
        run, start = longest_run(values)
        if run >= STUCK_SHARE * values.size and not _standstill(capture, name, start, run):
            return (
                f"flat/stuck signal: '{name}' repeats {values[start]:.6g} for {run} of "
                f"{values.size} samples from sample {start} (a frozen sensor?)"
            )
    return None
