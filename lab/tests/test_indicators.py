"""Task-invariant feature stages: states, axis model, residual, order and state statistics."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
from axiswatch import StftStage
from axiswatch.datasets import Fault, simulate_capture
from axiswatch_lab._indicators import (
    STATES,
    OrderStage,
    ResidualStage,
    StateStage,
    fit_axis_model,
    operating_states,
)
from lab_naive import least_squares_normal_equations

CRUISE_FORWARD = 1  # row of "cruise+" among the moving states (rows of ResidualStage)


def test_fit_axis_model_matches_normal_equations(rng: np.random.Generator) -> None:
    q, v, a = rng.uniform(-1, 1, size=(3, 500))
    tau = rng.normal(size=500)
    model = fit_axis_model(q, v, a, tau)
    design = model.design(q, v, a)
    np.testing.assert_allclose(
        model.coefficients, least_squares_normal_equations(design, tau), rtol=1e-8, atol=1e-10
    )
    np.testing.assert_allclose(model.residual(q, v, a, tau), tau - design @ model.coefficients)


def test_operating_states_rejects_mismatched_shapes() -> None:
    with pytest.raises(ValueError, match=r"1-D of one shape; got \(3,\) and \(2,\)"):
        operating_states(np.zeros(3), np.zeros(2))


def test_every_state_appears_in_a_pick_and_place_capture() -> None:
    capture = simulate_capture("long_slow", seed=1)
    signals, rate = aw.resample_capture(capture)
    from scipy.signal import savgol_filter

    acceleration = savgol_filter(signals[:, 1], 21, 2, deriv=1, delta=1.0 / rate)
    states = operating_states(signals[:, 1], acceleration)
    assert set(np.unique(states)) == set(range(len(STATES)))


@pytest.mark.parametrize("task", ["short_fast", "long_slow", "heavy", "inspect"])
def test_friction_raises_the_forward_cruise_residual_on_every_task(task: str) -> None:
    # Measured: +3.2 to +21 N m at severity 0.6 (healthy cruise+ means -2.2 to 10.7 across tasks).
    stage = ResidualStage().fit(simulate_capture("short_fast", seed=0))
    healthy = stage.transform(simulate_capture(task, seed=11)).X
    worn = stage.transform(simulate_capture(task, fault=Fault("friction", 0.6), seed=11)).X
    assert worn[CRUISE_FORWARD, -3] > healthy[CRUISE_FORWARD, -3] + 2.0


@pytest.mark.parametrize("task", ["short_fast", "long_slow", "heavy", "inspect"])
def test_backlash_multiplies_the_forward_cruise_residual_spread(task: str) -> None:
    # Measured: std x 5 to x 30 at severity 0.6.
    stage = ResidualStage().fit(simulate_capture("short_fast", seed=0))
    healthy = stage.transform(simulate_capture(task, seed=12)).X
    loose = stage.transform(simulate_capture(task, fault=Fault("backlash", 0.6), seed=12)).X
    assert loose[CRUISE_FORWARD, -2] > 3.0 * healthy[CRUISE_FORWARD, -2]


def test_stage_shapes() -> None:
    baseline = simulate_capture("short_fast", seed=0)
    other = simulate_capture("heavy", seed=3)
    assert ResidualStage().fit(baseline).transform(other).X.shape == (6, 11)
    assert ResidualStage(stats_only=True).fit(baseline).transform(other).X.shape == (6, 3)
    order = OrderStage().fit(baseline).transform(other)
    assert order.X.shape == (2, order.frequencies_hz.size)
    assert order.frequencies_hz.max() <= 12.0
    assert StateStage().fit(baseline).transform(other).X.shape == (7, 5)
    assert StftStage(aw.FeatureSpec(hop=20)).fit(baseline).transform(other).X.shape[1] == 390


def test_baseline_without_motion_is_rejected_by_the_order_stage() -> None:
    still = aw.Capture(
        {"position": np.zeros(250), "speed": np.full(2000, 1e-3), "torque": np.ones(2000)},
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        source="still.parquet",
    )
    with pytest.raises(
        aw.CaptureError, match=r"still\.parquet: the baseline has no stretch of motion"
    ):
        OrderStage().fit(still)


def test_capture_too_short_for_the_state_analysis() -> None:
    short = aw.Capture(
        {"position": np.zeros(2), "speed": np.zeros(16), "torque": np.zeros(16)},
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        source="short.parquet",
    )
    with pytest.raises(
        aw.CaptureError, match=r"short\.parquet: capture too short for the state analysis"
    ):
        StateStage().fit(short)
