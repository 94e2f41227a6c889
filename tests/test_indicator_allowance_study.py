"""The per-indicator allowance study (lab): its chosen variant is the product's rule."""

from __future__ import annotations

import math

import pytest

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._indicator_allowance import VARIANTS, _models, _scorers


@pytest.mark.slow
def test_the_chosen_variant_scores_as_the_product_and_the_scalar_rule_is_the_old_one() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[2])
    reader_fits = {t: [robot.capture(t, seed=f"fit{k}") for k in range(5)] for t in range(4)}
    reader = IndicatorModel()
    fits = {t: [reader.readings(c) for c in caps] for t, caps in reader_fits.items()}
    models, prior = _models(fits, None, 99.0)
    scorers = _scorers(models, prior, 99.0)
    assert list(scorers) == list(VARIANTS)
    tests = [
        reader.readings(robot.capture(t, seed=f"test{t}", fault=fault))
        for t in range(4)
        for fault in (None, Fault("friction", 0.8))
    ]
    compared = 0
    for axis, model in models.items():
        for readings in tests:
            product = model.assess_readings(readings)
            chosen = scorers["per-indicator"][axis].distance(readings)
            if math.isfinite(product.distance):
                # The product's stored score is its distance in units of the threshold.
                assert chosen == pytest.approx(product.distance / product.threshold, rel=1e-9)
                compared += 1
            # The scalar variant: the one allowance of the largest shift, as before the study.
            old = scorers["scalar"][axis]
            assert old.threshold >= prior.allowance(99.0)
    assert compared >= 24
