"""IndicatorModel: where every number of the decision comes from, and how it behaves."""

from __future__ import annotations

import ast
import copy
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._calibration import fit_half_laplace, half_laplace_threshold
from axiswatch.indicators._fleet import (
    fleet_difference,
    indicator_allowances,
    own_pair_allowances,
    pool_fleet,
    pool_fleet_without,
)
from axiswatch.indicators._model import IndicatorModel
from axiswatch.indicators._readings import INDICATORS
from axiswatch.indicators._spreads import leave_one_out_distances, robust_spread
from tests import naive

RATE = 200.0


def _capture(
    seed: int, *, coulomb: float = 3.0, payload: float = 0.0, rate: float = RATE
) -> aw.Capture:
    """A 200 Hz axis: friction, a task-dependent payload, noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 6, 1 / rate)
    q = np.sin(np.pi * t / 2 + rng.uniform(0, 2 * np.pi)) + 0.3 * np.sin(np.pi * t)
    v = np.gradient(q, 1 / rate)
    tau = coulomb * np.sign(v) + 2.0 * v + payload * (v > 0) + rng.normal(scale=0.5, size=t.size)
    return aw.Capture(
        {"position": q, "speed": v, "torque": tau},
        {"position": rate, "speed": rate, "torque": rate},
    )


def _fitted(
    seed: int, *, task_envelope_factor: float | None = 2.0, **kwargs: float
) -> IndicatorModel:
    return IndicatorModel(task_envelope_factor=task_envelope_factor).fit(
        _capture(seed, **kwargs), [_capture(seed + k, **kwargs) for k in range(1, 6)]
    )


def test_robust_spread_matches_the_naive_twin() -> None:
    values = [*np.random.default_rng(0).normal(size=11).tolist(), 50.0, math.nan]
    assert robust_spread(values) == pytest.approx(naive.robust_spread(values), rel=1e-12)
    assert math.isnan(robust_spread([1.0, 2.0]))


def test_threshold_is_the_calibration_fit_without_a_fleet() -> None:
    model = _fitted(10)
    rows = model.calibration_rows_
    loo = []
    for k in range(1, len(rows)):
        others = rows[:k] + rows[k + 1 :]
        centre = {n: float(np.median([o[n] for o in others])) for n in model.scales_}
        z = [
            abs(rows[k][n] - centre[n]) / s
            if n.endswith("friction") or n.startswith("load")
            else max((rows[k][n] - centre[n]) / s, 0.0)
            for n, s in model.scales_.items()
        ]
        loo.append(max(z))
    assert model.threshold_ == pytest.approx(fit_half_laplace(loo).threshold(99.0))
    assert any("no task-change allowance" in note for note in model.notes_)


def test_fleet_allowance_comes_from_the_fleet_pairs() -> None:
    # Without the task envelope: these "tasks" differ in payload only, on one motion, which the
    # envelope (by design, from the motion alone) would take for the baseline's task.
    fleet = [_fitted(100 * k, payload=float(k), task_envelope_factor=None) for k in range(5)]
    prior = pool_fleet(fleet)
    assert prior.n_axes == 5
    assert prior.n_pairs == 20  # 10 pairs, both ways
    assert prior.allowance(99.0) == pytest.approx(half_laplace_threshold(prior.allowance_scale, 99))
    assert all(n == 20 for n in prior.indicator_pairs.values())
    model = fleet[0].use_fleet(prior)
    # Each indicator's allowance: the fleet's, or the axis's own pairs' where larger (fleet[0]
    # carries no payload, the end of the fleet's range: its own pairs are larger on some).
    own = own_pair_allowances(
        fleet[0].centre_, fleet[0].within_, [m.centre_ for m in fleet[1:]], prior, 99.0
    )
    fleet_allowed = prior.allowances(99.0)
    assert model.allowances_ == {n: max(fleet_allowed[n], own[n]) for n in model.within_}
    assert any(own[n] > fleet_allowed[n] for n in model.within_)
    assert model.fleet is not None
    assert model.fleet.centres == ()  # the model keeps its prior without the fleet's centres
    # A task change is scored in allowance units: 1 is an allowance, the threshold at least 1.
    assert model.threshold_ >= 1.0
    want = fit_half_laplace(
        leave_one_out_distances(
            model.calibration_rows_,
            {n: s * model.allowances_[n] for n, s in model.scales_.items()},
        )[1:]
    ).threshold(99.0)
    assert model.threshold_ == pytest.approx(max(want, 1.0), rel=1e-12)
    # Task spread enters the scale: a fleet axis with another payload is not an alarm.
    other_task = model.assess(_capture(999, payload=2.0))
    assert not other_task.alarm
    assert other_task.case == "no task envelope: fleet allowance"
    for entry in other_task.indicators.values():
        assert entry["spreads"] / entry["allowance"] <= other_task.distance + 1e-12


def test_indicator_allowances_match_the_naive_twin() -> None:
    fleet = [_fitted(100 * k, payload=float(k % 3), task_envelope_factor=None) for k in range(6)]
    prior = pool_fleet(fleet)
    got = prior.allowances(99.0)
    want = naive.indicator_allowances_naive(
        [m.centre_ for m in fleet],
        [m.within_ for m in fleet],
        prior.task_spreads,
        99.0,
        prior.allowance(99.0),
    )
    assert got == pytest.approx(want, rel=1e-12)
    # Bonferroni over the indicators with their own allowance: the family-wise rate is 1 %.
    m = sum(math.isfinite(s) for s in prior.indicator_scales.values())
    for name, scale in prior.indicator_scales.items():
        assert got[name] == pytest.approx(half_laplace_threshold(scale, 100 - 1 / m), rel=1e-12)


def test_a_fault_on_an_indicator_a_task_change_hardly_moves_is_not_hidden() -> None:
    # The payload (the fleet's "tasks", two of them in six axes) moves the forward drive load
    # and the Coulomb estimate a lot, the backward drive load not at all.
    fleet = [
        _fitted(100 * k, payload=p, task_envelope_factor=None)
        for k, p in enumerate([0.0, 0.0, 0.0, 0.0, 4.0, 4.0])
    ]
    prior = pool_fleet(fleet)
    model = fleet[0].use_fleet(prior)
    allowed = model.allowances_
    assert allowed["load_backward"] < 0.1 * allowed["coulomb_friction"]
    worn = model.assess(_capture(999, coulomb=8.0))
    assert worn.alarm
    assert worn.top == "load_backward"
    assert "x its task-change allowance" in worn.reason()
    # The one allowance of the pairs' largest shift (the rule before) would have hidden it.
    assert worn.indicators["load_backward"]["spreads"] < prior.allowance(99.0)
    assert not model.assess(_capture(998, payload=4.0)).alarm  # the other task is not


def test_an_indicator_without_its_own_allowance_takes_the_fleets_one() -> None:
    # Two of four axes log at 50 Hz and give no impulsiveness: it has no task spread.
    fleet = [_fitted(100 * k, payload=float(k), rate=200.0 if k < 2 else 50.0) for k in range(4)]
    prior = pool_fleet(fleet)
    assert "impulsiveness" not in prior.indicator_scales
    # Taken apart from the fleet's centres, the axis has the fleet's allowances only.
    model = fleet[0].use_fleet(dataclasses.replace(prior, centres=()))
    assert model.allowances_["impulsiveness"] == prior.allowance(99.0)
    assert model.allowances_["coulomb_friction"] == prior.allowances(99.0)["coulomb_friction"]
    allowed = indicator_allowances({"a": 1.0, "b": math.nan, "c": 0.0}, 99.0, 7.0)
    assert allowed == {"a": pytest.approx(half_laplace_threshold(1.0, 99.0)), "b": 7.0, "c": 7.0}


def test_fleet_prior_resists_a_faulty_minority() -> None:
    healthy = [_fitted(100 * k, payload=float(k)) for k in range(5)]
    worn = _fitted(700, coulomb=9.0)
    clean = pool_fleet(healthy).task_spreads["coulomb_friction"]
    mixed = pool_fleet([*healthy, worn]).task_spreads["coulomb_friction"]
    assert mixed < 1.5 * clean
    # The allowances rest on the median over the pairs: 5 of the 15 involve the worn axis.
    clean_allowed = pool_fleet(healthy).allowances(99.0)["coulomb_friction"]
    mixed_allowed = pool_fleet([*healthy, worn]).allowances(99.0)["coulomb_friction"]
    assert mixed_allowed < 1.5 * clean_allowed


def test_a_worn_axis_of_four_is_flagged_against_the_other_three() -> None:
    # Three healthy axes at three tasks and one worn from its first capture. Pooled with the
    # others, the worn axis is in 3 of the 6 pairs: the median pair is a worn one, and the
    # allowances it is checked against hide it.
    healthy = [_fitted(100 * k, payload=float(k)) for k in range(3)]
    worn = _fitted(700, coulomb=9.0)
    fleet = [worn, *healthy]
    prior = pool_fleet(fleet)
    # The rule before: checked against the fleet with itself included, the worn axis passes.
    before = [copy.deepcopy(m).use_fleet(prior) for m in fleet]
    assert [m.fleet_check_ for m in before] == [None, None, None, None]
    assert fleet_difference(worn.centre_, worn.within_, prior, 99.0)[0] < 1.0
    models = [
        m.use_fleet(prior, check_against=pool_fleet_without(fleet, k)) for k, m in enumerate(fleet)
    ]
    assert models[0].fleet_check_ is not None
    assert models[0].fleet_check_.startswith("this axis's baseline differs from its fleet's: ")
    assert "x its task-change allowance (already worn, or a task unlike the fleet's)" in (
        models[0].fleet_check_
    )
    assert models[0].fleet_check_.endswith("checked against the 3 other axes of its profile")
    assert [m.fleet_check_ for m in models[1:]] == [None, None, None]
    # Captures are still scored with the prior of all four: no decision on a capture changes.
    for old, new in zip(before, models, strict=True):
        assert new.fleet is not None
        assert new.fleet.task_spreads == prior.task_spreads
        assert new.threshold_ == old.threshold_
        assert new.task_change_scales_ == old.task_change_scales_


def test_a_fleet_of_three_checks_each_axis_with_itself_included() -> None:
    fleet = [_fitted(100 * k, payload=float(k)) for k in range(2)] + [_fitted(700, coulomb=9.0)]
    assert [pool_fleet_without(fleet, k) for k in range(3)] == [None, None, None]
    prior = pool_fleet(fleet)
    worn = fleet[2].use_fleet(prior, check_against=pool_fleet_without(fleet, 2))
    assert any("checked against its fleet of 3 axes, itself included" in n for n in worn.notes_)
    # The rule before, unchanged, and its limit: in 2 of the 3 pairs, the worn axis is not seen.
    assert fleet_difference(worn.centre_, worn.within_, prior, 99.0)[0] < 1.0
    assert worn.fleet_check_ is None


def test_fleet_difference_matches_the_naive_twin() -> None:
    fleet = [_fitted(100 * k, payload=float(k % 3)) for k in range(5)] + [_fitted(7, coulomb=6.0)]
    prior = pool_fleet_without(fleet, 5)
    assert prior is not None
    worn = fleet[5]
    up = {i.name for i in INDICATORS if i.sided == "up"}
    got = fleet_difference(worn.centre_, worn.within_, prior, 99.0)[0]
    fallback = prior.allowance(99.0)
    allowances = {n: prior.allowances(99.0).get(n, fallback) for n in worn.within_}
    want = naive.fleet_difference_naive(
        worn.centre_, worn.within_, prior.centre, prior.task_spreads, allowances, up
    )
    assert got == pytest.approx(want, rel=1e-12)
    assert got > 1.0


def test_an_indicator_without_a_task_spread_is_not_checked() -> None:
    # The 50 Hz axis gives no impulsiveness: the other three of a 200 Hz axis read it twice,
    # too few for a task spread, so a task change's effect on it is unknown.
    fleet = [_fitted(100 * k, payload=float(k), rate=200.0 if k < 3 else 50.0) for k in range(4)]
    axis = fleet[0]
    assert "impulsiveness" in axis.within_
    with_itself = fleet_difference(axis.centre_, axis.within_, pool_fleet(fleet), 99.0)[1]
    assert "impulsiveness" in with_itself
    others = pool_fleet_without(fleet, 0)
    assert others is not None
    assert math.isnan(others.task_spreads["impulsiveness"])
    distance, shifts = fleet_difference(axis.centre_, axis.within_, others, 99.0)
    assert "impulsiveness" not in shifts
    assert "coulomb_friction" in shifts
    fallback = others.allowance(99.0)
    allowances = {n: others.allowances(99.0).get(n, fallback) for n in axis.within_}
    up = {i.name for i in INDICATORS if i.sided == "up"}
    assert distance == pytest.approx(
        naive.fleet_difference_naive(
            axis.centre_, axis.within_, others.centre, others.task_spreads, allowances, up
        ),
        rel=1e-12,
    )


def test_the_checked_axis_must_be_in_the_fleet() -> None:
    fleet = [_fitted(100 * k) for k in range(4)]
    with pytest.raises(IndexError, match=r"'index' parameter must be in \[0, 4\).*Got 4"):
        pool_fleet_without(fleet, 4)


def test_a_fleet_check_needs_a_prior_to_score_with() -> None:
    fleet = [_fitted(100 * k) for k in range(4)]
    with pytest.raises(ValueError, match="'check_against' parameter of use_fleet needs a fleet"):
        fleet[0].use_fleet(None, check_against=pool_fleet_without(fleet, 0))


def test_fleet_needs_three_axes() -> None:
    with pytest.raises(aw.CalibrationError, match="at least 3 axes of one profile; got 2"):
        pool_fleet([_fitted(1), _fitted(50)])


def test_a_faulty_baseline_is_reported_not_trusted() -> None:
    worn_baseline = _capture(1, coulomb=9.0)
    model = IndicatorModel().fit(worn_baseline, [_capture(k) for k in range(2, 8)])
    assert model.baseline_check_ is not None
    assert "the median of all is the reference" in model.baseline_check_
    assert model.centre_["coulomb_friction"] == pytest.approx(3.0, abs=0.5)


def test_a_friction_rise_alarms_and_names_friction() -> None:
    model = _fitted(20)
    verdict = model.assess(_capture(40, coulomb=6.0))
    assert verdict.alarm
    assert verdict.top == "coulomb_friction"
    assert verdict.component == "friction"
    assert sum(v["share"] for v in verdict.indicators.values()) == pytest.approx(1.0)
    # Without a task envelope (the default) the reason names the indicator, not the case.
    plain = _fitted(20, task_envelope_factor=None).assess(_capture(40, coulomb=6.0))
    assert plain.case.startswith("no task envelope")
    assert plain.reason().startswith("coulomb_friction (friction)")


def test_unavailable_indicators_are_reported_and_others_scored() -> None:
    model = IndicatorModel().fit(
        _capture(30, rate=50.0), [_capture(30 + k, rate=50.0) for k in range(1, 6)]
    )
    verdict = model.assess(_capture(37, rate=50.0))
    assert verdict.scored
    assert verdict.unavailable["impulsiveness"] == "needs a torque rate >= 100 Hz (got 50 Hz)"
    assert "coulomb_friction" in verdict.indicators


def test_too_few_calibration_captures() -> None:
    with pytest.raises(aw.CalibrationError, match="at least 2 calibration captures"):
        IndicatorModel().fit(_capture(1), [_capture(2)])


#: Where the simulators, the studies and the numbers measured on them live.
SIMULATOR_MODULES = ("axiswatch.datasets", "axiswatch_lab")
SIMULATOR_CONSTANTS = ("MECHANICS_SCALES", "MECHANICS_TASK_CHANGE_SCALE")
#: The product default's decision path: readings, the model, its spreads and threshold, the
#: monitor's method and its decision rule.
DECISION_PATH = (
    "indicators/_signals.py",
    "indicators/_motion.py",
    "indicators/_readings.py",
    "indicators/_ringing.py",
    "indicators/_order_lines.py",
    "indicators/_spreads.py",
    "indicators/_fleet.py",
    "indicators/_assessment.py",
    "indicators/_model.py",
    "_profiles.py",
    "_calibration.py",
    "indicators/_axis.py",
    "monitor/_decision.py",
)


def _simulator_imports(source: str) -> set[str]:
    """What a module's source imports from the simulators and studies, or names of their
    constants (relative imports included)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found |= {n for n in names if n.startswith(SIMULATOR_MODULES)}
        if isinstance(node, ast.ImportFrom) and node.level > 0:
            found.add(f"relative import {node.module}")
    return found | {name for name in SIMULATOR_CONSTANTS if name in source}


