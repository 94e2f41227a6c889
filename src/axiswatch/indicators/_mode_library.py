"""ModeLibrary: an axis's operating modes, each with its own normal, learned while guarded.

A capture of a known mode is scored in that mode's within-mode spreads. A capture of a new mode
is scored by a guard: readings that grow with a fault whatever the mode. The threshold pools
the within-mode distances of all the axis's modes (half-Laplace, :mod:`axiswatch._calibration`).
A drift test keeps a slow fault from being learned into a mode's normal.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.stats import norm

from axiswatch._calibration import HalfLaplaceFit
from axiswatch.indicators._drift import ReadingCusum, cusum_limit
from axiswatch.indicators._mode_normals import (
    ModeBlock,
    NormalStats,
    centre_error,
    nan_median,
    normal_shift,
    other_rows,
)
from axiswatch.indicators._modes import (
    MOTION_READINGS,
    SPECTRUM_BANDS,
    CaptureDescription,
    mode_differences,
    mode_distance,
    mode_tolerance,
)
from axiswatch.indicators._readings import INDICATORS, Readings

__all__ = ["ModeAssessment", "ModeLibrary", "tail_threshold"]

#: Readings that only grow with a fault in any mode: the guard's (kinematic lines are added).
GUARD_READINGS: tuple[str, ...] = (
    "coulomb_friction",
    "viscous_friction",
    "impulsiveness",
    "gap_ringing",
)
#: Readings compared in decades; and those where a change either way is abnormal.
_LOG = {i.name for i in INDICATORS if i.log}
_BOTH = {i.name for i in INDICATORS if i.sided == "both"}
#: The median's standard error over the mean's, for Gaussian readings (sqrt(pi / 2)).
_MEDIAN_EFFICIENCY = math.sqrt(math.pi / 2.0)
#: Pooled within-mode distances from which their own tail sets the threshold: fewer left a
#: tail of a handful of excesses, and thresholds of 8-14 spreads on development robots.
MIN_TAIL_DISTANCES = 30

State = Literal["known", "learning", "drift", "still"]


def _log_reading(name: str) -> bool:
    return name in _LOG or name.startswith(("tooth_lines:", "bearing_lines:"))


def _row(description: CaptureDescription) -> dict[str, float]:
    out = {}
    for name, value in description.readings.values.items():
        if _log_reading(name):
            out[name] = math.log10(value) if math.isfinite(value) and value > 0 else math.nan
        else:
            out[name] = float(value)
    return out


def _guarded(name: str) -> bool:
    return name in GUARD_READINGS or name.startswith(("tooth_lines:", "bearing_lines:"))


def _indicator_distance(
    row: Mapping[str, float],
    centre: Mapping[str, float],
    spreads: Mapping[str, float],
    dof: int,
) -> tuple[float, str]:
    """The largest shift of a reading from the centre, in spreads, on the normal scale.

    A spread estimated from ``dof + 1`` captures is itself uncertain: the shift is a Student
    t with ``dof`` degrees of freedom, and is taken to the normal shift of equal tail
    probability (:func:`~._mode_normals.normal_shift`), so that a young mode's distances
    compare with a mature mode's.
    """
    best, where = math.nan, ""
    for name, spread in spreads.items():
        x, c = row.get(name, math.nan), centre.get(name, math.nan)
        if not (math.isfinite(x) and math.isfinite(c) and spread > 0):
            continue
        z = (x - c) / spread
        z = abs(z) if name in _BOTH else max(z, 0.0)
        if not z <= best:
            best, where = z, name
    return float(normal_shift(best, dof)), where


def _spectrum_distance(
    x: NDArray[np.float64], centre: NDArray[np.float64], spread: NDArray[np.float64], dof: int
) -> float:
    # The largest rise over the bands: a line or an impact band grows; the mean over the
    # bands diluted it (development robots: tooth AUROC 0.64 -> 0.72, bearing 0.67 -> 0.82).
    # On the normal scale, as the readings' shifts (_indicator_distance).
    return float(normal_shift(max(float(np.max((x - centre) / spread)), 0.0), dof))


@dataclass(frozen=True)
class ModeAssessment:
    """The verdict on one capture.

    Attributes
    ----------
    source, mode : str
    state : {"known", "learning", "drift", "still"}
        Scored in its mode's normal; scored by the guard while its mode is learned (``n_seen``
        of ``n_fit``); its mode drifted from its first fit; the axis did not move.
    score : float
        In threshold units: above 1 is an alarm (NaN when still).
    alarm : bool
    where : str
        The reading that gave the score (``spectrum`` for the torque spectrum).
    n_seen, n_fit : int
    false_alarm_rate : float
        The rate of alarms on healthy captures the threshold implies.
    """

    source: str
    mode: str
    state: State
    score: float
    alarm: bool
    where: str = ""
    n_seen: int = 0
    n_fit: int = 0
    false_alarm_rate: float = math.nan


def _columns(members: Sequence[CaptureDescription]) -> dict[str, object]:
    """A mode's captures as columns: what the library reads of them, and nothing else."""
    names = sorted({n for d in members for n in d.readings.values})
    return {
        "sources": [d.source for d in members],
        "declared": [d.declared for d in members],
        "signatures": np.array([d.signature for d in members], np.float64),
        "scales": np.array([d.torque_scale for d in members], np.float64),
        "spectra": np.array([d.spectrum for d in members], np.float64),
        "names": names,
        "readings": np.array(
            [[d.readings.values.get(n, math.nan) for n in names] for d in members], np.float64
        ),
        "present": np.array([[n in d.readings.values for n in names] for d in members], bool),
    }


