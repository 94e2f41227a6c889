"""A verdict per axis in a service engineer's words: state, fault, part, since when, how sure.

Pipeline side-stage of the report and the terminal summary. It presents the monitor's alarms
(:mod:`~axiswatch.monitor.report.attention`) and changes no score and no alarm. An alarm is "act now"
once confirmed, else "watch, unconfirmed". The words come from
:data:`~axiswatch.monitor.report.advice.ADVICE`.
"""

from __future__ import annotations

import json
import textwrap
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import timedelta
from typing import Any

import pandas as pd

from axiswatch.monitor._feedback import feedback_words
from axiswatch.monitor.report.advice import TASK_CHANGE_HINT, advice_for, part_words
from axiswatch.monitor.report.attention import AxisAttention, triage
from axiswatch.monitor.report.results import fleet_rejections, fleet_results, fleet_summary
from axiswatch.monitor.store import AlarmState, StoreBackend

__all__ = [
    "CONFIRM_CAPTURES",
    "LARGE_MARGIN",
    "STATES",
    "Verdict",
    "attention_lines",
    "axis_verdicts",
    "fleet_verdicts",
]

#: Verdict states, most urgent first. ``act now``: a confirmed alarm, or a fault the engineer
#: confirmed. ``bad data``: rejected or changed files, no baseline, no new captures: the axis is
#: blind, so it ranks above ``watch``: an unconfirmed excursion, an alarm someone judged, or a
#: baseline to check. ``learning``: the alarm level is not set yet.
STATES: tuple[str, ...] = ("act now", "bad data", "watch", "learning", "OK")
#: Captures in a row over the alarm level that confirm an alarm. A healthy capture passes the
#: 99th-percentile level about 1 time in 100; two in a row about 1 time in 10,000.
CONFIRM_CAPTURES = 2
#: Times the alarm level at which one capture confirms an alarm: under the half-Laplace fit that
#: sets the level, a healthy capture gets that far about 1 time in 10,000, as two in a row do.
LARGE_MARGIN = 2.0
#: Captures before an excursion that say how it developed.
BEFORE_CAPTURES = 5
#: Rise over the captures before an excursion, in alarm levels, that reads as "built up".
BUILD_UP = 0.25
#: Columns of the terminal summary's lines.
WIDTH = 100


@dataclass(frozen=True)
class Verdict:
    """One axis's verdict.

    Attributes
    ----------
    robot, axis, method : str
    kind : str
        The monitor's own state of the axis (:data:`~axiswatch.monitor.report.attention.KINDS`).
    state : str
        One of :data:`STATES`.
    confirmed : bool
        An alarm's excursion is confirmed (False for "watch, unconfirmed"); True otherwise.
    fault : str
        The suspected fault in words; empty when there is none.
    component : str
        The part to look at; empty when there is none.
    action : str
        What to do.
    since : str
        Since when, and how it developed.
    sureness : str
        How sure: how far over, for how many captures, how often earlier captures got there.
    feedback : str
        The engineer's acknowledgement, if any.
    details : str
        The monitor's technical line (code names and statistics): shown folded.
    indicator : str or None
        Code name of the indicator behind the fault (its colour).
    severity : float
        Last capture over its alarm level (NaN when unknown).
    last_capture_at : str or None
    """

    robot: str
    axis: str
    method: str
    kind: str
    state: str
    confirmed: bool
    fault: str
    component: str
    action: str
    since: str
    sureness: str
    feedback: str
    details: str
    indicator: str | None
    severity: float
    last_capture_at: str | None

    @property
    def label(self) -> str:
        """The state as shown: ``watch, unconfirmed`` for an excursion not confirmed yet."""
        return self.state if self.confirmed else f"{self.state}, unconfirmed"

    @property
    def needs_attention(self) -> bool:
        """Act now, bad data or watch."""
        return self.state in STATES[:3]

    @property
    def headline(self) -> str:
        """The fault and the part to look at (empty when neither)."""
        if self.fault and self.component:
            return f"{_capital(self.fault)}. Suspected: {self.component}."
        return f"{_capital(self.fault or self.component)}." if self.fault or self.component else ""

    def sentences(self) -> list[str]:
        """The verdict's lines, as the report's first screen and the terminal show them."""
        return [
            text
            for text in (
                self.headline,
                f"What to do: {self.action}" if self.action else "",
                self.since,
                f"How sure: {self.sureness}" if self.sureness else "",
                self.feedback,
            )
            if text
        ]


