"""Coulomb and viscous friction read only where the least squares can tell them apart (lab study).

Research study (docs/evaluation.md, "Friction only where it is identified"). The product reads
``coulomb_friction`` and ``viscous_friction`` by least squares of the moving torque on
``sign(v)``, ``v``, the acceleration, 1 and a cubic in the position
(:func:`axiswatch.indicators._readings._friction`); it drops ``v`` only when ``std|v| <= 0.1 mean|v|``. On
a task of constant-speed moves ``|v|`` is nearly one value, ``v`` is nearly ``c sign(v)`` and
the two coefficients trade off from capture to capture (development robots 4, 6 and 7: Robot
A's 12 friction days), yet the speeds' spread left by the ramps keeps that test from firing.

The candidate is the textbook identifiability test of a regression coefficient: the variance
inflation factor of the speed column, ``VIF = 1 / (1 - R^2)`` with ``R^2`` that of ``v``
regressed on the other columns of the same design. ``VIF > 10`` (``R^2 > 0.9``) is the usual
bound for a coefficient that collinearity makes unreliable (Kutner, Nachtsheim, Neter & Li,
*Applied Linear Statistical Models*, 5th ed., 2005, sec. 10.5; Marquardt, *Technometrics* 12,
1970). It replaces the product's speed-spread test (a capture at exactly one speed has an
infinite VIF, so that case is kept).

Where the pair is not identified the capture reads **neither** coefficient (NaN, reason
:data:`NOT_SEPARABLE`). Why not the sum at the capture's speed (``v`` dropped, the ``sign(v)``
coefficient being ``F_c + F_v |v|``, the product's present fallback): that sum is a different
quantity from a capture of another task (another speed) and from a capture whose pair is
identified, so one indicator would carry two meanings across the baseline and the tests; and the
friction at the capture's steady speed is what ``load_forward`` / ``load_backward`` already read
(with the mean gravity). The sum is scored beside it (``friction identified, at speed``) for
the record only; the rule is held on ``friction identified``.

:func:`speed_inflation` and :func:`identified_friction` are the pure functions;
:func:`identified_readings` replaces the friction pair of a product reading. ``python -m
axiswatch_lab.studies.friction_only_where_identified OUT [SEED ...]`` scores ``current`` (the product) and the
variants, :data:`STUDY`, from the same captures (:mod:`axiswatch_lab._variant_study`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from operator import itemgetter
from pathlib import Path

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from axiswatch import Capture
from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab import _variant_study
from axiswatch_lab._product import MOVING_FRACTION, Motion, Readings, friction_design, motion
from axiswatch_lab._variant_study import Variant

__all__ = [
    "NOT_SEPARABLE",
    "STUDY",
    "VARIANTS",
    "VIF_BOUND",
    "identified_friction",
    "identified_readings",
    "speed_inflation",
]

VARIANTS: tuple[str, ...] = ("current", "friction identified", "friction identified, at speed")
#: The textbook bound on a variance inflation factor (R^2 = 0.9 of the column on the others).
VIF_BOUND = 10.0
NOT_SEPARABLE = "Coulomb and viscous friction not separable: the moves run at one speed"
FRICTION: tuple[str, ...] = ("coulomb_friction", "viscous_friction")


def _design(m: Motion, moving: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The product's friction design, every column kept (:func:`friction_design`)."""
    return friction_design(m, moving)[0]


def speed_inflation(design: NDArray[np.float64]) -> float:
    """Variance inflation factor of the speed column (column 1) of the friction design.

    ``1 / (1 - R^2)``, ``R^2`` the share of the speed's variance about its mean explained by
    the least squares on the other columns (the design holds a constant column). Infinite
    when the speed is a combination of the others.

    Examples
    --------
    >>> v = np.array([1.0, 2.0, 3.0, -1.0, -2.0, -3.0])
    >>> x = np.column_stack([np.sign(v), v, np.ones_like(v)])
    >>> round(speed_inflation(x), 3)  # R^2 = 16/18.67 of v on sign(v)
    7.0
    >>> x[:, 1] = 2 * np.sign(v)
    >>> speed_inflation(x)
    inf
    """
    speed = design[:, 1]
    others = np.delete(design, 1, axis=1)
    coefficients, *_ = scipy.linalg.lstsq(others, speed)
    residual = speed - others @ coefficients
    total = float(np.sum((speed - np.mean(speed)) ** 2))
    left = float(residual @ residual)
    if not total > 0 or left <= 1e-12 * total:
        return math.inf
    return total / left


