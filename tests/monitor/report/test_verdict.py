"""Verdicts in words: state, fault, part, since when, how sure; and the table behind the words."""

from __future__ import annotations

import json
import math
import re

import pandas as pd
import pytest

from axiswatch.indicators._readings import INDICATORS
from axiswatch.indicators._spreads import ORDER_LINES
from axiswatch.monitor.report.advice import ADVICE, advice_for, indicator_colour
from axiswatch.monitor.report.attention import AxisAttention
from axiswatch.monitor.report.verdict import (
    CONFIRM_CAPTURES,
    LARGE_MARGIN,
    attention_lines,
    axis_verdicts,
)
from axiswatch.monitor.store import AlarmState

#: What must never reach a verdict's sentences: indicator code names and statistics terms.
CODE = re.compile(r"\b[a-z]+_[a-z_:]+\b|spread|half-Laplace|percentile|\bpct\b|allowance")


def _details(top: str, level: float, *, falling: bool = False) -> str:
    """A score's details as method ``indicators`` stores them: ``top`` set the distance."""
    value, baseline = (1.0, 2.0) if falling else (2.0, 1.0)
    return json.dumps(
        {
            "indicators": {
                top: {"value": value, "baseline": baseline, "spreads": 6 * level, "share": 0.8},
                "impulsiveness": {"value": 1, "baseline": 1, "spreads": 0.5, "share": 0.2},
            },
            "threshold_spreads": 6.0,
        }
    )


def _axis(levels: list[float], *, top: str = "coulomb_friction", axis: str = "a1") -> pd.DataFrame:
    """Five calibration captures at 0.3, then monitored ones at ``levels`` (alarm level 1)."""
    rows = []
    for day, level in enumerate([0.3] * 5 + levels, start=2):
        rows.append(
            {
                "robot": "r1", "axis": axis, "method": "indicators", "epoch": 1,
                "capture": f"2026-03-{day:02d}.csv", "captured_at": f"2026-03-{day:02d}T00:00:00",
                "role": "calibration" if day < 7 else "monitor", "distance": level,
                "threshold": 1.0, "over": level > 1.0, "alarm": level > 1.0,
                "details": _details(top, level), "reason": "",
            }
        )  # fmt: skip
    return pd.DataFrame(rows)


def _item(frame: pd.DataFrame, kind: str) -> AxisAttention:
    last = frame.iloc[-1]
    return AxisAttention(
        "r1", str(last.axis), "indicators", kind, f"technical line of {last.axis}",
        float(last.distance), str(last.captured_at), [kind],
    )  # fmt: skip


def _alarm(frame: pd.DataFrame, verdict: str | None = None, by: str | None = None) -> AlarmState:
    last = frame.iloc[-1]
    return AlarmState(
        "r1", str(last.axis), "indicators", 1, 1, str(last.capture), str(last.captured_at),
        by, None if by is None else "looked at it", None if by is None else "2026-04-01",
        verdict,
    )  # fmt: skip


def _verdict(levels: list[float], **alarm: str | None) -> object:
    frame = _axis(levels)
    kind = "acknowledged" if alarm.get("by") else "alarm"
    [verdict] = axis_verdicts([_item(frame, kind)], frame, [_alarm(frame, **alarm)])
    return verdict


def test_one_capture_over_is_watch_unconfirmed_and_a_run_or_a_margin_is_act_now() -> None:
    single = _verdict([0.2, 0.3, 0.2, 1.3])
    assert (single.state, single.confirmed, single.label) == ("watch", False, "watch, unconfirmed")
    assert single.sureness.startswith("1.3 times the alarm level on one capture: unconfirmed")
    assert single.action.startswith("Nothing yet: a second capture over the alarm level")
    run = _verdict([0.2, 0.3, 0.2] + [1.3] * CONFIRM_CAPTURES)
    assert (run.state, run.confirmed) == ("act now", True)
    assert f"confirmed by {CONFIRM_CAPTURES} captures in a row" in run.sureness
    assert run.since.startswith(f"Over the alarm level since 2026-03-{9 + 1:02d}")
    large = _verdict([0.2, 0.3, 0.2, LARGE_MARGIN])
    assert (large.state, large.confirmed) == ("act now", True)
    assert "confirmed by a large margin" in large.sureness
    # Over the level with no alarm (a k-of-n rule not met yet): the monitor decides, not this.
    frame = _axis([0.2, 3.0, 3.0])
    [pending] = axis_verdicts([_item(frame, "ok")], frame, [])
    assert (pending.state, pending.label) == ("watch", "watch, unconfirmed")
    assert "2 captures in a row: not an alarm yet under the monitor's rule" in pending.sureness
    # The last capture is back under the level while the alarm holds (clear_m > 1).
    back = _verdict([0.2, 1.5, 1.5, 0.5])
    assert (back.state, back.confirmed) == ("watch", False)
    assert back.since.startswith("In alarm, but the last capture (2026-03-10) is back under")