def _descriptions(columns: Mapping[str, Any]) -> list[CaptureDescription]:
    names = columns["names"]
    return [
        CaptureDescription(
            source,
            signature,
            float(scale),
            Readings({n: float(v) for n, v, p in zip(names, row, kept, strict=True) if p}),
            spectrum,
            declared,
        )
        for source, declared, signature, scale, spectrum, row, kept in zip(
            columns["sources"],
            columns["declared"],
            columns["signatures"],
            columns["scales"],
            columns["spectra"],
            columns["readings"],
            columns["present"],
            strict=True,
        )
    ]


@dataclass
class _Mode:
    name: str
    members: list[CaptureDescription] = field(default_factory=list)
    reference: dict[str, float] | None = None
    drifted: bool = False
    joined: int = 0
    #: The CUSUM drift test's state per guard reading; None until that test reads it.
    drift: dict[str, ReadingCusum] | None = None

    @property
    def seen(self) -> int:
        """Captures the mode learned (a library stored before they were counted: kept ones)."""
        return max(self.joined, len(self.members))

    def __getstate__(self) -> dict[str, object]:
        # Stored as columns: a library is saved with every score it learns from, and its
        # captures as objects pickled to 2.7x the bytes (the readings' reasons it never reads).
        state = dict(self.__dict__)
        state["members"] = _columns(self.members)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        members = state.get("members", [])
        if isinstance(members, dict):  # columns (a library stored earlier kept a list)
            state = {**state, "members": _descriptions(members)}
        self.__dict__.update({"drift": None, **state})

    def join(self, description: CaptureDescription, window: int) -> None:
        """Add a capture (to the CUSUM drift test too, once it reads the mode); keep the first
        ``window`` (the first fit) and the latest ``window`` (the normal), so a stored library
        stays the same size."""
        self.joined = self.seen + 1
        self.members.append(description)
        if self.drift is not None:
            self._track(description, window)
        if len(self.members) > 2 * window:
            del self.members[window:-window]

    def track(self, window: int) -> dict[str, ReadingCusum]:
        """The CUSUM drift test started again from the captures kept."""
        self.drift = {}
        for description in self.members:
            self._track(description, window)
        return self.drift

    def _track(self, description: CaptureDescription, window: int) -> None:
        assert self.drift is not None
        for name, value in _row(description).items():
            if _guarded(name) and math.isfinite(value):
                self.drift.setdefault(name, ReadingCusum(window)).add(value)


