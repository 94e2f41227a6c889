"""One capture's work: the self-contained jobs that fit baselines and score captures.

Pipeline stage below the monitor's driver. A job carries everything it needs (file, fitted model,
expected rates), runs in any process (``axiswatch.monitor._parallel.parallel_map``) on one BLAS thread,
and returns an outcome or an error record: it never raises for a bad capture.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

from axiswatch._axis_model import MonitoredModel
from axiswatch._capture import DEFAULT_SIGNALS, Capture, read_capture, with_speed
from axiswatch._capture_length import MAX_CAPTURE_ROWS, check_capture_length
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import CalibrationError, CaptureError, ProfileError
from axiswatch.monitor._fleet import FleetFile
from axiswatch.monitor._models import ModelRef, keep_model, resolve_model
from axiswatch.monitor._quality import QualityReference, data_quality_problem

if TYPE_CHECKING:
    from axiswatch.indicators._modes import CaptureDescription

__all__ = [
    "FitJob",
    "FitOutcome",
    "ScoreJob",
    "ScoreOutcome",
    "file_hash",
    "fit_baseline",
    "score_capture",
]


def profile_for(file: FleetFile, given: AxisProfile | None) -> AxisProfile | None:
    """The profile a capture file is read with: the given one, else the fleet folder's."""
    if given is not None:
        return given
    return AxisProfile.find(file.path.parents[2], file.robot, file.axis)


