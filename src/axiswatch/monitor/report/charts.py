"""Interactive trend charts of the report, drawn by Plotly.

Each function returns an HTML ``<div>`` that draws itself from the page's one inline copy of
plotly.js, so the report opens from a file share with no server.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Sequence
from typing import Any

import pandas as pd

from axiswatch.monitor._methods import methods
from axiswatch.monitor.report.advice import indicator_colour

__all__ = ["distance_chart", "plotly_library"]

_CONFIG = {"displaylogo": False, "responsive": True}
_HALF_DAY = pd.Timedelta(hours=12)


def _unit(method: str) -> str:
    """What a method's stored distance counts (a method no longer registered: spreads)."""
    preset = methods().get(method)
    return "healthy spreads" if preset is None else preset.distance_unit


def plotly_library() -> str:
    """The minified plotly.js of the installed ``plotly`` package, for one inline ``<script>``."""
    from plotly.offline import get_plotlyjs

    return str(get_plotlyjs())


def _hover(text: str) -> str:
    # Plotly's hover labels take a little HTML: escape the reason's '<' and '>' and break it
    # at its clauses so that it stays readable.
    return html.escape(str(text), quote=False).replace("; ", "<br>")


def _span(figure: Any, start: pd.Timestamp, stop: pd.Timestamp, colour: str, label: str) -> None:
    figure.add_shape(
        type="rect", xref="x", yref="paper", x0=start - _HALF_DAY, x1=stop + _HALF_DAY,
        y0=0, y1=1, fillcolor=colour, opacity=0.15, line_width=0, layer="below",
    )  # fmt: skip
    # Labelled at the span's right end: a baseline's label then never covers the calibration's.
    figure.add_annotation(
        x=stop + _HALF_DAY, xref="x", y=1.0, yref="paper", text=label, showarrow=False,
        xanchor="right", yanchor="bottom", font={"size": 10, "color": colour},
    )  # fmt: skip


def _vertical(figure: Any, when: pd.Timestamp, colour: str, label: str) -> None:
    figure.add_shape(
        type="line", xref="x", yref="paper", x0=when, x1=when, y0=0, y1=1,
        line={"color": colour, "dash": "dot", "width": 1},
    )  # fmt: skip
    figure.add_annotation(
        x=when, xref="x", y=0.0, yref="paper", text=label, showarrow=False, textangle=-90,
        xanchor="right", yanchor="bottom", font={"size": 9, "color": colour},
    )  # fmt: skip


