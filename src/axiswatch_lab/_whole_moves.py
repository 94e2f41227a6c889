"""Drive loads read from whole moves only (issue 13, i15a; lab study).

Research study (docs/evaluation.md, "Drive loads from whole moves"). The product's
``load_forward`` / ``load_backward`` (:func:`~axiswatch.read_indicators`) are the mean of
``torque * sign(speed)`` over the steady samples (above half the capture's peak speed) of each
direction. That mean holds the gravity and payload torque averaged over the *positions*
traversed. A capture starts at a random phase of the task cycle, so it often cuts a move: the
steady samples of a cut move cover only part of the move's positions, and the reading moves by
the difference of the gravity torque between the two halves of the stroke. On development
robot 2 (a wrist with a 4.4 kg payload) the healthy ``load_backward`` of one task takes three
values, about 0, 6 and 12 N m, with the phase; the baseline's six readings sat at 6, the
within-task spread came out 0.7, and Robot A alarmed on 20 days, every one topped by
``load_backward`` (on the baseline's own task too).

The candidate reads the loads on **whole moves** only: the samples of runs of one direction
(``|speed|`` above ``MOVING_FRACTION`` of the peak, as the product's motion mask) that start and
end inside the capture, so every reading averages the same stretch of positions. A direction
without a whole steady move gives NaN and a reason. No constant is added.

:func:`whole_move_mask` is the pure function; :func:`whole_move_readings` replaces the two loads
of a product reading. ``python -m axiswatch_lab._whole_moves OUT [SEED ...]`` scores the
product (``current``) and the candidate (``whole moves``), :data:`STUDY`, from the same
captures (:mod:`axiswatch_lab._variant_study`): the transfer design (paired AUROC / ``dr99`` /
``far99`` per fault, Robot A) and the monitor study's scenarios scored by the model directly, as
:mod:`axiswatch_lab._indicator_allowance` does. Development robots only.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from axiswatch._capture import Capture
from axiswatch._readings import MOVING_FRACTION, Readings, motion
from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab import _variant_study
from axiswatch_lab._variant_study import Variant

__all__ = ["STUDY", "VARIANTS", "whole_move_mask", "whole_move_readings"]

LOADS: tuple[tuple[float, str, str], ...] = (
    (1.0, "load_forward", "positive"),
    (-1.0, "load_backward", "negative"),
)


def whole_move_mask(speed: NDArray[np.float64], moving_fraction: float) -> NDArray[np.bool_]:
    """The samples of the moves that start and end inside the capture.

    A move is a run of samples with ``|speed| > moving_fraction x max |speed|`` and one sign of
    the speed; it is whole when neither its first nor its last sample is an end of the capture.

    Examples
    --------
    >>> v = np.array([2.0, 2.0, 0.0, -2.0, -2.0, 0.0, 2.0])
    >>> whole_move_mask(v, 0.1).astype(int).tolist()  # the first and last moves are cut
    [0, 0, 0, 1, 1, 0, 0]
    """
    peak = float(np.max(np.abs(speed))) if speed.size else 0.0
    moving = np.abs(speed) > moving_fraction * peak
    label = np.where(moving, np.sign(speed), 0.0)
    cuts = np.flatnonzero(np.diff(label) != 0) + 1
    out = np.zeros(speed.size, dtype=bool)
    for start, stop in zip(np.r_[0, cuts], np.r_[cuts, speed.size], strict=True):
        if label[start] != 0 and start > 0 and stop < speed.size:
            out[start:stop] = True
    return out


def whole_move_readings(capture: Capture, read: Readings) -> Readings:
    """``read`` with its drive loads taken over the steady samples of whole moves only."""
    m = motion(capture)
    values, reasons = dict(read.values), dict(read.reasons)
    peak = float(np.max(np.abs(m.speed))) if m.speed.size else 0.0
    if not peak > 0:
        return read
    whole = whole_move_mask(m.speed, MOVING_FRACTION)
    steady = whole & (np.abs(m.speed) > 0.5 * peak)
    min_samples = max(5, round(0.2 * m.rate_hz))
    for d, name, word in LOADS:
        mine = steady & (np.sign(m.speed) == d)
        reasons.pop(name, None)
        if mine.sum() >= min(min_samples, 3):
            values[name] = float(np.mean(m.torque[mine] * d))
        else:
            values[name] = math.nan
            reasons[name] = f"needs a whole steady move in the {word} direction"
    return dataclasses.replace(read, values=values, reasons=reasons)


def _both(read: Callable[[Capture], Readings]) -> Callable[[Capture], tuple[Readings, Readings]]:
    def both(capture: Capture) -> tuple[Readings, Readings]:
        r = read(capture)
        return r, whole_move_readings(capture, r)

    return both


STUDY: tuple[Variant[tuple[Readings, Readings]], ...] = (
    Variant("current", lambda taken: taken[0]),
    Variant("whole moves", lambda taken: taken[1]),
)
VARIANTS: tuple[str, ...] = tuple(v.name for v in STUDY)


if __name__ == "__main__":  # python -m axiswatch_lab._whole_moves OUT [SEED ...]
    import sys

    _variant_study.main(
        Path(sys.argv[1]), STUDY, _both, tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS
    )
