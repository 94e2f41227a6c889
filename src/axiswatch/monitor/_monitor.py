"""Monitor a fleet: per robot axis a baseline, a calibrated threshold, scores and alarm states.

Pipeline top stage (below the CLI). For every robot axis found under ``ROOT`` (see ``_fleet``) and
one detection method:

1. **Baseline** (the paper's commissioning capture): the first capture that can be read, or the
   one named by ``MonitorConfig.baseline``; after :func:`rebaseline`, the capture named then, or
   the next capture that arrives. A capture that raised an alarm is never a baseline.
2. **Calibration**: the next ``calibration_size`` usable captures (default 5) are assumed
   healthy; the threshold is the ``percentile`` (default 99) of the half-Laplace fit of their
   distances (paper, end of "Proposed Method"). Five is the fewest that still gives the fit a
   sample (its scale is the mean distance, whose relative standard error is 1/sqrt(5) = 45 %)
   while keeping the first week of a new robot free of alarms; raise it where captures are
   cheap. A capture alarmed under an earlier baseline is never used for calibration.
3. **Scoring**: every later capture gets its distance to the baseline, whether it is over the
   threshold, and the alarm state: raised when ``alarm_k`` of the last ``alarm_n`` captures are
   over (``k = n = 1`` by default, as in the paper), cleared after ``clear_m`` clean captures in a
   row (default 1).

The driver process alone writes the store, one transaction per capture, committed in capture
order per axis and computing the role, threshold and alarm state from what the store holds at
that moment; scoring itself (read, features, distance) goes through
:func:`axiswatch.monitor._parallel.parallel_map`. Hence a killed run resumes exactly, and a second
process on the same store skips what the first has written.
"""

from __future__ import annotations

import json
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from glob import escape
from pathlib import Path
from typing import Any

from axiswatch._model import HealthModel
from axiswatch.exceptions import StoreError
from axiswatch.monitor._fleet import FleetFile, check_fleet_root, discover_fleet, split_settled
from axiswatch.monitor._ledger import (
    commit_score,
    insert_baseline,
    now,
    params_json,
    reject,
    stamp,
)
from axiswatch.monitor._parallel import parallel_map
from axiswatch.monitor._quality import QualityReference
from axiswatch.monitor._scoring import (
    FitJob,
    MonitorConfig,
    ScoreJob,
    ScoreOutcome,
    file_hash,
    fit_baseline,
    params_hash,
    score_capture,
)
from axiswatch.monitor._store import Store

__all__ = [
    "DEFAULT_SETTLE_S",
    "DEFAULT_STALE_AFTER",
    "MonitorSummary",
    "check_request",
    "monitor_fleet",
    "parameter_differences",
]

Progress = Callable[[str, int, int], None]

#: Seconds a capture file must go unmodified before it is scored (a file still being written
#: is not a capture yet); deliver files atomically (README) and this wait costs nothing.
DEFAULT_SETTLE_S = 10.0
#: Silence after which an axis is *stale*: no new capture file for this long.
DEFAULT_STALE_AFTER = timedelta(days=3)
#: A capture dated later than this after now is *future-dated* (a logger's clock is wrong): it
#: is not scored until its date has come, so that it cannot block later captures.
_FUTURE_TOLERANCE = timedelta(days=1)


# --- summary -----------------------------------------------------------------------------------


@dataclass
class MonitorSummary:
    """What one ``monitor`` run did and what the fleet's state is afterwards.

    Exit status of ``axiswatch monitor`` (:attr:`exit_code`): 0 when nothing needs attention;
    otherwise the sum of 4 (at least one axis is in alarm) and 8 (a capture is rejected, a
    scored file changed, an axis cannot be scored or is stale; acknowledged rejections and
    changes, counted in ``acknowledged``, do not count); so 4, 8 or 12. ``waiting``: capture
    files not settled yet (scored by a later run; no attention needed).
    """

    method: str
    n_files: int = 0
    scored: int = 0
    new_baselines: int = 0
    rejected: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)
    axis_problems: list[str] = field(default_factory=list)
    alarms: list[tuple[str, str]] = field(default_factory=list)
    stale: list[str] = field(default_factory=list)
    waiting: int = 0
    acknowledged: int = 0

    @property
    def exit_code(self) -> int:
        """0, or 4 (alarm) + 8 (rejected, changed, axis problem or stale axis)."""
        attention = bool(self.rejected or self.changed or self.axis_problems or self.stale)
        return 4 * bool(self.alarms) + 8 * attention


