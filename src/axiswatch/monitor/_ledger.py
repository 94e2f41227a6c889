"""The axis ledger: every change of a store's state, each one ``BEGIN IMMEDIATE`` transaction.

Pipeline stage below the monitor's driver. A capture's role (calibration, monitor, excluded), the
threshold and the alarm state are computed *inside* the transaction that writes the capture, from
what the store holds at that moment; so a killed run resumes exactly, and two processes on one
store never disagree.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version

from axiswatch._attribution import describe_top_indicator
from axiswatch._calibration import HalfLaplaceFit, fit_half_laplace
from axiswatch.exceptions import CalibrationError, StoreError
from axiswatch.monitor._scoring import FitOutcome, MonitorConfig, ScoreOutcome
from axiswatch.monitor._store import Store

__all__ = [
    "alarm_step",
    "commit_score",
    "describe_threshold",
    "insert_baseline",
    "now",
    "params_json",
    "rebaseline",
    "reject",
]


def params_json(config: MonitorConfig) -> str:
    return json.dumps(config.params(), sort_keys=True)


def alarm_step(
    previous_alarm: bool, recent_over: Sequence[bool], *, k: int, n: int, m: int
) -> bool:
    """Alarm state after one more capture.

    Parameters
    ----------
    previous_alarm : bool
        State before this capture.
    recent_over : sequence of bool
        Whether each recent capture (oldest first, this one last) was over the threshold; at
        least ``max(n, m)`` entries unless the history is shorter.
    k, n : int
        Raise when at least ``k`` of the last ``n`` are over.
    m : int
        Clear when the last ``m`` are all under.

    Returns
    -------
    bool

    Examples
    --------
    >>> alarm_step(False, [True, False, True], k=2, n=3, m=2)
    True
    >>> alarm_step(True, [True, False, False], k=2, n=3, m=2)
    False
    """
    if previous_alarm:
        tail = list(recent_over)[-m:]
        return not (len(tail) == m and not any(tail))
    return sum(bool(v) for v in list(recent_over)[-n:]) >= k


def now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _library_version() -> str:
    try:
        return version("axiswatch")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


# --- store writes (each one transaction) -------------------------------------------------------


def reject(
    store: Store,
    method: str,
    robot: str,
    axis: str,
    capture: str,
    relative: str,
    digest: str,
    error: str,
) -> None:
    with store.write() as db:
        db.execute(
            "INSERT OR IGNORE INTO rejections (robot, axis, method, capture, path, file_hash, "
            "error, rejected_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (robot, axis, method, capture, relative, digest, error, now()),
        )


def insert_baseline(
    store: Store, outcome: FitOutcome, epoch: int, config: MonitorConfig
) -> int | None:
    """Insert the baseline of ``epoch`` unless another process did; return its id."""
    file = outcome.job.file
    with store.write() as db:
        row = db.execute(
            "SELECT id, capture FROM baselines WHERE robot=? AND axis=? AND method=? AND epoch=?",
            (file.robot, file.axis, config.method, epoch),
        ).fetchone()
        if row is not None:
            return int(row["id"]) if row["capture"] == file.capture else None
        cursor = db.execute(
            "INSERT INTO baselines (robot, axis, method, epoch, capture, captured_at, path, "
            "file_hash, features_hash, params, library_version, created_at) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                file.robot, file.axis, config.method, epoch, file.capture,
                file.captured_at.isoformat(), outcome.job.relative, outcome.file_hash,
                outcome.features_hash, params_json(config), _library_version(), now(),
            ),
        )  # fmt: skip
        baseline_id = int(cursor.lastrowid or 0)
        stat = file.path.stat()
        db.execute(
            "INSERT INTO scores (baseline_id, robot, axis, method, capture, captured_at, path, "
            "file_hash, file_size, file_mtime_ns, role, distance, threshold, over, alarm, "
            "reason, details, scored_at) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, 'baseline', NULL, NULL, 0, 0, ?, ?, ?)",
            (
                baseline_id, file.robot, file.axis, config.method, file.capture,
                file.captured_at.isoformat(), outcome.job.relative, outcome.file_hash,
                stat.st_size, stat.st_mtime_ns,
                f"baseline of epoch {epoch}: the healthy reference every later capture is "
                "compared with",
                json.dumps({"rates_hz": outcome.rates_hz}), now(),
            ),
        )  # fmt: skip
    return baseline_id


def _percentile_text(percentile: float) -> str:
    return f"{percentile:g}th pct"


def describe_threshold(threshold: float, fit: HalfLaplaceFit, percentile: float) -> str:
    """Where a stored threshold comes from: the fitted percentile, or the task-change allowance.

    The threshold is the fit's percentile raised, where lower, to ``threshold_floor`` (see
    :func:`commit_score`), so a threshold above the fitted value is the floor. Once the library's
    one threshold rule (``alarm_threshold(...).describe()``) exists, this reads it instead.

    Examples
    --------
    >>> fit = HalfLaplaceFit(scale=1.4, n_distances=5, ks_statistic=0.2, ks_pvalue=0.9)
    >>> describe_threshold(fit.threshold(99), fit, 99.0)
    '99th pct of the half-Laplace fit of 5 healthy captures'
    >>> describe_threshold(12.94, fit, 99.0)
    'task-change allowance, above the 6.447 fitted on 5 healthy captures'
    """
    fitted = fit.threshold(percentile)
    if threshold > fitted:
        return f"task-change allowance, above the {fitted:.4g} fitted on {fit.n_distances} healthy captures"
    return f"{_percentile_text(percentile)} of the half-Laplace fit of {fit.n_distances} healthy captures"


def commit_score(store: Store, outcome: ScoreOutcome, config: MonitorConfig) -> bool:
    """Write one capture's result; return True when this call wrote it."""
    job = outcome.job
    file = job.file
    with store.write() as db:
        if db.execute(
            "SELECT 1 FROM scores WHERE baseline_id=? AND capture=?",
            (job.baseline_id, file.capture),
        ).fetchone():
            return False
        baseline = db.execute("SELECT * FROM baselines WHERE id=?", (job.baseline_id,)).fetchone()
        if baseline["retired_at"] is not None:
            return False
        if outcome.error is not None:
            db.execute(
                "INSERT OR IGNORE INTO rejections (robot, axis, method, capture, path, file_hash, "
                "error, rejected_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    file.robot, file.axis, config.method, file.capture, job.relative,
                    outcome.file_hash, outcome.error, now(),
                ),
            )  # fmt: skip
            return True
        distance = outcome.distance
        details = dict(outcome.details)
        over = alarm = False
        threshold: float | None = baseline["threshold"]
        if threshold is None:
            alarmed_before = db.execute(
                "SELECT 1 FROM scores WHERE robot=? AND axis=? AND method=? AND capture=? "
                "AND alarm=1",
                (file.robot, file.axis, config.method, file.capture),
            ).fetchone()
            if alarmed_before:
                role = "excluded"
                reason = (
                    f"distance {distance:.4g}; not used for calibration: this capture raised an "
                    "alarm under an earlier baseline"
                )
            else:
                role = "calibration"
                healthy = [
                    float(r[0])
                    for r in db.execute(
                        "SELECT distance FROM scores WHERE baseline_id=? AND role='calibration' "
                        "ORDER BY id",
                        (job.baseline_id,),
                    )
                ] + [distance]
                count, size = len(healthy), config.calibration_size
                reason = (
                    f"calibration capture {count} of {size}: distance {distance:.4g}, assumed "
                    "healthy"
                )
                if count >= size:
                    try:
                        fit = fit_half_laplace(healthy)
                    except CalibrationError as exc:
                        reason += f"; threshold not set yet ({exc})"
                    else:
                        threshold = fit.threshold(config.percentile)
                        reason += (
                            f"; threshold set to {threshold:.4g} "
                            f"({_percentile_text(config.percentile)} of the half-Laplace fit of "
                            f"{count} healthy distances)"
                        )
                        floor = config.threshold_floor()
                        if floor > threshold:
                            threshold = floor
                            reason += (
                                f", raised to the floor {floor:.4g} that healthy task changes "
                                "need (development protocol, docs/evaluation.md)"
                            )
                        db.execute(
                            "UPDATE baselines SET threshold=?, calibration=? WHERE id=?",
                            (
                                threshold,
                                json.dumps(dataclasses.asdict(fit)),
                                job.baseline_id,
                            ),
                        )
                        db.execute(
                            "UPDATE scores SET threshold=? WHERE baseline_id=? "
                            "AND role='calibration'",
                            (threshold, job.baseline_id),
                        )
        else:
            role = "monitor"
            fit = HalfLaplaceFit(**json.loads(baseline["calibration"]))
            details["pvalue"] = fit.pvalue(distance)
            over = bool(distance > threshold)
            k, n, m = config.alarm_k, config.alarm_n, config.clear_m
            history = db.execute(
                "SELECT over, alarm FROM scores WHERE baseline_id=? AND role='monitor' "
                "ORDER BY id DESC LIMIT ?",
                (job.baseline_id, max(n, m)),
            ).fetchall()[::-1]
            recent = [bool(r["over"]) for r in history] + [over]
            previous = bool(history[-1]["alarm"]) if history else False
            alarm = alarm_step(previous, recent, k=k, n=n, m=m)
            comparison = ">" if over else "<="
            reason = (
                f"distance {distance:.4g} {comparison} threshold {threshold:.4g} "
                f"({describe_threshold(threshold, fit, config.percentile)})"
            )
            top = describe_top_indicator(details.get("indicators", {}))
            if (over or alarm) and top is not None:
                reason += f"; top indicator {top}"
            n_over = sum(recent[-n:])
            if n > 1:
                reason += f"; {n_over} of last {min(n, len(recent))} over"
            if alarm and not previous:
                reason += "; ALARM raised"
            elif alarm:
                clean = 0
                for value in reversed(recent):
                    if value:
                        break
                    clean += 1
                reason += f"; alarm persists until {m} clean captures in a row ({clean} so far)"
            elif previous:
                reason += f"; alarm cleared after {m} clean capture(s) in a row"
            else:
                reason += "; healthy"
        db.execute(
            "INSERT INTO scores (baseline_id, robot, axis, method, capture, captured_at, path, "
            "file_hash, file_size, file_mtime_ns, role, distance, threshold, over, alarm, "
            "reason, details, scored_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
            "?, ?, ?)",
            (
                job.baseline_id, file.robot, file.axis, config.method, file.capture,
                file.captured_at.isoformat(), job.relative, outcome.file_hash,
                outcome.file_size, outcome.file_mtime_ns, role, distance, threshold, int(over),
                int(alarm), reason, json.dumps(details, sort_keys=True), now(),
            ),
        )  # fmt: skip
    return True


