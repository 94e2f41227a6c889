"""The former default's indicators (``mechanics``): exact on constructed signals, task-invariant
and fault-sensitive on the simulator (the figures in the comments are measured)."""

from __future__ import annotations

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
import lab_naive as naive
from axiswatch_lab import _mechanics
from axiswatch_lab._mechanics import (
    COLUMNS,
    ENERGY_LEVELS,
    INDICATORS,
    MechanicsStage,
    explain_indicators,
)
from axiswatch_lab._product import LIKELY_FAULTS, describe_top_indicator


def _moves_out_and_back(n_cycles: int = 3, rate_hz: float = 1000.0) -> tuple[np.ndarray, ...]:
    t = np.arange(0, 2.0 * n_cycles + 0.5, 1.0 / rate_hz)
    q = np.zeros_like(t)
    for c in range(n_cycles):
        for t0, sign in ((2.0 * c + 0.25, 1.0), (2.0 * c + 1.25, -1.0)):
            q += sign * 0.4 * (1 - np.cos(np.pi * np.clip((t - t0) / 0.6, 0, 1)))
    v = np.gradient(q, 1.0 / rate_hz)
    return t, q, v, np.gradient(v, 1.0 / rate_hz)


def test_viscous_friction_recovers_the_coefficient_whatever_coulomb_inertia_and_load() -> None:
    _, q, v, a = _moves_out_and_back()
    for inertia, coulomb, load in ((2.0, 7.0, 5.0), (9.0, 30.0, -40.0)):
        tau = inertia * a + 4.0 * v + coulomb * np.sign(v) + load
        # Exact up to rounding: the trapezoid rule makes the inertia's work telescope.
        assert _mechanics.viscous_friction(q, v, tau, 1000.0) == pytest.approx(4.0, rel=1e-9)


def test_viscous_friction_matches_the_loop_twin(rng: np.random.Generator) -> None:
    _, q, v, a = _moves_out_and_back()
    tau = 3.0 * a + 2.5 * v + 6.0 * np.sign(v) + 0.3 * rng.normal(size=v.size)
    assert _mechanics.viscous_friction(q, v, tau, 1000.0) == pytest.approx(
        naive.viscous_friction(q, v, tau, 1000.0, list(ENERGY_LEVELS)), rel=1e-9
    )


def test_a_move_cut_by_the_capture_keeps_the_windows_inside_it() -> None:
    # The first move runs from sample 250 to 850, peak at 550. Cut at 300 (speed 26 % of the
    # peak, rising): levels 0.3-0.75 remain; cut at 480 (94 %): no two levels remain, the move is
    # dropped; cut at 650 (after the peak): dropped. The estimate stays exact in each case.
    _, q, v, a = _moves_out_and_back()
    tau = 5.0 * a + 4.0 * v + 9.0 * np.sign(v)
    for cut in (300, 480, 650):
        assert _mechanics.viscous_friction(q[cut:], v[cut:], tau[cut:], 1000.0) == pytest.approx(
            4.0, rel=1e-9
        )
    # That move alone: usable when cut at 300, not at 480.
    alone = slice(300, 950)
    assert _mechanics.viscous_friction(q[alone], v[alone], tau[alone], 1000.0) == pytest.approx(4.0)
    assert np.isnan(_mechanics.viscous_friction(q[480:950], v[480:950], tau[480:950], 1000.0))


def test_viscous_friction_is_nan_without_a_complete_move() -> None:
    v = np.linspace(0.0, 1.0, 500)  # accelerating until the capture ends
    assert np.isnan(_mechanics.viscous_friction(np.cumsum(v) / 1000, v, v, 1000.0))


def test_moves_merges_noise_gaps_and_drops_blips() -> None:
    v = np.r_[np.zeros(50), np.ones(60), [0.0], np.ones(60), np.zeros(50), -np.ones(5), np.zeros(9)]
    assert _mechanics.moves(v, min_gap=10) == [(50, 171)]


