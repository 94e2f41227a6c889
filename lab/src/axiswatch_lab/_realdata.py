"""Cross-condition evaluation on recorded data (gearbox, CWRU bearings).

Pipeline top stage for research use; the CLI's ``experiment gearbox`` and ``experiment cwru``
call :func:`evaluate_dataset`. Protocol (after the datasets' ``days.csv``):

* the **baseline** is the first ``n_baseline_segments`` healthy segments of the baseline condition
  (its feature matrix is the rows of those segments, stacked);
* the remaining healthy segments of that condition are the **calibration** set: the half-Laplace
  fit of their distances gives the thresholds at the 95th and 99th percentile;
* healthy segments of **other** conditions must not alarm (operation change); **faulty** segments
  of any condition must.

Per method and baseline condition: ``auroc`` (faulty vs healthy-other-condition segments;
threshold-free), ``far95``/``far99`` (share of healthy-other-condition segments above the
threshold) and ``dr95``/``dr99`` (share of faulty segments, all conditions, above it). Where a
dataset has no healthy segment of another condition (CWRU: healthy data only at 0 HP), ``auroc``
and ``far*`` cannot be measured and are NaN.

Features are chosen a priori for single high-rate accelerometers (not tuned on these data): every
accelerometer channel, no product channels (a product of two vibration signals has no physical
meaning such as the mechanical power ``speed * torque`` of the paper), Hann window of 128 samples,
``hop = 128`` (non-overlapping windows, so each sample enters one row; chosen for run time: LRA's
eigenproblem grows with the number of rows) and ``padding = "valid"`` (segments are not whole
cycles, so wrapping them around would create an artificial edge).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.signal import butter, hilbert, sosfiltfilt
from sklearn.metrics import roc_auc_score

from axiswatch import (
    BaselineDetector,
    FeatureSpec,
    LRADetector,
    PCADetector,
    alarm_threshold,
    extract_features,
)
from axiswatch.datasets import Segment, read_dataset
from axiswatch.exceptions import CalibrationError, DataNotFoundError
from axiswatch_lab._domain_adaptation import (
    CORALDetector,
    EnergyDetector,
    SubspaceAlignmentDetector,
)
from axiswatch_lab._plots import new_axes
from axiswatch_lab._product import bearing_lines

__all__ = [
    "CWRU_FEATURES",
    "GEARBOX_FEATURES",
    "REAL_DATA_METHODS",
    "bearing_line_readings",
    "evaluate_dataset",
    "plot_distances",
    "segment_distances",
    "summarize_distances",
    "summarize_line_readings",
]

GEARBOX_FEATURES = FeatureSpec(
    signals=("a1", "a2", "a3", "a4"),
    combinations="none",
    segment_length=128,
    hop=128,
    padding="valid",
)
CWRU_FEATURES = FeatureSpec(
    signals=("DE_accel", "FE_accel"),
    combinations="none",
    segment_length=128,
    hop=128,
    padding="valid",
)

#: Methods compared, each with parameters fixed a priori (the detectors' defaults: PCA and the
#: distribution detectors keep 95 % of the baseline's variance; LRA is the paper's mu=0.5, d=2,
#: lambda=1; CORAL uses Ledoit-Wolf shrinkage).
REAL_DATA_METHODS: dict[str, Callable[[], BaselineDetector]] = {
    "pca": PCADetector,
    "lra": LRADetector,
    "energy": EnergyDetector,
    "coral": CORALDetector,
    "sa": SubspaceAlignmentDetector,
}

SUMMARY_COLUMNS = ["method", "baseline_condition", "auroc", "far95", "dr95", "far99", "dr99"]


def _roles(
    segments: Sequence[Segment], baseline_condition: str, n_baseline_segments: int
) -> list[str]:
    healthy_here = [
        i for i, s in enumerate(segments) if s.healthy and s.condition == baseline_condition
    ]
    if len(healthy_here) < n_baseline_segments + 2:
        conditions = sorted({s.condition for s in segments if s.healthy})
        raise ValueError(
            f"The baseline condition {baseline_condition!r} needs at least "
            f"{n_baseline_segments + 2} healthy segments ({n_baseline_segments} baseline, 2 "
            f"calibration); it has {len(healthy_here)}. Conditions with healthy data: {conditions}."
        )
    first_recording = segments[healthy_here[0]].recording_id
    baseline = [i for i in healthy_here if segments[i].recording_id == first_recording]
    baseline = sorted(baseline, key=lambda i: segments[i].start)[:n_baseline_segments]
    roles = []
    for i, s in enumerate(segments):
        same = s.condition == baseline_condition
        if i in baseline:
            roles.append("baseline")
        elif s.healthy:
            roles.append("calibration" if same else "healthy_other")
        else:
            roles.append("fault_same" if same else "fault_other")
    return roles


def segment_distances(
    segments: Sequence[Segment],
    features: FeatureSpec,
    *,
    baseline_conditions: Sequence[str] | None = None,
    methods: Sequence[str] | None = None,
    n_baseline_segments: int | None = None,
) -> pd.DataFrame:
    """Distance of every segment to the baseline, for every method and baseline condition.

    Parameters
    ----------
    segments : sequence of Segment
        From :func:`axiswatch.read_dataset`.
    features : FeatureSpec
        How each segment becomes features (for instance :data:`GEARBOX_FEATURES`).
    baseline_conditions : sequence of str, optional
        Default: every condition with enough healthy segments.
    methods : sequence of str, optional
        Keys of :data:`REAL_DATA_METHODS`; default all.
    n_baseline_segments : int, optional
        Default: the number of segments ``days.csv`` marks ``baseline`` (at least 1).

    Returns
    -------
    DataFrame
        One row per (baseline condition, method, segment): ``baseline_condition``, ``method``,
        ``segment_id``, ``recording_id``, ``condition``, ``healthy``, ``role`` (``baseline``,
        ``calibration``, ``healthy_other``, ``fault_same``, ``fault_other``), ``distance``,
        ``threshold95``, ``threshold99``. Baseline segments get no distance (NaN).

    Raises
    ------
    ValueError
        An unknown method, or a baseline condition without enough healthy segments.
    """
    methods = list(REAL_DATA_METHODS) if methods is None else list(methods)
    unknown = [m for m in methods if m not in REAL_DATA_METHODS]
    if unknown:
        raise ValueError(
            f"Unknown method(s) {unknown}; expected some of {list(REAL_DATA_METHODS)}."
        )
    if n_baseline_segments is None:
        n_baseline_segments = max(1, sum(s.role == "baseline" for s in segments))
    if baseline_conditions is None:
        counts = pd.Series([s.condition for s in segments if s.healthy]).value_counts()
        baseline_conditions = sorted(counts.index[counts >= n_baseline_segments + 2])
    matrices = [extract_features(s.capture, features).X for s in segments]
    rows: list[dict[str, Any]] = []
    for condition in baseline_conditions:
        roles = _roles(segments, condition, n_baseline_segments)
        baseline = np.vstack([m for m, r in zip(matrices, roles, strict=True) if r == "baseline"])
        for method in methods:
            detector = REAL_DATA_METHODS[method]().fit(baseline)
            distances = np.array(
                [
                    np.nan if r == "baseline" else detector.distance(m)
                    for m, r in zip(matrices, roles, strict=True)
                ]
            )
            try:
                healthy = distances[np.array(roles) == "calibration"]
                thresholds = (
                    alarm_threshold(healthy, percentile=95).value,
                    alarm_threshold(healthy, percentile=99).value,
                )
            except CalibrationError:
                # A method blind to these data (every healthy distance 0, e.g. LRA when no
                # singular value exceeds sqrt(lambda)) gets no threshold: its far/dr are NaN.
                thresholds = (np.nan, np.nan)
            for segment, role, distance in zip(segments, roles, distances, strict=True):
                rows.append(
                    {
                        "baseline_condition": condition,
                        "method": method,
                        "segment_id": segment.segment_id,
                        "recording_id": segment.recording_id,
                        "condition": segment.condition,
                        "healthy": segment.healthy,
                        "role": role,
                        "distance": float(distance),
                        "threshold95": thresholds[0],
                        "threshold99": thresholds[1],
                    }
                )
    return pd.DataFrame(rows)


def summarize_distances(distances: pd.DataFrame) -> pd.DataFrame:
    """The evaluation table of :func:`segment_distances`' output, one row per method and baseline.

    Returns
    -------
    DataFrame with columns exactly ``method``, ``baseline_condition``, ``auroc``, ``far95``,
    ``dr95``, ``far99``, ``dr99`` (see the module docstring; NaN where not measurable).

    Examples
    --------
    >>> import pandas as pd
    >>> rows = pd.DataFrame({"method": "m", "baseline_condition": "c",
    ...     "role": ["healthy_other", "healthy_other", "fault_other", "fault_same"],
    ...     "distance": [1.0, 3.0, 2.0, 5.0], "threshold95": 2.5, "threshold99": 4.0})
    >>> summarize_distances(rows).iloc[0].to_dict()
    {'method': 'm', 'baseline_condition': 'c', 'auroc': 0.75, 'far95': 0.5, 'dr95': 0.5, 'far99': 0.0, 'dr99': 0.5}
    """
    table = []
    for (method, condition), group in distances.groupby(
        ["method", "baseline_condition"], sort=False
    ):
        healthy = group.loc[group.role == "healthy_other", "distance"].to_numpy()
        faulty = group.loc[group.role.isin(["fault_same", "fault_other"]), "distance"].to_numpy()
        row: dict[str, Any] = {"method": method, "baseline_condition": condition}
        row["auroc"] = (
            float(
                roc_auc_score(
                    np.r_[np.zeros(healthy.size), np.ones(faulty.size)], np.r_[healthy, faulty]
                )
            )
            if healthy.size and faulty.size
            else np.nan
        )
        for q in (95, 99):
            threshold = float(group[f"threshold{q}"].iloc[0])
            measurable = not np.isnan(threshold)
            row[f"far{q}"] = (
                float(np.mean(healthy > threshold)) if healthy.size and measurable else np.nan
            )
            row[f"dr{q}"] = (
                float(np.mean(faulty > threshold)) if faulty.size and measurable else np.nan
            )
        table.append(row)
    return pd.DataFrame(table, columns=SUMMARY_COLUMNS)


def evaluate_dataset(
    segments: Sequence[Segment],
    features: FeatureSpec,
    **kwargs: Any,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Distances of every segment and the evaluation table (see :func:`segment_distances`)."""
    distances = segment_distances(segments, features, **kwargs)
    return distances, summarize_distances(distances)


