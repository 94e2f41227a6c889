"""The robot family: determinism, the development/held-out split, what each draw varies."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from axiswatch.datasets._family import (
    DEVELOPMENT_ROBOTS,
    HELD_OUT_ROBOTS,
    UNIT_FIELDS,
    draw_robot,
    draw_unit,
    unit_factors,
)
from axiswatch.datasets._robot import (
    AxisSpec,
    Fault,
    Task,
    _reference,
    _simulate_axis,
    simulate_capture,
)


def test_split_is_disjoint_and_draws_are_deterministic() -> None:
    assert not set(DEVELOPMENT_ROBOTS) & set(HELD_OUT_ROBOTS)
    assert draw_robot(5) == draw_robot(5)
    a, b = draw_robot(5).capture(0, seed=1), draw_robot(5).capture(0, seed=1)
    np.testing.assert_array_equal(a.signals["torque"], b.signals["torque"])


def test_family_varies_every_named_property() -> None:
    robots = [draw_robot(s) for s in DEVELOPMENT_ROBOTS + HELD_OUT_ROBOTS]
    specs = [r.spec for r in robots]
    assert {r.kind for r in robots} == {"arm", "wrist"}
    assert {r.friction_fault for r in robots} == {"coulomb", "viscous", "both"}
    for name in ("gear_ratio", "tooth_stage_ratio", "bearing_order", "stiffness", "coulomb", "kp"):
        assert len({getattr(s, name) for s in specs}) >= 4, name
    rates = {s.fast_rate_hz for s in specs}
    assert min(rates) <= 50
    assert max(rates) >= 2000
    assert any(s.position_rate_hz < s.fast_rate_hz for s in specs)
    assert any(s.position_rate_hz == s.fast_rate_hz for s in specs)
    assert all(s.position_rate_hz >= 20 for s in specs)
    tasks = [t for r in robots for t in r.tasks]
    assert any(t.cruise_fraction > 0 for t in tasks)
    assert any(t.cruise_fraction == 0 for t in tasks)


@pytest.mark.parametrize("seed", DEVELOPMENT_ROBOTS[:3])
def test_drawn_axes_track_their_reference(seed: int) -> None:
    robot = draw_robot(seed)
    run = _simulate_axis(robot.tasks[0], None, 2.0, 0.0, robot.spec)
    assert np.abs(run.motor_position - run.reference_position).max() < 1e-2


def test_stroke_capture_moves_one_way_and_rates_follow_the_spec() -> None:
    robot = draw_robot(2)
    capture = robot.capture(robot.stroke_task, seed=0)
    speed = capture.signals["speed"]
    moving = np.abs(speed) > 0.1 * np.abs(speed).max()
    assert len(set(np.sign(speed[moving]).tolist())) == 1
    assert capture.rates_hz["torque"] == robot.spec.fast_rate_hz
    assert capture.rates_hz["position"] == robot.spec.position_rate_hz


def test_constant_speed_task_cruises() -> None:
    task = Task("cruise", 1.0, 1.0, 0.2, 0.2, 0.0, 0.0, cruise_fraction=0.6)
    time_s = np.linspace(0.0, 1.0, 1001)
    ref = _reference(task, time_s)
    middle = (time_s > 0.25) & (time_s < 0.75)
    assert np.ptp(ref.speed[middle]) < 1e-9
    assert ref.position[-2] == pytest.approx(1.0, abs=1e-3)


def test_temperature_and_quantisation() -> None:
    spec = AxisSpec(temperature_coefficient=-0.01, torque_quantum=0.5, position_quantum=1e-3)
    task = Task("t", 1.0, 0.5, 0.2, 0.2, 1.0, 0.0)
    cold = _simulate_axis(task, Fault("friction", 0.0), 1.0, 0.0, spec, temperature_c=20.0)
    hot = _simulate_axis(task, Fault("friction", 0.0), 1.0, 0.0, spec, temperature_c=40.0)
    moving = np.abs(cold.motor_speed) > 0.5
    # Friction falls as the oil warms: less torque to move the same way.
    assert np.mean(np.abs(hot.motor_torque[moving])) < np.mean(np.abs(cold.motor_torque[moving]))
    capture = simulate_capture(task, spec=spec, seed=0)
    torque = capture.signals["torque"]
    np.testing.assert_allclose(torque / 0.5, np.round(torque / 0.5), atol=1e-9)
    assert "temperature_c" in capture.metadata


def test_unknown_task_and_bad_rate_are_rejected() -> None:
    with pytest.raises(ValueError, match="Unknown task 'nope' of robot1"):
        draw_robot(1).capture("nope")
    with pytest.raises(ValueError, match=r"must divide 4000 Hz\. Got 3000\.0"):
        simulate_capture("light", spec=AxisSpec(fast_rate_hz=3000.0))


def test_units_differ_only_in_the_unit_fields_reproducibly() -> None:
    robot = draw_robot(2)
    assert all(draw_unit(robot, k, 0.0) == robot for k in range(7))
    unit = draw_unit(robot, 3, 0.1)
    assert unit == draw_unit(draw_robot(2), 3, 0.1)  # reproducible
    assert unit != draw_unit(robot, 4, 0.1)  # another unit
    assert (unit.seed, unit.kind, unit.tasks, unit.friction_fault) == (
        robot.seed,
        robot.kind,
        robot.tasks,
        robot.friction_fault,
    )
    changed = {
        f.name
        for f in dataclasses.fields(robot.spec)
        if getattr(unit.spec, f.name) != getattr(robot.spec, f.name)
    }
    assert changed == set(UNIT_FIELDS) | {"stribeck_peak"}
    factors = unit_factors(2, 3, 0.1)
    for name in UNIT_FIELDS:
        assert getattr(unit.spec, name) == getattr(robot.spec, name) * factors[name]
    # The Stribeck peak keeps its share of the Coulomb friction.
    assert unit.spec.stribeck_peak / unit.spec.coulomb == pytest.approx(
        robot.spec.stribeck_peak / robot.spec.coulomb, rel=1e-12
    )
    # Same capture seed: the same phase, temperature and noise, another physics.
    a, b = robot.capture(1, seed="x"), unit.capture(1, seed="x")
    assert a.signals["torque"].shape == b.signals["torque"].shape
    assert not np.array_equal(a.signals["torque"], b.signals["torque"])


def test_unit_factors_are_lognormal_with_the_spread() -> None:
    spread = 0.2
    logs = np.log(
        [[unit_factors(s, k, spread)[n] for n in UNIT_FIELDS] for s in range(20) for k in range(50)]
    )
    # 1000 draws per field: median and log-sd within about 4 standard errors.
    assert np.all(np.abs(np.median(logs, axis=0)) < 4 * 1.2533 * spread / math.sqrt(1000))
    assert np.all(np.abs(logs.std(axis=0, ddof=1) / spread - 1) < 4 / math.sqrt(2 * 999))
    assert abs(np.corrcoef(logs.T)[0, 1]) < 0.15  # independent fields
    with pytest.raises(ValueError, match="'spread' of unit_factors must be a float >= 0"):
        unit_factors(0, 0, -0.1)
