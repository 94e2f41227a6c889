"""Reading a monitoring store: results per capture, the fleet summary, rejections.

The report and the CLI read through it. It only reads.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np
import pandas as pd

from axiswatch._likely_faults import LIKELY_FAULTS, describe_top_indicator
from axiswatch.monitor._feedback import alarm_feedback
from axiswatch.monitor.store import StoreBackend

__all__ = ["fleet_rejections", "fleet_results", "fleet_summary", "indicator_spreads"]


def fleet_results(
    store: StoreBackend, *, robot: str | None = None, axis: str | None = None
) -> pd.DataFrame:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Further columns: ``captured_at``, ``epoch``, ``role``, ``over``, ``reason``, ``details``
    (JSON), ``path`` (relative to the fleet folder), ``top_indicator`` (for the indicator
    methods, over the threshold or in alarm: ``indicators``, the indicator that set the distance,
    the part it watches and its shift; ``mechanics``, the one with the largest share of the
    distance and its likely meaning; None otherwise), ``feedback`` (on the captures of an
    acknowledged alarm: the engineer's verdict, ``seen`` without one; None otherwise:
    :func:`~axiswatch.monitor._feedback.alarm_feedback`), ``mode`` (with ``--modes``: the
    capture's operating mode, and ``learning n of K`` while it is learned; None otherwise).
    Baseline rows are included (role ``baseline``, no distance).
    """
    frame = store.score_table(robot=robot, axis=axis)
    # Named only where it explains an alarm: "likely a damaged gear tooth" on a capture under
    # the threshold would read as a finding.
    parsed = [json.loads(details) for details in frame["details"]]
    frame["top_indicator"] = [
        _top_indicator(details) if flagged else None
        for details, flagged in zip(parsed, frame["over"] | frame["alarm"], strict=True)
    ]
    frame["feedback"] = alarm_feedback(frame, store.acknowledgements(robot, axis))
    frame["mode"] = [_mode(details) for details in parsed]
    return frame


def _mode(details: dict[str, Any]) -> str | None:
    """The capture's operating mode and its state, in words (``MonitorConfig.modes``)."""
    mode, state = details.get("mode"), details.get("mode_state")
    if mode is None:
        return None
    if state == "learning":
        return f"{mode} (learning {details.get('mode_seen')} of {details.get('mode_fit')})"
    return f"{mode} (drifted)" if state == "drift" else str(mode)


def _top_indicator(details: dict[str, Any]) -> str | None:
    """The method's own words where it stores them (``indicators``: the indicator that set the
    distance, in its allowance), else the indicator with the largest share (``mechanics``); the
    same rule as the alarm's reason and the report's first screen."""
    return details.get("top_indicator") or describe_top_indicator(details.get("indicators", {}))


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
    # Indicators with a known likely fault first, in that table's order.
    known = [name for name in LIKELY_FAULTS if name in frame.columns]
    return frame[known + [name for name in frame.columns if name not in known]]


def fleet_rejections(store: StoreBackend) -> pd.DataFrame:
    """Rejected capture files: robot, axis, capture, method, path, error, rejected_at."""
    return store.rejection_table()


def fleet_summary(
    store: StoreBackend, *, stale_after: timedelta | None = None, now: datetime | None = None
) -> pd.DataFrame:
    """One row per axis and method of the active baselines: the fleet's state at a glance.

    Columns: ``robot``, ``axis``, ``method``, ``epoch``, ``baseline`` (capture), ``threshold``,
    ``scored`` (calibration and monitored captures), ``over`` (captures over the threshold),
    ``alarms`` (alarms raised), ``last_capture``, ``last_distance``, ``last_seen`` (when a new
    capture file of the axis was last seen, UTC), ``state``, ``rejected`` (files of the axis
    rejected, removed ones included), ``threshold_origin``
    (:meth:`~axiswatch._calibration.Threshold.describe`), ``alarm_since`` (the capture that
    raised the alarm in force), ``acknowledged_by`` (who saw it, if anyone) and
    ``bad_data_acknowledged`` (when someone acknowledged the bad data after the last scored
    capture, ``rejections --ack``, if nothing after it still needs attention; None otherwise).

    ``state``, the first that holds: ``ALARM`` (the alarm rule fired and has not cleared),
    ``stale`` (no new capture file for longer than ``stale_after``), ``bad data`` (a capture
    after the last scored one was rejected by the data-quality check: no motion, a stuck signal,
    out of range; and nobody acknowledged it, nor was its file removed from the fleet folder:
    as in the report and the monitor's exit status), ``calibrating`` (threshold not set yet),
    ``ok``.
    """
    frame = store.summary_table()
    activity = store.axis_activity()[["robot", "axis", "last_seen_at"]]
    frame = frame.merge(activity, on=["robot", "axis"], how="left")
    frame = frame.merge(store.latest_bad_data(), on=["robot", "axis", "method"], how="left")
    when = datetime.now(UTC) if now is None else now
    seen = pd.to_datetime(frame["last_seen_at"], utc=True)
    stale = (
        np.zeros(len(frame), dtype=bool)
        if stale_after is None
        else ((pd.Timestamp(when) - seen) > pd.Timedelta(stale_after)).to_numpy(dtype=bool)
    )
    bad = (frame["bad_capture"].notna() & (frame["bad_capture"] > frame["last_capture"])).to_numpy(
        dtype=bool
    )
    # Acknowledged bad data after the last scored capture: no longer a state, said in a column.
    acknowledged = frame["seen_capture"].notna() & (frame["seen_capture"] > frame["last_capture"])
    acknowledged &= ~bad
    state = np.select(
        [
            frame["last_alarm"].fillna(0).astype(bool).to_numpy(),
            stale,
            bad,
            frame["threshold"].isna(),
        ],
        ["ALARM", "stale", "bad data", "calibrating"],
        "ok",
    )
    frame["state"] = state
    frame["bad_data_acknowledged"] = frame["seen_at"].where(acknowledged, None)
    frame = frame.rename(columns={"last_seen_at": "last_seen"})
    internal = ("last_alarm", "bad_capture", "seen_capture", "seen_at", "rejected")
    columns = [c for c in frame.columns if c not in internal]
    return frame[[*columns, "rejected"]]
