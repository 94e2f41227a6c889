"""Drive loads read from whole moves only (lab study).

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

:func:`~axiswatch.indicators._readings.whole_move_mask` is the pure function (in the product since the
opt-in operating point ``whole_moves``); :func:`whole_move_readings` replaces the two loads
of a product reading with :func:`~axiswatch._readings.drive_loads` over whole moves. ``python -m axiswatch_lab.studies.drive_loads_from_whole_moves OUT [SEED ...]`` scores the
product (``current``) and the candidate (``whole moves``), :data:`STUDY`, from the same
captures (:mod:`axiswatch_lab._variant_study`): the transfer design (paired AUROC / ``dr99`` /
``far99`` per fault, Robot A) and the monitor study's scenarios scored by the model directly, as
:mod:`axiswatch_lab.studies.allowance_per_indicator` does. Development robots only.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from axiswatch import Capture
from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab import _variant_study
from axiswatch_lab._product import MOVING_FRACTION, Readings, drive_loads, motion, whole_move_mask
from axiswatch_lab._variant_study import Variant

__all__ = ["STUDY", "VARIANTS", "whole_move_readings"]


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
    loads, why_not = drive_loads(m, steady, min_samples, whole_moves=True)
    for name in loads:
        reasons.pop(name, None)
    values.update(loads)
    reasons.update(why_not)
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


if (
    __name__ == "__main__"
):  # python -m axiswatch_lab.studies.drive_loads_from_whole_moves OUT [SEED ...]
    import sys

    _variant_study.main(
        Path(sys.argv[1]), STUDY, _both, tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS
    )
