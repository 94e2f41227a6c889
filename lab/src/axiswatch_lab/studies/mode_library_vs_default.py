"""The mode library against the default on the robot family: within a mode, Robot A, faults
growing after a mode change, a fault that starts just after one.

``python -m axiswatch_lab.studies.mode_library_vs_default [development|held-out|SEEDS] [CASES]``
prints one row per robot and case, then the means. ``CASES``: some of ``within``, ``robot_a``,
``growing`` (default), ``at_change``, ``cross_task`` and ``variants`` (the library's options,
:data:`VARIANTS`). ``axiswatch experiment modes`` runs these scenarios as one table. The
product's internals come through :mod:`axiswatch_lab._product`.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from sklearn.metrics import roc_auc_score

from axiswatch import AxisProfile, IndicatorModel
from axiswatch.datasets import (
    DEVELOPMENT_ROBOTS,
    HELD_OUT_ROBOTS,
    Fault,
    FaultKind,
    SimulatedRobot,
    draw_robot,
)
from axiswatch_lab._product import (
    CaptureDescription,
    ModeAssessment,
    ModeLibrary,
    describe_capture,
)

FAULTS: tuple[FaultKind, ...] = ("backlash", "friction", "tooth", "bearing")
N_FIT = 5
SEVERITY = 0.6


def _options(robot: SimulatedRobot) -> dict[str, object]:
    return {
        "gear_ratio": robot.spec.gear_ratio,
        "gear_stages": {"tooth stage": robot.spec.tooth_stage_ratio},
        "bearing_orders": {"motor bearing": robot.spec.bearing_order},
    }


def _profile(robot: SimulatedRobot) -> AxisProfile:
    return AxisProfile(
        name=robot.name,
        gear_ratio=robot.spec.gear_ratio,
        gear_stages={"tooth stage": robot.spec.tooth_stage_ratio},
        bearing_orders={"motor bearing": robot.spec.bearing_order},
    )


def _describe(
    robot: SimulatedRobot, task: int, seed: str, fault: Fault | None = None
) -> CaptureDescription:
    return describe_capture(robot.capture(task, fault=fault, seed=seed), None, _options(robot))


def _auroc(healthy: Sequence[float], faulty: Sequence[float]) -> float:
    h = [x if math.isfinite(x) else 0.0 for x in healthy]
    f = [x if math.isfinite(x) else 0.0 for x in faulty]
    labels = [0] * len(h) + [1] * len(f)
    return float(roc_auc_score(labels, h + f))


def _default_score(model: IndicatorModel, d: CaptureDescription) -> tuple[float, bool, bool]:
    verdict = model.assess_readings(d.readings)
    score = verdict.distance / verdict.threshold if verdict.scored else math.nan
    return score, bool(verdict.alarm), bool(verdict.scored)


def within_mode(
    robot: SimulatedRobot,
    n_test: int = 6,
    tasks: int = 4,
    faults: Sequence[FaultKind] = FAULTS,
) -> dict[str, float]:
    """Learn ``tasks`` modes (``N_FIT`` captures each), then score healthy and faulty captures
    of each without learning; the default is fitted on task 0's same captures."""
    library = ModeLibrary(n_fit=N_FIT)
    fitting = {t: [_describe(robot, t, f"fit{k}") for k in range(N_FIT + 1)] for t in range(tasks)}
    for t in range(tasks):
        for d in fitting[t]:
            library.update(d)
    default = IndicatorModel(_profile(robot)).fit_readings([d.readings for d in fitting[0]])
    out: dict[str, float] = {"modes": float(len(library.modes_))}
    healthy = {t: [_describe(robot, t, f"test{k}") for k in range(n_test)] for t in range(tasks)}
    h_lib = {t: [library.score(d).score for d in healthy[t]] for t in range(tasks)}
    h_def = [_default_score(default, d)[0] for d in healthy[0]]
    out["far_library"] = float(np.mean([s > 1 for t in range(tasks) for s in h_lib[t]]))
    out["far_default"] = float(np.mean([s > 1 for s in h_def]))
    for fault in faults:
        f_lib, f0_lib, f_def, auc = [], [], [], []
        for t in range(tasks):
            faulty = [
                _describe(robot, t, f"{fault}{k}", Fault(fault, SEVERITY)) for k in range(n_test)
            ]
            scores = [library.score(d).score for d in faulty]
            auc.append(_auroc(h_lib[t], scores))
            f_lib += scores
            if t == 0:
                f0_lib = scores
                f_def = [_default_score(default, d)[0] for d in faulty]
        out[f"auroc_{fault}"] = float(np.mean(auc))
        out[f"auroc0_{fault}"] = _auroc(h_lib[0], f0_lib)
        out[f"auroc0_default_{fault}"] = _auroc(h_def, f_def)
        out[f"dr_{fault}"] = float(np.mean([s > 1 for s in f_lib]))
    return out


