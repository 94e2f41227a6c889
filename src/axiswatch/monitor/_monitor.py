"""Monitor a fleet: per robot axis a baseline, a calibrated threshold, scores and alarm states.

The driver: baseline, calibration and scoring as the monitor manual's "What monitor does"
says. It alone writes the store, one transaction per capture. Workers only score.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from glob import escape
from pathlib import Path
from typing import Any

from axiswatch._axis_model import MonitoredModel
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import ProfileError, StoreError
from axiswatch.monitor._fleet import (
    FleetFile,
    LayoutProblem,
    check_fleet_root,
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
from axiswatch.monitor._ledger import commit_score, insert_baseline, params_json, reject
from axiswatch.monitor._models import ModelRef, keep_model, resolve_model
from axiswatch.monitor._parallel import WorkerPool
from axiswatch.monitor._persist import load_model, model_version
from axiswatch.monitor._quality import QualityReference
from axiswatch.monitor._scoring import (
    FitJob,
    FitOutcome,
    MonitorConfig,
    ScoreJob,
    ScoreOutcome,
    fit_baseline,
    params_hash,
    profile_for,
    score_capture,
)
from axiswatch.monitor.store import (
    AlarmState,
    Baseline,
    ChangedFile,
    Rejection,
    RunCaches,
    SavedModel,
    StoreWriter,
    now,
    now_us,
)
from axiswatch.paper._features import FeatureSpec

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
#: is not a capture yet); deliver files atomically (docs/monitor.md) and this wait costs nothing.
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
    otherwise the sum of 4 (at least one axis is in an alarm nobody acknowledged) and 8 (a
    capture is rejected, a scored file changed, an axis cannot be scored or is stale, a baseline
    needs checking; acknowledged rejections, changes and baseline checks, counted in
    ``acknowledged``, do not count); so 4, 8 or 12. ``alarms`` lists the axes in unacknowledged alarm, ``acknowledged_alarms`` the alarms
    someone saw (``Store.acknowledge``) that have not cleared and been raised again since.
    ``waiting``: capture files not settled yet (scored by a later run; no attention needed).
    ``calibrating`` (method ``indicators``): axes whose baseline waits for its calibration
    captures (no attention needed); ``baseline_checks``: active baselines whose capture
    disagrees with the calibration captures after it (a faulty first capture?) or with their
    fleet's, stored with the baseline and listed on every run until acknowledged
    (``rejections --ack``) or re-baselined, and stored baselines slower than 20 Hz (noted every
    run until re-baselined), which need attention;
    ``fleet_priors``: axes fitted before their fleet had 3 axes that got its task-change
    allowances in this run (their later captures are scored with them; no attention needed).

    ``n_files`` counts the capture files of the axis folders this run listed;
    ``unchanged_folders`` the axis folders it did not list, unchanged since a run finished them
    (``monitor._index``).
    """

    method: str
    n_files: int = 0
    unchanged_folders: int = 0
    scored: int = 0
    new_baselines: int = 0
    rejected: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)
    axis_problems: list[str] = field(default_factory=list)
    alarms: list[tuple[str, str]] = field(default_factory=list)
    stale: list[str] = field(default_factory=list)
    waiting: int = 0
    acknowledged: int = 0
    acknowledged_alarms: list[AlarmState] = field(default_factory=list)
    calibrating: list[str] = field(default_factory=list)
    baseline_checks: list[str] = field(default_factory=list)
    fleet_priors: list[str] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0, or 4 (alarm) + 8 (rejected, changed, axis problem, stale axis or baseline check)."""
        attention = bool(
            self.rejected or self.changed or self.axis_problems or self.stale
            or self.baseline_checks
        )  # fmt: skip
        return 4 * bool(self.alarms) + 8 * attention


# --- one run's context -------------------------------------------------------------------------


@dataclass
class _Axis:
    robot: str
    axis: str
    files: list[FleetFile]
    baseline: Baseline | None = None
    model: ModelRef | None = None
    rates_hz: dict[str, float] = field(default_factory=dict)
    candidates: list[FleetFile] = field(default_factory=list)
    epoch: int = 1
    reference: QualityReference | None = None


@dataclass
class _Run:
    """What one run knows: where, with what, the file index (a file hashed only when new or
    changed), the workers, what the store held when it started, and the summary being built."""

    root: Path
    store: StoreWriter
    config: MonitorConfig
    pool: WorkerPool
    caches: RunCaches
    index: FileIndex
    progress: Progress | None
    summary: MonitorSummary
    params: str
    params_hash: str = ""
    profile_hashes: dict[tuple[str, str], str] = field(default_factory=dict)
    owners: dict[Path, FleetFile] = field(default_factory=dict)
    unreadable_paths: set[Path] = field(default_factory=set)
    stored_models: list[_Axis] = field(default_factory=list)  # scored without a refit
    problem_axes: set[tuple[str, str]] = field(default_factory=set)
    rejected: set[tuple[str, str]] = field(default_factory=set)
    alarmed: set[tuple[str, str, str]] = field(default_factory=set)
    done: dict[str, int] = field(default_factory=lambda: {"baselines": 0, "captures": 0})

    @property
    def method(self) -> str:
        return self.config.method

    @functools.cached_property
    def template(self) -> MonitoredModel:
        """An unfitted model of the configured method: what each fit job copies."""
        return self.config.model()

    def digest(self, path: Path) -> str | None:
        """The file's hash through the index, or None when it cannot be read (recorded as a
        transient rejection, tried again next run)."""
        try:
            return self.index.digest(path)
        except OSError as exc:
            owner = self.owners.get(path)
            if owner is not None and path not in self.unreadable_paths:
                self.unreadable_paths.add(path)
                self.unreadable(owner, f"cannot be read ({exc.strerror or exc})")
            return None

    def problem(self, state: _Axis, message: str) -> None:
        """An axis that cannot be scored: reported, and its folder listed again next run."""
        self.summary.axis_problems.append(message)
        self.problem_axes.add((state.robot, state.axis))

    def persist(self, outcome: FitOutcome, baseline_id: int) -> ModelRef:
        """Keep a fitted model in the store (with the baseline's data-quality reference); the
        reference jobs carry to it."""
        source = self.caches.model_source()
        if outcome.blob is None or source is None:
            # Not storable, or no store workers can read: the model travels with its jobs.
            inline = outcome.inline if outcome.blob is None else load_model(outcome.blob)
            return ModelRef(outcome.model_key, "", inline=inline)
        reference = None if outcome.reference is None else dict(outcome.reference.spans)
        saved = SavedModel(
            outcome.file_hash,
            self.params,
            model_version(),
            outcome.model_key,
            outcome.rates_hz,
            reference,
        )
        self.caches.save_model(baseline_id, saved, outcome.blob)
        return ModelRef(outcome.model_key, source)

    def rejection_key(self, robot: str, axis: str) -> str:
        """What a rejection of the axis's captures depends on: the parameters, and the content
        of the axis profile that applied (none, or a malformed one: its error). Adding or fixing
        the profile changes it, and the captures are read again."""
        key = (robot, axis)
        if key not in self.profile_hashes:
            try:
                profile = self.config.profile or AxisProfile.find(self.root, robot, axis)
                text = repr(profile)
            except (ProfileError, OSError) as exc:  # its captures are rejected with this error
                text = str(exc)
            self.profile_hashes[key] = hashlib.sha256(text.encode()).hexdigest()[:16]
        return f"{self.params_hash}+{self.profile_hashes[key]}"

    def unreadable(self, file: FleetFile, reason: str) -> None:
        relative = self.relative(file.path)
        reject(
            self.store, self.method, file.robot, file.axis, file.capture, relative, "",
            f"{relative}: {reason}; tried again next run", kind="unreadable", transient=True,
        )  # fmt: skip

    def relative(self, path: Path) -> str:
        return path.relative_to(self.root).as_posix()

    def is_rejected(self, file: FleetFile) -> bool:
        """Rejected with this content, or unreadable now."""
        digest = self.digest(file.path)
        return digest is None or (self.relative(file.path), digest) in self.rejected

    def usable(self, file: FleetFile) -> bool:
        """A candidate baseline: not rejected (this content) and never alarmed."""
        return not self.is_rejected(file) and (
            (file.robot, file.axis, file.capture) not in self.alarmed
        )

    def fit_job(
        self, file: FleetFile, following: Sequence[FleetFile] = (), *, refit: bool = False
    ) -> FitJob:
        """The fit job of a baseline candidate; ``following``: the usable captures after it (an
        IndicatorModel is fitted on the first that give a reading, too); ``refit``: of a stored
        baseline (:attr:`FitJob.refit`)."""
        relative = self.relative(file.path)
        if not self.template.fits_calibration:
            following = ()
        return FitJob(
            file, relative, self.template, self.config.profile,
            calibration=tuple(following),
            relatives=tuple(self.relative(f.path) for f in following),
            calibration_size=self.config.calibration_size,
            refit=refit,
            max_rows=self.config.max_capture_rows,
        )  # fmt: skip

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


def _changed_files(run: _Run, changed: Sequence[tuple[str, str, str]]) -> list[str]:
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


def _plan_active(run: _Run, state: _Axis, baseline: Baseline) -> FitJob | None:
    """Refit the axis's active baseline, unless its file is missing or changed."""
    params = run.params
    if baseline.params != params:
        differences = "; ".join(parameter_differences(baseline.params, params))
        raise StoreError(
            f"store '{run.store.location}': the baseline of robot {state.robot} axis "
            f"{state.axis} ({run.method}) was made with other parameters ({differences}). "
            "Use the same options, another store, or re-baseline the axis."
        )
    state.baseline = baseline
    stored = next((f for f in state.files if f.capture == baseline.capture), None)
    hashed = None if stored is None else run.digest(stored.path)
    if stored is None or hashed != baseline.file_hash:
        what = (
            "is missing or waiting"
            if stored is None
            else "cannot be read"
            if hashed is None
            else "changed after it was fitted"
        )
        run.problem(
            state,
            f"{baseline.path}: baseline file {what}; robot {state.robot} axis "
            f"{state.axis} is not scored (re-baseline it)",
        )
        return None
    state.candidates = [stored]
    saved = run.caches.saved_model(baseline.id)
    if saved is not None and saved.reference is not None and _still_valid(run, saved, baseline):
        source = run.caches.model_source()
        assert source is not None  # a store that keeps models is one workers can read
        state.model, state.rates_hz = ModelRef(saved.model_hash, source), saved.rates_hz
        state.reference = QualityReference(dict(saved.reference))
        run.stored_models.append(state)
        _note_slow_baseline(run, state, baseline, saved.rates_hz)
        return None
    following = [f for f in state.files if _key(f) > _key(stored) and run.usable(f)]
    return run.fit_job(stored, following, refit=True)


def _note_slow_baseline(
    run: _Run, state: _Axis, baseline: Baseline, rates_hz: Mapping[str, float]
) -> None:
    """List a stored indicators baseline slower than 20 Hz under *Baselines to check*: kept and
    scored as before (also when refitted after an upgrade), reported on every run (its folder
    listed again) until it is rebaselined; never an alarm."""
    slow = run.template.baseline_note(rates_hz)
    if slow is not None:
        run.summary.baseline_checks.append(f"{baseline.path}: {slow}")
        run.problem_axes.add((state.robot, state.axis))


def _refit_failed(
    run: _Run, state: _Axis, baseline: Baseline, why: str, rates_hz: Mapping[str, float]
) -> None:
    """A stored baseline that cannot be refitted: its axis is not scored, one line says why. A
    baseline slower than 20 Hz also gets its rebaseline advice on that line: a rebaseline is
    what mends both, and without a refitted model the note of a kept slow baseline is not made.
    ``rates_hz``: the baseline capture's, when the refit read it; else the stored model's."""
    if not rates_hz:
        saved = run.caches.saved_model(baseline.id)
        rates_hz = {} if saved is None else saved.rates_hz
    slow = run.template.baseline_note(rates_hz)
    advice = "" if slow is None else f" ({slow})"
    run.problem(state, f"{why.removesuffix('.')}; the stored baseline cannot be refitted{advice}")


def _still_valid(run: _Run, saved: SavedModel, baseline: Baseline) -> bool:
    """A stored model of the baseline that this run can use as it is: same file, parameters,
    library version and model format. Any other is refitted (and never read: a blob of an
    older format cannot be). A model saved without the baseline's data-quality reference is
    refitted too: the reference judges "no motion" in every later capture."""
    return saved.reference is not None and (
        saved.file_hash,
        saved.params,
        saved.library_version,
    ) == (baseline.file_hash, run.params, model_version())


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
                run.problem(
                    state,
                    f"{state.robot}/{state.axis}: re-baseline capture '{chosen}' is not in "
                    "the fleet folder; the axis is not scored",
                )
                return None
            ordered = _from_capture(ordered, chosen)
        else:
            seen = run.store.last_captured_at(state.robot, state.axis, run.method)
            ordered = [f for f in ordered if seen is None or f.captured_at > seen]
    state.candidates = [f for f in ordered if run.usable(f)]
    return run.fit_job(state.candidates[0], state.candidates[1:]) if state.candidates else None


def _plan_baseline(run: _Run, state: _Axis) -> FitJob | None:
    """The fit job of an axis: its active baseline, or the first candidate of a new epoch."""
    latest = run.store.latest_baseline(state.robot, state.axis, run.method)
    if latest is not None and not latest.retired:
        return _plan_active(run, state, latest)
    return _plan_new(run, state, latest)


def _accept_baseline(run: _Run, state: _Axis, outcome: FitOutcome) -> FitJob | None:
    """Record a fitted (or failed) baseline candidate; the next candidate's job on failure."""
    file = outcome.job.file
    if outcome.waiting is not None:  # an IndicatorModel short of calibration captures
        if state.baseline is not None:
            _refit_failed(run, state, state.baseline, outcome.waiting, outcome.rates_hz)
        else:
            run.summary.calibrating.append(outcome.waiting)
            run.problem_axes.add((state.robot, state.axis))  # listed again next run
        return None
    if state.baseline is not None:  # an active baseline, refitted
        if outcome.error is not None:
            _refit_failed(run, state, state.baseline, outcome.error, outcome.rates_hz)
        else:
            state.model = run.persist(outcome, state.baseline.id)
            state.rates_hz = outcome.rates_hz
            state.reference = outcome.reference
            _note_slow_baseline(run, state, state.baseline, outcome.rates_hz)
        return None
    if outcome.error is not None:
        digest = run.digest(file.path) or ""
        reject(
            run.store,
            run.method,
            file.robot,
            file.axis,
            file.capture,
            outcome.job.relative,
            digest,
            str(outcome.error),
            kind=outcome.kind,
            params_hash=run.rejection_key(file.robot, file.axis),
            transient=outcome.transient,
        )
        if not outcome.transient:
            # Rejected for good: not scored (nor re-rejected as out of order) in this run.
            run.rejected.add((outcome.job.relative, digest))
        state.candidates = state.candidates[1:]
        if state.epoch == 1 and file.capture == run.config.baseline:
            state.candidates = []  # the chosen baseline is unusable: no other one
        return run.fit_job(state.candidates[0], state.candidates[1:]) if state.candidates else None
    inserted = insert_baseline(run.store, outcome, state.epoch, run.config)
    if inserted is None:
        run.problem(
            state,
            f"{state.robot}/{state.axis}: another process chose a different baseline "
            "at the same time; run monitor again",
        )
        return None
    if inserted.added:  # not when another run on the store added the same one first
        run.summary.new_baselines += 1
    state.baseline = run.store.baseline(inserted.id)
    state.model = run.persist(outcome, inserted.id)
    state.rates_hz = outcome.rates_hz
    state.reference = outcome.reference
    return None


def _fit_baselines(run: _Run, jobs: list[FitJob], by_axis: dict[tuple[str, str], _Axis]) -> None:
    """Fit the jobs' baselines; retry an axis's next candidate until one fits or none is left."""
    total = len(by_axis)
    pooled = run.template.pooled
    fitted: list[FitOutcome] = []
    while jobs:
        retry: list[FitJob] = []
        for _, outcome in run.pool.map(fit_baseline, jobs):
            file = outcome.job.file
            run.done["baselines"] += 1
            run.report("baselines", run.done["baselines"], total)
            if pooled and outcome.error is None and outcome.waiting is None:
                fitted.append(outcome)  # accepted once its fleet's prior is known
                continue
            next_job = _accept_baseline(run, by_axis[(file.robot, file.axis)], outcome)
            if next_job is not None:
                retry.append(next_job)
        jobs = retry
    # Workers finish in any order. The fleet's prior no longer depends on the order its axes are
    # pooled in (each pair is read both ways, in its baseline's spreads: fleet_pair_shifts; read
    # one way it did, and a run on several workers scored differently from a serial one); the
    # baselines are still accepted in one order, so a run on several workers stores them (their
    # ids) and lists their checks as a serial run does.
    fitted.sort(key=lambda outcome: (outcome.job.file.robot, outcome.job.file.axis))
    for outcome in _with_fleet_priors(run, fitted):
        _accept_baseline(run, by_axis[(outcome.job.file.robot, outcome.job.file.axis)], outcome)


def _own_model(outcome: FitOutcome) -> MonitoredModel:
    model = outcome.inline if outcome.blob is None else load_model(outcome.blob)
    assert model is not None
    return model


@dataclass(frozen=True)
class _StoredModel:
    """An axis's stored model of its active baseline."""

    robot: str
    axis: str
    baseline_id: int
    saved: SavedModel
    baseline: MonitoredModel


def _stored_models(run: _Run, fitting: set[tuple[str, str]]) -> dict[str, list[_StoredModel]]:
    """The stored models of the active baselines of every axis the store knows (its folder
    listed in this run or not), but ``fitting``, by fleet."""
    source = run.caches.model_source()
    groups: dict[str, list[_StoredModel]] = defaultdict(list)
    if source is None:  # a store that keeps no models: only this run's fits are pooled
        return groups
    for row in run.store.axis_activity().itertuples(index=False):
        robot, axis = str(row.robot), str(row.axis)
        baseline = run.store.latest_baseline(robot, axis, run.method)
        if (robot, axis) in fitting or baseline is None or baseline.retired:
            continue
        saved = run.caches.saved_model(baseline.id)
        # An outdated model (another format, version or parameters: an upgrade) is left out of
        # the pool until its axis is refitted, when a new file of it arrives.
        if saved is None or not _still_valid(run, saved, baseline):
            continue
        stored = resolve_model(ModelRef(saved.model_hash, source))
        try:
            profile = run.config.profile or AxisProfile.find(run.root, robot, axis)
        except ProfileError:
            continue  # its captures are rejected with the profile's error until it is fixed
        groups[stored.fleet_key(profile)].append(
            _StoredModel(robot, axis, baseline.id, saved, stored)
        )
    return groups


def _give_prior(
    run: _Run, stored: Sequence[_StoredModel], pooled: Sequence[MonitoredModel]
) -> None:
    """Store ``pooled``, the stored axes fitted without a fleet prior (their fleet had fewer than
    3 axes then) now with their fleet's: their captures are scored with the task-change
    allowances from the next run on (a run scores the axes with a stored model before it fits new
    ones); the scores and decisions already stored stay (each score's details say how many fleet
    axes it was scored with). A stored distance is in units of the threshold that applied, so the
    threshold the monitor decides with stays 1."""
    for entry, upgraded in zip(stored, pooled, strict=True):
        if not upgraded.fleet_axes():
            return  # fewer than 3 axes, or nothing to pool: no prior for any
        model_key, blob = keep_model(upgraded)
        if blob is None:
            continue
        check = upgraded.checks().get("fleet")
        # The prior and its check in one transaction: once the prior is stored the axis is
        # never pooled again, so a check left for later would be lost with a killed run.
        with run.store.batch():
            run.caches.save_model(
                entry.baseline_id, dataclasses.replace(entry.saved, model_hash=model_key), blob
            )
            if check is not None:
                run.store.record_baseline_check(entry.baseline_id, "fleet", check)
        line = (
            f"{entry.robot}/{entry.axis}: task-change allowances from "
            f"{upgraded.fleet_axes()} axes of its fleet, from its next run's captures on"
        )
        run.summary.fleet_priors.append(line if check is None else f"{line}; {check}")


def _with_fleet_priors(run: _Run, fitted: list[FitOutcome]) -> list[FitOutcome]:
    """The new models with the prior of their fleet: pooled over the own models of the axes of
    one fleet (the model's ``fleet_key``) fitted in this run or stored with an active baseline,
    each new baseline checked against the others' prior (the model's ``with_fleet``). An axis
    keeps the prior it was fitted with until it is re-baselined (its allowances must not move
    under its captures); one fitted without a prior, because its fleet had fewer than 3 axes
    then, gets the prior once its fleet has them (:func:`_give_prior`)."""
    if not fitted:
        return fitted
    groups = _stored_models(run, {(o.job.file.robot, o.job.file.axis) for o in fitted})
    new: dict[str, list[tuple[int, MonitoredModel]]] = defaultdict(list)
    for position, outcome in enumerate(fitted):
        own = _own_model(outcome)
        new[own.fleet_key(profile_for(outcome.job.file, run.config.profile))].append(
            (position, own)
        )
    out = list(fitted)
    stores_models = run.caches.model_source() is not None
    for key, members in new.items():
        # One pool per fleet: the new baselines and the stored ones still without a prior get it
        # together; the stored ones with a prior keep theirs.
        needing = [g for g in groups[key] if not g.baseline.fleet_axes() and stores_models]
        keeping = [g.baseline for g in groups[key] if g not in needing]
        pooled = run.template.with_fleet(
            [*(g.baseline for g in needing), *(b for _, b in members)], keeping
        )
        _give_prior(run, needing, pooled[: len(needing)])
        for (position, _), baseline in zip(members, pooled[len(needing) :], strict=True):
            if not baseline.fleet_axes():
                continue
            model_key, blob = keep_model(baseline)
            out[position] = dataclasses.replace(
                fitted[position], model_key=model_key, blob=blob,
                inline=baseline if blob is None else None,
                summary=baseline.summary(), checks=baseline.checks(),
            )  # fmt: skip
    return out


def _score_jobs(run: _Run, states: Sequence[_Axis]) -> list[ScoreJob]:
    """One job per capture after the baseline that is neither scored under it nor rejected."""
    with run.store.batch():  # the new files' index entries (and late captures) in one commit
        return _score_jobs_of(run, states)


def _score_jobs_of(run: _Run, states: Sequence[_Axis]) -> list[ScoreJob]:
    jobs: list[ScoreJob] = []
    for state in states:
        if state.model is None or state.baseline is None:
            continue
        baseline = state.baseline
        done = run.store.scored_captures(baseline.id)
        start = (baseline.captured_at, baseline.capture)
        chosen = baseline.epoch == 1 and run.config.baseline == baseline.capture
        for file in state.files:
            if file.capture in done or run.is_rejected(file):
                continue
            relative = run.relative(file.path)
            if _key(file) <= start:
                digest = run.digest(file.path)
                if (
                    not chosen
                    and digest is not None
                    and not run.caches.was_scored(relative, digest, run.method)
                ):
                    _out_of_order(run, file, baseline)
                continue
            jobs.append(
                ScoreJob(
                    file,
                    relative,
                    baseline.id,
                    state.model,
                    state.rates_hz,
                    profile=run.config.profile,
                    reference=state.reference,
                    max_rows=run.config.max_capture_rows,
                )
            )
    return jobs


def _out_of_order(run: _Run, file: FleetFile, baseline: Baseline) -> None:
    """A capture dated before the axis's baseline that was never scored: it arrived late."""
    relative = run.relative(file.path)
    reject(
        run.store, run.method, file.robot, file.axis, file.capture, relative,
        run.digest(file.path) or "",
        f"{relative}: dated before the baseline {baseline.capture} of epoch {baseline.epoch} and "
        "never scored (it arrived out of order); re-baseline the axis with --from to score it",
        kind="out of order",
    )  # fmt: skip


def _score_in_order(run: _Run, planned: Iterable[ScoreJob], *, expected: int | None = None) -> None:
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
                    if commit_score(run.store, ready, run.config, key) and ready.error is None:
                        run.summary.scored += 1
        count += len(group)
        run.report("captures", first + count, first + len(jobs))
    run.done["captures"] += len(jobs)


def _holds(run: _Run, rejection: Rejection) -> bool:
    """A rejection holds for this run's parameters and its axis's profile."""
    made_under = rejection.params_hash
    return made_under is None or made_under == run.rejection_key(rejection.robot, rejection.axis)


def _standing_rejections(run: _Run) -> list[str]:
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
        if not _holds(run, rejection):
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


def _standing_checks(run: _Run) -> list[str]:
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
        run = _Run(
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
            if not r.transient and _holds(run, r)
        }
        run.alarmed = store.alarmed_captures(run.method)

        grouped: dict[tuple[str, str], list[FleetFile]] = defaultdict(list)
        for file in files:
            grouped[(file.robot, file.axis)].append(file)
        by_axis = {key: _Axis(key[0], key[1], axis_files) for key, axis_files in grouped.items()}
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
                        if job := _plan_baseline(run, state):
                            fit_jobs.append(job)
                    jobs = _score_jobs_of(run, run.stored_models[known:])
                yield from jobs

        # Axes with a stored model first, as they are planned (a day's run has one new capture
        # per axis: the batches are sized for as many jobs as axes); then a chunk at a time, so
        # that what the driver holds per axis stays bounded however large the fleet (workers
        # keep the models themselves).
        _score_in_order(run, stored_jobs(), expected=len(by_axis))
        for first in range(0, len(fit_jobs), _AXES_PER_CHUNK):
            chunk = fit_jobs[first : first + _AXES_PER_CHUNK]
            states = [by_axis[(job.file.robot, job.file.axis)] for job in chunk]
            _fit_baselines(run, chunk, by_axis)
            _score_in_order(run, _score_jobs(run, states))
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


def _not_future(run: _Run, files: Sequence[FleetFile]) -> list[FleetFile]:
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


def check_request(
    root: str | Path,
    config: MonitorConfig,
    *,
    finished: Mapping[tuple[str, str], int] | None = None,
) -> None:
    """Check what a run asks for before anything is stored.

    ``finished``: axis folders a run with these very parameters finished (``monitor._index``),
    with their modification times then. With any, the signals were columns of the captures it
    scored and are not looked up again, and one unchanged folder shows the fleet folder is not
    an unmounted share (looking again would list folders a run with nothing new never lists).

    Raises
    ------
    NotADirectoryError, DataNotFoundError
        If ``root`` is not a folder or holds no capture file (an unmounted share).
    ValueError
        If ``config.baseline`` names a file that no axis folder holds, or a signal is a column
        of none of the first captures of the first axes (a typo such as ``torqe``).
    """
    root = Path(root)
    check_fleet_root(root, known=finished)
    if not finished:
        _check_signals(root, config)
    if (
        config.baseline is not None
        and next(root.glob(f"*/*/{escape(config.baseline)}"), None) is None
    ):
        raise ValueError(
            f"baseline capture '{config.baseline}' is in no axis folder of '{root}'; expected "
            "the file name of a capture, such as 2026-03-01.parquet."
        )


#: Axes whose first capture's columns are compared with the requested signals.
_AXES_CHECKED = 8


def _check_signals(root: Path, config: MonitorConfig) -> None:
    """Raise when a requested signal is a column of no capture among the first of a few axes
    (axes read through a profile that maps their own column names are not looked at).

    Only signals the user chose are checked: with the default signals, a fleet whose files name
    their columns otherwise is a data problem, rejected per capture with the missing column and
    the hint of an axis profile, not a usage error.
    """
    signals = config.features.signals
    if tuple(signals) == tuple(FeatureSpec().signals):
        return
    listed: set[tuple[str, str]] = set()

    def beyond_checked(robot: str, axis: str) -> bool:
        # Without a profile every axis is looked at: the first few folders are enough.
        if config.profile is None and len(listed) >= _AXES_CHECKED:
            return True
        listed.add((robot, axis))
        return False

    files, _ = discover_fleet(root, skip=beyond_checked)
    files = [f for f in files if not _maps_columns(f, config.profile)]
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


def _maps_columns(file: FleetFile, given: AxisProfile | None) -> bool:
    """Whether the file's profile renames its columns (a malformed profile is not looked at
    here: the file's jobs reject it with the profile's error)."""
    try:
        profile = profile_for(file, given)
    except ProfileError:
        return True
    return profile is not None and bool(profile.columns)


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