def test_how_sure_counts_the_earlier_captures_that_got_that_far() -> None:
    verdict = _verdict([0.2, 1.4, 0.2, 0.3, 1.3])
    assert verdict.sureness.endswith(
        "1 of this axis's 9 earlier captures got that far (2026-03-08)."
    )
    assert _verdict([0.2, 0.3, 1.3]).sureness.endswith(
        "None of this axis's 7 earlier captures got that far."
    )


def test_since_says_how_the_excursion_developed() -> None:
    built = _verdict([0.1, 0.3, 0.5, 0.7, 0.9, 1.2, 1.4])
    assert built.since == (
        "Over the alarm level since 2026-03-12 (2 captures), rising. It built up over the 5 "
        "captures before, from 0.1 to 0.9 of the alarm level."
    )
    sudden = _verdict([0.2, 0.3, 0.2, 0.3, 0.2, 1.3])
    assert sudden.since.endswith("It came suddenly: the 5 captures before stood at about 0.2 of "
                                 "the alarm level.")  # fmt: skip


def test_the_fault_part_and_action_come_from_the_table_in_words() -> None:
    frame = _axis([0.2, 1.5, 1.6], top="load_backward")
    [verdict] = axis_verdicts([_item(frame, "alarm")], frame, [_alarm(frame)])
    assert verdict.headline == (
        "Friction rising in backward moves. Suspected: drive train lubrication."
    )
    assert verdict.action.startswith("Check the lubrication of the gearbox or ball screw")
    assert verdict.indicator == "load_backward"
    assert "load_backward" in verdict.details  # the code name is kept, folded
    falling = frame.assign(details=[_details("load_backward", 1, falling=True)] * len(frame))
    [verdict] = axis_verdicts([_item(falling, "alarm")], falling, [_alarm(falling)])
    assert verdict.fault == "friction falling in backward moves"
    bearing = _axis([0.2, 1.5, 1.6], top="bearing_lines:motor_inner_race")
    [verdict] = axis_verdicts([_item(bearing, "alarm")], bearing, [_alarm(bearing)])
    assert verdict.headline == "Bearing damage. Suspected: bearing motor inner race."


def test_the_engineers_feedback_sets_the_state() -> None:
    levels = [0.2, 0.3, 1.3]
    confirmed = _verdict(levels, verdict="fault-confirmed", by="ana")
    assert (confirmed.state, confirmed.confirmed) == ("act now", True)
    assert confirmed.feedback == "ana fault confirmed on 2026-04-01: looked at it."
    assert confirmed.action.endswith("After the repair: axiswatch ack --rebaseline.")
    false_alarm = _verdict(levels, verdict="false-alarm", by="ana")
    assert (false_alarm.state, false_alarm.confirmed) == ("watch", True)
    assert false_alarm.feedback == "ana marked a false alarm on 2026-04-01: looked at it."
    task = _verdict(levels, verdict="task-changed", by="ana")
    assert task.action.startswith("If the new task stays, re-baseline the axis")
    assert _verdict(levels, by="ana").feedback == "ana saw it on 2026-04-01: looked at it."


def test_a_confirmed_fault_no_longer_asks_to_record_a_task_change() -> None:
    # The linear axis's friction alarm, acknowledged with --fault-confirmed. Before: "... If the
    # tool or payload changed, record it: axiswatch ack --task-changed. After the repair: ...".
    frame = _axis([0.2, 1.5, 1.6], top="load_forward")
    [open_alarm] = axis_verdicts([_item(frame, "alarm")], frame, [_alarm(frame)])
    assert "ack --task-changed" in open_alarm.action  # a payload change moves it too
    alarm = _alarm(frame, verdict="fault-confirmed", by="ana")
    [confirmed] = axis_verdicts([_item(frame, "acknowledged")], frame, [alarm])
    assert confirmed.action.startswith("Check the lubrication of the gearbox or ball screw")
    assert "--task-changed" not in confirmed.action
    assert confirmed.action.endswith("After the repair: axiswatch ack --rebaseline.")


def test_rising_friction_asks_whether_the_payload_changed() -> None:
    # A heavier payload raises the Coulomb friction too: the engineer who changed it says so.
    frame = _axis([0.2, 1.5, 1.6], top="coulomb_friction")
    [open_alarm] = axis_verdicts([_item(frame, "alarm")], frame, [_alarm(frame)])
    assert open_alarm.action.startswith("Check the lubrication")
    assert "If the tool or payload changed, record it" in open_alarm.action