def rebaseline(
    store: Store,
    robot: str,
    axis: str,
    *,
    method: str | None = None,
    from_capture: str | None = None,
) -> list[str]:
    """Retire the active baseline of an axis (after maintenance); the next monitor run starts anew.

    Parameters
    ----------
    store : Store
    robot, axis : str
    method : {"lra", "pca"} or None, default=None
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
    retired = []
    with store.write() as db:
        rows = db.execute(
            "SELECT id, method, epoch FROM baselines WHERE robot=? AND axis=? "
            "AND retired_at IS NULL AND (? IS NULL OR method=?) ORDER BY method",
            (robot, axis, method, method),
        ).fetchall()
        if not rows:
            known = sorted(
                f"{r[0]}/{r[1]} ({r[2]})"
                for r in db.execute(
                    "SELECT robot, axis, method FROM baselines WHERE retired_at IS NULL"
                )
            )
            raise StoreError(
                f"robot '{robot}' axis '{axis}'"
                + (f" method '{method}'" if method else "")
                + f" has no active baseline in store '{store.path}'; axes with one: "
                + (", ".join(known) or "none")
                + "."
            )
        if from_capture is not None:
            alarmed = db.execute(
                "SELECT method FROM scores WHERE robot=? AND axis=? AND capture=? AND alarm=1",
                (robot, axis, from_capture),
            ).fetchone()
            if alarmed:
                raise StoreError(
                    f"capture '{from_capture}' of robot '{robot}' axis '{axis}' raised an alarm "
                    f"({alarmed[0]}); an alarmed capture cannot be a baseline. Choose a capture "
                    "recorded after the maintenance."
                )
        stamp = now()
        for row in rows:
            db.execute("UPDATE baselines SET retired_at=? WHERE id=?", (stamp, row["id"]))
            db.execute(
                "INSERT INTO rebaselines (robot, axis, method, retired_epoch, from_capture, "
                "requested_at) VALUES (?, ?, ?, ?, ?, ?)",
                (robot, axis, row["method"], row["epoch"], from_capture, stamp),
            )
            retired.append(str(row["method"]))
    return retired
