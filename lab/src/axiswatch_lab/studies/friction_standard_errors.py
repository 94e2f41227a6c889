"""A friction reading as uncertain as its own least squares says (lab study).

Research study (docs/evaluation.md, "Drive loads from whole moves", second candidate). The
product reads ``coulomb_friction`` and ``viscous_friction`` by least squares of the torque on
``sign(v)``, ``v``, the acceleration and a cubic in the position
(:func:`~axiswatch.read_indicators`). On a task of constant-speed moves most moving samples
share one speed, ``sign(v)`` and ``v`` are nearly collinear, and the two coefficients trade off
from capture to capture: on development robot 4 the healthy viscous readings of its
constant-speed task spread 1.9 (1.4826 x MAD) against 0.17 on the baseline's task, and Robot A
alarms on them. The least squares says so itself: the coefficient's standard error
``sqrt(sigma^2 (X'X)^-1)`` (``sigma^2`` the residual variance) is 2.9 there against 0.10.

Candidate: a capture's friction reading is compared with the spread it can have. The baseline's
within-task spread ``s_w`` belongs to readings of the baseline's precision (``se_ref``, the
median standard error of the fitting captures' readings); a reading whose own standard error
``se`` is larger has a spread larger in proportion, so its shift is taken in
``sqrt((s_w max(1, se / se_ref))^2 + s_t^2)`` instead of ``sqrt(s_w^2 + s_t^2)`` (times its
allowance, as the product). No constant: the factor is the ratio of the capture's own standard
error to the baseline's. The residuals are autocorrelated, so ``se`` is too small in absolute
terms; only its ratio to ``se_ref`` (the same regression on the same axis) is used. The
threshold is the product's (the calibration captures' ratios are about 1 by construction, and
the factor can only lower a distance).

:func:`friction_standard_errors` is the pure function (its arithmetic
:func:`~axiswatch._readings.least_squares_errors`, shared with the product's opt-in
``whole_moves``). ``python -m axiswatch_lab.studies.friction_standard_errors
OUT [SEED ...]`` scores ``current`` (the product), ``whole moves``
(:mod:`axiswatch_lab.studies.drive_loads_from_whole_moves`), ``friction errors`` and ``whole moves, friction errors`` from
the same captures (:data:`STUDY`, :mod:`axiswatch_lab._variant_study`); development robots
only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab import _variant_study
from axiswatch_lab._product import (
    FRICTION,
    MOVING_FRACTION,
    Motion,
    Readings,
    _distance,
    _transformed,
    friction_design,
    least_squares_errors,
    motion,
)
from axiswatch_lab._variant_study import Variant
from axiswatch_lab.studies.drive_loads_from_whole_moves import whole_move_readings

__all__ = ["STUDY", "VARIANTS", "friction_standard_errors"]

VARIANTS: tuple[str, ...] = (
    "current",
    "whole moves",
    "friction errors",
    "whole moves, friction errors",
)

#: One capture: (the product's readings, with whole-move loads, friction standard errors).
Taken = tuple[Readings, Readings, dict[str, float]]


def friction_standard_errors(m: Motion) -> dict[str, float]:
    """Standard errors of the product's Coulomb and viscous coefficients of one capture.

    The same design as :func:`axiswatch.indicators._readings._friction` (moving samples: ``|v|`` above
    ``MOVING_FRACTION`` of the peak; columns ``sign(v)``, ``v``, the acceleration, 1 and a cubic
    in the position; ``v`` dropped when the speeds are one), ``sqrt(diag(sigma^2 (X'X)^-1))``
    with ``sigma^2`` the residual sum of squares over ``n - p``. NaN where the product reads
    no coefficient.

    Examples
    --------
    >>> t = np.arange(0, 6, 0.01)
    >>> q = np.sin(np.pi * t / 2) + 0.3 * np.sin(np.pi * t)
    >>> v = np.gradient(q, 0.01)
    >>> noise = np.random.default_rng(0).normal(scale=0.1, size=t.size)
    >>> m = Motion(t, q, v, np.gradient(v, 0.01), 3 * np.sign(v) + 2 * v + noise, 100.0)
    >>> se = friction_standard_errors(m)
    >>> 0 < se["viscous_friction"] < 0.05 and 0 < se["coulomb_friction"] < 0.05
    True
    """
    out = dict.fromkeys(FRICTION, math.nan)
    peak = float(np.max(np.abs(m.speed))) if m.speed.size else 0.0
    moving = np.abs(m.speed) > MOVING_FRACTION * peak
    direction = np.sign(m.speed)
    min_samples = max(5, round(0.2 * m.rate_hz))
    if not all(int(np.sum(moving & (direction == d))) >= min_samples for d in (1.0, -1.0)):
        return out
    x, separable = friction_design(m, moving)
    if not separable:
        x = np.delete(x, 1, axis=1)
    y = m.torque[moving]
    n, p = x.shape
    if n <= p:
        return out
    coefficients, *_ = np.linalg.lstsq(x, y, rcond=None)
    errors = least_squares_errors(x, y, np.asarray(coefficients, dtype=np.float64))
    out["coulomb_friction"] = float(errors[0])
    if separable:
        out["viscous_friction"] = float(errors[1])
    return out


def _take(read: Callable[[Capture], Readings]) -> Callable[[Capture], Taken]:
    def take(capture: Capture) -> Taken:
        r = read(capture)
        return r, whole_move_readings(capture, r), friction_standard_errors(motion(capture))

    return take


def _readings(taken: Taken, variant: str) -> Readings:
    return taken[1] if variant.startswith("whole moves") else taken[0]


def _reference_errors(fitting: Sequence[Taken]) -> dict[str, float]:
    """``se_ref`` per friction indicator: the median standard error of the fitting captures'."""
    out = {}
    for name in FRICTION:
        finite = [t[2][name] for t in fitting if math.isfinite(t[2][name])]
        out[name] = float(np.median(finite)) if finite else math.nan
    return out


def error_distance(
    model: IndicatorModel, reference: Mapping[str, float], taken: Taken, variant: str
) -> float:
    """The variant's distance in units of the model's threshold (over when above 1)."""
    readings = _readings(taken, variant)
    scales = dict(model.task_change_scales_)
    if variant.endswith("friction errors") and model.fleet is not None:
        allowances = model.allowances_
        for name in FRICTION:
            if name not in scales:
                continue
            ratio = taken[2][name] / reference.get(name, math.nan)
            factor = max(1.0, ratio) if math.isfinite(ratio) else 1.0
            s_t = model.fleet.task_spreads.get(name, math.nan)
            s_w = model.within_[name] * factor
            spread = math.hypot(s_w, s_t) if math.isfinite(s_t) else s_w
            scales[name] = spread * allowances.get(name, 1.0)
    d, _ = _distance(_transformed(readings), model.centre_, scales)
    return d / model.threshold_


def _variant(name: str) -> Variant[Taken]:
    def score(model: IndicatorModel, fitting: Sequence[Taken], taken: Taken) -> tuple[float, bool]:
        distance = error_distance(model, _reference_errors(fitting), taken, name)
        return distance, distance > 1

    return Variant(name, lambda taken: _readings(taken, name), score)


STUDY: tuple[Variant[Taken], ...] = tuple(_variant(name) for name in VARIANTS)


if (
    __name__ == "__main__"
):  # python -m axiswatch_lab.studies.friction_standard_errors OUT [SEED ...]
    import sys

    _variant_study.main(
        Path(sys.argv[1]), STUDY, _take, tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS
    )