#: How a rejection says the model did not compare a capture of other motion (the indicators'
#: task envelope on an axis without a fleet).
OTHER_MOTION = "motion unlike the baseline's task"
#: How the line of an axis learning a new operating mode starts (``MonitorConfig.modes``).
NEW_MODE = "Learning new mode"
#: Axes learning a new mode listed by name in the terminal's summary; the others counted.
LISTED_NEW_MODES = 10


def _capital(text: str) -> str:
    return text[:1].upper() + text[1:]


def _day(stamp: Any) -> str:
    return "" if stamp is None or stamp is pd.NA else str(stamp)[:10]


def _times(level: float) -> str:
    """A level in alarm levels, to the digits a person reads.

    Examples
    --------
    >>> _times(1.2345), _times(2445.1)
    ('1.2', '2445')
    """
    return f"{level:.1f}" if level < 100 else f"{level:.0f}"


def _axes(n: int) -> str:
    return "1 axis" if n == 1 else f"{n} axes"


def _top(details: dict[str, Any]) -> tuple[str | None, bool]:
    """The indicator with the largest share of a score's distance, and whether it rose."""
    entries = details.get("indicators") or {}
    moved = [(e.get("share", 0.0), name) for name, e in entries.items()]
    if not moved:
        return None, True
    _, name = max(moved)
    entry = entries[name]
    rose = not (entry.get("value", 0.0) < entry.get("baseline", 0.0))
    return name, rose


def _also(details: dict[str, Any], top: str | None, fault: str) -> list[str]:
    """Other faults whose indicator alone reaches the alarm level (method ``indicators``)."""
    limit = float(details.get("threshold_spreads", 0.0) or 0.0)
    if limit <= 0:
        return []
    found = []
    for name, entry in (details.get("indicators") or {}).items():
        level = entry["spreads"] / float(entry.get("allowance", 1.0)) / limit
        if name == top or level < 1.0:
            continue
        row = advice_for(name)
        words = row.rising if entry["value"] >= entry["baseline"] else row.falling
        if words != fault and words not in found:
            found.append(words)
    return found


def _excursion(own: pd.DataFrame) -> dict[str, Any]:
    """An axis's last excursion over its alarm level: the run of captures over it, the
    captures before and the levels (distance over alarm level)."""
    scored = own.dropna(subset=["distance"])
    monitored = scored[scored.role == "monitor"]
    last = monitored.iloc[-1]
    limit = float(last["threshold"])
    over = monitored.over.to_numpy(dtype=bool)
    run = 0
    while run < len(over) and over[len(over) - 1 - run]:
        run += 1
    first = monitored.iloc[len(monitored) - max(run, 1)]
    earlier = scored[scored.captured_at < first["captured_at"]]
    before = monitored[monitored.captured_at < first["captured_at"]].tail(BEFORE_CAPTURES)
    return {
        "last": last,
        "run": run,
        "first": first,
        "levels": (monitored.distance.tail(max(run, 1)) / limit).tolist(),
        "earlier": list(
            zip(map(_day, earlier.captured_at), earlier.distance / limit, strict=False)
        ),
        "before": (before.distance / limit).tolist(),
    }