def file_hash(path: Path) -> str:
    """SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _one_line(exc: BaseException, path: Path, relative: str) -> str:
    if isinstance(exc, MemoryError):
        return (
            f"{relative}: not enough memory to read and score it; a smaller --max-capture-rows "
            "refuses such a file before it is loaded (axiswatch rejections --retry to try again)"
        )
    text = (str(exc).splitlines() or [type(exc).__name__])[0].replace(str(path), relative)
    text = fleet_relative(text, path, relative)
    return text if text.startswith(relative) else f"{relative}: {text}"


def fleet_relative(text: str, path: Path, relative: str) -> str:
    """``text`` with the paths of files under the fleet folder named relative to it, as the
    capture file is: the fleet folder is ``path`` without ``relative`` (a malformed axis
    profile's message named it by its full path).

    Parameters
    ----------
    text : str
        A message.
    path : Path
        A capture file under the fleet folder.
    relative : str
        ``path`` relative to the fleet folder (POSIX).

    Returns
    -------
    str
        ``text`` without the fleet folder's prefix where a path starts with it; other paths
        (a profile given with ``--profile`` elsewhere) as they are.

    Examples
    --------
    >>> from pathlib import Path
    >>> fleet_relative(
    ...     "axis profile /data/fleet/r1/robot.toml: gear_ratio must be > 0.",
    ...     Path("/data/fleet/r1/a1/c.csv"), "r1/a1/c.csv",
    ... )
    'axis profile r1/robot.toml: gear_ratio must be > 0.'
    >>> fleet_relative("/data/fleet2/r1/robot.toml", Path("/data/fleet/r1/a1/c.csv"), "r1/a1/c.csv")
    '/data/fleet2/r1/robot.toml'
    """
    root = path.parents[len(PurePosixPath(relative).parts) - 1]
    if root == Path():
        return text
    prefix = re.escape(f"{root}{os.sep}")
    # Only where a path starts: not inside a longer one (/data/myfleet/...).
    return re.sub(rf"(?<![\w.~/\\-]){prefix}", "", text)


def _failure_kind(exc: BaseException) -> tuple[str, bool]:
    """Kind of a job's failure and whether it is transient: an operating-system error reading
    the file (permission, I/O error on a share) may pass; a malformed capture does not. A
    malformed axis profile is transient too: the capture is read again once the profile is
    fixed, though the capture file itself does not change."""
    if isinstance(exc, OSError) and not isinstance(exc, CaptureError):
        return "unreadable", True
    return "invalid", isinstance(exc, ProfileError)


def _read(path: Path, relative: str, max_rows: int, **kwargs: Any) -> Capture:
    """:func:`~axiswatch.read_capture` of a file no longer than ``max_rows`` rows (checked from
    its header before it is loaded)."""
    check_capture_length(path, max_rows, relative)
    return read_capture(path, **kwargs)


def _read_signals(
    path: Path, relative: str, max_rows: int, signals: Sequence[str] | None, **kwargs: Any
) -> Capture:
    """:func:`_read` of a method's ``signals``, a missing speed derived from the position
    (:func:`~axiswatch.with_speed`): every method reads a capture of position and current
    alike. ``None``: every signal, as read (the indicators derive the speed themselves)."""
    if signals is None or "speed" not in signals or not set(signals) <= set(DEFAULT_SIGNALS):
        return _read(path, relative, max_rows, signals=signals, **kwargs)
    return with_speed(_read(path, relative, max_rows, **kwargs)).select(signals)


def _bad_data(relative: str, problem: str) -> str:
    return f"{relative}: bad data ({problem}); a data-quality verdict, not a maintenance one"


# --- jobs: self-contained, picklable, never raise for a bad capture -------------------------

#: What makes one capture unusable: a malformed capture (:class:`CaptureError`, also raised for a
#: capture too short or without a usable move), a file that cannot be read (``OSError``: gone
#: or unreadable since it was found), or one too large for the memory left (``MemoryError``,
#: under a raised ``max_capture_rows``: the other captures are still scored). Any other error
#: (a configuration error, a bug) is raised: recording it against every file would report
#: hundreds of bad captures for one cause.
_DATA_ERRORS = (CaptureError, OSError, MemoryError)


@dataclass(frozen=True)
class FitJob:
    """Fit a baseline from one capture file (``model``: unfitted, :meth:`MonitorConfig.model`).

    A model that ``fits_calibration`` is fitted on the baseline and the first
    ``calibration_size`` of the ``calibration`` files it can read (``relatives``: their paths
    below the fleet folder).
    """

    file: FleetFile
    relative: str
    model: MonitoredModel
    profile: AxisProfile | None = None
    calibration: tuple[FleetFile, ...] = ()
    relatives: tuple[str, ...] = ()
    calibration_size: int = 0
    #: Of a stored baseline (after an upgrade, new options of the library): the model's checks
    #: of new baselines are not applied, a stored one is kept and noted (``baseline_note``).
    refit: bool = False
    #: Files of more rows are rejected before they are loaded.
    max_rows: int = MAX_CAPTURE_ROWS


@dataclass(frozen=True)
class FitOutcome:
    """A fitted model (its content hash and blob; the worker keeps the model itself, or sends it
    back as ``inline`` when it cannot be stored) and what identifies it, or the error that
    prevented it."""

    job: FitJob
    model_key: str
    blob: bytes | None
    inline: MonitoredModel | None
    rates_hz: dict[str, float]
    file_hash: str
    features_hash: str
    error: str | None
    kind: str = "invalid"
    transient: bool = False
    reference: QualityReference | None = None
    waiting: str | None = None
    summary: dict[str, Any] | None = None
    checks: dict[str, str] = field(default_factory=dict)


def fit_baseline(job: FitJob) -> FitOutcome:
    """Read the baseline capture and the captures after it the model needs, and fit the model
    (a ``parallel_map`` job); an outcome ``waiting`` while fewer than ``calibration_size`` of
    them can be read."""
    template = job.model
    path = job.file.path
    try:
        profile = profile_for(job.file, job.profile)
        digest = file_hash(path)
        capture = _read_signals(path, job.relative, job.max_rows, template.signals, profile=profile)
        if not job.refit:
            template.check_baseline(capture)
        problem = data_quality_problem(capture)
        if problem is not None:
            error = _bad_data(job.relative, problem)
            return FitOutcome(job, "", None, None, {}, digest, "", error, "bad data")
        baseline, why = template.read(capture, profile)
    except _DATA_ERRORS as exc:
        kind, transient = _failure_kind(exc)
        error = _one_line(exc, path, job.relative)
        return FitOutcome(job, "", None, None, {}, "", "", error, kind, transient)
    if why is not None:
        error = f"{job.relative}: not a baseline, {why}"
        return FitOutcome(job, "", None, None, {}, digest, "", error, "not scored")
    reference = QualityReference.of(capture)
    size = job.calibration_size if template.fits_calibration else 0
    read, names = [baseline], [(digest, job.relative)]
    unusable: list[str] = []  # why, for the axis's line while it waits
    for file, relative in zip(job.calibration, job.relatives, strict=True):
        if len(read) > size:
            break
        # Skipped as the score job will skip it: bad data, or nothing the model can read.
        try:
            calibration = _read_signals(
                file.path,
                relative,
                job.max_rows,
                template.signals,
                expected_rates_hz=capture.rates_hz,
                profile=profile,
            )
            problem = data_quality_problem(calibration, reference)
            if problem is not None:
                unusable.append(_bad_data(relative, problem))
                continue
            taken, why = template.read(calibration, profile)
            if why is None:
                read.append(taken)
                names.append((file_hash(file.path), relative))
            else:
                unusable.append(f"{relative}: {why}")
        except _DATA_ERRORS as exc:
            unusable.append(_one_line(exc, file.path, relative))
            continue
    if len(read) <= size:
        waiting = (
            f"{job.file.robot}/{job.file.axis}: calibrating, {len(read) - 1} of "
            f"{size} captures after the baseline {job.relative} give a reading; "
            "the indicators baseline is set once all have arrived"
        )
        if unusable:
            # Otherwise an axis whose later captures all fail (another rate than the baseline's)
            # waits for ever without a word of why.
            first = unusable[0].removesuffix(".")
            waiting += f" ({len(unusable)} could not be used; the first: {first})"
        rates = dict(capture.rates_hz)  # of the baseline: a stored one's line names them
        return FitOutcome(job, "", None, None, rates, digest, "", None, waiting=waiting)
    try:
        fitted = template.fit_read(read, names)
    except CalibrationError as exc:
        error = f"{job.relative}: not a baseline: {exc}"
        return FitOutcome(job, "", None, None, {}, digest, "", error, "not scored")
    except _DATA_ERRORS as exc:
        kind, transient = _failure_kind(exc)
        error = _one_line(exc, path, job.relative)
        return FitOutcome(job, "", None, None, {}, "", "", error, kind, transient)
    key, blob = keep_model(fitted)
    return FitOutcome(
        job, key, blob, fitted if blob is None else None, dict(capture.rates_hz), digest,
        fitted.fingerprint(), None, reference=reference, summary=fitted.summary(),
        checks=fitted.checks(),
    )  # fmt: skip


@dataclass(frozen=True)
class ScoreJob:
    """Score one capture file against a fitted baseline."""

    file: FleetFile
    relative: str
    baseline_id: int
    model: ModelRef
    rates_hz: dict[str, float]
    profile: AxisProfile | None = None
    reference: QualityReference | None = None
    #: Files of more rows are rejected before they are loaded.
    max_rows: int = MAX_CAPTURE_ROWS
    #: Also describe the capture for its axis's mode library (``MonitorConfig.modes``).
    modes: bool = False


@dataclass(frozen=True)
class ScoreOutcome:
    """Distance and details of one capture, or the error that prevented scoring it."""

    job: ScoreJob
    file_hash: str
    file_size: int
    file_mtime_ns: int
    distance: float
    details: dict[str, Any]
    error: str | None
    kind: str = "invalid"
    transient: bool = False
    #: What the axis's mode library reads of the capture (``ScoreJob.modes``).
    description: CaptureDescription | None = None


def score_capture(job: ScoreJob) -> ScoreOutcome:
    """Read, validate and score one capture (a ``parallel_map`` job)."""
    path = job.file.path
    digest, size, mtime = "", 0, 0
    try:
        stat = path.stat()
        size, mtime = stat.st_size, stat.st_mtime_ns
        digest = file_hash(path)
        model = resolve_model(job.model)
        profile = profile_for(job.file, job.profile)
        capture = _read_signals(
            path,
            job.relative,
            job.max_rows,
            model.signals,
            expected_rates_hz=job.rates_hz,
            profile=profile,
        )
        problem = data_quality_problem(capture, job.reference)
        if problem is not None:
            error = _bad_data(job.relative, problem)
            return ScoreOutcome(job, digest, size, mtime, math.nan, {}, error, "bad data")
        if job.modes:
            return _described(job, model, capture, profile, (digest, size, mtime))
        assessment = model.score(capture, digest, profile)
    except _DATA_ERRORS as exc:
        kind, transient = _failure_kind(exc)
        error = _one_line(exc, path, job.relative)
        return ScoreOutcome(job, digest, size, mtime, math.nan, {}, error, kind, transient)
    if not assessment.scored:
        # Not an alarm and not a healthy score: nothing the model reads could be read.
        error = f"{job.relative}: {assessment.reason()}"
        return ScoreOutcome(job, digest, size, mtime, math.nan, {}, error, "not scored")
    details = dict(assessment.details)
    note = model.baseline_note(capture.rates_hz)  # the baseline's rate, to 0.1 %
    if note is not None and not details.get("baseline_check"):
        details["baseline_check"] = note
    return ScoreOutcome(job, digest, size, mtime, assessment.distance, details, None)


def _described(
    job: ScoreJob,
    model: MonitoredModel,
    capture: Capture,
    profile: AxisProfile | None,
    file: tuple[str, int, int],
) -> ScoreOutcome:
    """The capture's description for its mode library, with the baseline's details where its
    readings compare with the baseline's (a capture of another mode has none)."""
    from axiswatch.indicators._axis import IndicatorBaseline
    from axiswatch.indicators._modes import describe_capture

    if not isinstance(model, IndicatorBaseline):
        raise TypeError(f"modes need the indicators method; got {type(model).__name__}")
    read, _ = model.read(capture, profile)
    declaration = None if profile is None else profile.mode
    description = describe_capture(capture, declaration, readings=read)
    if not description.moving:
        error = f"{job.relative}: the axis hardly moved; nothing to compare with a mode"
        return ScoreOutcome(job, *file, math.nan, {}, error, "not scored")
    assessment = model.score_read(read, file[0])
    details = dict(assessment.details) if math.isfinite(assessment.distance) else {}
    return ScoreOutcome(job, *file, assessment.distance, details, None, description=description)