def tail_threshold(healthy_distances: Sequence[float], percentile: float) -> float:
    """The ``percentile`` of the next healthy distance: exponential above the median.

    A distance is the largest of several shifts, so its tail is lighter than a half-Laplace
    from 0 puts it: on the development robots that rule set thresholds of 8-14 spreads. Here
    the median is the location and the excesses above it are exponential (:mod:`scipy.stats`
    ``expon``), their scale estimated from ``n`` of them; the threshold is the prediction
    quantile (:meth:`~axiswatch._calibration.HalfLaplaceFit.prediction_threshold`) at the
    tail's share ``2 (1 - q)``. Infinite with fewer than 4 distances above the median.

    Examples
    --------
    >>> round(tail_threshold([1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 3.0, 4.0, 5.0, 6.0], 95.0), 3)
    9.783
    """
    values = np.sort(np.asarray([d for d in healthy_distances if math.isfinite(d)], np.float64))
    if values.size < 2:
        return math.inf
    median = float(np.median(values))
    excess = values[values > median] - median
    if excess.size < 4 or not excess.mean() > 0:
        return math.inf
    # The exponential's maximum-likelihood scale is the mean excess (as fit_half_laplace's,
    # without its goodness-of-fit test, which the threshold does not use).
    fit = HalfLaplaceFit(float(excess.mean()), int(excess.size), math.nan, math.nan)
    return median + fit.prediction_threshold(100.0 - 2.0 * (100.0 - percentile))


#: A mode's centre and spreads of the readings, the spectrum's centre and spreads.
_Normal = tuple[
    dict[str, float], dict[str, float], NDArray[np.float64], tuple[NDArray[np.float64], int]
]


