"""The fleet-check study: its rows, the monitor's check, and the real hydraulic fleet when present."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS
from axiswatch_lab._product import FleetPrior, Readings, fleet_difference, pool_fleet_without
from axiswatch_lab.studies.fleet_check_leaves_self_out import (
    SCENARIOS,
    drive_friction_difference,
    drive_friction_prior,
    drive_friction_view,
    growth_difference,
    hydraulic_fleet_checks,
    inverse_variance_difference,
    inverse_variance_weight,
    robot_fleet_checks,
)
from lab_data import SHARED_DATA

RULES = (
    "itself included",
    "leave-self-out",
    "drive friction",
    "inverse variance",
    "growth only",
)


def _consistent(rows: list[dict[str, object]]) -> None:
    for row in rows:
        distance = float(row["distance"])  # type: ignore[arg-type]
        assert row["flagged"] == (math.isfinite(distance) and distance > 1.0)
        assert bool(row["check"]) == row["monitor"]


@pytest.mark.slow
def test_robot_rows_check_each_axis_by_each_rule() -> None:
    rows = robot_fleet_checks(DEVELOPMENT_ROBOTS[4], 4)
    assert len(rows) == len(SCENARIOS) * 4 * len(RULES)
    _consistent(rows)
    worn = {(r["scenario"], r["axis"]) for r in rows if r["health"] == "worn"}
    assert worn == {(name, "a0") for name, fault in SCENARIOS if fault is not None}
    for row in rows:
        if row["rule"] == "leave-self-out":  # the product's check, through the monitor
            assert row["monitor"] == row["flagged"]
            assert not row["flagged"] or "3 other axes" in str(row["check"])
    assert all(r["scoring_unchanged"] for r in rows)


def _axis(seed: int, friction: float, gravity: float) -> IndicatorModel:
    """Six captures' readings of a hand-built axis: the drive loads are friction plus and minus
    the task's mean gravity torque, the Coulomb reading friction alone (noise 0.2 each)."""
    rng = np.random.default_rng(seed)
    read = []
    for _ in range(6):
        f = friction + rng.normal(scale=0.2)
        values = {
            "coulomb_friction": f + rng.normal(scale=0.2),
            "load_forward": f + gravity + rng.normal(scale=0.2),
            "load_backward": f - gravity + rng.normal(scale=0.2),
        }
        read.append(Readings(values))
    return IndicatorModel().fit_readings(read)


HEALTHY = [_axis(k, 10.0, g) for k, g in ((1, 0.0), (2, 1.0), (3, -1.0), (4, 0.5))]


def test_the_loads_mean_drops_gravity_and_keeps_friction() -> None:
    centre, within = drive_friction_view(
        {"load_forward": 10.0 + 7.0, "load_backward": 10.0 - 7.0, "impulsiveness": 0.5},
        {"load_forward": 0.6, "load_backward": 0.8, "impulsiveness": 0.1},
    )
    assert centre == {"impulsiveness": 0.5, "load_forward": 10.0}
    assert within == {"impulsiveness": 0.1, "load_forward": pytest.approx(0.5)}
    # One-way strokes: a lone backward load is kept, a lone forward one is not checked.
    assert drive_friction_view({"load_backward": 3.0}, {"load_backward": 0.2}) == (
        {"load_backward": 3.0},
        {"load_backward": 0.2},
    )
    assert drive_friction_view({"load_forward": 3.0}, {"load_forward": 0.2}) == ({}, {})


def test_a_task_with_another_gravity_is_flagged_per_direction_but_not_by_the_mean() -> None:
    fleet = [_axis(0, 10.0, 15.0), *HEALTHY]
    per_direction = fleet_difference(
        fleet[0].centre_, fleet[0].within_, pool_fleet_without(fleet, 0), 99.0
    )
    assert per_direction[0] > 1.0
    top = max(per_direction[1], key=per_direction[1].__getitem__)
    assert top in {"load_forward", "load_backward"}
    assert drive_friction_difference(fleet[0], fleet, 0, 99.0) < 1.0
    prior = drive_friction_prior(fleet, 0)
    assert prior is not None
    assert "load_backward" not in prior.task_spreads


def test_a_worn_axis_is_flagged_by_the_mean_of_its_loads() -> None:
    fleet = [_axis(0, 14.0, 0.0), *HEALTHY]
    assert drive_friction_difference(fleet[0], fleet, 0, 99.0) > 1.0
    assert all(drive_friction_difference(m, fleet, k, 99.0) < 1.0 for k, m in enumerate(fleet) if k)