def _development(found: dict[str, Any]) -> str:
    """Since when, and how the excursion developed."""
    run, levels, before = found["run"], found["levels"], found["before"]
    if run == 0:
        return (
            f"In alarm, but the last capture ({_day(found['last']['captured_at'])}) is back "
            f"under the alarm level, at {levels[-1]:.1f} of it."
        )
    start = _day(found["first"]["captured_at"])
    if run == 1:
        text = f"Over the alarm level on its last capture only ({start})."
    else:
        trend = (
            "rising"
            if levels[-1] > 1.1 * levels[0]
            else "easing"
            if levels[-1] < 0.9 * levels[0]
            else "steady"
        )
        text = f"Over the alarm level since {start} ({run} captures), {trend}."
    if len(before) >= 2:
        typical = float(pd.Series(before).median())
        if before[-1] - before[0] >= BUILD_UP and before[-1] >= 0.5:
            text += (
                f" It built up over the {len(before)} captures before, from "
                f"{before[0]:.1f} to {before[-1]:.1f} of the alarm level."
            )
        elif typical < 0.5:
            text += (
                f" It came suddenly: the {len(before)} captures before stood at about "
                f"{typical:.1f} of the alarm level."
            )
        else:
            text += (
                f" The {len(before)} captures before were already close, at about "
                f"{typical:.1f} of the alarm level."
            )
    return text


def _sureness(found: dict[str, Any], confirmed: bool) -> str:
    """How far over, for how many captures, and how often earlier captures got that far."""
    run, level, earlier = found["run"], found["levels"][-1], found["earlier"]
    far = [day for day, e in earlier if e >= level]
    when = f" ({', '.join(far)})" if 0 < len(far) <= 3 else ""
    history = (
        f"{len(far) or 'None'} of this axis's {len(earlier)} earlier captures got that far{when}."
    )
    if run == 0:
        return f"{_times(level)} of the alarm level on the last capture. {history}"
    if not confirmed and run == 1:
        return (
            f"{_times(level)} times the alarm level on one capture: unconfirmed until the next "
            f"capture. {history}"
        )
    if not confirmed:  # over the level, but the monitor's alarm rule has not fired yet
        return (
            f"{_times(level)} times the alarm level, {run} captures in a row: not an alarm yet "
            f"under the monitor's rule. {history}"
        )
    why = f"{run} captures in a row" if run >= CONFIRM_CAPTURES else "a large margin"
    return f"{_times(level)} times the alarm level, confirmed by {why}. {history}"


def _fault_verdict(item: AxisAttention, own: pd.DataFrame, alarm: AlarmState | None) -> Verdict:
    """The verdict of an axis with an excursion: in alarm, acknowledged, or over the level."""
    found = _excursion(own)
    run, level = found["run"], found["levels"][-1]
    run_rows = own[(own.role == "monitor") & own.over].tail(max(run, 1))
    parsed = [json.loads(d) for d in run_rows.details] or [json.loads(found["last"]["details"])]
    tops = [_top(p) for p in parsed]
    counts = Counter(name for name, _ in tops)
    best = max(counts.values())
    # The indicator behind most of the excursion's captures, the latest on a tie.
    index = max(i for i, (name, _) in enumerate(tops) if counts[name] == best)
    name, rose = tops[index]
    details = parsed[index]
    row = advice_for(name)
    fault = row.rising if rose else row.falling
    part = part_words(name, details.get("component")) if name else ""
    component = row.component.format(part=part)
    advice = (row.action if rose else row.action_falling).format(part=part)
    also = _also(parsed[-1], name, fault)
    if also:
        advice += f" Also moved: {', '.join(also)}."
    sure = run >= CONFIRM_CAPTURES or (run >= 1 and level >= LARGE_MARGIN)
    # Over the level without an alarm (a k-of-n rule not met yet): never more than "watch".
    sure &= alarm is not None
    state, confirmed, feedback = ("act now" if sure else "watch"), sure, ""
    action = advice if sure else (
        "Nothing yet: a second capture over the alarm level confirms it. If it does: "
        + advice[:1].lower() + advice[1:]
    )  # fmt: skip
    if alarm is not None and alarm.acknowledged:
        feedback = feedback_words(
            alarm.verdict, str(alarm.acknowledged_by), str(alarm.acknowledged_at), str(alarm.note)
        )
        # A person judged it: more captures no longer decide, the judgement does.
        state, confirmed = "watch", True
        if alarm.verdict == "fault-confirmed":
            # The engineer found a fault: no longer a payload change to record.
            repair = advice.replace(f" {TASK_CHANGE_HINT}", "")
            state, action = "act now", f"{repair} After the repair: axiswatch ack --rebaseline."
        elif alarm.verdict == "false-alarm":
            action = "None while it stays as seen; an alarm raised again is news."
        elif alarm.verdict == "task-changed":
            action = "If the new task stays, re-baseline the axis: axiswatch ack --rebaseline."
    measured = f" The indicator {name} reads {row.measures}." if name else ""
    return Verdict(
        item.robot, item.axis, item.method, item.kind, state, confirmed, fault, component, action,
        _development(found), _sureness(found, sure), feedback, item.line + measured, name,
        item.severity, item.last_capture_at,
    )  # fmt: skip


