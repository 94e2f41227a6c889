"""The monitor's ``indicators`` method: an :class:`~axiswatch.IndicatorModel` per axis baseline.

Fit on the baseline and ``K`` calibration captures, pooled with the axis's fleet, scored in
units of the threshold that applied. docs/internals.md, "The method indicators".
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from axiswatch._axis_model import Assessment, MonitoredModel
from axiswatch._capture import Capture, rate_at_least
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import CalibrationError, CaptureError
from axiswatch.indicators._assessment import IndicatorAssessment, grouped_reasons
from axiswatch.indicators._fleet import (
    LEAVE_SELF_OUT_MAX_AXES,
    FleetPrior,
    pool_fleet,
    pool_fleet_without,
)
from axiswatch.indicators._model import IndicatorModel
from axiswatch.indicators._readings import Readings, read_indicators
from axiswatch.indicators._ringing import MIN_RINGING_RATE_HZ

__all__ = [
    "MIN_MONITOR_RATE_HZ",
    "IndicatorBaseline",
    "assess_capture",
    "check_monitor_rate",
    "fit_indicator_baseline",
    "fleet_key",
    "indicator_details",
    "slow_baseline_note",
    "read_axis_indicators",
    "threshold_units",
    "with_fleet",
]


@dataclass(frozen=True)
class IndicatorBaseline:
    """An axis's fitted :class:`~axiswatch.IndicatorModel` and the captures it was fitted on.

    Attributes
    ----------
    model : IndicatorModel
        Fitted on the baseline and the calibration captures (with the fleet prior, when set).
    file_hashes : tuple of str
        SHA-256 of those captures' files, baseline first: a capture with one of them is given
        its leave-one-out assessment.
    paths : tuple of str
        Their paths below the fleet folder, in the same order.
    """

    model: IndicatorModel
    file_hashes: tuple[str, ...] = ()
    paths: tuple[str, ...] = ()

    #: What the monitor reads of a file: every column (the profile names them).
    signals: ClassVar[tuple[str, ...] | None] = None
    #: The calibration captures' readings set the within-task spreads.
    fits_calibration: ClassVar[bool] = True
    #: New baselines wait for their fleet's prior.
    pooled: ClassVar[bool] = True

    def fit(
        self, baseline: Capture, calibration: Sequence[Capture] = (), *, fleet: Sequence[Any] = ()
    ) -> IndicatorBaseline:
        """:meth:`IndicatorModel.fit` of a copy of the model, pooled with ``fleet`` (fitted
        baselines of the other axes of its profile) when given."""
        model = copy.deepcopy(self.model).fit(baseline, calibration)
        fitted = IndicatorBaseline(model)
        return fitted.with_fleet([fitted], fleet)[0] if fleet else fitted

    def assess(self, capture: Capture) -> IndicatorAssessment:
        """:meth:`IndicatorModel.assess`."""
        return self.model.assess(capture)

    def check_baseline(self, capture: Capture) -> None:
        """:func:`check_monitor_rate`."""
        check_monitor_rate(capture)

    def baseline_note(self, rates_hz: Mapping[str, float]) -> str | None:
        """:func:`slow_baseline_note`."""
        return slow_baseline_note(rates_hz)

    def read(self, capture: Capture, profile: AxisProfile | None) -> tuple[Readings, str | None]:
        """The capture's readings (:func:`read_axis_indicators`), and why none can be used."""
        read = read_axis_indicators(
            capture, profile, order_lines=self.model.order_lines, whole_moves=self.model.whole_moves
        )
        if read.available():
            return read, None
        return read, f"no indicator can be read ({grouped_reasons(read.reasons)})"

    def fit_read(
        self, read: Sequence[Readings], names: Sequence[tuple[str, str]]
    ) -> IndicatorBaseline:
        """:func:`fit_indicator_baseline` with this model's parameters."""
        model = self.model
        return fit_indicator_baseline(
            read,
            [file_hash for file_hash, _ in names],
            [path for _, path in names],
            percentile=model.percentile,
            task_envelope_factor=model.task_envelope_factor,
            order_lines=model.order_lines,
            whole_moves=model.whole_moves,
        )

    def fingerprint(self) -> str:
        """SHA-256 of the readings fitted on."""
        rows = json.dumps([r.values for r in self.model.fit_readings_], sort_keys=True, default=str)
        return hashlib.sha256(rows.encode()).hexdigest()

    def summary(self) -> dict[str, Any]:
        """The model's parameters and the captures it was fitted on."""
        return {"indicator_model": {**self.model.params(), "fitted_on": list(self.paths)}}

    def score(self, capture: Capture, file_hash: str, profile: AxisProfile | None) -> Assessment:
        """:func:`assess_capture` in units of the threshold that applied
        (:func:`threshold_units`), with :func:`indicator_details`."""
        if file_hash in self.file_hashes:  # read when it was fitted
            return self._in_units(assess_capture(self, capture, file_hash, profile), file_hash)
        return self.score_read(self.read(capture, profile)[0], file_hash)

    def score_read(self, read: Readings, file_hash: str) -> Assessment:
        """:meth:`score` of a capture's readings already read (:meth:`read`)."""
        if file_hash in self.file_hashes:
            assessment = self.model.assess_fitting(self.file_hashes.index(file_hash))
        else:
            assessment = self.model.assess_readings(read)
        return self._in_units(assessment, file_hash, read.repaired)

    def _in_units(
        self, assessment: IndicatorAssessment, file_hash: str, repaired: int = 0
    ) -> Assessment:
        if not assessment.scored:
            # Not an alarm and not a healthy score: no indicator of the model could be read.
            return Assessment(math.nan, 1.0, False, explanation=assessment.reason())
        details = indicator_details(self, assessment, left_out=file_hash in self.file_hashes)
        if repaired:
            details["repaired_spikes"] = repaired
        distance = threshold_units(assessment)
        return Assessment(distance, 1.0, distance > 1.0, leading=assessment.top, details=details)

    def fleet_key(self, profile: AxisProfile | None) -> str:
        """:func:`fleet_key`."""
        return fleet_key(profile)

    def fleet_axes(self) -> int:
        """Axes of the model's fleet prior (0 without one)."""
        return 0 if self.model.fleet is None else self.model.fleet.n_axes

    def checks(self) -> dict[str, str]:
        """The model's ``baseline_check_`` and ``fleet_check_`` that are set."""
        found = {
            kind: getattr(self.model, f"{kind}_check_", None) for kind in ("baseline", "fleet")
        }
        return {kind: str(note) for kind, note in found.items() if note}

    def with_fleet(
        self, models: Sequence[IndicatorBaseline], others: Sequence[IndicatorBaseline]
    ) -> list[IndicatorBaseline]:
        """:func:`with_fleet` of the baselines ``models`` and the stored ``others``."""
        return with_fleet(models, [other.model for other in others])

    def allowance(self) -> float | None:
        """The fleet's one task-change allowance at the model's percentile, in spreads: that of
        the indicators without their own (None without a prior)."""
        fleet = self.model.fleet
        return None if fleet is None else fleet.allowance(self.model.percentile)


