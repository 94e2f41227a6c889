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
:func:`axiswatch._parallel.parallel_map`. Hence a killed run resumes exactly, and a second
process on the same store skips what the first has written.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, Literal

import numpy as np
from threadpoolctl import threadpool_limits

from axiswatch._calibration import HalfLaplaceFit, fit_half_laplace
from axiswatch._capture import read_capture
from axiswatch._detectors import BaselineDetector, LRADetector, PCADetector
from axiswatch._features import FeatureSpec
from axiswatch._fleet import FleetFile, discover_fleet
from axiswatch._model import HealthModel
from axiswatch._parallel import parallel_map
from axiswatch._store import Store
from axiswatch.exceptions import AxiswatchError, CalibrationError, StoreError

__all__ = [
    "MONITOR_FEATURES",
    "MonitorConfig",
    "MonitorSummary",
    "alarm_step",
    "file_hash",
    "fleet_rejections",
    "fleet_results",
    "fleet_summary",
    "monitor_fleet",
    "rebaseline",
]

#: Features of the monitor: the library's defaults (position, speed, torque and their products,
#: Hann window of 128, circular padding, magnitude scaling) with a hop of 8 samples. At 2 kHz a
#: slice every 4 ms still overlaps its neighbour by 94 %, and the 8x fewer rows make scoring a
#: fleet 5-10x cheaper.
MONITOR_FEATURES = FeatureSpec(hop=8)

Method = Literal["lra", "pca"]
Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class MonitorConfig:
    """Parameters of the monitor; all but ``baseline`` are stored with every baseline.

    Parameters
    ----------
    method : {"lra", "pca"}, default="lra"
        The paper's Low Rank Alignment distance or the PCA baseline (library defaults of
        :class:`LRADetector` and :class:`PCADetector`).
    percentile : float in (0, 100), default=99.0
    calibration_size : int >= 2, default=5
        ``K``: captures after the baseline that calibrate the threshold.
    alarm_k, alarm_n : int, default=1, 1
        Alarm when at least ``k`` of the last ``n`` captures are over the threshold.
    clear_m : int, default=1
        An alarm clears after ``m`` captures in a row under the threshold.
    baseline : str or None, default=None
        File name of the capture to use as every new axis's baseline (axes without such a file
        start at their first capture).
    features : FeatureSpec, default=MONITOR_FEATURES
    align_phase : bool, default=True
        Align every capture to the baseline's phase of the task cycle (``HealthModel``).

    Examples
    --------
    >>> MonitorConfig(alarm_k=2, alarm_n=3).params()["alarm"]
    {'k': 2, 'n': 3, 'clear_m': 1}
    """

    method: Method = "lra"
    percentile: float = 99.0
    calibration_size: int = 5
    alarm_k: int = 1
    alarm_n: int = 1
    clear_m: int = 1
    baseline: str | None = None
    features: FeatureSpec = MONITOR_FEATURES
    align_phase: bool = True

    def __post_init__(self) -> None:
        if self.method not in ("lra", "pca"):
            raise ValueError(
                f"The 'method' parameter must be 'lra' or 'pca'. Got {self.method!r} instead."
            )
        if not (0.0 < self.percentile < 100.0):
            raise ValueError(
                "The 'percentile' parameter must be a float in (0, 100). "
                f"Got {self.percentile!r} instead."
            )
        if not (isinstance(self.calibration_size, int) and self.calibration_size >= 2):
            raise ValueError(
                "The 'calibration_size' parameter must be an int >= 2 (the half-Laplace fit "
                f"needs two distances). Got {self.calibration_size!r} instead."
            )
        if not (1 <= self.alarm_k <= self.alarm_n):
            raise ValueError(
                "The alarm rule needs 1 <= k <= n ('k of the last n captures over'). "
                f"Got k={self.alarm_k!r}, n={self.alarm_n!r} instead."
            )
        if self.clear_m < 1:
            raise ValueError(f"The 'clear_m' parameter must be >= 1. Got {self.clear_m!r} instead.")

    def detector(self) -> BaselineDetector:
        """A fresh detector of the configured method."""
        return LRADetector() if self.method == "lra" else PCADetector()

    def params(self) -> dict[str, Any]:
        """JSON-ready parameters: features, detector, calibration and alarm rule."""
        return {
            "method": self.method,
            "detector": self.detector().get_params(),
            "features": dataclasses.asdict(self.features),
            "align_phase": self.align_phase,
            "percentile": self.percentile,
            "calibration_size": self.calibration_size,
            "alarm": {"k": self.alarm_k, "n": self.alarm_n, "clear_m": self.clear_m},
        }


