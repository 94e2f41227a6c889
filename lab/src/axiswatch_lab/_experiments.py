"""Paper experiments: the lab-generated dataset (paper, "Experimental Results").

Pipeline top stage for research use; the CLI's ``experiment`` commands call these functions.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.base import clone
from sklearn.metrics import roc_auc_score
from threadpoolctl import threadpool_limits

from axiswatch import (
    BaselineDetector,
    Capture,
    FeatureSpec,
    FeatureStage,
    HealthModel,
    IndicatorDetector,
    LRADetector,
    PCADetector,
    alarm_threshold,
    extract_features,
    half_laplace_threshold,
)
from axiswatch.datasets import LAB_DAYS, Fault, FaultKind, lab_dataset, simulate_capture
from axiswatch.exceptions import CalibrationError
from axiswatch_lab._mechanics import MECHANICS_TASK_CHANGE_SCALE, MechanicsStage

__all__ = [
    "LAB_FEATURES",
    "PERCENTILES",
    "PROTOCOLS",
    "ROBOT_A_TASKS",
    "ROBOT_FEATURES",
    "STAGE_METHODS",
    "alarm_summary",
    "lab_distances",
    "lab_roc",
    "robot_a",
    "robot_b",
]

#: Features of the lab experiment: the "stationary" reading under which the paper's claim holds
#: (see docs/paper-notes.md): circular padding, Hann window of 128, one row per sample, no
#: product channels, magnitude ("spectrum") scaling.
LAB_FEATURES = FeatureSpec(combinations="none", segment_length=128, padding="circular")


@dataclass(frozen=True)
class _Method:
    name: str
    detector: BaselineDetector


def lab_distances(
    *,
    seed: int = 0,
    features: FeatureSpec = LAB_FEATURES,
    percentile: float = 99.0,
) -> pd.DataFrame:
    """Distance of every lab day to day 1, for the LRA and PCA detectors, with verdicts.

    The threshold of each method is fitted on the healthy test days of both operations (days
    2, 3, 5-10 except the anomaly), the protocol under which the paper's figure is reproduced.

    Returns
    -------
    DataFrame with columns ``day``, ``label``, ``method``, ``distance``, ``threshold``, ``alarm``.

    Examples
    --------
    >>> table = lab_distances()
    >>> table[table.alarm].groupby("method").label.apply(list).to_dict()
    {'lra': ['A']}
    """
    data = lab_dataset(seed=seed)
    X = [extract_features(day.capture, features).X for day in data]
    rows = []
    for method in (_Method("lra", LRADetector()), _Method("pca", PCADetector())):
        with threadpool_limits(limits=1, user_api="blas"):
            detector = method.detector.fit(X[0])
            distances = np.array([detector.distance(x) for x in X[1:]])
        healthy = np.array([not day.anomalous for day in data[1:]])
        threshold = alarm_threshold(distances[healthy], percentile=percentile).value
        for day, distance in zip(data[1:], distances, strict=True):
            rows.append(
                {
                    "day": day.day,
                    "label": day.label,
                    "method": method.name,
                    "distance": float(distance),
                    "threshold": threshold,
                    "alarm": bool(distance > threshold),
                }
            )
    return pd.DataFrame(rows)


#: Threshold percentiles of the paper's fig. 2.
PERCENTILES: tuple[float, ...] = (50.0, 75.0, 90.0, 95.0, 97.5, 99.0)

#: Calibration protocols of :func:`lab_roc`: which healthy distances the half-Laplace is fitted on.
PROTOCOLS: tuple[str, ...] = ("same_run", "separate_runs", "all_days", "first_operation")


def _default_methods() -> dict[str, BaselineDetector]:
    return {"lra": LRADetector(), "pca": PCADetector()}


def _threshold(
    distances: NDArray[np.float64], percentile: float, floor: float | None = None
) -> float:
    try:
        return alarm_threshold(distances, percentile=percentile, floor=floor).value
    except CalibrationError:
        # Every calibration distance is exactly 0 (LRA embeds healthy days in its closed-form
        # bulk): the fit degenerates to a point mass at 0, whose every percentile is 0.
        if distances.size and not np.any(distances):
            return 0.0 if floor is None else floor
        raise


def lab_roc(
    *,
    seed: int = 0,
    n_repetitions: int = 10,
    percentiles: Sequence[float] = PERCENTILES,
    protocols: Sequence[str] = PROTOCOLS,
    features: FeatureSpec = LAB_FEATURES,
    methods: Mapping[str, BaselineDetector] | None = None,
    n_calibration_runs: int = 3,
    lab_options: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """TPR and FPR at half-Laplace percentiles, and AUROC, on the lab dataset (paper fig. 2).

    Each repetition draws a fresh lab run (new noise), fits every detector on its day 1 and
    scores days 2-10; day 4 ("A") is the positive, the other eight days (including the three
    second-operation days) the negatives. The threshold at each percentile comes from a
    half-Laplace fit of healthy distances chosen by the protocol:

    * ``same_run``: the run's own healthy test days (days 2, 3, 5-10: both operations; labels used);
    * ``separate_runs``: the healthy days 2-10 of ``n_calibration_runs`` other runs with the same
      schedule but no anomaly (fresh noise), scored against the same day-1 baseline;
    * ``all_days``: all nine test days of the run, anomaly included (no labels needed);
    * ``first_operation``: the run's healthy first-operation test days only (2, 3, 5, 9, 10), as if
      the second operation had not been seen at calibration time.

    When every calibration distance is exactly 0 the threshold is 0 (see ``_threshold``).

    Parameters
    ----------
    seed : int, default=0
        Seeds every run (repetitions and calibration runs get independent child seeds).
    n_repetitions : int, default=10
        Runs averaged, as in the paper.
    percentiles : sequence of float, default=PERCENTILES
    protocols : sequence of str, default=PROTOCOLS
    features : FeatureSpec, default=LAB_FEATURES
    methods : mapping of str to BaselineDetector, optional
        Default ``{"lra": LRADetector(), "pca": PCADetector()}``; each is cloned per run.
    n_calibration_runs : int, default=3
        Runs used by the ``separate_runs`` protocol.
    lab_options : mapping, optional
        Keyword arguments of :func:`~axiswatch.lab_dataset` (``sample_rate_hz``, ``noise_std``,
        ``continuous_time``, ...), to test the paper's gaps.

    Returns
    -------
    DataFrame
        One row per method x protocol x percentile: ``method``, ``protocol``, ``percentile``,
        ``fpr``, ``tpr`` (means over repetitions), ``auroc`` (mean over repetitions of
        :func:`sklearn.metrics.roc_auc_score` of the nine test days; threshold-free, so equal across
        protocols).

    Examples
    --------
    >>> table = lab_roc(n_repetitions=2, percentiles=[99.0], protocols=["same_run"])
    >>> table[["method", "fpr", "tpr", "auroc"]].to_string(index=False)
    'method  fpr  tpr  auroc\\n   lra  0.0  1.0  1.000\\n   pca  0.0  0.0  0.625'
    """
    unknown = [p for p in protocols if p not in PROTOCOLS]
    if unknown:
        raise ValueError(f"Unknown protocol(s) {unknown}; expected some of {list(PROTOCOLS)}.")
    if not (isinstance(n_repetitions, int) and n_repetitions >= 1):
        raise ValueError(
            f"The 'n_repetitions' parameter must be an int >= 1. Got {n_repetitions!r} instead."
        )
    methods = _default_methods() if methods is None else dict(methods)
    options = dict(lab_options or {})
    healthy_days = tuple("O1" if label == "A" else label for label in options.get("days", LAB_DAYS))
    children = np.random.SeedSequence(seed).spawn(n_repetitions * (1 + n_calibration_runs))
    with threadpool_limits(limits=1, user_api="blas"):
        records = _lab_roc_records(
            children,
            n_repetitions,
            n_calibration_runs,
            percentiles,
            protocols,
            features,
            methods,
            options,
            healthy_days,
        )
    table = pd.DataFrame(records)
    keys = ["method", "protocol", "percentile"]
    return table.groupby(keys, sort=False, as_index=False).mean()


def _lab_roc_records(
    children: Sequence[np.random.SeedSequence],
    n_repetitions: int,
    n_calibration_runs: int,
    percentiles: Sequence[float],
    protocols: Sequence[str],
    features: FeatureSpec,
    methods: Mapping[str, BaselineDetector],
    options: dict[str, Any],
    healthy_days: tuple[str, ...],
) -> list[dict[str, Any]]:
    # Small SVDs (300 x 195): BLAS threads only contend on a shared 2-core machine (measured
    # 10-20x slower with two threads under load), hence one thread for the whole experiment.
    records = []
    for rep in range(n_repetitions):
        seeds = children[rep * (1 + n_calibration_runs) : (rep + 1) * (1 + n_calibration_runs)]
        run = lab_dataset(seed=np.random.default_rng(seeds[0]), **options)
        test_X = [extract_features(day.capture, features).X for day in run[1:]]
        positive = np.array([day.anomalous for day in run[1:]])
        first_op = np.array([day.operation == "O1" and not day.anomalous for day in run[1:]])
        calibration_X = [
            extract_features(day.capture, features).X
            for child in seeds[1:]
            for day in lab_dataset(
                seed=np.random.default_rng(child), **{**options, "days": healthy_days}
            )[1:]
        ]
        for name, template in methods.items():
            detector = clone(template).fit(extract_features(run[0].capture, features).X)
            distances = np.array([detector.distance(x) for x in test_X])
            auroc = float(roc_auc_score(positive, distances))
            pools = {
                "same_run": distances[~positive],
                "separate_runs": np.array([detector.distance(x) for x in calibration_X]),
                "all_days": distances,
                "first_operation": distances[first_op],
            }
            for protocol in protocols:
                for percentile in percentiles:
                    alarm = distances > _threshold(pools[protocol], percentile)
                    records.append(
                        {
                            "method": name,
                            "protocol": protocol,
                            "percentile": float(percentile),
                            "fpr": float(alarm[~positive].mean()),
                            "tpr": float(alarm[positive].mean()),
                            "auroc": auroc,
                        }
                    )
    return records


#: Features of the robot studies: the paper's (products of the signals, Hann 128, circular
#: padding) but one row every 16 samples (8 ms, an eighth of the window) instead of every sample,
#: so that a 3 s capture gives 375 rows instead of 6,000 and a 190-day study runs in about a
#: minute. See docs/paper-notes.md.
ROBOT_FEATURES = FeatureSpec(segment_length=128, hop=16, padding="circular")

#: Robot A (paper fig. 3): the tasks it runs, changing on days 30, 87 and 125.
ROBOT_A_TASKS: tuple[str, ...] = ("long_fast", "heavy", "short_fast", "palletize")


#: Feature stage x detector pairs scored beside the paper's methods in the robot studies: the
#: product default chosen by :func:`axiswatch.select_default` (docs/evaluation.md).
StageMethod = tuple[Callable[[], FeatureStage], Callable[[], BaselineDetector]]
STAGE_METHODS: Mapping[str, StageMethod] = {"mechanics": (MechanicsStage, IndicatorDetector)}


def _day_row(
    day: int, capture: Capture, method: str, alignment: str, distance: float
) -> dict[str, Any]:
    """One row of a robot study's table."""
    return {
        "day": day,
        "task": capture.metadata["task"],
        "fault": capture.metadata["fault"],
        "severity": float(capture.metadata["severity"]),
        "method": method,
        "alignment": alignment,
        "distance": distance,
    }