#: The lowest rate the monitor reads indicators at (docs/monitor.md: "any rate from 20 Hz"): that of
#: ``gap_ringing``, the indicator that needs the least.
MIN_MONITOR_RATE_HZ = MIN_RINGING_RATE_HZ


def check_monitor_rate(capture: Capture) -> None:
    """Refuse a capture whose fastest signal is slower than :data:`MIN_MONITOR_RATE_HZ`.

    Friction and drive loads can be read at any rate, so such a capture was scored: a 100 Hz log
    stamped in milliseconds, read as seconds, gave 0.1 Hz and distances in wrong units, silently.

    Raises
    ------
    CaptureError
        Naming the capture, its fastest rate and the likely cause.

    Examples
    --------
    >>> from axiswatch import as_capture
    >>> check_monitor_rate(as_capture({"torque": [0.0, 1.0, 0.0]}, 0.1, source="c.csv"))
    Traceback (most recent call last):
    ...
    axiswatch.exceptions.CaptureError: c.csv: signals sampled at 0.1 Hz at most; ...
    """
    fastest = max(capture.rates_hz.values())
    # Within the 0.1 % a rate is checked to: a 20 Hz log's stamps give 19.99999... Hz.
    if not rate_at_least(fastest, MIN_MONITOR_RATE_HZ):
        raise CaptureError(
            f"{capture.source}: signals sampled at {fastest:.3g} Hz at most; the indicators need "
            f"{MIN_MONITOR_RATE_HZ:g} Hz or more (stamps in milliseconds read as seconds? "
            'declare the unit in the axis profile: [units] time = "ms").'
        )


