"""Which axes need a service engineer now, and one line each on why.

The report's first screen, as pure functions of what the store holds. The kinds, most urgent
first: alarm, bad data, baseline check, stale, acknowledged. docs/internals.md, "Attention".
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import pandas as pd

from axiswatch._likely_faults import describe_top_indicator
from axiswatch.monitor.store import AlarmState, BaselineCheck

__all__ = ["KINDS", "METHOD_ORDER", "AxisAttention", "by_axis", "lead_method", "triage"]

#: Kinds in order of urgency; all but the last two need attention.
KINDS: tuple[str, ...] = (
    "alarm",
    "bad data",
    "baseline check",
    "stale",
    "acknowledged",
    "calibrating",
    "ok",
)

#: The method that leads the report when the store holds it: the product default first.
METHOD_ORDER: tuple[str, ...] = ("indicators", "lra", "pca")


@dataclass(frozen=True)
class AxisAttention:
    """One axis's place on the first screen.

    Attributes
    ----------
    robot, axis, method : str
    kind : str
        One of :data:`KINDS`.
    line : str
        What a service engineer needs to know, in one line.
    severity : float
        Distance over threshold of the last capture (NaN when unknown): orders axes of a kind.
    last_capture_at : str or None
        When the axis's last scored capture was taken.
    problems : list of str
        Every kind that applies (an alarmed axis can also have rejected captures).
    """

    robot: str
    axis: str
    method: str
    kind: str
    line: str
    severity: float
    last_capture_at: str | None
    problems: list[str] = field(default_factory=list)

    @property
    def needs_attention(self) -> bool:
        """Alarm, bad data, baseline check, stale or acknowledged alarm."""
        return self.kind in KINDS[:-2]

    @property
    def anchor(self) -> str:
        """The id of the axis's section in the report."""
        return f"{self.robot}-{self.axis}"


def lead_method(methods: Sequence[str]) -> str | None:
    """The method the report leads with: the first of :data:`METHOD_ORDER` present.

    Examples
    --------
    >>> lead_method(["pca", "indicators", "lra"]), lead_method(["pca", "lra"]), lead_method([])
    ('indicators', 'lra', None)
    """
    present = set(methods)
    return next((m for m in METHOD_ORDER if m in present), next(iter(sorted(present)), None))


def _day(stamp: str | None) -> str:
    return "" if stamp is None else str(stamp)[:10]


def _alarm_line(
    last: Any, state: AlarmState, captures_in_alarm: int, threshold_origin: str | None
) -> str:
    plural = "s" if captures_in_alarm != 1 else ""
    line = f"ALARM since {_day(state.raised_at)} ({captures_in_alarm} capture{plural} in alarm): "
    if last is None:
        return line
    details = json.loads(last["details"])
    top = details.get("top_indicator") or describe_top_indicator(details.get("indicators", {}))
    if top:
        line += f"{top}. "
    origin = f" ({threshold_origin})" if threshold_origin else ""
    if last["over"]:
        return (
            line + f"Distance {last['distance']:.4g} > threshold {last['threshold']:.4g}{origin}."
        )
    return line + (
        f"Last distance {last['distance']:.4g} under threshold {last['threshold']:.4g}{origin}; "
        "the alarm holds until enough clean captures in a row."
    )


