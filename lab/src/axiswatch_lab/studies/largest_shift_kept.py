"""How the model combines its indicators: per-indicator AUROC and combination rules
(lab only).

Research study (docs/evaluation.md, "Combining the indicators"). :class:`~axiswatch.IndicatorModel`
scores a capture of another task by the *largest* shift over its indicators in allowance units,
``max_i u_i`` with ``u_i = z_i / A_i`` (``z_i`` the one-sided or absolute shift in
``sqrt(s_w^2 + s_t^2)``, ``A_i`` the task-change allowance: the fleet's at the Bonferroni level
``100 - (100 - p) / m``, or the axis's own pairs' where larger), threshold
``max(1, calibration fit)``. A reading that separates a fault well alone may be lost in that
maximum. This study measures, from the same readings and the same fitted fleet:

* per indicator and fault, the AUROC of its ``z_i`` against the healthy captures of the other
  tasks (per baseline axis, the mean over the axes: as the transfer study's AUROC). Per axis
  ``u_i = z_i / A_i`` with ``A_i`` a constant, so the AUROC of ``u_i`` is that of ``z_i``;
* combination rules, each a distance ``D`` from the capture's ``u_i`` (or ``z_i``) and a
  threshold ``max(floor, calibration fit)``, the fit the half-Laplace percentile ``p`` of the
  calibration captures' leave-one-out ``D`` (so a healthy capture of the baseline's task is over
  at the nominal rate) and the floor what a healthy task change reaches at ``p`` in ``D``'s units:

  - ``current``: ``max_i u_i``, floor 1 (the product's rule, scored exactly as it);
  - ``max, no Bonferroni``: ``max_i u_i'`` with every half-Laplace allowance at ``p`` instead of
    the Bonferroni level (``u_i' = u_i ln(100 m / (100 - p)) / ln(100 / (100 - p))``; an
    indicator on the fleet's one allowance keeps it), floor 1. Per axis a constant multiple of
    ``max_i u_i`` up to those indicators: its AUROC is about the current one's, only the
    threshold differs;
  - ``max of z``: ``max_i z_i`` in spreads (no per-indicator allowance), floor the fleet's one
    allowance (the rule before per-indicator allowances: what the scaling does);
  - ``min p``: the task-change p-value of each indicator under its half-Laplace fit,
    ``-ln p_i = u_i L_i`` (``L_i = ln(100 m / (100 - p))`` for an allowance at the Bonferroni
    level, ``ln(100 / (100 - p))`` for the fleet's one allowance); ``D = max_i (-ln p_i)``, floor
    ``ln(100 m / (100 - p))`` (Bonferroni); the same as ``current`` except for the indicators on
    the fleet's one allowance;
  - ``Fisher``: ``-ln`` of the combined p-value of ``sum_i -ln p_i`` (Gamma(k, 1) for ``k``
    indicators read, if independent), floor ``ln(100 / (100 - p))``. A sum of the ``u_i``
    weighted by ``L_i``: every indicator's shift counts;
  - ``root-sum-square``: ``sqrt(sum_i u_i^2)``, floor the ``p`` percentile of the same statistic
    when each ``u_i L_i`` is an independent unit exponential (simulated, fixed seed).

  The floors of ``Fisher`` and ``root-sum-square`` assume independent indicators; the
  indicators a task change moves are correlated (loads move several at once), so a task change's
  rate can be above ``100 - p`` %: Robot A and ``far99`` show it.

Only the development robots (:data:`~axiswatch.datasets.DEVELOPMENT_ROBOTS`); nothing here is
used by the product. ``python -m axiswatch_lab.studies.largest_shift_kept OUT [SEED ...]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from axiswatch import IndicatorModel, fit_half_laplace
from axiswatch.datasets import DEVELOPMENT_ROBOTS, FAULT_KINDS, draw_robot
from axiswatch_lab._product import Readings, _centre_without, _distance, _transformed
from axiswatch_lab._transfer import (
    TransferDesign,
    _auroc,
    _profile,
    fleet_readings,
    paired_measures,
    paired_readings,
    robot_a_readings,
)
from axiswatch_lab.studies.allowance_per_indicator import _models, variant_summary

__all__ = ["VARIANTS", "Combiner", "combination_study"]

VARIANTS: tuple[str, ...] = (
    "current",
    "max, no Bonferroni",
    "max of z",
    "min p",
    "Fisher",
    "root-sum-square",
)


class Combiner:
    """Every variant's distance (in units of its threshold) for one model with a fleet prior.

    ``model`` must have had :meth:`~axiswatch.IndicatorModel.use_fleet` called.
    """

    def __init__(self, model: IndicatorModel) -> None:
        assert model.fleet is not None
        self.model = model
        p = model.percentile
        prior = model.fleet
        self.scalar = prior.allowance(p)
        self.allowances = model.allowances_
        self.unit_scales = model.task_change_scales_
        fitted = {n for n, s in prior.indicator_scales.items() if math.isfinite(s) and s > 0}
        m = max(len(fitted), 1)
        self.bonferroni = math.log(100.0 * m / (100.0 - p))
        self.plain = math.log(100.0 / (100.0 - p))
        fleet = prior.allowances(p)
        own = getattr(model, "own_allowances_", {}) or {}
        # L_i: -ln p_i = u_i L_i. An indicator on the fleet's one allowance (no scale of its
        # own, or no own pairs) has its allowance at p, the others at the Bonferroni level.
        self.weights: dict[str, float] = {}
        for n in self.unit_scales:
            on_scalar = n not in fitted and not (n in own and own[n] > fleet.get(n, self.scalar))
            self.weights[n] = self.plain if on_scalar else self.bonferroni
        rng = np.random.default_rng(0)
        names = list(self.unit_scales)
        draws = rng.exponential(size=(20000, len(names))) / np.array(
            [self.weights[n] for n in names]
        )
        self.floors = {
            "current": 1.0,
            "max, no Bonferroni": 1.0,
            "max of z": self.scalar,
            "min p": self.bonferroni,
            "Fisher": self.plain,
            "root-sum-square": float(np.percentile(np.sqrt((draws**2).sum(axis=1)), p)),
        }
        rows = model.calibration_rows_
        loo = [
            _distance(row, _centre_without(rows, k, list(self.unit_scales)), self.unit_scales)[1]
            for k, row in enumerate(rows)
        ]
        self.thresholds: dict[str, float] = {}
        for v in VARIANTS:
            cal = [self.raw(v, u) for u in loo[1:]]
            fit = fit_half_laplace([d for d in cal if math.isfinite(d)]).threshold(p)
            self.thresholds[v] = max(self.floors[v], fit)

    def units(self, readings: Readings) -> dict[str, float]:
        """``u_i`` per indicator read (one-sided for indicators that only grow)."""
        return _distance(_transformed(readings), self.model.centre_, self.unit_scales)[1]

    def raw(self, variant: str, u: Mapping[str, float]) -> float:
        """The variant's distance from the ``u_i`` (NaN when none is read)."""
        if not u:
            return math.nan
        if variant == "current":
            return max(u.values())
        if variant == "max, no Bonferroni":
            return max(
                x * (self.weights[n] / self.plain if self.weights[n] == self.bonferroni else 1.0)
                for n, x in u.items()
            )
        if variant == "max of z":
            return max(x * self.allowances.get(n, 1.0) for n, x in u.items())
        neglogp = {n: x * self.weights[n] for n, x in u.items()}
        if variant == "min p":
            return max(neglogp.values())
        if variant == "Fisher":
            return float(-stats.gamma.logsf(sum(neglogp.values()), len(neglogp)))
        if variant == "root-sum-square":
            return math.sqrt(sum(x * x for x in u.values()))
        raise ValueError(f"unknown variant {variant!r}")

    def distances(self, readings: Readings) -> dict[str, float]:
        """Per variant, the distance over its threshold (1 = at the threshold)."""
        u = self.units(readings)
        return {v: self.raw(v, u) / self.thresholds[v] for v in VARIANTS}


