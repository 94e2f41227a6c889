"""Operating modes: declared or read from a capture, and the per-axis mode library."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from scipy.stats import norm

from axiswatch import Capture
from axiswatch._mode_declaration import ModeDeclaration, parse_mode_section
from axiswatch.datasets import draw_robot
from axiswatch.datasets._robot import Fault
from axiswatch.exceptions import CaptureError
from axiswatch.indicators._drift import cusum_limit
from axiswatch.indicators._mode_library import ModeLibrary
from axiswatch.indicators._modes import (
    PRIOR_MODE_TOLERANCE,
    SPECTRUM_BANDS,
    CaptureDescription,
    declared_mode,
    describe_capture,
    mode_differences,
)
from axiswatch.indicators._readings import Readings

SIGNATURE = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5, 3.0])


def _description(
    rng: np.random.Generator,
    *,
    signature: np.ndarray = SIGNATURE,
    friction: float = 1.0,
    impulsiveness: float = 2.0,
    spectrum_rise: float = 0.0,
    source: str = "c.csv",
) -> CaptureDescription:
    values = {
        "coulomb_friction": friction + 0.05 * rng.standard_normal(),
        "viscous_friction": 0.5 + 0.02 * rng.standard_normal(),
        "impulsiveness": impulsiveness * math.exp(0.05 * rng.standard_normal()),
    }
    spectrum = np.linspace(0.0, -3.0, SPECTRUM_BANDS) + 0.05 * rng.standard_normal(SPECTRUM_BANDS)
    spectrum[10] += spectrum_rise
    noisy = signature * (1 + 0.005 * rng.standard_normal(signature.size))
    return CaptureDescription(source, noisy, 10.0, Readings(values), spectrum)


# -- declared modes -----------------------------------------------------------------------------
def test_parse_mode_section_reads_one_source_and_payload() -> None:
    declaration = parse_mode_section({"metadata": "program", "payload_metadata": "load"})
    assert declaration == ModeDeclaration(metadata="program", payload_metadata="load")


@pytest.mark.parametrize(
    ("section", "match"),
    [
        ({"colum": "program"}, "unknown key 'colum'"),
        ({"column": "program", "metadata": "task"}, "exactly one of column, metadata"),
        ({"payload_column": "kg"}, "exactly one of column, metadata"),
        ({"column": ""}, "column must be a non-empty string"),
        ({"file_pattern": "prog("}, "file_pattern is not a regular expression"),
    ],
)
def test_parse_mode_section_rejects_bad_tables(section: dict[str, str], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        parse_mode_section(section, source="axis.toml")


def test_declared_mode_from_column_metadata_and_file_name() -> None:
    program = np.array([3.0, 3.0, 3.0, 4.0])
    capture = Capture(
        {"torque": np.zeros(4), "program": program},
        {"torque": 10.0, "program": 10.0},
        source="/data/cell2_prog7_heavy.csv",
        metadata={"task": "weld", "kg": "12"},
    )
    assert declared_mode(capture, ModeDeclaration(column="program")) == "3"
    assert declared_mode(capture, ModeDeclaration(metadata="task", payload_metadata="kg")) == (
        "weld@12"
    )
    pattern = r"prog(?P<program>\d+)_(?P<payload>[a-z]+)"
    assert declared_mode(capture, ModeDeclaration(file_pattern=pattern)) == "7@heavy"


@pytest.mark.parametrize(
    ("declaration", "match"),
    [
        (ModeDeclaration(column="program"), "mode column 'program' is missing"),
        (ModeDeclaration(metadata="task"), "metadata key 'task' is missing"),
        (ModeDeclaration(file_pattern="prog(?P<program>\\d+)"), "does not match the mode's"),
    ],
)
def test_declared_mode_names_the_capture_when_missing(
    declaration: ModeDeclaration, match: str
) -> None:
    capture = Capture({"torque": np.zeros(4)}, {"torque": 10.0}, source="/data/run.csv")
    with pytest.raises(CaptureError, match=f"/data/run.csv: .*{match}"):
        declared_mode(capture, declaration)


# -- learned modes ------------------------------------------------------------------------------
def test_payload_change_is_another_mode_and_phase_is_not() -> None:
    robot = draw_robot(3)
    heavy = robot.tasks[0].__class__(**{**robot.tasks[0].__dict__, "payload_kg": 30.0})
    other = robot.__class__(**{**robot.__dict__, "tasks": (heavy, *robot.tasks[1:])})
    first, again = (describe_capture(robot.capture(0, seed=s)) for s in (1, 2))
    loaded = describe_capture(other.capture(0, seed=3))
    same = mode_differences(again.signature, first.signature, first.torque_scale)
    changed = mode_differences(loaded.signature, first.signature, first.torque_scale)
    assert same[-1] < 0.02 < PRIOR_MODE_TOLERANCE < changed[-1]
    assert np.max(changed[:-1]) < PRIOR_MODE_TOLERANCE


def test_a_capture_that_does_not_move_is_still() -> None:
    rng = np.random.default_rng(0)
    still = _description(rng, signature=np.full(7, np.nan))
    assert ModeLibrary().update(still).state == "still"


# -- the library --------------------------------------------------------------------------------
def _learned(rng: np.random.Generator, n: int = 8, **kwargs: float) -> ModeLibrary:
    library = ModeLibrary(n_fit=5, percentile=99.0)
    for _ in range(n):
        library.update(_description(rng, **kwargs))  # type: ignore[arg-type]
    return library


def test_a_new_mode_is_learning_n_of_k_then_known() -> None:
    rng = np.random.default_rng(1)
    library = ModeLibrary(n_fit=5)
    states = [library.update(_description(rng)) for _ in range(6)]
    assert [(v.state, v.n_seen) for v in states[:5]] == [("learning", k) for k in range(1, 6)]
    assert states[5].state == "known"
    assert not any(v.alarm for v in states)


def test_a_known_mode_scores_a_fault_over_its_threshold() -> None:
    rng = np.random.default_rng(2)
    library = _learned(rng, 12)
    healthy = [library.score(_description(rng)) for _ in range(20)]
    worn = library.score(_description(rng, friction=1.6))
    lined = library.score(_description(rng, spectrum_rise=1.5))
    assert sum(v.alarm for v in healthy) <= 1
    assert worn.alarm
    assert worn.where == "coulomb_friction"
    assert lined.alarm
    assert lined.where == "spectrum"
    assert healthy[0].false_alarm_rate == pytest.approx(0.01)


def test_an_alarm_is_not_learned() -> None:
    rng = np.random.default_rng(3)
    library = _learned(rng, 8)
    before = len(library.modes_["mode0"].members)
    assert library.update(_description(rng, friction=2.0)).alarm
    assert len(library.modes_["mode0"].members) == before


def test_two_motions_are_two_modes_and_the_guard_waits_for_two() -> None:
    rng = np.random.default_rng(4)
    library = _learned(rng, 6)
    fast = SIGNATURE * [2.0, 2.0, 2.0, 1.0, 1.0, 1.0, 1.0]
    verdict = library.update(_description(rng, signature=fast, friction=3.0))
    assert (verdict.mode, verdict.state, verdict.alarm) == ("mode1", "learning", False)
    assert math.isnan(verdict.score)


def test_the_guard_alarms_on_a_new_mode_beyond_every_known_one() -> None:
    rng = np.random.default_rng(5)
    library = ModeLibrary(n_fit=5)
    slow, fast = SIGNATURE, SIGNATURE * [2.0, 2.0, 2.0, 1.0, 1.0, 1.0, 1.0]
    for signature, friction in ((slow, 1.0), (fast, 1.2)):
        for _ in range(6):
            library.update(_description(rng, signature=signature, friction=friction))
    third = SIGNATURE * [3.0, 3.0, 3.0, 1.0, 1.0, 1.0, 1.0]
    healthy = library.score(_description(rng, signature=third, friction=1.1))
    worn = library.score(_description(rng, signature=third, friction=4.0))
    assert healthy.state == worn.state == "learning"
    assert not healthy.alarm
    assert worn.alarm
    assert worn.where == "coulomb_friction"


def test_a_slow_fault_is_not_learned_away() -> None:
    rng = np.random.default_rng(6)
    library = _learned(rng, 6)
    verdicts = [library.update(_description(rng, friction=1.0 + 0.01 * k)) for k in range(30)]
    first = next(k for k, v in enumerate(verdicts) if v.alarm)
    assert verdicts[first].state == "drift"
    assert verdicts[first].score < 1.0, "each capture alone is under the threshold"
    assert library.modes_["mode0"].drifted


def test_the_threshold_grows_steadier_with_healthy_evidence() -> None:
    rng = np.random.default_rng(7)
    library = _learned(rng, 6)
    n_early = len(library.within_mode_distances()[0])
    for _ in range(20):
        library.update(_description(rng))
    assert len(library.within_mode_distances()[0]) > n_early
    assert all(math.isfinite(t) for t in library.thresholds())


def test_the_first_threshold_counts_every_tail_tested() -> None:
    # Before 30 distances pool, the readings' threshold is a Bonferroni bound over the tails:
    # two for coulomb and viscous friction (a change either way), one for impulsiveness.
    rng = np.random.default_rng(9)
    library = _learned(rng, 6)
    assert len(library.within_mode_distances()[0]) < 30
    assert library.tails() == 5
    each = (1.0 - library.percentile / 100.0) / 2.0
    assert library.thresholds()[0] == pytest.approx(norm.isf(each / 5), rel=1e-12)


def test_declared_modes_are_kept_apart() -> None:
    rng = np.random.default_rng(8)
    library = ModeLibrary(n_fit=3)
    for name in ("weld", "weld", "weld", "paint"):
        d = _description(rng)
        library.update(
            CaptureDescription(d.source, d.signature, 10.0, d.readings, d.spectrum, name)
        )
    assert sorted(library.modes_) == ["paint", "weld"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_fit": 2}, "'n_fit' parameter must be an int >= 3"),
        ({"percentile": 100.0}, "'percentile' parameter must be a float in"),
        ({"n_fit": 5, "window": 4}, "'window' parameter must be an int >= n_fit"),
        ({"drift_test": "mean"}, "'drift_test' parameter must be 'medians' or 'cusum'"),
    ],
)
def test_library_rejects_bad_parameters(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ModeLibrary(**kwargs)  # type: ignore[arg-type]


def test_a_simulated_fault_in_a_known_mode_alarms() -> None:
    robot = draw_robot(3)
    library = ModeLibrary(n_fit=5, percentile=99.0)
    for k in range(8):
        library.update(describe_capture(robot.capture(1, seed=f"fit{k}")))
    worn = describe_capture(robot.capture(1, seed="worn", fault=Fault("friction", 0.6)))
    healthy = describe_capture(robot.capture(1, seed="ok"))
    assert library.score(worn).alarm
    assert not library.score(healthy).alarm


def test_teach_turns_a_mode_change_alarm_into_a_new_mode() -> None:
    rng = np.random.default_rng(9)
    library = _learned(rng, 8)
    heavier = _description(rng, friction=2.0)
    assert library.update(heavier).alarm
    name = library.teach(heavier, "heavy")
    assert name == "heavy"
    assert library.modes_["heavy"].members == [heavier]
    assert library.match(_description(rng)) == "mode0"


def test_teach_refuses_a_capture_that_does_not_move() -> None:
    still = _description(np.random.default_rng(10), signature=np.full(7, np.nan), source="s.csv")
    with pytest.raises(ValueError, match=r"s\.csv: the axis did not move"):
        ModeLibrary().teach(still)


def test_a_known_motion_at_another_load_is_scored_in_its_mode_when_asked() -> None:
    heavier = SIGNATURE * [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.5]  # the carried load: 3 -> 4.5
    for motion_match, expected in ((False, ("mode1", "learning")), (True, ("mode0", "known"))):
        rng = np.random.default_rng(11)
        library = ModeLibrary(n_fit=5, motion_match=motion_match)
        for _ in range(8):
            library.update(_description(rng))
        loaded = _description(rng, signature=heavier, friction=1.6)
        verdict = library.score(loaded)
        assert (verdict.mode, verdict.state) == expected
    # The engineer says it is another mode: taught as a new one, which its like then match.
    assert verdict.alarm
    assert library.teach(loaded) == "mode1"
    assert library.match(_description(rng, signature=heavier)) == "mode1"


def test_a_taught_payload_keeps_its_captures_when_the_motion_is_noisy() -> None:
    # Two modes of one motion, told apart by the carried load (3.0 and 3.4 of a torque scale
    # of 10: half a tolerance). A capture at the taught load, with a motion reading off by as
    # much from both, is the taught mode's: the load decides, not the noisier reading.
    rng = np.random.default_rng(14)
    library = _learned(rng, 8)
    taught = SIGNATURE * [1.0, 1.0, 1.0, 1.0, 1.0, 0.99, 3.4 / 3.0]
    for k in range(5):
        library.teach(_description(rng, signature=taught, source=f"t{k}.csv"), mode="heavy")
    probe = taught * [1.0, 1.0, 1.0, 1.0, 1.0, 0.54 / 0.495, 1.0]
    description = CaptureDescription("p.csv", probe, 10.0, Readings({}), np.zeros(SPECTRUM_BANDS))
    assert library.match(description) == "heavy"


def test_teach_makes_an_alarm_of_a_known_mode_a_new_mode() -> None:
    rng = np.random.default_rng(12)
    library = _learned(rng, 8)
    members = list(library.modes_["mode0"].members)
    # A payload: the carried load a tenth higher, within the mode's tolerance.
    loaded = SIGNATURE * [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.1]
    heavier = [
        _description(rng, signature=loaded, friction=2.0, source=f"h{k}.csv") for k in range(2)
    ]
    assert library.score(heavier[0]).alarm
    assert [library.teach(d) for d in heavier] == ["mode1", "mode1"]
    assert library.modes_["mode0"].members == members
    assert library.score(_description(rng, signature=loaded, friction=2.0)).mode == "mode1"


def test_a_false_alarm_joins_its_mode_and_restarts_a_drifted_one() -> None:
    rng = np.random.default_rng(13)
    library = _learned(rng, 6)
    verdicts = [library.update(_description(rng, friction=1.0 + 0.01 * k)) for k in range(30)]
    assert verdicts[-1].state == "drift"
    level = _description(rng, friction=1.3, source="level.csv")
    assert library.score(level).alarm
    assert library.accept(level) == "mode0"
    mode = library.modes_["mode0"]
    assert not mode.drifted
    assert mode.members[-1] is level
    assert len(mode.members) == library.n_fit + 1
    # The engineer's new level is the mode's normal: its like is healthy.
    assert not library.score(_description(rng, friction=1.3)).alarm


def test_the_cusum_drift_test_finds_a_slow_fault_and_restarts_on_a_false_alarm() -> None:
    rng = np.random.default_rng(13)
    library = ModeLibrary(n_fit=5, drift_test="cusum")
    for _ in range(6):
        library.update(_description(rng))
    verdicts = [library.update(_description(rng, friction=1.0 + 0.01 * k)) for k in range(30)]
    first = next(k for k, v in enumerate(verdicts) if v.alarm)
    assert verdicts[first].state == "drift"
    assert verdicts[first].score < 1.0, "each capture alone is under the threshold"
    level = _description(rng, friction=1.3, source="level.csv")
    assert library.accept(level) == "mode0"
    mode = library.modes_["mode0"]
    assert not mode.drifted
    # The drift test starts again from the captures kept.
    assert mode.drift is not None
    assert max(c.total for c in mode.drift.values()) < cusum_limit(1000.0)
    assert not library.score(_description(rng, friction=1.3)).alarm


def test_a_stored_library_takes_up_the_cusum_drift_test_from_its_captures() -> None:
    rng = np.random.default_rng(15)
    library = _learned(rng, 8)
    assert library.modes_["mode0"].drift is None  # the medians' test keeps no state
    del library.__dict__["drift_test"]  # as pickled before the drift test was an option
    stored = pickle.loads(pickle.dumps(library))
    assert stored.drift_test == "medians"
    stored.drift_test = "cusum"
    assert stored.update(_description(rng)).state == "known"
    drift = stored.modes_["mode0"].drift
    assert drift is not None
    assert sorted(drift) == ["coulomb_friction", "impulsiveness", "viscous_friction"]
    assert len(drift["coulomb_friction"].reference) == 9


def test_teaching_a_declared_mode_not_yet_seen_keeps_its_name() -> None:
    rng = np.random.default_rng(14)
    library = _learned(rng, 6)
    d = _description(rng, friction=2.0)
    paint = CaptureDescription(d.source, d.signature, 10.0, d.readings, d.spectrum, "paint")
    assert library.teach(paint) == "paint"
    assert library.accept(paint) == "paint"