def test_the_simulator_check_sees_an_import_and_a_constant() -> None:
    assert _simulator_imports("from axiswatch.datasets._robot import GEAR_RATIO\n")
    assert _simulator_imports("import axiswatch_lab._transfer\n")
    assert _simulator_imports("x = MECHANICS_SCALES[0]\n")
    assert not _simulator_imports("from axiswatch._capture import Capture\n")


def test_nothing_in_the_decision_path_comes_from_the_simulator() -> None:
    """The default method's modules import no simulator, study or constant measured on one (the
    lab, which holds the former default and its simulator scales, among them)."""
    src = Path(aw.__file__).parent
    for module in DECISION_PATH:
        source = (src / module).read_text()
        assert _simulator_imports(source) == set(), module
    # The monitor's default is this method, with no threshold floor measured in development.
    default = aw.MonitorConfig()
    assert default.method == "indicators"
    assert default.preset.task_change_scale is None
    assert default.decision_rule().floor is None


def test_leave_one_out_distances_match_the_naive_twin() -> None:
    gen = np.random.default_rng(3)
    rows = [
        {"coulomb_friction": float(gen.normal()), "impulsiveness": float(gen.normal())}
        for _ in range(7)
    ]
    rows[2]["impulsiveness"] = math.nan  # a reading one capture does not give
    scales = {"coulomb_friction": 0.7, "impulsiveness": 0.2}
    got = leave_one_out_distances(rows, scales)
    want = naive.leave_one_out_distances_naive(rows, scales, {"coulomb_friction"})
    assert got == pytest.approx(want, rel=1e-12)