# --- the driver --------------------------------------------------------------------------------


@dataclass
class _Axis:
    robot: str
    axis: str
    files: list[FleetFile]
    baseline: Any = None  # sqlite3.Row of the active baseline
    model: HealthModel | None = None
    rates_hz: dict[str, float] = field(default_factory=dict)
    candidates: list[FleetFile] = field(default_factory=list)
    epoch: int = 1
    reference: QualityReference | None = None


def _key(file: FleetFile) -> tuple[datetime, str]:
    return (file.captured_at, file.capture)


Digest = Callable[[Path], str | None]


def _changed_files(
    store: Store, root: Path, files: Sequence[FleetFile], digest: Digest
) -> tuple[list[str], int]:
    """Files whose content differs from when they were scored (recorded, and listed unless
    acknowledged); and how many acknowledged ones were left out."""
    scored: dict[str, Any] = {}
    for row in store.rows(
        "SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns FROM scores "
        "ORDER BY id"
    ):
        scored[row["path"]] = row
    changed, acknowledged = [], 0
    for file in files:
        relative = file.path.relative_to(root).as_posix()
        previous = scored.get(relative)
        if previous is None:
            continue
        stat = file.path.stat()
        if (stat.st_size, stat.st_mtime_ns) == (previous["file_size"], previous["file_mtime_ns"]):
            continue
        current = digest(file.path)
        if current is None or current == previous["file_hash"]:
            continue
        with store.write() as db:
            db.execute(
                "INSERT OR IGNORE INTO changed_files (robot, axis, capture, path, scored_hash, "
                "current_hash, detected_at) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (
                    file.robot,
                    file.axis,
                    file.capture,
                    relative,
                    previous["file_hash"],
                    current,
                    now(),
                ),
            )
        if store.changed_file_acknowledged(relative, previous["file_hash"], current):
            acknowledged += 1
            continue
        changed.append(
            f"{relative}: content changed after it was scored; the stored result is kept "
            "(re-baseline the axis to score it afresh)"
        )
    return changed, acknowledged


def _standing_rejections(
    store: Store, root: Path, method: str, phash: str, digest: Digest
) -> tuple[list[str], int]:
    """Rejections that still hold (the file still has the rejected content, or a transient
    problem was seen again in this run), not acknowledged; and how many acknowledged ones."""
    standing, acknowledged = [], 0
    scored = {
        (r["path"], r["file_hash"])
        for r in store.rows("SELECT path, file_hash FROM scores WHERE method=?", (method,))
    }
    for row in store.rejections_of(method, phash):
        path = root / row["path"]
        if (row["path"], row["file_hash"]) in scored:
            continue
        if not row["transient"] and not (path.is_file() and digest(path) == row["file_hash"]):
            continue
        if row["acknowledged_at"] is not None:
            acknowledged += 1
        else:
            standing.append(str(row["error"]))
    return standing, acknowledged


def parameter_differences(stored: str, asked: str) -> list[str]:
    """The parameters that differ between two ``params`` JSON texts, one ``name: a -> b`` each.

    Examples
    --------
    >>> parameter_differences('{"a": 1, "b": {"c": 2}}', '{"a": 1, "b": {"c": 3}, "d": 4}')
    ['b.c: 2 -> 3', 'd: (none) -> 4']
    """

    def flat(value: Any, prefix: str = "") -> dict[str, Any]:
        if isinstance(value, dict):
            out: dict[str, Any] = {}
            for key, item in value.items():
                out.update(flat(item, f"{prefix}{key}."))
            return out
        return {prefix[:-1]: value}

    old, new = flat(json.loads(stored)), flat(json.loads(asked))
    return [
        f"{name}: {json.dumps(old[name]) if name in old else '(none)'} -> "
        f"{json.dumps(new[name]) if name in new else '(none)'}"
        for name in sorted(set(old) | set(new))
        if old.get(name, ...) != new.get(name, ...)
    ]


