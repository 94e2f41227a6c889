"""The monitor's decision for one capture: a pure function of the axis's history and distance.

:func:`decide` gives the role, threshold, over, alarm state and reason. The store calls it
inside the transaction that writes the capture, so a killed run resumes exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from axiswatch._calibration import HalfLaplaceFit, Threshold, alarm_threshold
from axiswatch.exceptions import CalibrationError

__all__ = [
    "AxisHistory",
    "Decision",
    "DecisionRule",
    "Role",
    "alarm_step",
    "decide",
    "stored_threshold",
]

Role = Literal["calibration", "monitor", "excluded"]


@dataclass(frozen=True)
class DecisionRule:
    """The rules a decision follows (the monitor's parameters that decide, nothing else).

    Attributes
    ----------
    percentile : float in (0, 100)
        Threshold percentile of the half-Laplace fit of the calibration distances.
    calibration_size : int
        ``K``: calibration captures after the baseline.
    alarm_k, alarm_n : int
        Raise the alarm when at least ``k`` of the last ``n`` captures are over.
    clear_m : int
        Clear it after ``m`` captures in a row under the threshold.
    floor : float or None
        Least threshold (:func:`axiswatch._calibration.alarm_threshold`); None: no floor.
    """

    percentile: float = 99.0
    calibration_size: int = 5
    alarm_k: int = 1
    alarm_n: int = 1
    clear_m: int = 1
    floor: float | None = None

    @property
    def window(self) -> int:
        """How many recent monitored captures a decision needs: ``max(n, m)``."""
        return max(self.alarm_n, self.clear_m)


@dataclass(frozen=True)
class AxisHistory:
    """What the store holds about one baseline of an axis, as a decision needs it.

    Attributes
    ----------
    threshold : float or None
        The baseline's threshold; None while it is calibrating.
    fit : HalfLaplaceFit or None
        The half-Laplace fit that set it.
    calibration_distances : tuple of float
        Distances of the baseline's calibration captures, in scoring order.
    recent : tuple of (bool, bool)
        ``(over, alarm)`` of the last ``DecisionRule.window`` monitored captures, oldest first.
    alarmed_before : bool
        The capture now decided raised an alarm under an earlier baseline of the axis.
    """

    threshold: float | None = None
    fit: HalfLaplaceFit | None = None
    calibration_distances: tuple[float, ...] = ()
    recent: tuple[tuple[bool, bool], ...] = ()
    alarmed_before: bool = False


@dataclass(frozen=True)
class Decision:
    """Role, threshold, over, alarm and reason of one capture.

    Attributes
    ----------
    role : {"calibration", "monitor", "excluded"}
    threshold : float or None
        The threshold the capture was compared with (for the capture that completes the
        calibration, the one it set).
    over, alarm : bool
    reason : str
    calibrated : Threshold or None
        Set when this capture completes the calibration: the store records it as the baseline's
        threshold and gives it to every calibration capture of the baseline.
    details : dict
        Added to the capture's details (``pvalue`` of a monitored capture).
    """

    role: Role
    threshold: float | None
    over: bool
    alarm: bool
    reason: str
    calibrated: Threshold | None = None
    details: dict[str, Any] = field(default_factory=dict)


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


def _percentile_text(percentile: float) -> str:
    return f"{percentile:g}th pct"


def decide(
    history: AxisHistory, distance: float, rule: DecisionRule, *, top_indicator: str | None = None
) -> Decision:
    """Role, threshold, over, alarm and reason of a capture at ``distance`` from the baseline.

    While the baseline has no threshold, the capture calibrates (assumed healthy; the
    ``calibration_size``-th sets the threshold by :func:`~axiswatch._calibration.alarm_threshold`)
    unless it raised an alarm under an earlier baseline (role ``excluded``, never used). Once the
    threshold is set, the capture is monitored: over when ``distance > threshold``, the alarm
    raised when ``alarm_k`` of the last ``alarm_n`` are over and cleared after ``clear_m`` clean
    captures in a row (:func:`alarm_step`).

    The reason of a monitored capture names where its threshold comes from
    (:meth:`~axiswatch._calibration.Threshold.describe`: the fitted percentile or the task-change
    allowance) and, when the capture is over or in alarm, ``top_indicator``.

    Parameters
    ----------
    history : AxisHistory
    distance : float
    rule : DecisionRule
    top_indicator : str or None, default=None
        The indicator that explains most of the distance, in words
        (:func:`~axiswatch.paper._attribution.describe_top_indicator`); None when there is none.

    Returns
    -------
    Decision

    Examples
    --------
    >>> rule = DecisionRule(calibration_size=2)
    >>> first = decide(AxisHistory(), 1.0, rule)
    >>> first.role, first.threshold
    ('calibration', None)
    >>> second = decide(AxisHistory(calibration_distances=(1.0,)), 3.0, rule)
    >>> round(second.threshold, 4)  # 99th percentile of a half-Laplace of scale 2: 2 ln(100)
    9.2103
    >>> fitted = AxisHistory(threshold=second.threshold, fit=second.calibrated.fit)
    >>> decide(fitted, 10.0, rule).reason
    'distance 10 > threshold 9.21 (99th pct of half-Laplace fit of 2 healthy captures); ALARM raised'
    >>> decide(fitted, 10.0, rule, top_indicator="bearing_lines +9.8").reason.split("; ")[1]
    'top indicator bearing_lines +9.8'
    """
    if history.threshold is None:
        return _calibrate(history, distance, rule)
    assert history.fit is not None, "a baseline with a threshold has a fit"
    return _monitor(history.threshold, history.fit, history.recent, distance, rule, top_indicator)


def _calibrate(history: AxisHistory, distance: float, rule: DecisionRule) -> Decision:
    if history.alarmed_before:
        reason = (
            f"distance {distance:.4g}; not used for calibration: this capture raised an "
            "alarm under an earlier baseline"
        )
        return Decision("excluded", None, False, False, reason)
    healthy = [*history.calibration_distances, distance]
    count, size = len(healthy), rule.calibration_size
    reason = f"calibration capture {count} of {size}: distance {distance:.4g}, assumed healthy"
    if count < size:
        return Decision("calibration", None, False, False, reason)
    try:
        threshold = alarm_threshold(healthy, percentile=rule.percentile, floor=rule.floor)
    except CalibrationError as exc:
        return Decision(
            "calibration", None, False, False, f"{reason}; threshold not set yet ({exc})"
        )
    reason += (
        f"; threshold set to {threshold.fitted:.4g} ({_percentile_text(rule.percentile)} of the "
        f"half-Laplace fit of {count} healthy distances)"
    )
    if threshold.origin == "floor":
        reason += (
            f", raised to the floor {threshold.value:.4g} that healthy task changes need "
            "(development protocol, docs/evaluation.md)"
        )
    return Decision("calibration", threshold.value, False, False, reason, calibrated=threshold)


def stored_threshold(threshold: float, fit: HalfLaplaceFit, rule: DecisionRule) -> Threshold:
    """The :class:`Threshold` a stored value came from: the fitted percentile, or the floor
    where it is above the fit's (``alarm_threshold`` takes the larger)."""
    origin: Literal["fit", "floor"] = (
        "floor" if threshold > fit.threshold(rule.percentile) else "fit"
    )
    return Threshold(threshold, fit, rule.percentile, fit.n_distances, rule.floor, origin)


def _monitor(
    threshold: float,
    fit: HalfLaplaceFit,
    history: Sequence[tuple[bool, bool]],
    distance: float,
    rule: DecisionRule,
    top_indicator: str | None,
) -> Decision:
    over = bool(distance > threshold)
    k, n, m = rule.alarm_k, rule.alarm_n, rule.clear_m
    recent = [bool(was_over) for was_over, _ in history] + [over]
    previous = bool(history[-1][1]) if history else False
    alarm = alarm_step(previous, recent, k=k, n=n, m=m)
    comparison = ">" if over else "<="
    origin = stored_threshold(threshold, fit, rule)
    reason = f"distance {distance:.4g} {comparison} threshold {threshold:.4g} ({origin.describe()})"
    if (over or alarm) and top_indicator is not None:
        reason += f"; top indicator {top_indicator}"
    if n > 1:
        reason += f"; {sum(recent[-n:])} of last {min(n, len(recent))} over"
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
    return Decision(
        "monitor", threshold, over, alarm, reason, details={"pvalue": fit.pvalue(distance)}
    )
