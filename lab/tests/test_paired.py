"""Reduced paired evaluation, asserting what the fuller runs measured (lab/docs/decision-log.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
import axiswatch_lab as lab
from axiswatch import PCADetector
from axiswatch_lab import _mechanics
from axiswatch_lab._paired import DEFAULT_STAGES, PairedDesign, paired_evaluation
from lab_cli import run

#: The columns of paired.csv, as the issue names them.
PAIRED_COLUMNS = [
    "features",
    "method",
    "fault",
    "auroc",
    "far95",
    "dr95",
    "far99",
    "dr99",
    "oracle_auroc",
]


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    design = PairedDesign(
        test_tasks=("short_fast", "heavy", "long_slow"),
        faults=("backlash", "friction"),
        n_per_cell=2,
    )
    stages = {name: DEFAULT_STAGES[name] for name in ("stft", "residual")}
    return paired_evaluation(design, stages=stages, methods={"pca": PCADetector})


#: What the monitor's threshold rule gives, beside them.
FLOOR_COLUMNS = ["far95_floor", "dr95_floor", "far99_floor", "dr99_floor"]


def test_columns_are_exactly_the_documented_ones(table: pd.DataFrame) -> None:
    assert list(table.columns) == PAIRED_COLUMNS + FLOOR_COLUMNS


def test_floor_columns_equal_the_plain_ones_without_a_floor(table: pd.DataFrame) -> None:
    for plain, floored in zip(PAIRED_COLUMNS[4:8], FLOOR_COLUMNS, strict=True):
        np.testing.assert_array_equal(table[plain], table[floored])


def test_residual_stage_sees_backlash_and_friction_across_tasks(table: pd.DataFrame) -> None:
    # Measured over seeds 0 and 1: oracle 1.00; across tasks backlash 1.00, friction 0.83-0.96.
    residual = table.set_index(["features", "fault"]).loc["residual"]
    assert (residual.oracle_auroc >= 0.9).all()
    assert residual.loc["backlash", "auroc"] >= 0.9
    assert residual.loc["friction", "auroc"] >= 0.75


def test_same_task_calibration_does_not_cover_other_tasks(table: pd.DataFrame) -> None:
    # The open problem (issue 7 targets not reached): a threshold fitted on the baseline task's
    # captures is exceeded by healthy captures of other tasks (measured far99 = 1.0).
    assert table.set_index(["features", "fault"]).loc[("residual", "backlash"), "far99"] >= 0.5


def test_paper_features_see_nothing_at_the_threshold(table: pd.DataFrame) -> None:
    # |STFT| rows of captures at random phases: the calibration captures' spread dwarfs any fault.
    stft = table.set_index(["features", "fault"]).loc["stft"]
    assert (stft.dr99 == 0.0).all()
    assert (stft.oracle_auroc < 0.9).all()


def test_command_writes_paired_csv_and_figure(tmp_path: Path) -> None:
    result = run("experiment", "paired", "--out", tmp_path, "--per-cell", "1", "--no-oracle")
    assert result.returncode == 0, result.stderr
    written = pd.read_csv(tmp_path / "paired.csv")
    assert list(written.columns) == PAIRED_COLUMNS + FLOOR_COLUMNS
    assert len(written) == 5 * 3 * 4  # stages x methods x faults
    assert written.oracle_auroc.isna().all()
    assert (tmp_path / "paired.png").stat().st_size > 1000


def test_mechanics_scales_are_those_of_the_development_protocol() -> None:
    # MECHANICS_SCALES is a constant of the code; it must be what the protocol measures.
    np.testing.assert_allclose(lab.development_scales(), _mechanics.MECHANICS_SCALES, rtol=5e-3)


def test_task_change_scale_is_that_of_the_development_protocol() -> None:
    assert lab.development_task_change_scale() == pytest.approx(
        _mechanics.MECHANICS_TASK_CHANGE_SCALE, rel=5e-3
    )


def test_development_design_shares_no_task_or_seed_with_the_reported_one() -> None:
    reported = PairedDesign()
    assert not set(lab.DEVELOPMENT_DESIGN.test_tasks) & set(reported.test_tasks)
    assert lab.DEVELOPMENT_DESIGN.seed != reported.seed


def test_protocol_selects_the_mechanics_stage_with_the_indicator_detector() -> None:
    # Measured on the development design: worst AUROC 0.78 (mean 0.95, far99 0.00); the next
    # best is 0.56. The product default (STAGE_METHODS) is this choice.
    ranking = lab.select_default()
    best = ranking.iloc[0]
    assert (best.features, best.method) == ("mechanics", "indicator")
    assert best.worst_auroc > ranking.iloc[1].worst_auroc + 0.1
    from axiswatch_lab._experiments import STAGE_METHODS

    assert STAGE_METHODS["mechanics"] == (lab.MechanicsStage, aw.IndicatorDetector)


def test_the_evaluation_runs_blas_on_one_thread() -> None:
    # The suite pins BLAS to one thread (conftest), so the driver is given two first: the
    # evaluation must bring it back to one while it fits (a multi-threaded BLAS on small SVDs
    # made select_default 4x slower on a 2-core machine) and restore the caller's limit after.
    from threadpoolctl import threadpool_info, threadpool_limits

    seen: list[int] = []

    class CountingStage(lab.StateStage):
        def fit(self, baseline: aw.Capture) -> CountingStage:
            seen.append(max(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"))
            super().fit(baseline)
            return self

    design = PairedDesign(
        test_tasks=("short_fast", "heavy"),
        faults=("friction",),
        n_per_cell=1,
        n_calibration=2,
        duration_s=1.0,
    )
    with threadpool_limits(2, user_api="blas"):
        before = max(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")
        paired_evaluation(
            design, stages={"state": CountingStage}, methods={"pca": PCADetector}, oracle=False
        )
        after = max(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")
    assert before == after == 2
    assert seen == [1]