@pytest.fixture(scope="module")
def stage() -> MechanicsStage:
    return MechanicsStage().fit(awd.simulate_capture("short_fast", seed=11))


def _shift(stage: MechanicsStage, capture: aw.Capture) -> np.ndarray:
    assert stage.baseline_rows_ is not None
    return stage.transform(capture).X.mean(axis=0) - stage.baseline_rows_.mean(axis=0)


@pytest.mark.parametrize("task", ["short_fast", "long_slow", "palletize"])
def test_each_fault_raises_its_own_indicator_on_every_task(
    stage: MechanicsStage, task: str
) -> None:
    # Shifts in units of the healthy cross-task spread, measured: friction 5.8-6.9 (viscous),
    # tooth 2.5-7.7 (the larger of impulsiveness and tooth lines), bearing 4.4-10.8 (bearing
    # lines); a healthy task change moves no column by more than 2.4.
    column = {name: j for j, name in enumerate(_mechanics.COLUMNS)}

    def shift(kind: str) -> np.ndarray:
        return _shift(stage, awd.simulate_capture(task, fault=awd.Fault(kind, 0.6), seed=21))  # type: ignore[arg-type]

    assert shift("friction")[column["viscous_friction"]] > 4.0
    tooth = shift("tooth")
    assert max(tooth[column["impulsiveness"]], tooth[column["tooth_lines"]]) > 2.0
    assert shift("bearing")[column["bearing_lines"]] > 3.5
    # Backlash is the weakest: the larger of impulsiveness and reversal bursts, measured
    # 4.1 (short_fast), 1.2 (long_slow), 1.8 (palletize).
    backlash = shift("backlash")
    assert max(backlash[column["impulsiveness"]], backlash[column["reversal_bursts"]]) > 1.0


def test_healthy_task_changes_stay_within_a_few_spreads(stage: MechanicsStage) -> None:
    # Measured worst case over these tasks: +2.36 spreads (viscous friction, heavy: 10 kg payload).
    for task in ("long_slow", "heavy", "inspect", "palletize"):
        assert np.all(_shift(stage, awd.simulate_capture(task, seed=31)) < 3.0), task


def test_reversal_bursts_are_nan_where_the_torque_does_not_reverse() -> None:
    t = np.arange(0, 1, 1e-3)
    torque = 20 + np.sin(2 * np.pi * 3 * t)  # gravity holds one flank all the time
    assert np.isnan(_mechanics.reversal_bursts(torque, np.ones_like(t), 1000.0, t >= 0))


def test_reversal_bursts_only_count_the_selected_samples() -> None:
    t = np.arange(0, 2, 1e-3)
    torque = 50 * np.sin(2 * np.pi * t)
    band = np.zeros_like(t)
    band[[500, 1000, 1500]] = [3.0, 30.0, 3.0]
    late = t > 1.2  # only the reversal at 1.5 s
    expected = 3.0 / np.sqrt(2 * np.pi * 50)
    assert _mechanics.reversal_bursts(torque, band, 1000.0, late) == pytest.approx(
        expected, rel=1e-3
    )


def test_scales_of_the_wrong_length_are_rejected() -> None:
    with pytest.raises(ValueError, match=r"'scales' parameter of MechanicsStage must be 5"):
        MechanicsStage(scales=(1.0, 1.0)).fit(awd.simulate_capture("short_fast", seed=0))


def test_band_beyond_nyquist_is_rejected() -> None:
    with pytest.raises(
        aw.CaptureError, match=r"'band_hz' of MechanicsStage, \(40.0, 1500.0\), needs"
    ):
        MechanicsStage(band_hz=(40.0, 1500.0)).fit(awd.simulate_capture("short_fast", seed=0))
    with pytest.raises(ValueError, match=r"'band_hz' parameter of MechanicsStage must satisfy"):
        MechanicsStage(band_hz=(300.0, 40.0)).fit(awd.simulate_capture("short_fast", seed=0))


