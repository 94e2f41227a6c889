"""The nearest-task study (lab): its unit-change prior, its matching, and its record."""

from __future__ import annotations

import dataclasses
import inspect
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_limits
from typer.testing import CliRunner

import axiswatch_lab._transfer as transfer_module
import axiswatch_lab.studies.nearest_task_not_adopted as nearest_module
from axiswatch import IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot, draw_unit
from axiswatch_lab._product import pool_fleet
from axiswatch_lab._transfer import TransferDesign
from axiswatch_lab.cli import experiment_app
from axiswatch_lab.studies.nearest_task_not_adopted import (
    extra_unit_index,
    holding_axes,
    nearest_task_study,
    robot_nearest_task,
    same_task_pairs,
    score_nearest,
    unit_change_prior,
    wrong_matches,
)
from lab_naive import unit_change_prior_naive

#: A task signature (top speed, moving speed quantiles, position quantiles, share moving).
REFERENCE = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5])


def _faster(factor: float) -> np.ndarray:
    """REFERENCE with its top speed times ``factor``: ``|factor - 1|`` from it."""
    return REFERENCE * np.array([factor, 1, 1, 1, 1, 1])


def test_unit_change_prior_matches_its_naive_twin() -> None:
    rng = np.random.default_rng(7)
    names = ("coulomb_friction", "impulsiveness", "viscous_friction")
    centres = [
        {n: float(rng.normal(10.0 * (k // 2), 1.0)) for n in names} for k in range(8)
    ]  # pairs
    within = [{n: float(rng.uniform(0.2, 1.5)) for n in names} for _ in range(8)]
    del centres[2]["viscous_friction"], centres[5]["impulsiveness"]  # not read on every axis
    pairs = [(0, 1), (2, 3), (4, 5), (6, 7)]
    prior = unit_change_prior(centres, within, pairs)
    assert prior is not None
    spreads, scale, scales = unit_change_prior_naive(
        centres, within, pairs, {n: n == "impulsiveness" for n in names}
    )
    for name in names:
        assert prior.task_spreads[name] == pytest.approx(spreads[name], rel=1e-12)
        assert prior.indicator_scales[name] == pytest.approx(scales[name], rel=1e-12)
    assert prior.allowance_scale == pytest.approx(scale, rel=1e-12)
    assert (prior.n_axes, prior.centres) == (8, ())
    # Only the pairs count: two units differ by about sqrt(2), two pairs by 10 or more.
    assert prior.task_spreads["coulomb_friction"] < 3.0


def test_unit_change_prior_needs_three_same_task_pairs() -> None:
    centres = [{"coulomb_friction": float(k)} for k in range(6)]
    within = [{"coulomb_friction": 1.0}] * 6
    assert unit_change_prior(centres, within, [(0, 1), (2, 3)]) is None
    assert unit_change_prior(centres, within, [(0, 1), (2, 3), (4, 5)]) is not None


def test_same_task_pairs_need_each_within_the_other() -> None:
    # Axis 1 holds axis 0 (0.15 <= 0.2), axis 0 does not hold axis 1 (0.15 > 0.1).
    pairs = same_task_pairs([REFERENCE, _faster(1.15), _faster(1.16)], [0.1, 0.2, 0.2])
    assert pairs == [(1, 2)]


def test_wrong_match_count_on_a_tiny_constructed_case() -> None:
    # Axes: task 0 at REFERENCE (envelope 0.1), task 1 at +30 % top speed (envelope 0.2 of its
    # 2.6: it holds signatures from +4.8 % to +55 %).
    references = [REFERENCE, _faster(1.3)]
    envelopes = [0.1, 0.2]
    signatures = [
        REFERENCE,  # task 0, held by axis 0 only: right
        _faster(1.06),  # task 0, held by both: wrong
        _faster(1.3),  # task 1, held by axis 1 only: right
        _faster(3.0),  # task 1, held by none: not a wrong match
        np.full(6, np.nan),  # motion not read: held by none
    ]
    tasks = [0, 0, 1, 1, 0]
    assert wrong_matches(signatures, tasks, references, envelopes, [0, 1]) == 1
    assert wrong_matches(signatures, tasks, references, envelopes, [1, 1]) == 2
    assert [k for _, k in holding_axes(_faster(1.06), references, envelopes)] == [0, 1]


@pytest.fixture(scope="module")
def small_fleet() -> tuple[list[IndicatorModel], dict[int, object]]:
    """Axes of tasks 0, 1 and 2 of one robot (4 captures each), pooled; readings of one more
    capture of tasks 0, 1 and 3."""
    robot = draw_robot(DEVELOPMENT_ROBOTS[1])
    reader = IndicatorModel()
    with threadpool_limits(1):
        fleet = [
            IndicatorModel().fit_readings(
                [reader.readings(robot.capture(t, seed=k)) for k in range(4)]
            )
            for t in range(3)
        ]
        prior = pool_fleet(fleet)
        for model in fleet:
            model.use_fleet(prior)
        tests = {t: reader.readings(robot.capture(t, seed=99)) for t in (0, 1, 3)}
    return fleet, tests  # type: ignore[return-value]


def test_variant_is_the_default_when_no_other_axis_matches(
    small_fleet: tuple[list[IndicatorModel], dict[int, object]],
) -> None:
    fleet, tests = small_fleet
    # Stand-ins for the unit-change models: any models other than the baseline's do.
    unit_models = [
        IndicatorModel().fit_readings(m.fit_readings_).use_fleet(pool_fleet(fleet)) for m in fleet
    ]
    own = fleet[0]
    references = [m.task_reference_ for m in fleet]
    envelopes = [m.task_envelope_ for m in fleet]
    for task in (0, 3):  # the baseline's own task; a task no axis runs
        readings = tests[task]
        assert task == 0 or not holding_axes(readings.signature, references, envelopes)  # type: ignore[attr-defined]
        default = own.assess_readings(readings)  # type: ignore[arg-type]
        score = score_nearest(readings, own, 0, fleet, unit_models)  # type: ignore[arg-type]
        assert score.matched is None
        assert score.ratio == default.distance / default.threshold
        assert score.alarm == default.alarm
    # A capture of task 1 goes to axis 1 (so the test above can fail), unless there is no prior.
    score = score_nearest(tests[1], own, 0, fleet, unit_models)  # type: ignore[arg-type]
    scored = unit_models[1].assess_readings(tests[1])  # type: ignore[arg-type]
    assert score.matched == 1
    assert score.ratio == scored.distance / scored.threshold
    assert score_nearest(tests[1], own, 0, fleet, None).matched is None  # type: ignore[arg-type]


def test_the_study_takes_no_order_lines() -> None:
    with pytest.raises(ValueError, match="takes no order lines"):
        robot_nearest_task(DEVELOPMENT_ROBOTS[0], TransferDesign(order_lines=True))
    with pytest.raises(ValueError, match="at least two units per task"):
        robot_nearest_task(DEVELOPMENT_ROBOTS[0], units_per_task=1)


def test_extra_units_take_indices_no_other_unit_has() -> None:
    for n_tasks in (1, 2, 6):
        first = list(range(n_tasks + 1))  # unit t of task t, then Robot A
        extra = [extra_unit_index(u, t, n_tasks) for u in range(1, 5) for t in range(n_tasks)]
        assert len(set(first + extra)) == len(first) + len(extra)
        # The second unit is the two-unit study's (n_tasks + 1 + t).
        assert [extra_unit_index(1, t, n_tasks) for t in range(n_tasks)] == [
            n_tasks + 1 + t for t in range(n_tasks)
        ]
    with pytest.raises(ValueError, match="u >= 1"):
        extra_unit_index(0, 0, 6)
    with pytest.raises(ValueError, match="task < n_tasks"):
        extra_unit_index(1, 6, 6)


#: The smallest study that fits every axis (seconds per record).
TINY_DESIGN = TransferDesign(
    n_per_cell=1, n_calibration=4, robot_a_days=8, degradation_days=0, unit_spread=0.2
)


@pytest.mark.slow
def test_two_units_per_task_is_the_default_record() -> None:
    # The default is today's fleet (checked on the signatures, not by a second record: the
    # record is the slow part).
    for function in (robot_nearest_task, nearest_task_study):
        assert inspect.signature(function).parameters["units_per_task"].default == 2
    with threadpool_limits(1):
        two = robot_nearest_task(DEVELOPMENT_ROBOTS[1], TINY_DESIGN, units_per_task=2)
    assert two["same_task_pairs"] == 6
    # The two-unit study's record before units_per_task existed (main at 1fed49f, this design):
    # its second units (index and capture seeds) are unchanged.
    today = {"backlash": 0.8222222222, "bearing": 0.4055555556, "friction": 0.8, "tooth": 0.45}
    for fault, auroc in today.items():
        assert two[f"nearest_auroc_{fault}"] == pytest.approx(auroc, abs=1e-9), fault


@pytest.fixture(scope="module")
def three_unit_command(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[object, pd.DataFrame, list[int]]:
    """The command on robot 1 with ``--fast --unit-spread 0.2 --units-per-task 3``, ``--fast``'s
    design made TINY_DESIGN (without its unit spread, which the option gives): its result, its
    table, and the units it drew. One robot record is the slow part of this module, so the
    command and the three-unit study are read from one run (it is
    ``robot_nearest_task(DEVELOPMENT_ROBOTS[1], TINY_DESIGN, units_per_task=3)``)."""
    out = tmp_path_factory.mktemp("nearest")
    drawn: list[int] = []

    def recording(robot: object, unit: int, spread: float) -> object:
        drawn.append(unit)
        return draw_unit(robot, unit, spread)  # type: ignore[arg-type]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(nearest_module, "draw_unit", recording)
        patch.setattr(transfer_module, "draw_unit", recording)
        # The command reads FAST_DESIGN from the module when it runs (the claim is that --fast
        # reaches the computation, not FAST_DESIGN's sizes).
        patch.setattr(
            transfer_module, "FAST_DESIGN", dataclasses.replace(TINY_DESIGN, unit_spread=0)
        )
        result = CliRunner().invoke(
            experiment_app,
            [
                "nearest-task",
                *("--out", str(out), "--robots", "1", "--fast", "--unit-spread", "0.2"),
                *("--units-per-task", "3"),
            ],
        )
    table = pd.read_csv(out / "robots.csv") if result.exit_code == 0 else pd.DataFrame()
    return result, table, drawn


@pytest.mark.slow
def test_three_units_per_task_draw_distinct_units(
    three_unit_command: tuple[object, pd.DataFrame, list[int]],
) -> None:
    result, table, drawn = three_unit_command
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    record = table.iloc[0]
    n_tasks = len(draw_robot(DEVELOPMENT_ROBOTS[1]).tasks)
    # Every fleet axis and Robot A a unit of its own: 3 per task and one.
    assert sorted(drawn) == sorted(set(drawn))
    assert len(drawn) == 3 * n_tasks + 1
    assert record["same_task_pairs"] == 3 * n_tasks  # 3 pairs per task, none across tasks
    assert record["pairs_across_tasks"] == 0


@pytest.mark.slow
def test_the_command_writes_the_table(
    three_unit_command: tuple[object, pd.DataFrame, list[int]],
) -> None:
    result, table, _ = three_unit_command
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    assert list(table.robot) == ["robot1"]
    # --fast's design (here TINY_DESIGN's 8 days, not the full study's 48): days after the
    # baseline and n_calibration calibration days.
    assert table.robot_a_test_days.tolist() == [
        TINY_DESIGN.robot_a_days - TINY_DESIGN.n_calibration - 1
    ]
    # Every measure of the record, for each variant, in its range.
    record = table.iloc[0]
    for variant in ("default", "nearest", "absent"):
        for fault in ("backlash", "friction", "tooth", "bearing"):
            assert 0.0 <= record[f"{variant}_auroc_{fault}"] <= 1.0
        assert 0.0 <= record[f"{variant}_far99"] <= 1.0
    for share in ("share_rerouted", "share_wrong_match", "share_wrong_nearest"):
        assert 0.0 <= record[share] <= 1.0
    assert not math.isnan(record["absent_share_rerouted"])
    assert record["same_task_pairs"] == 18  # three units per task: 3 pairs per task


def test_the_command_refuses_unreadable_robots(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        experiment_app, ["nearest-task", "--out", str(tmp_path), "--robots", "some"]
    )
    assert result.exit_code == 2
    assert "--robots must be 'development' or seeds such as 1,2; got 'some'" in result.output