_ROLE_STYLE = {
    "calibration": ("tab:blue", "o", "healthy, baseline condition (calibration)"),
    "healthy_other": ("tab:green", "s", "healthy, other condition"),
    "fault_same": ("tab:red", "^", "faulty, baseline condition"),
    "fault_other": ("tab:orange", "v", "faulty, other condition"),
}


def plot_distances(distances: pd.DataFrame, *, axes: Any = None) -> Any:
    """Distance of every segment (log scale), one panel per method and baseline condition.

    Parameters
    ----------
    distances : DataFrame
        Output of :func:`segment_distances`.
    axes : array of matplotlib Axes of shape (n_methods, n_baselines), optional
        Default: a new figure (no pyplot, no backend switched).

    Returns
    -------
    matplotlib Figure
    """
    methods = list(dict.fromkeys(distances.method))
    conditions = list(dict.fromkeys(distances.baseline_condition))
    if axes is None:
        axes = new_axes(
            len(methods),
            len(conditions),
            figsize=(3.2 * len(conditions) + 1, 1.9 * len(methods) + 0.8),
            squeeze=False,
            sharex=True,
        )
    axes = np.asarray(axes).reshape(len(methods), len(conditions))
    for i, method in enumerate(methods):
        for j, condition in enumerate(conditions):
            ax = axes[i, j]
            group = distances[
                (distances.method == method) & (distances.baseline_condition == condition)
            ]
            group = group[group.role != "baseline"].reset_index(drop=True)
            for role, (color, marker, label) in _ROLE_STYLE.items():
                part = group[group.role == role]
                ax.scatter(part.index, part.distance, s=9, c=color, marker=marker, label=label)
            ax.axhline(
                group.threshold99.iloc[0], color="k", lw=0.8, ls="--", label="99th pct threshold"
            )
            ax.set_yscale("log")
            ax.tick_params(labelsize=7)
            if i == 0:
                ax.set_title(f"baseline {condition}", fontsize=9)
            if j == 0:
                ax.set_ylabel(method, fontsize=9)
    fig = axes[0, 0].figure
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, fontsize=7, frameon=False)
    fig.supxlabel("segment (in days.csv order)", fontsize=8, y=0.04)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig


