"""Backlash as the drive's ringing after the gear crosses its gap: the study.

Research study (docs/evaluation.md, "Backlash as ringing after the gap crossings"). It chose
:func:`axiswatch.indicators._ringing.gap_ringing` (the product's ``gap_ringing`` reading since) over the
former backlash indicator ``reversal_bursts`` (bursts within +-0.02 s of the *commanded*
torque's sign changes, in the band ``[0.04, 0.4] x rate``, needing 100 Hz). Two candidates of
the reading (:data:`CANDIDATES`) and three variants of the readings (:data:`VARIANTS`: the former
product, ``reversal_bursts`` replaced, or ``gap_ringing`` added beside it) are scored on the
development robots by the lab's transfer study (:func:`axiswatch_lab._transfer.robot_transfer`)
and the monitor study's scenarios, each variant from the same readings. The former product's
``reversal_bursts`` is read here as the product read it before (:func:`reversal_bursts_before`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch_lab._mechanics import reversal_bursts
from axiswatch_lab._product import (
    CROSSING_HYSTERESIS,
    INDICATORS,
    MIN_BAND_MOTION_S,
    MIN_BAND_RATE_HZ,
    MOVING_FRACTION,
    Indicator,
    Motion,
    Readings,
    _band,
    gap_ringing,
    indicator_model,
    motion,
    pool_fleet,
    pool_fleet_without,
    read_indicators,
)
from axiswatch_lab._transfer import TransferDesign, _profile, robot_transfer
from axiswatch_lab.studies.task_envelope_factor import _FIT, scenario_days

__all__ = [
    "CANDIDATES",
    "REVERSAL_BURSTS",
    "VARIANTS",
    "candidate_ringing",
    "reversal_bursts_before",
    "ringing_study",
]

#: The candidates compared (docs/evaluation.md): ``v1`` every sign change and the robust level
#: of the motion (the first full run, failed the rule); ``v2`` passages through +-10 % of each
#: estimate's peak and the residual away from the windows (the product's since).
CANDIDATES: dict[str, dict[str, Any]] = {
    "v1": {"hysteresis": 0.0, "reference": "motion"},
    "v2": {"hysteresis": CROSSING_HYSTERESIS, "reference": "away"},
}

#: The former product's backlash indicator, declared for the study's model only.
REVERSAL_BURSTS = Indicator(
    "reversal_bursts",
    f"a torque rate >= {MIN_BAND_RATE_HZ:g} Hz and torque reversals while moving",
    component="gear backlash",
    log=True,
)


def reversal_bursts_before(m: Motion) -> tuple[float, str | None]:
    """``reversal_bursts`` as :func:`~axiswatch.indicators._readings.read_indicators` read it before
    ``gap_ringing`` replaced it (NaN and the reason where it could not be read)."""
    peak = float(np.max(np.abs(m.speed))) if m.speed.size else 0.0
    moving = np.abs(m.speed) > MOVING_FRACTION * peak
    if peak <= 0 or moving.sum() < max(5, round(0.2 * m.rate_hz)):
        return math.nan, "needs motion (the axis did not move for 0.2 s)"
    if m.rate_hz < MIN_BAND_RATE_HZ:
        return math.nan, f"needs a torque rate >= {MIN_BAND_RATE_HZ:g} Hz (got {m.rate_hz:g} Hz)"
    seconds_moving = float(moving.sum()) / m.rate_hz
    if seconds_moving < MIN_BAND_MOTION_S:
        return math.nan, f"needs {MIN_BAND_MOTION_S:g} s of motion (got {seconds_moving:.2g} s)"
    bursts = reversal_bursts(
        m.torque,
        _band(m.torque, m.rate_hz),
        m.rate_hz,
        moving,
        smoothing_hz=min(10.0, 0.05 * m.rate_hz),
    )
    if not math.isfinite(bursts):
        return math.nan, "needs torque reversals while moving (none in this capture)"
    return bursts, None


def candidate_ringing(m: Motion, candidate: str) -> tuple[float, str | None]:
    """:func:`~axiswatch.indicators._ringing.gap_ringing` of a motion with a candidate's options."""
    return gap_ringing(
        m.time_s,
        m.position,
        m.speed,
        m.acceleration,
        m.torque,
        m.rate_hz,
        moving_fraction=MOVING_FRACTION,
        **CANDIDATES[candidate],
    )


# --- the study --------------------------------------------------------------------------------

#: The former product (``reversal_bursts``); ``reversal_bursts`` replaced by ``gap_ringing``
#: (the product's since); ``gap_ringing`` added beside it.
VARIANTS: tuple[str, ...] = ("product", "replaced", "added")


def _variant(
    base: Readings,
    bursts: tuple[float, str | None],
    ringing: tuple[float, str | None],
    variant: str,
) -> Readings:
    """The readings of a variant from the product's ``base`` (whose ``gap_ringing`` is
    replaced by the candidate's ``ringing``) and the former ``bursts``."""
    values = {n: v for n, v in base.values.items() if n != "gap_ringing"}
    reasons = {n: r for n, r in base.reasons.items() if n != "gap_ringing"}
    kept = {"product": [("reversal_bursts", bursts)], "replaced": [("gap_ringing", ringing)]}
    for name, (value, why) in kept.get(
        variant, [("reversal_bursts", bursts), ("gap_ringing", ringing)]
    ):
        values[name] = value
        if why is not None:
            reasons[name] = why
    return Readings(values, reasons, base.source, base.signature, base.order_profile)


