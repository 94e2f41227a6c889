"""The store's protocols, one per caller: the driver's writer, the readers', the operator's.

:class:`StoreBackend` is all three: what a backend implements. A caller names the smallest one
it needs; a new backend passes ``tests/monitor/store/test_store_contract.py``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from datetime import datetime
from typing import Protocol, runtime_checkable

import pandas as pd

from axiswatch.monitor._decision import AxisHistory, Decision
from axiswatch.monitor.store.records import (
    AddedBaseline,
    AlarmState,
    Baseline,
    BaselineCheck,
    ChangedFile,
    IndexedFile,
    NewBaseline,
    NewScore,
    Rejection,
    SavedModel,
    ScoredFile,
)

__all__ = ["RunCaches", "StoreBackend", "StoreOperator", "StoreReader", "StoreWriter"]


class _Opened(Protocol):
    """A store that is open: where it is, and how to release it."""

    @property
    def location(self) -> str:
        """Where the store is, for messages (a file path, a URL)."""
        ...

    def close(self) -> None:
        """Release the store."""
        ...


class _Standing(_Opened, Protocol):
    """Alarms and standing problems: what the driver and the readers both read."""

    def alarms(self, method: str | None = None) -> list[AlarmState]:
        """Axes in alarm after their last monitored capture (active baselines), acknowledged or
        not, and axes whose fault was confirmed (``ack --fault-confirmed``) until they are
        re-baselined; one per axis and method, ordered by robot, axis, method."""
        ...

    def baseline_checks(self, method: str | None = None) -> list[BaselineCheck]:
        """The checks of the active baselines (of ``method``), acknowledged or not; ordered by
        robot, axis, method and kind."""
        ...

    def axis_activity(self) -> pd.DataFrame:
        """robot, axis, n_files, newest_capture, last_seen_at (ISO, UTC); by robot, axis."""
        ...


class _ModeLibraries(Protocol):
    """The mode library of a baseline: what it learned of the axis's operating modes."""

    def mode_library(self, baseline_id: int) -> bytes | None:
        """The baseline's stored mode library (None before its first capture)."""
        ...

    def save_mode_library(self, baseline_id: int, blob: bytes) -> None:
        """Keep (or replace) the baseline's mode library."""
        ...


class StoreWriter(_Standing, _ModeLibraries, Protocol):
    """What the monitor's driver reads and writes while it scores a fleet.

    Every write is atomic: it happens whole or not at all, also when the process is killed, and
    two processes writing one store take turns. Paths are relative to the fleet folder (POSIX).
    """

    def batch(self) -> AbstractContextManager[None]:
        """Group the writes made inside into one transaction: when the block ends they are all
        kept, and when it is left by an exception (or the process dies in it) none of them is.

        Each write inside stays atomic on its own (one that raises changes nothing); a batch
        inside a batch is part of the outer one. The monitor stores the scores of the captures
        a worker returns together in one batch: fewer commits for the one process that writes.
        """
        ...

    # writes

    def add_baseline(self, baseline: NewBaseline) -> AddedBaseline | None:
        """Add the baseline of an epoch, its capture's score row and its checks; return the
        baseline's id, ``added``.

        If the epoch already has a baseline (another process added it), return its id, not
        added, when it is the same capture, None when it is another one.
        """
        ...

    def record_score(
        self, score: NewScore, decide: Callable[[AxisHistory], Decision], *, window: int
    ) -> bool:
        """Decide and write one capture's score in one transaction; False if nothing was written.

        Nothing is written when the capture is already scored under the baseline or the baseline
        is retired. Otherwise ``decide`` gets the baseline's :class:`AxisHistory` (``window``
        recent monitored captures) and its :class:`Decision` is written; a decision that
        completes the calibration also sets the baseline's threshold and fit and gives the
        threshold to every calibration capture of the baseline. If ``decide`` raises, nothing is
        written.
        """
        ...

    def reject_capture(self, rejection: Rejection, *, baseline_id: int | None = None) -> bool:
        """Record a rejected file (once per method, path and content); False if not recorded.

        With ``baseline_id``, only while that baseline is active and the capture is not scored
        under it.
        """
        ...

    def mark_rejection_removed(self, rejection: Rejection, at: str | None) -> None:
        """Record that the file of a (not transient) rejection is gone from the fleet folder
        since ``at``, or, ``at`` None, that its rejected content is back. The rejection is
        named by its method, path and file hash; it is kept either way (history)."""
        ...

    def record_changed_file(self, change: ChangedFile) -> None:
        """Record that a scored file's content changed (once per path and pair of hashes)."""
        ...

    def record_baseline_check(self, baseline_id: int, kind: str, note: str) -> None:
        """Record a check of a baseline (one per baseline and kind): the same note again
        changes nothing; another note replaces it and is news again (not acknowledged)."""
        ...

    # standing problems and axis activity

    def resolve_transient(self, method: str, seen_before: str) -> None:
        """Forget transient rejections of ``method`` not seen again since ``seen_before``."""
        ...

    def record_axis_activity(self, seen: Sequence[tuple[str, str, int, str]], at: str) -> None:
        """Per ``(robot, axis, n_files, newest_capture)``: ``last_seen_at`` becomes ``at`` when
        the axis is new or has a file it did not have before."""
        ...

    # reads

    def baseline(self, baseline_id: int) -> Baseline:
        """The baseline with this id."""
        ...

    def latest_baseline(self, robot: str, axis: str, method: str) -> Baseline | None:
        """The axis's baseline of the highest epoch (retired or not), or None."""
        ...

    def requested_baseline(
        self, robot: str, axis: str, method: str, retired_epoch: int
    ) -> str | None:
        """The capture asked for as the next baseline when ``retired_epoch`` was retired."""
        ...

    def last_captured_at(self, robot: str, axis: str, method: str) -> datetime | None:
        """Capture time of the latest capture scored on the axis under any baseline."""
        ...

    def scored_captures(self, baseline_id: int) -> set[str]:
        """File names of the captures scored under a baseline (its own included)."""
        ...

    def scored_files(self) -> dict[str, ScoredFile]:
        """Per path, the file as it was when last scored (by any method)."""
        ...

    def scored_contents(self, method: str) -> set[tuple[str, str]]:
        """``(path, file hash)`` of every capture scored by ``method``."""
        ...

    def rejections(self, method: str) -> list[Rejection]:
        """Rejected files of ``method``, in the order they were rejected."""
        ...

    def alarmed_captures(self, method: str) -> set[tuple[str, str, str]]:
        """``(robot, axis, capture)`` of every capture that raised or kept an alarm."""
        ...

    def axes_in_alarm(self, method: str) -> list[tuple[str, str]]:
        """``(robot, axis)`` whose active baseline's last monitored capture is in alarm, sorted."""
        ...

    def changed_file_acknowledged(self, change: ChangedFile) -> bool:
        """Whether someone acknowledged this change of this file."""
        ...

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        """Forget the rejections of ``paths`` (all when empty): the next run tries them again."""
        ...