def test_with_fewer_than_three_others_the_mean_falls_back_to_the_fleet_with_itself() -> None:
    fleet = [_axis(0, 14.0, 0.0), *HEALTHY[:2]]
    assert drive_friction_prior(fleet, 0) is None
    assert drive_friction_difference(fleet[0], fleet, 0, 99.0) == pytest.approx(
        fleet_difference(fleet[0].centre_, fleet[0].within_, IndicatorModel.pool(fleet), 99.0)[0]
    )


def _two_noises(seed: int, friction: float, gravity: float) -> IndicatorModel:
    """The drive loads of :func:`_axis` alone, the forward load four times noisier than the
    backward one (2.0 against 0.5), as the drive of robot 5 in lab/docs/decision-log.md."""
    rng = np.random.default_rng(seed)
    read = []
    for _ in range(6):
        f = friction + rng.normal(scale=0.2)
        values = {
            "load_forward": f + gravity + rng.normal(scale=2.0),
            "load_backward": f - gravity + rng.normal(scale=0.5),
        }
        read.append(Readings(values))
    return IndicatorModel().fit_readings(read)


def test_the_weighted_mean_keeps_friction_and_a_share_of_gravity() -> None:
    centre, within = drive_friction_view(
        {"load_forward": 10.0 + 2.0, "load_backward": 10.0 - 2.0},
        {"load_forward": 2.0, "load_backward": 0.5},
        0.2,
    )
    # F + (2 w - 1) G: friction whole, 60 % of the gravity term with the backward load's sign.
    assert centre["load_forward"] == pytest.approx(10.0 - 0.6 * 2.0)
    assert within["load_forward"] == pytest.approx(math.hypot(0.2 * 2.0, 0.8 * 0.5))
    assert drive_friction_view(centre, within, 0.5) == drive_friction_view(centre, within)


def test_the_weight_is_the_fleets_inverse_variance() -> None:
    fleet = [_two_noises(k, 10.0, 0.0) for k in range(5)]
    forward = float(np.median([m.within_["load_forward"] for m in fleet]))
    backward = float(np.median([m.within_["load_backward"] for m in fleet]))
    weight = inverse_variance_weight(fleet)
    assert weight == pytest.approx(backward**2 / (forward**2 + backward**2))
    assert weight < 0.25  # the noisy forward load counts little
    assert inverse_variance_weight(fleet[:2]) == 0.5
    # Equal noise in both directions: about the plain mean.
    assert inverse_variance_weight(HEALTHY) == pytest.approx(0.5, abs=0.25)


def test_wear_the_plain_mean_dilutes_is_kept_by_the_weighted_one() -> None:
    # Friction +2.5: 5 backward spreads, 1.25 forward ones. The plain mean's spread is set by
    # the noisy direction; weighted, the precise backward load carries the wear.
    healthy = [_two_noises(k, 10.0, g) for k, g in ((1, 0.0), (2, 0.3), (3, -0.3), (4, 0.1))]
    fleet = [_two_noises(0, 12.5, 0.0), *healthy]
    assert drive_friction_difference(fleet[0], fleet, 0, 99.0) < 1.0
    assert inverse_variance_difference(fleet[0], fleet, 0, 99.0) > 1.0
    assert all(
        inverse_variance_difference(m, fleet, k, 99.0) < 1.0 for k, m in enumerate(fleet) if k
    )


def test_growth_only_counts_a_centre_above_the_fleets() -> None:
    prior = FleetPrior(
        {"coulomb_friction": 0.3},
        1.0,
        {"coulomb_friction": 3.0},
        4,
        6,
        {"coulomb_friction": 1.0},
        {"coulomb_friction": 6},
    )
    within = {"coulomb_friction": 0.4}
    above, below = {"coulomb_friction": 9.0}, {"coulomb_friction": -3.0}
    assert growth_difference(above, within, prior, 99.0) == pytest.approx(
        fleet_difference(above, within, prior, 99.0)[0]
    )
    assert fleet_difference(below, within, prior, 99.0)[0] > 1.0
    assert growth_difference(below, within, prior, 99.0) == 0.0
    assert math.isnan(growth_difference({}, within, prior, 99.0))


@pytest.mark.skipif(
    not (SHARED_DATA / "hydraulic_actuator").is_dir(), reason="hydraulic data not present"
)
@pytest.mark.slow
def test_hydraulic_rows() -> None:
    rows = hydraulic_fleet_checks(SHARED_DATA)
    assert {(r["axis"], r["rule"]) for r in rows} == {
        (a, rule) for a in ("act1", "act2", "act3", "act5") for rule in RULES
    }
    assert {r["health"] for r in rows if r["axis"] == "act3"} == {"faulty"}
    _consistent(rows)


def test_an_absent_data_set_gives_no_rows() -> None:
    assert hydraulic_fleet_checks(SHARED_DATA / "no such folder") == []