class _Cached:
    """Readings of a capture, read once whatever the variant (captures are simulated again per
    variant, bit for bit the same; keyed by their signals)."""

    def __init__(self, read: Callable[[Capture], Readings], candidate: str) -> None:
        self.read = read
        self.candidate = candidate
        self.cache: dict[
            bytes, tuple[Readings, tuple[float, str | None], tuple[float, str | None]]
        ] = {}

    def __call__(self, capture: Capture, variant: str) -> Readings:
        key = b"".join(np.asarray(s).tobytes() for s in capture.signals.values())
        if key not in self.cache:
            m = motion(capture)
            self.cache[key] = (
                self.read(capture),
                reversal_bursts_before(m),
                candidate_ringing(m, self.candidate),
            )
        return _variant(*self.cache[key], variant)


def _read(cached: _Cached, variant: str, capture: Capture) -> Readings:
    return cached(capture, variant)


def _declared() -> AbstractContextManager[object]:
    """The model's declarations with :data:`REVERSAL_BURSTS` (the study only: the product's
    model declares its own indicators)."""
    return mock.patch.object(indicator_model, "INDICATORS", (*INDICATORS, REVERSAL_BURSTS))


def _monitor_rows(seed: int, cached: _Cached) -> list[dict[str, object]]:
    """The monitor study's scenarios (:func:`axiswatch_lab.studies.task_envelope_factor._scenario`: 4 axes,
    two task changes; a friction fault on axis 0's own task), scored by the product's model."""
    robot = draw_robot(seed)
    rows: list[dict[str, object]] = []
    for scenario in ("healthy", "fault"):
        by_axis: dict[int, tuple[list[tuple[Capture, bool]], list[tuple[Capture, bool]]]] = {}
        for a, day, task, fault in scenario_days(scenario):
            fitting, monitored = by_axis.setdefault(a, ([], []))
            capture = robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}")
            (fitting if day < _FIT else monitored).append((capture, fault is not None))
        captures = list(by_axis.values())
        for variant in VARIANTS:
            models = [
                IndicatorModel().fit_readings([cached(c, variant) for c, _ in fitting])
                for fitting, _ in captures
            ]
            prior = pool_fleet(models)
            for k, model in enumerate(models):
                model.use_fleet(prior, check_against=pool_fleet_without(models, k))
            counts = {"false_alarms": 0, "healthy": 0, "detected": 0, "faulty": 0}
            for model, (_, monitored) in zip(models, captures, strict=True):
                for capture, faulty in monitored:
                    over = model.assess_readings(cached(capture, variant)).alarm
                    counts["faulty" if faulty else "healthy"] += 1
                    counts["detected" if faulty else "false_alarms"] += int(over)
            rows.append({"robot": robot.name, "scenario": scenario, "variant": variant, **counts})
    return rows


def ringing_study(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    monitor: bool = True,
    candidate: str = "v1",
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(transfer rows, monitor-scenario rows): one per robot and variant (and scenario)."""
    transfer: list[dict[str, object]] = []
    monitor_rows: list[dict[str, object]] = []
    with threadpool_limits(1), _declared():
        for seed in seeds:
            design_ = design or TransferDesign()
            reader = IndicatorModel(_profile(draw_robot(seed), design_.kinematics)).readings
            cached = _Cached(reader, candidate)
            for variant in VARIANTS:
                record = robot_transfer(
                    seed, design_, read=functools.partial(_read, cached, variant)
                )
                transfer.append({"variant": variant, **record})
            if monitor:
                monitor_rows += _monitor_rows(seed, _Cached(read_indicators, candidate))
            progress(f"robot {seed} done")
    return pd.DataFrame(transfer), pd.DataFrame(monitor_rows)


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS, candidate: str = "v1") -> None:
    """Write ``transfer.csv`` and ``monitor.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    transfer, monitor = ringing_study(seeds, candidate=candidate)
    transfer.to_csv(out / "transfer.csv", index=False)
    monitor.to_csv(out / "monitor.csv", index=False)
    print(summary(transfer, monitor))


def summary(transfer: pd.DataFrame, monitor: pd.DataFrame) -> str:
    """The figures the decision rule reads, per variant."""
    numeric = transfer.select_dtypes("number").assign(variant=transfer["variant"])
    grouped = numeric.groupby("variant", sort=False)
    table = grouped.mean()
    table["robot_a_false_alarms"] = grouped["robot_a_false_alarms"].sum()
    table["robots_a_clean"] = grouped["robot_a_false_alarms"].apply(lambda s: int((s == 0).sum()))
    lines = [table.T.to_string(float_format=lambda v: f"{v:.3f}")]
    lines.append(
        transfer.pivot(index="robot", columns="variant", values="auroc_backlash").to_string()
    )
    lines.append(
        transfer.pivot(index="robot", columns="variant", values="robot_a_false_alarms").to_string()
    )
    if not monitor.empty:
        counts = monitor.drop(columns=["robot"]).groupby(["scenario", "variant"], sort=False)
        lines.append(counts.sum().to_string())
    return "\n\n".join(lines)


if (
    __name__ == "__main__"
):  # python -m axiswatch_lab.studies.backlash_as_gap_ringing OUT CANDIDATE [SEED ...]
    import sys

    seeds = tuple(int(s) for s in sys.argv[3:]) or DEVELOPMENT_ROBOTS
    main(Path(sys.argv[1]), seeds, sys.argv[2])