def check_request(root: str | Path, config: MonitorConfig) -> None:
    """Check what a run asks for before anything is stored.

    Raises
    ------
    NotADirectoryError, DataNotFoundError
        If ``root`` is not a folder or holds no capture file (an unmounted share).
    ValueError
        If ``config.baseline`` names a file that no axis folder holds, or a signal is a column
        of none of the first captures of the first axes (a typo such as ``torqe``).
    """
    root = Path(root)
    check_fleet_root(root)
    _check_signals(root, config.features.signals)
    if (
        config.baseline is not None
        and next(root.glob(f"*/*/{escape(config.baseline)}"), None) is None
    ):
        raise ValueError(
            f"baseline capture '{config.baseline}' is in no axis folder of '{root}'; expected "
            "the file name of a capture, such as 2026-03-01.parquet."
        )


#: Axes whose models the driver holds at once (see monitor_fleet).
_AXES_PER_CHUNK = 256


def monitor_fleet(
    root: str | Path,
    store: Store,
    config: MonitorConfig | None = None,
    *,
    workers: int = 1,
    dask: object | None = None,
    progress: Progress | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    stale_after: timedelta | None = DEFAULT_STALE_AFTER,
) -> MonitorSummary:
    """Score every capture of the fleet not scored yet; keep baselines, thresholds and alarms.

    Parameters
    ----------
    root : str or Path
        Fleet folder ``ROOT/<robot>/<axis>/<capture>.<ext>``.
    store : Store
        Where results go (and what was done before).
    config : MonitorConfig, optional
    workers, dask
        Passed to :func:`axiswatch.monitor._parallel.parallel_map`.
    progress : callable (stage, done, total), optional
        Called as baselines are fitted and captures scored.
    settle_s : float, default=DEFAULT_SETTLE_S (10)
        A capture file modified less than this many seconds ago is still being written: it
        waits for a later run.
    stale_after : timedelta or None, default=DEFAULT_STALE_AFTER (3 days)
        An axis without a new capture file for this long is stale (None: never).

    Returns
    -------
    MonitorSummary

    Raises
    ------
    NotADirectoryError, DataNotFoundError, ValueError
        As :func:`check_request`, before anything is stored.
    StoreError
        If an axis's stored baseline was made with other parameters than ``config`` (naming
        them), or the store cannot be read or written (corrupt, full disk).
    """
    config = MonitorConfig() if config is None else config
    root = Path(root)
    method = config.method
    started = datetime.now(UTC)
    seen_at = stamp()
    check_request(root, config)
    phash = params_hash(config)
    discovered, problems = discover_fleet(root)
    summary = MonitorSummary(method=method, n_files=len(discovered) + len(problems))
    hashes: dict[Path, str | None] = {}

    def relative(file: FleetFile) -> str:
        return file.path.relative_to(root).as_posix()

    def unreadable(file: FleetFile, reason: str) -> None:
        reject(
            store, method, file.robot, file.axis, file.capture, relative(file), "",
            f"{relative(file)}: {reason}; tried again next run", kind="unreadable", transient=True,
        )  # fmt: skip

    def digest(path: Path) -> str | None:
        """The file's hash, or None when it cannot be read (recorded as a transient rejection)."""
        if path not in hashes:
            try:
                hashes[path] = file_hash(path)
            except OSError as exc:
                hashes[path] = None
                owner = next((f for f in discovered if f.path == path), None)
                if owner is not None:
                    unreadable(owner, f"cannot be read ({exc.strerror or exc})")
        return hashes[path]

    for problem in problems:
        if not problem.capture:  # a folder: reported every run while it lasts, not stored
            summary.axis_problems.append(problem.reason)
            continue
        reject(
            store, method, problem.robot, problem.axis, problem.capture,
            problem.path.relative_to(root).as_posix(),
            digest(problem.path) or "", problem.reason, kind="layout",
        )  # fmt: skip
    store.record_axis_activity(_activity(discovered), started.isoformat(timespec="seconds"))
    files, waiting, failed = split_settled(discovered, settle_s, time.time())
    summary.waiting = len(waiting)
    for file, reason in failed:
        unreadable(file, reason)
    future_from = datetime.now() + _FUTURE_TOLERANCE
    for file in [f for f in files if f.captured_at > future_from]:
        reject(
            store, method, file.robot, file.axis, file.capture, relative(file), "",
            f"{relative(file)}: dated {file.captured_at.isoformat()}, in the future (a logger "
            "clock?); not scored before that date", kind="future", transient=True,
        )  # fmt: skip
    files = [f for f in files if f.captured_at <= future_from]
    summary.changed, changes_seen = _changed_files(store, root, files, digest)

    rejected = store.rejected_files(method, phash)
    alarmed = {
        (r["robot"], r["axis"], r["capture"])
        for r in store.rows(
            "SELECT robot, axis, capture FROM scores WHERE method=? AND alarm=1", (method,)
        )
    }
    params = params_json(config)

    grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
    for file in files:
        grouped[(file.robot, file.axis)].append(file)
    axes = [_Axis(robot, axis, axis_files) for (robot, axis), axis_files in grouped.items()]

    def usable(state: _Axis, file: FleetFile) -> bool:
        hashed = digest(file.path)
        return (
            hashed is not None
            and (relative(file), hashed) not in rejected
            and (
                state.robot,
                state.axis,
                file.capture,
            )
            not in alarmed
        )

    fit_jobs: list[FitJob] = []
    for state in axes:
        rows = store.rows(
            "SELECT * FROM baselines WHERE robot=? AND axis=? AND method=? ORDER BY epoch DESC "
            "LIMIT 1",
            (state.robot, state.axis, method),
        )
        latest = rows[0] if rows else None
        if latest is not None and latest["retired_at"] is None:
            if latest["params"] != params:
                differences = "; ".join(parameter_differences(latest["params"], params))
                raise StoreError(
                    f"store '{store.path}': the baseline of robot {state.robot} axis "
                    f"{state.axis} ({method}) was made with other parameters ({differences}). "
                    "Use the same options, another store, or re-baseline the axis."
                )
            state.baseline = latest
            by_name = {f.capture: f for f in state.files}
            stored = by_name.get(latest["capture"])
            hashed = None if stored is None else digest(stored.path)
            if stored is None or hashed != latest["file_hash"]:
                what = (
                    "is missing or waiting"
                    if stored is None
                    else "cannot be read"
                    if hashed is None
                    else "changed after it was fitted"
                )
                summary.axis_problems.append(
                    f"{latest['path']}: baseline file {what}; robot {state.robot} axis "
                    f"{state.axis} is not scored (re-baseline it)"
                )
                continue
            state.candidates = [stored]
            fit_jobs.append(FitJob(stored, relative(stored), config))
            continue
        state.epoch = 1 if latest is None else int(latest["epoch"]) + 1
        ordered = state.files
        if latest is None:
            if config.baseline is not None and config.baseline in {f.capture for f in ordered}:
                ordered = [
                    f for f in ordered if _key(f) >= _key(_by_capture(ordered, config.baseline))
                ]
        else:
            request = store.rows(
                "SELECT from_capture FROM rebaselines WHERE robot=? AND axis=? AND method=? "
                "AND retired_epoch=? ORDER BY id DESC LIMIT 1",
                (state.robot, state.axis, method, latest["epoch"]),
            )
            chosen = request[0]["from_capture"] if request else None
            if chosen is not None:
                if chosen not in {f.capture for f in ordered}:
                    summary.axis_problems.append(
                        f"{state.robot}/{state.axis}: re-baseline capture '{chosen}' is not in "
                        "the fleet folder; the axis is not scored"
                    )
                    continue
                ordered = [f for f in ordered if _key(f) >= _key(_by_capture(ordered, chosen))]
            else:
                seen = store.rows(
                    "SELECT max(captured_at) AS last FROM scores WHERE robot=? AND axis=? "
                    "AND method=?",
                    (state.robot, state.axis, method),
                )[0]["last"]
                ordered = [f for f in ordered if seen is None or f.captured_at.isoformat() > seen]
        state.candidates = [f for f in ordered if usable(state, f)]
        if state.candidates:
            fit_jobs.append(FitJob(state.candidates[0], relative(state.candidates[0]), config))

    by_axis = {(s.robot, s.axis): s for s in axes}
    counts = {"baselines": 0, "captures": 0}

    def fit_chunk(fit_jobs: list[FitJob]) -> None:
        while fit_jobs:
            retry: list[FitJob] = []
            for _, outcome in parallel_map(fit_baseline, fit_jobs, workers=workers, dask=dask):
                file = outcome.job.file
                state = by_axis[(file.robot, file.axis)]
                counts["baselines"] += 1
                if progress is not None:
                    progress("baselines", counts["baselines"], len(axes))
                if state.baseline is not None:
                    if outcome.model is None:
                        summary.axis_problems.append(
                            f"{outcome.error}; the stored baseline cannot be refitted"
                        )
                    else:
                        state.model, state.rates_hz = outcome.model, outcome.rates_hz
                        state.reference = outcome.reference
                    continue
                if outcome.model is None:
                    reject(
                        store, method, file.robot, file.axis, file.capture, outcome.job.relative,
                        digest(file.path) or "", str(outcome.error), kind=outcome.kind,
                        params_hash=phash, transient=outcome.transient,
                    )  # fmt: skip
                    state.candidates = state.candidates[1:]
                    if (
                        config.baseline is not None
                        and state.epoch == 1
                        and file.capture == config.baseline
                    ):
                        state.candidates = []
                    if state.candidates:
                        retry.append(
                            FitJob(state.candidates[0], relative(state.candidates[0]), config)
                        )
                    continue
                baseline_id = insert_baseline(store, outcome, state.epoch, config)
                if baseline_id is None:
                    summary.axis_problems.append(
                        f"{state.robot}/{state.axis}: another process chose a different baseline "
                        "at the same time; run monitor again"
                    )
                    continue
                summary.new_baselines += 1
                state.baseline = store.rows("SELECT * FROM baselines WHERE id=?", (baseline_id,))[0]
                state.model, state.rates_hz = outcome.model, outcome.rates_hz
                state.reference = outcome.reference
            fit_jobs = retry

    def score_chunk(states: Sequence[_Axis]) -> None:
        jobs: list[ScoreJob] = []
        for state in states:
            if state.model is None or state.baseline is None:
                continue
            baseline_id = int(state.baseline["id"])
            done_captures = {
                r["capture"]
                for r in store.rows(
                    "SELECT capture FROM scores WHERE baseline_id=?", (baseline_id,)
                )
            }
            start = (
                datetime.fromisoformat(state.baseline["captured_at"]),
                state.baseline["capture"],
            )
            chosen = (
                int(state.baseline["epoch"]) == 1 and config.baseline == state.baseline["capture"]
            )
            ever_scored: set[str] | None = None
            for file in state.files:
                if file.capture in done_captures:
                    continue
                hashed = digest(file.path)
                if hashed is None or (relative(file), hashed) in rejected:
                    continue
                if _key(file) <= start:
                    if ever_scored is None:
                        ever_scored = store.scored_captures(state.robot, state.axis, method)
                    if not chosen and file.capture not in ever_scored:
                        _out_of_order(store, method, file, relative(file), hashed, state.baseline)
                    continue
                jobs.append(
                    ScoreJob(
                        file, relative(file), baseline_id, state.model, state.rates_hz,
                        state.reference,
                    )
                )  # fmt: skip

        # Commit in capture order per axis, whatever order results complete in.
        pending: dict[int, ScoreOutcome] = {}
        queue_of: dict[int, list[int]] = defaultdict(list)
        for index, job in enumerate(jobs):
            queue_of[job.baseline_id].append(index)
        for count, (index, result) in enumerate(
            parallel_map(score_capture, jobs, workers=workers, dask=dask), start=1
        ):
            pending[index] = result
            queue = queue_of[jobs[index].baseline_id]
            while queue and queue[0] in pending:
                ready = pending.pop(queue.pop(0))
                if commit_score(store, ready, config) and ready.error is None:
                    summary.scored += 1
            if progress is not None:
                progress("captures", counts["captures"] + count, counts["captures"] + len(jobs))
        counts["captures"] += len(jobs)

    # Axes are handled a chunk at a time so that the driver never holds more than
    # _AXES_PER_CHUNK fitted models (a few MB each) however large the fleet.
    for first in range(0, len(fit_jobs), _AXES_PER_CHUNK):
        chunk = fit_jobs[first : first + _AXES_PER_CHUNK]
        states = [by_axis[(job.file.robot, job.file.axis)] for job in chunk]
        fit_chunk(chunk)
        score_chunk(states)
        for state in states:
            state.model = None

    store.resolve_transient(method, seen_at)
    summary.rejected, rejections_seen = _standing_rejections(store, root, method, phash, digest)
    summary.acknowledged = changes_seen + rejections_seen
    if stale_after is not None:
        summary.stale = _stale_axes(store, started, stale_after)
    for row in store.rows(
        "SELECT b.robot, b.axis, (SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id "
        "AND s.role='monitor' ORDER BY s.id DESC LIMIT 1) AS alarm FROM baselines b "
        "WHERE b.method=? AND b.retired_at IS NULL ORDER BY b.robot, b.axis",
        (method,),
    ):
        if row["alarm"]:
            summary.alarms.append((row["robot"], row["axis"]))
    return summary


