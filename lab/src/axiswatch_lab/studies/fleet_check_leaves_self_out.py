"""The fleet check of a baseline: against the other axes (leave-self-out) or the whole fleet.

Research study (lab/docs/decision-log.md, "Through the monitor", "A worn axis in
the fleet"). Each axis's :class:`~axiswatch.IndicatorModel` is fitted as the monitor fits it
(:func:`~axiswatch.indicators._axis.fit_indicator_baseline` on the baseline and ``K = 5``
calibration captures) and its baseline is checked against its fleet two ways:

* ``leave-self-out``: what the monitor does (:func:`~axiswatch.indicators._axis.with_fleet`):
  against the prior of the other axes when 3 remain, else of all;
* ``itself included``: the rule before: against the prior of all the axes, the checked one
  included.

Two candidates for the check (docs/evaluation.md, "The fleet check of a baseline at a task
unlike its fleet's"), each against the other axes as ``leave-self-out``:

* ``drive friction``: the two drive loads compared as their mean (:func:`drive_friction_view`,
  :func:`drive_friction_prior`, :func:`drive_friction_difference`);
* ``growth only``: every indicator one-sided, only a centre above the fleet's counts;
* ``inverse variance`` (docs/evaluation.md, "An inverse-variance mean of the drive loads in the
  fleet check"): as ``drive friction`` with the loads weighted by the inverse of the other
  axes' typical within-task variances (:func:`inverse_variance_weight`).

A flag is a distance over 1 (the monitor's ``fleet_check_``, "differs from its fleet's", for the
rule it uses: ``monitor`` in each row).

* **Robots** (``draw_robot``; development 0-7, held-out 1000-1011): one fleet of ``n_axes`` axes
  of one robot, no profile, 6 fitting captures each. ``tasks``: axis ``a`` on task
  ``a mod n_tasks``, all healthy (a flag is a healthy axis listed, for a task unlike the
  others'); ``worn``: every axis on task 0, axis 0 with a friction fault of severity 1.0 from
  its first capture (as ``tests/monitor/test_monitor_indicators.py``); ``worn backlash`` and
  ``worn friction 0.6``: the same with a backlash fault of severity 1.0, a friction fault of 0.6.
* **Hydraulic actuators** (``../shared/data``): the four units as one fleet, the first 6 records
  of each; act3 has gear damage from its first record.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from axiswatch import IndicatorModel
from axiswatch.datasets import Fault, draw_robot
from axiswatch_lab._product import (
    MIN_AXES,
    FleetPrior,
    Readings,
    _task_change_scales,
    fit_indicator_baseline,
    fleet_difference,
    pool_fleet,
    pool_fleet_without,
    read_axis_indicators,
    with_fleet,
)

__all__ = [
    "SCENARIOS",
    "drive_friction_difference",
    "drive_friction_prior",
    "drive_friction_view",
    "growth_difference",
    "hydraulic_fleet_checks",
    "inverse_variance_difference",
    "inverse_variance_weight",
    "robot_fleet_checks",
]

_FITTING = 6  # the baseline and K = 5
_PERCENTILE = 99.0


_DRIVE_LOADS = ("load_forward", "load_backward")
#: Where the lab keeps the loads' mean: the product pools and scores only the indicators it
#: declares, and ``load_forward`` is declared as the mean is (two-sided, in the loads' unit).
_MEAN_LOAD = "load_forward"


def drive_friction_view(
    centre: Mapping[str, float], within: Mapping[str, float], forward_weight: float = 0.5
) -> tuple[dict[str, float], dict[str, float]]:
    """An axis's centre and within-task spreads with its two drive loads replaced by their
    weighted mean.

    A direction's drive load is the mean of ``torque x sign(speed)`` over its steady motion:
    friction plus the mean gravity and payload torque there, ``F + G`` forward and ``F - G``
    backward. Another task (a payload, a stroke at another height) moves ``G``, the two
    directions by opposite amounts; wear moves ``F``, both up. Their weighted mean
    ``w F_f + (1 - w) F_b = F + (2 w - 1) G`` keeps the whole wear whatever ``w`` and drops the
    task's gravity and payload exactly at ``w = 1/2`` (when both directions cover the same
    positions at the same speeds), a fraction ``|2 w - 1|`` of it remaining otherwise.

    Parameters
    ----------
    centre, within : mapping of str to float
        An axis's centre and within-task spread ``s_w`` per indicator.
    forward_weight : float in [0, 1], default 0.5
        ``w``, the forward load's weight (the candidate ``drive friction``: 0.5; ``inverse
        variance``: :func:`inverse_variance_weight` of the fleet).

    Returns
    -------
    (dict of str to float, dict of str to float)
        Copies without the two loads and with their mean under ``load_forward`` (centre
        ``w c_f + (1 - w) c_b``, spread ``sqrt(w^2 s_f^2 + (1 - w)^2 s_b^2)``, the directions'
        readings taken as independent). An axis that gives one load only (one-way strokes)
        keeps a lone ``load_backward`` and drops a lone ``load_forward``: in a fleet of two-way
        axes fewer than 3 others give it alone, so the candidate as written in
        docs/evaluation.md would not check it either.

    Examples
    --------
    >>> drive_friction_view({"load_forward": 5.0, "load_backward": 1.0, "coulomb_friction": 2.0},
    ...                     {"load_forward": 0.3, "load_backward": 0.4, "coulomb_friction": 0.1})
    ({'coulomb_friction': 2.0, 'load_forward': 3.0}, {'coulomb_friction': 0.1, 'load_forward': 0.25})
    >>> centre, within = drive_friction_view({"load_forward": 5.0, "load_backward": 1.0},
    ...                                      {"load_forward": 0.3, "load_backward": 0.4}, 0.75)
    >>> centre["load_forward"], round(within["load_forward"], 4)
    (4.0, 0.2462)
    """
    out_centre = {n: v for n, v in centre.items() if n not in _DRIVE_LOADS}
    out_within = {n: v for n, v in within.items() if n not in _DRIVE_LOADS}
    forward, backward = _DRIVE_LOADS
    gives = {n: n in centre and n in within for n in _DRIVE_LOADS}
    if all(gives.values()):
        w = forward_weight
        out_centre[_MEAN_LOAD] = w * centre[forward] + (1.0 - w) * centre[backward]
        out_within[_MEAN_LOAD] = math.hypot(w * within[forward], (1.0 - w) * within[backward])
    elif gives[backward]:
        out_centre[backward], out_within[backward] = centre[backward], within[backward]
    return out_centre, out_within


def inverse_variance_weight(models: Sequence[IndicatorModel]) -> float:
    """The forward load's weight ``w`` for :func:`drive_friction_view`: inverse-variance, from
    the fleet's typical within-task spreads of the two loads.

    ``w = m_b^2 / (m_f^2 + m_b^2)`` with ``m_f``, ``m_b`` the median within-task spreads of the
    forward and backward load over the models that read both: one weight for every axis, so
    that all are compared on the same combination of the loads (each axis's own spreads, from
    its 6 captures, would give each axis another share ``2 w - 1`` of its gravity term, and let
    a worn axis's own noise set the weight it is checked with).

    Parameters
    ----------
    models : sequence of IndicatorModel
        The fleet the weight is read from (the other axes, in the check).

    Returns
    -------
    float in [0, 1]
        0.5 (equal weights, the plain mean) when fewer than 3 models read both loads or their
        spreads are not positive.

    Examples
    --------
    >>> fleet = []
    >>> for spreads in ((0.6, 0.3), (0.4, 0.2), (0.5, 0.25)):
    ...     model = IndicatorModel()
    ...     model.within_ = dict(zip(("load_forward", "load_backward"), spreads))
    ...     fleet.append(model)
    >>> inverse_variance_weight(fleet)  # 0.25^2 / (0.5^2 + 0.25^2)
    0.2
    """
    both = [m.within_ for m in models if all(n in m.within_ for n in _DRIVE_LOADS)]
    if len(both) < MIN_AXES:
        return 0.5
    forward, backward = (float(np.median([w[n] for w in both])) for n in _DRIVE_LOADS)
    total = forward**2 + backward**2
    if not (math.isfinite(total) and total > 0):
        return 0.5
    return backward**2 / total


def drive_friction_prior(
    models: Sequence[IndicatorModel], index: int, forward_weight: float = 0.5
) -> FleetPrior | None:
    """:func:`~axiswatch.indicators._fleet.pool_fleet_without` of the models seen through
    :func:`drive_friction_view`: what the ``index``-th axis is checked against."""
    viewed = []
    for model in models:
        seen = copy.copy(model)  # shares the fitted readings; only the two dicts are replaced
        seen.centre_, seen.within_ = drive_friction_view(
            model.centre_, model.within_, forward_weight
        )
        viewed.append(seen)
    return pool_fleet_without(viewed, index)


def drive_friction_difference(
    model: IndicatorModel,
    models: Sequence[IndicatorModel],
    index: int,
    percentile: float,
    forward_weight: float = 0.5,
) -> float:
    """The candidate ``drive friction``: the ``index``-th model's :func:`drive_friction_view`
    against :func:`drive_friction_prior` (the fleet with itself included, each load on its own,
    with fewer than 3 others)."""
    prior = drive_friction_prior(models, index, forward_weight)
    if prior is None:
        return fleet_difference(model.centre_, model.within_, pool_fleet(models), percentile)[0]
    view = drive_friction_view(model.centre_, model.within_, forward_weight)
    return fleet_difference(*view, prior, percentile)[0]


def inverse_variance_difference(
    model: IndicatorModel, models: Sequence[IndicatorModel], index: int, percentile: float
) -> float:
    """The candidate ``inverse variance``: :func:`drive_friction_difference` with the forward
    load weighted by :func:`inverse_variance_weight` of the other axes (the checked axis's
    own spreads do not set the weight it is checked with)."""
    others = [*models[:index], *models[index + 1 :]]
    weight = inverse_variance_weight(others)
    return drive_friction_difference(model, models, index, percentile, weight)


def growth_difference(
    centre: Mapping[str, float],
    within: Mapping[str, float],
    prior: FleetPrior,
    percentile: float,
) -> float:
    """:func:`~axiswatch.indicators._fleet.fleet_difference` with every indicator one-sided:
    only a centre above the fleet's counts (the candidate ``growth only``)."""
    _, shifts = fleet_difference(centre, within, prior, percentile)
    scales = _task_change_scales({n: within[n] for n in shifts}, prior, percentile)
    grown = [max((centre[n] - prior.centre[n]) / scales[n], 0.0) for n in shifts]
    return max(grown) if grown else math.nan


def _scoring(model: IndicatorModel) -> list[NDArray[np.float64]]:
    """What a capture's decision depends on (the fleet check is not part of it)."""
    scales = model.task_change_scales_
    allowances = model.allowances_
    return [
        np.array([model.threshold_, model.own_threshold_]),
        np.array(model.loo_distances_),
        np.array(model.own_loo_distances_),
        np.array([scales[n] for n in sorted(scales)]),
        np.array([allowances[n] for n in sorted(allowances)]),
    ]


def _checks(fitting: dict[str, list[Readings]], health: dict[str, str]) -> list[dict[str, object]]:
    """One row per axis and rule: its distance from its fleet, whether it is flagged, and
    whether the monitor (:func:`with_fleet`) flags it and scores as without any check."""
    baselines = [
        fit_indicator_baseline(
            read, [f"{a}/{k}" for k in range(len(read))], [""] * len(read), percentile=_PERCENTILE
        )
        for a, read in fitting.items()
    ]
    models = [b.model for b in baselines]
    prior = pool_fleet(models)
    monitor = [b.model for b in with_fleet(baselines)]
    rows: list[dict[str, object]] = []
    for k, axis in enumerate(fitting):
        model = models[k]
        others = pool_fleet_without(models, k)
        # The same model scored with the fleet's prior and no other check than with itself
        # included: any difference from the monitor's would be the check changing a decision.
        plain = copy.deepcopy(model).use_fleet(prior)
        unchanged = all(
            np.array_equal(a, b, equal_nan=True)
            for a, b in zip(_scoring(plain), _scoring(monitor[k]), strict=True)
        )
        against = prior if others is None else others
        distances = {
            "itself included": fleet_difference(model.centre_, model.within_, prior, _PERCENTILE)[
                0
            ],
            "leave-self-out": fleet_difference(model.centre_, model.within_, against, _PERCENTILE)[
                0
            ],
            "drive friction": drive_friction_difference(model, models, k, _PERCENTILE),
            "inverse variance": inverse_variance_difference(model, models, k, _PERCENTILE),
            "growth only": growth_difference(model.centre_, model.within_, against, _PERCENTILE),
        }
        for rule, distance in distances.items():
            rows.append(
                {
                    "axis": axis,
                    "health": health[axis],
                    "rule": rule,
                    "flagged": math.isfinite(distance) and distance > 1.0,
                    "distance": distance,
                    "monitor": monitor[k].fleet_check_ is not None,
                    "scoring_unchanged": unchanged,
                    "check": monitor[k].fleet_check_ or "",
                }
            )
    return rows


#: The designs of the study: (name, the worn axis's fault; None: every axis healthy, each on
#: its own task).
SCENARIOS: tuple[tuple[str, Fault | None], ...] = (
    ("tasks", None),
    ("worn", Fault("friction", 1.0)),
    ("worn backlash", Fault("backlash", 1.0)),
    ("worn friction 0.6", Fault("friction", 0.6)),
)


def robot_fleet_checks(seed: int, n_axes: int) -> list[dict[str, object]]:
    """The fleets of robot ``seed`` (:data:`SCENARIOS`, the module docstring)."""
    robot = draw_robot(seed)
    rows: list[dict[str, object]] = []
    for scenario, wear in SCENARIOS:
        fitting: dict[str, list[Readings]] = {}
        health: dict[str, str] = {}
        for a in range(n_axes):
            task = a % len(robot.tasks) if wear is None else 0
            fault = wear if a == 0 else None
            fitting[f"a{a}"] = [
                read_axis_indicators(robot.capture(task, seed=f"{a}/{day}", fault=fault), None)
                for day in range(_FITTING)
            ]
            health[f"a{a}"] = "worn" if fault is not None else "healthy"
        rows += [
            {"seed": seed, "n_axes": n_axes, "scenario": scenario, **row}
            for row in _checks(fitting, health)
        ]
    return rows


def hydraulic_fleet_checks(data_root: Path) -> list[dict[str, object]]:
    """The four hydraulic actuators as one fleet; empty when the data set is absent."""
    from axiswatch_lab._transfer import hydraulic_captures

    folder = data_root / "hydraulic_actuator"
    if not folder.is_dir():
        return []
    captures = hydraulic_captures(folder)
    reader = IndicatorModel()
    health = {a: h for a, h, _ in captures}
    fitting = {
        a: [reader.readings(c) for u, _, c in captures if u == a][:_FITTING] for a in sorted(health)
    }
    return [{"dataset": "hydraulic_actuator", **row} for row in _checks(fitting, health)]


def main(out: Path, data_root: Path, seeds: tuple[int, ...], sizes: tuple[int, ...]) -> None:
    """Write ``robots.csv`` and ``hydraulic.csv`` under ``out`` and print the flags."""
    out.mkdir(parents=True, exist_ok=True)
    robots = pd.DataFrame([r for n in sizes for s in seeds for r in robot_fleet_checks(s, n)])
    robots.to_csv(out / "robots.csv", index=False)
    hydraulic = pd.DataFrame(hydraulic_fleet_checks(data_root))
    hydraulic.to_csv(out / "hydraulic.csv", index=False)
    robots["group"] = robots["seed"].map(lambda s: "development" if s < 1000 else "held-out")
    print(
        robots.groupby(["n_axes", "scenario", "group", "rule", "health"])["flagged"]
        .agg(["sum", "count"])
        .to_string()
    )
    flagged = robots[robots["flagged"]]
    print(flagged[["seed", "n_axes", "scenario", "rule", "axis", "health", "distance"]].to_string())
    print(
        "monitor's flags:",
        int(robots.drop_duplicates(["seed", "n_axes", "scenario", "axis"])["monitor"].sum()),
        "; scoring unchanged by the check on every axis:",
        bool(robots["scoring_unchanged"].all()),
    )
    if not hydraulic.empty:
        print(hydraulic.drop(columns="dataset").to_string())


if __name__ == "__main__":
    # python -m axiswatch_lab.studies.fleet_check_leaves_self_out OUT DATA_ROOT [SEED ...]  (fleets of 4 and 6 axes)
    import sys

    chosen = tuple(int(s) for s in sys.argv[3:]) or (*range(8), *range(1000, 1012))
    main(Path(sys.argv[1]), Path(sys.argv[2]), chosen, (4, 6))
