"""Rate-, unit- and motion-aware indicators: what each needs, signed friction, any rate."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import axiswatch as aw
from axiswatch.indicators._readings import motion, read_indicators
from tests import naive


def _axis(
    rate: float,
    *,
    coulomb: float = 3.0,
    viscous: float = 2.0,
    gravity: float = 0.0,
    one_way: bool = False,
    cruise: bool = False,
    seconds: float = 6.0,
) -> aw.Capture:
    t = np.arange(0, seconds, 1 / rate)
    if cruise:  # constant speed both ways: a triangle wave of position
        q = 2 * np.abs(((t / 2) % 1) - 0.5)
    elif one_way:
        q = 0.5 * (1 - np.cos(np.pi * np.clip(t / seconds, 0, 1)))
    else:
        q = np.sin(np.pi * t / 2) + 0.3 * np.sin(np.pi * t)
    v = np.gradient(q, 1 / rate)
    tau = coulomb * np.sign(v) + viscous * v + gravity * np.cos(q)
    return aw.Capture(
        {"position": q, "speed": v, "torque": tau},
        {"position": rate, "speed": rate, "torque": rate},
    )


@pytest.mark.parametrize("rate", [20.0, 250.0, 4000.0])
def test_friction_is_read_at_any_rate(rate: float) -> None:
    r = read_indicators(_axis(rate))
    assert r.values["coulomb_friction"] == pytest.approx(3.0, abs=0.05)
    assert r.values["viscous_friction"] == pytest.approx(2.0, abs=0.05)


def test_band_indicators_say_what_they_need_at_20_hz() -> None:
    r = read_indicators(_axis(20.0))
    assert np.isnan(r.values["impulsiveness"])
    assert r.reasons["impulsiveness"] == "needs a torque rate >= 100 Hz (got 20 Hz)"
    assert set(r.available()) >= {"coulomb_friction", "viscous_friction"}


def test_negative_friction_is_a_signed_reading() -> None:
    r = read_indicators(_axis(250.0, viscous=-1.5))
    assert r.values["viscous_friction"] == pytest.approx(-1.5, abs=0.05)


def test_gravity_loaded_axis_keeps_its_coulomb_friction() -> None:
    # cos(q) over q in [-1.3, 1.3] is what the cubic in the position absorbs.
    r = read_indicators(_axis(500.0, gravity=40.0))
    assert r.values["coulomb_friction"] == pytest.approx(3.0, abs=0.3)
    assert r.values["viscous_friction"] == pytest.approx(2.0, abs=0.3)


def test_one_direction_stroke_reads_its_load() -> None:
    r = read_indicators(_axis(250.0, one_way=True))
    assert np.isnan(r.values["coulomb_friction"])
    assert "both directions" in r.reasons["coulomb_friction"]
    # Steady part of a cosine stroke: speed above half its peak.
    capture = _axis(250.0, one_way=True)
    v = capture.signals["speed"]
    steady = np.abs(v) > 0.5 * np.abs(v).max()
    assert r.values["load_forward"] == pytest.approx(float(np.mean(3.0 + 2.0 * v[steady])))
    assert "negative" in r.reasons["load_backward"]


def test_constant_speed_moves_read_the_friction_at_that_speed() -> None:
    r = read_indicators(_axis(250.0, cruise=True))
    assert np.isnan(r.values["viscous_friction"])
    assert "more than one speed" in r.reasons["viscous_friction"]
    assert r.values["coulomb_friction"] == pytest.approx(3.0 + 2.0 * 1.0, abs=0.1)


def test_friction_matches_the_normal_equations() -> None:
    capture = _axis(100.0, gravity=5.0)
    m = motion(capture)
    moving = np.abs(m.speed) > 0.1 * np.abs(m.speed).max()
    q = m.position[moving]
    q = (q - q.mean()) / np.ptp(q)
    v = m.speed[moving]
    A = np.column_stack([np.sign(v), v, m.acceleration[moving], np.ones_like(v), q, q**2, q**3])
    expected = naive.least_squares_normal_equations(A, m.torque[moving])
    r = read_indicators(capture)
    assert r.values["coulomb_friction"] == pytest.approx(expected[0], rel=1e-8)
    assert r.values["viscous_friction"] == pytest.approx(expected[1], rel=1e-8)


def test_speed_from_position_and_position_from_speed() -> None:
    full = _axis(250.0)
    no_speed = full.select(["position", "torque"])
    no_position = full.select(["speed", "torque"])
    base = read_indicators(full).values["viscous_friction"]
    assert read_indicators(no_speed).values["viscous_friction"] == pytest.approx(base, rel=0.02)
    assert read_indicators(no_position).values["viscous_friction"] == pytest.approx(base, rel=0.02)


def test_a_still_axis_is_unavailable_everywhere() -> None:
    still = aw.Capture(
        {"position": np.zeros(500), "torque": np.ones(500)}, {"position": 250.0, "torque": 250.0}
    )
    r = read_indicators(still)
    assert r.available() == []
    assert all("needs motion" in why for why in r.reasons.values())


def test_a_capture_without_torque_is_refused() -> None:
    capture = _axis(250.0).select(["position", "speed"])
    with pytest.raises(aw.CaptureError, match=r"need a 'torque' signal.*AxisProfile"):
        read_indicators(capture)


def test_bearing_line_is_seen_with_kinematics() -> None:
    rate, gear = 1000.0, 50.0
    t = np.arange(0, 6, 1 / rate)
    q = 1.5 * np.sin(np.pi * t / 3)
    v = np.gradient(q, 1 / rate)
    noise = np.random.default_rng(0).normal(scale=0.3, size=t.size)
    line = 0.5 * np.cos(5.3 * gear * q)
    rates = {"position": rate, "speed": rate, "torque": rate}
    healthy = aw.Capture({"position": q, "speed": v, "torque": 3 * np.sign(v) + noise}, rates)
    faulty = aw.Capture({"position": q, "speed": v, "torque": 3 * np.sign(v) + noise + line}, rates)
    kinematics = {"gear_ratio": gear, "bearing_orders": {"motor": 5.3}}
    with threadpool_limits(1):  # small least squares: threads only contend on a loaded machine
        h = read_indicators(healthy, **kinematics).values["bearing_lines:motor"]
        f = read_indicators(faulty, **kinematics).values["bearing_lines:motor"]
    assert h < 3
    assert f > 10 * h


def test_kinematic_line_says_when_the_rate_is_too_low() -> None:
    r = read_indicators(_axis(100.0), gear_ratio=100.0, bearing_orders={"motor": 5.4})
    assert np.isnan(r.values["bearing_lines:motor"])
    assert "below 45 Hz" in r.reasons["bearing_lines:motor"]


@pytest.mark.parametrize(("seed", "task"), [(4, 1), (2, 0)])
def test_readings_do_not_turn_on_the_last_bits_of_the_rate(seed: int, task: int) -> None:
    """A rate read from time stamps is exact to about 1e-12 (stamps written as text or as Unix
    seconds; 1e-9 for a fitted slope): every reading moves continuously with it. Window lengths
    rounded with Python's ``round`` flipped at whole and half samples, and ``gap_ringing`` moved
    by 10-17 % on these development captures (50 Hz and 100 Hz) between 1 - 1e-12 and 1 + 1e-12
    times the rate; fails before ``whole_samples``."""
    from axiswatch.datasets import draw_robot

    capture = draw_robot(seed).capture(task, seed=3)
    read = read_indicators(capture)
    for factor in (1 - 1e-9, 1 - 1e-12, 1 + 1e-12, 1 + 1e-9):
        rates = {name: rate * factor for name, rate in capture.rates_hz.items()}
        moved = read_indicators(aw.Capture(capture.signals, rates, capture.start_s))
        for name, value in read.values.items():
            np.testing.assert_allclose(moved.values[name], value, rtol=1e-6, err_msg=name)


def test_whole_samples_is_the_exact_nearest_count_away_from_halves() -> None:
    """Against exact rational arithmetic, on products at least 1e-6 of a sample from a half;
    at a half, upward whatever the last bit of the rate."""
    from fractions import Fraction

    from axiswatch.indicators._signals import whole_samples

    rng = np.random.default_rng(0)
    pairs = zip(rng.uniform(0.001, 1.0, 500), rng.uniform(20.0, 4000.0, 500), strict=True)
    for seconds, rate in pairs:
        exact = Fraction(float(seconds)) * Fraction(float(rate))
        if abs(exact - int(exact) - Fraction(1, 2)) > Fraction(1, 10**6):
            assert whole_samples(seconds, rate) == int(exact + Fraction(1, 2)), (seconds, rate)
    for seconds, rate, half in ((0.05, 50.0, 2.5), (0.05, 110.0, 5.5), (0.3, 125.0, 37.5)):
        for factor in (1 - 1e-9, 1.0, 1 + 1e-9):
            assert whole_samples(seconds, rate * factor) == int(half + 0.5)


def _spiky(rng: np.random.Generator) -> np.ndarray:
    """A smooth torque with noise, one lone spike and an event of two samples."""
    t = np.arange(4000) / 2000.0
    x = 10 * np.sin(2 * np.pi * t) + rng.normal(scale=0.05, size=t.size)
    x[1000] += 8.0  # lone
    x[2000:2002] += 8.0  # an event of two samples
    return x


def test_repair_lone_spikes_matches_the_naive_twin() -> None:
    from axiswatch.indicators._signals import (
        LONE_SPIKE_FACTOR,
        LONE_SPIKE_NEIGHBOURS,
        repair_lone_spikes,
    )

    rng = np.random.default_rng(5)
    for x in (_spiky(rng), rng.normal(size=20000), np.round(5 * rng.normal(size=3000))):
        expected = naive.repair_lone_spikes_naive(
            x.tolist(), LONE_SPIKE_FACTOR, LONE_SPIKE_NEIGHBOURS
        )
        np.testing.assert_array_equal(repair_lone_spikes(x), expected)
    x = _spiky(rng)
    repaired = repair_lone_spikes(x)
    assert np.flatnonzero(repaired != x).tolist() == [1000]  # the event of two samples is kept
    clean = rng.normal(size=20000)
    assert repair_lone_spikes(clean) is clean  # noise alone is never repaired


def test_impulsiveness_shrugs_off_one_glitched_sample_but_not_a_fault() -> None:
    from axiswatch.indicators._signals import repair_lone_spikes

    capture = aw.datasets.simulate_capture("heavy", seed=1)
    torque = np.array(capture.signals["torque"])
    low, high = np.percentile(torque, [1.0, 99.0])
    glitched = torque.copy()
    glitched[torque.size // 2] = torque.max() + 0.5 * (high - low)
    before = read_indicators(capture).values["impulsiveness"]
    after = read_indicators(
        aw.Capture({**capture.signals, "torque": glitched}, capture.rates_hz)
    ).values["impulsiveness"]
    assert after == pytest.approx(before, rel=1e-3)
    # Impacts of a fault span several samples (or, sample-wide, stand among noise): nothing
    # of them is repaired, so their readings are those read without the repair, bit for bit.
    for kind in ("backlash", "bearing", "tooth", "friction"):
        faulty = aw.datasets.simulate_capture("heavy", fault=aw.datasets.Fault(kind, 1.0), seed=1)
        torque = motion(faulty).torque
        assert repair_lone_spikes(torque) is torque, kind