def _score_days_stages(
    captures: Sequence[Capture], stage_methods: Mapping[str, StageMethod]
) -> list[dict[str, Any]]:
    """Distance of every capture to the first through each feature stage x detector."""
    rows = []
    for name, (stage_factory, detector_factory) in stage_methods.items():
        model = HealthModel(detector=detector_factory(), stage=stage_factory()).fit(captures[0])
        for day, capture in enumerate(captures[1:], start=2):
            rows.append(_day_row(day, capture, name, "none", model.distance(capture)))
    return rows


def alarm_summary(
    table: pd.DataFrame,
    *,
    n_calibration: int = 5,
    percentile: float = 99.0,
    task_change_scales: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """Alarms of a robot study: threshold from the first days, then count and first alarm.

    The threshold of every method and alignment is the ``percentile`` of the half-Laplace fit of
    the distances of days ``2 .. n_calibration + 1`` (captures of the baseline's task, as a
    commissioning engineer would take them), raised for a method of ``task_change_scales``
    (default: the product default ``{"mechanics": MECHANICS_TASK_CHANGE_SCALE}``) to the same
    percentile of healthy task changes in development, as the monitor does; every later day
    alarms when its distance exceeds it.

    Returns
    -------
    DataFrame
        ``method``, ``alignment``, ``threshold``, ``n_days`` (scored after calibration),
        ``false_alarms`` (alarms on healthy days), ``first_alarm_day`` (any day; NaN if none),
        ``first_faulty_alarm_day`` (first alarm on a day with a fault; NaN if none).

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"day": range(2, 12), "method": "m", "alignment": "none",
    ...     "fault": ["none"] * 9 + ["bearing"], "distance": [1.0] * 9 + [50.0]})
    >>> summary = alarm_summary(table)
    >>> int(summary.false_alarms[0]), float(summary.first_faulty_alarm_day[0])
    (0, 11.0)
    """
    if task_change_scales is None:
        task_change_scales = {"mechanics": MECHANICS_TASK_CHANGE_SCALE}
    rows = []
    for (method, alignment), group in table.groupby(["method", "alignment"], sort=False):
        group = group.sort_values("day")
        calibration = group.iloc[:n_calibration]
        scored = group.iloc[n_calibration:]
        scale = task_change_scales.get(str(method))
        threshold = _threshold(
            calibration.distance.to_numpy(),
            percentile,
            None if scale is None else half_laplace_threshold(scale, percentile),
        )
        alarm = scored.distance.to_numpy() > threshold
        healthy = (scored.fault == "none").to_numpy()
        days = scored.day.to_numpy()
        rows.append(
            {
                "method": method,
                "alignment": alignment,
                "threshold": threshold,
                "n_days": int(scored.shape[0]),
                "false_alarms": int(np.sum(alarm & healthy)),
                "first_alarm_day": float(days[alarm][0]) if alarm.any() else float("nan"),
                "first_faulty_alarm_day": (
                    float(days[alarm & ~healthy][0]) if (alarm & ~healthy).any() else float("nan")
                ),
            }
        )
    return pd.DataFrame(rows)


def _score_days(
    captures: Sequence[Capture], features: FeatureSpec, methods: Mapping[str, BaselineDetector]
) -> list[dict[str, Any]]:
    """Distance of every capture to the first, per method, with and without phase alignment.

    Features are taken once per capture and alignment and shared by the methods (the phase lag
    depends only on the baseline's signals, not on the detector).
    """
    rows: list[dict[str, Any]] = []
    if not methods:
        return rows
    for aligned in (False, True):
        models = {
            name: HealthModel(features, detector, align_phase=aligned).fit(captures[0])
            for name, detector in methods.items()
        }
        reference = next(iter(models.values()))
        for day, capture in enumerate(captures[1:], start=2):
            X = reference.featurize(capture)[0].X
            for name, model in models.items():
                alignment = "phase" if aligned else "none"
                distance = float(model.detector_.distance(X))
                rows.append(_day_row(day, capture, name, alignment, distance))
    return rows


def robot_a(
    *,
    seed: int = 0,
    n_days: int = 190,
    task_change_days: Sequence[int] = (30, 87, 125),
    tasks: Sequence[str] = ROBOT_A_TASKS,
    duration_s: float = 3.0,
    features: FeatureSpec = ROBOT_FEATURES,
    methods: Mapping[str, BaselineDetector] | None = None,
    stage_methods: Mapping[str, StageMethod] = STAGE_METHODS,
) -> pd.DataFrame:
    """Robot A (paper fig. 3): a healthy axis over ``n_days`` daily captures, task changes.

    Day 1 is the baseline; every later day's capture (random phase of the task cycle) is scored
    by each method, with and without :class:`~axiswatch.HealthModel`'s phase alignment, and by
    each of ``stage_methods`` (alignment "none": their rows are operating states or directions).

    Returns
    -------
    DataFrame
        ``day``, ``task``, ``fault``, ``severity``, ``method``, ``alignment`` ("none" or
        "phase"), ``distance``; days 2 .. n_days.

    Examples
    --------
    >>> table = robot_a(n_days=4, task_change_days=(3,), duration_s=0.5, stage_methods={})
    >>> table[(table.method == "lra") & (table.alignment == "none")].task.tolist()
    ['long_fast', 'heavy', 'heavy']
    """
    if len(tasks) < len(task_change_days) + 1:
        raise ValueError(
            f"Robot A needs {len(task_change_days) + 1} tasks for {len(task_change_days)} task "
            f"changes; got {len(tasks)}."
        )
    rng = np.random.default_rng(seed)
    captures = []
    for day in range(1, n_days + 1):
        task = tasks[sum(day >= change for change in task_change_days)]
        captures.append(simulate_capture(task, duration_s=duration_s, seed=rng))
    methods = _default_methods() if methods is None else dict(methods)
    with threadpool_limits(limits=1, user_api="blas"):
        return pd.DataFrame(
            _score_days(captures, features, methods) + _score_days_stages(captures, stage_methods)
        )


def robot_b(
    *,
    seed: int = 0,
    n_days: int = 148,
    task: str = "heavy",
    fault: FaultKind = "bearing",
    duration_s: float = 3.0,
    features: FeatureSpec = ROBOT_FEATURES,
    methods: Mapping[str, BaselineDetector] | None = None,
    stage_methods: Mapping[str, StageMethod] = STAGE_METHODS,
) -> pd.DataFrame:
    """Robot B (paper fig. 4): one task, a fault growing until breakdown on day ``n_days + 1``.

    The severity on day ``t`` is ``((t - 1) / n_days) ** 2``: negligible for months, then
    accelerating (wear that feeds on itself), 0.99 on the last day.

    Returns
    -------
    DataFrame
        As :func:`robot_a`.

    Examples
    --------
    >>> table = robot_b(n_days=3, duration_s=0.5, stage_methods={})
    >>> sorted(set(table.severity.round(3)))
    [0.111, 0.444]
    """
    rng = np.random.default_rng(seed)
    captures = []
    for day in range(1, n_days + 1):
        severity = ((day - 1) / n_days) ** 2
        today = Fault(fault, severity) if severity > 0 else None
        captures.append(simulate_capture(task, fault=today, duration_s=duration_s, seed=rng))
    methods = _default_methods() if methods is None else dict(methods)
    with threadpool_limits(limits=1, user_api="blas"):
        return pd.DataFrame(
            _score_days(captures, features, methods) + _score_days_stages(captures, stage_methods)
        )