def test_verdicts_rank_by_urgency_then_sureness() -> None:
    single, run = _axis([0.2, 1.2], axis="a1"), _axis([1.1, 1.1], axis="a2")
    ok = _axis([0.2], axis="a3")
    bad = AxisAttention("r1", "a4", "indicators", "bad data", "1 capture file(s) rejected, "
                        "latest: r1/a4/x.csv: file is empty (0 bytes).", math.nan, None,
                        ["bad data"])  # fmt: skip
    learning = AxisAttention("r1", "a5", "indicators", "calibrating", "Calibrating", math.nan,
                             None)  # fmt: skip
    results = pd.concat([single, run, ok])
    items = [_item(single, "alarm"), bad, learning, _item(run, "alarm"), _item(ok, "ok")]
    ranked = axis_verdicts(items, results, [_alarm(single), _alarm(run)])
    assert [(v.axis, v.label) for v in ranked] == [
        ("a2", "act now"), ("a4", "bad data"), ("a1", "watch, unconfirmed"), ("a5", "learning"),
        ("a3", "OK"),
    ]  # fmt: skip
    assert ranked[1].since.startswith("1 capture file(s) rejected, latest: r1/a4/x.csv")
    lines = attention_lines(ranked, "indicators")
    # The axis with rejected files is counted: the run lists its files (by the hundred, for a
    # first run of a misread export), so its verdict would repeat them.
    assert lines[0] == (
        "Needs attention (indicators): 3 of 5 axes; 1 axis with rejected or changed files "
        "('axiswatch rejections' lists them)"
    )
    assert lines[1] == "  ACT NOW  r1/a2  Friction rising. Suspected: drive train lubrication."
    assert not any("r1/a4" in line for line in lines)
    assert any(line.startswith("  WATCH, UNCONFIRMED  r1/a1  ") for line in lines)
    assert lines[-1] == "  1 axis learning, 1 axis OK."
    assert max(map(len, lines[1:])) <= 100


@pytest.mark.parametrize("top", [*ADVICE, "tooth_lines:intermediate", "bearing_lines:outer"])
def test_no_code_name_or_statistics_term_in_a_verdict(top: str) -> None:
    frame = _axis([0.2, 1.3, 1.4], top=top or "coulomb_friction")
    if not top:  # the paper's methods store no indicators
        frame = frame.assign(details="{}")
    [verdict] = axis_verdicts([_item(frame, "alarm")], frame, [_alarm(frame)])
    text = " ".join(verdict.sentences())
    assert verdict.fault
    assert verdict.action
    assert not CODE.search(text.replace("axiswatch ack --", "")), text


def test_every_indicator_has_words_and_its_own_colour() -> None:
    """A new indicator must get a row of the table: else its verdict says nothing useful."""
    names = [i.name for i in INDICATORS] + [ORDER_LINES.name]
    assert [n for n in names if n.split(":")[0] not in ADVICE] == []
    colours = [row.colour for row in ADVICE.values()]
    assert len(set(colours)) == len(colours)
    # Red, orange and green mark alarms, excursions and baselines in the charts.
    assert not {"#d62728", "#ff7f0e", "#2ca02c", "red", "orange", "green"} & set(colours)
    assert advice_for("no_such_indicator").rising == "an unusual reading"


@pytest.mark.parametrize("top", [i.name for i in INDICATORS] + [ORDER_LINES.name])
def test_an_indicator_read_without_gears_never_names_a_gearbox_alone(top: str) -> None:
    # A linear axis (a ball screw, a linear servo) has no gearbox. Before: "Check the gearbox
    # lubrication", "plan a gearbox service", "backlash in the gear train" for every axis.
    frame = _axis([0.2, 1.3, 1.4], top=top)
    [verdict] = axis_verdicts([_item(frame, "alarm")], frame, [_alarm(frame)])
    row = ADVICE[top]
    for text in (" ".join(verdict.sentences()), row.measures, row.action, row.action_falling):
        assert "gear " not in text, text
        assert "gear'" not in text, text
        assert "gearbox" not in text or "gearbox or ball screw" in text, text


def _colours(chart: str) -> dict[str, str]:
    """Each indicator trace's line colour in a chart's figure JSON."""
    figure = json.loads(re.search(r"Plotly\.newPlot\(\s*\"[^\"]+\",\s*(\[.*?\]),\s*\{", chart,
                                  re.S)[1])  # fmt: skip
    return {t["name"]: t["line"].get("color") for t in figure if "line" in t}


def test_an_indicator_has_one_colour_on_every_axis() -> None:
    """Plotly colours traces by their order: an axis without the friction reading showed its
    drive load in the friction's colour."""
    from axiswatch.monitor.report.charts import distance_chart

    both = _axis([0.2, 1.3], top="load_backward")
    one = both.assign(
        details=[json.dumps({"indicators": {"load_backward": json.loads(d)["indicators"][
            "load_backward"]}, "threshold_spreads": 6.0}) for d in both.details]
    )  # fmt: skip
    first = _colours(distance_chart(both, div_id="a", indicators=True))
    second = _colours(distance_chart(one, div_id="b", indicators=True))
    assert first["load_backward"] == second["load_backward"] == indicator_colour("load_backward")
    assert first["impulsiveness"] == ADVICE["impulsiveness"].colour
    # A part of a profile is coloured by its name, so also the same on every axis.
    bearing = _axis([0.2, 1.3], top="bearing_lines:outer")
    shown = _colours(distance_chart(bearing, div_id="c", indicators=True))
    assert shown["bearing_lines:outer"] == indicator_colour("bearing_lines:outer")
