"""The store's records: what goes in and comes out, in domain words, for every backend.

With the time stamps, the summary columns and the messages the backends share.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import pandas as pd

from axiswatch._calibration import HalfLaplaceFit
from axiswatch.monitor._decision import DecisionRule, stored_threshold

__all__ = [
    "AddedBaseline",
    "AlarmState",
    "Baseline",
    "BaselineCheck",
    "ChangedFile",
    "IndexedFile",
    "NewBaseline",
    "NewScore",
    "Rejection",
    "SavedModel",
    "ScoredFile",
    "now",
    "now_us",
    "summary_extras",
]


def now() -> str:
    """The store's time stamp: UTC, ISO 8601, whole seconds."""
    return datetime.now(UTC).isoformat(timespec="seconds")


def now_us() -> str:
    """UTC to the microsecond: orders the rejections seen again within one run."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


@dataclass(frozen=True)
class Baseline:
    """A stored baseline of one axis and method (one epoch).

    ``threshold`` and ``fit`` are None while it calibrates; ``retired`` once re-baselined.
    """

    id: int
    robot: str
    axis: str
    method: str
    epoch: int
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    features_hash: str
    params: str
    threshold: float | None
    fit: HalfLaplaceFit | None
    retired: bool


@dataclass(frozen=True)
class NewBaseline:
    """A baseline to add, with the score row of its capture (role ``baseline``)."""

    robot: str
    axis: str
    method: str
    epoch: int
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    features_hash: str
    params: str
    library_version: str
    file_size: int
    file_mtime_ns: int
    reason: str
    details: dict[str, Any]
    #: The checks of the baseline that need a person (kind -> note, as in
    #: :class:`BaselineCheck`), stored with it in one transaction.
    checks: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class BaselineCheck:
    """A note on an active baseline that needs a person until acknowledged or re-baselined.

    ``kind``: ``baseline`` (its capture disagrees with the calibration captures after it: a
    faulty first capture?) or ``fleet`` (it differs from its fleet's by more than a task-change
    allowance: worn already, or another task).
    """

    baseline_id: int
    robot: str
    axis: str
    method: str
    path: str
    kind: str
    note: str
    detected_at: str
    acknowledged_at: str | None = None


@dataclass(frozen=True)
class AddedBaseline:
    """The epoch's baseline after :meth:`StoreBackend.add_baseline`: its id, and whether this
    call added it (False: another process had added the same capture first, so that two runs
    on one store do not both count it as new)."""

    id: int
    added: bool


@dataclass(frozen=True)
class NewScore:
    """A scored capture of one baseline, before its decision (role, threshold, alarm)."""

    baseline_id: int
    robot: str
    axis: str
    method: str
    capture: str
    captured_at: datetime
    path: str
    file_hash: str
    file_size: int
    file_mtime_ns: int
    distance: float
    details: dict[str, Any]


@dataclass(frozen=True)
class Rejection:
    """A capture file that could not be used, and why (one line naming the file)."""

    robot: str
    axis: str
    method: str
    capture: str
    path: str
    file_hash: str
    error: str
    #: ``layout``, ``unreadable``, ``invalid``, ``bad data``, ``out of order`` or ``future``.
    kind: str = "invalid"
    #: The parameters the rejection was made under (None: it does not depend on them).
    params_hash: str | None = None
    #: Re-checked every run (an unreadable file, a future date); forgotten once resolved.
    transient: bool = False
    acknowledged_at: str | None = None
    #: What an acknowledgement of it is of, where ``error`` also says something that changes
    #: without being news (a misnamed folder's file count); None: the whole ``error``.
    reason_key: str | None = None
    #: When a run found the file gone from the fleet folder (deleted or moved away): kept as
    #: history, no longer a problem; None while the rejected content is there.
    removed_at: str | None = None


@dataclass(frozen=True)
class ScoredFile:
    """What a file was when it was last scored (to notice a later change of content)."""

    robot: str
    axis: str
    capture: str
    path: str
    file_hash: str
    file_size: int
    file_mtime_ns: int


@dataclass(frozen=True)
class ChangedFile:
    """A file whose content changed after it was scored."""

    robot: str
    axis: str
    capture: str
    path: str
    scored_hash: str
    current_hash: str


@dataclass(frozen=True)
class IndexedFile:
    """A fleet file as last hashed: path (relative to the fleet folder), size, ``mtime_ns``,
    SHA-256."""

    path: str
    size: int
    mtime_ns: int
    hash: str


@dataclass(frozen=True)
class SavedModel:
    """What a stored fitted model was made from (its blob is read by hash)."""

    file_hash: str
    params: str
    library_version: str
    model_hash: str
    rates_hz: dict[str, float]
    #: ``QualityReference.spans`` of the baseline capture (the no-motion check of later
    #: captures); None for a model saved before it was kept, which is then refitted.
    reference: dict[str, float] | None = None


@dataclass(frozen=True)
class AlarmState:
    """An axis in alarm (one method): since which capture, and whether someone saw it."""

    robot: str
    axis: str
    method: str
    baseline_id: int
    raised_score_id: int
    raised_capture: str
    raised_at: str
    acknowledged_by: str | None
    note: str | None
    acknowledged_at: str | None
    #: The engineer's verdict (:data:`~axiswatch.monitor._feedback.ACK_VERDICTS`), if any.
    verdict: str | None = None

    @property
    def acknowledged(self) -> bool:
        """An acknowledgement names this alarm (it was not cleared and raised again since)."""
        return self.acknowledged_by is not None


def summary_extras(
    frame: pd.DataFrame, baselines: list[Baseline], alarms: list[AlarmState]
) -> pd.DataFrame:
    """Add ``threshold_origin``, ``alarm_since`` and ``acknowledged_by`` to a summary table
    whose rows are ``baselines`` (in order); shared by the backends."""
    frame["threshold_origin"] = [_threshold_origin(b) for b in baselines]
    by_key = {(a.robot, a.axis, a.method): a for a in alarms}
    keys = [(b.robot, b.axis, b.method) for b in baselines]
    frame["alarm_since"] = [getattr(by_key.get(k), "raised_capture", None) for k in keys]
    frame["acknowledged_by"] = [getattr(by_key.get(k), "acknowledged_by", None) for k in keys]
    return frame


def _threshold_origin(baseline: Baseline) -> str | None:
    """Where a baseline's threshold comes from, in words (None while it calibrates)."""
    if baseline.threshold is None or baseline.fit is None:
        return None
    params = json.loads(baseline.params)
    rule = DecisionRule(percentile=float(params.get("percentile", 99.0)))
    return stored_threshold(baseline.threshold, baseline.fit, rule).describe()


def _no_active_baseline(
    location: str, robot: str, axis: str, method: str | None, active: Any
) -> str:
    """The message of :meth:`StoreBackend.retire_baselines` for an axis without a baseline."""
    known = sorted(f"{r[0]}/{r[1]} ({r[2]})" for r in active)
    return (
        f"robot '{robot}' axis '{axis}'"
        + (f" method '{method}'" if method else "")
        + f" has no active baseline in store '{location}'; axes with one: "
        + (", ".join(known) or "none")
        + "."
    )


def _alarmed_baseline(robot: str, axis: str, capture: str, method: str) -> str:
    return (
        f"capture '{capture}' of robot '{robot}' axis '{axis}' raised an alarm "
        f"({method}); an alarmed capture cannot be a baseline. Choose a capture "
        "recorded after the maintenance."
    )
