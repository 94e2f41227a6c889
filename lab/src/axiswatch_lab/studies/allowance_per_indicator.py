"""Per-indicator task-change allowance against the fleet's one scalar.

Research study ("Transfer" and "Through the monitor", docs/evaluation.md). The fleet's
task-change allowance of :class:`~axiswatch.IndicatorModel` is one number: the percentile of a
half-Laplace fitted (``median / ln 2``) to the *largest* shift over the indicators between two
of the fleet's axes. It is set by the indicators a task change moves most (drive loads,
friction), so a fault that moves a task-invariant indicator (a kinematic line) stays under it.
The alternatives scored here, each from the same readings:

* ``scalar``: the model as it is (distance ``max_i z_i``; threshold ``max(calibration fit,
  allowance)``);
* ``per-indicator``: per indicator ``i`` a half-Laplace fitted to the pairwise ``|z_i|`` of the
  fleet's axes (``median / ln 2`` over the pairs that read it), its allowance ``A_i`` at the
  Bonferroni percentile ``100 - (100 - p) / m`` (``m`` the indicators with an allowance, so that
  the family-wise rate of a healthy task change stays ``100 - p`` %); the capture is scored in
  allowance units ``u_i = z_i / A_i`` (distance ``max_i u_i``), the calibration captures'
  leave-one-out distances in the same units, threshold ``max(1, calibration fit)``. An indicator
  with a task spread read on fewer than 3 pairs, or without one, takes the scalar allowance;
* ``per-indicator, no Bonferroni``: the same at the percentile ``p`` itself (to show what the
  correction buys);
* ``per-indicator, threshold only``: the distance stays ``max_i z_i`` in spreads and the
  calibration fit stays in spreads; a capture alarms when some ``z_i > max(fit, A_i)``
  (AUROC on ``max_i z_i / max(fit, A_i)``);
* ``pairwise spreads`` (changes the spreads, not the rule): the task spread ``s_t`` of an
  indicator is ``1.4826 x`` the median over the fleet's pairs of ``|centre_a - centre_b|``
  instead of ``sqrt(2) x 1.4826 x MAD`` of the centres (the two agree for Gaussian centres; the
  MAD is far too small when the tasks' centres form clusters); the scalar allowance is refitted
  in those spreads; ``pairwise spreads, per-indicator``: both changes.

Added for the allowances from an axis's own pairs (lab/docs/decision-log.md, "Allowances from an
axis's own pairs"):

* ``fleet only``: the product's rule before the own pairs (the study's reference), its
  allowances taken from the fleet prior
  (:meth:`FleetPrior.allowances`), the reference the others are compared with;
* ``own pairs, at least the fleet's``: per axis, ``A_i = max(A_i(fleet), A_i(own))``, where
  ``A_i(own)`` is the same half-Laplace rule (``median / ln 2``, the fleet's Bonferroni level)
  fitted to the ``|z_i|`` of the axis's centre against each other axis's centre
  (:func:`~axiswatch.indicators._fleet.own_pair_allowances`, the product's since it was chosen):
  an axis whose task is unlike the fleet's gets a larger allowance, a normal axis about the
  fleet's;
* ``own pairs``: ``A_i(own)`` alone (smaller than the fleet's on an axis in the fleet's middle).

Scenarios: the lab's transfer study (:mod:`axiswatch_lab._transfer`: paired AUROC and ``dr99``
per fault against healthy captures of other tasks, ``far99``, Robot A) and the monitor study's
fleets (:mod:`axiswatch_lab.studies.task_envelope_factor`'s scenarios: 4 axes, two task changes; a friction
fault on axis 0's own task), scored by the model directly. Run on the development robots to
choose; nothing here is used by the product.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from axiswatch import IndicatorModel, fit_half_laplace, half_laplace_threshold
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch.exceptions import CalibrationError
from axiswatch_lab._product import (
    MIN_PAIRS,
    FleetPrior,
    Readings,
    _distance,
    _transformed,
    leave_one_out_distances,
    own_pair_allowances,
    pool_fleet,
    pool_fleet_without,
)
from axiswatch_lab._transfer import (
    TransferDesign,
    _profile,
    fleet_readings,
    paired_measures,
    paired_readings,
    robot_a_readings,
)
from axiswatch_lab.studies.task_envelope_factor import _scenario

__all__ = ["VARIANTS", "allowance_study", "indicator_allowances", "variant_summary"]

VARIANTS: tuple[str, ...] = (
    "fleet only",
    "own pairs, at least the fleet's",
    "own pairs",
    "scalar",
    "per-indicator",
    "per-indicator, no Bonferroni",
    "per-indicator, threshold only",
    "pairwise spreads",
    "pairwise spreads, per-indicator",
)


def indicator_allowances(
    models: Sequence[IndicatorModel], prior: FleetPrior, percentile: float, *, bonferroni: bool
) -> dict[str, float]:
    """``A_i`` per indicator with a task spread (the scalar allowance where too few pairs)."""
    scalar = prior.allowance(percentile)
    names = [n for n, s in prior.task_spreads.items() if math.isfinite(s) and s > 0]
    shifts: dict[str, list[float]] = {n: [] for n in names}
    for a, b in itertools.combinations(models, 2):
        for n in names:
            scale = math.hypot(prior.task_spreads[n], a.within_.get(n, math.nan))
            z = (a.centre_.get(n, math.nan) - b.centre_.get(n, math.nan)) / scale
            if math.isfinite(z):
                shifts[n].append(abs(z))
    fitted = [n for n in names if len(shifts[n]) >= MIN_PAIRS and np.median(shifts[n]) > 0]
    m = max(len(fitted), 1)
    level = 100.0 - (100.0 - percentile) / m if bonferroni else percentile
    out = {n: scalar for n in names}
    for n in fitted:
        out[n] = half_laplace_threshold(float(np.median(shifts[n])) / math.log(2.0), level)
    return out


class Scorer:
    """One variant's distance and threshold for a fitted model with a fleet prior."""

    def __init__(
        self,
        model: IndicatorModel,
        allowances: Mapping[str, float],
        variant: str,
    ) -> None:
        self.model = model
        assert model.fleet is not None
        scalar = model.fleet.allowance(model.percentile)
        scales = model.scales_
        self.variant = variant
        loo = leave_one_out_distances(model.calibration_rows_, scales)
        fit = fit_half_laplace([d for d in loo[1:] if math.isfinite(d)]).threshold(model.percentile)
        if variant == "scalar":
            # The rule before this study, written out (the product's may differ since).
            self.scales = scales
            self.threshold = max(fit, scalar)
            self.per: dict[str, float] = {}
        elif variant == "per-indicator, threshold only":
            self.scales = scales
            self.per = {n: max(fit, allowances.get(n, scalar)) for n in scales}
            self.threshold = 1.0
        else:
            self.scales = {n: s * allowances.get(n, scalar) for n, s in scales.items()}
            units = leave_one_out_distances(model.calibration_rows_, self.scales)
            self.threshold = max(
                1.0,
                fit_half_laplace([d for d in units[1:] if math.isfinite(d)]).threshold(
                    model.percentile
                ),
            )
            self.per = {}

    def distance(self, readings: Readings) -> float:
        """In the threshold's units (1 = the threshold)."""
        values = _transformed(readings)
        d, shifts = _distance(values, self.model.centre_, self.scales)
        if self.per:
            return max((z / self.per[n] for n, z in shifts.items()), default=math.nan)
        return d / self.threshold


