"""Monitor a fleet: per robot axis a baseline, a calibrated threshold, scores and alarm states.

The driver: baseline, calibration and scoring as the monitor manual's "What monitor does"
says. It alone writes the store, one transaction per capture. Workers only score.
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Iterable, Iterator, Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path

from axiswatch.monitor._config import MonitorConfig, params_hash
from axiswatch.monitor._fleet import (
    FleetFile,
    LayoutProblem,
    discover_fleet,
    split_settled,
)
from axiswatch.monitor._index import (
    FileIndex,
    axis_folder_time,
    run_caches,
    unchanged_axes,
    verify_budget,
)
from axiswatch.monitor._ledger import commit_score, params_json, reject
from axiswatch.monitor._parallel import WorkerPool
from axiswatch.monitor._planning import fit_baselines, plan_baseline, score_jobs, score_jobs_of
from axiswatch.monitor._requests import check_request, parameter_differences
from axiswatch.monitor._run import AxisState, MonitorSummary, Progress, Run
from axiswatch.monitor._scoring import FitJob, ScoreJob, ScoreOutcome, score_capture
from axiswatch.monitor.store import (
    ChangedFile,
    Rejection,
    StoreWriter,
    now,
    now_us,
)

__all__ = [
    "DEFAULT_SETTLE_S",
    "DEFAULT_STALE_AFTER",
    "MonitorSummary",
    "check_request",
    "monitor_fleet",
    "parameter_differences",
]

#: Seconds a capture file must go unmodified before it is scored (a file still being written
#: is not a capture yet); deliver files atomically (docs/monitor.md) and this wait costs nothing.
DEFAULT_SETTLE_S = 10.0
#: Silence after which an axis is *stale*: no new capture file for this long.
DEFAULT_STALE_AFTER = timedelta(days=3)
#: A capture dated later than this after now is *future-dated* (a logger's clock is wrong): it
#: is not scored until its date has come, so that it cannot block later captures.
_FUTURE_TOLERANCE = timedelta(days=1)


def _record_layout_problems(run: Run, problems: Iterable[LayoutProblem]) -> None:
    for problem in problems:
        if not problem.capture and problem.files:
            # A misnamed folder: one rejection for all its files, transient (forgotten once the
            # folder is renamed and its files are scored under the new name); its axis folders
            # are listed again next run.
            run.problem_axes |= set(problem.axes)
            folder = run.relative(problem.path) + "/"
            # A store from before kept one rejection per file of the folder: now the folder's.
            earlier = [
                r.path
                for r in run.store.rejections(run.method)
                if r.capture and r.kind == "layout" and r.path.startswith(folder)
            ]
            if earlier:
                run.store.retry_rejections(earlier, run.method)
            reject(
                run.store, run.method, problem.robot, problem.axis, "",
                folder, "", problem.reason, kind="layout",
                transient=True, reason_key=problem.reason_key,
            )  # fmt: skip
            continue
        if not problem.capture:  # a folder: reported every run while it lasts, not stored
            run.summary.axis_problems.append(problem.reason)
            continue
        reject(
            run.store,
            run.method,
            problem.robot,
            problem.axis,
            problem.capture,
            run.relative(problem.path),
            run.digest(problem.path) or "",
            problem.reason,
            kind="layout",
        )


def _changed_files(run: Run, changed: Sequence[tuple[str, str, str]]) -> list[str]:
    """Scored files whose content differs from when they were scored (recorded, and listed
    unless acknowledged: those are counted in the summary's ``acknowledged``); ``changed`` from
    :meth:`FileIndex.verify`."""
    messages = []
    for relative, _, current in changed:
        scored = run.caches.last_scored(relative)
        if scored is None or scored.file_hash == current:
            continue
        change = ChangedFile(
            scored.robot, scored.axis, scored.capture, relative, scored.file_hash, current
        )
        run.store.record_changed_file(change)
        if run.store.changed_file_acknowledged(change):
            run.summary.acknowledged += 1
            continue
        messages.append(
            f"{relative}: content changed after it was scored; the stored result is kept "
            "(re-baseline the axis to score it afresh)"
        )
    return messages


def _score_in_order(run: Run, planned: Iterable[ScoreJob], *, expected: int | None = None) -> None:
    """Score the jobs anywhere; commit each axis's results in capture order as they complete.

    ``planned`` may be a generator that plans the jobs while the first ones run (``expected``:
    about how many it gives, to size the batches); an axis's jobs come in capture order.
    """
    pending: dict[int, ScoreOutcome] = {}
    queue_of: dict[int, list[int]] = defaultdict(list)
    jobs: list[ScoreJob] = []

    def dispatched() -> Iterator[ScoreJob]:
        # A result can only come back for a job sent, so its axis's queue is known by then.
        for job in planned:
            queue_of[job.baseline_id].append(len(jobs))
            jobs.append(job)
            yield job

    first = run.done["captures"]
    count = 0
    for group in run.pool.map_groups(score_capture, dispatched(), expected=expected):
        # A worker's batch in one transaction: the driver, which alone writes, commits less.
        with run.store.batch():
            for index, result in group:
                pending[index] = result
                queue = queue_of[jobs[index].baseline_id]
                while queue and queue[0] in pending:
                    ready = pending.pop(queue.pop(0))
                    key = run.rejection_key(ready.job.file.robot, ready.job.file.axis)
                    if (
                        commit_score(run.store, ready, run.config, key, run.modes)
                        and ready.error is None
                    ):
                        run.summary.scored += 1
                        file = ready.job.file
                        run.summary.unread.add_details(f"{file.robot}/{file.axis}", ready.details)
                        run.summary.note_repairs(f"{file.robot}/{file.axis}", ready.details)
        count += len(group)
        run.report("captures", first + count, first + len(jobs))
    run.done["captures"] += len(jobs)


def holds(run: Run, rejection: Rejection) -> bool:
    """A rejection holds for this run's parameters and its axis's profile."""
    made_under = rejection.params_hash
    return made_under is None or made_under == run.rejection_key(rejection.robot, rejection.axis)


def _standing_rejections(run: Run) -> list[str]:
    """Rejections that still hold (the file still has the rejected content, or a transient
    problem was seen again in this run), not acknowledged (those are counted).

    A rejected file gone from the fleet folder (deleted, moved away) is marked removed in the
    store, kept as history: the report and the summary then stop asking for attention, as this
    exit status does; if the same content comes back, the mark is cleared and it holds again.
    """
    standing = []
    for rejection in run.store.rejections(run.method):
        path = run.root / rejection.path
        if not rejection.transient:  # a transient one is forgotten once not seen again
            there = path.is_file()
            if not there and rejection.removed_at is None:
                run.store.mark_rejection_removed(rejection, now())
            elif (
                there
                and rejection.removed_at is not None
                and run.digest(path) == rejection.file_hash
            ):
                run.store.mark_rejection_removed(rejection, None)
        # Point queries: a run's cost must not follow the history of scores.
        scored = run.caches.was_scored(rejection.path, rejection.file_hash, run.method)
        if not holds(run, rejection):
            if scored:  # made under other options or another profile, and scored since
                run.store.retry_rejections([rejection.path], run.method)
            continue
        if scored:
            continue
        if not rejection.transient and not (
            path.is_file() and run.digest(path) == rejection.file_hash
        ):
            continue
        if rejection.acknowledged_at is not None:
            run.summary.acknowledged += 1
        else:
            standing.append(rejection.error)
    return standing


def _standing_checks(run: Run) -> list[str]:
    """The stored checks of the method's active baselines not acknowledged (those are counted),
    one line each: every run reports them, whichever run fitted the baseline, until they are
    acknowledged or the axis is re-baselined."""
    standing = []
    for check in run.store.baseline_checks(run.method):
        if check.acknowledged_at is not None:
            run.summary.acknowledged += 1
        else:
            standing.append(f"{check.path}: {check.note}")
    return standing


#: Axes fitted and scored at a time (see monitor_fleet).
_AXES_PER_CHUNK = 256
#: Axes planned in one transaction before their captures are sent to the workers.
_AXES_PER_PLAN = 64


def monitor_fleet(
    root: str | Path,
    store: StoreWriter,
    config: MonitorConfig | None = None,
    *,
    workers: int = 1,
    dask: object | None = None,
    progress: Progress | None = None,
    verify_per_run: int | None = None,
    settle_s: float = DEFAULT_SETTLE_S,
    stale_after: timedelta | None = DEFAULT_STALE_AFTER,
) -> MonitorSummary:
    """Score every capture of the fleet not scored yet; keep baselines, thresholds and alarms.

    Parameters
    ----------
    root : str or Path
        Fleet folder ``ROOT/<robot>/<axis>/<capture>.<ext>``.
    store : StoreWriter
        Where results go (and what was done before): ``Store(path)``, or another backend.
    config : MonitorConfig, optional
        Default ``MonitorConfig()``: the product default, as ``axiswatch monitor``.
    workers, dask
        Where jobs run: :class:`axiswatch.monitor._parallel.WorkerPool` (as ``parallel_map``).
    progress : callable (stage, done, total), optional
        Called as baselines are fitted and captures scored.
    verify_per_run : int, optional
        Kept files compared with the disk in this run, to find files changed in place
        (``monitor._index``); default :func:`~axiswatch.monitor._index.verify_budget` of the
        fleet's axes.
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
    started = datetime.now(UTC)
    seen_at = now_us()
    root = Path(root)
    caches = run_caches(store)
    params = params_json(config)
    finished = caches.axis_folder_times(config.method, params)
    check_request(root, config, finished=finished)
    index = FileIndex(caches, root, caches.start_run())
    changed, dirty = index.verify(
        verify_budget(len(finished)) if verify_per_run is None else verify_per_run
    )
    skipped = unchanged_axes(root, finished, dirty)
    folder_times: dict[tuple[str, str], int | None] = {}

    def skip(robot: str, axis: str) -> bool:
        if (robot, axis) in skipped:
            return True
        # Read before the folder is listed: a file arriving later changes it again.
        folder_times[(robot, axis)] = axis_folder_time(root, robot, axis)
        return False

    discovered, problems = discover_fleet(root, skip=skip)
    with WorkerPool(workers, dask) as pool:
        run = Run(
            root,
            store,
            config,
            pool,
            caches,
            index,
            progress,
            MonitorSummary(
                method=config.method,
                n_files=len(discovered) + sum(max(p.files, 1) for p in problems),
                unchanged_folders=len(skipped),
            ),
            params,
            params_hash=params_hash(config),
            owners={f.path: f for f in discovered},
        )
        _record_layout_problems(run, problems)
        # Folders not listed hold no new file: their axes' activity is left as it was.
        store.record_axis_activity(_activity(discovered), started.isoformat(timespec="seconds"))
        files, waiting, failed = split_settled(discovered, settle_s, time.time())
        run.summary.waiting = len(waiting)
        for file, reason in failed:
            run.unreadable(file, reason)
        files = _not_future(run, files)
        # An axis folder with a file not scored yet (waiting, unreadable, dated in the future)
        # must be listed again next run.
        kept = set(files)
        run.problem_axes |= {(f.robot, f.axis) for f in discovered if f not in kept}
        run.summary.changed = _changed_files(run, changed)
        run.rejected = {
            (r.path, r.file_hash)
            for r in store.rejections(run.method)
            if not r.transient and holds(run, r)
        }
        run.alarmed = store.alarmed_captures(run.method)
        run.summary.alarmed_before = set(run.alarmed)

        grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
        for file in files:
            grouped[(file.robot, file.axis)].append(file)
        by_axis = {
            key: AxisState(key[0], key[1], axis_files) for key, axis_files in grouped.items()
        }
        fit_jobs: list[FitJob] = []

        def stored_jobs() -> Iterator[ScoreJob]:
            """Plan a slice of axes at a time (one transaction each) and send the captures of
            those with a stored model to the workers at once: planning a large fleet (hashing
            its new files) runs while the first captures are scored."""
            axes = list(by_axis.values())
            for start in range(0, len(axes), _AXES_PER_PLAN):
                known = len(run.stored_models)
                with store.batch():
                    for state in axes[start : start + _AXES_PER_PLAN]:
                        if job := plan_baseline(run, state):
                            fit_jobs.append(job)
                    jobs = score_jobs_of(run, run.stored_models[known:])
                yield from jobs

        # Axes with a stored model first, as they are planned (a day's run has one new capture
        # per axis: the batches are sized for as many jobs as axes); then a chunk at a time, so
        # that what the driver holds per axis stays bounded however large the fleet (workers
        # keep the models themselves).
        _score_in_order(run, stored_jobs(), expected=len(by_axis))
        for first in range(0, len(fit_jobs), _AXES_PER_CHUNK):
            chunk = fit_jobs[first : first + _AXES_PER_CHUNK]
            states = [by_axis[(job.file.robot, job.file.axis)] for job in chunk]
            fit_baselines(run, chunk, by_axis)
            _score_in_order(run, score_jobs(run, states))
            for state in states:
                state.model = None

    # An axis with a rejected capture is listed every run: ``rejections --retry`` forgets the
    # rejection, and the file must then be tried again (one removed from the folder is not
    # there to try; if it comes back, its folder's time changes).
    problem_axes = (
        run.problem_axes
        | {(f.robot, f.axis) for f in discovered if f.path in run.unreadable_paths}
        | {(r.robot, r.axis) for r in store.rejections(run.method) if r.removed_at is None}
    )
    with store.batch():
        for robot_axis, mtime_ns in folder_times.items():
            if mtime_ns is not None and robot_axis not in problem_axes:
                caches.finish_axis_folder(*robot_axis, config.method, params, mtime_ns)
    store.resolve_transient(run.method, seen_at)
    run.summary.rejected = _standing_rejections(run)
    run.summary.baseline_checks += _standing_checks(run)
    for alarm in store.alarms(run.method):
        if alarm.acknowledged:
            run.summary.acknowledged_alarms.append(alarm)
        else:
            run.summary.alarms.append((alarm.robot, alarm.axis))
    if stale_after is not None:
        run.summary.stale = _stale_axes(store, started, stale_after)
    return run.summary


def _not_future(run: Run, files: Sequence[FleetFile]) -> list[FleetFile]:
    """The files not dated in the future; those are recorded as transient rejections."""
    future_from = datetime.now() + _FUTURE_TOLERANCE
    for file in files:
        if file.captured_at > future_from:
            relative = run.relative(file.path)
            reject(
                run.store, run.method, file.robot, file.axis, file.capture, relative, "",
                f"{relative}: dated {file.captured_at.isoformat()}, in the future (a logger "
                "clock?); not scored before that date", kind="future", transient=True,
            )  # fmt: skip
    return [f for f in files if f.captured_at <= future_from]


def _activity(files: Sequence[FleetFile]) -> list[tuple[str, str, int, str]]:
    """(robot, axis, number of capture files, newest capture) of every axis with files."""
    grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
    for file in files:
        grouped[(file.robot, file.axis)].append(file)
    return [
        (robot, axis, len(own), max(f.capture for f in own))
        for (robot, axis), own in sorted(grouped.items())
    ]


def _stale_axes(store: StoreWriter, now_utc: datetime, stale_after: timedelta) -> list[str]:
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
