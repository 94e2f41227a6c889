"""The indicator-combination study (lab, i14c): its ``current`` variant scores exactly as the
product, and the other rules follow their definitions on hand-made shifts."""

from __future__ import annotations

import math

import pytest
from scipy import stats

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._product import Readings
from axiswatch_lab.studies.allowance_per_indicator import _models
from axiswatch_lab.studies.largest_shift_kept import VARIANTS, Combiner


@pytest.fixture(scope="module")
def fleet() -> tuple[dict[int, IndicatorModel], list[Readings]]:
    robot = draw_robot(DEVELOPMENT_ROBOTS[2])
    reader = IndicatorModel()
    fits = {
        t: [reader.readings(robot.capture(t, seed=f"fit{k}")) for k in range(5)] for t in range(4)
    }
    models, _ = _models(fits, None, 99.0)
    tests = [
        reader.readings(robot.capture(t, seed=f"test{t}", fault=fault))
        for t in range(4)
        for fault in (None, Fault("friction", 0.8), Fault("backlash", 0.8))
    ]
    return models, tests


@pytest.mark.slow
def test_current_scores_as_the_product(
    fleet: tuple[dict[int, IndicatorModel], list[Readings]],
) -> None:
    models, tests = fleet
    compared = 0
    for model in models.values():
        combiner = Combiner(model)
        assert combiner.thresholds["current"] == pytest.approx(model.threshold_, rel=1e-12)
        for readings in tests:
            product = model.assess_readings(readings)
            got = combiner.distances(readings)
            assert set(got) == set(VARIANTS)
            if math.isfinite(product.distance):
                assert got["current"] == pytest.approx(
                    product.distance / product.threshold, rel=1e-9
                )
                compared += 1
    assert compared >= 36


@pytest.mark.slow
def test_the_rules_on_hand_made_shifts(
    fleet: tuple[dict[int, IndicatorModel], list[Readings]],
) -> None:
    models, _ = fleet
    combiner = Combiner(next(iter(models.values())))
    names = list(combiner.unit_scales)[:3]
    u = dict(zip(names, (0.5, 2.0, 0.0), strict=True))
    w = [combiner.weights[n] for n in names]
    assert combiner.raw("current", u) == 2.0
    assert combiner.raw("root-sum-square", u) == pytest.approx(math.sqrt(4.25))
    assert combiner.raw("min p", u) == pytest.approx(max(0.5 * w[0], 2.0 * w[1]))
    fisher = 0.5 * w[0] + 2.0 * w[1]
    assert combiner.raw("Fisher", u) == pytest.approx(-math.log(stats.gamma.sf(fisher, 3)))
    # Fisher's 2 sum -ln p is chi-square with 2k degrees of freedom.
    assert combiner.raw("Fisher", u) == pytest.approx(-math.log(stats.chi2.sf(2 * fisher, 6)))
    assert combiner.raw("max of z", u) == pytest.approx(
        max(x * combiner.allowances[n] for n, x in u.items())
    )
    # Without the Bonferroni level an allowance is ln(100) / ln(100 m) of its value: u grows.
    assert combiner.raw("max, no Bonferroni", u) >= combiner.raw("current", u)
    assert combiner.floors["min p"] == pytest.approx(combiner.bonferroni)
    assert combiner.floors["Fisher"] == pytest.approx(math.log(100.0))
    assert all(math.isnan(combiner.raw(v, {})) for v in VARIANTS)
    for v in VARIANTS:
        assert combiner.thresholds[v] >= combiner.floors[v]
