"""Reduced versions of the paper experiments, asserting what the full runs measured (with margins)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from axiswatch_lab._experiments import alarm_summary, lab_roc, robot_a, robot_b
from lab_cli import run


@pytest.fixture(scope="module")
def roc() -> pd.DataFrame:
    return lab_roc(
        n_repetitions=2,
        percentiles=[50.0, 90.0, 99.0],
        protocols=["same_run", "all_days", "first_operation"],
        n_calibration_runs=1,
    )


def test_lab_auroc_lra_perfect_pca_not(roc: pd.DataFrame) -> None:
    auroc = roc.groupby("method").auroc.mean()
    assert auroc["lra"] == 1.0
    # The paper's "PCA below chance" does not hold threshold-free: PCA ranks the anomaly above the
    # five first-operation days and below the three second-operation days, AUROC 5/8 (see
    # docs/paper-notes.md). Below chance are its thresholded points (next test).
    assert auroc["pca"] == pytest.approx(0.625, abs=0.01)


def test_lab_threshold_points(roc: pd.DataFrame) -> None:
    same = roc[roc.protocol == "same_run"].set_index(["method", "percentile"])
    # LRA at the 99th percentile: the anomaly and nothing else (paper's shape).
    assert same.loc[("lra", 99.0), "tpr"] == 1.0
    assert same.loc[("lra", 99.0), "fpr"] == 0.0
    # PCA: every point on or below the chance line, strictly below where it flags anything.
    pca = same.loc["pca"]
    assert (pca.tpr <= pca.fpr).all()
    assert (pca.tpr < pca.fpr).any()
    # Calibrated on the first operation only, both methods flag the second operation.
    first = roc[(roc.protocol == "first_operation") & (roc.percentile == 99.0)]
    assert (first.fpr >= 0.3).all()


def test_lab_roc_rejects_unknown_protocol() -> None:
    with pytest.raises(ValueError, match=r"Unknown protocol\(s\) \['leave_one_out'\]"):
        lab_roc(protocols=["leave_one_out"])
    with pytest.raises(ValueError, match="'n_repetitions' parameter must be an int >= 1"):
        lab_roc(n_repetitions=0)


def test_robot_a_needs_enough_tasks() -> None:
    with pytest.raises(ValueError, match="Robot A needs 4 tasks for 3 task changes; got 2"):
        robot_a(tasks=("heavy", "light"))


def test_experiment_commands_write_figure_and_table(tmp_path: Path) -> None:
    result = run("experiment", "robot-b", "--out", tmp_path, "--days", "3", "--seed", "1")
    assert result.returncode == 0, result.stderr
    table = pd.read_csv(tmp_path / "robot_b.csv")
    assert list(table.columns) == [
        "day",
        "task",
        "fault",
        "severity",
        "method",
        "alignment",
        "distance",
    ]
    assert (tmp_path / "robot_b.png").stat().st_size > 1000
    assert "robot_b.csv" in result.stdout


def test_roc_table_has_the_exact_columns(roc: pd.DataFrame) -> None:
    assert list(roc.columns) == ["method", "protocol", "percentile", "fpr", "tpr", "auroc"]
    assert len(roc) == 2 * 3 * 3  # methods x protocols x percentiles


@pytest.fixture(scope="module")
def study_a() -> pd.DataFrame:
    return robot_a(n_days=8, task_change_days=(4, 6), seed=0)


def _pre_post(table: pd.DataFrame, method: str, alignment: str) -> tuple[pd.Series, pd.Series]:
    rows = table[(table.method == method) & (table.alignment == alignment)]
    return rows[rows.day < 4].distance, rows[rows.day >= 4].distance


@pytest.mark.parametrize("method", ["lra", "pca"])
def test_robot_a_task_changes_show_for_both_methods_once_aligned(
    study_a: pd.DataFrame, method: str
) -> None:
    # Full run (190 days): with alignment the median distance of the later tasks is 6-10x (LRA)
    # and 9-13x (PCA) that of the baseline's task. The paper's "LRA stays flat" does not hold here.
    before, after = _pre_post(study_a, method, "phase")
    assert after.min() > before.max()
    assert after.median() > 3 * before.median()


def test_robot_a_without_alignment_pca_measures_the_phase(study_a: pd.DataFrame) -> None:
    # Full run: unaligned, PCA's distance on the baseline's own task is 17x its aligned value
    # (random capture phase), larger than what a task change adds.
    unaligned, _ = _pre_post(study_a, "pca", "none")
    aligned, _ = _pre_post(study_a, "pca", "phase")
    assert unaligned.median() > 5 * aligned.median()


def test_robot_b_paper_features_barely_see_a_growing_bearing_fault() -> None:
    # Full run (148 days): the last week's median distance is 0.96-1.23x the first month's for both
    # methods, below the first month's 99th percentile. Reduced: severity up to 0.84 on day 12.
    table = robot_b(n_days=12, seed=0)
    paper = table[table.method.isin(["lra", "pca"])]
    for (method, alignment), rows in paper.groupby(["method", "alignment"]):
        early = rows[rows.day <= 6].distance
        late = rows[rows.day >= 10].distance
        assert late.median() < 2.0 * early.median(), (method, alignment)
    # The product default sees it: measured late median 71, early 1.4 (x50).
    mechanics = table[table.method == "mechanics"]
    early = mechanics[mechanics.day <= 6].distance
    late = mechanics[mechanics.day >= 10].distance
    assert late.median() > 10 * early.median()


def test_robot_a_default_raises_no_false_alarm_through_task_changes() -> None:
    # Reduced Robot A (48 days, the four tasks, changes on days 15, 27, 38), the product default
    # only; the full 190-day run also gives 0 (lab/docs/decision-log.md).
    table = robot_a(n_days=48, task_change_days=(15, 27, 38), methods={})
    summary = alarm_summary(table).set_index("method").loc["mechanics"]
    assert summary.n_days == 42
    assert summary.false_alarms == 0
