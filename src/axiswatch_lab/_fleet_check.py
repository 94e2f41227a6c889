"""The fleet check of a baseline: against the other axes (leave-self-out) or the whole fleet.

Research study of issue 13, item 2 (docs/evaluation.md, "Through the monitor", "A worn axis in
the fleet"). Each axis's :class:`~axiswatch.IndicatorModel` is fitted as the monitor fits it
(:func:`~axiswatch.monitor._indicators.fit_indicator_baseline` on the baseline and ``K = 5``
calibration captures) and its baseline is checked against its fleet two ways:

* ``leave-self-out``: what the monitor does (:func:`~axiswatch.monitor._indicators.with_fleet`):
  against the prior of the other axes when 3 remain, else of all;
* ``itself included``: the rule before: against the prior of all the axes, the checked one
  included.

Nothing is chosen here; a flag is a non-empty ``fleet_check_`` ("differs from its fleet's").

* **Robots** (``draw_robot``; development 0-7, held-out 1000-1011): one fleet of ``n_axes`` axes
  of one robot, no profile, 6 fitting captures each. ``tasks``: axis ``a`` on task
  ``a mod n_tasks``, all healthy (a flag is a healthy axis listed, for a task unlike the
  others'); ``worn``: every axis on task 0, axis 0 with a friction fault of severity 1.0 from
  its first capture (as ``tests/test_monitor_indicators.py``).
* **Hydraulic actuators** (``../shared/data``): the four units as one fleet, the first 6 records
  of each; act3 has gear damage from its first record.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pandas as pd

from axiswatch._indicator_model import (
    IndicatorModel,
    fleet_difference,
    pool_fleet,
    pool_fleet_without,
)
from axiswatch._readings import Readings
from axiswatch.datasets import Fault, draw_robot
from axiswatch.monitor._indicators import fit_indicator_baseline, read_axis_indicators, with_fleet

__all__ = ["hydraulic_fleet_checks", "robot_fleet_checks"]

_FITTING = 6  # the baseline and K = 5
_PERCENTILE = 99.0


def _checks(fitting: dict[str, list[Readings]], health: dict[str, str]) -> list[dict[str, object]]:
    """One row per axis and rule: whether its baseline is flagged, and its distance."""
    baselines = [
        fit_indicator_baseline(
            read, [f"{a}/{k}" for k in range(len(read))], [""] * len(read), percentile=_PERCENTILE
        )
        for a, read in fitting.items()
    ]
    models = [b.model for b in baselines]
    prior = pool_fleet(models)
    included = [copy.deepcopy(m).use_fleet(prior) for m in models]
    checked = [b.model for b in with_fleet(baselines)]
    rows: list[dict[str, object]] = []
    for k, axis in enumerate(fitting):
        others = pool_fleet_without(models, k)
        for rule, model, against in (
            ("itself included", included[k], prior),
            ("leave-self-out", checked[k], prior if others is None else others),
        ):
            distance, _ = fleet_difference(model.centre_, model.within_, against, _PERCENTILE)
            rows.append(
                {
                    "axis": axis,
                    "health": health[axis],
                    "rule": rule,
                    "flagged": model.fleet_check_ is not None,
                    "distance": distance,
                    "check": model.fleet_check_ or "",
                }
            )
    return rows


def robot_fleet_checks(seed: int, n_axes: int) -> list[dict[str, object]]:
    """The ``tasks`` and ``worn`` fleets of robot ``seed`` (see the module docstring)."""
    robot = draw_robot(seed)
    rows: list[dict[str, object]] = []
    for scenario in ("tasks", "worn"):
        fitting: dict[str, list[Readings]] = {}
        health: dict[str, str] = {}
        for a in range(n_axes):
            task = a % len(robot.tasks) if scenario == "tasks" else 0
            fault = Fault("friction", 1.0) if scenario == "worn" and a == 0 else None
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
    if not hydraulic.empty:
        print(hydraulic.drop(columns="dataset").to_string())


if __name__ == "__main__":
    # python -m axiswatch_lab._fleet_check OUT DATA_ROOT [SEED ...]  (fleets of 4 and 6 axes)
    import sys

    chosen = tuple(int(s) for s in sys.argv[3:]) or (*range(8), *range(1000, 1012))
    main(Path(sys.argv[1]), Path(sys.argv[2]), chosen, (4, 6))
