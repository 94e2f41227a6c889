"""Drive loads read from whole moves only (issue 13, i15a; lab study).

Research study (docs/evaluation.md, "Drive loads from whole moves"). The product's
``load_forward`` / ``load_backward`` (:func:`~axiswatch.read_indicators`) are the mean of
``torque * sign(speed)`` over the steady samples (above half the capture's peak speed) of each
direction. That mean holds the gravity and payload torque averaged over the *positions*
traversed. A capture starts at a random phase of the task cycle, so it often cuts a move: the
steady samples of a cut move cover only part of the move's positions, and the reading moves by
the difference of the gravity torque between the two halves of the stroke. On development
robot 2 (a wrist with a 4.4 kg payload) the healthy ``load_backward`` of one task takes three
values, about 0, 6 and 12 N m, with the phase; the baseline's six readings sat at 6, the
within-task spread came out 0.7, and Robot A alarmed on 20 days, every one topped by
``load_backward`` (on the baseline's own task too).

The candidate reads the loads on **whole moves** only: the samples of runs of one direction
(``|speed|`` above ``MOVING_FRACTION`` of the peak, as the product's motion mask) that start and
end inside the capture, so every reading averages the same stretch of positions. A direction
without a whole steady move gives NaN and a reason. No constant is added.

:func:`whole_move_mask` is the pure function; :func:`whole_move_readings` replaces the two loads
of a product reading. ``study`` scores the product (``current``) and the candidate (``whole
moves``) from the same captures: the transfer design (paired AUROC / ``dr99`` / ``far99`` per
fault, Robot A) and the monitor study's scenarios scored by the model directly, as
:mod:`axiswatch_lab._indicator_allowance` does. Development robots only.
``python -m axiswatch_lab._whole_moves OUT [SEED ...]``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from axiswatch._capture import Capture
from axiswatch._indicator_model import IndicatorModel
from axiswatch._readings import MOVING_FRACTION, Readings, motion, read_indicators
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._indicator_allowance import _models
from axiswatch_lab._task_envelope import _AXES, _FIT
from axiswatch_lab._transfer import (
    TransferDesign,
    _profile,
    fleet_readings,
    paired_measures,
    paired_readings,
    robot_a_readings,
)

__all__ = ["VARIANTS", "study", "whole_move_mask", "whole_move_readings"]

VARIANTS: tuple[str, ...] = ("current", "whole moves")
LOADS: tuple[tuple[float, str, str], ...] = (
    (1.0, "load_forward", "positive"),
    (-1.0, "load_backward", "negative"),
)


def whole_move_mask(speed: NDArray[np.float64], moving_fraction: float) -> NDArray[np.bool_]:
    """The samples of the moves that start and end inside the capture.

    A move is a run of samples with ``|speed| > moving_fraction x max |speed|`` and one sign of
    the speed; it is whole when neither its first nor its last sample is an end of the capture.

    Examples
    --------
    >>> v = np.array([2.0, 2.0, 0.0, -2.0, -2.0, 0.0, 2.0])
    >>> whole_move_mask(v, 0.1).astype(int).tolist()  # the first and last moves are cut
    [0, 0, 0, 1, 1, 0, 0]
    """
    peak = float(np.max(np.abs(speed))) if speed.size else 0.0
    moving = np.abs(speed) > moving_fraction * peak
    label = np.where(moving, np.sign(speed), 0.0)
    cuts = np.flatnonzero(np.diff(label) != 0) + 1
    out = np.zeros(speed.size, dtype=bool)
    for start, stop in zip(np.r_[0, cuts], np.r_[cuts, speed.size], strict=True):
        if label[start] != 0 and start > 0 and stop < speed.size:
            out[start:stop] = True
    return out


def whole_move_readings(capture: Capture, read: Readings) -> Readings:
    """``read`` with its drive loads taken over the steady samples of whole moves only."""
    m = motion(capture)
    values, reasons = dict(read.values), dict(read.reasons)
    peak = float(np.max(np.abs(m.speed))) if m.speed.size else 0.0
    if not peak > 0:
        return read
    whole = whole_move_mask(m.speed, MOVING_FRACTION)
    steady = whole & (np.abs(m.speed) > 0.5 * peak)
    min_samples = max(5, round(0.2 * m.rate_hz))
    for d, name, word in LOADS:
        mine = steady & (np.sign(m.speed) == d)
        reasons.pop(name, None)
        if mine.sum() >= min(min_samples, 3):
            values[name] = float(np.mean(m.torque[mine] * d))
        else:
            values[name] = math.nan
            reasons[name] = f"needs a whole steady move in the {word} direction"
    return dataclasses.replace(read, values=values, reasons=reasons)


def _both(read: Callable[[Capture], Readings]) -> Callable[[Capture], tuple[Readings, Readings]]:
    def both(capture: Capture) -> tuple[Readings, Readings]:
        r = read(capture)
        return r, whole_move_readings(capture, r)

    return both


def _pick(tree: object, k: int) -> object:
    """The ``k``-th reading of every (product, candidate) pair in nested lists and dicts."""
    if isinstance(tree, tuple) and len(tree) == 2 and isinstance(tree[0], Readings):
        return tree[k]
    if isinstance(tree, dict):
        return {key: _pick(v, k) for key, v in tree.items()}
    if isinstance(tree, list):
        return [_pick(v, k) for v in tree]
    return tree


def _transfer_rows(seed: int, design: TransferDesign) -> list[dict[str, object]]:
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)
    both = _both(IndicatorModel(profile).readings)
    fits = fleet_readings(robot, both, design)  # type: ignore[arg-type]
    tests = paired_readings(robot, both, design)  # type: ignore[arg-type]
    robot_a = robot_a_readings(robot, both, design.robot_a_days)  # type: ignore[arg-type]
    rows = []
    for k, variant in enumerate(VARIANTS):
        f, t, a = _pick(fits, k), _pick(tests, k), _pick(robot_a, k)
        models, prior = _models(f, profile, 99.0)  # type: ignore[arg-type]
        bases = sorted(models)
        dist = {
            (b, key): [models[b].assess_readings(r).distance / models[b].threshold_ for r in read]
            for b in bases
            for key, read in t.items()  # type: ignore[attr-defined]
        }
        row: dict[str, object] = {"robot": robot.name, "variant": variant}
        row.update(paired_measures(dist, bases))
        every = [d for v in dist.values() for d in v]
        row["share_scored"] = float(np.mean([math.isfinite(d) for d in every]))
        model_a = IndicatorModel(profile).fit_readings(a[: design.n_calibration + 1])  # type: ignore[index]
        model_a.use_fleet(prior)
        verdicts = [model_a.assess_readings(r) for r in a[design.n_calibration + 1 :]]  # type: ignore[index]
        row["robot_a_false_alarms"] = int(sum(v.alarm for v in verdicts))
        row["robot_a_test_days"] = len(verdicts)
        rows.append(row)
    return rows


def _scenario(seed: int, scenario: str) -> list[tuple[int, list[object], list[dict[str, object]]]]:
    """:func:`axiswatch_lab._task_envelope._scenario` with both readings of every capture."""
    robot = draw_robot(seed)
    both = _both(read_indicators)
    out = []
    for a in range(_AXES):
        fitting: list[object] = []
        monitored: list[dict[str, object]] = []
        for day in range(_FIT + (12 if scenario == "healthy" else 8)):
            task, fault = a, None
            if scenario == "healthy" and day >= _FIT + 4:
                task = (a + 1 + (day - _FIT - 4) // 4) % 5
            if scenario == "fault" and a == 0 and day >= _FIT:
                fault = Fault("friction", 0.6)
            read = both(robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}"))
            if day < _FIT:
                fitting.append(read)
            else:
                monitored.append({"readings": read, "faulty": fault is not None})
        out.append((a, fitting, monitored))
    return out


def _monitor_rows(seed: int) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for scenario in ("healthy", "fault"):
        axes = _scenario(seed, scenario)
        for k, variant in enumerate(VARIANTS):
            fits = {a: _pick(fitting, k) for a, fitting, _ in axes}
            models, _ = _models(fits, None, 99.0)  # type: ignore[arg-type]
            counts = {"false_alarms": 0, "healthy": 0, "detected": 0, "faulty": 0}
            for a, _, monitored in axes:
                for entry in monitored:
                    readings = _pick(entry["readings"], k)
                    assert isinstance(readings, Readings)
                    over = models[a].assess_readings(readings).alarm
                    key = "faulty" if entry["faulty"] else "healthy"
                    counts[key] += 1
                    counts["detected" if entry["faulty"] else "false_alarms"] += int(over)
            rows.append(
                {"robot": f"robot{seed}", "scenario": scenario, "variant": variant, **counts}
            )
    return rows


def study(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(transfer rows, monitor-scenario rows): one per robot and variant (and scenario)."""
    transfer, monitor = [], []
    with threadpool_limits(1):
        for seed in seeds:
            transfer += _transfer_rows(seed, design or TransferDesign())
            monitor += _monitor_rows(seed)
            progress(f"robot {seed} done")
    return pd.DataFrame(transfer), pd.DataFrame(monitor)


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS) -> None:
    """Write ``transfer.csv`` and ``monitor.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    transfer, monitor = study(seeds)
    transfer.to_csv(out / "transfer.csv", index=False)
    monitor.to_csv(out / "monitor.csv", index=False)
    numeric = transfer.drop(columns=["robot"]).groupby("variant", sort=False)
    summary = numeric.mean()
    summary["robot_a_false_alarms"] = numeric["robot_a_false_alarms"].sum()
    summary["robots_a_clean"] = numeric["robot_a_false_alarms"].apply(lambda s: int((s == 0).sum()))
    print(summary.T.to_string(float_format=lambda v: f"{v:.3f}"))
    by_robot = transfer.pivot(index="robot", columns="variant", values="robot_a_false_alarms")
    print(by_robot[list(VARIANTS)].to_string())
    print(monitor.drop(columns=["robot"]).groupby(["scenario", "variant"], sort=False).sum())


if __name__ == "__main__":  # python -m axiswatch_lab._whole_moves OUT [SEED ...]
    import sys

    main(Path(sys.argv[1]), tuple(int(s) for s in sys.argv[2:]) or DEVELOPMENT_ROBOTS)
