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

The driver process alone writes the store (any :class:`~axiswatch.monitor.StoreBackend`; the
driver holds no SQL), one transaction per capture, committed in capture order per axis; the store
calls the pure :func:`~axiswatch.monitor._decision.decide` inside that transaction, from what it
holds at that moment. Scoring itself (read, features, distance) goes through
:func:`axiswatch.monitor._parallel.parallel_map`. Hence a killed run resumes exactly, and a second
process on the same store skips what the first has written.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from axiswatch._model import HealthModel
from axiswatch.exceptions import StoreError
from axiswatch.monitor._fleet import FleetFile, LayoutProblem, discover_fleet
from axiswatch.monitor._ledger import commit_score, insert_baseline, params_json, reject
from axiswatch.monitor._parallel import parallel_map
from axiswatch.monitor._scoring import (
    FitJob,
    FitOutcome,
    MonitorConfig,
    ScoreJob,
    ScoreOutcome,
    file_hash,
    fit_baseline,
    score_capture,
)
from axiswatch.monitor._store import AlarmState, Baseline, ChangedFile, StoreBackend

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


# --- one run's context -------------------------------------------------------------------------


@dataclass
class _Axis:
    robot: str
    axis: str
    files: list[FleetFile]
    baseline: Baseline | None = None
    model: HealthModel | None = None
    rates_hz: dict[str, float] = field(default_factory=dict)
    candidates: list[FleetFile] = field(default_factory=list)
    epoch: int = 1


@dataclass
class _Run:
    """What one run knows: where, with what, the files' hashes (each file hashed once), what the
    store held when it started, and the summary being built."""

    root: Path
    store: StoreBackend
    config: MonitorConfig
    workers: int
    dask: object | None
    progress: Progress | None
    summary: MonitorSummary
    hashes: dict[Path, str] = field(default_factory=dict)
    rejected: set[tuple[str, str]] = field(default_factory=set)
    alarmed: set[tuple[str, str, str]] = field(default_factory=set)
    done: dict[str, int] = field(default_factory=lambda: {"baselines": 0, "captures": 0})

    @property
    def method(self) -> str:
        return self.config.method

    def digest(self, path: Path) -> str:
        if path not in self.hashes:
            self.hashes[path] = file_hash(path)
        return self.hashes[path]

    def relative(self, path: Path) -> str:
        return path.relative_to(self.root).as_posix()

    def is_rejected(self, file: FleetFile) -> bool:
        return (self.relative(file.path), self.digest(file.path)) in self.rejected

    def usable(self, file: FleetFile) -> bool:
        """A candidate baseline: not rejected (this content) and never alarmed."""
        return not self.is_rejected(file) and (
            (file.robot, file.axis, file.capture) not in self.alarmed
        )

    def fit_job(self, file: FleetFile) -> FitJob:
        return FitJob(file, self.relative(file.path), self.config.model(), self.config.profile)

    def report(self, stage: str, done: int, total: int) -> None:
        if self.progress is not None:
            self.progress(stage, done, total)


def _key(file: FleetFile) -> tuple[datetime, str]:
    return (file.captured_at, file.capture)


def _from_capture(files: Sequence[FleetFile], capture: str) -> list[FleetFile]:
    """The files from ``capture`` on (it included)."""
    start = _key(next(f for f in files if f.capture == capture))
    return [f for f in files if _key(f) >= start]


# --- steps of a run ----------------------------------------------------------------------------


def _record_layout_problems(run: _Run, problems: Iterable[LayoutProblem]) -> None:
    for problem in problems:
        reject(
            run.store,
            run.method,
            problem.robot,
            problem.axis,
            problem.capture,
            run.relative(problem.path),
            run.digest(problem.path),
            problem.reason,
        )


def _changed_files(run: _Run, files: Sequence[FleetFile]) -> list[str]:
    """Files whose content differs from when they were scored (recorded, and listed)."""
    scored = run.store.scored_files()
    changed = []
    for file in files:
        relative = run.relative(file.path)
        previous = scored.get(relative)
        if previous is None:
            continue
        stat = file.path.stat()
        if (stat.st_size, stat.st_mtime_ns) == (previous.file_size, previous.file_mtime_ns):
            continue
        current = run.digest(file.path)
        if current == previous.file_hash:
            continue
        run.store.record_changed_file(
            ChangedFile(file.robot, file.axis, file.capture, relative, previous.file_hash, current)
        )
        changed.append(
            f"{relative}: content changed after it was scored; the stored result is kept "
            "(re-baseline the axis to score it afresh)"
        )
    return changed