def slow_baseline_note(rates_hz: Mapping[str, float]) -> str | None:
    """A note for a stored baseline slower than :data:`MIN_MONITOR_RATE_HZ` (fitted before
    new baselines were held to it: Unix milliseconds read as seconds), else None. Its model is
    kept and scored as before; the note asks for a rebaseline and is never an alarm.

    Examples
    --------
    >>> slow_baseline_note({"position": 0.1, "torque": 0.1})
    'baseline at 0.1 Hz, below the 20 Hz the indicators need: rebaseline'
    >>> slow_baseline_note({"torque": 100.0}) is None
    True
    """
    if not rates_hz:
        return None
    fastest = max(rates_hz.values())
    if rate_at_least(fastest, MIN_MONITOR_RATE_HZ):
        return None
    return (
        f"baseline at {fastest:.3g} Hz, below the {MIN_MONITOR_RATE_HZ:g} Hz the indicators "
        "need: rebaseline"
    )


def read_axis_indicators(
    capture: Capture,
    profile: AxisProfile | None,
    *,
    order_lines: bool = False,
    whole_moves: bool = False,
) -> Readings:
    """:func:`~axiswatch.read_indicators` with the kinematics of the axis's profile, if any
    (and the order spectrum with ``order_lines``, the whole-move loads and friction errors with
    ``whole_moves``).

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> read = read_axis_indicators(draw_robot(5).capture(0), None)  # a 20 Hz robot
    >>> read.reasons["impulsiveness"]
    'needs a torque rate >= 100 Hz (got 20 Hz)'
    """
    kinematics = profile.kinematics() if profile is not None else {}
    return read_indicators(capture, **kinematics, order_lines=order_lines, whole_moves=whole_moves)


def fit_indicator_baseline(
    readings: Sequence[Readings],
    file_hashes: Sequence[str],
    paths: Sequence[str],
    *,
    percentile: float,
    task_envelope_factor: float | None = None,
    order_lines: bool = False,
    whole_moves: bool = False,
) -> IndicatorBaseline:
    """Fit the axis's model on the readings of its baseline (first) and calibration captures.

    Parameters
    ----------
    readings : sequence of Readings
        Baseline first, then the ``K`` calibration captures, in capture order.
    file_hashes, paths : sequence of str
        Of the same captures.
    percentile : float in (0, 100)
    task_envelope_factor : float > 0 or None, default=None
        :class:`~axiswatch.IndicatorModel`'s: None scores every capture with the fleet's
        allowance.
    order_lines : bool, default=False
        :class:`~axiswatch.IndicatorModel`'s (the readings must carry order profiles).
    whole_moves : bool, default=False
        :class:`~axiswatch.IndicatorModel`'s (the readings must be read with it).

    Returns
    -------
    IndicatorBaseline

    Raises
    ------
    CalibrationError
        When no indicator is read on enough of the captures to give a spread.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> robot = draw_robot(0)
    >>> read = [read_axis_indicators(robot.capture(0, seed=k), None) for k in range(6)]
    >>> fitted = fit_indicator_baseline(read, [str(k) for k in range(6)], [""] * 6,
    ...                                 percentile=99.0)
    >>> fitted.allowance() is None, len(fitted.model.own_loo_distances_)
    (True, 6)
    """
    if not (len(readings) == len(file_hashes) == len(paths)):
        raise ValueError(
            "The 'readings', 'file_hashes' and 'paths' parameters must have one entry per "
            f"capture. Got {len(readings)}, {len(file_hashes)} and {len(paths)} instead."
        )
    model = IndicatorModel(
        percentile=percentile,
        task_envelope_factor=task_envelope_factor,
        order_lines=order_lines,
        whole_moves=whole_moves,
    ).fit_readings(list(readings))
    return IndicatorBaseline(model, tuple(file_hashes), tuple(paths))