def _other_verdict(item: AxisAttention) -> Verdict:
    """The verdict of an axis without an excursion: bad data, a baseline check, learning, OK."""
    problems = set(item.problems)
    if item.kind in ("bad data", "stale"):
        if "bad data" in problems and OTHER_MOTION in item.line:
            # Not a file to fix: the axis moved otherwise, by a new task or by a fault.
            fault = "captures not scored: the axis moved unlike its baseline"
            action = (
                "If its task changed for good, re-baseline it ('axiswatch rebaseline') or "
                "monitor 3 axes of its profile. If its task did not change, the motion did: "
                "check the drive and its load before re-baselining."
            )
        elif "bad data" in problems:
            fault = "capture files rejected or changed"
            action = (
                "Fix the export or the axis profile; 'axiswatch rejections' lists the files "
                "and '--ack' marks them seen."
            )
        else:
            fault = "no new captures"
            action = "Check the logger and the file share that deliver this axis's captures."
        # The monitor's line says which files and why, in words: shown, not folded.
        return Verdict(
            item.robot, item.axis, item.method, item.kind, "bad data", True, fault, "",
            action, item.line, "", "", "", None, item.severity, item.last_capture_at,
        )  # fmt: skip
    if item.kind == "baseline check":
        return Verdict(
            item.robot, item.axis, item.method, item.kind, "watch", True,
            "baseline to check: the axis may not have been healthy when it was recorded", "",
            "Check the axis; if it was worn, re-baseline it after maintenance. 'axiswatch rejections --ack' marks it seen.",
            f"Last capture {_day(item.last_capture_at) or 'none'}.", "", "", item.line, None,
            item.severity, item.last_capture_at,
        )  # fmt: skip
    if item.kind == "calibrating" and item.line.startswith(NEW_MODE):
        return Verdict(
            item.robot, item.axis, item.method, item.kind, "learning", True, "", "",
            "None: a guard watches it meanwhile; if it alarms, 'axiswatch ack --task-changed' "
            "teaches a mode change, '--fault-confirmed' keeps it a fault.",
            item.line.split(";")[0] + ".", "", "", item.line, None, item.severity,
            item.last_capture_at,
        )  # fmt: skip
    if item.kind == "calibrating":
        return Verdict(
            item.robot, item.axis, item.method, item.kind, "learning", True, "", "",
            "None: the alarm level is set once its first captures are in.",
            "Learning this axis's normal from its first captures.", "", "", item.line, None,
            item.severity, item.last_capture_at,
        )  # fmt: skip
    level = "" if item.severity != item.severity else f", at {item.severity:.1f} of the alarm level"
    return Verdict(
        item.robot, item.axis, item.method, item.kind, "OK", True, "", "", "",
        f"Last capture {_day(item.last_capture_at)}{level}.", "", "", item.line, None,
        item.severity, item.last_capture_at,
    )  # fmt: skip