def _robot_rows(
    seed: int, design: TransferDesign
) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """(variant rows, per-indicator rows) of one robot."""
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    reader = IndicatorModel(profile)
    n_tasks = len(robot.tasks)
    fits = fleet_readings(robot, reader.readings, design)
    models, prior = _models(fits, profile, 99.0)
    tests = paired_readings(robot, reader.readings, design)
    robot_a = robot_a_readings(robot, reader.readings, design.robot_a_days)
    model_a = IndicatorModel(profile).fit_readings(robot_a[: design.n_calibration + 1])
    model_a.use_fleet(prior)
    bases = sorted(models)
    combiners = {b: Combiner(models[b]) for b in bases}
    # Per baseline axis and test cell: each capture's u_i and the variants' distances.
    units = {
        (b, key): [combiners[b].units(r) for r in read]
        for b in bases
        for key, read in tests.items()
    }
    combiner_a = Combiner(model_a)
    robot_a_distances = [combiner_a.distances(r) for r in robot_a[design.n_calibration + 1 :]]
    rows: list[dict[str, object]] = []
    for v in VARIANTS:
        dist = {
            k: [combiners[k[0]].raw(v, u) / combiners[k[0]].thresholds[v] for u in us]
            for k, us in units.items()
        }
        row: dict[str, object] = {"robot": robot.name, "variant": v}
        row.update(paired_measures(dist, bases))
        a = [d[v] for d in robot_a_distances]
        row["robot_a_false_alarms"] = int(sum(d > 1 for d in a))
        row["robot_a_test_days"] = len(a)
        rows.append(row)
    # Per indicator: the AUROC of z_i (the same as of u_i: per axis a constant factor).
    names = sorted({n for b in bases for n in combiners[b].unit_scales})
    per: list[dict[str, object]] = []
    for n in names:
        entry: dict[str, object] = {"robot": robot.name, "indicator": n}
        for fault in FAULT_KINDS:
            scores = []
            for b in bases:
                if n not in combiners[b].unit_scales:
                    continue
                h = [
                    u.get(n, math.nan)
                    for t in range(n_tasks)
                    if t != b
                    for u in units[(b, (t, "healthy"))]
                ]
                f = [u.get(n, math.nan) for t in range(n_tasks) for u in units[(b, (t, fault))]]
                h, f = [x for x in h if math.isfinite(x)], [x for x in f if math.isfinite(x)]
                if h and f:
                    scores.append(_auroc(h, f))
            entry[f"auroc_{fault}"] = float(np.mean(scores)) if scores else math.nan
        # Where the maximum comes from: the median u_i, and how often the indicator is the
        # largest u_i, over the healthy captures of other tasks and over each fault's captures.
        for health in ("healthy", *FAULT_KINDS):
            us = [
                u
                for b in bases
                for t in range(n_tasks)
                if health != "healthy" or t != b
                for u in units[(b, (t, health))]
                if u
            ]
            read = [u[n] for u in us if math.isfinite(u.get(n, math.nan))]
            entry[f"median_u_{health}"] = float(np.median(read)) if read else math.nan
            entry[f"top_{health}"] = float(np.mean([max(u, key=u.__getitem__) == n for u in us]))
        per.append(entry)
    return rows, per


def combination_study(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(variant rows: one per robot and variant, per-indicator rows: one per robot and
    indicator)."""
    rows, per = [], []
    for seed in seeds:
        r, p = _robot_rows(seed, design or TransferDesign())
        rows += r
        per += p
        progress(f"robot {seed} done")
    return pd.DataFrame(rows), pd.DataFrame(per)


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS) -> None:
    """Write ``variants.csv`` and ``indicators.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    variants, per = combination_study(seeds)
    variants.to_csv(out / "variants.csv", index=False)
    per.to_csv(out / "indicators.csv", index=False)
    summarise(variants, per)


def summarise(variants: pd.DataFrame, per: pd.DataFrame) -> None:
    """Print the variants' means (Robot A summed) and the per-indicator AUROC means."""
    print(variant_summary(variants))
    print(
        per.drop(columns=["robot"])
        .groupby("indicator")
        .mean()
        .to_string(float_format=lambda v: f"{v:.3f}")
    )


if __name__ == "__main__":  # python -m axiswatch_lab.studies.largest_shift_kept OUT [SEED ...]
    import sys

    main(Path(sys.argv[1]), tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS)
