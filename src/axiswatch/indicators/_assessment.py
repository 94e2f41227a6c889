"""IndicatorAssessment: the verdict of an IndicatorModel on one capture, and its reason in words."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from axiswatch._axis_model import Assessment

__all__ = ["IndicatorAssessment", "grouped_reasons"]


def grouped_reasons(reasons: Mapping[str, str]) -> str:
    """Why indicators are not read, a reason shared by several said once.

    Examples
    --------
    >>> grouped_reasons({"a": "needs motion", "b": "needs motion", "c": "needs torque"})
    'a, b: each needs motion; c needs torque'
    """
    names: dict[str, list[str]] = {}
    for name, why in reasons.items():
        names.setdefault(why, []).append(name)
    return "; ".join(
        f"{group[0]} {why}" if len(group) == 1 else f"{', '.join(group)}: each {why}"
        for why, group in names.items()
    )


@dataclass(frozen=True)
class IndicatorAssessment(Assessment):
    """Verdict of an :class:`~axiswatch.IndicatorModel` on one capture (``leading`` is ``top``).

    Attributes
    ----------
    distance : float
        Largest shift, in spreads; with the fleet's allowances (a task change), the largest
        shift in units of its indicator's allowance; NaN when no indicator could be scored.
    threshold : float
        In the distance's units.
    alarm : bool
    top : str or None
        The indicator with the largest shift.
    component : str or None
        What ``top`` watches.
    indicators : dict
        Per indicator read: ``value``, ``baseline`` (the centre), ``spreads`` (the shift, in
        spreads), ``share`` (its part of the sum of the shifts in the distance's units) and,
        with the fleet's allowances, ``allowance`` (its task-change allowance, in spreads) and,
        with ``whole_moves``, for a friction reading looser than the baseline's,
        ``error_factor`` (how much its within-task spread was widened:
        :meth:`IndicatorModel.error_factors`).
    unavailable : dict of str to str
        Indicators not scored, and why.
    case : str
        Which spreads and threshold applied, in words: ``"same task as the baseline: own
        spreads"``, ``"task changed: fleet allowance"``, ``"task not read from the motion:
        fleet allowance"`` or, with the envelope off, ``"no task envelope: fleet allowance"``
        (``"...: no fleet prior"`` without one); ``"task changed: no fleet prior"`` for a
        capture of another task on an axis without a fleet prior, which is not scored.
    task_distance : float
        Signature distance from the baseline's task (NaN when not read), against
        ``task_envelope``.
    task_envelope : float
        The baseline task's envelope (NaN when its signature could not be read).
    """

    distance: float
    threshold: float
    alarm: bool
    top: str | None
    component: str | None
    indicators: dict[str, dict[str, float]]
    unavailable: dict[str, str] = field(default_factory=dict)
    case: str = "task changed: fleet allowance"
    task_distance: float = math.nan
    task_envelope: float = math.nan

    def __post_init__(self) -> None:
        object.__setattr__(self, "leading", self.top)

    @property
    def same_task(self) -> bool:
        """Whether the capture was scored as the baseline's task (own spreads)."""
        return self.case.startswith("same task")

    def reason(self) -> str:
        """One line: what moved, or why nothing could be scored."""
        if not self.scored:
            # One reason shared by every indicator (no motion) is said once, not once each.
            return "not scored: " + grouped_reasons(self.unavailable)
        assert self.top is not None
        entry = self.indicators[self.top]
        # Without an envelope every capture is scored one way: the case says nothing (details
        # keep it).
        case = "" if self.case.startswith("no task envelope") else f"{self.case}; "
        part = f" ({self.component})" if self.component is not None else ""
        moved = f"{case}{self.top}{part} {entry['spreads']:.1f} spreads from its baseline"
        if "allowance" in entry:
            return (
                f"{moved}, {entry['spreads'] / entry['allowance']:.2f} x its task-change "
                f"allowance of {entry['allowance']:.1f} (threshold {self.threshold:.2f} x)"
            )
        return f"{moved} (threshold {self.threshold:.1f} spreads)"
