"""The text a ``monitor`` run prints: what it did, the fleet's table, problems and verdicts.

Each function returns the messages in order; the CLI prints each one, escaped.
"""

from __future__ import annotations

import re
import shlex
from collections.abc import Mapping
from datetime import timedelta
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from axiswatch.monitor._run import MonitorSummary
    from axiswatch.monitor._unread import UnreadIndicators
    from axiswatch.monitor.store import StoreBackend

__all__ = [
    "cleared_alarm_lines",
    "fleet_table",
    "fold_same_reason",
    "run_header",
    "run_problems",
    "unread_lines",
    "verdict_lines",
]


def run_header(result: MonitorSummary) -> str:
    """One line: the files seen, the new baselines and the captures scored in the run."""
    # n_files counts only the folders this run listed: say so, or a second run seems to
    # have lost the files of the unchanged folders.
    unchanged = (
        f" in the axis folders listed ({result.unchanged_folders} axis folder(s) "
        "unchanged since the last run, not listed)"
        if result.unchanged_folders
        else ""
    )
    return (
        f"{result.method}: {result.n_files} capture files{unchanged}, "
        f"{result.new_baselines} new baseline(s), {result.scored} capture(s) scored "
        "in this run."
    )


def fleet_table(store: StoreBackend, stale_after: timedelta | None, method: str) -> list[str]:
    """The fleet's summary of ``method``: the columns that fit a terminal, then the threshold."""
    from axiswatch.monitor.report.results import fleet_summary

    summary = fleet_summary(store, stale_after=stale_after)
    summary = summary[summary.method == method].reset_index(drop=True)
    if summary.empty:
        return ["No axis has a baseline yet."]
    # What fits a terminal; `axiswatch report` and `fleet_summary` have every column.
    columns = ["robot", "axis", "method", "state", "alarm_since", "scored", "over",
               "last_capture", "last_distance", "threshold", "rejected"]  # fmt: skip
    if summary.acknowledged_by.notna().any():
        columns.insert(5, "acknowledged_by")
    if summary.bad_data_acknowledged.notna().any():
        columns.insert(columns.index("state") + 1, "bad_data_acknowledged")
    shown = summary[columns].fillna(
        {"alarm_since": "", "acknowledged_by": "", "bad_data_acknowledged": ""}
    )
    lines = [shown.to_string(index=False, float_format=lambda v: f"{v:.4g}")]
    origins = summary.threshold_origin.dropna().unique()
    if len(origins) == 1:
        lines.append(f"threshold of every axis: {origins[0]}.")
    return lines


def verdict_lines(store: StoreBackend, method: str, stale_after: timedelta | None) -> list[str]:
    """The axes needing attention and their verdicts (the report's first screen), in lines."""
    from axiswatch.monitor.report.verdict import attention_lines, fleet_verdicts

    return attention_lines(fleet_verdicts(store, method, stale_after=stale_after), method)


