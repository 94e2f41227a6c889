"""HealthModel: the public one-screen API, end to end on the lab dataset and on shifted captures."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd


def test_lab_dataset_flags_only_the_anomaly() -> None:
    day1, *rest = awd.lab_dataset(seed=4)
    # The lab experiment's |STFT| settings.
    spec = aw.FeatureSpec(combinations="none", segment_length=128, padding="circular")
    model = aw.HealthModel(spec, aw.LRADetector()).fit(day1.capture)
    model.calibrate([d.capture for d in rest if not d.anomalous], percentile=99)
    verdicts = {d.day: model.assess(d.capture) for d in rest}
    assert [day for day, v in verdicts.items() if v.alarm] == [4]
    assert verdicts[4].pvalue < 0.01


def _cycle_capture(shift: int, rng: np.random.Generator, fault: float = 0.0) -> aw.Capture:
    """Four whole 0.25 s task cycles at 2 kHz, starting ``shift`` samples into the cycle."""
    k = np.arange(2000) + shift
    t = k / 2000.0
    speed = np.sin(2 * np.pi * 4 * t) + 0.3 * np.sin(2 * np.pi * 12 * t)
    torque = 0.5 * np.cos(2 * np.pi * 4 * t) + fault * np.sin(2 * np.pi * 150 * t) * (
        np.sin(2 * np.pi * 4 * t) > 0.9
    )
    return aw.Capture(
        {
            "speed": speed + 0.01 * rng.normal(size=2000),
            "torque": torque + 0.01 * rng.normal(size=2000),
        },
        {"speed": 2000.0, "torque": 2000.0},
    )


def test_phase_alignment_removes_the_start_phase(rng: np.random.Generator) -> None:
    spec = aw.FeatureSpec(
        signals=("speed", "torque"), combinations="none", segment_length=64, hop=4
    )
    baseline = _cycle_capture(0, rng)
    shifted = [_cycle_capture(int(s), rng) for s in rng.integers(0, 500, size=6)]
    aligned = aw.HealthModel(spec, aw.PCADetector(n_components=5)).fit(baseline)
    unaligned = aw.HealthModel(spec, aw.PCADetector(n_components=5), align_phase=False).fit(
        baseline
    )
    with_alignment = np.array([aligned.distance(c) for c in shifted])
    without = np.array([unaligned.distance(c) for c in shifted])
    # Without alignment the start phase alone makes healthy captures look far from the baseline.
    assert np.median(without) > 50 * np.median(with_alignment)
    # With alignment, a fault stands out of healthy captures at random phase.
    aligned.calibrate(shifted[:4])
    assert aligned.assess(_cycle_capture(123, rng, fault=0.5)).alarm
    assert not any(aligned.assess(c).alarm for c in shifted[4:])


def test_assess_before_calibrate_is_an_error(rng: np.random.Generator) -> None:
    model = aw.HealthModel(
        aw.FeatureSpec(signals=("speed",), combinations="none", segment_length=64)
    )
    model.fit(_cycle_capture(0, rng))
    with pytest.raises(aw.CalibrationError, match=r"not calibrated: call calibrate\(\)"):
        model.assess(_cycle_capture(0, rng))


def test_calibrate_on_distances(rng: np.random.Generator) -> None:
    model = aw.HealthModel(
        aw.FeatureSpec(signals=("speed",), combinations="none", segment_length=64)
    )
    model.fit(_cycle_capture(0, rng)).calibrate(np.array([1.0, 2.0, 3.0]), percentile=50)
    assert model.threshold_ == pytest.approx(2.0 * np.log(2.0))


def test_min_threshold_bounds_the_calibrated_one(
    robot_capture: aw.Capture, rng: np.random.Generator
) -> None:
    def noisy() -> aw.Capture:
        signals = {k: v + 0.01 * rng.normal(size=v.size) for k, v in robot_capture.signals.items()}
        return aw.Capture(signals, robot_capture.rates_hz)

    spec = aw.FeatureSpec(segment_length=32, hop=8)
    healthy = [noisy() for _ in range(4)]
    low = aw.HealthModel(spec, aw.PCADetector(n_components=2)).fit(robot_capture)
    high = aw.HealthModel(spec, aw.PCADetector(n_components=2), min_threshold=1e9)
    high.fit(robot_capture)
    assert low.calibrate(healthy).threshold_ < 1e9
    assert high.calibrate(healthy).threshold_ == 1e9


def test_one_feature_path_the_default_stage_is_the_aligned_stft(rng: np.random.Generator) -> None:
    spec = aw.FeatureSpec(
        signals=("speed", "torque"), combinations="none", segment_length=64, hop=4
    )
    baseline, shifted = _cycle_capture(0, rng), _cycle_capture(137, rng)
    model = aw.HealthModel(spec, aw.PCADetector(n_components=5)).fit(baseline)
    assert isinstance(model.stage_, aw.StftStage)
    assert (model.stage_.spec, model.stage_.align) == (spec, True)
    # The aligned features, computed by hand: resample, find the lag, roll, |STFT|.
    reference, _ = aw.resample_capture(baseline, spec.signals)
    signals, rate = aw.resample_capture(shifted, spec.signals)
    lag = aw.phase_lag(reference, signals)
    expected = aw.stft_features(
        np.roll(signals, -lag, axis=0), rate, segment_length=64, hop=4, scaling="magnitude"
    )
    features, model_lag = model.featurize(shifted)
    assert model_lag == lag == features.phase_lag != 0
    np.testing.assert_array_equal(features.X, expected)
    unaligned = aw.HealthModel(spec, aw.PCADetector(n_components=5), align_phase=False)
    features = unaligned.fit(baseline).featurize(shifted)[0]
    assert features.phase_lag == 0
    np.testing.assert_array_equal(features.X, aw.extract_features(shifted, spec).X)


def test_the_one_call_constructor_builds_the_papers_method(robot_capture: aw.Capture) -> None:
    for method, detector in (("lra", aw.LRADetector), ("pca", aw.PCADetector)):
        paper = aw.HealthModel.paper(method)
        assert isinstance(paper.detector, detector)
        assert (paper.stage, paper.align_phase, paper.features) == (None, True, aw.FeatureSpec())
    spec = aw.FeatureSpec(combinations="none", segment_length=64, hop=16)
    by_hand = aw.HealthModel(spec, aw.PCADetector()).fit(robot_capture)
    paper = aw.HealthModel.paper("pca", features=spec).fit(robot_capture)
    assert paper.distance(robot_capture) == by_hand.distance(robot_capture)


def test_paper_rejects_an_unknown_method() -> None:
    with pytest.raises(ValueError, match=r"'method' parameter of HealthModel.paper must be 'lra'"):
        aw.HealthModel.paper("mechanics")  # type: ignore[arg-type]


def test_an_lra_model_keeps_its_baselines_signals_not_its_features() -> None:
    import pickle

    from axiswatch.paper._stages import RecomputedFeatures

    baseline = awd.simulate_capture("heavy", seed=1, duration_s=0.5)
    model = aw.HealthModel(aw.FeatureSpec(), aw.LRADetector()).fit(baseline)
    features = aw.extract_features(baseline).X  # 1,000 rows x 390 columns at hop 1
    assert isinstance(model.detector_.baseline_, RecomputedFeatures)
    assert len(pickle.dumps(model)) < features.nbytes / 2  # the basis and the signals
    assert model.fingerprint() == hashlib.sha256(features.tobytes()).hexdigest()
    # A shorter test capture is compared with the baseline's leading rows, recomputed.
    reference = aw.LRADetector().fit(features)
    for seconds in (0.5, 0.4):
        test, _ = model.featurize(awd.simulate_capture("palletize", seed=2, duration_s=seconds))
        assert model.detector_.distance(test.X) == pytest.approx(
            reference.distance(test.X), rel=1e-12
        )


def test_a_detector_that_reads_the_baseline_on_every_test_keeps_it() -> None:
    baseline = awd.simulate_capture("heavy", seed=1, duration_s=0.3)
    for detector in (aw.PCADetector(), aw.LRADetector(solver="dense")):
        model = aw.HealthModel(aw.FeatureSpec(hop=8), detector).fit(baseline)
        assert isinstance(model.detector_.baseline_, np.ndarray)