def _plan_active(run: _Run, state: _Axis, baseline: Baseline) -> FitJob | None:
    """Refit the axis's active baseline, unless its file is missing or changed."""
    params = params_json(run.config)
    if baseline.params != params:
        raise StoreError(
            f"store '{run.store.location}': the baseline of robot {state.robot} axis "
            f"{state.axis} ({run.method}) was made with parameters {baseline.params}; this "
            f"run asks for {params}. Use the same options, another store, or "
            "re-baseline the axis."
        )
    state.baseline = baseline
    stored = next((f for f in state.files if f.capture == baseline.capture), None)
    if stored is None or run.digest(stored.path) != baseline.file_hash:
        what = "is missing" if stored is None else "changed after it was fitted"
        run.summary.axis_problems.append(
            f"{baseline.path}: baseline file {what}; robot {state.robot} axis "
            f"{state.axis} is not scored (re-baseline it)"
        )
        return None
    state.candidates = [stored]
    return run.fit_job(stored)


def _plan_new(run: _Run, state: _Axis, retired: Baseline | None) -> FitJob | None:
    """The first usable candidate of a new epoch: the configured or requested baseline, else
    the first capture (of a new axis) or the first one after everything scored (re-baseline)."""
    state.epoch = 1 if retired is None else retired.epoch + 1
    ordered = state.files
    names = {f.capture for f in ordered}
    if retired is None:
        chosen = run.config.baseline
        if chosen is not None and chosen in names:
            ordered = _from_capture(ordered, chosen)
    else:
        chosen = run.store.requested_baseline(state.robot, state.axis, run.method, retired.epoch)
        if chosen is not None:
            if chosen not in names:
                run.summary.axis_problems.append(
                    f"{state.robot}/{state.axis}: re-baseline capture '{chosen}' is not in "
                    "the fleet folder; the axis is not scored"
                )
                return None
            ordered = _from_capture(ordered, chosen)
        else:
            seen = run.store.last_captured_at(state.robot, state.axis, run.method)
            ordered = [f for f in ordered if seen is None or f.captured_at > seen]
    state.candidates = [f for f in ordered if run.usable(f)]
    return run.fit_job(state.candidates[0]) if state.candidates else None


def _plan_baseline(run: _Run, state: _Axis) -> FitJob | None:
    """The fit job of an axis: its active baseline, or the first candidate of a new epoch."""
    latest = run.store.latest_baseline(state.robot, state.axis, run.method)
    if latest is not None and not latest.retired:
        return _plan_active(run, state, latest)
    return _plan_new(run, state, latest)


def _accept_baseline(run: _Run, state: _Axis, outcome: FitOutcome) -> FitJob | None:
    """Record a fitted (or failed) baseline candidate; the next candidate's job on failure."""
    file = outcome.job.file
    if state.baseline is not None:  # an active baseline, refitted
        if outcome.model is None:
            run.summary.axis_problems.append(
                f"{outcome.error}; the stored baseline cannot be refitted"
            )
        else:
            state.model, state.rates_hz = outcome.model, outcome.rates_hz
        return None
    if outcome.model is None:
        reject(
            run.store,
            run.method,
            file.robot,
            file.axis,
            file.capture,
            outcome.job.relative,
            run.digest(file.path),
            str(outcome.error),
        )
        state.candidates = state.candidates[1:]
        if state.epoch == 1 and file.capture == run.config.baseline:
            state.candidates = []  # the chosen baseline is unusable: no other one
        return run.fit_job(state.candidates[0]) if state.candidates else None
    baseline_id = insert_baseline(run.store, outcome, state.epoch, run.config)
    if baseline_id is None:
        run.summary.axis_problems.append(
            f"{state.robot}/{state.axis}: another process chose a different baseline "
            "at the same time; run monitor again"
        )
        return None
    run.summary.new_baselines += 1
    state.baseline = run.store.baseline(baseline_id)
    state.model, state.rates_hz = outcome.model, outcome.rates_hz
    return None