def _payload_robot(robot: SimulatedRobot, task: int, extra_kg: float) -> SimulatedRobot:
    tasks = list(robot.tasks)
    tasks[task] = dataclasses.replace(tasks[task], payload_kg=tasks[task].payload_kg + extra_kg)
    return dataclasses.replace(robot, tasks=tuple(tasks))


#: Library options the decision log compares (``variants`` case); the first is the default.
VARIANTS: dict[str, dict[str, Any]] = {
    "base": {},
    "frozen, learn under 0.5": {"frozen": True, "learn_below": 0.5},
    "first 30": {"first_window": True},
    "first 30, learn under 0.5": {"first_window": True, "learn_below": 0.5},
    "motion match": {"motion_match": True},
    "CUSUM drift test": {"drift_test": "cusum"},
}
#: Days after a change the engineer made within which they teach its alarms (``teach=True``).
TEACH_DAYS = 5


def _replay(
    library: ModeLibrary,
    described: Sequence[CaptureDescription],
    changes: Sequence[int],
    teach: bool,
) -> list[ModeAssessment]:
    """Score each capture in turn; learn it, or, with ``teach``, teach an alarm that follows a
    change by at most :data:`TEACH_DAYS` (``ack --task-changed``)."""
    verdicts = []
    for day, d in enumerate(described):
        verdict = library.score(d)
        if teach and verdict.alarm and any(0 <= day - c < TEACH_DAYS for c in changes):
            library.teach(d)
        else:
            library.learn(d, verdict)
        verdicts.append(verdict)
    return verdicts


