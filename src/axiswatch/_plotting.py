"""Figures of the library: a distance trend with its threshold.

Matplotlib is imported lazily. Each function takes an optional ``ax``. Without one it draws on
its own figure, made without pyplot, so no backend is chosen or switched.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["new_axes", "plot_distance_trend"]


def new_axes(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **kwargs: Any) -> Any:
    """A new :class:`matplotlib.figure.Figure` and its axes (``Figure.subplots``), without pyplot.

    The figure belongs to no pyplot window manager: it needs no ``close`` and ``savefig`` writes
    it with the renderer of the file type, whatever backend the user has chosen.

    Examples
    --------
    >>> axes = new_axes(1, 2, figsize=(4.0, 2.0), squeeze=False)
    >>> axes.shape, type(axes[0, 0].figure).__name__
    ((1, 2), 'Figure')
    """
    from matplotlib.figure import Figure

    return Figure(figsize=figsize).subplots(nrows, ncols, **kwargs)


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
        Rows of :func:`axiswatch.monitor.fleet_results` for one robot, axis and method:
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
        ax = new_axes(figsize=(9, 3))
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
