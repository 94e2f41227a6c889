"""Why a capture scored what it did: per-indicator terms, their explanation, the threshold's origin."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
from axiswatch._calibration import HalfLaplaceFit
from axiswatch._mechanics import COLUMNS, INDICATORS, LIKELY_FAULTS
from axiswatch.monitor._decision import DecisionRule, stored_threshold
from axiswatch.paper._attribution import describe_top_indicator, explain_indicators
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


@pytest.fixture(scope="module")
def bearing() -> tuple[aw.MechanicsStage, aw.IndicatorDetector, aw.Capture]:
    stage = aw.MechanicsStage().fit(awd.simulate_capture("short_fast", seed=11))
    detector = aw.IndicatorDetector().fit(stage.baseline_rows_)
    return (
        stage,
        detector,
        awd.simulate_capture("short_fast", fault=awd.Fault("bearing", 0.6), seed=21),
    )


def test_explanation_reads_the_stage_and_splits_the_distance(
    bearing: tuple[aw.MechanicsStage, aw.IndicatorDetector, aw.Capture],
) -> None:
    stage, detector, capture = bearing
    X = stage.transform(capture).X
    why = explain_indicators(stage, detector, X)
    assert list(why) == list(COLUMNS)
    assert sum(e["share"] for e in why.values()) == pytest.approx(1.0, abs=1e-12)
    # Values and baselines are the stage's own readings (log10, mean of both directions).
    readings = stage.readings(capture)
    for i, name in enumerate(INDICATORS):
        assert np.log10(why[name]["value"]) == pytest.approx(readings[:, i].mean(), abs=1e-12)
        assert np.log10(why[name]["baseline"]) == pytest.approx(
            stage.baseline_readings_[:, i].mean(), abs=1e-12
        )
        # The shift in spreads is the change of the reading over the indicator's spread.
        expected = (readings[:, i].mean() - stage.baseline_readings_[:, i].mean()) / stage.scales[i]
        assert why[name]["spreads"] == pytest.approx(expected, abs=1e-9)
    assert why["viscous_friction_deficit"]["spreads"] == pytest.approx(
        -why["viscous_friction"]["spreads"], abs=1e-12
    )
    # A bearing defect: the bearing lines carry the distance (measured +9 spreads, 99 %).
    top = max(why, key=lambda name: why[name]["share"])
    assert top == "bearing_lines"
    line = describe_top_indicator(why)
    assert line is not None
    assert line.startswith("bearing_lines +")
    assert line.endswith(f"likely {LIKELY_FAULTS['bearing_lines']}")


def test_no_indicator_moved_up_gives_no_top_indicator() -> None:
    calm = {
        name: {"value": 1.0, "baseline": 1.0, "spreads": -0.5, "share": 0.0} for name in COLUMNS
    }
    assert describe_top_indicator(calm) is None
    assert describe_top_indicator({}) is None


def test_every_column_has_a_likely_fault() -> None:
    assert set(LIKELY_FAULTS) == set(COLUMNS)


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
