"""An axis without a fleet: what a task change does when nothing says what one does.

Research study ("An axis without a fleet", docs/evaluation.md). An axis with fewer than 3 axes
of its profile has no fleet prior, so no task-change allowance: its captures are scored in its
own within-task spreads. Per development robot of :func:`~axiswatch.datasets.draw_robot`, the
variants, each from the same readings of one fitted :class:`~axiswatch.IndicatorModel`
(baseline and 5 calibration captures, no fleet):

* ``compare every capture`` (the product before 2026-11-23): every capture against the centre
  in the own spreads, threshold the calibration fit;
* ``not compared beyond the envelope`` (the product since): a capture whose task signature is
  beyond the baseline's task envelope (``TASK_ENVELOPE_FACTOR``) is not compared; the others as
  before (:meth:`~axiswatch.IndicatorModel.assess_readings`);
* ``task-invariant indicators beyond the envelope``: such a capture is compared on the
  indicators meant to be task-invariant only (impulsiveness, reversal bursts, kinematic lines:
  ratios within the capture), in the own spreads, against the calibration fit of those alone.

Scenarios, as the transfer study's (:mod:`axiswatch_lab._transfer`) but without a fleet: Robot
A (190 days, three task changes, baseline day 1, calibration days 2-6) and the paired cells
(every task in turn the baseline; ``dr_same_<fault>``: faulty captures of the baseline's task
over the threshold; ``far_other``/``far_same``: healthy captures of other tasks / of the
baseline's task over it; AUROC of faulty captures of any task against healthy captures of the
other tasks, a capture not scored ranking as 0). Nothing here is used by the product.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from sklearn.metrics import roc_auc_score
from threadpoolctl import threadpool_limits

from axiswatch import IndicatorModel, fit_half_laplace
from axiswatch.datasets import FAULT_KINDS, draw_robot
from axiswatch_lab._product import (
    Readings,
    _distance,
    _transformed,
    leave_one_out_distances,
    signature_distance,
)
from axiswatch_lab._transfer import (
    TransferDesign,
    _profile,
    fleet_readings,
    paired_readings,
    robot_a_readings,
)

__all__ = ["VARIANTS", "lone_axis_robot", "lone_scores"]

VARIANTS: tuple[str, ...] = (
    "compare every capture",
    "not compared beyond the envelope",
    "task-invariant indicators beyond the envelope",
)


def _invariant(name: str) -> bool:
    return name in ("impulsiveness", "reversal_bursts") or name.startswith(
        ("tooth_lines:", "bearing_lines:")
    )


def lone_scores(model: IndicatorModel) -> dict[str, Callable[[Readings], tuple[float, bool]]]:
    """Per variant, a capture's ``(distance / threshold, alarm)`` (NaN: not scored) with a model
    fitted without a fleet prior."""
    if model.fleet is not None:
        raise ValueError("The study's model must have no fleet prior.")
    invariant = {n: s for n, s in model.within_.items() if _invariant(n)}
    loo = leave_one_out_distances(model.calibration_rows_, invariant) if invariant else []
    calibration = [d for d in loo[1:] if math.isfinite(d)]
    invariant_threshold = (
        fit_half_laplace(calibration).threshold(model.percentile)
        if len(calibration) >= 2
        else math.nan
    )

    def changed(r: Readings) -> bool:
        if model.task_reference_ is None or not len(r.signature):
            return False
        d = signature_distance(np.asarray(r.signature, dtype=np.float64), model.task_reference_)
        return math.isfinite(d) and d > model.task_envelope_

    def every(r: Readings) -> tuple[float, bool]:
        d, _ = _distance(_transformed(r), model.centre_, model.within_)
        return d / model.threshold_, bool(math.isfinite(d) and d > model.threshold_)

    def product(r: Readings) -> tuple[float, bool]:
        a = model.assess_readings(r)
        return a.distance / a.threshold, a.alarm

    def invariant_only(r: Readings) -> tuple[float, bool]:
        if not changed(r):
            return every(r)
        if not invariant or not math.isfinite(invariant_threshold):
            return math.nan, False
        d, _ = _distance(_transformed(r), model.centre_, invariant)
        return d / invariant_threshold, bool(math.isfinite(d) and d > invariant_threshold)

    return dict(zip(VARIANTS, (every, product, invariant_only), strict=True))


def _auroc(healthy: Sequence[float], faulty: Sequence[float]) -> float:
    h = [x if math.isfinite(x) else 0.0 for x in healthy]
    f = [x if math.isfinite(x) else 0.0 for x in faulty]
    return float(roc_auc_score([0] * len(h) + [1] * len(f), h + f))


def lone_axis_robot(seed: int, design: TransferDesign | None = None) -> list[dict[str, object]]:
    """One row per variant for one robot (see the module docstring; default: the transfer
    study's design)."""
    design = design or TransferDesign()
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    read = IndicatorModel(profile).readings
    fitting = design.n_calibration + 1
    taken = robot_a_readings(robot, read, design.robot_a_days)
    robot_a = lone_scores(IndicatorModel(profile).fit_readings(taken[:fitting]))
    n_tasks = len(robot.tasks)
    scores = {
        t: lone_scores(IndicatorModel(profile).fit_readings(fitting_readings))
        for t, fitting_readings in fleet_readings(robot, read, design).items()
    }
    cells = paired_readings(robot, read, design)
    rows: list[dict[str, object]] = []
    for variant in VARIANTS:
        verdicts = [robot_a[variant](r) for r in taken[fitting:]]
        row: dict[str, object] = {
            "robot": robot.name,
            "kind": robot.kind,
            "rate_hz": robot.spec.fast_rate_hz,
            "variant": variant,
            "robot_a_false_alarms": int(sum(alarm for _, alarm in verdicts)),
            "robot_a_not_scored": int(sum(not math.isfinite(d) for d, _ in verdicts)),
            "robot_a_test_days": len(verdicts),
        }
        for name, same in (("far_other", False), ("far_same", True)):
            row[name] = float(
                np.mean(
                    [
                        scores[b][variant](r)[1]
                        for b in range(n_tasks)
                        for t in range(n_tasks)
                        if (t == b) == same
                        for r in cells[(t, "healthy")]
                    ]
                )
            )
        for fault in FAULT_KINDS:
            row[f"dr_same_{fault}"] = float(
                np.mean(
                    [scores[b][variant](r)[1] for b in range(n_tasks) for r in cells[(b, fault)]]
                )
            )
            row[f"auroc_{fault}"] = float(
                np.mean(
                    [
                        _auroc(
                            [
                                scores[b][variant](r)[0]
                                for t in range(n_tasks)
                                if t != b
                                for r in cells[(t, "healthy")]
                            ],
                            [
                                scores[b][variant](r)[0]
                                for t in range(n_tasks)
                                for r in cells[(t, fault)]
                            ],
                        )
                        for b in range(n_tasks)
                    ]
                )
            )
        rows.append(row)
    return rows


def main(argv: Sequence[str]) -> None:
    """``python -m axiswatch_lab.studies.lone_axis_task_envelope OUT SEED ...``: one JSON line per robot and variant
    appended to ``OUT``."""
    out, seeds = Path(argv[0]), [int(s) for s in argv[1:]]
    with threadpool_limits(1):
        for seed in seeds:
            with out.open("a") as handle:
                for row in lone_axis_robot(seed):
                    handle.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
