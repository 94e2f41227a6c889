"""The monitor's pure decision: role, threshold, over, alarm and reason of one capture."""

from __future__ import annotations

import numpy as np
import pytest

from axiswatch._calibration import HalfLaplaceFit, Threshold
from axiswatch.monitor._decision import AxisHistory, Decision, DecisionRule, decide
from tests.naive import axis_decisions_naive, threshold_origin_naive


def decide_all(
    distances: list[float],
    alarmed_before: list[bool],
    rule: DecisionRule,
    *,
    top_indicator: str | None = None,
) -> list[Decision]:
    """Fold ``decide`` over one baseline's captures, keeping the history as a store does."""
    threshold: Threshold | None = None
    calibration: list[float] = []
    recent: list[tuple[bool, bool]] = []
    decisions = []
    for distance, excluded in zip(distances, alarmed_before, strict=True):
        if threshold is None:
            history = AxisHistory(calibration_distances=tuple(calibration), alarmed_before=excluded)
        else:
            history = AxisHistory(
                threshold=threshold.value, fit=threshold.fit, recent=tuple(recent[-rule.window :])
            )
        decision = decide(history, distance, rule, top_indicator=top_indicator)
        decisions.append(decision)
        if decision.role == "calibration":
            calibration.append(distance)
        if decision.role == "monitor":
            recent.append((decision.over, decision.alarm))
        if decision.calibrated is not None:
            threshold = decision.calibrated
    return decisions


@pytest.mark.parametrize("seed", range(40))
def test_decide_matches_the_naive_axis_on_random_histories(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    rule = DecisionRule(
        percentile=float(rng.choice([90.0, 95.0, 99.0, 99.9])),
        calibration_size=int(rng.integers(2, 7)),
        alarm_k=int(rng.integers(1, n + 1)),
        alarm_n=n,
        clear_m=int(rng.integers(1, 4)),
        floor=None if rng.random() < 0.5 else float(rng.uniform(0.5, 8.0)),
    )
    size = 60
    # Healthy distances of scale 1; a fault from capture 25 to 39 and stray faulty captures
    # after the tenth, all 60x larger (so that every seed raises and clears an alarm).
    index = np.arange(size)
    faulty = ((index >= 25) & (index < 40)) | ((rng.random(size) < 0.1) & (index >= 10))
    distances = rng.exponential(1.0, size) * np.where(faulty, 60.0, 1.0)
    excluded = list(rng.random(size) < 0.15)
    decisions = decide_all(list(distances), excluded, rule)
    expected = axis_decisions_naive(
        list(distances),
        excluded,
        calibration_size=rule.calibration_size,
        percentile=rule.percentile,
        floor=rule.floor,
        k=rule.alarm_k,
        n=rule.alarm_n,
        m=rule.clear_m,
    )
    assert [d.role for d in decisions] == [e[0] for e in expected]
    assert [(d.over, d.alarm) for d in decisions] == [(e[2], e[3]) for e in expected]
    for decision, (_, threshold, _, _) in zip(decisions, expected, strict=True):
        if threshold is None:
            assert decision.threshold is None
        else:
            assert decision.threshold == pytest.approx(threshold, rel=1e-12)
    assert sum(d.calibrated is not None for d in decisions) == 1
    assert any(d.alarm for d in decisions)
    assert not all(d.alarm for d in decisions[40:])  # and clears after the fault
    # Every monitored reason names the threshold's origin as the naive twin finds it.
    healthy = [
        d for d, decision in zip(distances, decisions, strict=True)
        if decision.role == "calibration"
    ][: rule.calibration_size]  # fmt: skip
    origin = threshold_origin_naive(healthy, rule.percentile, rule.floor)
    monitored = [d.reason for d in decisions if d.role == "monitor"]
    assert monitored
    assert all(("(task-change allowance " in r) == (origin == "floor") for r in monitored)


def test_reasons_say_what_was_decided() -> None:
    rule = DecisionRule(calibration_size=2, alarm_k=2, alarm_n=3, clear_m=2, floor=50.0)
    decisions = decide_all([1.0, 3.0, 60.0, 70.0, 1.0, 1.0, 1.0], [False] * 7, rule)
    floor = "(task-change allowance 50 (fitted 9.21 on 2 healthy captures))"
    assert [d.reason for d in decisions] == [
        "calibration capture 1 of 2: distance 1, assumed healthy",
        "calibration capture 2 of 2: distance 3, assumed healthy; threshold set to 9.21 (99th "
        "pct of the half-Laplace fit of 2 healthy distances), raised to the floor 50 that "
        "healthy task changes need (development protocol, docs/evaluation.md)",
        f"distance 60 > threshold 50 {floor}; 1 of last 1 over; healthy",
        f"distance 70 > threshold 50 {floor}; 2 of last 2 over; ALARM raised",
        f"distance 1 <= threshold 50 {floor}; 2 of last 3 over; alarm "
        "persists until 2 clean captures in a row (1 so far)",
        f"distance 1 <= threshold 50 {floor}; 1 of last 3 over; alarm "
        "cleared after 2 clean capture(s) in a row",
        f"distance 1 <= threshold 50 {floor}; 0 of last 3 over; healthy",
    ]
    assert decisions[1].calibrated is not None
    assert decisions[1].calibrated.origin == "floor"
    # The reason names the threshold's origin (the floor here, not the fitted percentile) and,
    # only over the threshold or in alarm, the top indicator.
    top = "viscous_friction +4.1 (likely friction)"
    named = decide_all([1.0, 3.0, 60.0, 70.0, 1.0, 1.0], [False] * 6, rule, top_indicator=top)
    flagged = [d.over or d.alarm for d in named]
    assert flagged == [False, False, True, True, True, False]
    assert [("; top indicator " + top) in d.reason for d in named] == flagged
    plain = DecisionRule(calibration_size=2)
    assert "(99th pct of half-Laplace fit of 2 healthy captures)" in (
        decide_all([1.0, 3.0, 1.0], [False] * 3, plain)[-1].reason
    )
    assert decisions[3].details["pvalue"] == pytest.approx(np.exp(-70.0 / 2.0))


def test_an_alarmed_capture_never_calibrates() -> None:
    decision = decide(AxisHistory(alarmed_before=True), 0.5, DecisionRule())
    assert (decision.role, decision.threshold, decision.over, decision.alarm) == (
        "excluded",
        None,
        False,
        False,
    )
    assert decision.reason == (
        "distance 0.5; not used for calibration: this capture raised an alarm under an earlier "
        "baseline"
    )


def test_a_calibration_that_cannot_be_fitted_waits() -> None:
    decision = decide(
        AxisHistory(calibration_distances=(0.0,)), 0.0, DecisionRule(calibration_size=2)
    )
    assert decision.calibrated is None
    assert decision.threshold is None
    assert decision.reason.endswith(
        "; threshold not set yet (All healthy distances are 0: the half-Laplace scale cannot be "
        "estimated (were the calibration captures copies of the baseline?).)"
    )


def test_a_monitored_capture_needs_the_fit() -> None:
    fit = HalfLaplaceFit(scale=1.0, n_distances=5, ks_statistic=0.1, ks_pvalue=0.9)
    decision = decide(AxisHistory(threshold=4.6, fit=fit), 5.0, DecisionRule())
    assert (decision.role, decision.over, decision.alarm) == ("monitor", True, True)
    with pytest.raises(AssertionError, match="a baseline with a threshold has a fit"):
        decide(AxisHistory(threshold=4.6), 5.0, DecisionRule())