class StoreReader(_Standing, Protocol):
    """What the results, the report and the attention list read."""

    def latest_bad_data(self) -> pd.DataFrame:
        """robot, axis, method, bad_capture, seen_capture, seen_at: per axis with a capture
        rejected as bad data whose file is still there (not removed), the newest such capture
        nobody acknowledged (None if none), the newest acknowledged one (None if none) and the
        latest acknowledgement of those (ISO, UTC)."""
        ...

    def problem_table(self, method: str | None = None) -> pd.DataFrame:
        """Rejections, changed files and checks of active baselines (kind ``baseline check``):
        kind, method, path, error, since, acknowledged_at, removed_at (a rejection whose file is
        gone; None otherwise); ordered by path, kind, method."""
        ...

    def acknowledgements(self, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """Every acknowledgement, oldest first: ``robot, axis, method, capture`` (the capture
        that raised the alarm seen; None for a re-baseline without alarm), ``rebaseline``,
        ``acknowledged_by``, ``note``, ``acknowledged_at``, ``verdict`` (None without one)."""
        ...

    def rebaseline_requests(self) -> pd.DataFrame:
        """Every re-baseline: ``robot, axis, method, retired_epoch, from_capture, requested_at``."""
        ...

    # tables for people (results, summary, report)

    def score_table(self, *, robot: str | None = None, axis: str | None = None) -> pd.DataFrame:
        """One row per score: robot, axis, capture, method, distance, threshold, alarm,
        captured_at, epoch, role, over, reason, details, path; ordered by robot, axis, method,
        capture time, capture and epoch."""
        ...

    def summary_table(self) -> pd.DataFrame:
        """One row per active baseline: robot, axis, method, epoch, baseline, threshold, scored,
        over, alarms (raised), last_capture, last_distance, last_alarm, rejected,
        threshold_origin (:meth:`~axiswatch._calibration.Threshold.describe`; None while
        calibrating), alarm_since (the capture that raised the alarm in force) and
        acknowledged_by (who saw it, if anyone); ordered by robot, axis, method."""
        ...

    def rejection_table(self) -> pd.DataFrame:
        """Rejections: robot, axis, capture, method, path, error, rejected_at, acknowledged_at
        (None until ``rejections --ack``), removed_at (None while the file is there); ordered by
        robot, axis, path, method and then as recorded."""
        ...

    def changed_file_table(self) -> pd.DataFrame:
        """Changed files: robot, axis, path, detected_at, acknowledged_at (None until
        ``rejections --ack``); ordered by path, then as recorded."""
        ...


class StoreOperator(_Opened, _ModeLibraries, Protocol):
    """What a person changes: re-baselines, retries and acknowledgements."""

    def retire_baselines(
        self,
        robot: str,
        axis: str,
        *,
        method: str | None = None,
        from_capture: str | None = None,
    ) -> list[str]:
        """Retire the axis's active baselines (of ``method``, or all) and record the request.

        Returns the methods retired, sorted. Raises :class:`~axiswatch.StoreError` when the axis
        has no active baseline (the message lists the axes that have one), or when
        ``from_capture`` raised an alarm under any method.
        """
        ...

    def retry_rejections(self, paths: Sequence[str], method: str | None = None) -> int:
        """Forget the rejections of ``paths`` (all when empty): the next run tries them again."""
        ...

    def acknowledge_problems(self, paths: Sequence[str], at: str, method: str | None = None) -> int:
        """Mark the rejections, changed files and checks of active baselines (by the baseline
        capture's path) of ``paths`` (all when empty) as seen; how many were not seen before."""
        ...

    def acknowledge(
        self,
        robot: str,
        axis: str,
        *,
        by: str,
        note: str,
        method: str | None = None,
        rebaseline: bool = False,
        verdict: str | None = None,
    ) -> list[str]:
        """Record that someone saw the axis's alarm (or, ``rebaseline``, maintained the axis).

        Parameters
        ----------
        robot, axis : str
        by : str
            Who (not empty).
        note : str
            What they saw or did (not empty).
        method : str or None, default=None
            Only this method's alarm; default every method in alarm on the axis.
        rebaseline : bool, default=False
            The record of a re-baseline after maintenance: made for the latest baseline of each
            method whether or not it is in alarm (it names the alarm when there is one). The
            caller retires the baselines (``rebaseline`` of the ledger) before.
        verdict : str or None, default=None
            What they concluded: one of :data:`~axiswatch.monitor._feedback.ACK_VERDICTS`.

        Returns
        -------
        list of str
            The methods acknowledged.

        Raises
        ------
        ValueError
            If ``by`` or ``note`` is empty, or ``verdict`` is unknown.
        StoreError
            If the axis has no baseline (for ``method``), or, without ``rebaseline``, is not in
            alarm.
        """
        ...


class StoreBackend(StoreWriter, StoreReader, StoreOperator, Protocol):
    """What the monitor needs from a store, in domain words; :class:`~axiswatch.monitor.store.SQLiteStore` is the product's.

    The driver's writer, the readers' reader and the operator's changes together. A new backend
    passes ``tests/monitor/store/test_store_contract.py``.
    """


@runtime_checkable
class RunCaches(Protocol):
    """What lets a run skip the work earlier runs did (optional for a backend; a store without
    it gets per-run caches in memory, ``monitor._index.MemoryCaches``): fitted models, the file
    index and the times of finished axis folders. Losing any of it loses time, no result."""

    def model_source(self) -> str | None:
        """Path of the store workers read fitted models from (None: models travel with jobs)."""
        ...

    def saved_model(self, baseline_id: int) -> SavedModel | None:
        """The stored fitted model of a baseline, without its blob."""
        ...

    def save_model(self, baseline_id: int, saved: SavedModel, blob: bytes) -> None:
        """Keep (or replace) the fitted model of a baseline."""
        ...

    def model_blob(self, model_hash: str) -> bytes | None:
        """The blob of a stored model, by its content hash."""
        ...

    def start_run(self) -> int:
        """Number a new run (the index records which run last verified a file)."""
        ...

    def indexed_file(self, path: str) -> IndexedFile | None:
        """A file's index entry."""
        ...

    def index_file(self, entry: IndexedFile, run: int) -> None:
        """Record (or update) a file's entry, verified in ``run``."""
        ...

    def files_to_verify(self, run: int, limit: int) -> list[IndexedFile]:
        """Up to ``limit`` entries not verified in ``run``, least recently verified first."""
        ...

    def mark_verified(self, paths: Sequence[str], run: int) -> None:
        """Record that these files were compared with the disk in ``run``."""
        ...

    def last_scored(self, path: str) -> ScoredFile | None:
        """The file as it was when last scored, if it was."""
        ...

    def was_scored(self, path: str, file_hash: str, method: str) -> bool:
        """Whether this content of a file has a score by ``method``."""
        ...

    def axis_folder_times(self, method: str, params: str) -> dict[tuple[str, str], int]:
        """Modification time of each axis folder when a run with these parameters finished it."""
        ...

    def finish_axis_folder(
        self, robot: str, axis: str, method: str, params: str, mtime_ns: int
    ) -> None:
        """Record that a run handled every file of an axis folder with this modification time."""
        ...
