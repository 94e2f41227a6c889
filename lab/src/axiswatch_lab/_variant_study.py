"""One set of captures, several ways to read and score them: the harness of the variant studies.

The studies of a reading or scoring candidate against the product
(``studies.drive_loads_from_whole_moves``, ``studies.friction_standard_errors``,
``studies.friction_only_where_identified``) take every capture once, keep what each
variant needs from it (its readings, and whatever else it scores with), and score each variant
from the same captures:

* the **transfer design** (:mod:`axiswatch_lab._transfer`): per robot the paired ``far99`` /
  AUROC / ``dr99`` per fault against healthy captures of other tasks, the share scored, and
  Robot A's false-alarm days, each variant's models fitted as the product fits them
  (:func:`axiswatch_lab.studies.allowance_per_indicator._models`);
* the **monitor scenarios** of :mod:`axiswatch_lab.studies.task_envelope_factor`, scored by the model
  directly: 4 axes on their own tasks, then other tasks (``healthy``) or axis 0 with a friction
  fault of severity 0.6 (``fault``).

A :class:`Variant` says which readings of a taken capture its models are fitted on, and how a
capture is scored (by default as the product scores it: ``assess_readings``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar, cast

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._product import Readings, read_indicators
from axiswatch_lab._transfer import (
    TransferDesign,
    _profile,
    fleet_readings,
    paired_measures,
    paired_readings,
    robot_a_readings,
)
from axiswatch_lab.studies.allowance_per_indicator import _models, variant_summary
from axiswatch_lab.studies.task_envelope_factor import _FIT, scenario_days

__all__ = ["Variant", "main", "study"]

T = TypeVar("T")

#: What a study keeps of a capture, from the product's reader: ``take(read)(capture)``.
Take = Callable[[Callable[[Capture], Readings]], Callable[[Capture], T]]


@dataclass(frozen=True)
class Variant(Generic[T]):
    """A way to read and score captures taken once for every variant of a study.

    Attributes
    ----------
    name : str
    readings : callable
        A taken capture -> the readings this variant's models are fitted on and read.
    score : callable or None
        ``(model, the model's fitting captures as taken, a taken capture) -> (distance in units
        of the model's threshold, over)``. None: the product's, ``assess_readings`` of
        ``readings`` (its distance over ``threshold_``, and its ``alarm``).

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> read = [IndicatorModel().readings(draw_robot(0).capture(0, seed=k)) for k in range(7)]
    >>> model = IndicatorModel().fit_readings(read[:6])
    >>> distance, over = Variant("current", lambda r: r).assess(model, read[:6], read[6])
    >>> distance == model.assess_readings(read[6]).distance / model.threshold_
    True
    """

    name: str
    readings: Callable[[T], Readings]
    score: Callable[[IndicatorModel, Sequence[T], T], tuple[float, bool]] | None = None

    def assess(self, model: IndicatorModel, fitting: Sequence[T], taken: T) -> tuple[float, bool]:
        """``(distance in threshold units, over)`` of one taken capture."""
        if self.score is not None:
            return self.score(model, fitting, taken)
        verdict = model.assess_readings(self.readings(taken))
        return verdict.distance / model.threshold_, verdict.alarm


def _transfer_rows(
    seed: int, design: TransferDesign, variants: Sequence[Variant[T]], take: Take[T]
) -> list[dict[str, object]]:
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    # The transfer helpers are typed for readers of Readings; here they carry whatever the
    # study takes of a capture (they only store what the reader returns).
    read: Any = take(IndicatorModel(profile).readings)
    fits = cast(dict[int, list[T]], fleet_readings(robot, read, design))
    tests = cast(dict[Any, list[T]], paired_readings(robot, read, design))
    robot_a = cast(list[T], robot_a_readings(robot, read, design.robot_a_days))
    n_fit = design.n_calibration + 1
    rows = []
    for variant in variants:
        models, prior = _models(
            {t: [variant.readings(x) for x in f] for t, f in fits.items()}, profile, 99.0
        )
        bases = sorted(models)
        dist = {
            (b, key): [variant.assess(models[b], fits[b], x)[0] for x in taken]
            for b in bases
            for key, taken in tests.items()
        }
        row: dict[str, object] = {"robot": robot.name, "variant": variant.name}
        row.update(paired_measures(dist, bases))
        every = [d for v in dist.values() for d in v]
        row["share_scored"] = float(np.mean([math.isfinite(d) for d in every]))
        model_a = IndicatorModel(profile).fit_readings(
            [variant.readings(x) for x in robot_a[:n_fit]]
        )
        model_a.use_fleet(prior)
        over = [variant.assess(model_a, robot_a[:n_fit], x)[1] for x in robot_a[n_fit:]]
        row["robot_a_false_alarms"] = int(sum(over))
        row["robot_a_test_days"] = len(over)
        rows.append(row)
    return rows


def _scenario(
    seed: int, scenario: str, take: Take[T]
) -> list[tuple[int, list[T], list[tuple[T, bool]]]]:
    """:func:`axiswatch_lab.studies.task_envelope_factor._scenario`, every capture taken by ``take``."""
    robot = draw_robot(seed)
    read = take(read_indicators)
    out: dict[int, tuple[int, list[T], list[tuple[T, bool]]]] = {}
    for a, day, task, fault in scenario_days(scenario):
        _, fitting, monitored = out.setdefault(a, (a, [], []))
        x = read(robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}"))
        if day < _FIT:
            fitting.append(x)
        else:
            monitored.append((x, fault is not None))
    return list(out.values())


def _monitor_rows(
    seed: int, variants: Sequence[Variant[T]], take: Take[T]
) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for scenario in ("healthy", "fault"):
        axes = _scenario(seed, scenario, take)
        for variant in variants:
            fits = {a: [variant.readings(x) for x in fitting] for a, fitting, _ in axes}
            models, _ = _models(fits, None, 99.0)
            counts = {"false_alarms": 0, "healthy": 0, "detected": 0, "faulty": 0}
            for a, fitting, monitored in axes:
                for x, faulty in monitored:
                    over = variant.assess(models[a], fitting, x)[1]
                    counts["faulty" if faulty else "healthy"] += 1
                    counts["detected" if faulty else "false_alarms"] += int(over)
            rows.append(
                {"robot": f"robot{seed}", "scenario": scenario, "variant": variant.name, **counts}
            )
    return rows


def study(
    variants: Sequence[Variant[T]],
    take: Take[T],
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(transfer rows, monitor-scenario rows): one per robot and variant (and scenario)."""
    transfer, monitor = [], []
    with threadpool_limits(1):
        for seed in seeds:
            transfer += _transfer_rows(seed, design or TransferDesign(), variants, take)
            monitor += _monitor_rows(seed, variants, take)
            progress(f"robot {seed} done")
    return pd.DataFrame(transfer), pd.DataFrame(monitor)


def main(
    out: Path,
    variants: Sequence[Variant[T]],
    take: Take[T],
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
) -> None:
    """Write ``transfer.csv`` and ``monitor.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    transfer, monitor = study(variants, take, seeds)
    transfer.to_csv(out / "transfer.csv", index=False)
    monitor.to_csv(out / "monitor.csv", index=False)
    print(variant_summary(transfer))
    print(monitor.drop(columns=["robot"]).groupby(["scenario", "variant"], sort=False).sum())
