"""The HTML report of a monitoring store: the service engineer's view.

One self-contained ``index.html``: needs attention now, then each axis, then rejected captures.
The monitor manual's "The report" describes each part.
"""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd

from axiswatch.monitor._feedback import ACK_VERDICTS
from axiswatch.monitor._methods import DEFAULT_METHOD
from axiswatch.monitor._methods import methods as registered_methods
from axiswatch.monitor.report.advice import indicator_colour
from axiswatch.monitor.report.attention import METHOD_ORDER, by_axis, lead_method, triage
from axiswatch.monitor.report.charts import distance_chart, plotly_library
from axiswatch.monitor.report.results import fleet_rejections, fleet_results, fleet_summary
from axiswatch.monitor.report.verdict import Verdict, axis_verdicts
from axiswatch.monitor.store import BaselineCheck, StoreBackend

__all__ = ["write_report"]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em 2em; max-width: 1150px; color: #222; }
h1 { margin-bottom: 0.2em; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; vertical-align: top; }
th { background: #f0f0f0; }
td:first-child, th:first-child, td.text { text-align: left; }
.meta, .note { color: #555; font-size: 0.9em; }
ol.attention { padding-left: 1.5em; }
ol.attention li { margin: 0.4em 0; padding: 0.3em 0.5em; border-left: 5px solid #999; }
li.act-now { border-color: #c00 !important; background: #fbe3e3; }
li.bad-data { border-color: #d80 !important; background: #fdf0d8; }
li.watch { border-color: #c90 !important; background: #fdf8e3; }
li.unconfirmed { border-style: dashed !important; background: #fefcf2; }
.kind { font-weight: bold; text-transform: uppercase; font-size: 0.8em; margin-right: 0.5em; }
.fault { font-weight: bold; }
.swatch { display: inline-block; width: 0.8em; height: 0.8em; margin: 0 0.3em; }
ol.attention div { margin: 0.15em 0; }
details.why { margin: 0.2em 0; font-size: 0.85em; color: #555; }
details.why summary { font-weight: normal; }
.all-clear { padding: 0.5em; background: #e3f4e3; border-left: 5px solid #393; }
details { margin: 0.8em 0; }
summary { cursor: pointer; font-weight: bold; }
section.axis { border-top: 1px solid #ccc; margin-top: 1.5em; }
input.filter { margin: 0.4em 0; width: 20em; }
"""

# Charts in a folded section are drawn while hidden; resize them once they are shown.
# A filter box hides the rows of the table after it that do not hold its text.
_SCRIPT = """
document.querySelectorAll('input.filter').forEach(function (box) {
  box.addEventListener('input', function () {
    var words = box.value.toLowerCase();
    box.nextElementSibling.querySelectorAll('tr.row').forEach(function (r) {
      r.style.display = r.textContent.toLowerCase().indexOf(words) < 0 ? 'none' : ''; });
  });
});
document.querySelectorAll('details').forEach(function (d) {
  d.addEventListener('toggle', function () {
    if (d.open) { d.querySelectorAll('.plotly-graph-div').forEach(function (g) {
      Plotly.Plots.resize(g); }); }
  });
});
"""

#: Axes listed with their verdict on the first screen; the others needing attention are folded.
LISTED = 20

#: Fleets up to this many axes get every axis's charts; larger ones only the listed axes'.
CHARTED_AXES = 60

#: The paper's methods, shown apart from the method leading the page.
_PAPER_METHODS = {"lra", "pca"}


def _others_title(methods: list[str]) -> str:
    """Title of the folded section of the methods that do not lead the page.

    Examples
    --------
    >>> _others_title(["lra", "pca"]), _others_title(["indicators", "pca"])
    ("The paper's methods", 'Other methods')
    """
    return "The paper's methods" if set(methods) <= _PAPER_METHODS else "Other methods"


_PAPER_NOTE = (
    "The paper's subspace distances (PCA, LRA) of |STFT| features, kept for comparison: they "
    "measure the task as much as the health of the axis (docs/evaluation.md), so their alarms "
    "after a task change are not maintenance calls."
)

_LEGEND = (
    "Distance of every capture to the axis's baseline: green band = baseline capture, blue band "
    "= calibration captures (assumed healthy; they set the threshold), dashed red = threshold, "
    "orange = over the threshold, red cross = alarm, dotted purple = known task change. "
    "Indicators (method indicators, the default): each one's shift of the capture from the "
    "baseline in units of the threshold (with a fleet of 3 or more axes of its profile: spreads "
    "of the axis's calibration captures and of its fleet's task changes, over that indicator's "
    "task-change allowance; without one: spreads of its calibration captures); the distance is "
    "the largest shift, so an indicator at the dashed line reaches the threshold alone. (Method "
    "mechanics: shifts in healthy spreads measured on the development simulator, green band = "
    "one spread, the distance the sum of the squared upward shifts.) Drag to zoom, double-click "
    "to reset, hover for the capture, its value and the reason."
)


def _stores_indicators(method: str) -> bool:
    """Whether a method's scores carry its indicators' shifts (one no longer registered: no)."""
    preset = registered_methods().get(method)
    return preset is not None and preset.stores_indicators


def _esc(value: Any) -> str:
    return html.escape("" if value is None else str(value))


def _when(stamp: Any) -> str:
    """A stored ISO time stamp as people read it: no 'T', no midnight time of day-captures."""
    text = "" if stamp is None else str(stamp)
    return text.removesuffix("T00:00:00").replace("T", " ")


def _format(value: Any) -> str:
    if isinstance(value, float):
        return "" if pd.isna(value) else f"{value:.4g}"
    return "" if value is None or value is pd.NA else str(value)


def _table(frame: pd.DataFrame, *, text: tuple[str, ...] = ()) -> str:
    header = "".join(f"<th>{_esc(c)}</th>" for c in frame.columns)
    body = []
    for values in frame.to_dict(orient="records"):
        cells = "".join(
            f"<td class='text'>{_esc(_format(v))}</td>"
            if k in text
            else f"<td>{_esc(_format(v))}</td>"
            for k, v in values.items()
        )
        body.append(f"<tr>{cells}</tr>")
    return f"<table><tr>{header}</tr>{''.join(body)}</table>"


def _anchor(verdict: Verdict) -> str:
    """The id of the axis's section in the report."""
    return f"{verdict.robot}-{verdict.axis}"


def _link(verdict: Verdict, charted: bool = True) -> str:
    """The axis's name, linked to its section where the page has one."""
    name = f"{_esc(verdict.robot)}/{_esc(verdict.axis)}"
    return f"<a href='#{_esc(_anchor(verdict))}'>{name}</a>" if charted else name


def _verdict_html(verdict: Verdict) -> str:
    """The verdict's sentences (those the terminal prints), the technical line folded."""
    first, *rest = verdict.sentences() or [""]
    swatch = (
        f"<span class='swatch' style='background:{indicator_colour(verdict.indicator)}'></span>"
        if verdict.indicator is not None
        else ""
    )
    lines = "".join(f"<div>{_esc(text)}</div>" for text in rest)
    return f"{swatch}<span class='fault'>{_esc(first)}</span>{lines}" + (
        f"<details class='why'><summary>Details</summary>{_esc(verdict.details)}</details>"
        if verdict.details
        else ""
    )


def _axis_table(verdicts: list[Verdict], charted: set[str], *, state: bool) -> str:
    """A filterable table of axes: name, state (where asked), last capture, verdict."""
    head = (
        "<th>axis</th>"
        + ("<th>state</th>" if state else "")
        + ("<th>last capture</th><th>note</th>")
    )
    rows = [
        f"<tr class='row'><td>{_link(v, _anchor(v) in charted)}</td>"
        + (f"<td class='text'>{_esc(v.label)}</td>" if state else "")
        + f"<td class='text'>{_esc(_when(v.last_capture_at))}</td>"
        f"<td class='text'>{_esc(' '.join(v.sentences()))} "
        f"<span class='note'>{_esc(v.details)}</span></td></tr>"
        for v in verdicts
    ]
    return (
        "<input class='filter' type='search' placeholder='Filter: robot, axis, state, words'>"
        f"<table><tr>{head}</tr>{''.join(rows)}</table>"
    )


def _first_screen(verdicts: list[Verdict], method: str, charted: set[str]) -> list[str]:
    """Needs attention now (the first :data:`LISTED`, the rest folded), then the calm axes
    folded: the same size however large the fleet."""
    urgent = [v for v in verdicts if v.needs_attention]
    calm = [v for v in verdicts if not v.needs_attention]
    parts = [f"<section id='attention'><h2>Needs attention now ({len(urgent)})</h2>"]
    if urgent:
        parts.append("<ol class='attention'>")
        for verdict in urgent[:LISTED]:
            css = verdict.state.replace(" ", "-") + ("" if verdict.confirmed else " unconfirmed")
            parts.append(
                f"<li class='{css}' data-axis='{_esc(verdict.robot)}/{_esc(verdict.axis)}' "
                f"data-kind='{_esc(verdict.kind)}' data-state='{_esc(verdict.label)}'>"
                f"<span class='kind'>{_esc(verdict.label)} </span>"
                f"{_link(verdict, _anchor(verdict) in charted)} {_verdict_html(verdict)}</li>"
            )
        parts.append("</ol>")
        more = urgent[LISTED:]
        if more:
            parts.append(
                f"<details id='more-attention'><summary>{len(more)} more "
                f"{'axis needs' if len(more) == 1 else 'axes need'} attention</summary>"
                + _axis_table(more, charted, state=True)
                + "</details>"
            )
    else:
        parts.append(
            f"<p class='all-clear'>No axis needs attention ({_esc(method)}): no alarm, no bad "
            "data, no baseline to check, no stale axis.</p>"
        )
    parts.append(
        f"<details id='healthy'><summary>No action needed ({len(calm)} "
        f"{'axis' if len(calm) == 1 else 'axes'})</summary>"
        + _axis_table(calm, charted, state=True)
        + "</details></section>"
    )
    return parts


def _events(
    rows: pd.DataFrame,
    acks: pd.DataFrame,
    rebaselines: pd.DataFrame,
    checks: Sequence[BaselineCheck],
    limit: int = 15,
) -> pd.DataFrame:
    """The axis's history (lead method rows, every method's acknowledgements and checks of its
    active baselines), newest last."""
    events: list[tuple[str, str, str, str]] = []
    previous = False
    for row in rows.itertuples(index=False):
        when, capture = str(row.captured_at), str(row.capture)
        if row.role == "baseline":
            events.append((when, capture, f"baseline of epoch {row.epoch}", ""))
            previous = False
        elif row.role == "excluded":
            events.append((when, capture, "excluded from calibration", str(row.reason)))
        elif row.role == "calibration" and "; threshold set to" in str(row.reason):
            tail = str(row.reason).split("; ", 1)[1]
            events.append((when, capture, "threshold set", tail))
        elif row.role == "monitor":
            mode = getattr(row, "mode", None)
            if isinstance(mode, str) and " (learning 1 of " in mode:
                name, total = mode.split(" (learning 1 of ")
                detail = f"learned from its first {total.rstrip(')')} captures, under a guard"
                events.append((when, capture, f"new operating mode {name}", detail))
            if row.alarm and not previous:
                events.append((when, capture, "ALARM raised", str(row.top_indicator or row.reason)))
            elif previous and not row.alarm:
                events.append((when, capture, "alarm cleared", f"distance {row.distance:.4g}"))
            previous = bool(row.alarm)
    for ack in acks.itertuples(index=False):
        what = "re-baseline after maintenance" if ack.rebaseline else "alarm acknowledged"
        verdict = getattr(ack, "verdict", None)
        if isinstance(verdict, str):
            what += f": {ACK_VERDICTS.get(verdict, verdict)}"
        seen = f" (alarm raised by {ack.capture})" if isinstance(ack.capture, str) else ""
        events.append(
            (
                str(ack.acknowledged_at),
                "",
                f"{what} ({ack.method})",
                f"by {ack.acknowledged_by}: {ack.note}{seen}",
            )
        )
    for check in checks:
        events.append(
            (check.detected_at, "", f"baseline to check ({check.method})",
             f"{check.path}: {check.note}")
        )  # fmt: skip
        if check.acknowledged_at is not None:
            events.append(
                (check.acknowledged_at, "", f"baseline check acknowledged ({check.method})",
                 check.path)
            )  # fmt: skip
    for request in rebaselines.itertuples(index=False):
        start = str(request.from_capture or "the next capture")
        events.append(
            (
                str(request.requested_at),
                "",
                f"baseline of epoch {request.retired_epoch} retired ({request.method})",
                f"new baseline from {start}",
            )
        )
    events.sort(key=lambda e: e[0])
    recent = [(_when(when), *rest) for when, *rest in events[-limit:]]
    return pd.DataFrame(recent, columns=["when", "capture", "event", "detail"])


def write_report(
    store: StoreBackend,
    out: str | Path,
    *,
    labels: pd.DataFrame | None = None,
    stale_after: timedelta | None = None,
    stale_factor: float = 3.0,
) -> Path:
    """Write ``out/index.html``, one self-contained page; return its path.

    Every file is written under a temporary name and renamed into place, so a browser or a web
    server never shows a half-written page.

    Parameters
    ----------
    store : StoreBackend
    out : str or Path
        Folder (created if needed).
    labels : DataFrame, optional
        Ground truth of a simulated fleet (``robot``, ``axis``, ``date``, ``task``, ``fault``);
        task changes and faulty captures are then marked on each trend.
    stale_after : timedelta, optional
        The summary's ``state`` is ``stale`` for axes without a new capture file for longer
        (see :func:`fleet_summary`).
    stale_factor : float, default=3.0
        See :func:`axiswatch.monitor.report.attention.triage`.

    Returns
    -------
    Path
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(
            f"report folder '{out}' is a file; expected a folder, the report is written to "
            "FOLDER/index.html."
        )
    out.mkdir(parents=True, exist_ok=True)
    summary = fleet_summary(store, stale_after=stale_after)
    results = fleet_results(store)
    rejections = fleet_rejections(store)
    changed = store.changed_file_table()
    alarms = store.alarms()
    checks = store.baseline_checks()
    acks = store.acknowledgements()
    rebaselines = store.rebaseline_requests()
    methods = sorted(
        set(summary.method) | set(rejections.method),
        key=lambda m: (METHOD_ORDER.index(m) if m in METHOD_ORDER else len(METHOD_ORDER), m),
    )
    lead = lead_method(methods)
    generated = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    newest = results.captured_at[results.role != "baseline"].max() if not results.empty else None
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>axiswatch fleet report</title>",
        f"<style>{_STYLE}</style>",
        f"<script type='text/javascript'>{plotly_library()}</script></head><body>",
        "<h1>axiswatch fleet report</h1>",
        f"<p class='meta'>Generated {_esc(generated)} from store {_esc(store.location)}. Newest "
        f"capture in the fleet: {_esc(_when(newest) or 'none')}. Method leading this page: "
        f"<b>{_esc(lead or 'none')}</b>"
        + (" (the product default)" if lead == DEFAULT_METHOD else "")
        + ".</p>",
    ]
    if lead is None:
        parts.append("<p>No axis has a baseline or a rejected capture yet.</p></body></html>")
        page = out / "index.html"
        _replace(page, "\n".join(parts).encode("utf-8"))
        return page
    items = triage(summary, results, rejections, changed, alarms, method=lead, checks=checks,
                   stale_factor=stale_factor)  # fmt: skip
    verdicts = axis_verdicts(items, results, alarms)
    # A large fleet's page charts only the axes listed as needing attention: the charts are
    # most of the page's size and of the time to write it.
    shown = (
        verdicts
        if len(verdicts) <= CHARTED_AXES
        else [v for v in verdicts if v.needs_attention][:LISTED]
    )
    charted = {_anchor(v) for v in shown}
    parts += _first_screen(verdicts, lead, charted)
    others = [m for m in methods if m != lead]
    if others:
        note = f"<p class='note'>{_esc(_PAPER_NOTE)}</p>" if set(others) & _PAPER_METHODS else ""
        parts.append(
            f"<details id='paper-methods'><summary>{_others_title(others)} "
            f"({', '.join(others)}): shown on request</summary>{note}"
        )
        for method in others:
            listed = triage(summary, results, rejections, changed, alarms, method=method,
                            checks=checks, stale_factor=stale_factor)  # fmt: skip
            frame = pd.DataFrame(
                [(f"{i.robot}/{i.axis}", i.kind, i.line) for i in listed],
                columns=["axis", "state", "line"],
            )
            parts += [f"<h3>{_esc(method)}</h3>", _table(frame, text=("state", "line"))]
        parts.append("</details>")
    parts += [
        "<h2>Axes</h2>",
        "<details id='legend'><summary>How to read the charts</summary>"
        f"<p class='note'>{_esc(_LEGEND)}</p></details>",
    ]
    if len(shown) < len(verdicts):
        parts.append(
            f"<p class='note'>Charts of the axes listed as needing attention ({len(shown)} of "
            f"{len(verdicts)}); every axis is in the tables above, with its verdict.</p>"
        )
    # Each table split by axis once: filtering the whole table per axis is quadratic in axes.
    results_of = by_axis(results)
    acks_of = by_axis(acks)
    rebaselines_of = by_axis(rebaselines)
    labels_of = by_axis(labels) if labels is not None else {}
    checks_of: dict[tuple[str, str], list[BaselineCheck]] = {}
    for check in checks:
        checks_of.setdefault((check.robot, check.axis), []).append(check)
    for verdict in shown:
        robot, axis = verdict.robot, verdict.axis
        own = results_of.get((robot, axis), results.iloc[:0])
        parts.append(
            f"<section class='axis' id='{_esc(_anchor(verdict))}'><h3>{_esc(robot)} / "
            f"{_esc(axis)} <span class='note'>({_esc(verdict.label)})</span></h3>"
            f"<div>{_verdict_html(verdict)}</div>"
        )
        events: list[tuple[str, str]] = []
        fault_dates: list[str] = []
        if labels is not None:
            truth = labels_of.get((robot, axis), labels.iloc[:0]).sort_values("date")
            fault_dates = [str(d) for d in truth[truth.fault != "none"].date]
            change = truth.task.ne(truth.task.shift()) & truth.task.shift().notna()
            events = [(str(r.date), f"task -> {r.task}") for r in truth[change].itertuples()]
        lead_rows = own[own.method == lead]
        if not lead_rows.empty:
            parts.append(
                distance_chart(
                    lead_rows, div_id=f"chart-{robot}-{axis}", indicators=_stores_indicators(lead),
                    events=events, fault_dates=fault_dates,
                )
            )  # fmt: skip
        history = _events(
            lead_rows,
            acks_of.get((robot, axis), acks.iloc[:0]),
            rebaselines_of.get((robot, axis), rebaselines.iloc[:0]),
            checks_of.get((robot, axis), []),
        )
        if not history.empty:
            parts += [
                "<h4>History</h4>",
                _table(history, text=("when", "capture", "event", "detail")),
            ]
        paper_rows = own[own.method.isin(others)]
        if not paper_rows.empty:
            parts.append(
                f"<details class='paper'><summary>{_others_title(list(paper_rows.method))} on "
                f"{_esc(robot)}/{_esc(axis)} ({', '.join(dict.fromkeys(paper_rows.method))})"
                "</summary>"
                + distance_chart(
                    paper_rows, div_id=f"paper-{robot}-{axis}", indicators=False, events=events
                )
                + "</details>"
            )
        parts.append("</section>")
    if not rejections.empty:
        parts += [
            "<h2 id='rejected'>Rejected captures</h2>",
            _table(
                rejections[["method", "path", "error"]].assign(
                    # the stored line starts with the path, which has its own column
                    error=[
                        str(error).removeprefix(f"{path}: ")
                        for path, error in zip(rejections.path, rejections.error, strict=True)
                    ],
                    seen=["" if pd.isna(at) else _when(at) for at in rejections.acknowledged_at],
                    removed=["" if pd.isna(at) else _when(at) for at in rejections.removed_at],
                ),
                text=("method", "path", "error", "seen", "removed"),
            ),
        ]
    if not changed.empty:
        parts += [
            "<h2>Files changed after they were scored</h2>",
            _table(
                changed[["path", "detected_at"]].assign(
                    seen=["" if pd.isna(at) else _when(at) for at in changed.acknowledged_at]
                ),
                text=("path", "detected_at", "seen"),
            ),
        ]
    parts.append(f"<script type='text/javascript'>{_SCRIPT}</script></body></html>")
    page = out / "index.html"
    _replace(page, "\n".join(parts).encode("utf-8"))
    return page


def _replace(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary file beside it, then a rename. A
    write that fails (a full disk) removes its temporary file: nothing is left behind."""
    temporary = path.with_name(f".{path.name}.tmp")
    try:
        temporary.write_bytes(data)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
