"""Figures (matplotlib imported lazily, Agg backend): the paper experiments and the monitor.

Pipeline top stage, beside :mod:`axiswatch._experiments` and under :mod:`axiswatch._report`.
Importing this module does not import matplotlib. Each function takes its table and an optional
``ax`` (or axes), and never calls ``plt.show``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["plot_distance_trend", "plot_roc", "plot_robot_study"]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_roc(table: pd.DataFrame, ax: Any = None) -> Any:
    """ROC points (FPR, TPR) of every method and protocol of :func:`~axiswatch._experiments.lab_roc`.

    Examples
    --------
    >>> table = pd.DataFrame({"method": ["lra"] * 2, "protocol": ["same_run"] * 2,
    ...                       "percentile": [50.0, 99.0], "fpr": [0.4, 0.0], "tpr": [1.0, 1.0],
    ...                       "auroc": [1.0, 1.0]})
    >>> plot_roc(table).axes[0].get_xlabel()
    'false positive rate'
    """
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 5))
    markers = dict(zip(sorted(table.protocol.unique()), "osD^v<>", strict=False))
    colours = {"lra": "tab:blue", "pca": "tab:red"}
    for (method, protocol), group in table.groupby(["method", "protocol"], sort=False):
        ordered = group.sort_values("percentile", ascending=False)
        ax.plot(
            ordered.fpr,
            ordered.tpr,
            marker=markers[protocol],
            color=colours.get(str(method)),
            label=f"{method}, {protocol} (AUROC {ordered.auroc.iloc[0]:.2f})",
            alpha=0.8,
        )
    ax.plot([0, 1], [0, 1], color="grey", linestyle=":", label="chance")
    ax.set(xlabel="false positive rate", ylabel="true positive rate", xlim=(-0.02, 1.02))
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize="x-small")
    ax.set_title("Lab dataset: ROC at the half-Laplace percentiles")
    return ax.figure


def plot_robot_study(table: pd.DataFrame, title: str, axes: Any = None) -> Any:
    """delta(t) of each method side by side (paper figs. 3-4), with and without phase alignment.

    Examples
    --------
    >>> table = pd.DataFrame({"day": [2, 3] * 2, "task": ["a", "b"] * 2,
    ...                       "method": ["lra", "lra", "pca", "pca"], "alignment": ["none"] * 4,
    ...                       "distance": [0.1, 0.2, 1.0, 3.0]})
    >>> len(plot_robot_study(table, "demo").axes)
    2
    """
    plt = _pyplot()
    methods = list(dict.fromkeys(table.method))
    if axes is None:
        _, axes = plt.subplots(1, len(methods), figsize=(6 * len(methods), 4), squeeze=False)
        axes = axes[0]
    changes = table.drop_duplicates("day").sort_values("day")
    change_days = changes.day[
        changes.task.ne(changes.task.shift()) & (changes.day > changes.day.min())
    ]
    for ax, method in zip(axes, methods, strict=True):
        for alignment, group in table[table.method == method].groupby("alignment"):
            ax.plot(
                group.day,
                group.distance,
                marker=".",
                linewidth=0.8,
                label=f"alignment: {alignment}",
            )
        for day in change_days:
            ax.axvline(day, color="grey", linestyle="--", linewidth=0.8)
        ax.set(xlabel="day", ylabel="distance delta(t)", title=f"{title}: {method}")
        ax.legend(fontsize="small")
    return axes[0].figure


def plot_distance_trend(
    results: pd.DataFrame,
    *,
    ax: Any = None,
    title: str | None = None,
    fault_dates: pd.Series | None = None,
    events: Sequence[tuple[str, str]] = (),
) -> Any:
    """Distance of every capture of one axis and method over time, with threshold and alarms.

    Parameters
    ----------
    results : DataFrame
        Rows of :func:`axiswatch._monitor.fleet_results` for one robot, axis and method:
        ``captured_at``, ``epoch``, ``role``, ``distance``, ``threshold``, ``over``, ``alarm``.
    ax : matplotlib Axes, optional
        Default: a new figure (Agg backend).
    title : str, optional
    fault_dates : Series of datetime, optional
        Ground truth (simulated fleets): dates of captures with a fault, drawn as a bar under the
        trend.
    events : sequence of (date-time, label), optional
        Known events (a task change, maintenance) drawn as dotted vertical lines.

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> import pandas as pd
    >>> rows = pd.DataFrame({
    ...     "captured_at": pd.date_range("2026-03-01", periods=4).astype(str),
    ...     "epoch": 1, "role": ["baseline", "calibration", "monitor", "monitor"],
    ...     "distance": [None, 1.0, 1.2, 5.0], "threshold": [None, 3.0, 3.0, 3.0],
    ...     "over": [False, False, False, True], "alarm": [False, False, False, True]})
    >>> ax = plot_distance_trend(rows, title="robot01/axis1 (lra)")
    >>> ax.get_title(loc="left")
    'robot01/axis1 (lra)'
    """
    if ax is None:
        _, ax = _pyplot().subplots(figsize=(9, 3))
    frame = results.copy()
    frame["when"] = pd.to_datetime(frame["captured_at"])
    day = pd.Timedelta(hours=12)
    for epoch, part in frame.groupby("epoch", sort=True):
        base = part[part.role == "baseline"]
        calibration = part[part.role == "calibration"]
        if not base.empty:
            start = base.when.iloc[0]
            ax.axvspan(start - day, start + day, color="tab:green", alpha=0.25, lw=0)
            ax.annotate(
                f"baseline {epoch}", (start, 1.0), xycoords=("data", "axes fraction"),
                va="top", ha="left", fontsize=7, color="tab:green",
            )  # fmt: skip
        if not calibration.empty:
            ax.axvspan(
                calibration.when.min() - day,
                calibration.when.max() + day,
                color="tab:blue",
                alpha=0.12,
                lw=0,
            )
        scored = part[part.role != "baseline"]
        threshold = scored.dropna(subset=["threshold"])
        if not threshold.empty:
            ax.step(
                threshold.when, threshold.threshold, where="mid", color="tab:red", lw=1,
                ls="--", label="threshold" if epoch == frame.epoch.min() else None,
            )  # fmt: skip
    scored = frame[frame.role != "baseline"].dropna(subset=["distance"])
    ax.plot(scored.when, scored.distance, color="0.3", lw=0.8, marker="o", ms=3, label="distance")
    over = scored[scored.over & ~scored.alarm]
    alarm = scored[scored.alarm]
    if not over.empty:
        ax.plot(over.when, over.distance, "o", color="orange", ms=5, label="over threshold")
    if not alarm.empty:
        ax.plot(alarm.when, alarm.distance, "X", color="tab:red", ms=8, label="alarm")
    positive = scored.distance[scored.distance > 0]
    if len(positive) and positive.max() / positive.min() > 100:
        ax.set_yscale("log")
    if fault_dates is not None and len(fault_dates):
        dates = pd.to_datetime(pd.Series(fault_dates))
        ax.plot(
            dates, np.zeros(len(dates)), "|", color="purple", ms=10,
            transform=ax.get_xaxis_transform(), label="fault (ground truth)",
        )  # fmt: skip
    for when, label in events:
        ax.axvline(pd.Timestamp(when), color="purple", ls=":", lw=1)
        ax.annotate(
            label, (pd.Timestamp(when), 0.98), xycoords=("data", "axes fraction"),
            va="top", ha="right", rotation=90, fontsize=7, color="purple",
        )  # fmt: skip
    ax.set_ylabel("distance")
    ax.legend(loc="upper left", fontsize=7, ncols=5, frameon=False, bbox_to_anchor=(0.0, -0.12))
    if title is not None:
        ax.set_title(title, fontsize=9, loc="left")
    ax.tick_params(labelsize=7)
    return ax


def plot_paired(table: Any, ax: Any = None) -> Any:
    """AUROC against the oracle's, one point per feature stage x method x fault.

    Points on the diagonal reach the oracle (a detector fitted on the test capture's own task);
    below 0.5 a healthy capture of another task looks sicker than a faulty one.

    Parameters
    ----------
    table : DataFrame
        Output of :func:`axiswatch._paired.paired_evaluation`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if ax is None:
        figure, ax = plt.subplots(figsize=(6.5, 5.5))
    else:
        figure = ax.figure
    markers = {"pca": "o", "lra": "s"}
    colours = dict(
        zip(
            sorted(table.features.unique()),
            plt.rcParams["axes.prop_cycle"].by_key()["color"],
            strict=False,
        )
    )
    for (features, method), group in table.groupby(["features", "method"]):
        ax.scatter(
            group.oracle_auroc,
            group.auroc,
            marker=markers.get(method, "^"),
            color=colours[features],
            label=f"{features} / {method}",
        )
        for row in group.itertuples():
            ax.annotate(
                row.fault[:2],
                (row.oracle_auroc, row.auroc),
                fontsize=7,
                xytext=(3, 2),
                textcoords="offset points",
            )
    ax.plot([0, 1], [0, 1], color="grey", linewidth=0.8)
    ax.axhline(0.5, color="grey", linestyle=":", linewidth=0.8)
    ax.set(
        xlim=(0, 1.02),
        ylim=(0, 1.02),
        xlabel="oracle AUROC (fitted on the test task)",
        ylabel="AUROC: faulty vs healthy other task",
    )
    ax.legend(fontsize=7, loc="lower right")
    return figure