def pairwise_prior(models: Sequence[IndicatorModel]) -> FleetPrior:
    """:func:`pool_fleet` with ``s_t = 1.4826 x median |centre_a - centre_b|`` over the pairs."""
    pooled = pool_fleet(models)
    spreads = {}
    for n in pooled.task_spreads:
        diffs = [
            abs(a.centre_.get(n, math.nan) - b.centre_.get(n, math.nan))
            for a, b in itertools.combinations(models, 2)
        ]
        finite = [d for d in diffs if math.isfinite(d)]
        spreads[n] = 1.4826 * float(np.median(finite)) if len(finite) >= MIN_PAIRS else math.nan
    distances = []
    for a, b in itertools.combinations(models, 2):
        scales = {
            n: math.hypot(spreads[n], a.within_.get(n, math.nan))
            for n in spreads
            if math.isfinite(spreads[n]) and spreads[n] > 0
        }
        d, _ = _distance(
            a.centre_, b.centre_, {n: s for n, s in scales.items() if math.isfinite(s)}
        )
        if math.isfinite(d):
            distances.append(d)
    scale = max(float(np.median(distances)) / math.log(2.0), 1e-12)
    # The Scorer takes its allowances from indicator_allowances(), not the prior's own.
    return dataclasses.replace(
        pooled, task_spreads=spreads, allowance_scale=scale, n_pairs=len(distances)
    )


def _models(
    fits: Mapping[int, list[Readings]], profile: object, percentile: float
) -> tuple[dict[int, IndicatorModel], FleetPrior]:
    models = {}
    for k, read in fits.items():
        try:
            models[k] = IndicatorModel(profile, percentile=percentile).fit_readings(read)  # type: ignore[arg-type]
        except CalibrationError:
            continue
    pool = list(models.values())
    prior = pool_fleet(pool)
    for k, model in enumerate(pool):
        model.use_fleet(prior, check_against=pool_fleet_without(pool, k))
    return models, prior


