"""IndicatorModel: an axis's physical indicators scored in spreads of its own and of its fleet.

The estimators and the reasons for them: docs/indicator-model.md.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from axiswatch._axis_model import AxisModel
from axiswatch._calibration import fit_half_laplace
from axiswatch._capture import Capture
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import CalibrationError
from axiswatch.indicators._assessment import IndicatorAssessment
from axiswatch.indicators._fleet import (
    FleetPrior,
    _allowances,
    _combined_spreads,
    _task_change_scales,
    fleet_difference,
    own_pair_allowances,
    pool_fleet,
    pool_fleet_without,
)
from axiswatch.indicators._order_lines import (
    MIN_COMMON_CELLS,
    OrderProfile,
    component_at,
    grown_lines,
    most_grown_order,
)
from axiswatch.indicators._readings import (
    FRICTION,
    Readings,
    read_indicators,
    signature_distance,
)
from axiswatch.indicators._spreads import (
    MIN_READINGS,
    ORDER_LINES,
    TASK_ENVELOPE_FACTOR,
    _centre_without,
    _declared,
    _distance,
    _fitting_order_lines,
    _transformed,
    leave_one_out_distances,
    reference_errors,
    robust_spread,
    task_envelope,
)

__all__ = [
    "IndicatorModel",
]


class IndicatorModel:
    """Baseline, spreads and threshold of one axis's physical indicators.

    Parameters
    ----------
    profile : AxisProfile, optional
        Kinematics for the kinematic lines (units and columns are applied when reading files).
    percentile : float in (0, 100), default=99.0
    fleet : FleetPrior, optional
        Task-change spreads and allowance of the axis's profile (:func:`pool_fleet`); can be
        set later with :meth:`use_fleet`, which also takes the prior of the other axes to
        check the baseline against (given here, the baseline is checked against ``fleet``,
        itself included).
    task_envelope_factor : float > 0 or None, default=None
        The task envelope in units of the largest leave-one-out signature distance of the
        fitting captures (:func:`task_envelope`; ``TASK_ENVELOPE_FACTOR`` = 2 was chosen on the
        development robots); None: with a fleet prior, every capture is scored as a task change
        (the fleet's spreads and allowance always). Without a fleet prior the envelope (this
        factor, ``TASK_ENVELOPE_FACTOR`` when None) tells a capture of another task, which is
        then not compared at all (nothing says what a task change does to the indicators; the
        assessment says so and how to monitor the new task). Off by default: on the development and held-out robots it
        detects far more same-task friction faults for a few more false alarms, but on the real
        hydraulic actuators it raised 55 false alarms in 297 healthy captures
        (docs/evaluation.md, "Through the monitor").
    order_lines : bool, default=False
        Also read the torque's order spectrum and score ``order_lines``: how much the order
        lines of a capture grew against the baseline's own order spectrum
        (:mod:`axiswatch.indicators._order_lines`), without kinematics. Its task-change spread and
        allowance come from the fleet: each axis's reference reading the other axes' captures.
    whole_moves : bool, default=False
        An opt-in operating point: read the drive loads on whole moves only and, with a fleet
        prior, widen the within-task spread of a friction reading looser than the baseline's
        (``max(1, se / se_ref)``, :meth:`error_factors`). On development robots 0-7 it cut Robot
        A's false-alarm days from 32 to 3 and on fresh robots 8-15 from 19 to 0, but lowered
        ``dr99`` at the fixed 99 % threshold by up to 0.03, so it is not the default
        (docs/evaluation.md, "An opt-in operating point: ``--whole-moves``").

    Attributes
    ----------
    centre_, within_ : dict of str to float
    threshold_ : float
        For a task change: with a fleet prior, the calibration fit in allowance units, at least
        1; without, the calibration fit in ``s_w``.
    own_threshold_ : float
        For the baseline's task: the calibration fit in ``s_w`` (no allowance).
    se_ref_ : dict of str to float
        With ``whole_moves``: per friction indicator, the median least-squares standard error of
        the fitting captures' readings (:func:`reference_errors`); empty without.
    loo_distances_, own_loo_distances_ : list of float
        Leave-one-out distance of each capture fitted on (baseline first; NaN where none) in the
        task-change units (:attr:`task_change_scales_`) and in the own spreads; each threshold
        is fitted on the calibration captures' (:func:`leave_one_out_distances`).
    order_reference_ : OrderProfile or None
        With ``order_lines``: the median order profile of the fitting captures
        (:func:`~axiswatch.indicators._order_lines.order_reference`); None when none gave one.
    task_reference_ : ndarray of shape (6,) or None
        The median task signature of the fitting captures (None when fewer than 3 are read),
        with or without ``task_envelope_factor``.
    task_envelope_ : float
        How far a capture's signature may be from it and still be the baseline's task (NaN
        without a reference).
    task_loo_distances_ : list of float
        Each fitting capture's signature distance from the median of the others'.
    baseline_check_ : str or None
        Why the baseline capture is not trusted as it is (None when it agrees).
    fleet_check_ : str or None
        With a fleet prior: how the axis's centre differs from its fleet's by more than the
        task-change allowance (:func:`fleet_difference`; None when it does not, or without a
        prior), and what it was checked against: the other axes of its profile
        (``check_against`` of :meth:`use_fleet`), else the fleet with the axis included.
    notes_ : list of str
        What the model could not estimate, in words.

    Examples
    --------
    >>> from axiswatch.datasets import draw_robot
    >>> robot = draw_robot(0)
    >>> model = IndicatorModel().fit(robot.capture(0, seed=0),
    ...                              [robot.capture(0, seed=k) for k in range(1, 6)])
    >>> model.assess(robot.capture(0, seed=9)).scored
    True
    """

    def __init__(
        self,
        profile: AxisProfile | None = None,
        *,
        percentile: float = 99.0,
        fleet: FleetPrior | None = None,
        task_envelope_factor: float | None = None,
        order_lines: bool = False,
        whole_moves: bool = False,
    ) -> None:
        self.profile = profile
        self.percentile = percentile
        self.fleet = fleet
        self.task_envelope_factor = task_envelope_factor
        self.order_lines = order_lines
        self.whole_moves = whole_moves

    @staticmethod
    def pool(models: Sequence[IndicatorModel]) -> FleetPrior:
        """:func:`pool_fleet`: the fleet prior of fitted models of one profile's axes."""
        return pool_fleet(models)

    @staticmethod
    def pool_without(models: Sequence[IndicatorModel], index: int) -> FleetPrior | None:
        """:func:`pool_fleet_without`: the prior the ``index``-th model's baseline is checked
        against (``check_against`` of :meth:`use_fleet`)."""
        return pool_fleet_without(models, index)

    def readings(self, capture: Capture) -> Readings:
        """The capture's indicators (:func:`~axiswatch.read_indicators` with the profile's
        kinematics, ``order_lines`` and ``whole_moves``)."""
        kinematics = self.profile.kinematics() if self.profile is not None else {}
        return read_indicators(
            capture, **kinematics, order_lines=self.order_lines, whole_moves=self.whole_moves
        )

    def fit(
        self,
        baseline: Capture,
        calibration: Sequence[Capture] = (),
        *,
        fleet: Sequence[IndicatorModel] = (),
    ) -> IndicatorModel:
        """Centre and within-task spreads from the baseline and the calibration captures.

        ``fleet``: fitted models of the other axes of the profile. With them, the model takes
        the prior of the whole fleet and is checked against the others' (:meth:`use_fleet`);
        with fewer than 3 axes in all it has no prior.
        """
        if len(calibration) < MIN_READINGS - 1:
            raise CalibrationError(
                f"IndicatorModel needs at least {MIN_READINGS - 1} calibration captures after "
                f"the baseline (a spread needs {MIN_READINGS} readings); got {len(calibration)}."
            )
        read = [self.readings(c) for c in (baseline, *calibration)]
        self.fit_readings(read)
        if not fleet:
            return self
        models = [*fleet, self]
        try:
            prior = pool_fleet(models)
        except CalibrationError:
            return self
        return self.use_fleet(prior, check_against=pool_fleet_without(models, len(fleet)))

    def fit_readings(self, read: Sequence[Readings]) -> IndicatorModel:
        """:meth:`fit` from readings already taken (first = the baseline)."""
        self.fit_readings_ = list(read)
        rows = [_transformed(r) for r in read]
        self.order_reference_: OrderProfile | None = None
        if self.order_lines:
            self.order_reference_, grown = _fitting_order_lines(read)
            for row, value in zip(rows, grown, strict=True):
                row[ORDER_LINES.name] = value
        names = list(rows[0])
        self.reasons_ = dict(read[0].reasons)
        self.centre_: dict[str, float] = {}
        self.within_: dict[str, float] = {}
        for name in names:
            values = [row[name] for row in rows]
            spread = robust_spread(values)
            if math.isfinite(spread) and spread > 0:
                self.centre_[name] = float(np.nanmedian(values))
                self.within_[name] = spread
            elif name not in self.reasons_:
                self.reasons_[name] = (
                    "no spread to scale by (read on fewer than 3 of the baseline and calibration "
                    "captures, or identical on all)"
                )
        self.calibration_rows_ = rows
        self.se_ref_ = reference_errors(read) if self.whole_moves else {}
        self.task_reference_: NDArray[np.float64] | None = None
        self.task_envelope_ = math.nan
        self.task_loo_distances_ = [math.nan] * len(read)
        # Always read: without a fleet prior a capture beyond the envelope is not compared.
        factor = self.task_envelope_factor or TASK_ENVELOPE_FACTOR
        envelope = task_envelope([r.signature for r in read], factor)
        if envelope is not None:
            self.task_reference_, self.task_envelope_, self.task_loo_distances_ = envelope
        self._threshold_from(rows, None)
        return self

    def use_fleet(
        self, fleet: FleetPrior | None, *, check_against: FleetPrior | None = None
    ) -> IndicatorModel:
        """Take a fleet prior (or drop it) and recompute the threshold and the checks.

        Parameters
        ----------
        fleet : FleetPrior or None
            What captures are scored with: the prior of all the profile's axes, this one
            included (:func:`pool_fleet`).
        check_against : FleetPrior, optional
            What the fleet check (``fleet_check_``) is made against: the prior of the other
            axes (:func:`pool_fleet_without`). None: ``fleet`` itself, this axis included (a
            worn axis then inflates the allowances it is checked against; the notes say so).

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> fleet = [IndicatorModel().fit(robot.capture(t, seed=0),
        ...                               [robot.capture(t, seed=k) for k in range(1, 6)])
        ...          for t in range(4)]
        >>> model = fleet[0].use_fleet(pool_fleet(fleet),
        ...                            check_against=pool_fleet_without(fleet, 0))
        >>> model.fleet.n_axes, model.fleet_check_ is None
        (4, True)
        """
        if fleet is None and check_against is not None:
            raise ValueError(
                "The 'check_against' parameter of use_fleet needs a fleet prior to score with "
                "('fleet'). Got fleet=None instead."
            )
        self.fleet = fleet
        self._threshold_from(self.calibration_rows_, check_against)
        return self

    def _own_allowances(self) -> None:
        """The axis's allowances from its own pairs (:func:`own_pair_allowances`), when its
        prior has the fleet's centres; the prior is then kept without them (a model of a fleet of
        ``n`` axes would otherwise store ``n`` centres)."""
        self.own_allowances_: dict[str, float] = {}
        if self.fleet is None or not self.fleet.centres:
            return  # a prior a model already keeps has no centres: the fleet's allowances only
        # The axis itself is among the centres when it was pooled: its pair with itself is none.
        others = [c for c in self.fleet.centres if c != self.centre_]
        self.own_allowances_ = own_pair_allowances(
            self.centre_, self.within_, others, self.fleet, self.percentile
        )
        self.fleet = dataclasses.replace(self.fleet, centres=())

    def error_factors(self, errors: Mapping[str, float]) -> dict[str, float]:
        """How much looser than the baseline's a capture's friction readings are: per friction
        indicator scored, ``max(1, se / se_ref)`` (1 where either error is not a positive
        number); empty without ``whole_moves`` or without a fleet prior.

        With a fleet prior a capture's friction shift is taken in
        ``sqrt((s_w x factor)^2 + s_t^2)`` times its allowance: ``s_w`` belongs to readings of
        the baseline's precision (``se_ref_``, the median standard error of the fitting
        captures'), and a reading whose own least squares is looser (constant-speed moves, where
        Coulomb and viscous trade off) spreads more in proportion. Only the ratio of two
        standard errors of the same regression on the same axis enters, no constant
        (docs/evaluation.md, "Drive loads from whole moves"). The factor never lowers a spread,
        so it never raises a distance. The threshold and the leave-one-out distances of the
        fitting captures are computed without it (their ratios are about 1 by construction), as
        in the study that chose it; a capture of the baseline's task scored in the own spreads
        (``task_envelope_factor``) takes no factor either.

        Parameters
        ----------
        errors : mapping of str to float
            The capture's :attr:`~axiswatch.indicators._readings.Readings.errors`.

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> fleet = [IndicatorModel(whole_moves=True).fit(
        ...     robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)])
        ...     for t in range(4)]
        >>> model = fleet[0].use_fleet(pool_fleet(fleet))
        >>> looser = {n: 3 * se for n, se in model.se_ref_.items()}
        >>> {n: round(f, 6) for n, f in model.error_factors(looser).items()}
        {'coulomb_friction': 3.0, 'viscous_friction': 3.0}
        >>> model.use_fleet(None).error_factors(looser)
        {}
        """
        if self.fleet is None or not self.whole_moves:
            return {}
        out = {}
        for name in FRICTION:
            if name not in self.within_:
                continue
            se, reference = errors.get(name, math.nan), self.se_ref_.get(name, math.nan)
            ratio = se / reference if math.isfinite(reference) and reference > 0 else math.nan
            out[name] = max(1.0, ratio) if math.isfinite(ratio) else 1.0
        return out

    @property
    def scales_(self) -> dict[str, float]:
        """``sqrt(s_w^2 + s_t^2)`` per scored indicator (``s_w`` alone without a fleet prior)."""
        return _combined_spreads(self.within_, self.fleet)

    @property
    def allowances_(self) -> dict[str, float]:
        """Task-change allowance per scored indicator, in spreads: the fleet's
        (:meth:`FleetPrior.allowances`; its one allowance for an indicator without its own), or
        the axis's own pairs' where larger (:func:`own_pair_allowances`); empty without a
        prior."""
        return _allowances(self.within_, self.fleet, self.percentile, self.own_allowances_)

    @property
    def task_change_scales_(self) -> dict[str, float]:
        """What a task change's shift is divided by: ``sqrt(s_w^2 + s_t^2) x A_i`` (so the
        distance is in allowance units), or :attr:`scales_` without a fleet prior."""
        return _task_change_scales(self.within_, self.fleet, self.percentile, self.own_allowances_)

    def _threshold_from(
        self, rows: Sequence[Mapping[str, float]], check_against: FleetPrior | None
    ) -> None:
        self._own_allowances()
        scales = self.task_change_scales_
        self.loo_distances_ = leave_one_out_distances(rows, scales)
        # The baseline's own leave-one-out distance is checked, not fitted: a faulty baseline
        # would inflate the threshold it is checked against.
        calibration = [d for d in self.loo_distances_[1:] if math.isfinite(d)]
        self.notes_: list[str] = []
        if len(calibration) < 2:
            raise CalibrationError(
                "No indicator could be read on the baseline and calibration captures: "
                + "; ".join(f"{k} {v}" for k, v in self.reasons_.items())
            )
        fitted = fit_half_laplace(calibration).threshold(self.percentile)
        self.threshold_ = fitted
        self.own_loo_distances_ = leave_one_out_distances(rows, self.within_)
        own_calibration = [d for d in self.own_loo_distances_[1:] if math.isfinite(d)]
        self.own_threshold_ = fit_half_laplace(own_calibration).threshold(self.percentile)
        if self.task_reference_ is None and self.task_envelope_factor is not None:
            self.notes_.append(
                "the task could not be read from the motion of the fitting captures: every "
                "capture is scored as a task change"
            )
        if self.fleet is None:
            self.notes_.append(
                "no task-change allowance: fewer than 3 axes of this profile to pool; a capture "
                "whose motion is unlike the baseline's task is not compared"
                if self.task_reference_ is not None
                else "no task-change allowance: fewer than 3 axes of this profile to pool, and "
                "the task could not be read from the motion: a task change may alarm"
            )
        else:
            # In allowance units: 1 is a shift as large as a healthy task change's allowance.
            self.threshold_ = max(fitted, 1.0)
            own = sum(math.isfinite(v) for v in self.fleet.indicator_scales.values())
            self.notes_.append(
                f"task-change allowances from {self.fleet.n_axes} axes ({self.fleet.n_pairs} "
                f"ordered pairs): {own} indicators their own, the others the fleet's one allowance "
                f"{self.fleet.allowance(self.percentile):.2f} spreads; calibration threshold "
                f"{fitted:.2f} allowances"
            )
        unit = "spreads" if self.fleet is None else "allowances"
        self.baseline_check_: str | None = None
        own_distance = self.loo_distances_[0]
        if math.isfinite(own_distance) and own_distance > self.threshold_:
            self.baseline_check_ = (
                f"the baseline capture is {own_distance:.1f} {unit} from the next captures "
                f"(threshold {self.threshold_:.1f}): the median of all is the reference"
            )
        self.fleet_check_: str | None = None
        if self.fleet is not None:
            if check_against is not None:
                against = check_against
                whom = f"checked against the {against.n_axes} other axes of its profile"
            else:
                against = self.fleet
                whom = f"checked against its fleet of {against.n_axes} axes, itself included"
                self.notes_.append(
                    f"baseline {whom} (a worn axis inflates the allowances it is checked against)"
                )
            d, shifts = fleet_difference(self.centre_, self.within_, against, self.percentile)
            if math.isfinite(d) and d > 1.0:
                top = max(shifts, key=shifts.__getitem__)
                self.fleet_check_ = (
                    f"this axis's baseline differs from its fleet's: {top} "
                    f"{shifts[top]:.1f} x its task-change allowance (already worn, or a task "
                    f"unlike the fleet's); {whom}"
                )
                self.notes_.append(self.fleet_check_)

    def assess(self, capture: Capture) -> IndicatorAssessment:
        """Distance, threshold, alarm and per-indicator details of one capture."""
        return self.assess_readings(self.readings(capture))

    def assess_readings(self, readings: Readings) -> IndicatorAssessment:
        """:meth:`assess` from readings already taken: with the own spreads and threshold when
        the capture's motion is the baseline's task, else with the fleet's."""
        distance = math.nan
        if self.task_reference_ is not None and len(readings.signature):
            signature = np.asarray(readings.signature, dtype=np.float64)
            distance = signature_distance(signature, self.task_reference_)
        changed = math.isfinite(distance) and distance > self.task_envelope_
        if changed and self.fleet is None:
            return self._not_compared(distance)
        if self.task_envelope_factor is not None and math.isfinite(distance) and not changed:
            case = "same task as the baseline: own spreads"
        else:
            known = (
                "no task envelope"
                if self.task_envelope_factor is None
                else "task changed"
                if changed
                else "task not read from the motion"
            )
            case = f"{known}: {'fleet allowance' if self.fleet is not None else 'no fleet prior'}"
        values, reasons = _transformed(readings), dict(readings.reasons)
        if self.order_lines:
            values[ORDER_LINES.name], why = self._order_lines(readings)
            if why is not None:
                reasons[ORDER_LINES.name] = why
        assessment = self._assess(
            values, reasons, self.centre_, own=case.startswith("same"), errors=readings.errors
        )
        component = assessment.component
        if assessment.top == ORDER_LINES.name:
            component = self._where_grown(readings)
        return dataclasses.replace(
            assessment,
            case=case,
            task_distance=distance,
            task_envelope=self.task_envelope_,
            component=component,
        )

    def _not_compared(self, task_distance: float) -> IndicatorAssessment:
        """A capture of another task on an axis without a fleet prior: nothing says what a task
        change does to its indicators (docs/evaluation.md, "An axis without a fleet")."""
        why = (
            f"unlike the baseline's task (task signature {task_distance:.2f} beyond its "
            f"envelope {self.task_envelope_:.2f}, as shares of the baseline's top speed, "
            "stroke or time moving): with fewer than 3 axes of this profile "
            "nothing says what a task change does to the indicators, so it is not compared "
            "(rebaseline the axis on its new task, monitor 3 axes of its profile, or run "
            "the monitor with --modes, which learns each task as a mode)"
        )
        return IndicatorAssessment(
            distance=math.nan,
            threshold=self.threshold_,
            alarm=False,
            top=None,
            component=None,
            indicators={},
            unavailable={"motion": why},
            case="task changed: no fleet prior",
            task_distance=task_distance,
            task_envelope=self.task_envelope_,
        )

    def _where_grown(self, readings: Readings) -> str:
        """Where the order lines grew most and, with the profile's kinematics, the component
        with a line there."""
        # order_lines is read only when both are there.
        assert readings.order_profile is not None
        assert self.order_reference_ is not None
        order = most_grown_order(readings.order_profile, self.order_reference_)
        where = f"new or grown order lines, most at order {order:.4g}"
        kinematics = self.profile.kinematics() if self.profile is not None else {}
        if kinematics.get("gear_ratio") is None:
            return where
        name = component_at(
            order,
            kinematics["gear_ratio"],
            kinematics["gear_stages"],
            kinematics["bearing_orders"],
        )
        return f"{where}: {name}" if name is not None else f"{where} (no component's line there)"

    def _order_lines(self, readings: Readings) -> tuple[float, str | None]:
        """The capture's ``order_lines`` against the baseline's reference, or why none."""
        if readings.order_profile is None:
            return math.nan, readings.reasons.get(
                ORDER_LINES.name, "not read (the readings were taken without order_lines)"
            )
        if self.order_reference_ is None:
            return math.nan, "the baseline's captures gave no order spectrum"
        value = grown_lines(readings.order_profile, self.order_reference_)
        if not math.isfinite(value):
            return math.nan, (
                f"shares fewer than {MIN_COMMON_CELLS} order cells with the baseline's spectrum "
                "(the speeds differ too much)"
            )
        return value, None

    def assess_fitting(self, index: int) -> IndicatorAssessment:
        """Leave-one-out assessment of the ``index``-th capture the model was fitted on (0: the
        baseline): against the median of the others, in the own spreads (a fitting capture is
        the baseline's task by definition), so its distance is ``own_loo_distances_[index]``.

        Examples
        --------
        >>> from axiswatch.datasets import draw_robot
        >>> robot = draw_robot(0)
        >>> model = IndicatorModel().fit(robot.capture(0, seed=0),
        ...                              [robot.capture(0, seed=k) for k in range(1, 6)])
        >>> model.assess_fitting(2).distance == model.own_loo_distances_[2]
        True
        """
        rows = self.calibration_rows_
        if not 0 <= index < len(rows):
            raise IndexError(
                f"The 'index' parameter must be in [0, {len(rows)}) (captures fitted on). "
                f"Got {index!r} instead."
            )
        centre = _centre_without(rows, index, list(self.within_))
        assessment = self._assess(rows[index], self.fit_readings_[index].reasons, centre, own=True)
        return dataclasses.replace(
            assessment,
            case="same task as the baseline: own spreads",
            task_distance=self.task_loo_distances_[index],
            task_envelope=self.task_envelope_,
        )

    def _assess(
        self,
        values: Mapping[str, float],
        reasons: Mapping[str, str],
        centre: Mapping[str, float],
        *,
        own: bool,
        errors: Mapping[str, float] | None = None,
    ) -> IndicatorAssessment:
        factors = {} if own else self.error_factors(errors or {})
        if factors:
            within = {n: s * factors.get(n, 1.0) for n, s in self.within_.items()}
            scales = _task_change_scales(within, self.fleet, self.percentile, self.own_allowances_)
        else:
            scales = self.within_ if own else self.task_change_scales_
        threshold = self.own_threshold_ if own else self.threshold_
        allowances = {} if own else self.allowances_
        distance, shifts = _distance(values, centre, scales)
        unavailable = {
            name: reasons.get(name, self.reasons_.get(name, "not read"))
            for name in values
            if name not in shifts
        }
        # Exactly rounded: a stored model lists its indicators in another order, and a plain
        # sum's last bit (so the shares') would depend on it.
        total = math.fsum(shifts.values())
        details: dict[str, dict[str, float]] = {
            name: {
                "value": values[name],
                "baseline": centre[name],
                "spreads": z * allowances.get(name, 1.0),
                "share": z / total if total > 0 else 0.0,
            }
            for name, z in shifts.items()
        }
        for name, entry in details.items():
            if name in allowances:
                entry["allowance"] = allowances[name]
            if factors.get(name, 1.0) > 1.0:
                entry["error_factor"] = factors[name]
        top = max(shifts, key=shifts.__getitem__) if shifts else None
        return IndicatorAssessment(
            distance=distance,
            threshold=threshold,
            alarm=bool(math.isfinite(distance) and distance > threshold),
            top=top,
            component=_declared(top).component if top is not None else None,
            indicators=details,
            unavailable=unavailable,
        )

    def params(self) -> dict[str, Any]:
        """JSON-ready description of what was estimated and from what (with ``whole_moves``,
        also ``whole_moves`` and ``se_ref``)."""
        params = {
            "centre": self.centre_,
            "within_spread": self.within_,
            "scales": self.scales_,
            "allowances": self.allowances_,
            "threshold": self.threshold_,
            "own_threshold": self.own_threshold_,
            "task_envelope": self.task_envelope_,
            "baseline_check": self.baseline_check_,
            "fleet_check": self.fleet_check_,
            "notes": self.notes_,
        }
        if self.whole_moves:  # absent otherwise: the default's description is as before
            params.update(whole_moves=True, se_ref=self.se_ref_)
        return params


if TYPE_CHECKING:  # checked by mypy: the product default is a model of an axis
    _CONFORMS: type[AxisModel] = IndicatorModel