def run_problems(result: MonitorSummary, *, store: str | Path, settle_s: float) -> list[str]:
    """What needs a look after a run: waiting files, problems by kind, acknowledged ones."""
    lines = []
    if result.waiting:
        lines.append(
            f"\n{result.waiting} capture file(s) modified less than {settle_s:g} s ago: "
            "waiting (scored by a later run)."
        )
    for title, items in (
        ("Rejected captures", fold_same_reason(result.rejected)),
        ("Changed files", result.changed),
        ("Axes not scored", result.axis_problems),
        ("Baselines to check", result.baseline_checks),
        ("Axes calibrating", result.calibrating),
        ("Fleet allowances now applied", result.fleet_priors),
        ("Axes with indicators not read", unread_lines(result.unread)),
        ("Data-quality notes", repair_lines(result.repaired)),
        ("Stale axes", result.stale),
    ):
        if items:
            # Folded lines: the heading counts every file, every axis.
            counts = {
                "Rejected captures": len(result.rejected),
                "Axes with indicators not read": len(list(result.unread.axes())),
            }
            count = counts.get(title, len(items))
            lines.append(f"\n{title} ({count}):")
            lines.extend(f"  {item}" for item in items)
            if title == "Rejected captures":
                lines.append(
                    "A rejected capture is tried again when its file, the options or its "
                    "axis profile change; to try again now: axiswatch rejections --store "
                    f"{shlex.quote(str(store))} --retry [PATH ...]"
                )
    if result.acknowledged:
        lines.append(
            f"\n{result.acknowledged} acknowledged problem(s) not shown "
            "('axiswatch rejections' lists them)."
        )
    if result.acknowledged_alarms:
        lines.append(f"\nAcknowledged alarms ({result.method}), not counted in the exit status:")
        lines.extend(
            f"  {seen.robot}/{seen.axis} since {seen.raised_capture}: seen by "
            f"{seen.acknowledged_by} at {seen.acknowledged_at}: {seen.note}"
            for seen in result.acknowledged_alarms
        )
    return lines


def cleared_alarm_lines(
    store: StoreBackend,
    method: str,
    alarmed_before: set[tuple[str, str, str]],
    store_path: str | Path,
) -> list[str]:
    """Axes with captures in alarm scored in this run, no longer in alarm at its end.

    A run that scores a backlog (a first run, a share mounted again) can raise an alarm and
    clear it: the state after the run is "ok", and the exit status says nothing.
    ``alarmed_before``: the run's ``MonitorSummary.alarmed_before``.
    """
    from axiswatch.monitor.report.results import fleet_results

    new = store.alarmed_captures(method) - alarmed_before
    in_alarm = set(store.axes_in_alarm(method))
    axes = sorted({(robot, axis) for robot, axis, _ in new} - in_alarm)
    if not axes:
        return []
    count = "1 axis" if len(axes) == 1 else f"{len(axes)} axes"
    lines = [f"\nAlarms raised and cleared again in this run ({count}); the state shows none:"]
    for robot, axis in axes:
        rows = fleet_results(store, robot=robot, axis=axis)
        rows = rows[
            (rows.method == method)
            & rows.capture.isin({c for r, a, c in new if (r, a) == (robot, axis)})
        ]
        first = rows.iloc[0]
        why = f" ({first.top_indicator})" if isinstance(first.top_indicator, str) else ""
        lines.append(
            f"  {robot}/{axis}: {len(rows)} capture(s) in alarm, the first {first.capture}{why}; "
            f"axiswatch results --store {shlex.quote(str(store_path))} --robot {robot} "
            f"--axis {axis}"
        )
    return lines


def repair_lines(repaired: Mapping[str, tuple[int, int]]) -> list[str]:
    """One line per axis whose captures had lone torque spikes repaired.

    Examples
    --------
    >>> repair_lines({"r1/a0": (2, 3)})
    ['r1/a0: 3 lone torque spike(s) in 2 capture(s) repaired before impulsiveness was read (a logger or cable glitch?); scored as usual']
    """
    return [
        f"{axis}: {spikes} lone torque spike(s) in {captures} capture(s) repaired before "
        "impulsiveness was read (a logger or cable glitch?); scored as usual"
        for axis, (captures, spikes) in repaired.items()
    ]


