"""Reading a monitoring store: results per capture, the fleet summary, rejections.

Pipeline stage below the report and the CLI; it only reads.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pandas as pd

from axiswatch._attribution import describe_top_indicator
from axiswatch._calibration import HalfLaplaceFit
from axiswatch._mechanics import COLUMNS
from axiswatch.monitor._ledger import describe_threshold
from axiswatch.monitor._store import Store

__all__ = ["fleet_rejections", "fleet_results", "fleet_summary", "indicator_spreads"]


def fleet_results(store: Store, *, robot: str | None = None, axis: str | None = None) -> Any:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Further columns: ``captured_at``, ``epoch``, ``role``, ``over``, ``reason``, ``details``
    (JSON), ``path`` (relative to the fleet folder), ``top_indicator`` (for the default method,
    over the threshold or in alarm: the indicator with the largest share of the distance, its
    shift and likely meaning; None otherwise). Baseline rows are included
    (role ``baseline``, no distance).
    """
    frame = store.frame(
        "SELECT s.robot, s.axis, s.capture, s.method, s.distance, s.threshold, s.alarm, "
        "s.captured_at, b.epoch, s.role, s.over, s.reason, s.details, s.path FROM scores s "
        "JOIN baselines b ON b.id = s.baseline_id "
        "WHERE (? IS NULL OR s.robot=?) AND (? IS NULL OR s.axis=?) "
        "ORDER BY s.robot, s.axis, s.method, s.captured_at, s.capture, b.epoch",
        (robot, robot, axis, axis),
    )
    frame["alarm"] = frame["alarm"].astype(bool)
    frame["over"] = frame["over"].astype(bool)
    frame["distance"] = frame["distance"].astype(np.float64)
    frame["threshold"] = frame["threshold"].astype(np.float64)
    # Named only where it explains an alarm: "likely a damaged gear tooth" on a capture under
    # the threshold would read as a finding.
    frame["top_indicator"] = [
        describe_top_indicator(json.loads(details).get("indicators", {})) if flagged else None
        for details, flagged in zip(frame["details"], frame["over"] | frame["alarm"], strict=True)
    ]
    return frame


def indicator_spreads(results: pd.DataFrame) -> pd.DataFrame:
    """Each indicator's shift from the baseline in healthy spreads, one column per indicator.

    Parameters
    ----------
    results : DataFrame
        :func:`fleet_results` (its ``details`` column).

    Returns
    -------
    DataFrame
        Same index; NaN where a score has no indicators (baselines, the paper's methods).
    """
    rows = [
        {name: entry["spreads"] for name, entry in json.loads(d).get("indicators", {}).items()}
        for d in results["details"]
    ]
    frame = pd.DataFrame(rows, index=results.index, dtype=np.float64)
    known = [name for name in COLUMNS if name in frame.columns]  # in the stage's order
    return frame[known + [name for name in frame.columns if name not in known]]


def fleet_rejections(store: Store) -> Any:
    """Rejected capture files: robot, axis, capture, method, path, error, rejected_at."""
    return store.frame(
        "SELECT robot, axis, capture, method, path, error, rejected_at FROM rejections "
        "ORDER BY robot, axis, path, method, id"
    )


def fleet_summary(store: Store) -> Any:
    """One row per axis and method of the active baselines: the fleet's state at a glance.

    Columns: ``robot``, ``axis``, ``method``, ``epoch``, ``baseline`` (capture), ``threshold``,
    ``scored`` (calibration and monitored captures), ``over`` (captures over the threshold),
    ``alarms`` (alarms raised), ``last_capture``, ``last_distance``, ``state``
    (``calibrating``, ``ok`` or ``ALARM``), ``rejected`` (files of the axis rejected),
    ``threshold_origin`` (:func:`~axiswatch.monitor._ledger.describe_threshold`), ``alarm_since`` (the
    capture that raised the alarm in force) and ``acknowledged_by`` (who saw it, if anyone).
    """
    frame = store.frame(
        "SELECT b.robot, b.axis, b.method, b.epoch, b.capture AS baseline, b.threshold, "
        "b.calibration, b.params, "
        "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.role!='baseline') "
        "AS scored, "
        "(SELECT coalesce(sum(s.over), 0) FROM scores s WHERE s.baseline_id=b.id) AS over, "
        "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.alarm=1 AND NOT coalesce("
        "(SELECT p.alarm FROM scores p WHERE p.baseline_id=b.id AND p.role='monitor' "
        "AND p.id<s.id ORDER BY p.id DESC LIMIT 1), 0)) AS alarms, "
        "(SELECT s.capture FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC LIMIT 1) "
        "AS last_capture, "
        "(SELECT s.distance FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC LIMIT 1) "
        "AS last_distance, "
        "(SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor' "
        "ORDER BY s.id DESC LIMIT 1) AS last_alarm, "
        "(SELECT count(*) FROM rejections r WHERE r.robot=b.robot AND r.axis=b.axis "
        "AND r.method=b.method) AS rejected "
        "FROM baselines b WHERE b.retired_at IS NULL ORDER BY b.robot, b.axis, b.method"
    )
    state = np.where(
        frame["threshold"].isna(),
        "calibrating",
        np.where(frame["last_alarm"].fillna(0).astype(bool), "ALARM", "ok"),
    )
    frame["state"] = state
    frame["threshold_origin"] = [
        None
        if threshold is None or pd.isna(threshold) or calibration is None
        else describe_threshold(
            float(threshold),
            HalfLaplaceFit(**json.loads(calibration)),
            float(json.loads(params)["percentile"]),
        )
        for threshold, calibration, params in zip(
            frame["threshold"], frame["calibration"], frame["params"], strict=True
        )
    ]
    alarms = {(a.robot, a.axis, a.method): a for a in store.alarms()}
    keys = list(zip(frame["robot"], frame["axis"], frame["method"], strict=True))
    frame["alarm_since"] = [getattr(alarms.get(k), "raised_capture", None) for k in keys]
    frame["acknowledged_by"] = [getattr(alarms.get(k), "acknowledged_by", None) for k in keys]
    return frame.drop(columns=["last_alarm", "calibration", "params"])