def bearing_line_readings(
    folder: str | Path,
    *,
    channel: str = "DE_accel",
    bearing_order: float = 5.4152,
    band_hz: tuple[float, float] = (40.0, 300.0),
    envelope_band_hz: tuple[float, float] = (2000.0, 5000.0),
    recordings: Sequence[str] | None = None,
) -> pd.DataFrame:
    """The product default's bearing-line indicator on a vibration dataset with a known speed.

    The only part of :class:`~axiswatch_lab.MechanicsStage` that applies to an accelerometer on a
    machine at constant speed: :func:`~axiswatch.line_ratio` at ``bearing_order`` and its
    sidebands (+-1, +-2; its double +-1), over the orders +-0.25 beside them, of the signal in
    ``band_hz``, the shaft angle being ``2 pi rpm / 60 t`` (``rpm`` from ``index.csv``'s
    ``condition_desc``, "... 1797 rpm"), i.e. :func:`~axiswatch.bearing_lines`. Read two ways: on the raw band, as on the robot's
    torque, and on the envelope of ``envelope_band_hz`` (the structure's resonance that bearing
    impacts ring, demodulated), as vibration practice reads bearings. The default
    ``bearing_order`` is the inner-race defect order of CWRU's drive-end bearing (6205-2RS JEM
    SKF: 5.4152); the envelope band was set once, a priori, not tuned.

    Returns
    -------
    DataFrame
        One row per segment: ``segment``, ``recording``, ``condition``, ``healthy``, ``fault``
        (``"none"`` when healthy), ``rpm``, ``lines_raw``, ``lines_envelope`` (``log10`` of the
        ratio).
    """
    folder = Path(folder)
    index = pd.read_csv(folder / "index.csv").set_index("recording_id")
    rows = []
    filters: dict[float, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for segment in read_dataset(folder, recordings=recordings):
        description = str(index.loc[segment.recording_id, "condition_desc"])
        match = re.search(r"(\d+(?:\.\d+)?) rpm", description)
        if match is None:
            raise DataNotFoundError(
                f"{folder / 'index.csv'}: column 'condition_desc' of {segment.recording_id} gives "
                f"no shaft speed; expected '... <number> rpm', got {description!r}."
            )
        capture = segment.capture
        if channel not in capture.signals:
            raise DataNotFoundError(
                f"{folder / (segment.recording_id + '.npz')}: no channel {channel!r}; "
                f"expected one of {sorted(capture.signals)}."
            )
        rate = float(capture.rates_hz[channel])
        signal = np.asarray(capture.signals[channel], dtype=np.float64)
        rpm = float(match.group(1))
        theta = np.asarray(2 * np.pi * rpm / 60.0 * np.arange(signal.size) / rate, dtype=np.float64)
        if rate not in filters:
            filters[rate] = (
                butter(4, band_hz, btype="bandpass", fs=rate, output="sos"),
                butter(4, envelope_band_hz, btype="bandpass", fs=rate, output="sos"),
            )
        band, resonance = filters[rate]
        envelope = np.abs(hilbert(sosfiltfilt(resonance, signal)))
        fault = str(index.loc[segment.recording_id, "fault_type"])
        rows.append(
            {
                "segment": segment.segment_id,
                "recording": segment.recording_id,
                "condition": segment.condition,
                "healthy": segment.healthy,
                "fault": "none" if segment.healthy or fault == "nan" else fault,
                "rpm": rpm,
                "lines_raw": float(
                    np.log10(bearing_lines(sosfiltfilt(band, signal), theta, bearing_order))
                ),
                "lines_envelope": float(
                    np.log10(bearing_lines(sosfiltfilt(band, envelope), theta, bearing_order))
                ),
            }
        )
    return pd.DataFrame(rows)


def summarize_line_readings(readings: pd.DataFrame) -> pd.DataFrame:
    """AUROC of each fault type's segments against the healthy ones, for both readings.

    Returns
    -------
    DataFrame
        ``fault``, ``n_segments``, ``auroc_raw``, ``auroc_envelope``.
    """
    healthy = readings[readings.healthy]
    rows = []
    for fault, faulty in readings[~readings.healthy].groupby("fault", sort=True):
        labels = np.r_[np.zeros(len(healthy)), np.ones(len(faulty))]
        row: dict[str, Any] = {"fault": fault, "n_segments": len(faulty)}
        for column in ("raw", "envelope"):
            scores = np.r_[healthy[f"lines_{column}"], faulty[f"lines_{column}"]]
            row[f"auroc_{column}"] = float(roc_auc_score(labels, scores))
        rows.append(row)
    return pd.DataFrame(rows)