def unread_lines(unread: UnreadIndicators) -> list[str]:
    """One line per axis: the indicators its scored captures could not give, on how many, and
    why. Reasons that differ only in their numbers are said once: for several indicators of an
    axis, and for several axes (a fleet logged at 20 Hz has no impact band anywhere).

    Examples
    --------
    >>> from axiswatch.monitor._unread import UnreadIndicators
    >>> unread = UnreadIndicators()
    >>> for axis in ("r1/a1", "r1/a2", "r2/a1"):
    ...     unread.add(axis, {"tooth_lines:out": "needs its order 7.8 below 45 Hz",
    ...                       "bearing_lines:in": "needs its order 11.9 below 45 Hz"})
    >>> unread.add("r2/a1", {})
    >>> for line in unread_lines(unread):
    ...     print(line)
    r1/a1 (and 1 more axis): bearing_lines:in, tooth_lines:out on 1 of 1 captures: needs its
    order 11.9 below 45 Hz
    r2/a1: bearing_lines:in, tooth_lines:out on 1 of 2 captures: needs its order 11.9 below 45 Hz
    """
    axes: dict[str, list[tuple[str, str]]] = {}
    for axis, scored, missing in unread.axes():
        groups: dict[tuple[int, str], list[str]] = {}
        # By name: a run's captures list them in reading order, the stored details by name.
        for name in sorted(missing):
            count, why = missing[name]
            groups.setdefault((count, _NUMBER.sub("#", why)), []).append(name)
        said = "; ".join(
            f"{', '.join(names)} on {count} of {scored} captures: {missing[names[0]][1]}"
            for (count, _), names in groups.items()
        )
        axes.setdefault(_NUMBER.sub("#", said), []).append((axis, said))
    lines = []
    for members in axes.values():
        (axis, said), more = members[0], len(members) - 1
        if more:
            aside = "" if len({s for _, s in members}) == 1 else ", numbers aside"
            axis += f" (and {more} more {'axis' if more == 1 else 'axes'}{aside})"
        lines.append(f"{axis}: {said}")
    return lines


def fold_same_reason(lines: list[str]) -> list[str]:
    """Rejection lines ``PATH: reason`` with one reason said once, naming how many files share it.

    A broken axis profile rejects every capture below it with the same line but for the path.
    Reasons that differ only in their numbers (each file's first stamp) are one reason too.
    ``axiswatch rejections`` still lists every file. Lines keep the order of their reason's
    first file; a line without ``": "`` is its own.

    Parameters
    ----------
    lines : list of str
        Rejection lines, each ``PATH: reason``.

    Returns
    -------
    list of str
        One line per reason: the first file's line, or with more files of the same reason
        ``FIRST (and N more capture files with this reason): reason``.

    Examples
    --------
    >>> fold_same_reason([
    ...     "r1/a1/d1.csv: r1/robot.toml: bad key", "r1/a2/d1.csv: empty file",
    ...     "r1/a1/d2.csv: r1/robot.toml: bad key", "r1/a2/d1.csv: r1/robot.toml: bad key",
    ... ])  # doctest: +NORMALIZE_WHITESPACE
    ['r1/a1/d1.csv (and 2 more capture files with this reason): r1/robot.toml: bad key',
     'r1/a2/d1.csv: empty file']
    """
    groups: dict[tuple[str, int], list[tuple[str, str]]] = {}  # (key, 0) or (line, its index)
    for index, line in enumerate(lines):
        path, sep, reason = line.partition(": ")
        key = (_NUMBER.sub("#", reason), 0) if sep else (line, index + 1)
        groups.setdefault(key, []).append((path, reason))
    folded = []
    for (_, alone), members in groups.items():
        (path, reason), more = members[0], len(members) - 1
        if alone:
            folded.append(reason if reason else path)
        elif not more:
            folded.append(f"{path}: {reason}")
        else:
            # Unix milliseconds read as seconds: each file's message names its own first stamp.
            aside = "" if len({r for _, r in members}) == 1 else ", numbers aside"
            folded.append(
                f"{path} (and {more} more capture files with this reason{aside}): {reason}"
            )
    return folded


#: A date or a measured number in a rejection reason (a stamp, a time, a rate: a decimal
#: point, an exponent or 3 digits): reasons that differ only in these are folded together.
_NUMBER = re.compile(
    r"\d{4}-\d{2}-\d{2}(?:[T ]\d{2}:\d{2}:\d{2})?|\d+\.\d+(?:e[+-]?\d+)?|\d+e[+-]?\d+|\d{3,}"
)