def distance_chart(
    rows: pd.DataFrame,
    *,
    div_id: str,
    indicators: bool,
    events: Sequence[tuple[str, str]] = (),
    fault_dates: Sequence[str] = (),
    height: int | None = None,
) -> str:
    """An axis's distance trend per method (and, for the default method, each indicator's).

    Parameters
    ----------
    rows : DataFrame
        :func:`~axiswatch.monitor.report.results.fleet_results` rows of one axis (one or more methods).
    div_id : str
        Id of the chart's ``<div>`` (unique in the page).
    indicators : bool
        Add a panel of each indicator's shift from the baseline in healthy spreads, with the
        healthy band (+-1 spread) and the shift that alone reaches the threshold (the first
        method's rows must carry ``details["indicators"]``).
    events : sequence of (date-time, label)
        Known events (task changes) drawn as dotted lines.
    fault_dates : sequence of str
        Ground truth of a simulated fleet: dates of faulty captures, ticks along the bottom.
    height : int, optional
        Pixels; default from the number of panels.

    Returns
    -------
    str
        ``<div>`` and ``<script>``; needs :func:`plotly_library` loaded before it.

    Examples
    --------
    >>> rows = pd.DataFrame({
    ...     "capture": [f"2026-03-0{d}.csv" for d in range(1, 5)], "method": "lra",
    ...     "captured_at": [f"2026-03-0{d}T00:00:00" for d in range(1, 5)], "epoch": 1,
    ...     "role": ["baseline", "calibration", "monitor", "monitor"],
    ...     "distance": [None, 1.0, 1.2, 5.0], "threshold": [None, 3.0, 3.0, 3.0],
    ...     "over": [False, False, False, True], "alarm": [False, False, False, True],
    ...     "reason": ["b", "c", "ok", "distance 5 > threshold 3; ALARM raised"],
    ...     "details": "{}"})
    >>> chart = distance_chart(rows, div_id="r1-a1", indicators=False)
    >>> 'id="r1-a1"' in chart, "Plotly.newPlot" in chart
    (True, True)
    """
    import plotly.graph_objects as go
    from plotly.io import to_html
    from plotly.subplots import make_subplots

    methods = list(dict.fromkeys(rows.method))
    # The method indicators stores its distance in units of the threshold that applied (the
    # threshold is 1): say so, as the indicators' panel does, or "1.55" has no unit.
    titles = [
        f"distance ({m}) in thresholds" if _unit(m) == "thresholds" else f"distance ({m})"
        for m in methods
    ]
    if indicators:
        # Method ``indicators`` scores a capture in the spreads of the case that applied (own
        # spreads for the baseline's task, the fleet's for a task change): its shifts are drawn
        # in units of that case's threshold, as its distance is.
        unit = _unit(methods[0])
        titles.append(f"indicators ({methods[0]}): shift from the baseline in {unit}")
    n_panels = len(titles)
    figure = make_subplots(
        rows=n_panels, cols=1, shared_xaxes=True, vertical_spacing=0.08, subplot_titles=titles
    )
    frame = rows.assign(when=pd.to_datetime(rows.captured_at))
    lead = frame[frame.method == methods[0]]
    for epoch, part in lead.groupby("epoch", sort=True):
        base = part[part.role == "baseline"]
        calibration = part[part.role == "calibration"]
        if not base.empty:
            start = base.when.iloc[0]
            _span(figure, start, start, "green", f"baseline {epoch}")
        if not calibration.empty:
            _span(
                figure, calibration.when.min(), calibration.when.max(), "royalblue", "calibration"
            )
    for when, label in events:
        _vertical(figure, pd.Timestamp(when), "purple", label)
    for day in map(pd.Timestamp, fault_dates):
        # Ticks along the bottom edge (paper coordinates: they show on a log axis too).
        figure.add_shape(
            type="rect", xref="x", yref="paper", x0=day - _HALF_DAY / 2,
            x1=day + _HALF_DAY / 2, y0=0, y1=0.02, fillcolor="purple", line_width=0,
        )  # fmt: skip
    if len(fault_dates):
        figure.add_annotation(
            x=pd.Timestamp(fault_dates[0]), xref="x", y=0.02, yref="paper", showarrow=False,
            text="fault (simulator label)", xanchor="left", yanchor="bottom",
            font={"size": 9, "color": "purple"},
        )  # fmt: skip
    for panel, method in enumerate(methods, start=1):
        own = frame[(frame.method == method) & (frame.role != "baseline")].dropna(
            subset=["distance"]
        )
        hover = [[c, _hover(r)] for c, r in zip(own.capture, own.reason, strict=True)]
        figure.add_trace(
            go.Scatter(
                x=own.when, y=own.distance, mode="lines+markers", name=f"distance ({method})",
                line={"color": "#555", "width": 1}, marker={"size": 5}, customdata=hover,
                hovertemplate="<b>%{customdata[0]}</b><br>distance %{y:.4g}<br>"
                "%{customdata[1]}<extra></extra>",
                legendgroup=method, showlegend=panel == 1,
            ),
            row=panel, col=1,
        )  # fmt: skip
        for epoch, part in own.groupby("epoch", sort=True):
            limit = part.dropna(subset=["threshold"])
            if not limit.empty:
                figure.add_trace(
                    go.Scatter(
                        x=limit.when, y=limit.threshold, mode="lines", line_shape="hv",
                        line={"color": "red", "dash": "dash", "width": 1},
                        name="threshold", legendgroup="threshold",
                        showlegend=bool(panel == 1 and epoch == own.epoch.min()),
                        hovertemplate="threshold %{y:.4g}<extra></extra>",
                    ),
                    row=panel, col=1,
                )  # fmt: skip
        for mask, name, marker in (
            (own.over & ~own.alarm, "over threshold", {"color": "orange", "size": 8}),
            (own.alarm, "alarm", {"color": "red", "size": 10, "symbol": "x"}),
        ):
            if mask.any():
                figure.add_trace(
                    go.Scatter(
                        x=own.when[mask], y=own.distance[mask], mode="markers", name=name,
                        marker=marker, customdata=[h for h, m in zip(hover, mask, strict=True) if m],
                        hovertemplate="<b>%{customdata[0]}</b><br>" + name
                        + ": distance %{y:.4g}<br>%{customdata[1]}<extra></extra>",
                        legendgroup=name, showlegend=panel == 1,
                    ),
                    row=panel, col=1,
                )  # fmt: skip
        positive = own.distance[own.distance > 0]
        if len(positive) and positive.max() / positive.min() > 100:
            figure.update_yaxes(type="log", row=panel, col=1)
    if indicators:
        _indicator_panel(go, figure, lead, n_panels)
    figure.update_layout(
        height=height or 260 + 230 * (n_panels - 1),
        margin={"l": 60, "r": 20, "t": 40, "b": 40},
        hovermode="closest",
        legend={"orientation": "h", "y": -0.08, "font": {"size": 10}},
        template="plotly_white",
    )
    return str(
        to_html(
            figure, full_html=False, include_plotlyjs=False, div_id=div_id, config=_CONFIG,
            default_width="100%",
        )
    )  # fmt: skip


