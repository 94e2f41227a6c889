"""Synchronous (equivalent-time) lines of a tooth or bearing fault (lab study of issue 13, i14b)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch import Capture
from axiswatch.datasets import draw_robot
from axiswatch_lab._product import Readings, motion
from axiswatch_lab.studies.synchronous_lines_any_rate import (
    FLOOR_GAP_CELLS,
    floor_orders,
    needed_snr,
    reader,
    synchronous,
    synchronous_line_ratio,
    tooth_orders,
)

GEAR_RATIO = 100.0
#: Stroke period (s), not a multiple of the log's sample spacing: a log whose samples repeat the
#: same instants of every cycle sees the same few angles again and again, and the floor beside a
#: line is then its own leakage.
PERIOD_S = 2.137


def _strokes(
    rate_hz: float, line: float = 0.0, order: float = 3.37, seconds: float = 8.0
) -> Capture:
    """Cosine strokes of 2 rad back and forth (:data:`PERIOD_S`) logged at ``rate_hz``
    without an anti-alias filter; torque: friction, noise and, with ``line``, a wave of that
    amplitude at ``order`` of the motor angle (``GEAR_RATIO x`` position): at up to 2.9 rad/s of
    the position the motor turns up to 47 rev/s, so order 3.37 is at up to 160 Hz, far above a
    20 Hz log's Nyquist frequency."""
    rng = np.random.default_rng(11)
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    w = 2 * np.pi / PERIOD_S
    position = 1.0 - np.cos(w * t)
    speed = w * np.sin(w * t)
    torque = 2.0 * np.sign(speed) + 0.5 * speed + rng.normal(scale=0.3, size=t.size)
    torque = torque + line * np.cos(order * GEAR_RATIO * position)
    return Capture(
        {"position": position, "speed": speed, "torque": torque},
        {"position": rate_hz, "speed": rate_hz, "torque": rate_hz},
    )


def test_synchronous_is_the_mean_of_the_demodulated_samples() -> None:
    rng = np.random.default_rng(0)
    r, angle = rng.normal(size=50), rng.uniform(0, 100, size=50)
    naive = [
        sum(x * complex(math.cos(-o * a), math.sin(-o * a)) for x, a in zip(r, angle, strict=True))
        / 50
        for o in (0.7, 3.3)
    ]
    assert np.allclose(synchronous(r, angle, [0.7, 3.3]), naive, rtol=1e-12, atol=1e-15)


def test_a_line_far_beyond_nyquist_is_recovered_from_samples_at_unrelated_angles() -> None:
    # 20 Hz samples of a line at up to 160 Hz: the samples' phases of the line spread over the circle,
    # and the synchronous sum finds its amplitude (half of the cosine's) at its exact order.
    m = motion(_strokes(20.0, line=1.0))
    keep = np.abs(m.speed) > 0.2 * np.max(np.abs(m.speed))
    theta = GEAR_RATIO * m.position[keep]
    c = synchronous(np.cos(3.37 * theta), theta, [3.37, 3.2])
    assert abs(c[0]) == pytest.approx(0.5, abs=0.05)
    assert abs(c[1]) < 0.25


def test_floor_orders_keep_off_the_lines_and_the_whole_orders() -> None:
    lines = tooth_orders(5.0)
    assert all(abs(o - round(o)) > 1e-9 for o in lines)
    assert max(lines) < 8
    revolutions = 100.0
    floors = floor_orders(lines, lines, revolutions)
    keep_off = np.asarray([*lines, *range(0, 10)])
    assert floors
    assert min(float(np.min(np.abs(keep_off - f))) for f in floors) > FLOOR_GAP_CELLS / revolutions


def test_the_ratio_finds_an_aliased_line_and_stays_near_ln2_without_one() -> None:
    healthy = synchronous_line_ratio(
        motion(_strokes(20.0)), GEAR_RATIO, [3.37, 4.37, 5.37, 6.37], []
    )
    faulty = synchronous_line_ratio(
        motion(_strokes(20.0, line=1.0)), GEAR_RATIO, [3.37, 4.37, 5.37, 6.37], []
    )
    # One of four lines present: the median over the lines does not see it ...
    assert isinstance(healthy, float)
    assert isinstance(faulty, float)
    assert 0.1 < healthy < 4
    # ... but a comb at every line does.
    cap = _strokes(20.0)
    m = motion(cap)
    theta = GEAR_RATIO * m.position
    comb = sum(np.cos(o * theta) for o in (3.37, 4.37, 5.37, 6.37))
    combed = Capture(
        {
            "position": cap.signals["position"],
            "speed": cap.signals["speed"],
            "torque": cap.signals["torque"] + comb,
        },
        dict(cap.rates_hz),
    )
    got = synchronous_line_ratio(motion(combed), GEAR_RATIO, [3.37, 4.37, 5.37, 6.37], [])
    assert isinstance(got, float)
    assert got > 3 * healthy


def test_unavailable_with_a_reason() -> None:
    short = motion(_strokes(20.0, seconds=0.6))
    got = synchronous_line_ratio(short, 0.2, [3.37, 4.37, 5.37, 6.37], [])
    assert isinstance(got, str)
    assert got.startswith("needs a motor-angle span of 10 revolutions")


def test_needed_ratio_falls_with_the_number_of_lines() -> None:
    assert needed_snr(8) == pytest.approx(math.sqrt(math.sqrt(2) * 1.6449 / math.sqrt(8)), rel=1e-3)
    assert needed_snr(32) < needed_snr(8)


def test_a_line_whose_phase_hardly_turns_over_the_span_is_not_counted() -> None:
    m = motion(_strokes(20.0))
    lines = [3.37, 4.37, 5.37, 6.37]
    assert isinstance(synchronous_line_ratio(m, GEAR_RATIO, lines, [], min_span=0.0), float)
    # A span of about 32 revolutions: no line turns 500 times over it.
    got = synchronous_line_ratio(m, GEAR_RATIO, lines, [], min_span=0.0, min_line_turns=500.0)
    assert got == "needs 4 lines with orders free of lines beside them"


def test_the_reader_replaces_the_product_lines_under_the_same_names() -> None:
    robot = draw_robot(3)
    capture = robot.capture(0, seed="t")
    cache: dict[int, Readings] = {}
    product = reader(robot, cache, None)(capture)
    candidate = reader(robot, cache, "synchronous-resolved")(capture)
    names = ["tooth_lines:tooth stage", "bearing_lines:motor bearing"]
    assert set(product.values) == set(candidate.values)
    for name in names:
        value = candidate.values[name]
        assert math.isfinite(value) or name in candidate.reasons
    others = [n for n in product.values if n not in names]
    assert [candidate.values[n] for n in others] == pytest.approx(
        [product.values[n] for n in others], nan_ok=True
    )
