"""Choosing the task envelope of the ``indicators`` method on the development robots.

Research study ("Through the monitor", docs/evaluation.md). The scenarios of
:mod:`axiswatch_lab.studies.through_the_monitor` (per robot 4 axes on tasks 0-3, the baseline and
``K = 5`` calibration captures; *healthy*: 4 captures of the own task, then 4 each of two other
tasks; *fault*: 8 captures of the own task, axis 0's with a friction fault of severity 0.6), read
once and scored by :class:`~axiswatch.IndicatorModel` directly (what the monitor does, without
its files and store) for each alternative:

* ``fleet always`` (the method before the envelope), ``own always`` (no fleet prior);
* the envelope at ``factor`` x the largest leave-one-out signature distance, for each factor;
* the signature without the position quantiles (speeds and share moving only): a task that
  moves the same way at another place is then the same task.

Run on :data:`~axiswatch.datasets.DEVELOPMENT_ROBOTS` to choose; the held-out robots and the
real data are scored by :mod:`axiswatch_lab.studies.through_the_monitor` with the choice, once.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import pandas as pd

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._product import (
    SIGNATURE_MOVING_QUANTILES,
    SIGNATURE_POSITION_QUANTILES,
    Readings,
    pool_fleet,
    pool_fleet_without,
    read_indicators,
)

__all__ = ["FACTORS", "envelope_study", "scenario_days"]

#: The envelope factors compared.
FACTORS: tuple[float, ...] = (1.5, 2.0, 3.0)
_AXES = 4
_FIT = 6  # the baseline and K = 5


def scenario_days(scenario: str) -> Iterator[tuple[int, int, int, Fault | None]]:
    """``(axis, day, task, fault)`` of every capture of a monitor scenario, axis by axis.

    Axis ``a`` runs task ``a``; its first ``_FIT`` days are its baseline and calibration.
    *healthy*: then 4 days of its own task and 4 each of tasks ``a + 1`` and ``a + 2`` (mod 5);
    *fault*: then 8 days of its own task, axis 0's with a friction fault of severity 0.6.

    Examples
    --------
    >>> [(a, day, task) for a, day, task, _ in scenario_days("healthy")][9:12]
    [(0, 9, 0), (0, 10, 1), (0, 11, 1)]
    >>> sum(fault is not None for *_, fault in scenario_days("fault"))
    8
    """
    for a in range(_AXES):
        for day in range(_FIT + (12 if scenario == "healthy" else 8)):
            task, fault = a, None
            if scenario == "healthy" and day >= _FIT + 4:
                task = (a + 1 + (day - _FIT - 4) // 4) % 5
            if scenario == "fault" and a == 0 and day >= _FIT:
                fault = Fault("friction", 0.6)
            yield a, day, task, fault


def _without_position(readings: Readings) -> Readings:
    """The same readings with a signature whose position quantiles no longer tell tasks apart
    (fixed at a unit stroke)."""
    if not readings.signature:
        return readings
    n = 1 + len(SIGNATURE_MOVING_QUANTILES)
    fixed = tuple(float(k) for k in range(len(SIGNATURE_POSITION_QUANTILES)))
    signature = (*readings.signature[:n], *fixed, *readings.signature[n + len(fixed) :])
    return dataclasses.replace(readings, signature=signature)


def _scenario(
    seed: int, scenario: str
) -> list[tuple[int, list[Readings], list[dict[str, object]]]]:
    """Per axis: its fitting readings and its monitored readings with their labels."""
    robot = draw_robot(seed)
    out: dict[int, tuple[int, list[Readings], list[dict[str, object]]]] = {}
    for a, day, task, fault in scenario_days(scenario):
        _, fitting, monitored = out.setdefault(a, (a, [], []))
        read = read_indicators(robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}"))
        if day < _FIT:
            fitting.append(read)
        else:
            monitored.append(
                {"readings": read, "same_task": task == a, "faulty": fault is not None}
            )
    return list(out.values())


def _variants() -> list[tuple[str, float | None, bool, bool]]:
    """(name, factor, use the fleet prior, drop the position quantiles)."""
    return [
        ("fleet always", None, True, False),
        ("own always", None, False, False),
        *[(f"envelope x{f:g}", f, True, False) for f in FACTORS],
        *[(f"envelope x{f:g}, no position", f, True, True) for f in FACTORS],
    ]


def envelope_study(seeds: Sequence[int] = DEVELOPMENT_ROBOTS) -> pd.DataFrame:
    """One row per robot, scenario, variant and monitored capture kind: captures over the
    threshold and captures scored as the baseline's task."""
    rows = []
    for seed in seeds:
        for scenario in ("healthy", "fault"):
            axes = _scenario(seed, scenario)
            for name, factor, pooled, no_position in _variants():
                prepare = _without_position if no_position else (lambda r: r)
                models = [
                    IndicatorModel(task_envelope_factor=factor).fit_readings(
                        [prepare(r) for r in fitting]
                    )
                    for _, fitting, _ in axes
                ]
                if pooled:
                    prior = pool_fleet(models)
                    models = [
                        m.use_fleet(prior, check_against=pool_fleet_without(models, k))
                        for k, m in enumerate(models)
                    ]
                for (a, _, monitored), model in zip(axes, models, strict=True):
                    for entry in monitored:
                        readings = entry["readings"]
                        assert isinstance(readings, Readings)
                        verdict = model.assess_readings(prepare(readings))
                        kind = (
                            "faulty"
                            if entry["faulty"]
                            else "same task"
                            if entry["same_task"]
                            else "task change"
                        )
                        rows.append(
                            {
                                "robot": seed,
                                "scenario": scenario,
                                "variant": name,
                                "axis": a,
                                "kind": kind,
                                "over": bool(verdict.alarm),
                                "scored": math.isfinite(verdict.distance),
                                "as_same_task": verdict.same_task,
                            }
                        )
    return pd.DataFrame(rows)


def summarise(table: pd.DataFrame) -> pd.DataFrame:
    """Per variant and kind: captures, over the threshold, scored as the baseline's task."""
    grouped = table.groupby(["variant", "kind"], sort=False)
    counts = grouped.agg(
        captures=("over", "size"), over=("over", "sum"), as_same_task=("as_same_task", "sum")
    )
    return pd.DataFrame(counts.unstack("kind"))


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS) -> None:
    """Write ``envelope.csv`` under ``out`` and print the summary."""
    out.mkdir(parents=True, exist_ok=True)
    table = envelope_study(seeds)
    table.to_csv(out / "envelope.csv", index=False)
    print(summarise(table).to_string())


if __name__ == "__main__":  # python -m axiswatch_lab.studies.task_envelope_factor OUT [SEED ...]
    import sys

    main(Path(sys.argv[1]), tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS)
