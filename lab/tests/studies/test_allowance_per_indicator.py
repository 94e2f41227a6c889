"""The per-indicator allowance study (lab): its chosen variant (own pairs, at least the fleet's)
is the product's rule, its `fleet only` variant the rule before, and the own pairs follow their
naive twin (i13h)."""

from __future__ import annotations

import math

import pytest

import lab_naive as naive
from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._product import FleetPrior, _declared, _transformed, own_pair_allowances
from axiswatch_lab.studies.allowance_per_indicator import VARIANTS, _models, _scorers


def test_own_pair_allowances_by_hand_on_a_tiny_fleet() -> None:
    # Two indicators with a fleet scale: Bonferroni at 99.5 %, the quantile ln(200) x scale.
    prior = FleetPrior(
        {"a": 3.0, "b": 1.0}, 1.0, {"a": 0.0, "b": 0.0}, 5, 10, {"a": 1.0, "b": 2.0}, {}
    )
    others = [{"a": 0.0, "b": 1.0}, {"a": 5.0, "b": 2.0}, {"a": 20.0}, {"a": 30.0}]
    own = own_pair_allowances({"a": 10.0, "b": 9.0}, {"a": 4.0, "b": 1.0}, others, prior, 99.0)
    # a: |z| = 2, 1, 2, 4 in spreads of hypot(3, 4) = 5; median 2, scale 2 / ln 2.
    assert own["a"] == pytest.approx(2.0 / math.log(2.0) * math.log(200.0), rel=1e-12)
    # b: read on 2 other axes only (fewer than 3 pairs): the fleet's allowance, 2 ln(200).
    assert own["b"] == pytest.approx(2.0 * math.log(200.0), rel=1e-12)
    # An axis sharing its centre with most others has a median |z| of 0: it keeps the fleet's.
    shared = [{"a": 5.0}, {"a": 5.0}, {"a": 5.0}, {"a": 20.0}]
    middle = own_pair_allowances({"a": 5.0}, {"a": 4.0}, shared, prior, 99.0)
    assert middle["a"] == pytest.approx(math.log(200.0), rel=1e-12)


@pytest.mark.slow
def test_the_chosen_variant_scores_as_the_product_and_as_its_naive_twin() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[2])
    reader = IndicatorModel()
    fits = {
        t: [reader.readings(robot.capture(t, seed=f"fit{k}")) for k in range(5)] for t in range(4)
    }
    models, prior = _models(fits, None, 99.0)
    scorers = _scorers(models, prior, 99.0)
    assert list(scorers) == list(VARIANTS)
    tests = [
        reader.readings(robot.capture(t, seed=f"test{t}", fault=fault))
        for t in range(4)
        for fault in (None, Fault("friction", 0.8))
    ]
    fleet = prior.allowances(99.0)
    n_fitted = sum(math.isfinite(s) and s > 0 for s in prior.indicator_scales.values())
    compared = 0
    larger_somewhere = False
    differs = False
    for axis, model in models.items():
        others = [o.centre_ for k, o in models.items() if k != axis]
        own = naive.own_pair_allowances_naive(
            model.centre_, model.within_, others, prior.task_spreads, fleet, n_fitted, 99.0
        )
        got = own_pair_allowances(model.centre_, model.within_, others, prior, 99.0)
        assert got == pytest.approx(own, rel=1e-12)
        larger = {n: max(a, own[n]) for n, a in fleet.items()}
        larger_somewhere |= larger != fleet
        scales = {n: s * larger.get(n, prior.allowance(99.0)) for n, s in model.scales_.items()}
        two_sided = {n for n in scales if _declared(n).sided == "both"}
        loo = naive.leave_one_out_distances_naive(model.calibration_rows_, scales, two_sided)
        threshold = naive.alarm_threshold_naive([d for d in loo[1:] if d == d], 99.0, 1.0)
        for readings in tests:
            product = model.assess_readings(readings)
            chosen = scorers["own pairs, at least the fleet's"][axis].distance(readings)
            before = scorers["fleet only"][axis].distance(readings)
            values = _transformed(readings)
            read = [
                n
                for n in scales
                if math.isfinite(values.get(n, math.nan)) and math.isfinite(model.centre_[n])
            ]
            z = {n: (values[n] - model.centre_[n]) / scales[n] for n in read}
            shifts = [abs(z[n]) if n in two_sided else max(z[n], 0.0) for n in read]
            if math.isfinite(product.distance):
                # The product's stored score is its distance in units of the threshold.
                assert chosen == pytest.approx(product.distance / product.threshold, rel=1e-9)
                assert chosen == pytest.approx(max(shifts) / threshold, rel=1e-9)
                differs |= not math.isclose(before, chosen, rel_tol=1e-9)
                compared += 1
    assert compared >= 24
    # The own pairs change something on this fleet, else the comparison above shows nothing.
    assert larger_somewhere
    assert differs
