"""Data-quality verdicts of a capture (monitor/_quality.py) and their naive twin."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch.monitor._quality import QualityReference, data_quality_problem, longest_run
from tests.naive import longest_run_naive


def test_longest_run_matches_naive() -> None:
    rng = np.random.default_rng(11)
    for size in (1, 2, 7, 300):
        for _ in range(20):
            values = rng.integers(0, 3, size=size).astype(np.float64)
            assert longest_run(values) == longest_run_naive(values.tolist())


@pytest.fixture
def moving() -> aw.Capture:
    t = np.arange(2000) / 2000.0
    rng = np.random.default_rng(5)
    return aw.as_capture(
        {"position": np.sin(6 * t), "torque": np.cos(6 * t) + 0.01 * rng.normal(size=t.size)},
        2000.0,
    )


def _with(capture: aw.Capture, name: str, values: np.ndarray) -> aw.Capture:
    return aw.as_capture({**capture.signals, name: values}, capture.rates_hz)


def test_each_verdict_and_a_usable_capture(moving: aw.Capture) -> None:
    reference = QualityReference.of(moving)
    assert data_quality_problem(moving, reference) is None
    glitch = moving.signals["torque"].copy()
    glitch[7] = 1e300
    problem = data_quality_problem(_with(moving, "torque", glitch), reference)
    assert problem is not None
    assert problem.startswith("out of range: signal 'torque' reads 1e+300")
    flat = data_quality_problem(_with(moving, "torque", np.zeros(2000)), reference)
    assert flat == "flat/stuck signal: 'torque' is 0 throughout (2000 samples)"
    frozen = moving.signals["torque"].copy()
    frozen[1000:] = frozen[1000]
    stuck = data_quality_problem(_with(moving, "torque", frozen), reference)
    assert stuck is not None
    assert stuck.startswith("flat/stuck signal: 'torque' repeats")
    idle = _with(moving, "position", 0.01 * moving.signals["position"])
    assert str(data_quality_problem(idle, reference)).startswith("no motion: position spans")
    assert data_quality_problem(idle) is None  # no reference: a baseline candidate


def test_a_standstill_for_part_of_a_capture_is_not_a_stuck_sensor() -> None:
    # The axis moves for 40 % of the capture and stands (speed exactly 0, position held) for the
    # rest: a capture of a moving axis, scored. The same speed frozen at 0 while the position
    # moves is a stuck sensor; so is a standing speed that is not exactly 0.
    t = np.arange(2000) / 1000.0
    moving = np.where(t < 0.8, np.sin(np.pi * t / 0.8), 0.0)
    position = np.concatenate([[0.0], np.cumsum(moving[:-1]) / 1000.0])
    torque = np.cos(7 * t) + 0.1 * t
    standing = aw.as_capture({"position": position, "speed": moving, "torque": torque}, 1000.0)
    assert data_quality_problem(standing) is None
    speed_only = aw.as_capture({"speed": moving, "torque": torque}, 1000.0)
    assert data_quality_problem(speed_only) is None
    frozen = np.where(t < 0.8, moving, 0.0)
    sliding = aw.as_capture({"position": t, "speed": frozen, "torque": torque}, 1000.0)
    assert data_quality_problem(sliding).startswith("flat/stuck signal: 'speed' repeats")
    held = aw.as_capture({"speed": np.where(t < 0.8, moving, 0.3), "torque": torque}, 1000.0)
    assert data_quality_problem(held).startswith("flat/stuck signal: 'speed' repeats")