def test_too_short_capture_is_rejected() -> None:
    short = awd.simulate_capture("short_fast", duration_s=0.1, seed=0)
    with pytest.raises(aw.CaptureError, match="too short for the mechanics indicators"):
        MechanicsStage().fit(short)


def test_baseline_without_motion_is_rejected() -> None:
    at_rest = aw.Capture(
        {"position": np.zeros(250), "speed": np.zeros(2000), "torque": np.ones(2000)},
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        source="rest.parquet",
    )
    with pytest.raises(
        aw.CaptureError,
        match=r"rest\.parquet: the baseline must show a usable move in both directions",
    ):
        MechanicsStage().fit(at_rest)


def test_a_capture_missing_a_direction_takes_the_baselines_row(stage: MechanicsStage) -> None:
    capture = awd.simulate_capture("long_slow", duration_s=0.9, phase_s=0.0, seed=3)  # forward only
    X = stage.transform(capture).X
    assert stage.baseline_rows_ is not None
    np.testing.assert_array_equal(X[1], stage.baseline_rows_[1])


def test_reversal_bursts_match_the_loop_twin() -> None:
    capture = awd.simulate_capture("long_fast", fault=awd.Fault("backlash", 0.6), seed=4)
    signals, rate = aw.resample_capture(capture, ("position", "speed", "torque"))
    speed, torque = signals[:, 1], signals[:, 2]
    from scipy.signal import butter, sosfiltfilt

    band = sosfiltfilt(butter(4, [40, 300], btype="bandpass", fs=rate, output="sos"), torque)
    where = np.abs(speed) > 0.1 * np.abs(speed).max()
    fast = _mechanics.reversal_bursts(torque, band, rate, where)
    assert np.isfinite(fast)
    assert fast == pytest.approx(naive.reversal_bursts(torque, band, rate, where, 10.0), rel=1e-12)


@pytest.fixture(scope="module")
def bearing() -> tuple[MechanicsStage, aw.IndicatorDetector, aw.Capture]:
    stage = MechanicsStage().fit(awd.simulate_capture("short_fast", seed=11))
    detector = aw.IndicatorDetector().fit(stage.baseline_rows_)
    return (
        stage,
        detector,
        awd.simulate_capture("short_fast", fault=awd.Fault("bearing", 0.6), seed=21),
    )


def test_explanation_reads_the_stage_and_splits_the_distance(
    bearing: tuple[MechanicsStage, aw.IndicatorDetector, aw.Capture],
) -> None:
    stage, detector, capture = bearing
    X = stage.transform(capture).X
    why = explain_indicators(stage, detector, X)
    assert list(why) == list(COLUMNS)
    assert sum(e["share"] for e in why.values()) == pytest.approx(1.0, abs=1e-12)
    # Values and baselines are the stage's own readings (log10, mean of both directions).
    readings = stage.readings(capture)
    for i, name in enumerate(INDICATORS):
        assert np.log10(why[name]["value"]) == pytest.approx(readings[:, i].mean(), abs=1e-12)
        assert np.log10(why[name]["baseline"]) == pytest.approx(
            stage.baseline_readings_[:, i].mean(), abs=1e-12
        )
        # The shift in spreads is the change of the reading over the indicator's spread.
        expected = (readings[:, i].mean() - stage.baseline_readings_[:, i].mean()) / stage.scales[i]
        assert why[name]["spreads"] == pytest.approx(expected, abs=1e-9)
    assert why["viscous_friction_deficit"]["spreads"] == pytest.approx(
        -why["viscous_friction"]["spreads"], abs=1e-12
    )
    # A bearing defect: the bearing lines carry the distance (measured +9 spreads, 99 %).
    top = max(why, key=lambda name: why[name]["share"])
    assert top == "bearing_lines"
    line = describe_top_indicator(why)
    assert line is not None
    assert line.startswith("bearing_lines +")
    assert line.endswith(f"likely {LIKELY_FAULTS['bearing_lines']}")


def test_every_column_has_a_likely_fault() -> None:
    assert set(LIKELY_FAULTS) == set(COLUMNS)