#: Axes whose first capture's columns are compared with the requested signals.
_AXES_CHECKED = 8


def _check_signals(root: Path, signals: Sequence[str]) -> None:
    """Raise when a requested signal is a column of no capture among the first of a few axes."""
    files, _ = discover_fleet(root)
    firsts = list({(f.robot, f.axis): f for f in reversed(files)}.values())[-_AXES_CHECKED:]
    seen: dict[str, list[str]] = {}
    for file in firsts:
        try:
            seen[file.path.relative_to(root).as_posix()] = _columns(file.path)
        except Exception:
            continue
    if not seen:
        return
    missing = [name for name in signals if not any(name in cols for cols in seen.values())]
    if missing:
        example, columns = next(iter(seen.items()))
        raise ValueError(
            f"The 'signals' parameter names {missing}, a column of none of {len(seen)} capture "
            f"file(s) looked at; {example} has columns {columns}."
        )


def _columns(path: Path) -> list[str]:
    """Column names of a capture file, read from its header only."""
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        return [str(name) for name in pq.read_schema(path).names]
    import pandas as pd

    return [str(name) for name in pd.read_csv(path, nrows=0).columns]


def _activity(files: Sequence[FleetFile]) -> list[tuple[str, str, int, str]]:
    """(robot, axis, number of capture files, newest capture) of every axis with files."""
    grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
    for file in files:
        grouped[(file.robot, file.axis)].append(file)
    return [
        (robot, axis, len(own), max(f.capture for f in own))
        for (robot, axis), own in sorted(grouped.items())
    ]


