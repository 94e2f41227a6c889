"""A monitoring store in memory: a test double of the StoreWriter protocol, in plain Python.

It passes the writer's contract (tests/monitor/store/test_store_contract.py) and the monitor runs on it to the
SQLite store's results, which shows that the driver needs nothing of a store but the protocol.
Beside the writer it has ``retire_baselines`` (a retired baseline is the writer's concern too)
and ``score_table`` (what the tests compare). One
lock makes each write atomic among threads; a write that raises changes nothing, because every
write computes first and changes the lists last.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import json
import threading
from collections.abc import Callable, Iterator, Sequence
from datetime import datetime
from typing import Any

import numpy as np
import pandas as pd

from axiswatch.exceptions import StoreError
from axiswatch.monitor._decision import AxisHistory, Decision
from axiswatch.monitor.store import (
    AddedBaseline,
    AlarmState,
    Baseline,
    BaselineCheck,
    ChangedFile,
    NewBaseline,
    NewScore,
    Rejection,
    ScoredFile,
    now,
    now_us,
)
from axiswatch.monitor.store.records import _alarmed_baseline, _no_active_baseline


@dataclasses.dataclass
class _Score:
    id: int
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
    role: str
    distance: float | None
    threshold: float | None
    over: bool
    alarm: bool
    reason: str
    details: dict[str, Any]


class MemoryStore:
    """A :class:`~axiswatch.monitor.store.StoreWriter` held in lists (row order = id order)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._in_batch = False
        self._baselines: list[Baseline] = []
        self._scores: list[_Score] = []
        self._rejections: list[tuple[Rejection, str]] = []
        self._changed: list[tuple[ChangedFile, str]] = []
        self._requests: list[tuple[str, str, str, int, str | None]] = []
        self._activity: dict[tuple[str, str], tuple[int, str, str]] = {}
        #: (baseline id, kind) -> (note, detected_at, acknowledged_at)
        self._checks: dict[tuple[int, str], tuple[str, str, str | None]] = {}
        self._mode_libraries: dict[int, bytes] = {}

    @property
    def location(self) -> str:
        return "memory"

    def close(self) -> None:
        pass

    def mode_library(self, baseline_id: int) -> bytes | None:
        return self._mode_libraries.get(baseline_id)

    def save_mode_library(self, baseline_id: int, blob: bytes) -> None:
        self._mode_libraries[baseline_id] = blob

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """Every list and dict as it was before the batch comes back if the batch raises."""
        if self._in_batch:
            yield
            return
        state = {k: copy.deepcopy(v) for k, v in vars(self).items() if k != "_lock"}
        self._in_batch = True
        try:
            yield
        except BaseException:
            vars(self).update(state)
            raise
        finally:
            self._in_batch = False

    # --- writes ----------------------------------------------------------------------------

    def add_baseline(self, baseline: NewBaseline) -> AddedBaseline | None:
        b = baseline
        with self._lock:
            for old in self._baselines:
                if (old.robot, old.axis, old.method, old.epoch) == (
                    b.robot,
                    b.axis,
                    b.method,
                    b.epoch,
                ):
                    return AddedBaseline(old.id, False) if old.capture == b.capture else None
            new = Baseline(
                len(self._baselines) + 1, b.robot, b.axis, b.method, b.epoch, b.capture,
                b.captured_at, b.path, b.file_hash, b.features_hash, b.params, None, None, False,
            )  # fmt: skip
            self._baselines.append(new)
            row = _Score(
                len(self._scores) + 1,
                new.id,
                b.robot,
                b.axis,
                b.method,
                b.capture,
                b.captured_at,
                b.path,
                b.file_hash,
                b.file_size,
                b.file_mtime_ns,
                "baseline",
                None,
                None,
                False,
                False,
                b.reason,
                dict(b.details),
            )
            self._scores.append(row)
            for kind, note in b.checks.items():
                self._checks[(new.id, kind)] = (note, now(), None)
            return AddedBaseline(new.id, True)

    def record_score(
        self, score: NewScore, decide: Callable[[AxisHistory], Decision], *, window: int
    ) -> bool:
        s = score
        with self._lock:
            if s.capture in self._captures(s.baseline_id):
                return False
            baseline = self._baseline(s.baseline_id)
            if baseline.retired:
                return False
            of_baseline = [r for r in self._scores if r.baseline_id == s.baseline_id]
            if baseline.threshold is None:
                history = AxisHistory(
                    calibration_distances=tuple(
                        float(r.distance or 0.0) for r in of_baseline if r.role == "calibration"
                    ),
                    alarmed_before=any(
                        r.alarm
                        for r in self._scores
                        if (r.robot, r.axis, r.method, r.capture)
                        == (s.robot, s.axis, s.method, s.capture)
                    ),
                )
            else:
                monitored = [r for r in of_baseline if r.role == "monitor"]
                history = AxisHistory(
                    threshold=baseline.threshold,
                    fit=baseline.fit,
                    recent=tuple((r.over, r.alarm) for r in monitored[-window:]),
                )
            decision = decide(history)
            if decision.calibrated is not None:
                value = decision.calibrated.value
                index = self._baselines.index(baseline)
                self._baselines[index] = dataclasses.replace(
                    baseline, threshold=value, fit=decision.calibrated.fit
                )
                for row in of_baseline:
                    if row.role == "calibration":
                        row.threshold = value
            row = _Score(
                len(self._scores) + 1,
                s.baseline_id,
                s.robot,
                s.axis,
                s.method,
                s.capture,
                s.captured_at,
                s.path,
                s.file_hash,
                s.file_size,
                s.file_mtime_ns,
                decision.role,
                s.distance,
                decision.threshold,
                decision.over,
                decision.alarm,
                decision.reason,
                {**s.details, **decision.details},
            )
            self._scores.append(row)
            return True

    def reject_capture(self, rejection: Rejection, *, baseline_id: int | None = None) -> bool:
        r = rejection
        with self._lock:
            if baseline_id is not None and (
                r.capture in self._captures(baseline_id) or self._baseline(baseline_id).retired
            ):
                return False
            for index, (old, _) in enumerate(self._rejections):
                if (old.method, old.path, old.file_hash) == (r.method, r.path, r.file_hash):
                    same = (old.reason_key or old.error) == (r.reason_key or r.error)
                    seen = old.acknowledged_at if same else None
                    self._rejections[index] = (
                        dataclasses.replace(r, acknowledged_at=seen, removed_at=None),
                        now_us(),
                    )
                    return False
            self._rejections.append((r, now_us()))
            return True

    def mark_rejection_removed(self, rejection: Rejection, at: str | None) -> None:
        key = (rejection.method, rejection.path, rejection.file_hash)
        with self._lock:
            for index, (old, stamp) in enumerate(self._rejections):
                if (old.method, old.path, old.file_hash) == key:
                    self._rejections[index] = (dataclasses.replace(old, removed_at=at), stamp)

    def record_changed_file(self, change: ChangedFile) -> None:
        c = change
        key = (c.path, c.scored_hash, c.current_hash)
        with self._lock:
            if all((o.path, o.scored_hash, o.current_hash) != key for o, _ in self._changed):
                self._changed.append((c, now()))

    def record_baseline_check(self, baseline_id: int, kind: str, note: str) -> None:
        with self._lock:
            old = self._checks.get((baseline_id, kind))
            if old is None or old[0] != note:
                self._checks[(baseline_id, kind)] = (note, now(), None)

    def retire_baselines(
        self,
        robot: str,
        axis: str,
        *,
        method: str | None = None,
        from_capture: str | None = None,
    ) -> list[str]:
        with self._lock:
            active = [b for b in self._baselines if not b.retired]
            chosen = sorted(
                (
                    b
                    for b in active
                    if (b.robot, b.axis) == (robot, axis) and method in (None, b.method)
                ),
                key=lambda b: b.method,
            )
            if not chosen:
                known = [(b.robot, b.axis, b.method) for b in active]
                raise StoreError(_no_active_baseline(self.location, robot, axis, method, known))
            if from_capture is not None:
                for row in self._scores:
                    if row.alarm and (row.robot, row.axis, row.capture) == (
                        robot,
                        axis,
                        from_capture,
                    ):
                        raise StoreError(_alarmed_baseline(robot, axis, from_capture, row.method))
            for b in chosen:
                self._baselines[self._baselines.index(b)] = dataclasses.replace(b, retired=True)
                self._requests.append((robot, axis, b.method, b.epoch, from_capture))
            return [b.method for b in chosen]

    # --- reads -----------------------------------------------------------------------------

    def _baseline(self, baseline_id: int) -> Baseline:
        for b in self._baselines:
            if b.id == baseline_id:
                return b
        raise StoreError(f"store 'memory' has no baseline with id {baseline_id}.")

    def _captures(self, baseline_id: int) -> set[str]:
        return {r.capture for r in self._scores if r.baseline_id == baseline_id}

    def baseline(self, baseline_id: int) -> Baseline:
        return self._baseline(baseline_id)

    def latest_baseline(self, robot: str, axis: str, method: str) -> Baseline | None:
        own = [b for b in self._baselines if (b.robot, b.axis, b.method) == (robot, axis, method)]
        return max(own, key=lambda b: b.epoch) if own else None

    def requested_baseline(
        self, robot: str, axis: str, method: str, retired_epoch: int
    ) -> str | None:
        found = [r[4] for r in self._requests if r[:4] == (robot, axis, method, retired_epoch)]
        return found[-1] if found else None

    def last_captured_at(self, robot: str, axis: str, method: str) -> datetime | None:
        times = [
            r.captured_at
            for r in self._scores
            if (r.robot, r.axis, r.method) == (robot, axis, method)
        ]
        return max(times) if times else None

    def scored_captures(self, baseline_id: int) -> set[str]:
        return self._captures(baseline_id)

    def scored_files(self) -> dict[str, ScoredFile]:
        return {
            r.path: ScoredFile(
                r.robot, r.axis, r.capture, r.path, r.file_hash, r.file_size, r.file_mtime_ns
            )
            for r in self._scores
        }

    def scored_contents(self, method: str) -> set[tuple[str, str]]:
        return {(r.path, r.file_hash) for r in self._scores if r.method == method}

    def rejections(self, method: str) -> list[Rejection]:
        return [r for r, _ in self._rejections if r.method == method]

    def alarmed_captures(self, method: str) -> set[tuple[str, str, str]]:
        return {
            (r.robot, r.axis, r.capture) for r in self._scores if r.method == method and r.alarm
        }

    def _last_alarm(self, baseline_id: int, before: int | None = None) -> bool | None:
        monitored = [
            r
            for r in self._scores
            if r.baseline_id == baseline_id
            and r.role == "monitor"
            and (before is None or r.id < before)
        ]
        return monitored[-1].alarm if monitored else None

    def axes_in_alarm(self, method: str) -> list[tuple[str, str]]:
        return sorted(
            (b.robot, b.axis)
            for b in self._baselines
            if b.method == method and not b.retired and self._last_alarm(b.id)
        )

    # --- acknowledgements --------------------------------------------------------------------

    def _raised(self, b: Baseline) -> _Score | None:
        """The score that raised the baseline's current alarm episode (None if not in alarm)."""
        monitored = [r for r in self._scores if r.baseline_id == b.id and r.role == "monitor"]
        if not monitored or not monitored[-1].alarm:
            return None
        clean = [r.id for r in monitored if not r.alarm]
        last_clean = max(clean) if clean else 0
        return next(r for r in monitored if r.alarm and r.id > last_clean)

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        found = []
        for b in self._baselines:
            if b.retired or method not in (None, b.method):
                continue
            raised = self._raised(b)
            if raised is None:
                continue
            found.append(
                AlarmState(
                    b.robot, b.axis, b.method, b.id, raised.id, raised.capture,
                    raised.captured_at.isoformat(), None, None, None,
                )
            )  # fmt: skip
        return sorted(found, key=lambda a: (a.robot, a.axis, a.method))

    # --- tables ----------------------------------------------------------------------------

    def acknowledgements(self, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """None: this double records no acknowledgement (the operator's protocol)."""
        columns = ["robot", "axis", "method", "capture", "rebaseline", "acknowledged_by", "note"]
        return pd.DataFrame(columns=[*columns, "acknowledged_at", "verdict"])

    def score_table(self, *, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        epochs = {b.id: b.epoch for b in self._baselines}
        rows = [
            {
                "robot": r.robot,
                "axis": r.axis,
                "capture": r.capture,
                "method": r.method,
                "distance": np.nan if r.distance is None else r.distance,
                "threshold": np.nan if r.threshold is None else r.threshold,
                "alarm": r.alarm,
                "captured_at": r.captured_at.isoformat(),
                "epoch": epochs[r.baseline_id],
                "role": r.role,
                "over": r.over,
                "reason": r.reason,
                "details": _json(r.details, sort_keys=r.role != "baseline"),
                "path": r.path,
            }
            for r in self._scores
            if robot in (None, r.robot) and axis in (None, r.axis)
        ]
        columns = [
            "robot", "axis", "capture", "method", "distance", "threshold", "alarm",
            "captured_at", "epoch", "role", "over", "reason", "details", "path",
        ]  # fmt: skip
        frame = pd.DataFrame(rows, columns=columns)
        frame = frame.sort_values(
            ["robot", "axis", "method", "captured_at", "capture", "epoch"], kind="stable"
        ).reset_index(drop=True)
        return frame.astype(
            {"alarm": bool, "over": bool, "distance": np.float64, "threshold": np.float64}
        )

    # --- standing problems and axis activity ---------------------------------------------------

    def resolve_transient(self, method: str, seen_before: str) -> None:
        with self._lock:
            self._rejections = [
                (r, at)
                for r, at in self._rejections
                if not (r.method == method and r.transient and at < seen_before)
            ]

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        def chosen(r: Rejection) -> bool:
            return (method is None or r.method == method) and (not paths or r.path in paths)

        with self._lock:
            kept = [(r, at) for r, at in self._rejections if not chosen(r)]
            count = len(self._rejections) - len(kept)
            self._rejections = kept
            return count

    def baseline_checks(self, method: str | None = None) -> list[BaselineCheck]:
        checks = []
        for (baseline_id, kind), (note, detected_at, acknowledged_at) in self._checks.items():
            b = self._baseline(baseline_id)
            if not b.retired and method in (None, b.method):
                checks.append(
                    BaselineCheck(
                        baseline_id, b.robot, b.axis, b.method, b.path, kind, note, detected_at,
                        acknowledged_at,
                    )
                )  # fmt: skip
        return sorted(checks, key=lambda c: (c.robot, c.axis, c.method, c.kind))

    def changed_file_acknowledged(self, change: ChangedFile) -> bool:
        return False  # acknowledging is the operator's, which this double is not

    def record_axis_activity(self, seen: Sequence[tuple[str, str, int, str]], at: str) -> None:
        with self._lock:
            for robot, axis, n_files, newest in seen:
                old = self._activity.get((robot, axis))
                new = old is None or n_files > old[0] or newest > old[1]
                last = at if new or old is None else old[2]
                self._activity[(robot, axis)] = (
                    n_files,
                    newest if old is None else max(old[1], newest),
                    last,
                )

    def axis_activity(self) -> pd.DataFrame:
        rows = [(*key, *value) for key, value in sorted(self._activity.items())]
        columns = ["robot", "axis", "n_files", "newest_capture", "last_seen_at"]
        return pd.DataFrame(rows, columns=columns)


def _json(details: dict[str, Any], *, sort_keys: bool) -> str:
    return json.dumps(details, sort_keys=sort_keys)
