"""The HTML report of a monitoring store: fleet summary on top, one trend figure per axis.

Pipeline side-stage (reads the store, writes files). The page is self-contained (figures embedded
as base64 PNG, no script, no server) and the PNGs are also written beside it.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Any

import pandas as pd

from axiswatch._plotting import new_axes, plot_distance_trend
from axiswatch.monitor._results import fleet_rejections, fleet_results, fleet_summary
from axiswatch.monitor._store import StoreBackend

__all__ = ["write_report"]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em; max-width: 1100px; color: #222; }
table { border-collapse: collapse; font-size: 0.85em; margin-bottom: 1em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f0f0f0; }
td:first-child, th:first-child { text-align: left; }
.ALARM { background: #f8d0d0; font-weight: bold; }
.calibrating { background: #e0ecf8; }
.note { color: #555; font-size: 0.9em; }
img { max-width: 100%; }
"""

_LEGEND = (
    "Each figure shows, per method, the distance of every capture to the axis's baseline over "
    "time: green band = baseline capture, blue band = calibration captures (assumed healthy; "
    "they set the threshold), dashed red line = alarm threshold, orange dot = over the threshold, "
    "red cross = alarm. A new baseline (after maintenance) starts a new epoch."
)


def _figure(
    axis_rows: pd.DataFrame,
    title: str,
    fault_dates: pd.Series | None,
    events: list[tuple[str, str]],
) -> Any:
    methods = sorted(axis_rows.method.unique())
    axes = new_axes(len(methods), 1, figsize=(9, 2.8 * len(methods)), squeeze=False, sharex=True)
    figure = axes[0, 0].figure
    for ax, method in zip(axes[:, 0], methods, strict=True):
        plot_distance_trend(
            axis_rows[axis_rows.method == method],
            ax=ax,
            title=f"{title} - {method}",
            fault_dates=fault_dates,
            events=events,
        )
    figure.tight_layout()
    return figure


def _table(frame: pd.DataFrame) -> str:
    rows = []
    header = "".join(f"<th>{html.escape(str(c))}</th>" for c in frame.columns)
    for values in frame.to_dict(orient="records"):
        css = str(values.get("state", ""))
        cells = "".join(f"<td>{html.escape(_format(v))}</td>" for v in values.values())
        rows.append(f'<tr class="{html.escape(css)}">{cells}</tr>')
    return f"<table><tr>{header}</tr>{''.join(rows)}</table>"


def _format(value: Any) -> str:
    if isinstance(value, float):
        return "" if pd.isna(value) else f"{value:.4g}"
    return "" if value is None else str(value)


def write_report(
    store: StoreBackend, out: str | Path, *, labels: pd.DataFrame | None = None
) -> Path:
    """Write ``out/index.html`` and one PNG per axis; return the page's path.

    Parameters
    ----------
    store : StoreBackend
    out : str or Path
        Folder (created if needed).
    labels : DataFrame, optional
        Ground truth of a simulated fleet (``robot``, ``axis``, ``date``, ``task``, ``fault``);
        task changes and faulty captures are then marked on each trend.

    Returns
    -------
    Path
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = fleet_summary(store)
    results = fleet_results(store)
    rejections = fleet_rejections(store)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>axiswatch fleet report</title>",
        f"<style>{_STYLE}</style></head><body>",
        "<h1>axiswatch fleet report</h1>",
        f"<p class='note'>Store: {html.escape(store.location)}. State after the last capture "
        "of each axis: <b>ALARM</b> when the alarm rule fired and has not cleared, "
        "<i>calibrating</i> while the threshold is not set yet.</p>",
        "<h2>Fleet summary</h2>",
        _table(summary) if not summary.empty else "<p>No axis has a baseline yet.</p>",
    ]
    if not rejections.empty:
        parts += ["<h2>Rejected captures</h2>", _table(rejections[["method", "path", "error"]])]
    changed = store.changed_file_table()
    if not changed.empty:
        parts += ["<h2>Files changed after they were scored</h2>", _table(changed)]
    parts += ["<h2>Axes</h2>", f"<p class='note'>{html.escape(_LEGEND)}</p>"]
    for (robot_key, axis_key), axis_rows in results.groupby(["robot", "axis"], sort=True):
        robot, axis = str(robot_key), str(axis_key)
        fault_dates = None
        events: list[tuple[str, str]] = []
        if labels is not None:
            own = labels[(labels.robot == robot) & (labels.axis == axis)].sort_values("date")
            fault_dates = own[own.fault != "none"].date
            task_changed = own.task.ne(own.task.shift()) & own.task.shift().notna()
            events = [(str(r.date), f"task -> {r.task}") for r in own[task_changed].itertuples()]
        figure = _figure(axis_rows, f"{robot}/{axis}", fault_dates, events)
        name = f"{robot}_{axis}.png"
        figure.savefig(out / name, dpi=90)
        buffer = io.BytesIO()
        figure.savefig(buffer, format="png", dpi=90)
        encoded = base64.b64encode(buffer.getvalue()).decode("ascii")
        parts.append(f"<h3 id='{html.escape(robot)}-{html.escape(axis)}'>{robot} / {axis}</h3>")
        parts.append(
            f"<img alt='distance trend of {robot}/{axis}' src='data:image/png;base64,{encoded}'>"
        )
        alarms = axis_rows[axis_rows.alarm | axis_rows.over]
        if not alarms.empty:
            parts.append("<p>Captures over the threshold:</p>")
            parts.append(_table(alarms[["capture", "method", "reason"]]))
    parts.append("</body></html>")
    page = out / "index.html"
    page.write_text("\n".join(parts), encoding="utf-8")
    return page
