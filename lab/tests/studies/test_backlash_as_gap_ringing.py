"""The study that chose `gap_ringing` over `reversal_bursts` (lab, i14a): its variants and the
former product's reading it reconstructs."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

import lab_naive as naive
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._product import Readings, motion
from axiswatch_lab._transfer import TransferDesign
from axiswatch_lab.studies.backlash_as_gap_ringing import (
    REVERSAL_BURSTS,
    VARIANTS,
    _variant,
    candidate_ringing,
    reversal_bursts_before,
)

SMALL_DESIGN = TransferDesign(n_per_cell=1, n_calibration=2, robot_a_days=8, degradation_days=3)


def test_the_variants_keep_the_former_or_the_new_backlash_reading_or_both() -> None:
    base = Readings(
        {"gap_ringing": 9.0, "coulomb_friction": 1.0}, {"impulsiveness": "needs x"}, "s"
    )
    bursts, ringing = (2.0, None), (math.nan, "needs y")
    product = _variant(base, bursts, ringing, "product")
    assert product.values == {"coulomb_friction": 1.0, "reversal_bursts": 2.0}
    replaced = _variant(base, bursts, ringing, "replaced")
    assert set(replaced.values) == {"coulomb_friction", "gap_ringing"}
    assert math.isnan(replaced.values["gap_ringing"])
    assert replaced.reasons == {"impulsiveness": "needs x", "gap_ringing": "needs y"}
    added = _variant(base, bursts, ringing, "added")
    assert set(added.values) == {"coulomb_friction", "reversal_bursts", "gap_ringing"}
    assert VARIANTS == ("product", "replaced", "added")
    assert REVERSAL_BURSTS.log


def test_the_former_reading_is_the_product_s_before_the_change() -> None:
    # The former product: reversal_bursts of the rate's band at 100 Hz and more, with its
    # reasons; its naive twin (tests/naive.py) on the same band.
    robot = draw_robot(DEVELOPMENT_ROBOTS[7])
    m = motion(robot.capture(0, fault=Fault("backlash", 0.6), seed="before"))
    value, why = reversal_bursts_before(m)
    assert why is None
    from axiswatch_lab._product import MOVING_FRACTION, _band

    moving = np.abs(m.speed) > MOVING_FRACTION * np.max(np.abs(m.speed))
    expected = naive.reversal_bursts(m.torque, _band(m.torque, m.rate_hz), m.rate_hz, moving, 10.0)
    assert math.isclose(value, expected, rel_tol=1e-12)
    slow = motion(draw_robot(DEVELOPMENT_ROBOTS[6]).capture(1, seed="before"))
    assert reversal_bursts_before(slow)[1] == "needs a torque rate >= 100 Hz (got 20 Hz)"
    assert math.isfinite(candidate_ringing(slow, "v2")[0])


def test_the_fast_study_runs_and_the_former_product_is_unchanged_by_the_candidate() -> None:
    # On the smallest design of the transfer tests (TINY there): whether the product's record
    # depends on the candidate and whether every capture is read at 100 Hz do not depend on the
    # study's size (FAST_DESIGN took 45 s of CPU here, this 26 s). With fewer captures one
    # AUROC could match by chance, so the product's whole record must match; the candidates'
    # own "replaced" records differ on this design (0.622 and 0.656 for backlash).
    from axiswatch_lab.studies.backlash_as_gap_ringing import ringing_study

    v1, _ = ringing_study([1], SMALL_DESIGN, monitor=False, candidate="v1", progress=print)
    v2, _ = ringing_study([1], SMALL_DESIGN, monitor=False, candidate="v2", progress=print)
    first, second = v1.set_index("variant"), v2.set_index("variant")
    assert first.loc["product", "auroc_backlash"] == second.loc["product", "auroc_backlash"]
    pd.testing.assert_series_equal(first.loc["product"], second.loc["product"])
    assert first.loc["replaced", "share_scored"] == 1.0  # read on every capture at 100 Hz
