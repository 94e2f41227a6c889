"""Reading a monitoring store: results per capture, the fleet summary, rejections.

Pipeline stage below the report and the CLI; it only reads.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from axiswatch.monitor._store import StoreBackend

__all__ = ["fleet_rejections", "fleet_results", "fleet_summary"]


def fleet_results(
    store: StoreBackend, *, robot: str | None = None, axis: str | None = None
) -> pd.DataFrame:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Further columns: ``captured_at``, ``epoch``, ``role``, ``over``, ``reason``, ``details``.
    Baseline rows are included (role ``baseline``, no distance).
    """
    return store.score_table(robot=robot, axis=axis)


def fleet_rejections(store: StoreBackend) -> pd.DataFrame:
    """Rejected capture files: robot, axis, capture, method, path, error, rejected_at."""
    return store.rejection_table()


def fleet_summary(store: StoreBackend) -> pd.DataFrame:
    """One row per axis and method of the active baselines: the fleet's state at a glance.

    Columns: ``robot``, ``axis``, ``method``, ``epoch``, ``baseline`` (capture), ``threshold``,
    ``scored`` (calibration and monitored captures), ``over`` (captures over the threshold),
    ``alarms`` (alarms raised), ``last_capture``, ``last_distance``, ``state``
    (``calibrating``, ``ok`` or ``ALARM``), ``rejected`` (files of the axis rejected).
    """
    frame = store.summary_table()
    state = np.where(
        frame["threshold"].isna(),
        "calibrating",
        np.where(frame["last_alarm"].fillna(0).astype(bool), "ALARM", "ok"),
    )
    frame["state"] = state
    return frame.drop(columns="last_alarm")
