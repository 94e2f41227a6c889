"""Why a capture scored what it did: per-indicator terms, their explanation, the threshold's origin."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._calibration import HalfLaplaceFit
from axiswatch.monitor._decision import DecisionRule, stored_threshold
from axiswatch.paper._attribution import LIKELY_FAULTS, describe_top_indicator
from tests.naive import indicator_terms


@pytest.mark.parametrize("one_sided", [True, False])
def test_indicator_terms_match_the_loop_twin_and_add_up_to_the_distance(
    rng: np.random.Generator, one_sided: bool
) -> None:
    baseline, test = rng.normal(size=(4, 6)), rng.normal(size=(3, 6)) + 0.3
    detector = aw.IndicatorDetector(one_sided=one_sided).fit(baseline)
    terms = detector.contributions(test)
    np.testing.assert_allclose(
        terms, indicator_terms(baseline, test, one_sided=one_sided), rtol=1e-12
    )
    assert terms.sum() == pytest.approx(detector.distance(test), rel=1e-12)


def test_the_top_indicator_is_the_largest_share_with_its_likely_fault() -> None:
    why = {
        "impulsiveness": {"value": 4.0, "baseline": 3.5, "spreads": 1.2, "share": 0.1},
        "bearing_lines": {"value": 9.0, "baseline": 1.1, "spreads": 9.04, "share": 0.9},
        "coulomb_friction": {"value": 5.0, "baseline": 5.0, "spreads": -0.3, "share": 0.0},
    }
    assert describe_top_indicator(why) == (
        "bearing_lines +9.0 healthy spreads (90 % of the distance): likely "
        + LIKELY_FAULTS["bearing_lines"]
    )
    # An indicator without a known fault is named alone.
    assert describe_top_indicator({"gap_ringing": {"spreads": 2.0, "share": 1.0}}) == (
        "gap_ringing +2.0 healthy spreads (100 % of the distance)"
    )


def test_no_indicator_moved_up_gives_no_top_indicator() -> None:
    calm = {
        name: {"value": 1.0, "baseline": 1.0, "spreads": -0.5, "share": 0.0}
        for name in LIKELY_FAULTS
    }
    assert describe_top_indicator(calm) is None
    assert describe_top_indicator({}) is None


def test_threshold_description_names_its_origin() -> None:
    fit = HalfLaplaceFit(scale=2.0, n_distances=5, ks_statistic=0.1, ks_pvalue=0.9)
    fitted = fit.threshold(99.0)
    rule = DecisionRule(percentile=99.0)
    assert stored_threshold(fitted, fit, rule).describe() == (
        "99th pct of half-Laplace fit of 5 healthy captures"
    )
    assert stored_threshold(fitted + 3.0, fit, rule).describe() == (
        f"task-change allowance {fitted + 3.0:.4g} (fitted {fitted:.3g} on 5 healthy captures)"
    )
    described = stored_threshold(fit.threshold(95.0), fit, DecisionRule(percentile=95.0))
    assert described.describe().startswith("95th pct")


def test_a_likely_fault_names_no_gearbox_a_linear_axis_lacks() -> None:
    # A ball-screw or linear servo axis has no gearbox. Before: "backlash in the gearbox".
    for name, meaning in LIKELY_FAULTS.items():
        if name != "tooth_lines":  # read only where the profile declares a gear stage
            assert "gearbox" not in meaning or "ball screw" in meaning, (name, meaning)
