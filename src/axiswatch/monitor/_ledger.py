"""The axis ledger: every change of a store's state the monitor makes, in domain words.

Each function is one atomic write of a :class:`~axiswatch.monitor.StoreBackend`. The decision
is made inside the store's transaction, from what the store holds at that moment.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

from axiswatch._likely_faults import describe_top_indicator
from axiswatch.monitor._config import MonitorConfig, params_hash
from axiswatch.monitor._decision import AxisHistory, Decision, decide
from axiswatch.monitor._persist import library_version
from axiswatch.monitor._scoring import FitOutcome, ScoreOutcome
from axiswatch.monitor.store import (
    AddedBaseline,
    NewBaseline,
    NewScore,
    Rejection,
    StoreOperator,
    StoreWriter,
)

if TYPE_CHECKING:
    from axiswatch.monitor._mode_decision import ModeBook

__all__ = ["commit_score", "insert_baseline", "params_json", "rebaseline", "reject"]


def params_json(config: MonitorConfig) -> str:
    """The parameters a baseline remembers (a run with others on the same axis is refused)."""
    return json.dumps(config.params(), sort_keys=True)


def reject(
    store: StoreWriter,
    method: str,
    robot: str,
    axis: str,
    capture: str,
    relative: str,
    digest: str,
    error: str,
    *,
    kind: str = "invalid",
    params_hash: str | None = None,
    transient: bool = False,
    reason_key: str | None = None,
) -> None:
    """Record a capture file of ``method`` that cannot be used (once per content; ``kind``,
    ``params_hash``, ``transient`` and ``reason_key`` as in
    :class:`~axiswatch.monitor.Rejection`)."""
    store.reject_capture(
        Rejection(
            robot, axis, method, capture, relative, digest, error, kind, params_hash, transient,
            reason_key=reason_key,
        )
    )  # fmt: skip


def insert_baseline(
    store: StoreWriter, outcome: FitOutcome, epoch: int, config: MonitorConfig
) -> AddedBaseline | None:
    """Insert the baseline of ``epoch`` unless another process did; return its id and whether
    this call added it (None: the other process chose another capture).

    The fit's checks (a model's ``checks()``) are stored with
    it in the same transaction: every later run reports them until acknowledged, also when the
    run that fitted it is killed right after this commit."""
    file = outcome.job.file
    stat = file.path.stat()
    details: dict[str, Any] = {"rates_hz": outcome.rates_hz}
    if outcome.summary is not None:  # what the model estimated, from what
        details.update(outcome.summary)
    checks = outcome.checks
    return store.add_baseline(
        NewBaseline(
            robot=file.robot,
            axis=file.axis,
            method=config.method,
            epoch=epoch,
            capture=file.capture,
            captured_at=file.captured_at,
            path=outcome.job.relative,
            file_hash=outcome.file_hash,
            features_hash=outcome.features_hash,
            params=params_json(config),
            library_version=library_version(),
            file_size=stat.st_size,
            file_mtime_ns=stat.st_mtime_ns,
            reason=f"baseline of epoch {epoch}: the healthy reference every later capture is "
            "compared with",
            details=details,
            checks=checks,
        )
    )


def commit_score(
    store: StoreWriter,
    outcome: ScoreOutcome,
    config: MonitorConfig,
    rejection_key: str | None = None,
    modes: ModeBook | None = None,
) -> bool:
    """Decide and write one capture's result (or its rejection); True when this call wrote it.

    ``rejection_key``: what a rejection depends on (default: the parameters' hash); the monitor
    adds its axis profile's. ``modes``: the run's mode libraries, which decide a capture that
    carries a description (``MonitorConfig.modes``)."""
    job = outcome.job
    file = job.file
    if outcome.error is not None:
        rejection = Rejection(
            file.robot,
            file.axis,
            config.method,
            file.capture,
            job.relative,
            outcome.file_hash,
            outcome.error,
            kind=outcome.kind,
            params_hash=rejection_key or params_hash(config),
            transient=outcome.transient,
        )
        return store.reject_capture(rejection, baseline_id=job.baseline_id)
    rule = config.decision_rule()
    if modes is not None and outcome.description is not None:
        return _commit_in_mode(store, outcome, config, modes, rule.window)
    top = outcome.details.get("top_indicator") or describe_top_indicator(
        outcome.details.get("indicators", {})
    )

    def decision(history: AxisHistory) -> Decision:
        return decide(history, outcome.distance, rule, top_indicator=top)

    score = _new_score(outcome, config, outcome.distance, dict(outcome.details))
    return store.record_score(score, decision, window=rule.window)


def _new_score(
    outcome: ScoreOutcome, config: MonitorConfig, distance: float, details: dict[str, Any]
) -> NewScore:
    job, file = outcome.job, outcome.job.file
    return NewScore(
        baseline_id=job.baseline_id,
        robot=file.robot,
        axis=file.axis,
        method=config.method,
        capture=file.capture,
        captured_at=file.captured_at,
        path=job.relative,
        file_hash=outcome.file_hash,
        file_size=outcome.file_size,
        file_mtime_ns=outcome.file_mtime_ns,
        distance=distance,
        details=details,
    )


def _commit_in_mode(
    store: StoreWriter, outcome: ScoreOutcome, config: MonitorConfig, modes: ModeBook, window: int
) -> bool:
    """Write a capture decided by its axis's mode library, then let the library learn."""
    assert outcome.description is not None
    baseline = (outcome.distance, outcome.details.get("top_indicator"))
    distance, decision, stored = modes.decide(
        outcome.job.baseline_id, outcome.description, outcome.job.file.capture, baseline
    )
    details = dict(outcome.details)
    if math.isfinite(outcome.distance):
        details["baseline_distance"] = outcome.distance
    score = _new_score(outcome, config, distance, details)
    written = store.record_score(score, decision, window=window)
    if written:
        stored()
    return written


def rebaseline(
    store: StoreOperator,
    robot: str,
    axis: str,
    *,
    method: str | None = None,
    from_capture: str | None = None,
) -> list[str]:
    """Retire the active baseline of an axis (after maintenance); the next monitor run starts anew.

    Parameters
    ----------
    store : StoreOperator
    robot, axis : str
    method : str or None, default=None
        Only this method's baseline; default every method the axis has.
    from_capture : str or None, default=None
        File name of the new baseline capture; default the next capture that arrives (the first
        one dated after every capture already scored).

    Returns
    -------
    list of str
        The methods whose baseline was retired.

    Raises
    ------
    StoreError
        If the axis has no active baseline (for that method), or ``from_capture`` raised an alarm.
    """
    return store.retire_baselines(robot, axis, method=method, from_capture=from_capture)