def test_the_threshold_is_fitted_on_the_calibration_captures_leave_one_out_distances() -> None:
    robot = aw.datasets.draw_robot(0)
    model = IndicatorModel().fit(
        robot.capture(0, seed=0), [robot.capture(0, seed=k) for k in range(1, 6)]
    )
    assert len(model.loo_distances_) == 6
    want = fit_half_laplace(model.loo_distances_[1:]).threshold(99.0)
    assert model.threshold_ == pytest.approx(want, rel=1e-12)
    for k in range(6):
        assert model.assess_fitting(k).distance == pytest.approx(model.own_loo_distances_[k])
    with pytest.raises(IndexError, match="'index' parameter must be in"):
        model.assess_fitting(6)


def test_a_large_fleet_checks_a_baseline_with_itself_included(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Above LEAVE_SELF_OUT_MAX_AXES the leave-self-out pools (cubic in a first run) are not made:
    # the check is against the whole fleet, and the notes say so. A cut at 3 axes shows it on 4.
    from axiswatch.indicators import _axis as _indicators

    monkeypatch.setattr(_indicators, "LEAVE_SELF_OUT_MAX_AXES", 3)
    baselines = [
        _indicators.IndicatorBaseline(_fitted(100 * k, payload=float(k)), ("h",) * 6, ("p",) * 6)
        for k in range(4)
    ]
    pooled = _indicators.with_fleet(baselines)
    for baseline in pooled:
        assert baseline.model.fleet is not None
        assert baseline.model.fleet.n_axes == 4
        assert any(
            "checked against its fleet of 4 axes, itself included" in n
            for n in baseline.model.notes_
        )
    monkeypatch.setattr(_indicators, "LEAVE_SELF_OUT_MAX_AXES", 200)
    small = _indicators.with_fleet(baselines)
    assert not any("itself included" in n for b in small for n in b.model.notes_)


def test_fleet_pair_shifts_match_the_loop_twin() -> None:
    from axiswatch.indicators._fleet import fleet_pair_shifts

    rng = np.random.default_rng(7)
    centres = rng.normal(size=(9, 4)) * [1.0, 10.0, 0.1, 3.0]
    within = rng.uniform(0.1, 2.0, size=(9, 4))
    centres[[1, 4], 2] = np.nan  # an indicator two axes do not read
    within[6, 0] = np.nan  # an axis without a within-task spread for one indicator
    centres[8, :] = np.nan  # an axis that shares nothing
    task = np.array([0.5, np.nan, 0.2, 0.0])  # no task spread, and a zero one: left out
    sided = np.array([False, False, True, True])
    distances, medians, counts = fleet_pair_shifts(centres, within, task, sided)
    expected_d, expected_z = naive.fleet_pair_shifts_naive(
        centres.tolist(), within.tolist(), task.tolist(), sided.tolist()
    )
    np.testing.assert_allclose(distances, expected_d, rtol=1e-12, equal_nan=True)
    assert counts.tolist() == [len(z) for z in expected_z] == [49, 0, 30, 0]
    np.testing.assert_allclose(
        medians, [float(np.median(z)) if z else math.nan for z in expected_z], rtol=1e-12
    )
    assert np.isnan(distances[8, :]).all()  # axis 8 reads nothing
    assert np.isnan(distances[:, 8]).all()
    assert np.isnan(np.diag(distances)).all()
    # Read in the baseline's spreads: axis 6 has no within-task spread of indicator 0, so the
    # pairs with 6 as the baseline (column 6) read only indicator 2, those with 6 as the
    # capture (row 6) both.
    assert distances[0, 6] == pytest.approx(
        max((centres[0, 2] - centres[6, 2]) / math.hypot(0.2, within[6, 2]), 0.0), rel=1e-12
    )
    assert distances[6, 0] == pytest.approx(
        max(
            abs(centres[6, 0] - centres[0, 0]) / math.hypot(0.5, within[0, 0]),
            (centres[6, 2] - centres[0, 2]) / math.hypot(0.2, within[0, 2]),
        ),
        rel=1e-12,
    )


def _task_fleet(robot: aw.datasets.SimulatedRobot, n_tasks: int) -> list[IndicatorModel]:
    """One model per task of ``robot``: baseline seed 0, calibration seeds 1-5."""
    return [
        IndicatorModel().fit(
            robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)]
        )
        for t in range(n_tasks)
    ]


