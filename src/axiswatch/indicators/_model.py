"""IndicatorModel: physical indicators scored in spreads estimated from the axis and its fleet.

Pipeline stage 6b (issue 13). No number in the decision comes from a simulator run; each is
estimated from what the user has:

* **centre** of an indicator: the median of its readings over the baseline and the calibration
  captures (``K + 1`` captures of one task). A faulty first capture therefore does not become the
  reference; it is reported (``baseline_check_``) when it disagrees with the next captures.
* **within-task spread** ``s_w``: ``1.4826 x MAD`` of those readings (a consistent estimate of
  the standard deviation for Gaussian readings, unmoved by one wild reading). With ``K = 5``
  (6 readings) its relative standard error is about 45 % (MAD's efficiency is 37 %); with fewer
  than 3 readings it is not estimated and the indicator is not scored.
* **task-change spread** ``s_t`` (:func:`pool_fleet`): over the axes of one profile, each at its
  own task, ``sqrt(2) x 1.4826 x MAD`` of their centres: the spread of the difference between
  two tasks' readings, robust to a minority (under half) of faulty axes. Needs 3 axes; with
  fewer, the model has no task-change allowance and says so (``notes_``).
* a reading's shift is ``z = (x - centre) / sqrt(s_w^2 + s_t^2)`` (one-sided for indicators
  that only grow with a fault); the **distance** of a capture is the largest ``z`` over the
  indicators it gives.
* with a fleet prior, each indicator has its own **task-change allowance** ``A_i``: each pair of
  the fleet's axes is a healthy task change, taken both ways as the monitor reads a capture
  (:func:`fleet_pair_shifts`: axis ``a``'s centre against baseline ``b``'s, in ``b``'s spreads,
  and ``b``'s against ``a``'s, so the prior does not depend on the order of the axes), and
  ``A_i`` is a percentile of the half-Laplace whose scale is ``median / ln 2`` of that
  indicator's ``|z_i|`` over the ordered pairs that read it (the median keeps a faulty minority,
  under half of the pairs, from inflating it). The percentile is
  Bonferroni's ``100 - (100 - p) / m`` over the ``m`` indicators with an allowance, so that a
  healthy task change exceeds *some* allowance at most ``100 - p`` % of the time, as the one
  allowance of the largest shift did before. One allowance for all (the same percentile ``p``
  of the half-Laplace of the ordered pairs' largest shift) was set by the indicators a task
  change moves most and hid a fault on the others (docs/evaluation.md, "Transfer"). An indicator
  read on fewer than 3 ordered pairs (2 axes), or without a task spread, takes that one
  allowance. For an indicator that
  only grows with a fault the two-sided ``|z_i|`` makes its allowance conservative.
* an axis whose own task is unlike the fleet's (a heavy payload on an arm, the other tasks
  alike) would take the fleet's typical allowance and alarm on every change away from its task:
  each axis takes, per indicator, the larger of the fleet's allowance and the same rule fitted to
  its *own* pairs only (:func:`own_pair_allowances`: its centre against each other axis's).
  Chosen on the development robots (docs/evaluation.md, "Allowances from an axis's own pairs");
  the fleet check keeps the fleet's allowances.
* **a loose friction reading** (``whole_moves=True`` only, an opt-in operating point, and with
  a fleet prior): the drive loads are read on whole moves and the least squares that reads
  ``coulomb_friction`` and ``viscous_friction`` gives each a standard error ``se``
  (:attr:`~axiswatch.indicators._readings.Readings.errors`); the model keeps ``se_ref``, the median of its
  fitting captures', and takes a capture's friction shift in ``sqrt((s_w max(1, se / se_ref))^2
  + s_t^2)`` (times its allowance): on constant-speed moves Coulomb and viscous trade off from
  one capture to the next and their own least squares says so. The threshold and the fitting
  captures' leave-one-out distances are computed without the factor
  (:meth:`IndicatorModel.error_factors`). Not the default: on the development and fresh robots
  it removed most of Robot A's false-alarm days but lowered ``dr99`` at the fixed 99 %
  threshold by up to 0.03 (docs/evaluation.md, "An opt-in operating point: ``--whole-moves``").
* a capture that changed task is scored in **allowance units**: its distance is the largest
  ``u_i = z_i / A_i``; the calibration captures' leave-one-out distances are in the same units
  and the **threshold** is the larger of 1 (an allowance) and the ``percentile`` of their
  half-Laplace fit. Without a fleet prior the distance is in spreads and the threshold is the
  calibration fit alone. With 3 axes there are 6 ordered pairs (3 pairs both ways): the
  allowances are then a rough guess, and the report says how many pairs they rest on.
* **the fleet check** (:func:`fleet_difference`): the axis's centre against the fleet's, in
  units of each indicator's task-change allowance; over 1, the baseline is reported
  (``fleet_check_``: already worn, or a task unlike the fleet's). It is made against the fleet
  *without* the axis (:func:`pool_fleet_without`, leave-self-out) whenever 3 other axes remain:
  pooled with the others, a worn axis inflates the task spreads and allowances it is checked
  against (with 4 axes, half the pairs involve it) and hides. With fewer others it is checked
  against the fleet with itself included, and says so. Captures are always scored with the prior
  pooled over all the axes.
* **the allowance only when the task changed** (``task_envelope_factor``, off by default: see
  :class:`IndicatorModel`): the fleet's spreads and allowance hide a fault as
  well as a task change, so a capture whose *motion* is the baseline's task is scored with the
  axis's own within-task spreads ``s_w`` and its own calibration threshold (the same half-Laplace
  rule on the leave-one-out distances in ``s_w``). Whether it is the baseline's task is read from
  the position and speed only (:func:`~axiswatch.indicators._readings.task_signature`; a fault changes the
  torque, hardly the commanded motion): a capture whose signature is within the **task
  envelope** of the baseline's (``TASK_ENVELOPE_FACTOR`` x the largest leave-one-out signature
  distance among the ``K + 1`` fitting captures, :func:`task_envelope`) is the same task; any
  other, and one whose motion cannot be read, is scored as a task change (fleet spreads, the
  threshold with the allowance), so missing data never tightens the test.
* **an axis without a fleet** (fewer than 3 axes of its profile): nothing says what a task
  change does to its indicators, and on the development robots such an axis, scored in its own
  spreads, alarmed on up to 157 of 184 days after task changes (docs/evaluation.md, "An axis
  without a fleet"). A capture whose motion is beyond the baseline's task envelope (the factor
  given, else ``TASK_ENVELOPE_FACTOR``) is therefore not compared, and its assessment says why
  and what to do (rebaseline the axis on its new task, or monitor 3 axes of its profile); the
  baseline's task is scored in the own spreads as before, and a capture whose motion cannot be
  read is scored too.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from axiswatch._calibration import fit_half_laplace, half_laplace_threshold
from axiswatch._capture import Capture
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import CalibrationError
from axiswatch.indicators._order_lines import (
    MIN_COMMON_CELLS,
    OrderProfile,
    component_at,
    grown_lines,
    most_grown_order,
    order_reference,
)
from axiswatch.indicators._readings import (
    FRICTION,
    INDICATORS,
    Indicator,
    Readings,
    read_indicators,
    signature_distance,
)

__all__ = [
    "FleetPrior",
    "IndicatorAssessment",
    "IndicatorModel",
    "fleet_difference",
    "fleet_pair_shifts",
    "indicator_allowances",
    "leave_one_out_distances",
    "pool_fleet",
    "pool_fleet_without",
    "reference_errors",
    "task_envelope",
]

#: ``1 / Phi^-1(3/4)``: MAD -> standard deviation for Gaussian data.
MAD_TO_SD = 1.4826
#: Least readings for a spread; least axes for a fleet prior.
MIN_READINGS = 3
MIN_AXES = 3
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


@dataclass(frozen=True)
class IndicatorAssessment:
    """Verdict on one capture.

    Attributes
    ----------
    distance : float
        Largest shift, in spreads; with the fleet's allowances (a task change), the largest
        shift in units of its indicator's allowance; NaN when no indicator could be scored.
    threshold : float
        In the distance's units.
    alarm : bool
    top : str or None
        The indicator with the largest shift.
    component : str or None
        What ``top`` watches.
    indicators : dict
        Per indicator read: ``value``, ``baseline`` (the centre), ``spreads`` (the shift, in
        spreads), ``share`` (its part of the sum of the shifts in the distance's units) and,
        with the fleet's allowances, ``allowance`` (its task-change allowance, in spreads) and,
        with ``whole_moves``, for a friction reading looser than the baseline's,
        ``error_factor`` (how much its within-task spread was widened:
        :meth:`IndicatorModel.error_factors`).
    unavailable : dict of str to str
        Indicators not scored, and why.
    case : str
        Which spreads and threshold applied, in words: ``"same task as the baseline: own
        spreads"``, ``"task changed: fleet allowance"``, ``"task not read from the motion:
        fleet allowance"`` or, with the envelope off, ``"no task envelope: fleet allowance"``
        (``"...: no fleet prior"`` without one); ``"task changed: no fleet prior"`` for a
        capture of another task on an axis without a fleet prior, which is not scored.
    task_distance : float
        Signature distance from the baseline's task (NaN when not read), against
        ``task_envelope``.
    task_envelope : float
        The baseline task's envelope (NaN when its signature could not be read).
    """

    distance: float
    threshold: float
    alarm: bool
    top: str | None
    component: str | None
    indicators: dict[str, dict[str, float]]
    unavailable: dict[str, str] = field(default_factory=dict)
    case: str = "task changed: fleet allowance"
    task_distance: float = math.nan
    task_envelope: float = math.nan

    @property
    def same_task(self) -> bool:
        """Whether the capture was scored as the baseline's task (own spreads)."""
        return self.case.startswith("same task")

    @property
    def scored(self) -> bool:
        """Whether any indicator was scored."""
        return math.isfinite(self.distance)

    def reason(self) -> str:
        """One line: what moved, or why nothing could be scored."""
        if not self.scored:
            # One reason shared by every indicator (no motion) is said once, not once each.
            names: dict[str, list[str]] = {}
            for name, why in self.unavailable.items():
                names.setdefault(why, []).append(name)
            return "not scored: " + "; ".join(
                f"{group[0]} {why}" if len(group) == 1 else f"{', '.join(group)}: each {why}"
                for why, group in names.items()
            )
        assert self.top is not None
        entry = self.indicators[self.top]
        # Without an envelope every capture is scored one way: the case says nothing (details
        # keep it).
        case = "" if self.case.startswith("no task envelope") else f"{self.case}; "
        part = f" ({self.component})" if self.component is not None else ""
        moved = f"{case}{self.top}{part} {entry['spreads']:.1f} spreads from its baseline"
        if "allowance" in entry:
            return (
                f"{moved}, {entry['spreads'] / entry['allowance']:.2f} x its task-change "
                f"allowance of {entry['allowance']:.1f} (threshold {self.threshold:.2f} x)"
            )
        return f"{moved} (threshold {self.threshold:.1f} spreads)"


class IndicatorModel:
    """Baseline, spreads and threshold of one axis's physical indicators.

    Parameters
    ----------
    profile : AxisProfile, optional
        Kinematics for the kinematic lines (units and columns are applied when reading files).
    percentile : float in (0, 100), default=99.0
    fleet : FleetPrior, optional
        Task-change spreads and allowance of the axis's profile (:func:`pool_fleet`); can be
        set later with :meth:`use_fleet`, which also takes the prior of the other axes to
        check the baseline against (given here, the baseline is checked against ``fleet``,
        itself included).
    task_envelope_factor : float > 0 or None, default=None
        The task envelope in units of the largest leave-one-out signature distance of the
        fitting captures (:func:`task_envelope`; ``TASK_ENVELOPE_FACTOR`` = 2 was chosen on the
        development robots); None: with a fleet prior, every capture is scored as a task change
        (the fleet's spreads and allowance always). Without a fleet prior the envelope (this
        factor, ``TASK_ENVELOPE_FACTOR`` when None) tells a capture of another task, which is
        then not compared at all (nothing says what a task change does to the indicators; the
        assessment says so and how to monitor the new task). Off by default: on the development and held-out robots it
        detects far more same-task friction faults for a few more false alarms, but on the real
        hydraulic actuators it raised 55 false alarms in 297 healthy captures
        (docs/evaluation.md, "Through the monitor").
    order_lines : bool, default=False
        Also read the torque's order spectrum and score ``order_lines``: how much the order
        lines of a capture grew against the baseline's own order spectrum
        (:mod:`axiswatch.indicators._order_lines`), without kinematics. Its task-change spread and
        allowance come from the fleet: each axis's reference reading the other axes' captures.
    whole_moves : bool, default=False
        An opt-in operating point: read the drive loads on whole moves only and, with a fleet
        prior, widen the within-task spread of a friction reading looser than the baseline's
        (``max(1, se / se_ref)``, :meth:`error_factors`). On development robots 0-7 it cut Robot
        A's false-alarm days from 32 to 3 and on fresh robots 8-15 from 19 to 0, but lowered
        ``dr99`` at the fixed 99 % threshold by up to 0.03, so it is not the default
        (docs/evaluation.md, "An opt-in operating point: ``--whole-moves``").

    Attributes
    ----------
    centre_, within_ : dict of str to float
    threshold_ : float
        For a task change: with a fleet prior, the calibration fit in allowance units, at least
        1; without, the calibration fit in ``s_w``.
    own_threshold_ : float
        For the baseline's task: the calibration fit in ``s_w`` (no allowance).
    se_ref_ : dict of str to float
        With ``whole_moves``: per friction indicator, the median least-squares standard error of
        the fitting captures' readings (:func:`reference_errors`); empty without.
    loo_distances_, own_loo_distances_ : list of float
        Leave-one-out distance of each capture fitted on (baseline first; NaN where none) in the
        task-change units (:attr:`task_change_scales_`) and in the own spreads; each threshold
        is fitted on the calibration captures' (:func:`leave_one_out_distances`).
    order_reference_ : OrderProfile or None
        With ``order_lines``: the median order profile of the fitting captures
        (:func:`~axiswatch.indicators._order_lines.order_reference`); None when none gave one.
    task_reference_ : ndarray of shape (6,) or None
        The median task signature of the fitting captures (None when fewer than 3 are read),
        with or without ``task_envelope_factor``.
    task_envelope_ : float
        How far a capture's signature may be from it and still be the baseline's task (NaN
        without a reference).
    task_loo_distances_ : list of float
        Each fitting capture's signature distance from the median of the others'.
    baseline_check_ : str or None
        Why the baseline capture is not trusted as it is (None when it agrees).
    fleet_check_ : str or None
        With a fleet prior: how the axis's centre differs from its fleet's by more than the
        task-change allowance (:func:`fleet_difference`; None when it does not, or without a
        prior), and what it was checked against: the other axes of its profile
        (``check_against`` of :meth:`use_fleet`), else the fleet with the axis included.
    notes_ : list of str
        What the model could not estimate, in words.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> robot = draw_robot(0)
    >>> model = IndicatorModel().fit(robot.capture(0, seed=0),
    ...                              [robot.capture(0, seed=k) for k in range(1, 6)])
    >>> model.assess(robot.capture(0, seed=9)).scored
    True
    """

    def __init__(
        self,
        profile: AxisProfile | None = None,
        *,
        percentile: float = 99.0,
        fleet: FleetPrior | None = None,
        task_envelope_factor: float | None = None,
        order_lines: bool = False,
        whole_moves: bool = False,
    ) -> None:
        self.profile = profile
        self.percentile = percentile
        self.fleet = fleet
        self.task_envelope_factor = task_envelope_factor
        self.order_lines = order_lines
        self.whole_moves = whole_moves

    @staticmethod
    def pool(models: Sequence[IndicatorModel]) -> FleetPrior:
        """:func:`pool_fleet`: the fleet prior of fitted models of one profile's axes."""
        return pool_fleet(models)

    @staticmethod
    def pool_without(models: Sequence[IndicatorModel], index: int) -> FleetPrior | None:
        """:func:`pool_fleet_without`: the prior the ``index``-th model's baseline is checked
        against (``check_against`` of :meth:`use_fleet`)."""
        return pool_fleet_without(models, index)

    def readings(self, capture: Capture) -> Readings:
        """The capture's indicators (:func:`~axiswatch.read_indicators` with the profile's
        kinematics, ``order_lines`` and ``whole_moves``)."""
        kinematics = self.profile.kinematics() if self.profile is not None else {}
        return read_indicators(
            capture, **kinematics, order_lines=self.order_lines, whole_moves=self.whole_moves
        )

    def fit(self, baseline: Capture, calibration: Sequence[Capture]) -> IndicatorModel:
        """Centre and within-task spreads from the baseline and the calibration captures."""
        if len(calibration) < MIN_READINGS - 1:
            raise CalibrationError(
                f"IndicatorModel needs at least {MIN_READINGS - 1} calibration captures after "
                f"the baseline (a spread needs {MIN_READINGS} readings); got {len(calibration)}."
            )
        read = [self.readings(c) for c in (baseline, *calibration)]
        return self.fit_readings(read)

    def fit_readings(self, read: Sequence[Readings]) -> IndicatorModel:
        """:meth:`fit` from readings already taken (first = the baseline)."""
        self.fit_readings_ = list(read)
        rows = [_transformed(r) for r in read]
        self.order_reference_: OrderProfile | None = None
        if self.order_lines:
            self.order_reference_, grown = _fitting_order_lines(read)
            for row, value in zip(rows, grown, strict=True):
                row[ORDER_LINES.name] = value
        names = list(rows[0])
        self.reasons_ = dict(read[0].reasons)
        self.centre_: dict[str, float] = {}
        self.within_: dict[str, float] = {}
        for name in names:
            values = [row[name] for row in rows]
            spread = robust_spread(values)
            if math.isfinite(spread) and spread > 0:
                self.centre_[name] = float(np.nanmedian(values))
                self.within_[name] = spread
            elif name not in self.reasons_:
                self.reasons_[name] = (
                    "no spread to scale by (read on fewer than 3 of the baseline and calibration "
                    "captures, or identical on all)"
                )
        self.calibration_rows_ = rows
        self.se_ref_ = reference_errors(read) if self.whole_moves else {}
        self.task_reference_: NDArray[np.float64] | None = None
        self.task_envelope_ = math.nan
        self.task_loo_distances_ = [math.nan] * len(read)
        # Always read: without a fleet prior a capture beyond the envelope is not compared.
        factor = self.task_envelope_factor or TASK_ENVELOPE_FACTOR
        envelope = task_envelope([r.signature for r in read], factor)
        if envelope is not None:
            self.task_reference_, self.task_envelope_, self.task_loo_distances_ = envelope
        self._threshold_from(rows, None)
        return self

    def use_fleet(
        self, fleet: FleetPrior | None, *, check_against: FleetPrior | None = None
    ) -> IndicatorModel:
        """Take a fleet prior (or drop it) and recompute the threshold and the checks.

        Parameters
        ----------
        fleet : FleetPrior or None
            What captures are scored with: the prior of all the profile's axes, this one
            included (:func:`pool_fleet`).
        check_against : FleetPrior, optional
            What the fleet check (``fleet_check_``) is made against: the prior of the other
            axes (:func:`pool_fleet_without`). None: ``fleet`` itself, this axis included (a
            worn axis then inflates the allowances it is checked against; the notes say so).

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> fleet = [IndicatorModel().fit(robot.capture(t, seed=0),
        ...                               [robot.capture(t, seed=k) for k in range(1, 6)])
        ...          for t in range(4)]
        >>> model = fleet[0].use_fleet(pool_fleet(fleet),
        ...                            check_against=pool_fleet_without(fleet, 0))
        >>> model.fleet.n_axes, model.fleet_check_ is None
        (4, True)
        """
        if fleet is None and check_against is not None:
            raise ValueError(
                "The 'check_against' parameter of use_fleet needs a fleet prior to score with "
                "('fleet'). Got fleet=None instead."
            )
        self.fleet = fleet
        self._threshold_from(self.calibration_rows_, check_against)
        return self

    def _own_allowances(self) -> None:
        """The axis's allowances from its own pairs (:func:`own_pair_allowances`), when its
        prior has the fleet's centres; the prior is then kept without them (a model of a fleet of
        ``n`` axes would otherwise store ``n`` centres)."""
        self.own_allowances_: dict[str, float] = {}
        if self.fleet is None or not self.fleet.centres:
            return  # a prior a model already keeps has no centres: the fleet's allowances only
        # The axis itself is among the centres when it was pooled: its pair with itself is none.
        others = [c for c in self.fleet.centres if c != self.centre_]
        self.own_allowances_ = own_pair_allowances(
            self.centre_, self.within_, others, self.fleet, self.percentile
        )
        self.fleet = dataclasses.replace(self.fleet, centres=())

    def error_factors(self, errors: Mapping[str, float]) -> dict[str, float]:
        """How much looser than the baseline's a capture's friction readings are: per friction
        indicator scored, ``max(1, se / se_ref)`` (1 where either error is not a positive
        number); empty without ``whole_moves`` or without a fleet prior.

        With a fleet prior a capture's friction shift is taken in
        ``sqrt((s_w x factor)^2 + s_t^2)`` times its allowance: ``s_w`` belongs to readings of
        the baseline's precision (``se_ref_``, the median standard error of the fitting
        captures'), and a reading whose own least squares is looser (constant-speed moves, where
        Coulomb and viscous trade off) spreads more in proportion. Only the ratio of two
        standard errors of the same regression on the same axis enters, no constant
        (docs/evaluation.md, "Drive loads from whole moves"). The factor never lowers a spread,
        so it never raises a distance. The threshold and the leave-one-out distances of the
        fitting captures are computed without it (their ratios are about 1 by construction), as
        in the study that chose it; a capture of the baseline's task scored in the own spreads
        (``task_envelope_factor``) takes no factor either.

        Parameters
        ----------
        errors : mapping of str to float
            The capture's :attr:`~axiswatch.indicators._readings.Readings.errors`.

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> fleet = [IndicatorModel(whole_moves=True).fit(
        ...     robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)])
        ...     for t in range(4)]
        >>> model = fleet[0].use_fleet(pool_fleet(fleet))
        >>> looser = {n: 3 * se for n, se in model.se_ref_.items()}
        >>> {n: round(f, 6) for n, f in model.error_factors(looser).items()}
        {'coulomb_friction': 3.0, 'viscous_friction': 3.0}
        >>> model.use_fleet(None).error_factors(looser)
        {}
        """
        if self.fleet is None or not self.whole_moves:
            return {}
        out = {}
        for name in FRICTION:
            if name not in self.within_:
                continue
            se, reference = errors.get(name, math.nan), self.se_ref_.get(name, math.nan)
            ratio = se / reference if math.isfinite(reference) and reference > 0 else math.nan
            out[name] = max(1.0, ratio) if math.isfinite(ratio) else 1.0
        return out

    @property
    def scales_(self) -> dict[str, float]:
        """``sqrt(s_w^2 + s_t^2)`` per scored indicator (``s_w`` alone without a fleet prior)."""
        return _combined_spreads(self.within_, self.fleet)

    @property
    def allowances_(self) -> dict[str, float]:
        """Task-change allowance per scored indicator, in spreads: the fleet's
        (:meth:`FleetPrior.allowances`; its one allowance for an indicator without its own), or
        the axis's own pairs' where larger (:func:`own_pair_allowances`); empty without a
        prior."""
        return _allowances(self.within_, self.fleet, self.percentile, self.own_allowances_)

    @property
    def task_change_scales_(self) -> dict[str, float]:
        """What a task change's shift is divided by: ``sqrt(s_w^2 + s_t^2) x A_i`` (so the
        distance is in allowance units), or :attr:`scales_` without a fleet prior."""
        return _task_change_scales(self.within_, self.fleet, self.percentile, self.own_allowances_)

    def _threshold_from(
        self, rows: Sequence[Mapping[str, float]], check_against: FleetPrior | None
    ) -> None:
        self._own_allowances()
        scales = self.task_change_scales_
        self.loo_distances_ = leave_one_out_distances(rows, scales)
        # The baseline's own leave-one-out distance is checked, not fitted: a faulty baseline
        # would inflate the threshold it is checked against.
        calibration = [d for d in self.loo_distances_[1:] if math.isfinite(d)]
        self.notes_: list[str] = []
        if len(calibration) < 2:
            raise CalibrationError(
                "No indicator could be read on the baseline and calibration captures: "
                + "; ".join(f"{k} {v}" for k, v in self.reasons_.items())
            )
        fitted = fit_half_laplace(calibration).threshold(self.percentile)
        self.threshold_ = fitted
        self.own_loo_distances_ = leave_one_out_distances(rows, self.within_)
        own_calibration = [d for d in self.own_loo_distances_[1:] if math.isfinite(d)]
        self.own_threshold_ = fit_half_laplace(own_calibration).threshold(self.percentile)
        if self.task_reference_ is None and self.task_envelope_factor is not None:
            self.notes_.append(
                "the task could not be read from the motion of the fitting captures: every "
                "capture is scored as a task change"
            )
        if self.fleet is None:
            self.notes_.append(
                "no task-change allowance: fewer than 3 axes of this profile to pool; a capture "
                "whose motion is unlike the baseline's task is not compared"
                if self.task_reference_ is not None
                else "no task-change allowance: fewer than 3 axes of this profile to pool, and "
                "the task could not be read from the motion: a task change may alarm"
            )
        else:
            # In allowance units: 1 is a shift as large as a healthy task change's allowance.
            self.threshold_ = max(fitted, 1.0)
            own = sum(math.isfinite(v) for v in self.fleet.indicator_scales.values())
            self.notes_.append(
                f"task-change allowances from {self.fleet.n_axes} axes ({self.fleet.n_pairs} "
                f"ordered pairs): {own} indicators their own, the others the fleet's one allowance "
                f"{self.fleet.allowance(self.percentile):.2f} spreads; calibration threshold "
                f"{fitted:.2f} allowances"
            )
        unit = "spreads" if self.fleet is None else "allowances"
        self.baseline_check_: str | None = None
        own_distance = self.loo_distances_[0]
        if math.isfinite(own_distance) and own_distance > self.threshold_:
            self.baseline_check_ = (
                f"the baseline capture is {own_distance:.1f} {unit} from the next captures "
                f"(threshold {self.threshold_:.1f}): the median of all is the reference"
            )
        self.fleet_check_: str | None = None
        if self.fleet is not None:
            if check_against is not None:
                against = check_against
                whom = f"checked against the {against.n_axes} other axes of its profile"
            else:
                against = self.fleet
                whom = f"checked against its fleet of {against.n_axes} axes, itself included"
                self.notes_.append(
                    f"baseline {whom} (a worn axis inflates the allowances it is checked against)"
                )
            d, shifts = fleet_difference(self.centre_, self.within_, against, self.percentile)
            if math.isfinite(d) and d > 1.0:
                top = max(shifts, key=shifts.__getitem__)
                self.fleet_check_ = (
                    f"this axis's baseline differs from its fleet's: {top} "
                    f"{shifts[top]:.1f} x its task-change allowance (already worn, or a task "
                    f"unlike the fleet's); {whom}"
                )
                self.notes_.append(self.fleet_check_)

    def assess(self, capture: Capture) -> IndicatorAssessment:
        """Distance, threshold, alarm and per-indicator details of one capture."""
        return self.assess_readings(self.readings(capture))

    def assess_readings(self, readings: Readings) -> IndicatorAssessment:
        """:meth:`assess` from readings already taken: with the own spreads and threshold when
        the capture's motion is the baseline's task, else with the fleet's."""
        distance = math.nan
        if self.task_reference_ is not None and len(readings.signature):
            signature = np.asarray(readings.signature, dtype=np.float64)
            distance = signature_distance(signature, self.task_reference_)
        changed = math.isfinite(distance) and distance > self.task_envelope_
        if changed and self.fleet is None:
            return self._not_compared(distance)
        if self.task_envelope_factor is not None and math.isfinite(distance) and not changed:
            case = "same task as the baseline: own spreads"
        else:
            known = (
                "no task envelope"
                if self.task_envelope_factor is None
                else "task changed"
                if changed
                else "task not read from the motion"
            )
            case = f"{known}: {'fleet allowance' if self.fleet is not None else 'no fleet prior'}"
        values, reasons = _transformed(readings), dict(readings.reasons)
        if self.order_lines:
            values[ORDER_LINES.name], why = self._order_lines(readings)
            if why is not None:
                reasons[ORDER_LINES.name] = why
        assessment = self._assess(
            values, reasons, self.centre_, own=case.startswith("same"), errors=readings.errors
        )
        component = assessment.component
        if assessment.top == ORDER_LINES.name:
            component = self._where_grown(readings)
        return dataclasses.replace(
            assessment,
            case=case,
            task_distance=distance,
            task_envelope=self.task_envelope_,
            component=component,
        )

    def _not_compared(self, task_distance: float) -> IndicatorAssessment:
        """A capture of another task on an axis without a fleet prior: nothing says what a task
        change does to its indicators (docs/evaluation.md, "An axis without a fleet")."""
        why = (
            f"unlike the baseline's task (task signature {task_distance:.2f} beyond its "
            f"envelope {self.task_envelope_:.2f}, as shares of the baseline's top speed, "
            "stroke or time moving): with fewer than 3 axes of this profile "
            "nothing says what a task change does to the indicators, so it is not compared "
            "(rebaseline the axis on its new task, or monitor 3 axes of its profile)"
        )
        return IndicatorAssessment(
            distance=math.nan,
            threshold=self.threshold_,
            alarm=False,
            top=None,
            component=None,
            indicators={},
            unavailable={"motion": why},
            case="task changed: no fleet prior",
            task_distance=task_distance,
            task_envelope=self.task_envelope_,
        )

    def _where_grown(self, readings: Readings) -> str:
        """Where the order lines grew most and, with the profile's kinematics, the component
        with a line there."""
        # order_lines is read only when both are there.
        assert readings.order_profile is not None
        assert self.order_reference_ is not None
        order = most_grown_order(readings.order_profile, self.order_reference_)
        where = f"new or grown order lines, most at order {order:.4g}"
        kinematics = self.profile.kinematics() if self.profile is not None else {}
        if kinematics.get("gear_ratio") is None:
            return where
        name = component_at(
            order,
            kinematics["gear_ratio"],
            kinematics["gear_stages"],
            kinematics["bearing_orders"],
        )
        return f"{where}: {name}" if name is not None else f"{where} (no component's line there)"

    def _order_lines(self, readings: Readings) -> tuple[float, str | None]:
        """The capture's ``order_lines`` against the baseline's reference, or why none."""
        if readings.order_profile is None:
            return math.nan, readings.reasons.get(
                ORDER_LINES.name, "not read (the readings were taken without order_lines)"
            )
        if self.order_reference_ is None:
            return math.nan, "the baseline's captures gave no order spectrum"
        value = grown_lines(readings.order_profile, self.order_reference_)
        if not math.isfinite(value):
            return math.nan, (
                f"shares fewer than {MIN_COMMON_CELLS} order cells with the baseline's spectrum "
                "(the speeds differ too much)"
            )
        return value, None

    def assess_fitting(self, index: int) -> IndicatorAssessment:
        """Leave-one-out assessment of the ``index``-th capture the model was fitted on (0: the
        baseline): against the median of the others, in the own spreads (a fitting capture is
        the baseline's task by definition), so its distance is ``own_loo_distances_[index]``.

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> model = IndicatorModel().fit(robot.capture(0, seed=0),
        ...                              [robot.capture(0, seed=k) for k in range(1, 6)])
        >>> model.assess_fitting(2).distance == model.own_loo_distances_[2]
        True
        """
        rows = self.calibration_rows_
        if not 0 <= index < len(rows):
            raise IndexError(
                f"The 'index' parameter must be in [0, {len(rows)}) (captures fitted on). "
                f"Got {index!r} instead."
            )
        centre = _centre_without(rows, index, list(self.within_))
        assessment = self._assess(rows[index], self.fit_readings_[index].reasons, centre, own=True)
        return dataclasses.replace(
            assessment,
            case="same task as the baseline: own spreads",
            task_distance=self.task_loo_distances_[index],
            task_envelope=self.task_envelope_,
        )

    def _assess(
        self,
        values: Mapping[str, float],
        reasons: Mapping[str, str],
        centre: Mapping[str, float],
        *,
        own: bool,
        errors: Mapping[str, float] | None = None,
    ) -> IndicatorAssessment:
        factors = {} if own else self.error_factors(errors or {})
        if factors:
            within = {n: s * factors.get(n, 1.0) for n, s in self.within_.items()}
            scales = _task_change_scales(within, self.fleet, self.percentile, self.own_allowances_)
        else:
            scales = self.within_ if own else self.task_change_scales_
        threshold = self.own_threshold_ if own else self.threshold_
        allowances = {} if own else self.allowances_
        distance, shifts = _distance(values, centre, scales)
        unavailable = {
            name: reasons.get(name, self.reasons_.get(name, "not read"))
            for name in values
            if name not in shifts
        }
        # Exactly rounded: a stored model lists its indicators in another order, and a plain
        # sum's last bit (so the shares') would depend on it.
        total = math.fsum(shifts.values())
        details: dict[str, dict[str, float]] = {
            name: {
                "value": values[name],
                "baseline": centre[name],
                "spreads": z * allowances.get(name, 1.0),
                "share": z / total if total > 0 else 0.0,
            }
            for name, z in shifts.items()
        }
        for name, entry in details.items():
            if name in allowances:
                entry["allowance"] = allowances[name]
            if factors.get(name, 1.0) > 1.0:
                entry["error_factor"] = factors[name]
        top = max(shifts, key=shifts.__getitem__) if shifts else None
        return IndicatorAssessment(
            distance=distance,
            threshold=threshold,
            alarm=bool(math.isfinite(distance) and distance > threshold),
            top=top,
            component=_declared(top).component if top is not None else None,
            indicators=details,
            unavailable=unavailable,
        )

    def params(self) -> dict[str, Any]:
        """JSON-ready description of what was estimated and from what (with ``whole_moves``,
        also ``whole_moves`` and ``se_ref``)."""
        params = {
            "centre": self.centre_,
            "within_spread": self.within_,
            "scales": self.scales_,
            "allowances": self.allowances_,
            "threshold": self.threshold_,
            "own_threshold": self.own_threshold_,
            "task_envelope": self.task_envelope_,
            "baseline_check": self.baseline_check_,
            "fleet_check": self.fleet_check_,
            "notes": self.notes_,
        }
        if self.whole_moves:  # absent otherwise: the default's description is as before
            params.update(whole_moves=True, se_ref=self.se_ref_)
        return params
