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

from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from axiswatch._model import HealthModel
from axiswatch.exceptions import StoreError
from axiswatch.monitor._fleet import FleetFile, discover_fleet
from axiswatch.monitor._ledger import commit_score, insert_baseline, now, params_json, reject
from axiswatch.monitor._parallel import parallel_map
from axiswatch.monitor._scoring import (
    FitJob,
    MonitorConfig,
    ScoreJob,
    ScoreOutcome,
    file_hash,
    fit_baseline,
    score_capture,
)
from axiswatch.monitor._store import AlarmState, Store

__all__ = ["MonitorSummary", "monitor_fleet"]

Progress = Callable[[str, int, int], None]


# --- summary -----------------------------------------------------------------------------------


@dataclass
class MonitorSummary:
    """What one ``monitor`` run did and what the fleet's state is afterwards.

    Exit status of ``axiswatch monitor`` (:attr:`exit_code`): 0 when nothing needs attention;
    otherwise the sum of 4 (at least one axis is in an alarm nobody acknowledged) and 8 (a
    capture is rejected, a scored file changed, or an axis cannot be scored); so 4, 8 or 12.
    ``alarms`` lists the axes in unacknowledged alarm, ``acknowledged`` the alarms someone saw
    (``Store.acknowledge``) that have not cleared and been raised again since.
    """

    method: str
    n_files: int = 0
    scored: int = 0
    new_baselines: int = 0
    rejected: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)
    axis_problems: list[str] = field(default_factory=list)
    alarms: list[tuple[str, str]] = field(default_factory=list)
    acknowledged: list[AlarmState] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0, or 4 (alarm) + 8 (rejected, changed or axis problem)."""
        attention = bool(self.rejected or self.changed or self.axis_problems)
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


def _key(file: FleetFile) -> tuple[datetime, str]:
    return (file.captured_at, file.capture)


def _changed_files(
    store: Store, root: Path, files: Sequence[FleetFile], hashes: dict[Path, str]
) -> list[str]:
    """Files whose content differs from when they were scored (recorded, and listed)."""
    scored: dict[str, Any] = {}
    for row in store.rows(
        "SELECT robot, axis, capture, path, file_hash, file_size, file_mtime_ns FROM scores "
        "ORDER BY id"
    ):
        scored[row["path"]] = row
    changed = []
    for file in files:
        relative = file.path.relative_to(root).as_posix()
        previous = scored.get(relative)
        if previous is None:
            continue
        stat = file.path.stat()
        if (stat.st_size, stat.st_mtime_ns) == (previous["file_size"], previous["file_mtime_ns"]):
            continue
        if file.path not in hashes:
            hashes[file.path] = file_hash(file.path)
        current = hashes[file.path]
        if current == previous["file_hash"]:
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
        changed.append(
            f"{relative}: content changed after it was scored; the stored result is kept "
            "(re-baseline the axis to score it afresh)"
        )
    return changed


def _standing_rejections(store: Store, root: Path, method: str) -> list[str]:
    """Rejections whose file still has the rejected content."""
    standing = []
    scored = {
        (r["path"], r["file_hash"])
        for r in store.rows("SELECT path, file_hash FROM scores WHERE method=?", (method,))
    }
    for row in store.rows(
        "SELECT path, file_hash, error FROM rejections WHERE method=? ORDER BY id", (method,)
    ):
        path = root / row["path"]
        if not path.is_file() or (row["path"], row["file_hash"]) in scored:
            continue
        if file_hash(path) == row["file_hash"]:
            standing.append(str(row["error"]))
    return standing


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

    Returns
    -------
    MonitorSummary

    Raises
    ------
    StoreError
        If an axis's stored baseline was made with other parameters than ``config``.
    """
    config = MonitorConfig() if config is None else config
    root = Path(root)
    method = config.method
    files, problems = discover_fleet(root)
    summary = MonitorSummary(method=method, n_files=len(files) + len(problems))
    hashes: dict[Path, str] = {}

    def digest(path: Path) -> str:
        if path not in hashes:
            hashes[path] = file_hash(path)
        return hashes[path]

    for problem in problems:
        reject(
            store, method, problem.robot, problem.axis, problem.capture,
            problem.path.relative_to(root).as_posix(),
            digest(problem.path), problem.reason,
        )  # fmt: skip
    summary.changed = _changed_files(store, root, files, hashes)

    rejected = {
        (r["path"], r["file_hash"])
        for r in store.rows("SELECT path, file_hash FROM rejections WHERE method=?", (method,))
    }
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

    def relative(file: FleetFile) -> str:
        return file.path.relative_to(root).as_posix()

    def usable(state: _Axis, file: FleetFile) -> bool:
        return (relative(file), digest(file.path)) not in rejected and (
            state.robot,
            state.axis,
            file.capture,
        ) not in alarmed

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
                raise StoreError(
                    f"store '{store.path}': the baseline of robot {state.robot} axis "
                    f"{state.axis} ({method}) was made with parameters {latest['params']}; this "
                    f"run asks for {params}. Use the same options, another store, or "
                    "re-baseline the axis."
                )
            state.baseline = latest
            by_name = {f.capture: f for f in state.files}
            stored = by_name.get(latest["capture"])
            if stored is None or digest(stored.path) != latest["file_hash"]:
                what = "is missing" if stored is None else "changed after it was fitted"
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
                    continue
                if outcome.model is None:
                    reject(
                        store, method, file.robot, file.axis, file.capture, outcome.job.relative,
                        digest(file.path), str(outcome.error),
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
            for file in state.files:
                if _key(file) <= start or file.capture in done_captures:
                    continue
                if (relative(file), digest(file.path)) in rejected:
                    continue
                jobs.append(
                    ScoreJob(file, relative(file), baseline_id, state.model, state.rates_hz)
                )

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

    summary.rejected = _standing_rejections(store, root, method)
    for alarm in store.alarms(method):
        if alarm.acknowledged:
            summary.acknowledged.append(alarm)
        else:
            summary.alarms.append((alarm.robot, alarm.axis))
    return summary


def _by_capture(files: Sequence[FleetFile], capture: str) -> FleetFile:
    return next(f for f in files if f.capture == capture)
