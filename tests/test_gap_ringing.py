"""The drive's ringing after the gear's gap crossings (lab, i14a): the physics on hand-built
signals, what it needs, its naive twin, and the study's variants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch._readings import Motion, Readings, motion
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch_lab._gap_ringing import (
    CANDIDATES,
    GAP_RINGING,
    MIN_RINGING_RATE_HZ,
    _sign_changes,
    _variant,
    gap_crossings,
    gap_ringing,
)
from tests import naive


def _swing(rate: float, seconds: float = 4.0, noise: float = 0.01) -> Motion:
    """A wrist swinging ``sin(pi t)``: inertial torque ``2 a`` (changing sign at t = 0, 1, 2, 3,
    where the speed peaks), Coulomb friction 0.5, white noise."""
    t = np.arange(0, seconds, 1 / rate)
    q = np.sin(np.pi * t)
    v, a = np.pi * np.cos(np.pi * t), -(np.pi**2) * np.sin(np.pi * t)
    tau = 2.0 * a + 0.5 * np.sign(v) + np.random.default_rng(0).normal(scale=noise, size=t.size)
    return Motion(t, q, v, a, tau, rate)


def _ring(t: np.ndarray, at: list[float], hz: float = 15.0, amplitude: float = 0.2) -> np.ndarray:
    out = np.zeros_like(t)
    for c in at:
        after = np.clip(t - c, 0, None)
        out += np.where(t > c, amplitude * np.exp(-after / 0.1) * np.sin(2 * np.pi * hz * after), 0)
    return out


def _with(m: Motion, torque: np.ndarray) -> Motion:
    return Motion(m.time_s, m.position, m.speed, m.acceleration, torque, m.rate_hz)


def test_the_crossings_are_the_sign_changes_of_the_inertial_torque() -> None:
    m = _swing(500.0)
    moving = np.abs(m.speed) > 0.1 * np.pi
    crossings = m.time_s[gap_crossings(m, moving)]
    # The rigid part changes sign at t = 1, 2, 3; the low-passed commanded torque within a few
    # ms of them (the friction step of 0.5 against an inertial slope of 2 pi^2 per second).
    assert crossings.size >= 3
    for c in (1.0, 2.0, 3.0):
        assert np.min(np.abs(crossings - c)) < 0.03
    assert np.all(np.min(np.abs(crossings[:, None] - [0.0, 1.0, 2.0, 3.0]), axis=1) < 0.05)


@pytest.mark.parametrize("rate", [100.0, 500.0, 4000.0])
def test_ringing_after_the_crossings_raises_the_reading_at_any_rate(rate: float) -> None:
    m = _swing(rate)
    quiet, why = gap_ringing(m)
    loud, _ = gap_ringing(_with(m, m.torque + _ring(m.time_s, [1.0, 2.0, 3.0])))
    assert why is None
    assert quiet < 3  # noise alone: about 1
    assert loud > 10 * quiet


def test_ringing_away_from_the_crossings_moves_it_far_less() -> None:
    # The same rings half a second after the crossings (at the reversals of the motion, where
    # the inertial torque peaks and nothing crosses a gap): outside every window.
    m = _swing(500.0)
    after, _ = gap_ringing(_with(m, m.torque + _ring(m.time_s, [1.0, 2.0, 3.0])))
    away, _ = gap_ringing(_with(m, m.torque + _ring(m.time_s, [1.5, 2.5, 3.5])))
    assert after > 5 * away


def test_it_is_free_of_the_torque_unit_and_of_a_rigid_load() -> None:
    m = _swing(500.0)
    rung = m.torque + _ring(m.time_s, [1.0, 2.0, 3.0])
    reading, _ = gap_ringing(_with(m, rung))
    # Another unit (a current in A) and a heavier link: the ratio does not move.
    assert gap_ringing(_with(m, 7.0 * rung))[0] == pytest.approx(reading, rel=1e-9)
    heavier = rung + 3.0 * m.acceleration
    assert gap_ringing(_with(m, heavier))[0] == pytest.approx(reading, rel=0.05)


def test_what_it_needs() -> None:
    m = _swing(10.0)
    value, why = gap_ringing(m)
    assert math.isnan(value)
    assert why == "needs a torque rate >= 20 Hz (got 10 Hz)"
    assert MIN_RINGING_RATE_HZ == 20.0
    # A gravity-loaded arm at constant speed: the torque never changes sign, no gap is crossed.
    t = np.arange(0, 4, 1 / 200.0)
    v = np.where(np.sin(np.pi * t) > 0, 1.0, -1.0) * np.minimum(1.0, 5 * np.abs(np.sin(np.pi * t)))
    q = np.cumsum(v) / 200.0
    tau = 20.0 + 0.5 * np.sign(v) + np.random.default_rng(1).normal(scale=0.01, size=t.size)
    value, why = gap_ringing(Motion(t, q, v, np.gradient(v, 1 / 200.0), tau, 200.0))
    assert math.isnan(value)
    assert why is not None
    assert why.startswith("needs gap crossings while moving")
    still = Motion(t, np.zeros_like(t), np.zeros_like(t), np.zeros_like(t), tau, 200.0)
    value, why = gap_ringing(still)
    assert math.isnan(value)
    assert why == "needs motion"


def test_it_is_read_at_20_hz_and_sees_the_simulated_backlash() -> None:
    # Development robot 6 logs at 20 Hz; the ringing reaches the 5-9 Hz band aliased.
    robot = draw_robot(DEVELOPMENT_ROBOTS[6])
    assert robot.spec.fast_rate_hz == 20.0
    healthy = gap_ringing(motion(robot.capture(2, seed="h")))[0]
    faulty = gap_ringing(motion(robot.capture(2, fault=Fault("backlash", 0.6), seed="h")))[0]
    assert math.isfinite(healthy)
    assert faulty > 2 * healthy


@pytest.mark.parametrize("candidate", sorted(CANDIDATES))
@pytest.mark.parametrize(("seed", "task"), [(0, 0), (1, 1), (6, 2)])
def test_it_matches_its_naive_twin(seed: int, task: int, candidate: str) -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[seed])
    m = motion(robot.capture(task, fault=Fault("backlash", 0.6), seed="twin"))
    fast, why = gap_ringing(m, **CANDIDATES[candidate])
    assert why is None
    slow = naive.gap_ringing_naive(
        m.time_s, m.position, m.speed, m.acceleration, m.torque, m.rate_hz, **CANDIDATES[candidate]
    )
    # Normal equations against LAPACK's least squares: the fit's condition number squared.
    assert fast == pytest.approx(slow, rel=1e-6)


def test_the_study_variants_replace_or_add_the_reading() -> None:
    base = Readings({"reversal_bursts": 2.0, "coulomb_friction": 1.0}, {}, "s")
    assert _variant(base, 5.0, None, "product") == base
    replaced = _variant(base, math.nan, "needs x", "replaced")
    assert math.isnan(replaced.values["reversal_bursts"])
    assert replaced.reasons == {"reversal_bursts": "needs x"}
    added = _variant(base, 5.0, None, "added")
    assert added.values == {"reversal_bursts": 2.0, "coulomb_friction": 1.0, "gap_ringing": 5.0}
    assert GAP_RINGING.log
    assert GAP_RINGING.sided == "up"


def test_the_hysteresis_ignores_an_estimate_hovering_at_zero() -> None:
    # A wrist cruising at constant speed: its inertial torque is noise about zero between the
    # acceleration (+1) and the deceleration (-1); the gear is crossed once, not at each wiggle.
    wiggle = 0.01 * np.array([1.0, -1.0] * 20)
    x = np.concatenate([np.ones(20), wiggle, -np.ones(20)])
    assert _sign_changes(x, 0.0).size == 39
    (once,) = _sign_changes(x, 0.1)
    assert once == 58  # the last sign change before the estimate leaves the band
    assert _sign_changes(np.ones(5), 0.1).size == 0
