"""A mode library's verdict as the monitor's decision."""

from __future__ import annotations

import math

from axiswatch.indicators._mode_library import ModeAssessment
from axiswatch.monitor._decision import DecisionRule
from axiswatch.monitor._mode_decision import guarded, mode_decision


def _verdict(state: str, score: float, *, alarm: bool | None = None) -> ModeAssessment:
    over = score > 1.0 if alarm is None else alarm
    return ModeAssessment("c.csv", "mode1", state, score, over, "", 2, 5, 0.001)  # type: ignore[arg-type]


def test_the_baseline_guards_a_new_mode_where_it_scores_higher() -> None:
    learning = _verdict("learning", math.nan)
    caught = guarded(learning, 1.5, "coulomb_friction +9.1")
    assert (caught.score, caught.alarm) == (1.5, True)
    assert caught.where == "coulomb_friction +9.1, against the baseline"
    assert guarded(learning, math.nan, None) == learning  # another task, no fleet: no score
    quiet = guarded(_verdict("learning", 0.8), 0.3, None)
    assert (quiet.score, quiet.alarm) == (0.8, False)  # the library's guard is higher


def test_a_known_mode_is_scored_by_its_own_normal_only() -> None:
    known = _verdict("known", 0.4)
    assert guarded(known, 7.0, "load_forward +30") == known


def test_the_alarm_follows_the_rule_k_of_n() -> None:
    rule = DecisionRule(alarm_k=2, alarm_n=3, clear_m=2)
    first = mode_decision(_verdict("known", 1.4), [], rule)
    assert (first.over, first.alarm, first.threshold) == (True, False, 1.0)
    second = mode_decision(_verdict("known", 1.2), [(True, False)], rule)
    assert second.alarm
    assert second.reason.endswith("ALARM raised")
    assert "top_indicator" not in second.details  # the verdict named no reading
    cleared = mode_decision(_verdict("known", 0.2), [(True, True), (False, True)], rule)
    assert not cleared.alarm
    assert cleared.reason.endswith("alarm cleared")


def test_a_drifted_mode_alarms_and_says_so() -> None:
    drift = mode_decision(_verdict("drift", 0.6, alarm=True), [], DecisionRule())
    assert drift.alarm
    assert drift.reason.startswith("mode mode1: drifted from its first fit")
    assert drift.details["mode_state"] == "drift"
