"""The supervised ceiling (lab, i19b): its classifiers rank separable and inseparable sets as
they must, its folds keep a capture out of its own training, its features follow their naive
twins, and its captures are the paired design's."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import welch
from sklearn.base import ClassifierMixin
from typer.testing import CliRunner

import lab_naive as naive
from axiswatch.datasets import DEVELOPMENT_ROBOTS, SimulatedRobot, draw_robot
from axiswatch_lab._product import CELLS_PER_DECADE, OrderProfile, _transformed
from axiswatch_lab._transfer import TransferDesign, _profile, paired_readings
from axiswatch_lab.cli import experiment_app
from axiswatch_lab.studies.supervised_ceiling import (
    CLASSIFIERS,
    COMPARISONS,
    FEATURE_SETS,
    ORDER_BAND_CELLS,
    RELATIVE_BAND_EDGES,
    WELCH_SEGMENT,
    CaptureFeatures,
    capture_features,
    make_classifier,
    order_bands,
    out_of_fold_scores,
    spectral_features,
)


def _auroc(labels: np.ndarray, scores: np.ndarray) -> float:
    from sklearn.metrics import roc_auc_score

    return float(roc_auc_score(labels, scores))


@pytest.mark.parametrize("classifier", CLASSIFIERS)
def test_the_ceiling_is_one_on_a_separable_set_and_a_half_on_an_inseparable_one(
    classifier: str,
) -> None:
    rng = np.random.default_rng(0)
    labels = np.repeat([0, 1], 60).astype(np.int64)
    noise = rng.normal(size=(120, 6))
    separable = noise + 4.0 * labels[:, None] * np.eye(6)[0]
    groups = np.arange(120)
    scores = out_of_fold_scores(separable, labels, groups, classifier)
    assert _auroc(labels, scores) > 0.98
    inseparable = out_of_fold_scores(noise, labels, groups, classifier)
    assert abs(_auroc(labels, inseparable) - 0.5) < 0.15


def test_grouped_folds_keep_a_capture_out_of_its_own_training() -> None:
    # 40 "captures" of 3 rows each, a random label per capture, and a column that only names the
    # capture: a row can be told only by memorising its capture's other rows.
    rng = np.random.default_rng(1)
    capture = np.repeat(np.arange(40), 3)
    labels = np.repeat(rng.permutation(np.repeat([0, 1], 20)), 3).astype(np.int64)
    names_only = np.eye(40)[capture]
    grouped = out_of_fold_scores(names_only, labels, capture, "logistic")
    rows = out_of_fold_scores(names_only, labels, np.arange(capture.size), "logistic")
    assert _auroc(labels, rows) > 0.9  # rows as groups: its other rows were in training
    assert _auroc(labels, grouped) < 0.7  # grouped: nothing to memorise


def test_out_of_fold_scores_need_two_groups_of_each_label() -> None:
    labels = np.array([0, 0, 0, 1], dtype=np.int64)
    with pytest.raises(ValueError, match=r"at least 2 groups of each label; got \[3, 1\]"):
        out_of_fold_scores(np.zeros((4, 1)), labels, np.arange(4), "logistic")


def test_an_unknown_classifier_is_refused() -> None:
    with pytest.raises(ValueError, match=r"must be one of .*'logistic'.*got 'forest'"):
        make_classifier("forest")


@pytest.mark.parametrize("n_samples", [40, 300, 5000])
def test_band_powers_follow_the_naive_twin_and_add_up_to_the_power(n_samples: int) -> None:
    rate = 500.0
    torque = np.random.default_rng(2).normal(size=n_samples)
    got = spectral_features(torque, rate)
    freqs, psd = welch(torque, fs=rate, nperseg=min(WELCH_SEGMENT, n_samples))
    want = naive.relative_band_powers_naive(
        freqs.tolist(), psd.tolist(), rate, list(RELATIVE_BAND_EDGES)
    )
    np.testing.assert_allclose(list(got.values()), want, rtol=1e-12)
    total = sum(10**v for v in got.values() if math.isfinite(v))
    # The PSD integrates to the power of the windowed, mean-removed segments: about the variance.
    assert total == pytest.approx(float(np.var(torque)), rel=0.25)
    if n_samples == 40:  # 12.5 Hz bins: the bands between the 0 bin and 0.025 x rate hold none
        assert math.isnan(got["psd[0.0078-0.011]"])


def test_a_line_lands_in_its_band() -> None:
    t = np.arange(4000) / 2000.0
    got = spectral_features(np.sin(2 * np.pi * 0.2 * 2000.0 * t), 2000.0)
    assert max(got, key=got.__getitem__) == "psd[0.15-0.21]"


def test_order_bands_follow_the_naive_twin() -> None:
    values = np.random.default_rng(3).normal(size=50)
    values[[3, 4, 20]] = np.nan
    values[36:48] = np.nan  # a whole band unread (cells 108-119 with first cell 72)
    profile = OrderProfile(first_cell=72, values=values)
    got = order_bands(profile)
    want = naive.order_bands_naive(72, values.tolist(), ORDER_BAND_CELLS)
    np.testing.assert_array_equal(list(got.values()), want)
    assert ORDER_BAND_CELLS * 4 == CELLS_PER_DECADE
    assert order_bands(None) == {}


def test_the_permutation_repeats_reach_the_importances() -> None:
    from axiswatch_lab.studies.supervised_ceiling import _top_features

    rng = np.random.default_rng(4)
    labels = np.repeat([0, 1], 30).astype(np.int64)
    features = rng.normal(size=(60, 4)) + 1.5 * labels[:, None] * np.eye(4)[0]
    names = ["a", "b", "c", "d"]
    once = _top_features(features, labels, np.arange(60), names, 2, n_repeats=1)
    five = _top_features(features, labels, np.arange(60), names, 2, n_repeats=5)
    assert once[:2] == five[:2]  # the logistic coefficients take no permutations
    assert once[2][1] == five[2][1] == "a"
    assert once[2][2] != five[2][2]


@pytest.mark.slow
def test_the_captures_are_the_paired_designs() -> None:
    robot = draw_robot(DEVELOPMENT_ROBOTS[5])  # 20 Hz: seconds
    design = TransferDesign(n_per_cell=1)
    from axiswatch import IndicatorModel

    read = IndicatorModel(_profile(robot, True)).readings
    paired = paired_readings(robot, read, design)
    taken = capture_features(robot, design)
    assert len(taken) == sum(len(v) for v in paired.values())
    for row in taken:
        want = _transformed(paired[(row.task, row.health)][row.index])
        assert row.readings.keys() == want.keys()
        np.testing.assert_array_equal(list(row.readings.values()), list(want.values()))


@pytest.fixture(scope="module")
def features_taken() -> dict[tuple[object, TransferDesign], list[CaptureFeatures]]:
    """The captures' features per (robot, design), shared by the command's runs below."""
    return {}


@pytest.fixture
def small_command(
    monkeypatch: pytest.MonkeyPatch,
    features_taken: dict[tuple[object, TransferDesign], list[CaptureFeatures]],
) -> None:
    """The ceiling command's computation made small where its tables' layout does not depend
    on it: the captures' features read once for every run of this module (the same robot and
    design give the same features), and a boosting of 10 trees instead of 100."""
    import axiswatch_lab.studies.supervised_ceiling as ceiling_module

    def taken_once(robot: SimulatedRobot, design: TransferDesign) -> list[CaptureFeatures]:
        if (robot, design) not in features_taken:
            features_taken[(robot, design)] = capture_features(robot, design)
        return features_taken[(robot, design)]

    def fewer_trees(name: str, seed: int = 0) -> ClassifierMixin:
        model = make_classifier(name, seed)
        return model.set_params(max_iter=10) if name == "boosting" else model

    monkeypatch.setattr(ceiling_module, "capture_features", taken_once)
    monkeypatch.setattr(ceiling_module, "make_classifier", fewer_trees)


@pytest.mark.slow
@pytest.mark.usefixtures("small_command")
@pytest.mark.parametrize(
    # One permutation per feature and fold: the table's layout does not depend on the repeats
    # (the study's default is 5).
    "options",
    [["--repeats", "1"], ["--permuted-labels", "--top", "0"]],
)
def test_the_command_writes_every_table(tmp_path: object, options: list[str]) -> None:
    from pathlib import Path

    out = Path(str(tmp_path)) / "ceiling"
    result = CliRunner().invoke(
        experiment_app,
        ["ceiling", "--out", str(out), "--robots", "5", "--per-cell", "2", *options],
    )
    assert result.exit_code == 0, result.output
    import pandas as pd

    aurocs = pd.read_csv(out / "aurocs.csv")
    assert len(aurocs) == 4 * len(FEATURE_SETS) * len(CLASSIFIERS) * len(COMPARISONS)
    assert aurocs.auroc.between(0, 1).all()
    summary = pd.read_csv(out / "summary.csv")
    assert set(summary.comparison) == set(COMPARISONS)
    if "--top" in options:  # --top 0: no importances computed
        assert (out / "top_features.csv").read_text().strip() in ("", '""')
        return
    top = pd.read_csv(out / "top_features.csv")
    assert set(top.feature_set) == set(FEATURE_SETS)
    assert set(top.method) == {"logistic coef", "boosting permutation"}


def test_the_command_refuses_no_permutation(tmp_path: object) -> None:
    result = CliRunner().invoke(
        experiment_app, ["ceiling", "--out", str(tmp_path), "--robots", "5", "--repeats", "0"]
    )
    assert result.exit_code == 2
    assert "Invalid value for '--repeats'" in result.output


def test_the_command_refuses_unreadable_robots(tmp_path: object) -> None:
    result = CliRunner().invoke(
        experiment_app, ["ceiling", "--out", str(tmp_path), "--robots", "some"]
    )
    assert result.exit_code == 2
    assert "--robots must be 'development' or seeds such as 1,2; got 'some'" in result.output