def _fit_baselines(run: _Run, jobs: list[FitJob], by_axis: dict[tuple[str, str], _Axis]) -> None:
    """Fit the jobs' baselines; retry an axis's next candidate until one fits or none is left."""
    total = len(by_axis)
    while jobs:
        retry: list[FitJob] = []
        for _, outcome in parallel_map(fit_baseline, jobs, workers=run.workers, dask=run.dask):
            file = outcome.job.file
            run.done["baselines"] += 1
            run.report("baselines", run.done["baselines"], total)
            next_job = _accept_baseline(run, by_axis[(file.robot, file.axis)], outcome)
            if next_job is not None:
                retry.append(next_job)
        jobs = retry


def _score_jobs(run: _Run, states: Sequence[_Axis]) -> list[ScoreJob]:
    """One job per capture after the baseline that is neither scored under it nor rejected."""
    jobs: list[ScoreJob] = []
    for state in states:
        if state.model is None or state.baseline is None:
            continue
        baseline = state.baseline
        done = run.store.scored_captures(baseline.id)
        start = (baseline.captured_at, baseline.capture)
        for file in state.files:
            if _key(file) <= start or file.capture in done or run.is_rejected(file):
                continue
            relative = run.relative(file.path)
            jobs.append(
                ScoreJob(
                    file, relative, baseline.id, state.model, state.rates_hz, run.config.profile
                )
            )
    return jobs


def _score_in_order(run: _Run, jobs: list[ScoreJob]) -> None:
    """Score the jobs anywhere; commit each axis's results in capture order as they complete."""
    pending: dict[int, ScoreOutcome] = {}
    queue_of: dict[int, list[int]] = defaultdict(list)
    for index, job in enumerate(jobs):
        queue_of[job.baseline_id].append(index)
    first = run.done["captures"]
    for count, (index, result) in enumerate(
        parallel_map(score_capture, jobs, workers=run.workers, dask=run.dask), start=1
    ):
        pending[index] = result
        queue = queue_of[jobs[index].baseline_id]
        while queue and queue[0] in pending:
            ready = pending.pop(queue.pop(0))
            if commit_score(run.store, ready, run.config) and ready.error is None:
                run.summary.scored += 1
        run.report("captures", first + count, first + len(jobs))
    run.done["captures"] += len(jobs)


def _standing_rejections(run: _Run) -> list[str]:
    """Rejections whose file still has the rejected content."""
    scored = run.store.scored_contents(run.method)
    standing = []
    for rejection in run.store.rejections(run.method):
        path = run.root / rejection.path
        if not path.is_file() or (rejection.path, rejection.file_hash) in scored:
            continue
        if file_hash(path) == rejection.file_hash:
            standing.append(rejection.error)
    return standing


#: Axes whose models the driver holds at once (see monitor_fleet).
_AXES_PER_CHUNK = 256


def monitor_fleet(
    root: str | Path,
    store: StoreBackend,
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
    store : StoreBackend
        Where results go (and what was done before): ``Store(path)``, or another backend.
    config : MonitorConfig, optional
        Default ``MonitorConfig()``: the product default, as ``axiswatch monitor``.
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
    files, problems = discover_fleet(root)
    run = _Run(
        Path(root),
        store,
        config,
        workers,
        dask,
        progress,
        MonitorSummary(method=config.method, n_files=len(files) + len(problems)),
    )
    _record_layout_problems(run, problems)
    run.summary.changed = _changed_files(run, files)
    run.rejected = {(r.path, r.file_hash) for r in store.rejections(run.method)}
    run.alarmed = store.alarmed_captures(run.method)

    grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
    for file in files:
        grouped[(file.robot, file.axis)].append(file)
    by_axis = {key: _Axis(key[0], key[1], axis_files) for key, axis_files in grouped.items()}
    fit_jobs = [job for state in by_axis.values() if (job := _plan_baseline(run, state))]

    # Axes are handled a chunk at a time so that the driver never holds more than
    # _AXES_PER_CHUNK fitted models (a few MB each) however large the fleet.
    for first in range(0, len(fit_jobs), _AXES_PER_CHUNK):
        chunk = fit_jobs[first : first + _AXES_PER_CHUNK]
        states = [by_axis[(job.file.robot, job.file.axis)] for job in chunk]
        _fit_baselines(run, chunk, by_axis)
        _score_in_order(run, _score_jobs(run, states))
        for state in states:
            state.model = None

    run.summary.rejected = _standing_rejections(run)
    for alarm in store.alarms(run.method):
        if alarm.acknowledged:
            run.summary.acknowledged.append(alarm)
        else:
            run.summary.alarms.append((alarm.robot, alarm.axis))
    return run.summary