def _scorers(
    models: Mapping[int, IndicatorModel],
    prior: FleetPrior,
    percentile: float,
    extra: IndicatorModel | None = None,
) -> dict[str, dict[int, Scorer]]:
    """Per variant a scorer per axis of the fleet (and of ``extra``, key -1: an axis fitted
    apart that takes the fleet's prior without being pooled)."""
    pool = list(models.values())
    pairwise = pairwise_prior(pool)
    fits = {True: prior, False: pairwise}
    allowances = {
        (p, b): indicator_allowances(pool, fits[p], percentile, bonferroni=b)
        for p in (True, False)
        for b in (True, False)
    }
    every = dict(models) if extra is None else {**models, -1: extra}
    fleet = prior.allowances(percentile)
    own = {
        k: own_pair_allowances(
            m.centre_,
            m.within_,
            [o.centre_ for j, o in models.items() if j != k],
            prior,
            percentile,
        )
        for k, m in every.items()
    }
    out = {}
    for v in VARIANTS:
        plain = not v.startswith("pairwise")
        rule = v if plain else ("scalar" if v == "pairwise spreads" else "per-indicator")
        chosen = allowances[(plain, "no Bonferroni" not in v)]
        scorers = {}
        for k, m in every.items():
            fitted = copy.deepcopy(m).use_fleet(fits[plain])
            if v == "fleet only":
                scorers[k] = Scorer(fitted, fleet, "per-indicator")
            elif v == "own pairs":
                scorers[k] = Scorer(fitted, own[k], "per-indicator")
            elif v == "own pairs, at least the fleet's":
                larger = {n: max(a, own[k].get(n, a)) for n, a in fleet.items()}
                scorers[k] = Scorer(fitted, larger, "per-indicator")
            else:
                scorers[k] = Scorer(fitted, chosen, rule)
        out[v] = scorers
    return out


def _transfer_rows(seed: int, design: TransferDesign) -> list[dict[str, object]]:
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    reader = IndicatorModel(profile)
    fits = fleet_readings(robot, reader.readings, design)
    models, prior = _models(fits, profile, 99.0)
    tests = paired_readings(robot, reader.readings, design)
    robot_a = robot_a_readings(robot, reader.readings, design.robot_a_days)
    model_a = IndicatorModel(profile).fit_readings(robot_a[: design.n_calibration + 1])
    rows = []
    bases = sorted(models)
    for variant, scorers in _scorers(models, prior, 99.0, model_a).items():
        dist = {
            (b, key): [scorers[b].distance(r) for r in read]
            for b in bases
            for key, read in tests.items()
        }
        row: dict[str, object] = {"robot": robot.name, "variant": variant}
        row.update(paired_measures(dist, bases))
        a = [scorers[-1].distance(r) for r in robot_a[design.n_calibration + 1 :]]
        row["robot_a_false_alarms"] = int(sum(d > 1 for d in a))
        row["robot_a_test_days"] = len(a)
        rows.append(row)
    return rows


def _monitor_rows(seed: int) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for scenario in ("healthy", "fault"):
        axes = _scenario(seed, scenario)
        models, prior = _models({a: fitting for a, fitting, _ in axes}, None, 99.0)
        for variant, scorers in _scorers(models, prior, 99.0).items():
            counts = {"false_alarms": 0, "healthy": 0, "detected": 0, "faulty": 0}
            for a, _, monitored in axes:
                for entry in monitored:
                    readings = entry["readings"]
                    assert isinstance(readings, Readings)
                    over = scorers[a].distance(readings) > 1
                    key = "faulty" if entry["faulty"] else "healthy"
                    counts[key] += 1
                    counts["detected" if entry["faulty"] else "false_alarms"] += int(over)
            rows.append(
                {"robot": f"robot{seed}", "scenario": scenario, "variant": variant, **counts}
            )
    return rows


def allowance_study(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(transfer rows, monitor-scenario rows): one per robot and variant (and scenario)."""
    transfer, monitor = [], []
    for seed in seeds:
        transfer += _transfer_rows(seed, design or TransferDesign())
        monitor += _monitor_rows(seed)
        progress(f"robot {seed} done")
    return pd.DataFrame(transfer), pd.DataFrame(monitor)


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS) -> None:
    """Write ``transfer.csv`` and ``monitor.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    transfer, monitor = allowance_study(seeds)
    transfer.to_csv(out / "transfer.csv", index=False)
    monitor.to_csv(out / "monitor.csv", index=False)
    print(variant_summary(transfer))
    print(monitor.drop(columns=["robot"]).groupby(["scenario", "variant"], sort=False).sum())


def variant_summary(transfer: pd.DataFrame) -> str:
    """Per variant, in the rows' order: the means over the robots (Robot A's days summed, the
    robots without one counted), then Robot A's days per robot."""
    numeric = transfer.drop(columns=["robot"]).groupby("variant", sort=False)
    summary = numeric.mean()
    summary["robot_a_false_alarms"] = numeric["robot_a_false_alarms"].sum()
    summary["robots_a_clean"] = numeric["robot_a_false_alarms"].apply(lambda s: int((s == 0).sum()))
    # Per robot: a total can hide a robot that got worse (robot6 and robot2 in the study before).
    by_robot = transfer.pivot(index="robot", columns="variant", values="robot_a_false_alarms")
    return "\n".join(
        [
            summary.T.to_string(float_format=lambda v: f"{v:.3f}"),
            by_robot[list(summary.index)].to_string(),
        ]
    )


if __name__ == "__main__":  # python -m axiswatch_lab.studies.allowance_per_indicator OUT [SEED ...]
    import sys

    main(Path(sys.argv[1]), tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS)
