"""The fleet prior: task-change spreads and allowances pooled over the axes of one profile."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from axiswatch._calibration import half_laplace_threshold
from axiswatch.exceptions import CalibrationError
from axiswatch.indicators._minimums import MIN_AXES
from axiswatch.indicators._order_lines import (
    grown_lines,
)
from axiswatch.indicators._spreads import (
    MAD_TO_SD,
    ORDER_LINES,
    _declared,
    _distance,
    robust_spread,
)

if TYPE_CHECKING:
    from axiswatch.indicators._model import IndicatorModel

__all__ = [
    "FleetPrior",
    "LEAVE_SELF_OUT_MAX_AXES",
    "MIN_AXES",
    "MIN_PAIRS",
    "fleet_difference",
    "fleet_pair_shifts",
    "indicator_allowances",
    "own_pair_allowances",
    "pool_fleet",
    "pool_fleet_without",
]

#: Least ordered pairs of fleet axes reading an indicator for its own allowance (3 axes give 6,
#: 2 axes 2).
MIN_PAIRS = 3


#: Largest fleet whose new baselines are checked against the fleet without them
#: (:func:`pool_fleet_without`). Measured on the development robots (docs/evaluation.md, "The
#: fleet check above 20 axes"): at 24 axes leave-self-out still flags worn axes that the check
#: with itself included misses (21 of 24 against 19), at 48 both flag 20 of 24. The leave-self-out
#: pools cost ``O(n^3)`` in a first run with every axis new: about 3 s at 200 axes (one BLAS
#: thread); a later new axis costs one pool. Above 200 axes the pairs with one axis are 1 % of
#: all pairs and the check is made with the axis included.
LEAVE_SELF_OUT_MAX_AXES = 200


@dataclass(frozen=True)
class FleetPrior:
    """What a healthy task change does to each indicator, pooled over axes of one profile.

    Attributes
    ----------
    task_spreads : dict of str to float
        ``s_t`` per indicator (NaN where fewer than 3 axes give it).
    allowance_scale : float
        Half-Laplace scale of the distance (largest shift) between two healthy axes
        (``median / ln 2``): the one allowance, for indicators without their own.
    centre : dict of str to float
        The fleet's median reading per indicator.
    n_axes, n_pairs : int
        The axes pooled, and the ordered pairs (each pair both ways: :func:`fleet_pair_shifts`)
        that read an indicator, which ``allowance_scale`` rests on.
    indicator_scales : dict of str to float
        Per indicator with a task spread: the half-Laplace scale of its ``|z_i|`` between two
        healthy axes (``median / ln 2`` over the ordered pairs that read it); NaN when fewer
        than ``MIN_PAIRS`` ordered pairs read it or their median is 0.
    indicator_pairs : dict of str to int
        How many ordered pairs each of those rests on.
    centres : tuple of dict of str to float
        Each pooled axis's centre (what an axis's own pairs are read from:
        :func:`own_pair_allowances`); a model keeps its prior without them once it has its own
        allowances (:meth:`IndicatorModel.use_fleet`).
    """

    task_spreads: dict[str, float]
    allowance_scale: float
    centre: dict[str, float]
    n_axes: int
    n_pairs: int
    indicator_scales: dict[str, float]
    indicator_pairs: dict[str, int]
    centres: tuple[dict[str, float], ...] = ()

    def allowance(self, percentile: float) -> float:
        """The one task-change allowance at ``percentile`` (of the pairs' largest shift)."""
        return half_laplace_threshold(self.allowance_scale, percentile)

    def allowances(self, percentile: float) -> dict[str, float]:
        """Each indicator's task-change allowance, family-wise at ``percentile``
        (:func:`indicator_allowances`)."""
        return indicator_allowances(self.indicator_scales, percentile, self.allowance(percentile))


def indicator_allowances(
    scales: Mapping[str, float], percentile: float, fallback: float
) -> dict[str, float]:
    """Per-indicator allowances whose family-wise rate is ``100 - percentile`` %.

    Parameters
    ----------
    scales : mapping of str to float
        Half-Laplace scale of each indicator's shift between two healthy axes; NaN (or not
        positive) where it could not be estimated.
    percentile : float in (0, 100)
    fallback : float
        The allowance of an indicator without a scale (the fleet's one allowance).

    Returns
    -------
    dict of str to float
        Per indicator of ``scales``: the ``100 - (100 - percentile) / m`` percentile of its
        half-Laplace, ``m`` the number of indicators with a scale (Bonferroni: the chance that a
        healthy task change exceeds any of the ``m`` is at most ``100 - percentile`` %), or
        ``fallback``.

    Examples
    --------
    >>> allowed = indicator_allowances({"a": 1.0, "b": 2.0, "c": math.nan}, 99.0, 7.0)
    >>> {k: round(v, 3) for k, v in allowed.items()}  # ln(200) and 2 ln(200): 99.5th pct
    {'a': 5.298, 'b': 10.597, 'c': 7.0}
    """
    fitted = {n: s for n, s in scales.items() if math.isfinite(s) and s > 0}
    level = 100.0 - (100.0 - percentile) / max(len(fitted), 1)
    return {
        n: half_laplace_threshold(fitted[n], level) if n in fitted else fallback for n in scales
    }


def fleet_pair_shifts(
    centres: NDArray[np.float64],
    within: NDArray[np.float64],
    task_spreads: NDArray[np.float64],
    one_sided: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The shifts between every ordered pair of a fleet's axes: what a healthy task change does.

    For axes ``i != j`` and indicator ``k``, ``z_ijk = (c_ik - c_jk) / s_jk`` with
    ``s_jk = sqrt(s_t,k^2 + s_w,jk^2)``: axis ``i``'s centre read as a capture against baseline
    ``j``, in the baseline's spreads, as the monitor reads a capture. Every pair is taken both
    ways, so nothing depends on the order the axes are listed in: a permutation of the axes
    permutes the rows and columns of ``distances`` and leaves ``medians`` and ``counts`` as they
    are (one pair read one way, ``i < j`` in ``i``'s spreads, made the prior depend on it).

    Parameters
    ----------
    centres, within : ndarray of shape (n_axes, n_indicators)
        Each axis's centre and within-task spread (NaN where not read).
    task_spreads : ndarray of shape (n_indicators,)
        ``s_t`` per indicator (an indicator whose ``s_t`` is not a positive number is left out).
    one_sided : ndarray of bool, shape (n_indicators,)
        Indicators of which only a growth counts in the pair's distance.

    Returns
    -------
    distances : ndarray of shape (n_axes, n_axes)
        ``[i, j]``: the largest shift of the ordered pair (capture ``i``, baseline ``j``) over
        the indicators it reads (``max(z, 0)`` for one-sided ones, ``|z|`` otherwise); NaN on
        the diagonal and where the pair shares none.
    medians : ndarray of shape (n_indicators,)
        Per indicator, the median of ``|z_ijk|`` over the ordered pairs that read it (a pair is
        a task change either way); NaN where none does or the indicator is left out.
    counts : ndarray of int, shape (n_indicators,)
        How many ordered pairs read each indicator.

    Notes
    -----
    One indicator at a time: memory is ``distances`` and a few ``(n_axes, n_axes)``
    temporaries, a peak of 40 MB at 1,000 axes whatever the number of indicators
    (``tracemalloc``, 8 indicators; the unordered pairs read one way, with every indicator's
    ``|z|`` kept, peaked at 128 MB).

    Examples
    --------
    >>> import numpy as np
    >>> d, middle, n = fleet_pair_shifts(np.array([[0.0], [3.0], [8.0]]),
    ...                                  np.array([[4.0], [4.0], [0.0]]),
    ...                                  np.array([3.0]), np.array([False]))
    >>> d.round(3).tolist()  # [i, j]: c_i - c_j in spreads of baseline j: 5, 5 and 3
    [[nan, 0.6, 2.667], [0.6, nan, 1.667], [1.6, 1.0, nan]]
    >>> float(middle[0].round(3)), int(n[0])  # median |z| of the 6 ordered pairs
    (1.3, 6)
    """
    n_axes, n_indicators = centres.shape
    distances = np.full((n_axes, n_axes), np.nan)
    medians = np.full(n_indicators, np.nan)
    counts = np.zeros(n_indicators, dtype=np.int64)
    usable = np.isfinite(task_spreads) & (task_spreads > 0)
    for k in np.flatnonzero(usable):
        # Row i the capture, column j the baseline and its spreads.
        z = (centres[:, k, None] - centres[None, :, k]) / np.hypot(task_spreads[k], within[:, k])
        np.fill_diagonal(z, np.nan)  # an axis against itself is no task change
        # fmax ignores NaN: the largest shift over the indicators read, NaN only where none is.
        np.fmax(distances, np.maximum(z, 0.0) if one_sided[k] else np.abs(z), out=distances)
        read = np.abs(z[np.isfinite(z)])
        counts[k] = read.size
        if read.size:
            medians[k] = np.median(read)
    return distances, medians, counts


def _order_line_pairs(
    models: Sequence[IndicatorModel],
    cross: Sequence[tuple[tuple[int, int], float]],
    task_spread: float,
    distances: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ordered pairs' distances (:func:`fleet_pair_shifts`) with their ``order_lines``
    shift, and that indicator's ``|z|`` over the ordered pairs.

    The order lines are read against each axis's own reference: the ordered pair (capture
    ``i``, baseline ``j``) is baseline ``j``'s reading of axis ``i``'s captures against ``j``'s
    own centre, in ``j``'s spreads, as :func:`fleet_pair_shifts` reads the other indicators.
    """
    out = distances.copy()
    shifts: list[float] = []
    name = ORDER_LINES.name
    for (j, i), seen in cross:  # model j's order_lines of model i's captures
        baseline = models[j]
        scale = math.hypot(task_spread, baseline.within_.get(name, math.nan))
        z = (seen - baseline.centre_.get(name, math.nan)) / scale
        if math.isfinite(z):
            out[i, j] = max(z, 0.0) if not math.isfinite(out[i, j]) else max(out[i, j], z, 0.0)
            shifts.append(abs(z))
    return out, np.asarray(shifts, dtype=np.float64)


def _order_cross_readings(
    models: Sequence[IndicatorModel],
) -> list[tuple[tuple[int, int], float]]:
    """``((i, j), x)``: model ``i``'s ``order_lines`` of model ``j``'s fitting captures (the
    median over them), for every ordered pair of models that read order lines."""
    out = []
    for (i, a), (j, b) in itertools.permutations(enumerate(models), 2):
        reference = getattr(a, "order_reference_", None)
        if reference is None:
            continue
        seen = [
            grown_lines(r.order_profile, reference)
            for r in b.fit_readings_
            if r.order_profile is not None
        ]
        finite = [x for x in seen if math.isfinite(x)]
        if finite:
            out.append(((i, j), float(np.median(finite))))
    return out


def pool_fleet(models: Sequence[IndicatorModel]) -> FleetPrior:
    """Pool fitted models of one profile's axes into a :class:`FleetPrior`.

    The prior every axis's captures are scored with (all the axes pooled). An axis's own fleet
    check is made against the others' (:func:`pool_fleet_without`).

    Raises
    ------
    CalibrationError
        With fewer than 3 fitted models.
    """
    if len(models) < MIN_AXES:
        raise CalibrationError(
            f"A fleet prior needs at least {MIN_AXES} axes of one profile; got {len(models)}."
        )
    names = sorted({name for model in models for name in model.centre_})
    centres = {name: [m.centre_.get(name, math.nan) for m in models] for name in names}
    task_spreads = {name: math.sqrt(2.0) * robust_spread(v) for name, v in centres.items()}
    fleet_centre = {
        name: float(np.nanmedian(v)) if np.isfinite(v).any() else math.nan
        for name, v in centres.items()
    }
    # The order lines are read against each axis's own reference, so their centres say nothing
    # of a task change; what one does is axis a's reading of axis b's captures.
    cross = _order_cross_readings(models)
    if ORDER_LINES.name in centres:
        shifts = [x - models[i].centre_.get(ORDER_LINES.name, math.nan) for (i, _), x in cross]
        finite = [abs(d) for d in shifts if math.isfinite(d)]
        task_spreads[ORDER_LINES.name] = (
            MAD_TO_SD * float(np.median(finite)) if len(finite) >= MIN_PAIRS else math.nan
        )
    spread = [n for n in names if math.isfinite(task_spreads[n]) and task_spreads[n] > 0]
    columns = [n for n in spread if n != ORDER_LINES.name]
    shape = (len(columns), len(models))  # transposed below: one row per axis
    within_rows = [[m.within_.get(n, math.nan) for m in models] for n in columns]
    pair_d, medians, counts = fleet_pair_shifts(
        np.array([centres[n] for n in columns], dtype=np.float64).reshape(shape).T,
        np.array(within_rows, dtype=np.float64).reshape(shape).T,
        np.array([task_spreads[n] for n in columns]),
        np.array([_declared(n).sided == "up" for n in columns], dtype=bool),
    )
    pair_shifts = {n: (float(medians[c]), int(counts[c])) for c, n in enumerate(columns)}
    if ORDER_LINES.name in spread:
        pair_d, order_z = _order_line_pairs(models, cross, task_spreads[ORDER_LINES.name], pair_d)
        pair_shifts[ORDER_LINES.name] = (
            float(np.median(order_z)) if order_z.size else math.nan,
            int(order_z.size),
        )
    distances = pair_d[np.isfinite(pair_d)]
    if not distances.size:
        raise CalibrationError("No indicator is read on enough axes of the fleet to pool.")
    scale = max(float(np.median(distances)) / math.log(2.0), 1e-12)
    indicator_scales = {
        n: middle / math.log(2.0) if count >= MIN_PAIRS else math.nan
        for n, (middle, count) in pair_shifts.items()
    }
    return FleetPrior(
        task_spreads,
        scale,
        fleet_centre,
        len(models),
        int(distances.size),
        indicator_scales,
        {n: count for n, (_, count) in pair_shifts.items()},
        tuple(dict(m.centre_) for m in models),
    )


def pool_fleet_without(models: Sequence[IndicatorModel], index: int) -> FleetPrior | None:
    """The prior of the fleet without its ``index``-th axis: what that axis's baseline is
    checked against (leave-self-out).

    Pooled with the others, a worn axis inflates the task spreads and allowances it is checked
    against: with 4 axes, half the pairs involve it and their median is a worn pair's.

    Parameters
    ----------
    models : sequence of IndicatorModel
        Fitted models of one profile's axes, the checked one included.
    index : int
        Position of the checked axis in ``models``.

    Returns
    -------
    FleetPrior or None
        :func:`pool_fleet` of the other models; None when fewer than 3 others remain (or none
        of their indicators is read on enough of them): the caller then checks against the
        fleet with the axis included (:meth:`IndicatorModel.use_fleet` without
        ``check_against``).

    Examples
    --------
    >>> from axiswatch import IndicatorModel
    >>> from axiswatch.datasets import draw_robot
    >>> robot = draw_robot(0)
    >>> fleet = [IndicatorModel().fit(robot.capture(t, seed=0),
    ...                               [robot.capture(t, seed=k) for k in range(1, 6)])
    ...          for t in range(4)]
    >>> pool_fleet_without(fleet, 0).n_axes, pool_fleet_without(fleet[:3], 0) is None
    (3, True)
    """
    if not 0 <= index < len(models):
        raise IndexError(
            f"The 'index' parameter must be in [0, {len(models)}) (the fleet's axes). "
            f"Got {index!r} instead."
        )
    others = [*models[:index], *models[index + 1 :]]
    if len(others) < MIN_AXES:
        return None
    try:
        return pool_fleet(others)
    except CalibrationError:
        return None


def _combined_spreads(within: Mapping[str, float], prior: FleetPrior | None) -> dict[str, float]:
    """``sqrt(s_w^2 + s_t^2)`` per indicator of ``within`` (``s_w`` where no ``s_t``)."""
    spreads = prior.task_spreads if prior is not None else {}
    out = {}
    for name, own in within.items():
        task = spreads.get(name, math.nan)
        out[name] = math.hypot(own, task) if math.isfinite(task) else own
    return out


def _allowances(
    within: Mapping[str, float],
    prior: FleetPrior | None,
    percentile: float,
    own: Mapping[str, float] | None = None,
) -> dict[str, float]:
    """Task-change allowance per indicator of ``within``: the fleet's, or the axis's ``own``
    (:func:`own_pair_allowances`) where that is larger; empty without a prior."""
    if prior is None:
        return {}
    fleet = prior.allowances(percentile)
    fallback = prior.allowance(percentile)
    mine = own or {}
    return {name: max(fleet.get(name, fallback), mine.get(name, -math.inf)) for name in within}


def _task_change_scales(
    within: Mapping[str, float],
    prior: FleetPrior | None,
    percentile: float,
    own: Mapping[str, float] | None = None,
) -> dict[str, float]:
    allowances = _allowances(within, prior, percentile, own)
    return {n: s * allowances.get(n, 1.0) for n, s in _combined_spreads(within, prior).items()}


def own_pair_allowances(
    centre: Mapping[str, float],
    within: Mapping[str, float],
    others: Sequence[Mapping[str, float]],
    prior: FleetPrior,
    percentile: float,
) -> dict[str, float]:
    """Task-change allowances of one axis from its own pairs with the other axes.

    The fleet's allowance ``A_i`` (:func:`indicator_allowances`) fits a half-Laplace to the
    ``|z_i|`` of *all* the fleet's pairs; here the same rule is fitted to the pairs that involve
    this axis only: ``z_i = (c_i - c_i') / sqrt(s_w,i^2 + s_t,i^2)`` of the axis's centre
    ``c_i`` against each other axis's ``c_i'`` (``s_w`` the axis's own within-task spread, as
    its captures are scored), scale ``median / ln 2``, at the fleet's Bonferroni level
    ``100 - (100 - p) / m`` (``m`` the indicators with a fleet scale). An axis whose own task is
    unlike the fleet's (a heavy payload on an arm, where the other tasks cluster) has large own
    pairs: the fleet's allowance, set by the fleet's typical pair, would call every change away
    from its task a fault. :class:`IndicatorModel` takes the larger of the two
    (docs/evaluation.md, "Allowances from an axis's own pairs": chosen on the development
    robots).

    Parameters
    ----------
    centre, within : mapping of str to float
        The axis's centre and within-task spread per indicator (on the compared scale).
    others : sequence of mapping of str to float
        The other axes' centres.
    prior : FleetPrior
        The fleet's prior: task spreads, the indicators with an allowance and their fallback.
    percentile : float in (0, 100)

    Returns
    -------
    dict of str to float
        Per indicator of ``prior.indicator_scales``: the own-pairs allowance in spreads, or the
        fleet's (:meth:`FleetPrior.allowances`) where fewer than ``MIN_PAIRS`` pairs read it,
        their median is 0, or the indicator is ``order_lines`` (read against each axis's own
        reference: its centres say nothing of a task change).

    Examples
    --------
    >>> prior = FleetPrior({"a": 3.0}, 1.0, {"a": 0.0}, 5, 10, {"a": 1.0}, {"a": 10})
    >>> others = [{"a": v} for v in (0.0, 5.0, 20.0, 30.0)]
    >>> own = own_pair_allowances({"a": 10.0}, {"a": 4.0}, others, prior, 99.0)
    >>> round(own["a"], 3)  # |z| 2, 1, 2, 4 in spreads of 5: median 2, 2 / ln 2 x ln 100
    13.288
    """
    fleet = prior.allowances(percentile)
    fitted = sum(math.isfinite(s) and s > 0 for s in prior.indicator_scales.values())
    level = 100.0 - (100.0 - percentile) / max(fitted, 1)
    out = {}
    for name, fallback in fleet.items():
        scale = math.hypot(prior.task_spreads.get(name, math.nan), within.get(name, math.nan))
        shifts = [
            abs((centre.get(name, math.nan) - other.get(name, math.nan)) / scale)
            for other in others
        ]
        finite = [z for z in shifts if math.isfinite(z)]
        middle = float(np.median(finite)) if finite else 0.0
        if name == ORDER_LINES.name or len(finite) < MIN_PAIRS or not middle > 0:
            out[name] = fallback
        else:
            out[name] = half_laplace_threshold(middle / math.log(2.0), level)
    return out


def fleet_difference(
    centre: Mapping[str, float],
    within: Mapping[str, float],
    prior: FleetPrior,
    percentile: float,
) -> tuple[float, dict[str, float]]:
    """How far an axis's centre is from its fleet's, in task-change allowances.

    The fleet check of :class:`IndicatorModel`: over 1, the axis's baseline differs from its
    fleet's by more than a healthy task change is allowed to (already worn, or a task unlike the
    fleet's).

    Parameters
    ----------
    centre, within : mapping of str to float
        The axis's centre and within-task spreads ``s_w`` per indicator (on the compared scale).
    prior : FleetPrior
        What the axis is checked against: the prior of the other axes
        (:func:`pool_fleet_without`), else the fleet's with the axis included.
    percentile : float in (0, 100)
        Of the allowances (:meth:`FleetPrior.allowances`).

    Returns
    -------
    (float, dict of str to float)
        The largest shift and each indicator's: ``(centre - prior.centre) / (sqrt(s_w^2 + s_t^2)
        x A_i)`` (one-sided for an indicator that only grows with a fault), over the indicators
        of ``within`` that both give and that have a task spread ``s_t`` in ``prior`` (an
        indicator read on fewer than 3 of its axes is not checked: what a task change does to
        it is unknown); NaN and empty when there is none.

    Examples
    --------
    >>> prior = FleetPrior({"coulomb_friction": 0.3}, 1.0, {"coulomb_friction": 3.0}, 4, 6,
    ...                    {"coulomb_friction": 1.0}, {"coulomb_friction": 6})
    >>> distance, shifts = fleet_difference({"coulomb_friction": 9.0},
    ...                                     {"coulomb_friction": 0.4}, prior, 99.0)
    >>> round(distance, 3)  # 6 / 0.5 spreads over an allowance of ln(100) = 4.6 spreads
    2.606
    """
    # An indicator without a task spread (fewer than 3 of the fleet's axes read it) has no
    # task-change allowance: its s_w alone would call any other task a difference.
    checked = {
        n: s for n, s in within.items() if math.isfinite(prior.task_spreads.get(n, math.nan))
    }
    return _distance(centre, prior.centre, _task_change_scales(checked, prior, percentile))