def _indicator_panel(go: Any, figure: Any, lead: pd.DataFrame, panel: int) -> None:
    scored = lead[(lead.role != "baseline") & lead.distance.notna()]
    parsed = [json.loads(d) for d in scored.details]
    # Method ``indicators``: the distance is the largest shift (not the sum of squared shifts of
    # ``mechanics``), over the indicators each capture gives, in units of the threshold of the
    # case that applied (``threshold_spreads``; a task change's shifts in units of each
    # indicator's ``allowance``): a shift of 1 alone reaches the threshold.
    largest = bool(lead.method.map(_unit).eq("thresholds").any())
    explained = [
        {
            n: {
                **e,
                "spreads": e["spreads"]
                / float(e.get("allowance", 1.0))
                / float(p.get("threshold_spreads", 1.0)),
            }
            for n, e in p.get("indicators", {}).items()
        }
        if largest
        else p.get("indicators", {})
        for p in parsed
    ]
    first_seen = list(dict.fromkeys(n for e in explained for n in e))
    names = sorted(first_seen) if largest else first_seen
    for name in names:
        entries = [e.get(name) for e in explained]
        keep = [e is not None for e in entries]
        if not any(keep):
            continue
        values = [e for e in entries if e is not None]
        figure.add_trace(
            go.Scatter(
                x=scored.when[keep], y=[e["spreads"] for e in values], mode="lines+markers",
                name=name, marker={"size": 4, "color": indicator_colour(name)},
                line={"width": 1, "color": indicator_colour(name)},
                # The deficit column mirrors the friction's: hidden until asked for (legend).
                visible="legendonly" if name == "viscous_friction_deficit" else True,
                customdata=[
                    [c, e["value"], e["baseline"], e["share"]]
                    for c, e in zip(scored.capture[keep], values, strict=True)
                ],
                hovertemplate="<b>%{customdata[0]}</b><br>" + name
                + f": %{{y:+.2f}} {'thresholds' if largest else 'healthy spreads'}"
                "<br>value %{customdata[1]:.4g} "
                "(baseline %{customdata[2]:.4g})<br>%{customdata[3]:.0%} of the distance"
                "<extra></extra>",
            ),
            row=panel, col=1,
        )  # fmt: skip
    if not largest:  # in thresholds, one healthy spread differs from capture to capture
        figure.add_hrect(
            y0=-1, y1=1, fillcolor="green", opacity=0.1, line_width=0, row=panel, col=1,
            annotation_text="healthy spread", annotation_position="top left",
        )  # fmt: skip
    thresholds = scored.threshold.dropna()
    if not thresholds.empty:
        last = float(thresholds.iloc[-1])
        alone = 1.0 if largest else math.sqrt(last)
        figure.add_hline(
            y=alone, line_dash="dash", line_color="red", line_width=1, row=panel, col=1,
            annotation_text=f"one indicator alone reaches the threshold ({alone:.2g})",
            annotation_position="top left",
        )  # fmt: skip