def robot_a(
    robot: SimulatedRobot,
    days: int = 190,
    *,
    teach: bool = False,
    options: Mapping[str, Any] | None = None,
) -> dict[str, float]:
    """A healthy axis: tasks 0, 1, 2, 3 in four quarters, then task 1 at another payload for
    the last tenth; a capture a day. Alarm days of the library and of the default."""
    changes = [round(days * k / 4) for k in (1, 2, 3)]
    heavy = _payload_robot(robot, 1, 5.0)
    library = ModeLibrary(n_fit=N_FIT, **(options or {}))
    described = []
    for day in range(days):
        task = sum(day >= c for c in changes)
        if day >= days - days // 10:
            described.append(_describe(heavy, 1, f"robotA{day}"))
        else:
            described.append(_describe(robot, task, f"robotA{day}"))
    verdicts = _replay(library, described, [*changes, days - days // 10], teach)
    default = IndicatorModel(_profile(robot)).fit_readings([d.readings for d in described[:6]])
    scored = [_default_score(default, d) for d in described[6:]]
    return {
        "library_alarm_days": float(sum(v.alarm for v in verdicts)),
        "library_learning_days": float(sum(v.state == "learning" for v in verdicts)),
        "library_modes": float(len(library.modes_)),
        "default_alarm_days": float(sum(a for _, a, _ in scored)),
        "default_not_scored": float(sum(not s for _, _, s in scored)),
        "default_scored_days": float(sum(s for _, _, s in scored)),
    }


def growing(
    robot: SimulatedRobot,
    fault: FaultKind,
    onset: int,
    days: int = 70,
    *,
    change: int = 20,
    teach: bool = False,
    options: Mapping[str, Any] | None = None,
) -> dict[str, float]:
    """Task 0 until day ``change``, task 1 from then; the fault grows linearly from day
    ``onset`` to severity 1 on the last day. Detection past severity 0.3, false alarms before
    onset, and how many captures each counts."""
    library = ModeLibrary(n_fit=N_FIT, **(options or {}))
    severities, described = [], []
    for day in range(days):
        severity = max(0.0, (day - onset) / (days - 1 - onset)) if day > onset else 0.0
        task = 0 if day < change else 1
        fault_now = Fault(fault, severity) if severity > 0 else None
        severities.append(severity)
        described.append(_describe(robot, task, f"grow{day}", fault_now))
    rows = list(zip(severities, _replay(library, described, [change], teach), strict=True))
    past = [v.alarm for s, v in rows if s > 0.3]
    before = [v.alarm for s, v in rows if s == 0.0]
    first = next((s for s, v in rows if v.alarm and s > 0), math.nan)
    return {
        "detection": float(np.mean(past)) if past else math.nan,
        "false_alarms": float(sum(before)),
        "first_alarm_severity": first,
        "learning_faulty": float(sum(v.state == "learning" for s, v in rows if s > 0)),
        "detected": float(sum(past)),
        "captures_past": float(len(past)),
        "captures_before": float(len(before)),
    }


#: Days from the mode change to the fault's onset in :func:`fault_at_change`.
FAULT_LAG = 3


def fault_at_change(
    robot: SimulatedRobot,
    fault: FaultKind,
    days: int = 70,
    *,
    change: int = 20,
    lag: int = FAULT_LAG,
    teach: bool = False,
    options: Mapping[str, Any] | None = None,
) -> dict[str, float]:
    """:func:`growing` with the fault starting ``lag`` days after the mode change: while the
    new mode is still learned, and within the days an engineer teaches."""
    return growing(robot, fault, change + lag, days, change=change, teach=teach, options=options)


def cross_task(
    robot: SimulatedRobot,
    n_test: int = 6,
    tasks: int = 4,
    faults: Sequence[FaultKind] = FAULTS,
) -> dict[str, float]:
    """The paper's cross-task case: a library fitted on task 0 (``N_FIT + 1`` captures), then,
    per fault, ``n_test`` healthy and ``n_test`` faulty captures of each other task, shuffled
    (fixed seed) and scored as they come, learning as the monitor does. AUROC of faulty
    against healthy scores (a capture without a score counts 0) and the healthy alarm rate."""
    fitting = [_describe(robot, 0, f"fit{k}") for k in range(N_FIT + 1)]
    healthy = [_describe(robot, t, f"test{k}") for t in range(1, tasks) for k in range(n_test)]
    out: dict[str, float] = {}
    alarms = []
    for fault in faults:
        faulty = [
            _describe(robot, t, f"{fault}{k}", Fault(fault, SEVERITY))
            for t in range(1, tasks)
            for k in range(n_test)
        ]
        library = ModeLibrary(n_fit=N_FIT)
        for d in fitting:
            library.update(d)
        stream = [(d, False) for d in healthy] + [(d, True) for d in faulty]
        # Seeded by the fault, so a run of some faults shuffles each as a run of all does.
        order = np.random.default_rng(FAULTS.index(fault)).permutation(len(stream))
        verdicts = [(library.update(stream[i][0]), stream[i][1]) for i in order]
        h = [v.score for v, bad in verdicts if not bad]
        f = [v.score for v, bad in verdicts if bad]
        out[f"auroc_{fault}"] = _auroc(h, f)
        out[f"dr_{fault}"] = float(np.mean([v.alarm for v, bad in verdicts if bad]))
        alarms += [v.alarm for v, bad in verdicts if not bad]
    out["far"] = float(np.mean(alarms))
    return out


def main(argv: Sequence[str]) -> None:
    which = argv[0] if argv else "development"
    seeds = {"development": DEVELOPMENT_ROBOTS, "held-out": HELD_OUT_ROBOTS}.get(which)
    if seeds is None:
        seeds = tuple(int(s) for s in which.split(","))
    cases = argv[1].split(",") if len(argv) > 1 else ["within", "robot_a", "growing"]
    rows: dict[str, list[dict[str, float]]] = {}
    for seed in seeds:
        robot = draw_robot(seed)
        if "within" in cases:
            rows.setdefault("within", []).append(within_mode(robot))
            print(robot.name, "within", rows["within"][-1], flush=True)
        if "cross_task" in cases:
            rows.setdefault("cross_task", []).append(cross_task(robot))
            print(robot.name, "cross_task", rows["cross_task"][-1], flush=True)
        if "robot_a" in cases:
            rows.setdefault("robot_a", []).append(robot_a(robot))
            print(robot.name, "robot_a", rows["robot_a"][-1], flush=True)
        if "growing" in cases:
            for fault in FAULTS:
                rows.setdefault(f"growing {fault}", []).append(growing(robot, fault, 30))
                print(robot.name, "growing", fault, rows[f"growing {fault}"][-1], flush=True)
        if "at_change" in cases:
            for fault in FAULTS:
                rows.setdefault(f"at change {fault}", []).append(fault_at_change(robot, fault))
                print(robot.name, "at change", fault, rows[f"at change {fault}"][-1], flush=True)
        if "variants" in cases:  # each library option, an engineer teaching after a change
            for name, options in VARIANTS.items():
                rows.setdefault(f"{name}: robot_a", []).append(
                    robot_a(robot, teach=True, options=options)
                )
                for fault in FAULTS:
                    rows.setdefault(f"{name}: growing {fault}", []).append(
                        growing(robot, fault, 30, teach=True, options=options)
                    )
    for case, found in rows.items():
        means = {k: round(float(np.nanmean([r[k] for r in found])), 3) for k in found[0]}
        print("mean", case, means, flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