def test_the_fleet_prior_does_not_depend_on_the_order_of_the_axes() -> None:
    """Fails before i17a: each pair ``i < j`` was read one way, in axis ``i``'s spreads (and a
    one-sided indicator counted only ``i``'s growth), so listing the axes in another order
    changed ``allowance_scale`` and the indicators' scales (on main a3707e2 this test fails at
    the first order: ``allowance_scale`` 1.566 against 1.840 in the listed order)."""
    fleet = _task_fleet(aw.datasets.draw_robot(2), 6)
    prior = pool_fleet(fleet)
    rng = np.random.default_rng(3)
    for _ in range(5):
        order = rng.permutation(len(fleet))
        other = pool_fleet([fleet[k] for k in order])
        assert other.allowance_scale == pytest.approx(prior.allowance_scale, rel=1e-12, abs=0)
        assert other.n_pairs == prior.n_pairs == 30
        assert other.indicator_pairs == prior.indicator_pairs
        assert other.task_spreads == pytest.approx(prior.task_spreads, rel=1e-12, nan_ok=True)
        assert other.indicator_scales == pytest.approx(
            prior.indicator_scales, rel=1e-12, nan_ok=True
        )
        assert other.allowances(99.0) == pytest.approx(prior.allowances(99.0), rel=1e-12)
        # and so each axis's model, scored with it, whatever the order it was pooled in
        for k in range(len(fleet)):
            here = copy.deepcopy(fleet[k]).use_fleet(prior)
            there = copy.deepcopy(fleet[k]).use_fleet(other)
            assert there.threshold_ == pytest.approx(here.threshold_, rel=1e-12)
            assert there.allowances_ == pytest.approx(here.allowances_, rel=1e-12)


def test_pool_fleet_takes_its_scales_from_the_pairs_of_the_loop_twin() -> None:
    from axiswatch.indicators._spreads import _declared

    fleet = _task_fleet(aw.datasets.draw_robot(2), 5)
    prior = pool_fleet(fleet)
    names = [n for n, s in prior.task_spreads.items() if math.isfinite(s) and s > 0]
    distances, shifts = naive.fleet_pair_shifts_naive(
        [[m.centre_.get(n, math.nan) for n in names] for m in fleet],
        [[m.within_.get(n, math.nan) for n in names] for m in fleet],
        [prior.task_spreads[n] for n in names],
        [_declared(n).sided == "up" for n in names],
    )
    finite = [d for row in distances for d in row if d == d]
    assert prior.n_pairs == len(finite) == 20  # 10 pairs, both ways
    assert prior.allowance_scale == pytest.approx(float(np.median(finite)) / math.log(2), rel=1e-12)
    for k, n in enumerate(names):
        assert prior.indicator_pairs[n] == len(shifts[k])
        assert prior.indicator_scales[n] == pytest.approx(
            float(np.median(shifts[k])) / math.log(2), rel=1e-12
        )