def fleet_key(profile: AxisProfile | None) -> str:
    """The fleet an axis is pooled with: its profile's name, else the profile file, else the
    axes read without a profile.

    Examples
    --------
    >>> fleet_key(None), fleet_key(AxisProfile(name="KR16 A1", source="a/axis.toml"))
    ('(no profile)', 'name: KR16 A1')
    """
    if profile is None:
        return "(no profile)"
    return f"name: {profile.name}" if profile.name else f"file: {profile.source}"


def with_fleet(
    baselines: Sequence[IndicatorBaseline], others: Sequence[IndicatorModel] = ()
) -> list[IndicatorBaseline]:
    """The baselines with the prior of their fleet, or unchanged when it has fewer than 3 axes or
    nothing to pool.

    Parameters
    ----------
    baselines : sequence of IndicatorBaseline
        The new baselines of one profile's axes.
    others : sequence of IndicatorModel, default=()
        The models of the profile's other axes (stored ones); the fleet is these and the
        baselines' own.

    Returns
    -------
    list of IndicatorBaseline
        In order, each model a copy scored with the prior of the whole fleet and checked
        (``fleet_check_``) against the prior of the fleet without it
        (:func:`~axiswatch.indicators._fleet.pool_fleet_without`), or, with fewer than 3 other
        axes, against the whole fleet's (its notes say so).

    Raises
    ------
    ValueError
        When ``others`` holds one of the baselines' own models (it would be pooled twice).

    Notes
    -----
    One pool of the fleet per baseline, each over the pairs of the other axes: cubic in the
    fleet's axes when all are new (a first run: about 3 s at 200 axes). So only a fleet of at
    most ``LEAVE_SELF_OUT_MAX_AXES`` (200) axes checks each baseline without it; a larger one
    checks it against the whole fleet's prior, where the pairs with one axis are at most 1 %.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> def fitted(task):
    ...     read = [read_axis_indicators(draw_robot(0).capture(task, seed=k), None)
    ...             for k in range(6)]
    ...     return fit_indicator_baseline(read, ["h"] * 6, ["p"] * 6, percentile=99.0)
    >>> own = [fitted(task) for task in range(4)]
    >>> pooled = with_fleet(own[:3], [own[3].model])
    >>> pooled[0].model.fleet.n_axes, own[0].allowance() is None
    (4, True)
    """
    own = {id(b.model) for b in baselines}
    if any(id(model) in own for model in others):
        # The call before others existed passed the fleet, these included: each would count twice.
        raise ValueError(
            "The 'others' parameter of with_fleet must hold the models of the profile's other "
            "axes; got one of these baselines' own (they are added to the fleet)."
        )
    fleet = [*others, *(b.model for b in baselines)]
    try:
        prior: FleetPrior = pool_fleet(fleet)
    except CalibrationError:
        return list(baselines)
    out = []
    small = len(fleet) <= LEAVE_SELF_OUT_MAX_AXES
    for k, baseline in enumerate(baselines):
        check = pool_fleet_without(fleet, len(others) + k) if small else None
        model = copy.deepcopy(baseline.model).use_fleet(prior, check_against=check)
        out.append(IndicatorBaseline(model, baseline.file_hashes, baseline.paths))
    return out


