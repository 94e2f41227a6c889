"""Indicators the scored captures could not give, tallied per axis to be said once per axis."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["UnreadIndicators"]

#: Not an indicator: a capture of another task that was not compared says so in its own row.
NOT_COMPARED = "motion"


@dataclass
class UnreadIndicators:
    """Per axis (``robot/axis``): the captures scored and, per indicator not read on some, on
    how many and the first reason given.

    Examples
    --------
    >>> unread = UnreadIndicators()
    >>> unread.add("r1/a1", {"impulsiveness": "needs a torque rate >= 100 Hz (got 20 Hz)"})
    >>> unread.add("r1/a1", {})
    >>> unread.scored["r1/a1"], unread.missing["r1/a1"]
    (2, {'impulsiveness': (1, 'needs a torque rate >= 100 Hz (got 20 Hz)')})
    """

    scored: dict[str, int] = field(default_factory=dict)
    missing: dict[str, dict[str, tuple[int, str]]] = field(default_factory=dict)

    def add(self, axis: str, unavailable: Mapping[str, str]) -> None:
        """Count one scored capture of ``axis`` and the indicators it could not give."""
        self.scored[axis] = self.scored.get(axis, 0) + 1
        mine = self.missing.setdefault(axis, {})
        for name, why in unavailable.items():
            if name != NOT_COMPARED:
                count, first = mine.get(name, (0, why))
                mine[name] = (count + 1, first)

    def add_details(self, axis: str, details: Mapping[str, Any]) -> None:
        """:meth:`add` from a score's details; a method that keeps no ``unavailable`` counts
        nothing (the paper's read every capture whole)."""
        if "unavailable" in details:
            self.add(axis, details["unavailable"])

    @classmethod
    def from_results(cls, frame: pd.DataFrame) -> UnreadIndicators:
        """The tally of the scored rows of ``fleet_results``: per axis, and per method where
        the rows hold more than one."""
        unread = cls()
        several = frame["method"].nunique() > 1
        for robot, axis, method, role, details in zip(
            frame["robot"], frame["axis"], frame["method"], frame["role"], frame["details"],
            strict=True,
        ):  # fmt: skip
            if role != "baseline":
                key = f"{robot}/{axis}" + (f" ({method})" if several else "")
                unread.add_details(key, json.loads(details))
        return unread

    def axes(self) -> Iterable[tuple[str, int, dict[str, tuple[int, str]]]]:
        """``(axis, captures scored, {indicator: (captures without it, first reason)})`` for
        every axis with an indicator not read, in the order they were first scored."""
        for axis, missing in self.missing.items():
            if missing:
                yield axis, self.scored[axis], missing