def _params_json(config: MonitorConfig) -> str:
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


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _library_version() -> str:
    try:
        return version("axiswatch")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def file_hash(path: Path) -> str:
    """SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _one_line(exc: BaseException, path: Path, relative: str) -> str:
    text = (str(exc).splitlines() or [type(exc).__name__])[0].replace(str(path), relative)
    return text if text.startswith(relative) else f"{relative}: {text}"


# --- jobs: self-contained, picklable, never raise for a bad capture -------------------------


@dataclass(frozen=True)
class FitJob:
    """Fit a baseline from one capture file."""

    file: FleetFile
    relative: str
    config: MonitorConfig


@dataclass(frozen=True)
class FitOutcome:
    """A fitted model and what identifies it, or the error that prevented it."""

    job: FitJob
    model: HealthModel | None
    rates_hz: dict[str, float]
    file_hash: str
    features_hash: str
    error: str | None


def fit_baseline(job: FitJob) -> FitOutcome:
    """Read the baseline capture and fit the health model on it (a ``parallel_map`` job)."""
    # Parallelism is across captures; a multi-threaded BLAS inside each job only fights for the
    # same cores (a 750 x 390 SVD took 30 s instead of 0.3 s on a loaded 2-core machine).
    with threadpool_limits(1):
        return _fit_baseline(job)


def _fit_baseline(job: FitJob) -> FitOutcome:
    path = job.file.path
    try:
        digest = file_hash(path)
        capture = read_capture(path, job.config.features.signals)
        model = HealthModel(
            job.config.features,
            job.config.detector(),
            percentile=job.config.percentile,
            align_phase=job.config.align_phase,
        ).fit(capture)
    except (AxiswatchError, ValueError, OSError) as exc:
        return FitOutcome(job, None, {}, "", "", _one_line(exc, path, job.relative))
    features_hash = hashlib.sha256(model.baseline_features_.X.tobytes()).hexdigest()
    return FitOutcome(job, model, dict(capture.rates_hz), digest, features_hash, None)


@dataclass(frozen=True)
class ScoreJob:
    """Score one capture file against a fitted baseline."""

    file: FleetFile
    relative: str
    baseline_id: int
    model: HealthModel
    rates_hz: dict[str, float]


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


def score_capture(job: ScoreJob) -> ScoreOutcome:
    """Read, validate and score one capture (a ``parallel_map`` job), on one BLAS thread."""
    with threadpool_limits(1):
        return _score_capture(job)


def _score_capture(job: ScoreJob) -> ScoreOutcome:
    path = job.file.path
    digest, size, mtime = "", 0, 0
    try:
        stat = path.stat()
        size, mtime = stat.st_size, stat.st_mtime_ns
        digest = file_hash(path)
        model = job.model
        capture = read_capture(path, model.features.signals, expected_rates_hz=job.rates_hz)
        features, lag = model.featurize(capture)
        details: dict[str, Any] = {
            "phase_lag_samples": int(lag),
            "phase_lag_s": float(lag / features.rate_hz),
            "n_rows": int(features.X.shape[0]),
        }
        detector = model.detector_
        if isinstance(detector, LRADetector):
            result = detector.align(features.X)
            distance = float(result.delta)
            details["lra_eigengap"] = float(result.eigengap)
            details["lra_tie_broken"] = bool(result.tie_broken)
        else:
            distance = float(detector.distance(features.X))
    except (AxiswatchError, ValueError, OSError) as exc:
        error = _one_line(exc, path, job.relative)
        return ScoreOutcome(job, digest, size, mtime, math.nan, {}, error)
    return ScoreOutcome(job, digest, size, mtime, distance, details, None)


# --- summary -----------------------------------------------------------------------------------


@dataclass
class MonitorSummary:
    """What one ``monitor`` run did and what the fleet's state is afterwards.

    Exit status of ``axiswatch monitor`` (:attr:`exit_code`): 0 when nothing needs attention;
    otherwise the sum of 4 (at least one axis is in alarm) and 8 (a capture is rejected, a
    scored file changed, or an axis cannot be scored); so 4, 8 or 12.
    """

    method: str
    n_files: int = 0
    scored: int = 0
    new_baselines: int = 0
    rejected: list[str] = field(default_factory=list)
    changed: list[str] = field(default_factory=list)
    axis_problems: list[str] = field(default_factory=list)
    alarms: list[tuple[str, str]] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """0, or 4 (alarm) + 8 (rejected, changed or axis problem)."""
        attention = bool(self.rejected or self.changed or self.axis_problems)
        return 4 * bool(self.alarms) + 8 * attention


# --- store writes (each one transaction) -------------------------------------------------------


def _reject(
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
            (robot, axis, method, capture, relative, digest, error, _now()),
        )


def _insert_baseline(
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
                outcome.features_hash, _params_json(config), _library_version(), _now(),
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
                json.dumps({"rates_hz": outcome.rates_hz}), _now(),
            ),
        )  # fmt: skip
    return baseline_id


def _percentile_text(percentile: float) -> str:
    return f"{percentile:g}th pct"


def _commit_score(store: Store, outcome: ScoreOutcome, config: MonitorConfig) -> bool:
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
                    outcome.file_hash, outcome.error, _now(),
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
                f"({_percentile_text(config.percentile)} of {fit.n_distances} healthy captures)"
            )
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
                int(alarm), reason, json.dumps(details, sort_keys=True), _now(),
            ),
        )  # fmt: skip
    return True


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
                    _now(),
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
        Passed to :func:`axiswatch._parallel.parallel_map`.
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
        _reject(
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
    params = _params_json(config)

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
    done = 0
    while fit_jobs:
        retry: list[FitJob] = []
        for _, outcome in parallel_map(fit_baseline, fit_jobs, workers=workers, dask=dask):
            file = outcome.job.file
            state = by_axis[(file.robot, file.axis)]
            done += 1
            if progress is not None:
                progress("baselines", done, len(axes))
            if state.baseline is not None:
                if outcome.model is None:
                    summary.axis_problems.append(
                        f"{outcome.error}; the stored baseline cannot be refitted"
                    )
                else:
                    state.model, state.rates_hz = outcome.model, outcome.rates_hz
                continue
            if outcome.model is None:
                _reject(
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
                    retry.append(FitJob(state.candidates[0], relative(state.candidates[0]), config))
                continue
            baseline_id = _insert_baseline(store, outcome, state.epoch, config)
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

    jobs: list[ScoreJob] = []
    for state in axes:
        if state.model is None or state.baseline is None:
            continue
        baseline_id = int(state.baseline["id"])
        done_captures = {
            r["capture"]
            for r in store.rows("SELECT capture FROM scores WHERE baseline_id=?", (baseline_id,))
        }
        start = (datetime.fromisoformat(state.baseline["captured_at"]), state.baseline["capture"])
        for file in state.files:
            if _key(file) <= start or file.capture in done_captures:
                continue
            if (relative(file), digest(file.path)) in rejected:
                continue
            jobs.append(ScoreJob(file, relative(file), baseline_id, state.model, state.rates_hz))

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
            if _commit_score(store, ready, config) and ready.error is None:
                summary.scored += 1
        if progress is not None:
            progress("captures", count, len(jobs))

    summary.rejected = _standing_rejections(store, root, method)
    for row in store.rows(
        "SELECT b.robot, b.axis, (SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id "
        "AND s.role='monitor' ORDER BY s.id DESC LIMIT 1) AS alarm FROM baselines b "
        "WHERE b.method=? AND b.retired_at IS NULL ORDER BY b.robot, b.axis",
        (method,),
    ):
        if row["alarm"]:
            summary.alarms.append((row["robot"], row["axis"]))
    return summary


def _by_capture(files: Sequence[FleetFile], capture: str) -> FleetFile:
    return next(f for f in files if f.capture == capture)


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
        now = _now()
        for row in rows:
            db.execute("UPDATE baselines SET retired_at=? WHERE id=?", (now, row["id"]))
            db.execute(
                "INSERT INTO rebaselines (robot, axis, method, retired_epoch, from_capture, "
                "requested_at) VALUES (?, ?, ?, ?, ?, ?)",
                (robot, axis, row["method"], row["epoch"], from_capture, now),
            )
            retired.append(str(row["method"]))
    return retired


def fleet_results(store: Store, *, robot: str | None = None, axis: str | None = None) -> Any:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Further columns: ``captured_at``, ``epoch``, ``role``, ``over``, ``reason``, ``details``.
    Baseline rows are included (role ``baseline``, no distance).
    """
    frame = store.frame(
        "SELECT s.robot, s.axis, s.capture, s.method, s.distance, s.threshold, s.alarm, "
        "s.captured_at, b.epoch, s.role, s.over, s.reason, s.details FROM scores s "
        "JOIN baselines b ON b.id = s.baseline_id "
        "WHERE (? IS NULL OR s.robot=?) AND (? IS NULL OR s.axis=?) "
        "ORDER BY s.robot, s.axis, s.method, s.captured_at, s.capture, b.epoch",
        (robot, robot, axis, axis),
    )
    frame["alarm"] = frame["alarm"].astype(bool)
    frame["over"] = frame["over"].astype(bool)
    frame["distance"] = frame["distance"].astype(np.float64)
    frame["threshold"] = frame["threshold"].astype(np.float64)
    return frame


