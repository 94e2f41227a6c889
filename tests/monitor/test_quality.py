"""Data-quality verdicts of a capture (monitor/_quality.py) and their naive twin."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
from axiswatch.monitor._quality import (
    GLITCH_SPANS,
    QualityReference,
    data_quality_problem,
    isolated_glitches,
    longest_run,
)
from tests.naive import isolated_glitches_naive, longest_run_naive


def test_longest_run_matches_naive() -> None:
    rng = np.random.default_rng(11)
    for size in (1, 2, 7, 300):
        for _ in range(20):
            values = rng.integers(0, 3, size=size).astype(np.float64)
            assert longest_run(values) == longest_run_naive(values.tolist())
            distinct = rng.normal(size=size)  # no value repeated: every run is one sample
            assert longest_run(distinct) == longest_run_naive(distinct.tolist()) == (1, 0)
    with_nan = np.array([np.nan, np.nan, 1.0, 2.0])  # NaN never equals NaN
    assert longest_run(with_nan) == longest_run_naive(with_nan.tolist())
    assert longest_run(np.empty(0)) == longest_run_naive([]) == (0, 0)


@pytest.fixture
def moving() -> aw.Capture:
    t = np.arange(2000) / 2000.0
    rng = np.random.default_rng(5)
    return aw.as_capture(
        {"position": np.sin(6 * t), "torque": np.cos(6 * t) + 0.01 * rng.normal(size=t.size)},
        2000.0,
    )


def _with(capture: aw.Capture, name: str, values: np.ndarray) -> aw.Capture:
    return aw.as_capture({**capture.signals, name: values}, {**capture.rates_hz, name: 2000.0})


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


def test_isolated_glitches_match_naive() -> None:
    rng = np.random.default_rng(12)
    for size in (1, 2, 3, 8, 400):
        for _ in range(30):
            values = np.sin(np.arange(size) / 9.0) + 0.05 * rng.normal(size=size)
            # Spikes, pairs, steps and edge samples, some far, some near.
            for _ in range(rng.integers(0, 4)):
                at = rng.integers(0, size)
                width = rng.integers(1, 3)
                values[at : at + width] += rng.choice([-1, 1]) * rng.choice([0.5, 3.0, 50.0])
            assert isolated_glitches(values).tolist() == isolated_glitches_naive(
                values.tolist(), GLITCH_SPANS
            )


def test_an_isolated_glitch_is_bad_data_an_event_or_a_step_is_not(moving: aw.Capture) -> None:
    reference = QualityReference.of(moving)
    torque = moving.signals["torque"]
    for at in (0, 700, 1999):  # inside, and at either end
        glitch = torque.copy()
        glitch[at] = 1e3  # 500 times the torque's range, under OUT_OF_RANGE
        problem = str(data_quality_problem(_with(moving, "torque", glitch), reference))
        assert problem.startswith(f"glitch: signal 'torque' reads 1000 at sample {at}, alone ")
    pair = torque.copy()
    pair[700:702] = 1e3  # two samples: an event (an impact), judged by the model
    step = np.where(np.arange(2000) < 700, torque, torque + 10.0)
    for values in (pair, step):
        verdict = data_quality_problem(_with(moving, "torque", values))
        assert verdict is None or not verdict.startswith("glitch")


def test_a_torque_in_another_unit_is_a_scale_change_a_larger_move_is_not(
    moving: aw.Capture,
) -> None:
    reference = QualityReference.of(moving)
    torque = moving.signals["torque"]
    for factor, said in ((1000.0, "1,000x"), (1e-3, "1/1,000x"), (57.3, "57x")):
        scaled = _with(moving, "torque", factor * torque)
        assert str(data_quality_problem(scaled, reference)).startswith(
            f"scale changed: signal 'torque' scale changed by {said} (it spans "
        )
    # A fault's tens of per cent; a larger torque for a larger move; a position in degrees
    # (a capture may hold a part of the task's moves: its span is no witness of a unit).
    assert data_quality_problem(_with(moving, "torque", 1.4 * torque), reference) is None
    assert data_quality_problem(_with(moving, "torque", 8.85 * torque), reference) is None
    larger = aw.as_capture(
        {"position": 3 * moving.signals["position"], "torque": 100 * torque}, moving.rates_hz
    )
    assert data_quality_problem(larger, reference) is None
    degrees = _with(moving, "position", 57.3 * moving.signals["position"])
    assert data_quality_problem(degrees, reference) is None
    speed = 6 * np.cos(6 * np.arange(2000) / 2000.0)
    with_speed = _with(moving, "speed", speed)
    in_degrees = _with(moving, "speed", 57.3 * speed)
    assert str(data_quality_problem(in_degrees, QualityReference.of(with_speed))).startswith(
        "scale changed: signal 'speed' scale changed by 57x (it spans 687.6, the baseline's 12, while the position (1x) and the torque (1x) kept"
    )
    assert data_quality_problem(_with(moving, "torque", 1000.0 * torque)) is None  # no baseline


def test_a_position_and_speed_in_another_unit_are_a_scale_change(moving: aw.Capture) -> None:
    # The position's unit moves the speed with it (read in the same unit per second), and
    # leaves the torque alone: no task does that. Before, --method pca alarmed on every such
    # capture and the default called it another task.
    t = np.arange(2000) / 2000.0
    with_speed = _with(moving, "speed", 6 * np.cos(6 * t))
    reference = QualityReference.of(with_speed)
    for factor, said in (
        (
            180 / np.pi,
            "scale changed: the position and speed scale changed by 57x while the torque",
        ),
        (np.pi / 180, "no motion: position spans"),
    ):
        moved = _with(
            _with(with_speed, "position", factor * with_speed.signals["position"]),
            "speed",
            factor * with_speed.signals["speed"],
        )
        # Degrees to rad shrinks the motion as an idle axis does: bad data either way.
        assert str(data_quality_problem(moved, reference)).startswith(said)
    # A faster, longer move that loads the axis more is a task, not a unit.
    task = _with(
        _with(with_speed, "position", 40 * with_speed.signals["position"]),
        "speed",
        40 * with_speed.signals["speed"],
    )
    task = _with(task, "torque", 5 * task.signals["torque"])
    assert data_quality_problem(task, reference) is None


def test_a_repaired_spike_is_a_data_quality_note_not_an_alarm(tmp_path: Path) -> None:
    # A lone torque spike under the bad-data limit (half the torque's range above its peak) is
    # repaired before impulsiveness is read. The monitor now says so once per axis.
    from typer.testing import CliRunner

    from axiswatch.cli import app
    from tests.conftest import settle

    folder = tmp_path / "fleet" / "r1" / "a0"
    folder.mkdir(parents=True)
    for day in range(1, 10):
        capture = aw.datasets.simulate_capture("heavy", seed=day)
        if day == 9:
            torque = np.array(capture.signals["torque"])
            low, high = np.percentile(torque, [1.0, 99.0])
            torque[torque.size // 2] = torque.max() + 0.5 * (high - low)
            capture = aw.Capture({**capture.signals, "torque": torque}, capture.rates_hz)
        aw.write_capture(capture, folder / f"2026-03-{day:02d}.parquet")
    settle(tmp_path / "fleet")
    store = tmp_path / "s.db"
    done = CliRunner().invoke(app, ["monitor", str(tmp_path / "fleet"), "--store", str(store)])
    assert done.exit_code == 0, done.output
    assert "Data-quality notes (1):" in done.output
    assert "r1/a0: 1 lone torque spike(s) in 1 capture(s) repaired" in done.output
    with aw.Store(store, read_only=True) as opened:
        last = opened.score_table().iloc[-1]
    assert not last.alarm
    assert '"repaired_spikes": 1' in last.details