def identified_friction(m: Motion, *, at_speed: bool = False) -> tuple[float, float, str | None]:
    """Coulomb and viscous coefficients where the speed's VIF is at most :data:`VIF_BOUND`.

    The product's least squares (moving samples: ``|v|`` above ``MOVING_FRACTION`` of the
    peak). Not identified: ``(nan, nan, NOT_SEPARABLE)``, or with ``at_speed`` the ``sign(v)``
    coefficient with ``v`` dropped (the friction at the capture's speed) and a NaN viscous one.
    The caller checks motion in both directions, as the product does.

    Examples
    --------
    >>> t = np.arange(0, 8, 0.01)
    >>> q = np.sin(np.pi * t / 2)  # speeds sweep 0..peak: identified
    >>> v = np.gradient(q, 0.01)
    >>> m = Motion(t, q, v, np.gradient(v, 0.01), 3 * np.sign(v) + 2 * v, 100.0)
    >>> [round(c, 2) for c in identified_friction(m)[:2]]
    [3.0, 2.0]
    >>> v = np.where(np.sin(np.pi * t / 2) > 0, 1.0, -1.0)  # one speed: not separable
    >>> m = Motion(t, np.cumsum(v) * 0.01, v, np.zeros_like(v), 3 * v + 2 * v, 100.0)
    >>> identified_friction(m)[2]
    'Coulomb and viscous friction not separable: the moves run at one speed'
    """
    peak = float(np.max(np.abs(m.speed)))
    moving = np.abs(m.speed) > MOVING_FRACTION * peak
    design = _design(m, moving)
    torque = m.torque[moving]
    if speed_inflation(design) <= VIF_BOUND:
        coefficients, *_ = scipy.linalg.lstsq(design, torque)
        return float(coefficients[0]), float(coefficients[1]), None
    if not at_speed:
        return math.nan, math.nan, NOT_SEPARABLE
    coefficients, *_ = scipy.linalg.lstsq(np.delete(design, 1, axis=1), torque)
    return float(coefficients[0]), math.nan, NOT_SEPARABLE


def identified_readings(capture: Capture, read: Readings, *, at_speed: bool = False) -> Readings:
    """``read`` with its friction pair from :func:`identified_friction` (where it has one)."""
    if not math.isfinite(read.values.get("coulomb_friction", math.nan)):
        return read  # no motion in both directions: the product's reason stands
    coulomb, viscous, why = identified_friction(motion(capture), at_speed=at_speed)
    values, reasons = dict(read.values), dict(read.reasons)
    values["coulomb_friction"], values["viscous_friction"] = coulomb, viscous
    for name in FRICTION:
        reasons.pop(name, None)
        if why is not None and not math.isfinite(values[name]):
            reasons[name] = why
    return dataclasses.replace(read, values=values, reasons=reasons)


def _all(read: Callable[[Capture], Readings]) -> Callable[[Capture], tuple[Readings, ...]]:
    def every(capture: Capture) -> tuple[Readings, ...]:
        r = read(capture)
        return (
            r,
            identified_readings(capture, r),
            identified_readings(capture, r, at_speed=True),
        )

    return every


STUDY: tuple[Variant[tuple[Readings, ...]], ...] = tuple(
    Variant(name, itemgetter(k)) for k, name in enumerate(VARIANTS)
)


if (
    __name__ == "__main__"
):  # python -m axiswatch_lab.studies.friction_only_where_identified OUT [SEED ...]
    import sys

    _variant_study.main(
        Path(sys.argv[1]), STUDY, _all, tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS
    )