def _stale_axes(store: Store, now_utc: datetime, stale_after: timedelta) -> list[str]:
    """Axes without a new capture file for longer than ``stale_after``, one line each."""
    lines = []
    for row in store.axis_activity().itertuples(index=False):
        silence = now_utc - datetime.fromisoformat(str(row.last_seen_at))
        if silence > stale_after:
            lines.append(
                f"{row.robot}/{row.axis}: stale, no new capture file for {_days(silence)} "
                f"(last seen {row.last_seen_at}, newest {row.newest_capture}; --stale-after "
                f"{_days(stale_after)})"
            )
    return lines


def _days(span: timedelta) -> str:
    hours = span.total_seconds() / 3600
    return f"{hours / 24:.1f} d" if hours >= 24 else f"{hours:.1f} h"


def _out_of_order(
    store: Store, method: str, file: FleetFile, relative: str, hashed: str, baseline: Any
) -> None:
    """A capture dated before the axis's baseline that was never scored: it arrived late."""
    reject(
        store, method, file.robot, file.axis, file.capture, relative, hashed,
        f"{relative}: dated before the baseline {baseline['capture']} of epoch "
        f"{baseline['epoch']} and never scored (it arrived out of order); re-baseline the axis "
        "with --from to score it", kind="out of order",
    )  # fmt: skip


def _by_capture(files: Sequence[FleetFile], capture: str) -> FleetFile:
    return next(f for f in files if f.capture == capture)