def triage(
    summary: pd.DataFrame,
    results: pd.DataFrame,
    rejections: pd.DataFrame,
    changed: pd.DataFrame,
    alarms: Sequence[AlarmState],
    *,
    method: str,
    checks: Sequence[BaselineCheck],
    stale_factor: float = 3.0,
) -> list[AxisAttention]:
    """Every axis of ``method``, the ones needing attention first, ranked by :data:`KINDS`.

    Parameters
    ----------
    summary : DataFrame
        :func:`~axiswatch.monitor.report.results.fleet_summary`.
    results : DataFrame
        :func:`~axiswatch.monitor.report.results.fleet_results`.
    rejections : DataFrame
        :func:`~axiswatch.monitor.report.results.fleet_rejections`.
    changed : DataFrame
        ``StoreBackend.changed_file_table()``.
    alarms : sequence of AlarmState
        ``StoreBackend.alarms()``.
    method : str
    checks : sequence of BaselineCheck
        ``StoreBackend.baseline_checks()``: the checks of the active baselines, acknowledged or
        not (those of other methods are left out here).
    stale_factor : float, default=3.0
        An axis is stale when its captures stopped while other axes kept arriving: its last
        capture is more than this many of its usual capture intervals behind the newest
        capture of the axes seen with new files after it (three missed captures in a row).
        A fleet imported at once, its units recorded on different days, is not stale.

    Returns
    -------
    list of AxisAttention
        Ranked: kind, then severity (largest first), then robot and axis.
    """
    own = results[(results.method == method) & (results.role != "baseline")]
    rows = summary[summary.method == method]
    rejected = rejections[rejections.method == method]
    axes = sorted(
        set(zip(rows.robot, rows.axis, strict=True))
        | set(zip(rejected.robot, rejected.axis, strict=True))
        | set(zip(changed.robot, changed.axis, strict=True))
    )
    arrived_later = _newest_arrived_later(rows, own)
    alarm_of = {(a.robot, a.axis): a for a in alarms if a.method == method}
    checks_of: dict[tuple[str, str], list[BaselineCheck]] = {}
    for check in checks:
        if check.method == method:
            checks_of.setdefault((check.robot, check.axis), []).append(check)
    # Each table split by axis once: filtering the whole table per axis is quadratic in axes.
    info_of = by_axis(rows)
    history_of = by_axis(own)
    # Rejected files since scored (a file repaired in place) are no longer rejected.
    rejected_of = by_axis(rejected[~rejected.path.isin(results.path[results.method == method])])
    changed_of = by_axis(changed)
    ranked = []
    for robot, axis in axes:
        row = info_of.get((robot, axis), rows.iloc[:0])
        info = row.iloc[0] if not row.empty else None
        history = history_of.get((robot, axis), own.iloc[:0])
        if info is not None:
            history = history[history.epoch == info["epoch"]]
        last = history.iloc[-1] if not history.empty else None
        problems: list[str] = []
        lines: list[str] = []
        severity = float("nan")
        if last is not None and pd.notna(last["threshold"]) and last["threshold"] > 0:
            severity = float(last["distance"] / last["threshold"])
        state = alarm_of.get((robot, axis))
        origin = None if info is None else info.get("threshold_origin")
        if state is not None:
            in_alarm = int((history.alarm & (history.captured_at >= state.raised_at)).sum())
            line = _alarm_line(last, state, in_alarm, origin)
            if state.acknowledged:
                problems.append("acknowledged")
                line += (
                    f" Seen by {state.acknowledged_by} on {_day(state.acknowledged_at)}: "
                    f"{state.note}"
                )
            else:
                problems.append("alarm")
            lines.append(line)
        everything = rejected_of.get((robot, axis), rejected.iloc[:0])
        # Removed from the folder since, or acknowledged (`rejections --ack`): on the line as
        # history, no longer a problem, as in the monitor's exit status.
        removed = everything[everything.removed_at.notna()]
        everything = everything[everything.removed_at.isna()]
        seen = everything[everything.acknowledged_at.notna()]
        bad = everything[everything.acknowledged_at.isna()]
        if info is None and (not bad.empty or (seen.empty and removed.empty)):
            problems.append("bad data")
            lines.append(
                f"No baseline: {len(bad)} capture file(s) rejected, latest "
                f"{bad.path.iloc[-1]}: {bad.error.iloc[-1]}"
                if not bad.empty
                else "No baseline yet."
            )
        elif not bad.empty:
            problems.append("bad data")
            lines.append(f"{len(bad)} capture file(s) rejected, latest: {bad.error.iloc[-1]}")
        moved = changed_of.get((robot, axis), changed.iloc[:0])
        seen_moved = moved[moved.acknowledged_at.notna()]  # on the line as seen, like `seen`
        moved = moved[moved.acknowledged_at.isna()]
        if not moved.empty:
            problems.append("bad data")
            lines.append(
                f"{len(moved)} file(s) changed after they were scored (results kept): "
                + ", ".join(moved.path)
            )
        last_at = None if last is None else str(last["captured_at"])
        times = pd.to_datetime(history.captured_at)
        newest = arrived_later.get((robot, axis))
        if newest is not None and len(times) >= 2:
            usual = times.diff().median()
            behind = newest - times.max()
            if usual > pd.Timedelta(0) and behind > stale_factor * usual:
                problems.append("stale")
                lines.append(
                    f"Stale: no capture since {_day(last_at)}, while other axes kept "
                    f"arriving: their newest is {_span(behind)} later ({behind / usual:.0f} x "
                    f"this axis's usual interval of {_span(usual)})."
                )
        if info is not None and info.get("state") == "stale" and "stale" not in problems:
            # The monitor's own notion of stale: no new capture file for longer than its
            # --stale-after, by the wall clock, whatever the dates of the captures say.
            problems.append("stale")
            lines.append(
                f"Stale: no new capture file since {_day(str(info['last_seen']))}. An archive "
                "imported once gets no new files: --stale-after off."
            )
        stored = checks_of.get((robot, axis), [])
        if any(c.acknowledged_at is None for c in stored):
            problems.append("baseline check")
        if set(problems) - {"baseline check"}:
            kind = min(problems, key=KINDS.index)
        else:
            learning = info is None or pd.isna(info["threshold"]) or _learning(last)
            calm = "calibrating" if learning else "ok"
            kind = "baseline check" if problems else calm
            lines.append(_healthy_line(info, last, history))
        if not seen.empty:
            lines.append(
                f"{len(seen)} capture file(s) rejected, seen on "
                f"{_day(seen.acknowledged_at.max())}, latest: {seen.error.iloc[-1]}"
            )
        if not removed.empty:
            last_removed = removed.sort_values("removed_at", kind="stable").iloc[-1]
            lines.append(
                f"{len(removed)} rejected capture file(s) since removed from the fleet folder "
                f"(history), last on {_day(last_removed.removed_at)}: {last_removed.path}."
            )
        if not seen_moved.empty:
            lines.append(
                f"{len(seen_moved)} file(s) changed after they were scored (results kept), seen "
                f"on {_day(seen_moved.acknowledged_at.max())}: " + ", ".join(seen_moved.path)
            )
        lines += [_check_line(c) for c in stored]
        if last is not None:
            # Checks in the scores' details that the store does not hold (see the module's doc).
            details = json.loads(last["details"])
            held = {c.note for c in stored}
            lines += [
                f"Baseline to check: {details[key]}."
                for key in ("baseline_check", "fleet_check")
                if details.get(key) and details[key] not in held
            ]
        ranked.append(
            AxisAttention(robot, axis, method, kind, " ".join(lines), severity, last_at, problems)
        )
    return sorted(
        ranked,
        key=lambda a: (
            KINDS.index(a.kind),
            -a.severity if a.severity == a.severity else 0.0,
            a.robot,
            a.axis,
        ),
    )


