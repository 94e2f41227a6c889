"""The fitted distribution's percentile against the next capture's, as the model's threshold.

Research study ("The threshold for the next capture", docs/evaluation.md). The threshold of an
:class:`~axiswatch.IndicatorModel` is the 99th percentile of a half-Laplace fitted to the
``K = 5`` calibration captures' leave-one-out distances (the paper's rule,
:meth:`~axiswatch.HalfLaplaceFit.threshold`). The alternative is the percentile of the *next*
healthy distance, the scale being estimated from those few
(:meth:`~axiswatch.HalfLaplaceFit.prediction_threshold`). Per development robot, from the same
distances of the transfer study's fleet (:mod:`axiswatch_lab._transfer`), the threshold is
recomputed both ways from each model's own calibration distances:

* with the fleet (the model's rule, ``max(1, fit)`` in allowance units): Robot A's days over,
  ``far99`` (healthy captures of other tasks over) and ``dr99_<fault>`` (faulty captures over);
* without a fleet (the same fitting captures, no prior): ``lone_far_same`` (healthy captures of
  the baseline's own task over, nominal ``1 - percentile``) and ``lone_dr_same_<fault>``.

Nothing here is used by the product.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from axiswatch import IndicatorModel, fit_half_laplace
from axiswatch.datasets import FAULT_KINDS, draw_robot
from axiswatch_lab._product import pool_fleet
from axiswatch_lab._transfer import (
    TransferDesign,
    _profile,
    fleet_readings,
    paired_readings,
    robot_a_readings,
)

__all__ = ["RULES", "robot_thresholds", "thresholds"]

RULES: tuple[str, ...] = ("fitted percentile", "next capture's percentile")


def thresholds(model: IndicatorModel) -> dict[str, float]:
    """The model's threshold by each rule, from its own calibration distances.

    The first is the model's own ``threshold_`` (tested equal to its recomputation).
    """
    calibration = [d for d in model.loo_distances_[1:] if math.isfinite(d)]
    fit = fit_half_laplace(calibration)
    floor = 1.0 if model.fleet is not None else 0.0
    return {
        RULES[0]: max(fit.threshold(model.percentile), floor),
        RULES[1]: max(fit.prediction_threshold(model.percentile), floor),
    }


def robot_thresholds(seed: int, design: TransferDesign | None = None) -> dict[str, object]:
    """One record per robot (see the module docstring)."""
    design = design or TransferDesign()
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    read = IndicatorModel(profile).readings
    fitting = design.n_calibration + 1
    fitted = fleet_readings(robot, read, design)
    fleet = {t: IndicatorModel(profile).fit_readings(r) for t, r in fitted.items()}
    prior = pool_fleet(list(fleet.values()))
    for model in fleet.values():
        model.use_fleet(prior)
    lone = {t: IndicatorModel(profile).fit_readings(r) for t, r in fitted.items()}
    cells = paired_readings(robot, read, design)
    taken = robot_a_readings(robot, read, design.robot_a_days)
    robot_a = IndicatorModel(profile).fit_readings(taken[:fitting]).use_fleet(prior)
    record: dict[str, object] = {"robot": robot.name, "rate_hz": robot.spec.fast_rate_hz}

    def over(
        models: dict[int, IndicatorModel], b: int, key: tuple[int, str], rule: str
    ) -> list[bool]:
        limit = thresholds(models[b])[rule]
        return [models[b].assess_readings(r).distance > limit for r in cells[key]]

    for rule in RULES:
        others = [
            o for b in fleet for t in fleet if t != b for o in over(fleet, b, (t, "healthy"), rule)
        ]
        record[f"{rule}: far99"] = float(np.mean(others))
        record[f"{rule}: lone_far_same"] = float(
            np.mean([o for b in lone for o in over(lone, b, (b, "healthy"), rule)])
        )
        for fault in FAULT_KINDS:
            record[f"{rule}: dr99_{fault}"] = float(
                np.mean([o for b in fleet for t in fleet for o in over(fleet, b, (t, fault), rule)])
            )
            record[f"{rule}: lone_dr_same_{fault}"] = float(
                np.mean([o for b in lone for o in over(lone, b, (b, fault), rule)])
            )
        limit = thresholds(robot_a)[rule]
        record[f"{rule}: robot_a_days_over"] = int(
            sum(robot_a.assess_readings(r).distance > limit for r in taken[fitting:])
        )
    return record


def main(argv: Sequence[str]) -> None:
    """``python -m axiswatch_lab.studies.fitted_percentile_kept OUT SEED ...``: one JSON line per robot
    appended to ``OUT``."""
    out = Path(argv[0])
    with threadpool_limits(1):
        for seed in (int(s) for s in argv[1:]):
            with out.open("a") as handle:
                handle.write(json.dumps(robot_thresholds(seed)) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
