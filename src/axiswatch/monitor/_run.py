"""One run of the monitor: its context, an axis's state in it, and the summary it builds."""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from axiswatch._axis_model import MonitoredModel
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import ProfileError
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._fleet import (
    FleetFile,
)
from axiswatch.monitor._index import (
    FileIndex,
)
from axiswatch.monitor._ledger import reject
from axiswatch.monitor._mode_decision import ModeBook
from axiswatch.monitor._models import ModelRef
from axiswatch.monitor._parallel import WorkerPool
from axiswatch.monitor._persist import load_model, model_version
from axiswatch.monitor._quality import QualityReference
from axiswatch.monitor._scoring import FitJob, FitOutcome
from axiswatch.monitor._unread import UnreadIndicators
from axiswatch.monitor.store import (
    AlarmState,
    Baseline,
    RunCaches,
    SavedModel,
    StoreWriter,
)

__all__ = ["AxisState", "MonitorSummary", "Progress", "Run", "capture_key", "from_capture"]

Progress = Callable[[str, int, int], None]


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
    ``unread``: per axis, the indicators the captures scored in this run could not give, and why
    (said once per axis; no attention needed). ``repaired``: per axis, captures whose lone
    torque spikes were repaired before ``impulsiveness`` was read (no attention needed).

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
    unread: UnreadIndicators = field(default_factory=UnreadIndicators)
    #: Per axis: captures of this run with lone torque spikes repaired, and the spikes.
    repaired: dict[str, tuple[int, int]] = field(default_factory=dict)
    #: ``(robot, axis, capture)`` of the captures in alarm before this run scored any.
    alarmed_before: set[tuple[str, str, str]] = field(default_factory=set)

    def note_repairs(self, axis: str, details: Mapping[str, Any]) -> None:
        """Count a scored capture's repaired spikes (``details["repaired_spikes"]``)."""
        spikes = int(details.get("repaired_spikes", 0))
        if spikes:
            captures, total = self.repaired.get(axis, (0, 0))
            self.repaired[axis] = (captures + 1, total + spikes)

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
class AxisState:
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
class Run:
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
    stored_models: list[AxisState] = field(default_factory=list)  # scored without a refit
    problem_axes: set[tuple[str, str]] = field(default_factory=set)
    rejected: set[tuple[str, str]] = field(default_factory=set)
    alarmed: set[tuple[str, str, str]] = field(default_factory=set)
    done: dict[str, int] = field(default_factory=lambda: {"baselines": 0, "captures": 0})
    #: The axes' mode libraries (``MonitorConfig.modes``), else None.
    modes: ModeBook | None = None

    def __post_init__(self) -> None:
        if self.config.modes and self.modes is None:
            self.modes = ModeBook(
                self.store, self.config.decision_rule(), self.config.calibration_size
            )

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

    def problem(self, state: AxisState, message: str) -> None:
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
            self.model_params(outcome.job.file.robot, outcome.job.file.axis),
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
        return f"{self.params_hash}+{self.profile_hash(robot, axis)}"

    def profile_hash(self, robot: str, axis: str) -> str:
        """A hash of the axis profile that applies to the axis (none, or a malformed one: its
        error)."""
        key = (robot, axis)
        if key not in self.profile_hashes:
            try:
                profile = self.config.profile or AxisProfile.find(self.root, robot, axis)
                text = repr(profile)
            except (ProfileError, OSError) as exc:  # its captures are rejected with this error
                text = str(exc)
            self.profile_hashes[key] = hashlib.sha256(text.encode()).hexdigest()[:16]
        return self.profile_hashes[key]

    def model_params(self, robot: str, axis: str) -> str:
        """What a stored model of the axis was fitted under: the parameters and the axis
        profile. A profile edited since (units, sides, columns) refits the model from the
        baseline's own captures, read as the profile now says: a reading moved by the edit is
        never scored against a model fitted before it."""
        return f"{self.params}\nprofile {self.profile_hash(robot, axis)}"

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


def capture_key(file: FleetFile) -> tuple[datetime, str]:
    return (file.captured_at, file.capture)


def from_capture(files: Sequence[FleetFile], capture: str) -> list[FleetFile]:
    """The files from ``capture`` on (it included)."""
    start = capture_key(next(f for f in files if f.capture == capture))
    return [f for f in files if capture_key(f) >= start]


# --- steps of a run ----------------------------------------------------------------------------