class ModeLibrary:
    """An axis's operating modes and their normals, learned from the captures as they come.

    Parameters
    ----------
    n_fit : int, default=5
        Captures of a mode before it is known: its first fit, frozen as its reference.
    percentile : float, default=99.9
        Healthy captures under the threshold, per capture; the implied false-alarm rate is
        ``1 - percentile / 100``, split evenly between the readings and the spectrum.
    window : int, default=30
        Latest healthy captures of a mode its centre is the median of.
    fleet_distances : sequence of float, default=()
        Within-mode distances of other axes of the profile, pooled into the threshold.
    frozen : bool, default=False
        Score a known mode's captures against its first fit (the median of its first
        ``n_fit`` captures) instead of the median of its latest ``window``.
    first_window : bool, default=False
        Take a known mode's normal from its first ``window`` captures, not its latest.
    motion_match : bool, default=False
        A capture of a known mode's motion at another load is scored in that mode, not
        learned as a new one (:meth:`match`).
    learn_below : float, default=1.0
        A known mode learns a capture scored at most this (in thresholds): one nearer the
        threshold is not an alarm, and does not widen the normal either.
    drift_test : {"medians", "cusum"}, default="medians"
        How a known mode's drift from its first fit is found: the medians of its first and
        latest ``n_fit`` values in its spread now, or a self-starting CUSUM per reading
        (:mod:`._drift`). The CUSUM finds a slow fault sooner, and a healthy drift too (real
        hydraulic actuators warming up).

    Examples
    --------
    >>> library = ModeLibrary(n_fit=3)
    >>> library.n_fit, library.modes_
    (3, {})
    """

    def __init__(
        self,
        n_fit: int = 5,
        percentile: float = 99.9,
        window: int = 30,
        fleet_distances: Sequence[float] = (),
        frozen: bool = False,
        learn_below: float = 1.0,
        first_window: bool = False,
        motion_match: bool = False,
        drift_test: Literal["medians", "cusum"] = "medians",
    ) -> None:
        if not (isinstance(n_fit, int) and n_fit >= 3):
            raise ValueError(f"The 'n_fit' parameter must be an int >= 3. Got {n_fit!r}.")
        if not (isinstance(percentile, int | float) and 50.0 < percentile < 100.0):
            raise ValueError(
                f"The 'percentile' parameter must be a float in (50, 100). Got {percentile!r}."
            )
        if not (isinstance(window, int) and window >= n_fit):
            raise ValueError(f"The 'window' parameter must be an int >= n_fit. Got {window!r}.")
        self.n_fit = n_fit
        self.percentile = percentile
        self.window = window
        self.fleet_distances = tuple(fleet_distances)
        self.frozen = frozen
        self.learn_below = learn_below
        self.first_window = first_window
        self.motion_match = motion_match
        if drift_test not in ("medians", "cusum"):
            raise ValueError(
                f"The 'drift_test' parameter must be 'medians' or 'cusum'. Got {drift_test!r}."
            )
        self.drift_test = drift_test
        self.modes_: dict[str, _Mode] = {}
        # What the learned captures give, cached until a capture is learned.
        self._cache: dict[str, object] = {}
        self._normals: dict[str, _Normal] = {}

    def __getstate__(self) -> dict[str, object]:
        # What the learned captures give is recomputed: a stored library keeps the captures.
        return {**self.__dict__, "_cache": {}, "_normals": {}}

    def __setstate__(self, state: dict[str, object]) -> None:
        # A library stored before the drift test was an option used the medians.
        self.__dict__.update({"drift_test": "medians", **state})

    # -- the modes' normals ------------------------------------------------------------------
    def _known(self) -> list[_Mode]:
        return [m for m in self.modes_.values() if m.reference is not None]

    def _recent(self, mode: _Mode) -> list[CaptureDescription]:
        if self.first_window:
            return mode.members[: self.window]
        return mode.members[-self.window :]

    def _centre(self, members: Sequence[CaptureDescription]) -> dict[str, float]:
        rows = [_row(d) for d in members]
        names = sorted({n for r in rows for n in r})
        centre = {}
        for n in names:
            finite = [r[n] for r in rows if math.isfinite(r.get(n, math.nan))]
            centre[n] = float(np.median(finite)) if finite else math.nan
        return centre

    def _recent_centre(self, mode: _Mode) -> dict[str, float]:
        """The median of the mode's recent captures, kept until a capture is learned."""
        key = f"centre:{mode.name}"
        if key not in self._cache:
            self._cache[key] = self._centre(self._recent(mode))
        return self._cache[key]  # type: ignore[return-value]

    def _stats(self) -> NormalStats:
        """The known modes' recent readings and spectra as arrays (:mod:`._mode_normals`)."""
        if "stats" not in self._cache:
            known = self._known()
            rows = [[_row(d) for d in self._recent(m)] for m in known]
            names = sorted({n for block in rows for r in block for n in r})
            blocks = [
                ModeBlock(
                    np.array([[r.get(n, math.nan) for n in names] for r in block], np.float64),
                    np.stack([d.spectrum for d in self._recent(m)]),
                )
                for m, block in zip(known, rows, strict=True)
            ]
            both = np.array([n in _BOTH for n in names], bool)
            self._cache["stats"] = NormalStats(blocks, both, self.n_fit, names)
        return self._cache["stats"]  # type: ignore[return-value]

    def spreads(self, mode: str) -> dict[str, float]:
        """A known mode's within-mode spread of each reading: its own variance, raised towards
        the variance pooled over the axis's modes (``n_fit - 1`` degrees of weight) when lower."""
        k = [m.name for m in self._known()].index(mode)
        spreads = self._stats().spreads(k)
        return {n: float(v) for n, v in zip(self._stats().names, spreads, strict=True) if v > 0}

    def _spectrum_centre(self, mode: _Mode) -> NDArray[np.float64]:
        return np.asarray(np.median([d.spectrum for d in self._recent(mode)], 0), np.float64)

    def within_mode_distances(self) -> tuple[list[float], list[float]]:
        """Leave-one-out distances of the known modes' captures: readings and spectrum.

        Each capture against the median of its mode's other recent captures, in spreads
        estimated without it: the healthy distances the thresholds are fitted on.
        """
        return self._stats().leave_one_out()

    def thresholds(self) -> tuple[float, float]:
        """The readings' and the spectrum's thresholds (:func:`tail_threshold` of the pooled
        within-mode distances), each at half the false-alarm rate."""
        if "thresholds" not in self._cache:
            self._cache["thresholds"] = self._thresholds()
        return self._cache["thresholds"]  # type: ignore[return-value]

    def _thresholds(self) -> tuple[float, float]:
        readings, spectra = self.within_mode_distances()
        each = 100.0 - (100.0 - self.percentile) / 2.0
        pooled = [*readings, *self.fleet_distances]
        return (
            self._young(pooled, each, self.tails()),
            self._young(spectra, each, SPECTRUM_BANDS),
        )

    def tails(self) -> int:
        """How many one-sided shifts a capture's readings are tested for: two for a reading
        whose change either way is abnormal, one for the others (at least 1)."""
        both = self._stats().both
        return max(int(both.size + both.sum()), 1)

    def _young(self, distances: Sequence[float], percentile: float, m: int) -> float:
        """The empirical tail from :data:`MIN_TAIL_DISTANCES` pooled distances on; before, the
        largest of ``m`` normal shifts (the readings' shifts are put on the normal scale): a
        Bonferroni bound over the ``m`` tails tested."""
        if len(distances) >= MIN_TAIL_DISTANCES:
            return tail_threshold(distances, percentile)
        return float(norm.isf((1.0 - percentile / 100.0) / m))

    # -- which mode ---------------------------------------------------------------------------
    def _signature(self, mode: _Mode) -> tuple[NDArray[np.float64], float]:
        key = f"signature:{mode.name}"
        if key not in self._cache:
            signatures = np.stack([d.signature for d in self._recent(mode)])
            scale = float(np.median([d.torque_scale for d in self._recent(mode)]))
            self._cache[key] = (nan_median(signatures, 0), scale)
        return self._cache[key]  # type: ignore[return-value]

    def tolerance(self, mode: str | None = None) -> NDArray[np.float64]:
        """How far each signature reading may be from a known mode's: from that mode's own
        captures (:func:`~axiswatch.indicators._modes.mode_tolerance`). For a mode being learned (or
        ``None``), from every known mode's captures; the prior before one is known.

        A mode's own tolerance keeps a task whose signature hardly moves with the phase
        tight: pooled, the loosest task's set every mode's, and on development robot 4 a
        task took another's captures."""
        key = f"tolerance:{mode}"
        if key not in self._cache:
            known = [m for m in self._known() if m.name == mode] or self._known()
            self._cache[key] = self._tolerance(known)
        return self._cache[key]  # type: ignore[return-value]

    def _tolerance(self, modes: Sequence[_Mode]) -> NDArray[np.float64]:
        differences = []
        size = 0
        for mode in modes:
            members = self._recent(mode)
            signatures = np.stack([d.signature for d in members])
            centres = nan_median(other_rows(signatures), 1)
            scales = np.median(other_rows(np.array([d.torque_scale for d in members])), 1)
            for d, centre, scale in zip(members, centres, scales, strict=True):
                differences.append(mode_differences(d.signature, centre, float(scale)))
            size = signatures.shape[1]
        return mode_tolerance(differences, size)

    def match(self, description: CaptureDescription, *, taught: bool = False) -> str | None:
        """The mode a capture belongs to; None for a new mode.

        With ``motion_match``, a capture whose motion is a known mode's but whose load is not
        is scored in that mode (a load change, or a fault, is then an alarm to teach), unless
        ``taught``: the engineer said it is a new mode."""
        if description.declared is not None:
            return description.declared if description.declared in self.modes_ else None
        found = self._nearest(description, None)
        if found is None and self.motion_match and not taught:
            found = self._nearest(description, slice(0, MOTION_READINGS), self._known())
        return found

    def _nearest(
        self,
        description: CaptureDescription,
        part: slice | None,
        modes: Sequence[_Mode] | None = None,
    ) -> str | None:
        """The mode whose signature is within tolerance on every reading (the gate), and
        nearest over all of them (the root mean square in tolerances).

        Ranked by the largest reading alone, a payload taught as its own mode lost its captures
        to the mode of the same motion: the phase's noise in one motion reading, equal for
        both, outweighed the carried load that told them apart."""
        best, name = math.inf, None
        for mode in self.modes_.values() if modes is None else modes:
            centre, scale = self._signature(mode)
            differences = mode_differences(description.signature, centre, scale)
            tolerance = self.tolerance(mode.name)
            if tolerance.size != differences.size:
                tolerance = mode_tolerance([], differences.size)
            if part is not None:
                differences, tolerance = differences[part], tolerance[part]
            if not mode_distance(differences, tolerance) <= 1.0:
                continue
            distance = float(np.sqrt(np.mean((differences / tolerance) ** 2)))
            if distance < best:
                best, name = distance, mode.name
        return name

    # -- verdicts -----------------------------------------------------------------------------
    def _guard(self, description: CaptureDescription, t_readings: float) -> tuple[float, str]:
        """The largest excess of a guard reading over every known mode's centre, in the
        within-mode spread and the widest difference between two modes' centres. NaN with
        fewer than 2 known modes: what a mode change does is not yet measured."""
        known = self._known()
        if len(known) < 2:
            return math.nan, ""
        variances = self._stats().pooled_variance()
        pooled = {
            n: float(v)
            for n, v in zip(self._stats().names, variances, strict=True)
            if _guarded(n) and math.isfinite(v)
        }
        row = _row(description)
        centres = [self._recent_centre(m) for m in known]
        best, where = math.nan, ""
        for n, within in pooled.items():
            values = [c[n] for c in centres if math.isfinite(c.get(n, math.nan))]
            x = row.get(n, math.nan)
            if not (len(values) >= 2 and math.isfinite(x)):
                continue
            between = max(values) - min(values)
            z = max(x - max(values), 0.0) / math.sqrt(within + between**2)
            if not z <= best:
                best, where = z, n
        return best / t_readings, where

    def score(self, description: CaptureDescription) -> ModeAssessment:
        """The verdict on a capture, without learning from it."""
        rate = 1.0 - self.percentile / 100.0
        name = self.match(description)
        source = description.source
        if not description.moving:
            return ModeAssessment(source, name or "", "still", math.nan, False)
        mode = self.modes_.get(name) if name is not None else None
        label = name or description.declared or f"mode{len(self.modes_)}"
        t_readings, t_spectrum = self.thresholds() if self._known() else (math.inf, math.inf)
        if mode is None or mode.reference is None:
            guard, where = self._guard(description, t_readings)
            seen = 1 + (len(mode.members) if mode else 0)
            alarm = bool(guard > 1.0)
            return ModeAssessment(
                source, label, "learning", guard, alarm, where, seen, self.n_fit, rate
            )
        if mode.name not in self._normals:
            self._normals[mode.name] = (
                mode.reference if self.frozen else self._recent_centre(mode),
                self.spreads(mode.name),
                self._spectrum_centre(mode),
                self._stats().spectrum_spread(),
            )
        centre, spreads, spectrum_centre, (band, band_dof) = self._normals[mode.name]
        error = float(centre_error(self.n_fit if self.frozen else len(self._recent(mode))))
        spreads = {n: v * error for n, v in spreads.items()}
        band = band * error
        dof = max(len(self._recent(mode)) - 1, 1)
        d_readings, where = _indicator_distance(_row(description), centre, spreads, dof)
        d_spectrum = _spectrum_distance(description.spectrum, spectrum_centre, band, band_dof)
        score = d_readings / t_readings if math.isfinite(d_readings) else 0.0
        if d_spectrum / t_spectrum > score:
            score, where = d_spectrum / t_spectrum, "spectrum"
        state: State = "drift" if mode.drifted else "known"
        alarm = bool(score > 1.0 or mode.drifted)
        return ModeAssessment(
            source, mode.name, state, score, alarm, where, mode.seen, self.n_fit, rate
        )

    def update(self, description: CaptureDescription) -> ModeAssessment:
        """Score a capture, then learn from it if it was scored healthy."""
        verdict = self.score(description)
        self.learn(description, verdict)
        return verdict

    def learn(self, description: CaptureDescription, verdict: ModeAssessment) -> bool:
        """Learn a capture from its verdict (:meth:`score`): only a healthy capture of a
        moving axis joins its mode. Returns whether it joined."""
        if verdict.state == "still" or verdict.alarm:
            return False
        if verdict.state == "known" and verdict.score > self.learn_below:
            return False
        mode = self.modes_.setdefault(verdict.mode, _Mode(verdict.mode))
        mode.join(description, self.window)
        self._cache.clear()
        self._normals.clear()
        if mode.reference is None and len(mode.members) >= self.n_fit:
            mode.reference = self._centre(mode.members)
        elif mode.reference is not None:
            mode.drifted = self._drifted(mode)
        return True

    def teach(self, description: CaptureDescription, mode: str | None = None) -> str:
        """Learn a capture the engineer says is healthy (an alarm that was a mode change).

        It joins ``mode`` (a new one of that name when unknown), else its declared mode, else
        the new mode it is being learned in, else a new mode. A capture that alarmed in a
        known mode is not of that mode: joined to it, a payload change taught on development
        robots made the mode drift. A drifted mode stays drifted. Returns the mode's name.
        """
        found = self._taught_mode(description)
        if found is not None and description.declared is None:
            found = found if self.modes_[found].reference is None else None
        return self._told(description, mode or found)

    def accept(self, description: CaptureDescription) -> str:
        """Learn a capture the engineer calls a false alarm: it joins the mode it matches (the
        mode being learned, for a guard's alarm). A drifted mode starts again from its latest
        ``n_fit`` captures and this one: its first fit and its drift test restart there.
        Returns the mode's name."""
        name = self._taught_mode(description)
        mode = self.modes_.get(name) if name is not None else None
        if mode is not None and mode.drifted:
            mode.members = mode.members[-self.n_fit :]
            mode.drifted = False
            mode.reference = None
            if mode.drift is not None:
                mode.track(self.window)
        return self._told(description, name)

    def _taught_mode(self, description: CaptureDescription) -> str | None:
        if not description.moving:
            raise ValueError(f"{description.source}: the axis did not move; nothing to learn.")
        return self.match(description, taught=True)

    def _told(self, description: CaptureDescription, name: str | None) -> str:
        """Join what the engineer said is healthy to mode ``name``; when None, to a new mode
        (named as declared, if it is)."""
        name = name or description.declared or f"mode{len(self.modes_)}"
        mode = self.modes_.setdefault(name, _Mode(name))
        mode.join(description, self.window)
        if mode.reference is None and len(mode.members) >= self.n_fit:
            mode.reference = self._centre(mode.members)
        self._cache.clear()
        self._normals.clear()
        return name

    def _drifted(self, mode: _Mode) -> bool:
        """Whether a known mode drifted from its first fit, by :attr:`drift_test`."""
        if self.drift_test == "cusum":
            return self._drifted_cusum(mode)
        return self._drifted_medians(mode)

    def _drifted_cusum(self, mode: _Mode) -> bool:
        """Whether a guard reading's CUSUM passed its limit (:mod:`._drift`): its values rose
        above the mode's first ``window``, in their own spread, for longer than chance allows.
        The limit's in-control run length is ``1 / (1 - percentile / 100)`` captures of the
        mode (1,000 at 99.9), Bonferroni over the readings tested; only rises of the guard
        readings, as :meth:`_drifted_medians`."""
        drift = mode.track(self.window) if mode.drift is None else mode.drift
        if not drift:
            return False
        run_length = len(drift) / (1.0 - self.percentile / 100.0)
        return max(c.total for c in drift.values()) > cusum_limit(run_length)

    def _drifted_medians(self, mode: _Mode) -> bool:
        """Whether a guard reading's latest ``n_fit`` values rose above its first ``n_fit``:
        a one-sided z of the two medians' difference, Bonferroni over the guard readings.

        Only the readings that grow with a fault in any mode (:data:`GUARD_READINGS`, the
        kinematic lines), and only a rise: a load, or a reading that falls, also moves as a
        machine warms up (real hydraulic actuators: 46-74 of their ~100 healthy captures
        drifted with every reading, both ways). Each reading counts its own values: one read
        in one direction of motion has a value in every other capture."""
        assert mode.reference is not None
        spreads = self.spreads(mode.name)
        rows = [_row(d) for d in mode.members]
        shifts = []
        for n, spread in spreads.items():
            if not _guarded(n):
                continue
            values = [r[n] for r in rows if math.isfinite(r.get(n, math.nan))]
            if len(values) >= 2 * self.n_fit:
                first = float(np.median(values[: self.n_fit]))
                latest = float(np.median(values[-self.n_fit :]))
                shifts.append((latest - first) / spread)
        if not shifts:
            return False
        error = _MEDIAN_EFFICIENCY * math.sqrt(2.0 / self.n_fit)
        limit = float(norm.isf((1.0 - self.percentile / 100.0) / len(shifts)))
        return max(shifts) / error > limit