def fleet_rejections(store: Store) -> Any:
    """Rejected capture files: robot, axis, capture, method, path, error, rejected_at."""
    return store.frame(
        "SELECT robot, axis, capture, method, path, error, rejected_at FROM rejections "
        "ORDER BY robot, axis, path, method, id"
    )


def fleet_summary(store: Store) -> Any:
    """One row per axis and method of the active baselines: the fleet's state at a glance.

    Columns: ``robot``, ``axis``, ``method``, ``epoch``, ``baseline`` (capture), ``threshold``,
    ``scored`` (calibration and monitored captures), ``over`` (captures over the threshold),
    ``alarms`` (alarms raised), ``last_capture``, ``last_distance``, ``state``
    (``calibrating``, ``ok`` or ``ALARM``), ``rejected`` (files of the axis rejected).
    """
    frame = store.frame(
        "SELECT b.robot, b.axis, b.method, b.epoch, b.capture AS baseline, b.threshold, "
        "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.role!='baseline') "
        "AS scored, "
        "(SELECT coalesce(sum(s.over), 0) FROM scores s WHERE s.baseline_id=b.id) AS over, "
        "(SELECT count(*) FROM scores s WHERE s.baseline_id=b.id AND s.alarm=1 AND NOT coalesce("
        "(SELECT p.alarm FROM scores p WHERE p.baseline_id=b.id AND p.role='monitor' "
        "AND p.id<s.id ORDER BY p.id DESC LIMIT 1), 0)) AS alarms, "
        "(SELECT s.capture FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC LIMIT 1) "
        "AS last_capture, "
        "(SELECT s.distance FROM scores s WHERE s.baseline_id=b.id ORDER BY s.id DESC LIMIT 1) "
        "AS last_distance, "
        "(SELECT s.alarm FROM scores s WHERE s.baseline_id=b.id AND s.role='monitor' "
        "ORDER BY s.id DESC LIMIT 1) AS last_alarm, "
        "(SELECT count(*) FROM rejections r WHERE r.robot=b.robot AND r.axis=b.axis "
        "AND r.method=b.method) AS rejected "
        "FROM baselines b WHERE b.retired_at IS NULL ORDER BY b.robot, b.axis, b.method"
    )
    state = np.where(
        frame["threshold"].isna(),
        "calibrating",
        np.where(frame["last_alarm"].fillna(0).astype(bool), "ALARM", "ok"),
    )
    frame["state"] = state
    return frame.drop(columns="last_alarm")