def axis_verdicts(
    items: Sequence[AxisAttention], results: pd.DataFrame, alarms: Sequence[AlarmState]
) -> list[Verdict]:
    """Every axis's verdict, ranked: by state, confirmed first, then by how far over.

    Parameters
    ----------
    items : sequence of AxisAttention
        :func:`~axiswatch.monitor.report.attention.triage` of one method.
    results : DataFrame
        :func:`~axiswatch.monitor.report.results.fleet_results` (at least the items' axes).
    alarms : sequence of AlarmState
        ``StoreBackend.alarms()``: the alarms in force, with their acknowledgements.

    Returns
    -------
    list of Verdict
        Ranked by :data:`STATES`, confirmed before unconfirmed, the largest excursion first,
        then in the order of ``items``.
    """
    verdicts = []
    rows = {key: part for key, part in results.groupby(["robot", "axis", "method"], sort=False)}
    alarm_of: dict[tuple[str, str, str], AlarmState] = {}
    for a in alarms:  # the first of each axis and method, as a search in order finds
        alarm_of.setdefault((a.robot, a.axis, a.method), a)
    for item in items:
        own = rows.get((item.robot, item.axis, item.method), results.iloc[:0])
        if not own.empty:
            own = own[own.epoch == own.epoch.max()]
            own = own[own.role.isin(("calibration", "monitor"))]
        alarm = alarm_of.get((item.robot, item.axis, item.method))
        monitored = own[own.role == "monitor"].dropna(subset=["distance"]) if len(own) else own
        excursion = not monitored.empty and (
            item.kind in ("alarm", "acknowledged")
            or (item.kind == "ok" and bool(monitored.over.iloc[-1]))
        )
        verdicts.append(_fault_verdict(item, own, alarm) if excursion else _other_verdict(item))
    order = {id(v): k for k, v in enumerate(verdicts)}
    return sorted(
        verdicts,
        key=lambda v: (
            STATES.index(v.state),
            not v.confirmed,
            -v.severity if v.severity == v.severity else 0.0,
            order[id(v)],
        ),
    )


def _wrap(text: str, indent: str) -> list[str]:
    return textwrap.wrap(
        text, WIDTH, initial_indent=indent, subsequent_indent="      ", break_on_hyphens=False
    )


def attention_lines(verdicts: Sequence[Verdict], method: str) -> list[str]:
    """The terminal's summary: the axes needing attention with their verdicts, then a count.

    The same sentences as the report's first screen (:meth:`Verdict.sentences`). Axes whose
    files were rejected or changed are only counted: the run lists their files, which a first
    run of a misread export does by the hundred.
    """
    if not verdicts:  # not "0 of 0 axes" while axes calibrate before their baseline is set
        return [f"Needs attention ({method}): none; no axis has a baseline yet."]
    urgent = [v for v in verdicts if v.needs_attention]
    files = [v for v in urgent if v.state == "bad data" and v.kind == "bad data"]
    lines = [f"Needs attention ({method}): {len(urgent)} of {_axes(len(verdicts))}"]
    if files:
        lines[0] += (
            f"; {_axes(len(files))} with rejected or changed files ('axiswatch rejections' "
            "lists them)"
        )
    for verdict in urgent:
        if verdict in files:
            continue
        first, *rest = verdict.sentences() or [""]
        lines += _wrap(f"{verdict.label.upper()}  {verdict.robot}/{verdict.axis}  {first}", "  ")
        lines += [line for text in rest for line in _wrap(text, "    ")]
    calm = Counter(v.state for v in verdicts if not v.needs_attention)
    if calm:
        ranked = sorted(calm.items(), key=lambda s: STATES.index(s[0]))
        lines.append("  " + ", ".join(f"{_axes(n)} {state}" for state, n in ranked) + ".")
    modes = [v for v in verdicts if v.since.startswith(NEW_MODE)]
    lines += [f"    {v.robot}/{v.axis}: {v.since}" for v in modes[:LISTED_NEW_MODES]]
    if len(modes) > LISTED_NEW_MODES:
        lines.append(f"    and {len(modes) - LISTED_NEW_MODES} more axes learning a new mode.")
    return lines


def fleet_verdicts(
    store: StoreBackend, method: str, *, stale_after: timedelta | None = None
) -> list[Verdict]:
    """Every axis's verdict for ``method``, read from the store (:func:`axis_verdicts`).

    Parameters
    ----------
    store : StoreBackend
    method : str
    stale_after : timedelta, optional
        See :func:`~axiswatch.monitor.report.results.fleet_summary`.
    """
    summary = fleet_summary(store, stale_after=stale_after)
    results = fleet_results(store)
    alarms = store.alarms(method)
    items = triage(
        summary, results, fleet_rejections(store), store.changed_file_table(), alarms,
        method=method, checks=store.baseline_checks(method),
    )  # fmt: skip
    return axis_verdicts(items, results, alarms)
