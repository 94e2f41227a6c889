"""Nearest task: score a task change against the fleet axis that runs that task.

Research code (``axiswatch experiment nearest-task``); nothing here is in the product. The
default (:class:`~axiswatch.IndicatorModel` with a fleet prior) scores a capture of another task
against the *baseline's* centre, in spreads widened by the fleet's task-change spread and
allowance. The variant studied here uses what the fleet knows about the new task itself:

* **match**: a capture's motion (:attr:`~axiswatch.indicators._readings.Readings.signature`) is *held* by a
  fleet axis when its :func:`~axiswatch.indicators._readings.signature_distance` from the axis's
  ``task_reference_`` is at most the axis's ``task_envelope_`` (the product's envelope,
  ``TASK_ENVELOPE_FACTOR`` x the largest leave-one-out signature distance of its fitting
  captures).
* **rule** (:func:`score_nearest`): a capture held by the baseline's own envelope, or by no other
  fleet axis (or whose motion cannot be read), is scored as the default does. Otherwise it is
  scored against the *nearest* axis ``f`` that holds it (smallest signature distance; any axis,
  of any unit, other than the baseline), with ``f``'s centre and within-task spreads ``s_w`` and
  the unit-change prior below in place of the fleet's task-change prior.
* **same-task pairs** (:func:`same_task_pairs`): pairs of fleet axes each held by the other's
  envelope (their reference signatures). They are what a user has to learn a healthy *unit*
  change on one task from.
* **unit-change prior** (:func:`unit_change_prior`), the estimator of :func:`pool_fleet
  <axiswatch.indicators._fleet.pool_fleet>` restricted to those pairs: per indicator the
  unit-change spread ``s_u = 1.4826 x median |c_a - c_b|`` over the same-task pairs that read it
  (the standard deviation of the difference of two units' centres, as ``pool_fleet``'s ``s_t``
  is that of two axes' centres; the difference is symmetric about 0, so its MAD is about 0;
  NaN with fewer than 3 pairs); then :func:`~axiswatch.indicators._fleet.fleet_pair_shifts` with
  ``s_u`` in place of ``s_t``, kept on the same-task ordered pairs only (each pair both ways),
  gives each indicator's ``|z|`` and each ordered pair's largest shift; the allowance scales are
  ``median / ln 2`` of those (an indicator read on fewer than ``MIN_PAIRS`` = 3 ordered pairs
  takes the one allowance), and the per-indicator allowances are the fleet's Bonferroni rule
  (:meth:`~axiswatch.FleetPrior.allowances`). With **fewer than 3 same-task pairs** there is no
  unit-change prior and every capture is scored as the default does. No own-pair allowances
  (the prior carries no centres): an axis has ``units_per_task - 1`` same-task partners in
  this study, 1 by default.
* **threshold**: the default's own rule on the matched axis: a model fitted on ``f``'s readings
  takes the unit-change prior (:meth:`~axiswatch.IndicatorModel.use_fleet`), so its threshold is
  the 99th percentile of the half-Laplace fitted to its calibration captures' leave-one-out
  distances in unit-change allowance units, at least 1 (an allowance). Distances are compared in
  units of their own threshold (``distance / threshold``, over at 1) so that captures scored by
  different axes share one scale.

The study (:func:`robot_nearest_task`) reuses the transfer study's pieces
(:mod:`axiswatch_lab._transfer`): per robot a fleet of ``units_per_task`` (default TWO) distinct
units per task (unit ``t``, the transfer study's fleet axis of task ``t``, and units
``u * (n_tasks + 1) + t``, ``u = 1 .. units_per_task - 1``, with their own capture seeds:
:func:`extra_unit_index`), all pooled into the default's fleet prior; baselines one per task (unit ``t``'s axis),
each scored on its own unit's paired test captures (:func:`~axiswatch_lab._transfer.paired_readings`);
Robot A is unit ``n_tasks`` with the same fleet. Default and variant score the same captures.
Also recorded: how often a capture of task ``t`` is held by an axis of another task (a wrong
match), and "task not in the fleet": the variant with the fleet's axes of the capture's task
left out (the baseline itself stays when it runs that task): the share of those captures it
reroutes (necessarily to a wrong task) rather than scoring as the default, and its paired
measures. The unit-change prior and the default's fleet prior keep all axes there: only the
matching is changed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import SimulatedRobot, draw_robot, draw_unit
from axiswatch.exceptions import CalibrationError
from axiswatch.monitor import parallel_map
from axiswatch_lab._product import (
    MAD_TO_SD,
    MIN_PAIRS,
    MIN_READINGS,
    ORDER_LINES,
    FleetPrior,
    IndicatorAssessment,
    Readings,
    _declared,
    fleet_pair_shifts,
    pool_fleet,
    pool_fleet_without,
    signature_distance,
)
from axiswatch_lab._transfer import (
    FAST_DESIGN,
    TransferDesign,
    _profile,
    fleet_readings,
    fleet_units,
    paired_measures,
    paired_readings,
    robot_a_readings,
)

__all__ = [
    "MIN_SAME_TASK_PAIRS",
    "NearestTaskScore",
    "extra_unit_index",
    "holding_axes",
    "nearest_task_study",
    "robot_nearest_task",
    "same_task_pairs",
    "score_nearest",
    "unit_change_prior",
    "wrong_matches",
]

#: Fewest same-task pairs for a unit-change prior; with fewer the variant is the default.
MIN_SAME_TASK_PAIRS = 3


def holding_axes(
    signature: Sequence[float] | NDArray[np.float64],
    references: Sequence[NDArray[np.float64] | None],
    envelopes: Sequence[float],
    exclude: Collection[int] = (),
) -> list[tuple[float, int]]:
    """The fleet axes whose task envelope holds a capture's signature, nearest first.

    Parameters
    ----------
    signature : array-like of shape (6,)
        The capture's task signature (empty or NaN where its motion was not read).
    references : sequence of ndarray of shape (6,) or None
        Each axis's ``task_reference_`` (None where it has none).
    envelopes : sequence of float
        Each axis's ``task_envelope_``.
    exclude : collection of int, default=()
        Axes not considered.

    Returns
    -------
    list of (float, int)
        ``(signature distance, axis)`` for every axis with ``distance <= envelope``, sorted by
        distance (then axis); empty when the signature cannot be read.

    Examples
    --------
    >>> import numpy as np
    >>> reference = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5])
    >>> capture = reference * [1.1, 1, 1, 1, 1, 1]  # top speed +10 %: distance 0.1
    >>> [(round(d, 3), k) for d, k in holding_axes(capture, [reference, None, reference],
    ...                                            [0.2, 0.2, 0.05])]
    [(0.1, 0)]
    """
    values = np.asarray(signature, dtype=np.float64)
    if not values.size or not bool(np.isfinite(values).all()):
        return []
    out = []
    for k, (reference, envelope) in enumerate(zip(references, envelopes, strict=True)):
        if reference is None or k in exclude:
            continue
        distance = signature_distance(values, reference)
        if math.isfinite(distance) and distance <= envelope:
            out.append((distance, k))
    return sorted(out)


def same_task_pairs(
    references: Sequence[NDArray[np.float64] | None], envelopes: Sequence[float]
) -> list[tuple[int, int]]:
    """Pairs ``(a, b)``, ``a < b``, of fleet axes each held by the other's task envelope.

    Parameters
    ----------
    references : sequence of ndarray of shape (6,) or None
        Each axis's ``task_reference_``.
    envelopes : sequence of float
        Each axis's ``task_envelope_``.

    Returns
    -------
    list of (int, int)
        Axis ``a``'s reference within ``b``'s envelope and ``b``'s within ``a``'s.

    Examples
    --------
    >>> import numpy as np
    >>> reference = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5])
    >>> near, far = reference * [1.05, 1, 1, 1, 1, 1], reference * [2, 1, 1, 1, 1, 1]
    >>> same_task_pairs([reference, near, far], [0.1, 0.1, 0.1])
    [(0, 1)]
    """
    held = [
        {k for _, k in holding_axes(r, references, envelopes)} if r is not None else set()
        for r in references
    ]
    n_axes = len(references)
    return [
        (a, b) for a in range(n_axes) for b in range(a + 1, n_axes) if b in held[a] and a in held[b]
    ]


def unit_change_prior(
    centres: Sequence[Mapping[str, float]],
    within: Sequence[Mapping[str, float]],
    pairs: Sequence[tuple[int, int]],
) -> FleetPrior | None:
    """What a healthy unit change on one task does to each indicator, from same-task pairs.

    :func:`~axiswatch.indicators._fleet.pool_fleet`'s estimator on the same-task pairs only (the
    module docstring): ``s_u`` in place of the task-change spread, the allowance scales from the
    ordered same-task pairs' shifts (:func:`~axiswatch.indicators._fleet.fleet_pair_shifts`).

    Parameters
    ----------
    centres, within : sequence of mapping of str to float
        Each fleet axis's ``centre_`` and ``within_`` (the order lines are left out: they are
        read against each axis's own reference, so their centres say nothing of a unit change).
    pairs : sequence of (int, int)
        The same-task pairs (:func:`same_task_pairs`), indices into ``centres``.

    Returns
    -------
    FleetPrior or None
        ``task_spreads`` holds ``s_u`` (NaN where fewer than 3 pairs read an indicator),
        ``n_axes`` the axes in some pair, ``n_pairs`` the ordered pairs with a shift, no
        ``centres``; None with fewer than ``MIN_SAME_TASK_PAIRS`` pairs or when no pair shares
        an indicator with a spread.

    Examples
    --------
    >>> centres = [{"coulomb_friction": c} for c in (0.0, 1.0, 10.0, 12.0, 20.0, 23.0)]
    >>> within = [{"coulomb_friction": 1.0}] * 6
    >>> prior = unit_change_prior(centres, within, [(0, 1), (2, 3), (4, 5)])
    >>> round(prior.task_spreads["coulomb_friction"], 4), prior.n_pairs  # 1.4826 x median(1, 2, 3)
    (2.9652, 6)
    >>> unit_change_prior(centres, within, [(0, 1), (2, 3)]) is None
    True
    """
    if len(pairs) < MIN_SAME_TASK_PAIRS:
        return None
    names = sorted({n for c in centres for n in c if n != ORDER_LINES.name})
    table = np.array([[c.get(n, math.nan) for n in names] for c in centres], dtype=np.float64)
    spreads = np.array([[w.get(n, math.nan) for n in names] for w in within], dtype=np.float64)
    table = table.reshape(len(centres), len(names))
    spreads = spreads.reshape(len(centres), len(names))
    unit_spreads = np.full(len(names), np.nan)
    for k in range(len(names)):
        differences = [abs(table[a, k] - table[b, k]) for a, b in pairs]
        finite = [d for d in differences if math.isfinite(d)]
        if len(finite) >= MIN_READINGS:
            unit_spreads[k] = MAD_TO_SD * float(np.median(finite))
    paired = np.zeros((len(centres), len(centres)), dtype=bool)
    for a, b in pairs:
        paired[a, b] = paired[b, a] = True
    one_sided = np.array([_declared(n).sided == "up" for n in names], dtype=bool)
    largest, _, _ = fleet_pair_shifts(table, spreads, unit_spreads, one_sided)
    pair_distances = largest[paired & np.isfinite(largest)]
    if not pair_distances.size:
        return None
    scales: dict[str, float] = {}
    counts: dict[str, int] = {}
    for k, name in enumerate(names):
        if not (math.isfinite(unit_spreads[k]) and unit_spreads[k] > 0):
            continue
        only = np.full(len(names), np.nan)
        only[k] = unit_spreads[k]
        # Two-sided here: the allowance of an indicator rests on |z|, as pool_fleet's does.
        shifts, _, _ = fleet_pair_shifts(table, spreads, only, np.zeros(len(names), dtype=bool))
        read = shifts[paired & np.isfinite(shifts)]
        counts[name] = int(read.size)
        middle = float(np.median(read)) if read.size else math.nan
        scales[name] = middle / math.log(2.0) if read.size >= MIN_PAIRS and middle > 0 else math.nan
    return FleetPrior(
        task_spreads={n: float(unit_spreads[k]) for k, n in enumerate(names)},
        allowance_scale=max(float(np.median(pair_distances)) / math.log(2.0), 1e-12),
        centre={n: float(np.nanmedian(table[:, k])) for k, n in enumerate(names)},
        n_axes=len({k for pair in pairs for k in pair}),
        n_pairs=int(pair_distances.size),
        indicator_scales=scales,
        indicator_pairs=counts,
    )


def wrong_matches(
    signatures: Sequence[Sequence[float] | NDArray[np.float64]],
    tasks: Sequence[int],
    references: Sequence[NDArray[np.float64] | None],
    envelopes: Sequence[float],
    axis_tasks: Sequence[int],
) -> int:
    """How many captures are held by the envelope of a fleet axis of another task.

    Parameters
    ----------
    signatures : sequence of array-like of shape (6,)
        The captures' task signatures.
    tasks : sequence of int
        The task each capture ran.
    references, envelopes : sequence
        Each fleet axis's ``task_reference_`` (or None) and ``task_envelope_``.
    axis_tasks : sequence of int
        The task each fleet axis runs.

    Returns
    -------
    int
        The captures held by at least one axis whose task is not theirs.

    Examples
    --------
    >>> import numpy as np
    >>> reference = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5])
    >>> other = reference * [1.5, 1, 1, 1, 1, 1]
    >>> captures = [reference, reference * [1.25, 1, 1, 1, 1, 1], other]  # 2nd: by axis 1
    >>> wrong_matches(captures, [0, 0, 1], [reference, other], [0.1, 0.2], [0, 1])
    1
    """
    count = 0
    for signature, task in zip(signatures, tasks, strict=True):
        held = holding_axes(signature, references, envelopes)
        count += any(axis_tasks[k] != task for _, k in held)
    return count


@dataclass(frozen=True)
class NearestTaskScore:
    """One capture scored by the variant.

    Attributes
    ----------
    ratio : float
        Distance in units of its threshold (over at 1; NaN where none).
    alarm : bool
    matched : int or None
        The fleet axis it was scored against; None: scored as the default.
    """

    ratio: float
    alarm: bool
    matched: int | None


def score_nearest(
    readings: Readings,
    own: IndicatorModel,
    own_index: int | None,
    fleet: Sequence[IndicatorModel],
    unit_models: Sequence[IndicatorModel] | None,
    exclude: Collection[int] = (),
    default: IndicatorAssessment | None = None,
) -> NearestTaskScore:
    """Score a capture with the nearest-task rule (module docstring).

    Parameters
    ----------
    readings : Readings
        The capture's readings.
    own : IndicatorModel
        The baseline's model, with its fleet prior (the default).
    own_index : int or None
        Its position in ``fleet`` (None when it is not a fleet axis, as Robot A).
    fleet : sequence of IndicatorModel
        The fleet's fitted models (their task references and envelopes).
    unit_models : sequence of IndicatorModel or None
        Per fleet axis, a model fitted on its readings with the unit-change prior
        (:func:`unit_change_prior`); None: no such prior, the default for every capture.
    exclude : collection of int, default=()
        Fleet axes not matched ("task not in the fleet").
    default : IndicatorAssessment, optional
        ``own.assess_readings(readings)`` when the caller has it already (not made again).

    Returns
    -------
    NearestTaskScore
    """
    if default is None:
        default = own.assess_readings(readings)
    fallback = NearestTaskScore(default.distance / default.threshold, default.alarm, None)
    if unit_models is None:
        return fallback
    signature = np.asarray(readings.signature, dtype=np.float64)
    if own.task_reference_ is not None and holding_axes(
        signature, [own.task_reference_], [own.task_envelope_]
    ):
        return fallback
    skip = {*exclude, *(() if own_index is None else (own_index,))}
    held = holding_axes(
        signature, [m.task_reference_ for m in fleet], [m.task_envelope_ for m in fleet], skip
    )
    if not held:
        return fallback
    nearest = held[0][1]
    scored = unit_models[nearest].assess_readings(readings)
    return NearestTaskScore(scored.distance / scored.threshold, scored.alarm, nearest)


def extra_unit_index(u: int, task: int, n_tasks: int) -> int:
    """The :func:`~axiswatch.datasets._family.draw_unit` index of unit ``u`` (``u >= 1``) of
    ``task`` in the study's fleet: ``u * (n_tasks + 1) + task``.

    Unit 0 of task ``t`` is unit ``t`` and Robot A unit ``n_tasks``
    (:func:`~axiswatch_lab._transfer.fleet_units`), so each block of ``n_tasks + 1`` indices
    holds one unit per task and ``u = 1`` gives the two-unit study's second units
    (``n_tasks + 1 + t``); no two axes and Robot A share an index.

    Parameters
    ----------
    u : int
        Which unit of the task, from 1.
    task : int
        The task, ``0 .. n_tasks - 1``.
    n_tasks : int
        The robot's tasks.

    Returns
    -------
    int

    Examples
    --------
    >>> [extra_unit_index(u, t, 6) for u in (1, 2) for t in (0, 5)]
    [7, 12, 14, 19]
    """
    if not (u >= 1 and 0 <= task < n_tasks):
        raise ValueError(
            f"Expected u >= 1 and 0 <= task < n_tasks; got u={u}, task={task}, n_tasks={n_tasks}."
        )
    return u * (n_tasks + 1) + task


def robot_nearest_task(
    seed: int, design: TransferDesign = FAST_DESIGN, units_per_task: int = 2
) -> dict[str, object]:
    """The study on one robot (module docstring); one JSON-ready record.

    ``units_per_task`` distinct units run each task in the fleet (default 2; unit ``u >= 1`` of
    task ``t`` is :func:`extra_unit_index`), all pooled into the default's fleet prior.

    Columns: ``default_`` / ``nearest_`` / ``absent_`` (the variant, task not in the fleet)
    ``far99``, ``auroc_<fault>``, ``dr99_<fault>`` (:func:`~axiswatch_lab._transfer.paired_measures`
    on distances in units of their threshold), ``robot_a_false_alarms_default`` /
    ``_nearest`` (and ``robot_a_rerouted``), ``same_task_pairs`` (and ``pairs_across_tasks``:
    those whose axes run different tasks), ``share_rerouted``, ``share_wrong_match`` (held by
    an axis of another task), ``share_wrong_nearest`` (rerouted to an axis of another task),
    ``absent_share_rerouted`` (of the captures of another task than the baseline's, with their
    task's axes left out).

    Raises
    ------
    ValueError
        With ``design.order_lines``: the unit-change prior does not read the order lines; with
        ``units_per_task < 2``: no same-task pairs.
    """
    if units_per_task < 2:
        raise ValueError(
            "The nearest-task study needs at least two units per task (its same-task pairs). "
            f"Got units_per_task={units_per_task} instead."
        )
    if design.order_lines:
        raise ValueError(
            "The nearest-task study takes no order lines (design.order_lines=False): the "
            "unit-change prior leaves them out. Got design.order_lines=True instead."
        )
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)

    def new_model() -> IndicatorModel:
        return IndicatorModel(profile, whole_moves=design.whole_moves)

    read = new_model().readings
    n_tasks = len(robot.tasks)
    units = fleet_units(robot, design)  # fleet axis t is unit t, Robot A unit n_tasks
    fitting = [(t, taken) for t, taken in fleet_readings(robot, read, design, units=units).items()]
    for u in range(1, units_per_task):
        others = [
            draw_unit(robot, extra_unit_index(u, t, n_tasks), design.unit_spread)
            for t in range(n_tasks)
        ]
        prefix = "second" if u == 1 else f"unit{u}-"  # "second": the two-unit study's seeds
        fitting += [
            (
                t,
                [
                    read(others[t].capture(t, seed=f"{prefix}{k}"))
                    for k in range(design.n_calibration + 1)
                ],
            )
            for t in range(n_tasks)
        ]
    fleet: list[IndicatorModel] = []
    axis_tasks: list[int] = []
    first_of: dict[int, int] = {}
    unfitted = 0
    for k, (t, taken) in enumerate(fitting):
        try:
            model = new_model().fit_readings(taken)
        except CalibrationError:
            unfitted += 1
            continue
        if k < n_tasks:
            first_of[t] = len(fleet)
        fleet.append(model)
        axis_tasks.append(t)
    prior = pool_fleet(fleet)
    for k, model in enumerate(fleet):
        model.use_fleet(prior, check_against=pool_fleet_without(fleet, k))
    references = [m.task_reference_ for m in fleet]
    envelopes = [m.task_envelope_ for m in fleet]
    pairs = same_task_pairs(references, envelopes)
    unit_prior = unit_change_prior([m.centre_ for m in fleet], [m.within_ for m in fleet], pairs)
    unit_models = (
        None
        if unit_prior is None
        else [new_model().fit_readings(m.fit_readings_).use_fleet(unit_prior) for m in fleet]
    )
    bases = sorted(first_of)
    by_unit: dict[SimulatedRobot, dict[tuple[int, str], list[Readings]]] = {}
    for b in bases:
        if units[b] not in by_unit:
            by_unit[units[b]] = paired_readings(units[b], read, design)
    default: dict[tuple[int, tuple[int, str]], list[float]] = {}
    nearest: dict[tuple[int, tuple[int, str]], list[float]] = {}
    absent: dict[tuple[int, tuple[int, str]], list[float]] = {}
    rerouted, wrong_nearest, absent_rerouted, absent_total = 0, 0, 0, 0
    signatures: list[NDArray[np.float64]] = []
    signature_tasks: list[int] = []
    for b in bases:
        index = first_of[b]
        own = fleet[index]
        for key, taken in by_unit[units[b]].items():
            t = key[0]
            left_out = {k for k, task in enumerate(axis_tasks) if task == t and k != index}
            default[(b, key)], nearest[(b, key)], absent[(b, key)] = [], [], []
            for r in taken:
                plain = own.assess_readings(r)
                default[(b, key)].append(plain.distance / plain.threshold)
                score = score_nearest(r, own, index, fleet, unit_models, default=plain)
                nearest[(b, key)].append(score.ratio)
                rerouted += score.matched is not None
                wrong_nearest += score.matched is not None and axis_tasks[score.matched] != t
                gone = score_nearest(
                    r, own, index, fleet, unit_models, exclude=left_out, default=plain
                )
                absent[(b, key)].append(gone.ratio)
                if t != b:
                    absent_total += 1
                    absent_rerouted += gone.matched is not None
                signatures.append(np.asarray(r.signature, dtype=np.float64))
                signature_tasks.append(t)
    n_scored = len(signatures)
    record: dict[str, object] = {
        "robot": robot.name,
        "axes_not_fitted": unfitted,
        "same_task_pairs": len(pairs),
        "pairs_across_tasks": sum(axis_tasks[a] != axis_tasks[b] for a, b in pairs),
        "unit_prior": unit_prior is not None,
        "share_rerouted": rerouted / n_scored,
        "share_wrong_match": wrong_matches(
            signatures, signature_tasks, references, envelopes, axis_tasks
        )
        / n_scored,
        "share_wrong_nearest": wrong_nearest / n_scored,
        "absent_share_rerouted": absent_rerouted / absent_total if absent_total else math.nan,
    }
    for name, distances in (("default", default), ("nearest", nearest), ("absent", absent)):
        record.update({f"{name}_{k}": v for k, v in paired_measures(distances, bases).items()})
    record.update(_robot_a(units[n_tasks], new_model, prior, fleet, unit_models, design, read))
    return record


def _robot_a(
    unit: SimulatedRobot,
    new_model: Callable[[], IndicatorModel],
    prior: FleetPrior,
    fleet: Sequence[IndicatorModel],
    unit_models: Sequence[IndicatorModel] | None,
    design: TransferDesign,
    read: Callable[[Capture], Readings],
) -> dict[str, object]:
    """Robot A's false-alarm days, default and variant, on the same days (the transfer study's
    Robot A: baseline day 1, calibration days ``2 .. n_calibration + 1``, the task changing)."""
    taken = robot_a_readings(unit, read, design.robot_a_days)
    model = new_model().fit_readings(taken[: design.n_calibration + 1]).use_fleet(prior)
    days = taken[design.n_calibration + 1 :]
    plain = [model.assess_readings(r) for r in days]
    scores = [
        score_nearest(r, model, None, fleet, unit_models, default=p)
        for r, p in zip(days, plain, strict=True)
    ]
    return {
        "robot_a_false_alarms_default": sum(p.alarm for p in plain),
        "robot_a_false_alarms_nearest": sum(s.alarm for s in scores),
        "robot_a_rerouted": sum(s.matched is not None for s in scores),
        "robot_a_test_days": len(days),
    }


def _one(args: tuple[int, TransferDesign, int]) -> dict[str, object]:
    # Parallelism is across robots; a multi-threaded BLAS inside each only fights for the cores.
    with threadpool_limits(1):
        return robot_nearest_task(*args)


def nearest_task_study(
    seeds: Sequence[int],
    design: TransferDesign = FAST_DESIGN,
    *,
    workers: int = 1,
    units_per_task: int = 2,
) -> pd.DataFrame:
    """:func:`robot_nearest_task` on every seed (in ``workers`` processes); one row per robot."""
    rows: dict[int, dict[str, object]] = {}
    tasks = [(s, design, units_per_task) for s in seeds]
    for index, record in parallel_map(_one, tasks, workers=workers):
        rows[index] = record
    return pd.DataFrame([rows[i] for i in sorted(rows)])
