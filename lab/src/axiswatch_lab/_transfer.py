"""The transfer study: does the indicator default hold on robots it was not tuned on?

Research code (``axiswatch experiment transfer``). Per simulated robot of
:mod:`axiswatch._family` (the development robots while choosing, the held-out robots to report):

* a **fleet** of six axes of that robot model, one per task (the last logged as one-direction
  strokes), each fitted with :class:`~axiswatch.IndicatorModel` on a baseline and
  ``n_calibration`` captures of its task, pooled into one :class:`~axiswatch.FleetPrior`;
* **paired**: every axis in turn is the baseline; AUROC of faulty captures (one fault type, any
  task) against healthy captures of the other tasks, averaged over the baselines; ``far99``: the
  share of those healthy captures over the threshold;
* **oracle**: per task, a model fitted on that task alone (no fleet), AUROC of faulty against
  healthy captures of the same task, averaged over tasks; ``margin`` is
  ``(auroc - 0.5) / (oracle - 0.5)``;
* **Robot A**: one axis for ``robot_a_days`` days, a capture a day at a random phase, the task
  changing ``3`` times; baseline day 1, calibration days ``2 .. n_calibration + 1``; false
  alarms are the later days over the threshold;
* **degradation** (the issue's "runs that alarm before the breakdown"): per fleet axis and
  fault type, a capture a day of the axis's own task with the fault's severity rising
  ``1/n, 2/n, ..., (n - 1)/n`` before the breakdown at 1 (``n = degradation_days``);
  ``ramp_alarmed_<fault>`` is the share of those runs with an alarm before the breakdown,
  ``ramp_severity_<fault>`` the median severity of their first alarm (NaN when none alarmed);
* ``share_scored``: the share of all test captures that got a distance;
* ``fleet_checks``: the fleet's (healthy) axes whose fleet check notes them as unlike the
  others, ``robot_a_fleet_check`` 1 when Robot A's does.

By default (``unit_spread=0``) the fleet's six axes, Robot A and every paired test capture come
from one simulated unit of the robot model: the fleet differs only by task. With
``unit_spread > 0`` each is a unit of its own (:func:`~axiswatch.datasets._family.draw_unit`):
fleet axis ``k`` is unit ``k`` (its calibration, its paired test captures at every task, its
oracle and its degradation runs), Robot A is unit ``6``, none of the fleet's.

Real data (:func:`real_data_transfer`): the hydraulic actuators and the linear axis of
``../shared/data`` with the same model, no parameter changed for them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.metrics import roc_auc_score
from threadpoolctl import threadpool_limits

from axiswatch import AxisProfile, Capture, IndicatorModel
from axiswatch.datasets import FAULT_KINDS, Fault, SimulatedRobot, draw_robot, draw_unit
from axiswatch.exceptions import CalibrationError
from axiswatch.monitor import parallel_map
from axiswatch_lab._product import Readings, pool_fleet, pool_fleet_without

__all__ = [
    "TransferDesign",
    "fleet_readings",
    "fleet_units",
    "paired_measures",
    "real_data_transfer",
    "robot_a_readings",
    "robot_transfer",
    "transfer_study",
]


@dataclass(frozen=True)
class TransferDesign:
    """Sizes of the simulated part of the study.

    Parameters
    ----------
    n_per_cell : int, default=4
        Test captures per (task, health).
    n_calibration : int, default=5
    severity : float, default=0.6
    robot_a_days : int, default=190
    kinematics : bool, default=True
        Give the model the robot's true kinematics (an AxisProfile with gear ratio, the tooth
        stage and the bearing order), as a service engineer would from the datasheets.
    order_lines : bool, default=False
        Models that also score the order lines against the baseline's own order spectrum
        (``IndicatorModel(order_lines=True)``).
    whole_moves : bool, default=False
        Models at the opt-in operating point ``IndicatorModel(whole_moves=True)`` (drive loads
        from whole moves, loose friction readings widened).
    degradation_days : int, default=12
        Days from a healthy axis to the breakdown in each degradation run (below 2: no runs).
    unit_spread : float, default=0.0
        Log standard deviation of the unit-to-unit factors of friction, backlash, stiffness,
        damping and motor inertia (:func:`~axiswatch.datasets._family.draw_unit`); 0: one unit
        for the whole study (the study before 2026-11-23, bit for bit).
    """

    n_per_cell: int = 4
    n_calibration: int = 5
    severity: float = 0.6
    robot_a_days: int = 190
    kinematics: bool = True
    order_lines: bool = False
    whole_moves: bool = False
    degradation_days: int = 12
    unit_spread: float = 0.0


#: A configuration of a few seconds per robot, for tests.
FAST_DESIGN = TransferDesign(n_per_cell=2, n_calibration=4, robot_a_days=24, degradation_days=4)


def _profile(robot: SimulatedRobot, kinematics: bool) -> AxisProfile:
    if not kinematics:
        return AxisProfile(name=robot.name)
    return AxisProfile(
        name=robot.name,
        gear_ratio=robot.spec.gear_ratio,
        gear_stages={"tooth stage": robot.spec.tooth_stage_ratio},
        bearing_orders={"motor bearing": robot.spec.bearing_order},
    )


def _auroc(healthy: Sequence[float], faulty: Sequence[float]) -> float:
    h = np.asarray([d if math.isfinite(d) else 0.0 for d in healthy])
    f = np.asarray([d if math.isfinite(d) else 0.0 for d in faulty])
    if h.size == 0 or f.size == 0:
        return math.nan
    labels = np.concatenate([np.zeros(h.size), np.ones(f.size)])
    return float(roc_auc_score(labels, np.concatenate([h, f])))


def fleet_units(robot: SimulatedRobot, design: TransferDesign) -> list[SimulatedRobot]:
    """The units of the study: one per fleet axis (task), then Robot A's; all ``robot`` itself
    when ``design.unit_spread`` is 0."""
    return [draw_unit(robot, k, design.unit_spread) for k in range(len(robot.tasks) + 1)]


def fleet_readings(
    robot: SimulatedRobot,
    read: Callable[[Capture], Readings],
    design: TransferDesign,
    *,
    units: Sequence[SimulatedRobot] | None = None,
) -> dict[int, list[Readings]]:
    """Per task, the readings (by ``read``) of the baseline and the ``design.n_calibration``
    calibration captures of the fleet's axis on that task (unit ``t`` of ``units`` for task
    ``t`` when given, else ``robot``)."""
    return {
        t: [
            read((units[t] if units else robot).capture(t, seed=f"fleet{k}"))
            for k in range(design.n_calibration + 1)
        ]
        for t in range(len(robot.tasks))
    }


def paired_measures(
    distances: Mapping[tuple[int, tuple[int, str]], Sequence[float]], bases: Sequence[int]
) -> dict[str, float]:
    """``far99``, ``auroc_<fault>`` and ``dr99_<fault>`` of the paired design from distances in
    units of their threshold (over when above 1), keyed by (baseline axis, (task, health)).

    The healthy captures of the baseline's own task are left out; AUROCs are averaged over the
    baseline axes."""
    tasks = sorted({t for _, (t, _) in distances})
    healthy = {
        b: [d for t in tasks if t != b for d in distances[(b, (t, "healthy"))]] for b in bases
    }
    out = {"far99": float(np.mean([d > 1 for b in bases for d in healthy[b]]))}
    for fault in FAULT_KINDS:
        faulty = {b: [d for t in tasks for d in distances[(b, (t, fault))]] for b in bases}
        out[f"auroc_{fault}"] = float(np.nanmean([_auroc(healthy[b], faulty[b]) for b in bases]))
        out[f"dr99_{fault}"] = float(np.mean([d > 1 for b in bases for d in faulty[b]]))
    return out


def paired_readings(
    robot: SimulatedRobot, read: Callable[[Capture], Readings], design: TransferDesign
) -> dict[tuple[int, str], list[Readings]]:
    """The paired test cells: ``design.n_per_cell`` readings (by ``read``) per (task, health),
    health being ``"healthy"`` or a fault kind at ``design.severity``."""
    return {
        (t, h): [
            read(
                robot.capture(
                    t,
                    fault=None if h == "healthy" else Fault(h, design.severity),  # type: ignore[arg-type]
                    seed=f"{h}{i}",
                )
            )
            for i in range(design.n_per_cell)
        ]
        for t in range(len(robot.tasks))
        for h in ("healthy", *FAULT_KINDS)
    }


def robot_transfer(
    seed: int,
    design: TransferDesign = TransferDesign(),
    *,
    read: Callable[[Capture], Readings] | None = None,
) -> dict[str, object]:
    """The study on one robot; one JSON-ready record (see the module docstring).

    ``read`` takes a capture's readings (default: the model's, with the design's profile); a
    study of another indicator passes its own.
    """
    robot = draw_robot(seed)
    profile = _profile(robot, design.kinematics)

    def new_model() -> IndicatorModel:
        return IndicatorModel(
            profile, order_lines=design.order_lines, whole_moves=design.whole_moves
        )

    read = read or new_model().readings
    n_tasks = len(robot.tasks)
    units = fleet_units(robot, design)
    fleet: dict[int, IndicatorModel] = {}
    unfitted = []
    for t, fitting in fleet_readings(robot, read, design, units=units).items():
        try:
            fleet[t] = new_model().fit_readings(fitting)
        except CalibrationError:
            unfitted.append(robot.tasks[t].name)  # reported: the axis cannot be monitored
    pool = list(fleet.values())
    prior = pool_fleet(pool)
    for k, model in enumerate(pool):
        model.use_fleet(prior, check_against=pool_fleet_without(pool, k))
    bases = sorted(fleet)
    # Per baseline axis, its own unit's test captures; equal units (no spread) share one set.
    by_unit: dict[SimulatedRobot, dict[tuple[int, str], list[Readings]]] = {}
    for b in bases:
        if units[b] not in by_unit:
            by_unit[units[b]] = paired_readings(units[b], read, design)
    tests_of = {b: by_unit[units[b]] for b in bases}
    distances = {
        (b, key): [fleet[b].assess_readings(r).distance for r in taken]
        for b in bases
        for key, taken in tests_of[b].items()
    }
    record: dict[str, object] = {
        "robot": robot.name,
        "kind": robot.kind,
        "rate_hz": robot.spec.fast_rate_hz,
        "position_rate_hz": robot.spec.position_rate_hz,
        "friction_fault": robot.friction_fault,
        "axes_not_fitted": ";".join(unfitted),
        # Healthy axes the fleet check sets apart from the others (a note, not an alarm).
        "fleet_checks": int(sum(m.fleet_check_ is not None for m in pool)),
    }
    all_d = [d for v in distances.values() for d in v]
    record["share_scored"] = float(np.mean([math.isfinite(d) for d in all_d]))
    healthy_other = {
        b: [d for t in range(n_tasks) if t != b for d in distances[(b, (t, "healthy"))]]
        for b in bases
    }
    record["far99"] = float(
        np.mean(
            [d > fleet[b].threshold_ for b in bases for d in healthy_other[b] if math.isfinite(d)]
        )
    )
    oracle_models = {t: new_model().fit_readings(m.fit_readings_) for t, m in fleet.items()}
    for fault in FAULT_KINDS:
        aurocs = [
            _auroc(
                healthy_other[b], [d for t in range(n_tasks) for d in distances[(b, (t, fault))]]
            )
            for b in bases
        ]
        oracle = [
            _auroc(
                [oracle_models[t].assess_readings(r).distance for r in tests_of[t][(t, "healthy")]],
                [oracle_models[t].assess_readings(r).distance for r in tests_of[t][(t, fault)]],
            )
            for t in bases
        ]
        record[f"auroc_{fault}"] = float(np.nanmean(aurocs))
        record[f"oracle_{fault}"] = float(np.nanmean(oracle))
        record[f"dr99_{fault}"] = float(
            np.mean(
                [
                    d > fleet[b].threshold_
                    for b in bases
                    for t in range(n_tasks)
                    for d in distances[(b, (t, fault))]
                ]
            )
        )
    record.update(_degradation(units, fleet, design, read))
    record.update(_robot_a(units[n_tasks], profile, prior, design, read))
    return record


def _degradation(
    units: Sequence[SimulatedRobot],
    fleet: Mapping[int, IndicatorModel],
    design: TransferDesign,
    read: Callable[[Capture], Readings],
) -> dict[str, object]:
    """Per fault: the share of the fleet's axes whose degradation run alarms before the
    breakdown, and the median severity of the first alarm (fleet axis ``t`` is ``units[t]``)."""
    days = design.degradation_days
    if days < 2:
        return {}
    severities = [k / days for k in range(1, days + 1)]
    record: dict[str, object] = {}
    for fault in FAULT_KINDS:
        first: list[float] = []
        for t, model in sorted(fleet.items()):
            for severity in severities[:-1]:  # the last capture is the breakdown itself
                fault_now = Fault(fault, severity)  # type: ignore[arg-type]
                capture = units[t].capture(t, fault=fault_now, seed=f"ramp{fault}{severity:.6f}")
                if model.assess_readings(read(capture)).alarm:
                    first.append(severity)
                    break
        record[f"ramp_alarmed_{fault}"] = len(first) / len(fleet) if fleet else math.nan
        record[f"ramp_severity_{fault}"] = float(np.median(first)) if first else math.nan
    return record


def robot_a_readings(
    robot: SimulatedRobot, read: Callable[[Capture], Readings], days: int
) -> list[Readings]:
    """Robot A's readings: a capture a day at a random phase for ``days`` days, the task
    changing on days ``days / 4``, ``days / 2`` and ``3 days / 4`` (tasks 0 to 3)."""
    changes = [round(days * k / 4) for k in (1, 2, 3)]
    tasks = [sum(day >= c for c in changes) for day in range(1, days + 1)]
    return [read(robot.capture(t, seed=f"robotA{day}")) for day, t in enumerate(tasks)]


def _robot_a(
    robot: SimulatedRobot,
    profile: AxisProfile,
    prior: object,
    design: TransferDesign,
    read: Callable[[Capture], Readings],
) -> dict[str, object]:
    taken = robot_a_readings(robot, read, design.robot_a_days)
    model = IndicatorModel(profile, order_lines=design.order_lines, whole_moves=design.whole_moves)
    model.fit_readings(taken[: design.n_calibration + 1]).use_fleet(prior)  # type: ignore[arg-type]
    verdicts = [model.assess_readings(r) for r in taken[design.n_calibration + 1 :]]
    return {
        "robot_a_fleet_check": int(model.fleet_check_ is not None),
        "robot_a_false_alarms": int(sum(v.alarm for v in verdicts)),
        "robot_a_days_scored": int(sum(v.scored for v in verdicts)),
        "robot_a_test_days": len(verdicts),
    }


def _one(args: tuple[int, TransferDesign]) -> dict[str, object]:
    # Parallelism is across robots; a multi-threaded BLAS inside each only fights for the cores
    # (a 10000 x 16 QR took 0.37 s instead of 0.02 s on a loaded 2-core machine).
    with threadpool_limits(1):
        return robot_transfer(*args)


def transfer_study(
    seeds: Sequence[int], design: TransferDesign = TransferDesign(), *, workers: int = 1
) -> pd.DataFrame:
    """:func:`robot_transfer` on every seed (in ``workers`` processes); one row per robot."""
    rows: dict[int, dict[str, object]] = {}
    for index, record in parallel_map(_one, [(s, design) for s in seeds], workers=workers):
        rows[index] = record
    return pd.DataFrame([rows[i] for i in sorted(rows)])


# --- real data -------------------------------------------------------------------------------


def _npz(path: Path) -> tuple[dict[str, NDArray[np.float64]], float]:
    with np.load(path, allow_pickle=False) as archive:
        channels = [str(c) for c in archive["channels"]]
        signals = {
            name: archive["signals"][j].astype(np.float64) for j, name in enumerate(channels)
        }
        fs = float(archive["fs"])
    return signals, fs


#: The hydraulic actuators' encoder: 14 bits a turn (PROVENANCE.md: assumed, not stated).
HYDRAULIC_RAD_PER_COUNT = 2 * math.pi / 16384


def hydraulic_captures(folder: Path) -> list[tuple[str, str, Capture]]:
    """(actuator, health, capture) per record: position from the angle, torque ``PG_1 - PG_2``."""
    index = pd.read_csv(folder / "index.csv")
    out = []
    for row in index.itertuples():
        signals, fs = _npz(folder / f"{row.recording_id}.npz")
        capture = Capture(
            {
                "position": signals["Angle"] * HYDRAULIC_RAD_PER_COUNT,
                "torque": signals["PG_1"] - signals["PG_2"],
            },
            {"position": fs, "torque": fs},
            source=str(row.recording_id),
        )
        out.append((str(row.actuator), str(row.health), capture))
    return out


def _hydraulic(
    folder: Path, n_calibration: int, percentile: float, order_lines: bool, whole_moves: bool
) -> list[dict[str, object]]:
    captures = hydraulic_captures(folder)
    units = sorted({a for a, _, _ in captures})
    reader = IndicatorModel(percentile=percentile, order_lines=order_lines, whole_moves=whole_moves)
    read = {a: [reader.readings(c) for u, _, c in captures if u == a] for a in units}
    health = {a: h for a, h, _ in captures}
    models = {
        a: IndicatorModel(
            percentile=percentile, order_lines=order_lines, whole_moves=whole_moves
        ).fit_readings(read[a][: n_calibration + 1])
        for a in units
    }
    pool = [models[a] for a in units]
    prior = pool_fleet(pool)  # the faulty unit included: the monitor can't know
    rows = []
    for k, a in enumerate(units):
        if health[a] != "healthy":
            continue
        model = models[a].use_fleet(prior, check_against=pool_fleet_without(pool, k))
        d = {u: [model.assess_readings(r).distance for r in read[u]] for u in units}
        own = d[a][n_calibration + 1 :]
        others = [x for u in units if u != a and health[u] == "healthy" for x in d[u]]
        faulty = [x for u in units if health[u] != "healthy" for x in d[u]]
        every = [x for u in units for x in d[u]]
        rows.append(
            {
                "dataset": "hydraulic_actuator",
                "baseline": a,
                "auroc": _auroc(others, faulty),
                "far99_own": float(np.mean([x > model.threshold_ for x in own])),
                "far99_other": float(np.mean([x > model.threshold_ for x in others])),
                "dr99": float(np.mean([x > model.threshold_ for x in faulty])),
                "share_scored": float(np.mean([math.isfinite(x) for x in every])),
                "n_captures": len(every),
                "baseline_check": model.baseline_check_,
            }
        )
    return rows


def linear_axis_captures(folder: Path, window_s: float = 20.0) -> dict[str, list[Capture]]:
    """Windows of ``window_s`` of each recording, on a uniform grid at the median step
    (the PLC logs every 39-55 ms): speed ``ActSpeed``, torque ``ActCurrent``; windows of the 2016
    session that hold a jam label are left out (not healthy)."""
    out: dict[str, list[Capture]] = {}
    for name in ("normal", "lineardrive_impaired", "pressure_anomaly", "session2016_jam_labels"):
        signals, _ = _npz(folder / f"{name}.npz")
        time_s = signals["time_s"] - signals["time_s"][0]
        step = float(np.median(np.diff(time_s)))
        grid = np.arange(0.0, time_s[-1], step)
        speed = np.interp(grid, time_s, signals["MotorData.ActSpeed"])
        current = np.interp(grid, time_s, signals["MotorData.ActCurrent"])
        label = (
            np.interp(grid, time_s, signals["Label"]) if "Label" in signals else np.zeros_like(grid)
        )
        n = round(window_s / step)
        out[name] = [
            Capture(
                {"speed": speed[k : k + n], "torque": current[k : k + n]},
                {"speed": 1.0 / step, "torque": 1.0 / step},
                source=f"{name}[{k}]",
            )
            for k in range(0, grid.size - n + 1, n)
            if not np.any(label[k : k + n] > 0)
        ]
    return out


def _linear_axis(
    folder: Path, n_calibration: int, percentile: float, order_lines: bool, whole_moves: bool
) -> list[dict[str, object]]:
    windows = linear_axis_captures(folder)
    reader = IndicatorModel(percentile=percentile, order_lines=order_lines, whole_moves=whole_moves)
    read = {k: [reader.readings(c) for c in v] for k, v in windows.items()}
    rows = []
    for base, other in (("normal", "session2016_jam_labels"), ("session2016_jam_labels", "normal")):
        model = IndicatorModel(
            percentile=percentile, order_lines=order_lines, whole_moves=whole_moves
        )
        model.fit_readings(read[base][: n_calibration + 1])
        d = {k: [model.assess_readings(r).distance for r in v] for k, v in read.items()}
        own = d[base][n_calibration + 1 :] + d["pressure_anomaly"] * (base == "normal")
        every = [x for v in d.values() for x in v]
        rows.append(
            {
                "dataset": "genesis_linear_axis",
                "baseline": base,
                "auroc": _auroc(d[other], d["lineardrive_impaired"]),
                "far99_own": float(np.mean([x > model.threshold_ for x in own])),
                "far99_other": float(np.mean([x > model.threshold_ for x in d[other]])),
                "dr99": float(np.mean([x > model.threshold_ for x in d["lineardrive_impaired"]])),
                "share_scored": float(np.mean([math.isfinite(x) for x in every])),
                "n_captures": len(every),
                "baseline_check": model.baseline_check_,
            }
        )
    return rows


REAL_DATASETS: tuple[str, ...] = ("hydraulic_actuator", "genesis_linear_axis")


def real_data_transfer(
    data_root: str | Path,
    *,
    n_calibration: int = 5,
    percentile: float = 99.0,
    datasets: Sequence[str] = REAL_DATASETS,
    order_lines: bool = False,
    whole_moves: bool = False,
) -> pd.DataFrame:
    """The same model on the real data sets found under ``data_root`` (absent ones skipped)."""
    with threadpool_limits(1):
        rows = _real_rows(
            Path(data_root), n_calibration, percentile, datasets, order_lines, whole_moves
        )
    return pd.DataFrame(rows)


def _real_rows(
    root: Path,
    n_calibration: int,
    percentile: float,
    datasets: Sequence[str],
    order_lines: bool,
    whole_moves: bool,
) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    if "hydraulic_actuator" in datasets and (root / "hydraulic_actuator" / "index.csv").is_file():
        rows += _hydraulic(
            root / "hydraulic_actuator", n_calibration, percentile, order_lines, whole_moves
        )
    if (
        "genesis_linear_axis" in datasets
        and (root / "genesis_linear_axis" / "normal.npz").is_file()
    ):
        rows += _linear_axis(
            root / "genesis_linear_axis", n_calibration, percentile, order_lines, whole_moves
        )
    return rows