def assess_capture(
    baseline: IndicatorBaseline, capture: Capture, file_hash: str, profile: AxisProfile | None
) -> IndicatorAssessment:
    """A capture's assessment: leave-one-out for a capture the model was fitted on (matched by
    its file's hash), else against the centre.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> captures = [draw_robot(0).capture(0, seed=k) for k in range(7)]
    >>> read = [read_axis_indicators(c, None) for c in captures[:6]]
    >>> fitted = fit_indicator_baseline(read, [str(k) for k in range(6)], [""] * 6,
    ...                                 percentile=99.0)
    >>> left_out = assess_capture(fitted, captures[2], "2", None)
    >>> left_out.distance == fitted.model.own_loo_distances_[2]
    True
    >>> assess_capture(fitted, captures[6], "new", None).scored
    True
    """
    if file_hash in baseline.file_hashes:
        return baseline.model.assess_fitting(baseline.file_hashes.index(file_hash))
    model = baseline.model
    read = read_axis_indicators(
        capture, profile, order_lines=model.order_lines, whole_moves=model.whole_moves
    )
    return model.assess_readings(read)


def threshold_units(assessment: IndicatorAssessment) -> float:
    """The score the monitor stores: the distance over the threshold that applied to it (1 is
    the threshold, for the baseline's task and for a task change alike).

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> captures = [draw_robot(0).capture(0, seed=k) for k in range(6)]
    >>> read = [read_axis_indicators(c, None) for c in captures]
    >>> fitted = fit_indicator_baseline(read, [str(k) for k in range(6)], [""] * 6,
    ...                                 percentile=99.0)
    >>> left_out = fitted.model.assess_fitting(1)
    >>> threshold_units(left_out) == left_out.distance / fitted.model.own_threshold_
    True
    """
    return assessment.distance / assessment.threshold


def indicator_details(
    baseline: IndicatorBaseline, assessment: IndicatorAssessment, *, left_out: bool
) -> dict[str, Any]:
    """What a score's details keep of an assessment (the report reads ``indicators`` as it
    does the ``mechanics`` method's: value, baseline, spreads and share per indicator);
    ``left_out``: the assessment is a fitted capture's leave-one-out one.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> read = [read_axis_indicators(draw_robot(0).capture(0, seed=k), None) for k in range(7)]
    >>> fitted = fit_indicator_baseline(read[:6], list("abcdef"), [""] * 6, percentile=99.0)
    >>> details = indicator_details(fitted, fitted.model.assess_readings(read[6]),
    ...                             left_out=False)
    >>> sorted(details["indicators"]["coulomb_friction"])
    ['baseline', 'share', 'spreads', 'value']
    """
    details: dict[str, Any] = {
        "indicators": assessment.indicators,
        "top_indicator": assessment.reason() if assessment.top is not None else None,
        "component": assessment.component,
        "unavailable": assessment.unavailable,
        "leave_one_out": left_out,
        "fleet_axes": 0 if baseline.model.fleet is None else baseline.model.fleet.n_axes,
        "case": assessment.case,
        "spreads_distance": assessment.distance,
        "threshold_spreads": assessment.threshold,
        "task_distance": assessment.task_distance,
        "task_envelope": assessment.task_envelope,
    }
    allowance = baseline.allowance()
    if allowance is not None and math.isfinite(allowance):
        details["task_change_allowance"] = allowance
    for check in ("baseline_check", "fleet_check"):
        text = getattr(baseline.model, f"{check}_", None)
        if text is not None:
            details[check] = text
    return details


if TYPE_CHECKING:  # checked by mypy: what the monitor fits and scores of the product default
    _CONFORMS: type[MonitoredModel] = IndicatorBaseline
