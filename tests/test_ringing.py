"""Backlash as the drive's ringing after the gear's gap crossings (`gap_ringing`): the physics
on hand-built signals, what it needs, its naive twin, and the simulated fault at 20 Hz."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, draw_robot
from axiswatch.indicators._readings import (
    MOVING_FRACTION,
    Motion,
    _friction,
    motion,
    read_indicators,
)
from axiswatch.indicators._ringing import (
    CROSSING_HYSTERESIS,
    MIN_RINGING_RATE_HZ,
    gap_crossings,
    gap_ringing,
    sign_passages,
)
from tests import naive

#: The reading's two option sets: every sign change against the motion's level, and the
#: default's passages through +-10 % of each peak against the residual away from the windows.
CANDIDATES: dict[str, dict[str, object]] = {
    "v1": {"hysteresis": 0.0, "reference": "motion"},
    "v2": {"hysteresis": CROSSING_HYSTERESIS, "reference": "away"},
}


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


def _read(
    m: Motion, torque: np.ndarray | None = None, **options: object
) -> tuple[float, str | None]:
    tau = m.torque if torque is None else torque
    return gap_ringing(m.time_s, m.position, m.speed, m.acceleration, tau, m.rate_hz, **options)  # type: ignore[arg-type]


def test_the_crossings_are_the_sign_changes_of_the_inertial_torque() -> None:
    m = _swing(500.0)
    rigid = 2.0 * m.acceleration
    crossings = m.time_s[gap_crossings(rigid, m.torque, m.rate_hz)]
    # The rigid part changes sign at t = 1, 2, 3; the low-passed commanded torque within a few
    # ms of them (the friction step of 0.5 against an inertial slope of 2 pi^2 per second).
    for c in (1.0, 2.0, 3.0):
        assert np.min(np.abs(crossings - c)) < 0.03
    assert np.all(np.min(np.abs(crossings[:, None] - [1.0, 2.0, 3.0]), axis=1) < 0.05)


@pytest.mark.parametrize("candidate", sorted(CANDIDATES))
@pytest.mark.parametrize("rate", [100.0, 500.0, 4000.0])
def test_ringing_after_the_crossings_raises_the_reading_at_any_rate(
    rate: float, candidate: str
) -> None:
    m = _swing(rate)
    quiet, why = _read(m, **CANDIDATES[candidate])
    loud, _ = _read(m, m.torque + _ring(m.time_s, [1.0, 2.0, 3.0]), **CANDIDATES[candidate])
    assert why is None
    assert quiet < 3  # noise alone: about 1
    assert loud > 10 * quiet


def test_ringing_away_from_the_crossings_does_not_raise_it() -> None:
    # The same rings half a second after the crossings (at the reversals of the motion, where
    # the inertial torque peaks and nothing crosses a gap): outside every window.
    m = _swing(500.0)
    after, _ = _read(m, m.torque + _ring(m.time_s, [1.0, 2.0, 3.0]))
    away, _ = _read(m, m.torque + _ring(m.time_s, [1.5, 2.5, 3.5]))
    assert away < 1.0 < 10.0 < after


def test_it_is_free_of_the_torque_unit_and_of_a_rigid_load() -> None:
    m = _swing(500.0)
    rung = m.torque + _ring(m.time_s, [1.0, 2.0, 3.0])
    reading, _ = _read(m, rung)
    # Another unit (a current in A) and a heavier link: the ratio does not move.
    assert _read(m, 7.0 * rung)[0] == pytest.approx(reading, rel=1e-9)
    assert _read(m, rung + 3.0 * m.acceleration)[0] == pytest.approx(reading, rel=0.05)


def test_the_hysteresis_ignores_an_estimate_hovering_at_zero() -> None:
    # A wrist cruising at constant speed: its inertial torque is noise about zero between the
    # acceleration (+1) and the deceleration (-1); the gear is crossed once, not at each wiggle.
    wiggle = 0.01 * np.array([1.0, -1.0] * 20)
    x = np.concatenate([np.ones(20), wiggle, -np.ones(20)])
    assert sign_passages(x, 0.0).size == 39
    (once,) = sign_passages(x, 0.1)
    assert once == 58  # the last sign change before the estimate leaves the band
    assert sign_passages(np.ones(5), 0.1).size == 0


def test_what_it_needs() -> None:
    value, why = _read(_swing(10.0))
    assert math.isnan(value)
    assert why == "needs a torque rate >= 20 Hz (got 10 Hz)"
    assert MIN_RINGING_RATE_HZ == 20.0
    # A gravity-loaded arm at constant speed: the torque never changes sign, no gap is crossed.
    t = np.arange(0, 4, 1 / 200.0)
    v = np.where(np.sin(np.pi * t) > 0, 1.0, -1.0) * np.minimum(1.0, 5 * np.abs(np.sin(np.pi * t)))
    q = np.cumsum(v) / 200.0
    tau = 20.0 + 0.5 * np.sign(v) + np.random.default_rng(1).normal(scale=0.01, size=t.size)
    value, why = gap_ringing(t, q, v, np.gradient(v, 1 / 200.0), tau, 200.0)
    assert math.isnan(value)
    assert why is not None
    assert why.startswith("needs gap crossings while moving")
    # Crossings all along the motion: no motion away from them to compare with.
    m = _swing(500.0, seconds=0.3)
    value, why = _read(_with_crossings_everywhere(m))
    assert math.isnan(value)
    assert why == "needs motion away from the gap crossings"
    zero = np.zeros_like(t)
    value, why = gap_ringing(t, zero, zero, zero, tau, 200.0)
    assert math.isnan(value)
    assert why == "needs motion"


def _with_crossings_everywhere(m: Motion) -> Motion:
    # 0.3 s of the swing from just before its crossing at t = 1 (at 0.04 s): every sample lies
    # within 0.05 s before or 0.3 s after it.
    shift = 0.96
    t = m.time_s + shift
    q, v, a = np.sin(np.pi * t), np.pi * np.cos(np.pi * t), -(np.pi**2) * np.sin(np.pi * t)
    tau = 2.0 * a + 0.5 * np.sign(v) + np.random.default_rng(2).normal(scale=0.01, size=t.size)
    return Motion(m.time_s, q, v, a, tau, m.rate_hz)


def test_it_is_read_at_20_hz_and_sees_the_simulated_backlash() -> None:
    # Development robot 6 logs at 20 Hz; the ringing reaches the 5-9 Hz band aliased.
    robot = draw_robot(DEVELOPMENT_ROBOTS[6])
    assert robot.spec.fast_rate_hz == 20.0
    healthy = read_indicators(robot.capture(2, seed="h"))
    faulty = read_indicators(robot.capture(2, fault=Fault("backlash", 0.6), seed="h"))
    assert math.isfinite(healthy.values["gap_ringing"])
    assert faulty.values["gap_ringing"] > 2 * healthy.values["gap_ringing"]
    assert "gap_ringing" not in healthy.reasons
    assert "reversal_bursts" not in healthy.values


@pytest.mark.parametrize("candidate", sorted(CANDIDATES))
@pytest.mark.parametrize(("seed", "task"), [(0, 0), (1, 1), (6, 2), (7, 3)])
def test_it_matches_its_naive_twin(seed: int, task: int, candidate: str) -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[seed])
    m = motion(robot.capture(task, fault=Fault("backlash", 0.6), seed="twin"))
    fast, why = _read(m, **CANDIDATES[candidate])
    assert why is None
    slow = naive.gap_ringing_naive(
        m.time_s, m.position, m.speed, m.acceleration, m.torque, m.rate_hz, **CANDIDATES[candidate]
    )
    # Normal equations against LAPACK's least squares: the fit's condition number squared.
    assert fast == pytest.approx(slow, rel=1e-6)


@pytest.mark.parametrize(("seed", "task"), [(0, 0), (1, 1), (6, 2), (7, 3)])
def test_the_friction_solve_it_reuses_is_its_own_fit(seed: int, task: int) -> None:
    # read_indicators hands the friction reading's coefficients to gap_ringing: on the moving
    # samples the two designs are one, so the reading is the one gap_ringing solves itself.
    capture = draw_robot(DEVELOPMENT_ROBOTS[seed]).capture(task, seed="fit")
    m = motion(capture)
    moving = np.abs(m.speed) > MOVING_FRACTION * float(np.max(np.abs(m.speed)))
    friction = _friction(m, moving, errors=False)
    assert friction.coefficients is not None
    signals = (m.time_s, m.position, m.speed, m.acceleration, m.torque, m.rate_hz)
    alone = gap_ringing(*signals)
    assert math.isfinite(alone[0])
    assert gap_ringing(*signals, fit=friction.coefficients) == alone
    assert read_indicators(capture).values["gap_ringing"] == alone[0]