def _newest_arrived_later(
    summary: pd.DataFrame, results: pd.DataFrame
) -> dict[tuple[str, str], pd.Timestamp]:
    """Per axis, the newest capture of the axes whose files arrived after its own last did.

    Arrival is the summary's ``last_seen``: when a monitor run last saw a new file of the axis.
    An axis missing here has no later arrival to compare with: an import, or a quiet fleet.
    """
    if "last_seen" not in summary.columns or results.empty:
        return {}
    newest = pd.to_datetime(results.captured_at).groupby([results.robot, results.axis]).max()
    seen = summary.drop_duplicates(["robot", "axis"]).set_index(["robot", "axis"])["last_seen"]
    table = pd.DataFrame({"seen": pd.to_datetime(seen, utc=True), "newest": newest}).dropna()
    if table.empty:
        return {}
    # Sorted by arrival, latest first: the running maximum over strictly later arrivals.
    by_arrival = table.groupby("seen")["newest"].max().sort_index(ascending=False)
    later = by_arrival.cummax().shift(1)
    out: dict[tuple[str, str], pd.Timestamp] = {}
    for key, when in table["seen"].items():
        robot, axis = cast("tuple[str, str]", key)
        if pd.notna(later[when]):
            out[str(robot), str(axis)] = later[when]
    return out


def _span(span: pd.Timedelta) -> str:
    """A time span in the unit a person reads: days, hours, minutes or seconds.

    Examples
    --------
    >>> _span(pd.Timedelta(days=4)), _span(pd.Timedelta(minutes=73)), _span(pd.Timedelta(seconds=12))
    ('4.0 d', '1.2 h', '12 s')
    """
    seconds = span.total_seconds()
    for unit, size in (("d", 86_400.0), ("h", 3_600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.1f} {unit}"
    return f"{seconds:.0f} s"


def by_axis(frame: pd.DataFrame) -> dict[tuple[str, str], pd.DataFrame]:
    """The rows of each (robot, axis), in the frame's order: one pass over the frame."""
    return {
        (str(robot), str(axis)): part
        for (robot, axis), part in frame.groupby(["robot", "axis"], sort=False)
    }


def _check_line(check: BaselineCheck) -> str:
    """The axis's line on a stored check: to check, or seen (``rejections --ack``) and when."""
    if check.acknowledged_at is None:
        return f"Baseline to check: {check.note}."
    return f"Baseline to check, seen on {_day(check.acknowledged_at)}: {check.note}."


def _learning(last: Any) -> bool:
    """Whether the last capture's mode is being learned (``MonitorConfig.modes``)."""
    return last is not None and json.loads(last["details"]).get("mode_state") == "learning"


def _healthy_line(info: Any, last: Any, history: pd.DataFrame) -> str:
    if info is None:  # only acknowledged (`rejections --ack`) or removed rejections
        return "No baseline yet."
    if last is None:
        return "Baseline set; no capture scored yet."
    if _learning(last):
        details = json.loads(last["details"])
        guard = (
            f", guard at {last['distance']:.2f} of the alarm level"
            if last["distance"] > 0
            else ", no guard yet"
        )
        return (
            f"Learning new mode {details['mode']} ({details['mode_seen']} of "
            f"{details['mode_fit']} captures){guard}; last {_day(last['captured_at'])}."
        )
    if pd.isna(info["threshold"]):
        return (
            f"Calibrating: {int(info['scored'])} of the captures that set the threshold "
            f"scored, last {_day(last['captured_at'])}."
        )
    raised = history[history.alarm & ~history.alarm.shift(fill_value=False)]
    cleared = (
        f" {len(raised)} alarm(s) raised and cleared ({', '.join(map(_day, raised.captured_at))})."
        if not raised.empty
        else ""
    )
    return (
        f"ok: last capture {_day(last['captured_at'])}, distance {last['distance']:.4g} "
        f"under threshold {last['threshold']:.4g}.{cleared}"
    )
