"""Plan a run's jobs: each axis's baseline fit, its fleet prior, and the captures to score."""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from axiswatch._axis_model import MonitoredModel
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import ProfileError, StoreError
from axiswatch.monitor._fleet import (
    FleetFile,
)
from axiswatch.monitor._ledger import insert_baseline, reject
from axiswatch.monitor._models import ModelRef, keep_model, resolve_model
from axiswatch.monitor._persist import load_model, model_version
from axiswatch.monitor._quality import QualityReference
from axiswatch.monitor._requests import parameter_differences
from axiswatch.monitor._run import AxisState, Run, capture_key, from_capture
from axiswatch.monitor._scoring import (
    FitJob,
    FitOutcome,
    ScoreJob,
    fit_baseline,
    profile_for,
)
from axiswatch.monitor.store import (
    Baseline,
    SavedModel,
)

__all__ = ["fit_baselines", "plan_baseline", "score_jobs", "score_jobs_of"]


def _plan_active(run: Run, state: AxisState, baseline: Baseline) -> FitJob | None:
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
    following = [f for f in state.files if capture_key(f) > capture_key(stored) and run.usable(f)]
    return run.fit_job(stored, following, refit=True)


def _note_slow_baseline(
    run: Run, state: AxisState, baseline: Baseline, rates_hz: Mapping[str, float]
) -> None:
    """List a stored indicators baseline slower than 20 Hz under *Baselines to check*: kept and
    scored as before (also when refitted after an upgrade), reported on every run (its folder
    listed again) until it is rebaselined; never an alarm."""
    slow = run.template.baseline_note(rates_hz)
    if slow is not None:
        run.summary.baseline_checks.append(f"{baseline.path}: {slow}")
        run.problem_axes.add((state.robot, state.axis))


def _refit_failed(
    run: Run, state: AxisState, baseline: Baseline, why: str, rates_hz: Mapping[str, float]
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


def _still_valid(run: Run, saved: SavedModel, baseline: Baseline) -> bool:
    """A stored model of the baseline that this run can use as it is: same file, parameters,
    axis profile, library version and model format. Any other is refitted (and never read: a blob of an
    older format cannot be). A model saved without the baseline's data-quality reference is
    refitted too: the reference judges "no motion" in every later capture."""
    params = run.model_params(baseline.robot, baseline.axis)
    return saved.reference is not None and (
        saved.file_hash,
        saved.params,
        saved.library_version,
    ) == (baseline.file_hash, params, model_version())


def _plan_new(run: Run, state: AxisState, retired: Baseline | None) -> FitJob | None:
    """The first usable candidate of a new epoch: the configured or requested baseline, else
    the first capture (of a new axis) or the first one after everything scored (re-baseline)."""
    state.epoch = 1 if retired is None else retired.epoch + 1
    ordered = state.files
    names = {f.capture for f in ordered}
    if retired is None:
        chosen = run.config.baseline
        if chosen is not None and chosen in names:
            ordered = from_capture(ordered, chosen)
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
            ordered = from_capture(ordered, chosen)
        else:
            seen = run.store.last_captured_at(state.robot, state.axis, run.method)
            ordered = [f for f in ordered if seen is None or f.captured_at > seen]
    state.candidates = [f for f in ordered if run.usable(f)]
    return run.fit_job(state.candidates[0], state.candidates[1:]) if state.candidates else None


def plan_baseline(run: Run, state: AxisState) -> FitJob | None:
    """The fit job of an axis: its active baseline, or the first candidate of a new epoch."""
    latest = run.store.latest_baseline(state.robot, state.axis, run.method)
    if latest is not None and not latest.retired:
        return _plan_active(run, state, latest)
    return _plan_new(run, state, latest)


def _accept_baseline(run: Run, state: AxisState, outcome: FitOutcome) -> FitJob | None:
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


def fit_baselines(run: Run, jobs: list[FitJob], by_axis: dict[tuple[str, str], AxisState]) -> None:
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


def _stored_models(run: Run, fitting: set[tuple[str, str]]) -> dict[str, list[_StoredModel]]:
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


def _give_prior(run: Run, stored: Sequence[_StoredModel], pooled: Sequence[MonitoredModel]) -> None:
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


def _with_fleet_priors(run: Run, fitted: list[FitOutcome]) -> list[FitOutcome]:
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


def score_jobs(run: Run, states: Sequence[AxisState]) -> list[ScoreJob]:
    """One job per capture after the baseline that is neither scored under it nor rejected."""
    with run.store.batch():  # the new files' index entries (and late captures) in one commit
        return score_jobs_of(run, states)


def score_jobs_of(run: Run, states: Sequence[AxisState]) -> list[ScoreJob]:
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
            if capture_key(file) <= start:
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
                    modes=run.config.modes,
                )
            )
    return jobs


def _out_of_order(run: Run, file: FleetFile, baseline: Baseline) -> None:
    """A capture dated before the axis's baseline that was never scored: it arrived late."""
    relative = run.relative(file.path)
    reject(
        run.store, run.method, file.robot, file.axis, file.capture, relative,
        run.digest(file.path) or "",
        f"{relative}: dated before the baseline {baseline.capture} of epoch {baseline.epoch} and "
        "never scored (it arrived out of order); re-baseline the axis with --from to score it",
        kind="out of order",
    )  # fmt: skip
