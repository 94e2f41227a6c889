"""The store contract: what every StoreBackend must do, run against SQLiteStore and a test double.

A new backend joins ``BACKENDS`` and passes this file. The in-memory double (tests/memory_store.py)
passing the writer's tests, and the monitor reaching the same results on it, shows that the
monitor needs nothing of a store but its writer's protocol. The last test keeps every SQL statement in the store's
SQLite modules.
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from collections.abc import Callable, Iterator
from datetime import datetime
from pathlib import Path

import pandas as pd
import pytest

import axiswatch
from axiswatch._calibration import alarm_threshold
from axiswatch.exceptions import StoreError
from axiswatch.monitor import MonitorConfig, SQLiteStore, StoreBackend, fleet_results
from axiswatch.monitor._decision import AxisHistory, Decision
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.store import (
    AddedBaseline,
    BaselineCheck,
    ChangedFile,
    NewBaseline,
    NewScore,
    Rejection,
)
from tests.memory_store import MemoryStore

BACKENDS: dict[str, Callable[[Path], StoreBackend]] = {
    "sqlite": lambda folder: SQLiteStore(folder / "s.db"),
    "memory": lambda folder: MemoryStore(),  # type: ignore[dict-item]  # a StoreWriter
}
#: A test of the people's side too (tables, acknowledgements: StoreReader, StoreOperator): run on
#: the backends that implement the whole StoreBackend, not on the in-memory StoreWriter.
WHOLE = pytest.mark.parametrize("store", ["sqlite"], indirect=True)


@pytest.fixture(params=sorted(BACKENDS))
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[StoreBackend]:
    opened = BACKENDS[request.param](tmp_path)
    yield opened
    opened.close()


def day(n: int) -> datetime:
    return datetime(2026, 3, n)


def add(store: StoreBackend, baseline: NewBaseline) -> int:
    """The id of a baseline this call adds."""
    added = store.add_baseline(baseline)
    assert added is not None
    assert added.added
    return added.id


def new_baseline(
    capture: str = "2026-03-01.csv", *, epoch: int = 1, axis: str = "a1", method: str = "pca"
) -> NewBaseline:
    return NewBaseline(
        robot="r1", axis=axis, method=method, epoch=epoch, capture=capture,
        captured_at=datetime.fromisoformat(capture[:10]), path=f"r1/{axis}/{capture}",
        file_hash="h-" + capture, features_hash="f", params='{"p": 1}', library_version="0",
        file_size=10, file_mtime_ns=20, reason="baseline", details={"rates_hz": {"speed": 2.0}},
    )  # fmt: skip


def new_score(
    baseline_id: int, n: int, distance: float = 1.0, *, axis: str = "a1", method: str = "pca"
) -> NewScore:
    capture = f"2026-03-{n:02d}.csv"
    return NewScore(
        baseline_id=baseline_id, robot="r1", axis=axis, method=method, capture=capture,
        captured_at=day(n), path=f"r1/{axis}/{capture}", file_hash=f"h-{capture}",
        file_size=n, file_mtime_ns=100 + n, distance=distance, details={"n_rows": 3},
    )  # fmt: skip


def fixed(decision: Decision, seen: list[AxisHistory] | None = None) -> Callable[..., Decision]:
    """A decide that records the history it gets and returns ``decision``."""

    def decide(history: AxisHistory) -> Decision:
        if seen is not None:
            seen.append(history)
        return decision

    return decide


CALIBRATING = Decision("calibration", None, False, False, "calibrating")


def test_a_baseline_is_added_once_per_epoch(store: StoreBackend) -> None:
    added = store.add_baseline(new_baseline())
    assert added is not None
    assert added.added
    first = added.id
    # Another process, same choice: its id, not added by this call (before: only the id, so
    # that two runs on one store both counted the baseline as new).
    assert store.add_baseline(new_baseline()) == AddedBaseline(first, added=False)
    assert store.add_baseline(new_baseline("2026-03-02.csv")) is None  # a different choice
    baseline = store.baseline(first)
    assert (baseline.robot, baseline.axis, baseline.method, baseline.epoch) == (
        "r1",
        "a1",
        "pca",
        1,
    )
    assert baseline.captured_at == day(1)
    assert (baseline.threshold, baseline.fit, baseline.retired) == (None, None, False)
    assert store.scored_captures(first) == {"2026-03-01.csv"}
    table = store.score_table()
    assert table[["capture", "role", "reason"]].values.tolist() == [
        ["2026-03-01.csv", "baseline", "baseline"]
    ]
    assert json.loads(table.details.iloc[0]) == {"rates_hz": {"speed": 2.0}}
    assert store.latest_baseline("r1", "a1", "pca") == baseline
    assert store.latest_baseline("r1", "a1", "lra") is None


def test_an_unknown_baseline_is_an_error(store: StoreBackend) -> None:
    with pytest.raises(StoreError, match=r"has no baseline with id 7"):
        store.baseline(7)


def test_decide_gets_the_calibration_history_and_the_fit_is_given_to_every_capture(
    store: StoreBackend,
) -> None:
    baseline_id = add(store, new_baseline())
    seen: list[AxisHistory] = []
    for n, distance in ((2, 1.0), (3, 2.0)):
        assert store.record_score(
            new_score(baseline_id, n, distance), fixed(CALIBRATING, seen), window=1
        )
    assert seen == [AxisHistory(), AxisHistory(calibration_distances=(1.0,))]
    threshold = alarm_threshold([1.0, 2.0, 3.0])
    completing = Decision("calibration", threshold.value, False, False, "set", calibrated=threshold)
    assert store.record_score(new_score(baseline_id, 4, 3.0), fixed(completing, seen), window=1)
    assert seen[-1].calibration_distances == (1.0, 2.0)
    baseline = store.baseline(baseline_id)
    assert (baseline.threshold, baseline.fit) == (threshold.value, threshold.fit)
    table = store.score_table()
    assert table.threshold.tolist()[1:] == [threshold.value] * 3
    assert table.role.tolist() == ["baseline"] + ["calibration"] * 3
    assert table.distance.tolist()[1:] == [1.0, 2.0, 3.0]


def test_decide_gets_the_recent_monitored_captures_oldest_first(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    threshold = alarm_threshold([1.0, 2.0])
    store.record_score(
        new_score(baseline_id, 2),
        fixed(Decision("calibration", threshold.value, False, False, "", calibrated=threshold)),
        window=2,
    )
    seen: list[AxisHistory] = []
    flags = [(True, True), (False, True), (False, False)]
    for n, (over, alarm) in enumerate(flags, start=3):
        decision = Decision("monitor", threshold.value, over, alarm, "", details={"pvalue": 0.5})
        store.record_score(new_score(baseline_id, n), fixed(decision, seen), window=2)
    store.record_score(new_score(baseline_id, 6), fixed(CALIBRATING, seen), window=2)
    assert [h.recent for h in seen] == [(), (flags[0],), tuple(flags[:2]), tuple(flags[1:])]
    assert all(h.threshold == threshold.value and h.fit == threshold.fit for h in seen)
    details = json.loads(store.score_table().details.iloc[-2])
    assert details == {"n_rows": 3, "pvalue": 0.5}


def test_a_capture_is_written_once_and_never_under_a_retired_baseline(
    store: StoreBackend,
) -> None:
    baseline_id = add(store, new_baseline())
    assert store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING), window=1)
    calls: list[AxisHistory] = []
    assert not store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING, calls), window=1)
    store.retire_baselines("r1", "a1")
    assert not store.record_score(new_score(baseline_id, 3), fixed(CALIBRATING, calls), window=1)
    assert calls == []
    assert len(store.score_table()) == 2


def test_a_failed_decision_writes_nothing(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())

    def failing(history: AxisHistory) -> Decision:
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        store.record_score(new_score(baseline_id, 2), failing, window=1)
    assert store.scored_captures(baseline_id) == {"2026-03-01.csv"}
    assert store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING), window=1)


def test_a_batch_keeps_all_its_writes_or_none(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    with store.batch():
        assert store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING), window=1)
        # A write that fails inside a batch changes nothing, and the batch goes on.
        with pytest.raises(RuntimeError, match="boom"):
            store.record_score(new_score(baseline_id, 3), _boom, window=1)
        assert store.record_score(new_score(baseline_id, 4), fixed(CALIBRATING), window=1)
        with store.batch():  # a nested batch is part of the outer one
            assert store.record_score(new_score(baseline_id, 5), fixed(CALIBRATING), window=1)
        # The batch's own writes are seen inside it (a decision builds on them).
        assert store.scored_captures(baseline_id) == {
            "2026-03-01.csv", "2026-03-02.csv", "2026-03-04.csv", "2026-03-05.csv"
        }  # fmt: skip
    assert store.scored_captures(baseline_id) == {
        "2026-03-01.csv", "2026-03-02.csv", "2026-03-04.csv", "2026-03-05.csv"
    }  # fmt: skip

    def stopped_in_a_batch() -> None:
        with store.batch():
            assert store.record_score(new_score(baseline_id, 6), fixed(CALIBRATING), window=1)
            store.reject_capture(
                Rejection("r1", "a1", "pca", "2026-03-07.csv", "r1/a1/2026-03-07.csv", "h7", "x")
            )
            raise KeyboardInterrupt  # the run stopped while the batch was open

    with pytest.raises(KeyboardInterrupt):
        stopped_in_a_batch()
    assert "2026-03-06.csv" not in store.scored_captures(baseline_id)
    assert store.rejections("pca") == []
    # Nothing is left half open: the next write commits on its own.
    assert store.record_score(new_score(baseline_id, 6), fixed(CALIBRATING), window=1)
    assert "2026-03-06.csv" in store.scored_captures(baseline_id)


def test_a_mode_library_is_kept_per_baseline_and_with_its_batch(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    assert store.mode_library(baseline_id) is None
    store.save_mode_library(baseline_id, b"first")
    store.save_mode_library(baseline_id, b"second")  # replaced, not added
    assert store.mode_library(baseline_id) == b"second"

    def stopped_in_a_batch() -> None:
        with store.batch():
            assert store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING), window=1)
            store.save_mode_library(baseline_id, b"learned from capture 2")
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        stopped_in_a_batch()
    # The library learns only with the score it learned from.
    assert store.mode_library(baseline_id) == b"second"


def _boom(history: AxisHistory) -> Decision:
    raise RuntimeError("boom")


@WHOLE
def test_alarmed_captures_and_axes_in_alarm(store: StoreBackend) -> None:
    old = add(store, new_baseline())
    threshold = alarm_threshold([1.0, 2.0])
    store.record_score(
        new_score(old, 2),
        fixed(Decision("calibration", 1.0, False, False, "", calibrated=threshold)),
        window=1,
    )
    store.record_score(new_score(old, 3), fixed(Decision("monitor", 1.0, True, True, "")), window=1)
    assert store.alarmed_captures("pca") == {("r1", "a1", "2026-03-03.csv")}
    assert store.alarmed_captures("lra") == set()
    assert store.axes_in_alarm("pca") == [("r1", "a1")]
    summary = store.summary_table()
    assert summary[["scored", "over", "alarms", "last_capture"]].values.tolist() == [
        [2, 1, 1, "2026-03-03.csv"]
    ]
    assert bool(summary.last_alarm.iloc[0])
    store.retire_baselines("r1", "a1", from_capture="2026-03-02.csv")
    assert store.axes_in_alarm("pca") == []
    assert store.summary_table().empty
    new = add(store, new_baseline("2026-03-02.csv", epoch=2))
    seen: list[AxisHistory] = []
    store.record_score(new_score(new, 3), fixed(CALIBRATING, seen), window=1)
    store.record_score(new_score(new, 4), fixed(CALIBRATING, seen), window=1)
    assert [h.alarmed_before for h in seen] == [True, False]
    assert store.latest_baseline("r1", "a1", "pca") == store.baseline(new)


def test_retiring_a_baseline(store: StoreBackend) -> None:
    for method in ("pca", "lra"):
        add(store, new_baseline(method=method))
    add(store, new_baseline(axis="a2"))
    with pytest.raises(
        StoreError,
        match=r"robot 'r1' axis 'a9' method 'pca' has no active baseline in store '.*'; axes "
        r"with one: r1/a1 \(lra\), r1/a1 \(pca\), r1/a2 \(pca\)\.",
    ):
        store.retire_baselines("r1", "a9", method="pca")
    assert store.retire_baselines("r1", "a1", from_capture="2026-03-05.csv") == ["lra", "pca"]
    for method in ("pca", "lra"):
        latest = store.latest_baseline("r1", "a1", method)
        assert latest is not None
        assert latest.retired
        assert store.requested_baseline("r1", "a1", method, 1) == "2026-03-05.csv"
    assert store.requested_baseline("r1", "a1", "pca", 2) is None
    assert store.retire_baselines("r1", "a2") == ["pca"]
    assert store.requested_baseline("r1", "a2", "pca", 1) is None
    with pytest.raises(StoreError, match=r"axes with one: none\."):
        store.retire_baselines("r1", "a1")


def test_an_alarmed_capture_cannot_be_the_next_baseline(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    store.record_score(
        new_score(baseline_id, 2), fixed(Decision("monitor", 1.0, True, True, "")), window=1
    )
    with pytest.raises(StoreError, match=r"'2026-03-02.csv' .* raised an alarm \(pca\)"):
        store.retire_baselines("r1", "a1", from_capture="2026-03-02.csv")
    assert not store.baseline(baseline_id).retired  # nothing was retired


def test_scored_files_and_times(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    assert store.last_captured_at("r1", "a1", "pca") == day(1)
    store.record_score(new_score(baseline_id, 3), fixed(CALIBRATING), window=1)
    assert store.last_captured_at("r1", "a1", "pca") == day(3)
    assert store.last_captured_at("r1", "a1", "lra") is None
    files = store.scored_files()
    assert sorted(files) == ["r1/a1/2026-03-01.csv", "r1/a1/2026-03-03.csv"]
    scored = files["r1/a1/2026-03-03.csv"]
    assert (scored.file_hash, scored.file_size, scored.file_mtime_ns) == (
        "h-2026-03-03.csv",
        3,
        103,
    )
    assert store.scored_contents("pca") == {(p, f.file_hash) for p, f in files.items()}
    assert store.scored_contents("lra") == set()


@WHOLE
def test_rejections_are_recorded_once_per_content(store: StoreBackend) -> None:
    def rejection(path: str, digest: str, method: str = "pca") -> Rejection:
        return Rejection("r1", "a1", method, path.rsplit("/", 1)[-1], path, digest, f"{path}: bad")

    assert store.reject_capture(rejection("r1/a1/2026-03-09.csv", "x"))
    assert not store.reject_capture(rejection("r1/a1/2026-03-09.csv", "x"))
    assert store.reject_capture(rejection("r1/a1/2026-03-09.csv", "y"))  # repaired, bad again
    assert store.reject_capture(rejection("r1/a1/2026-03-02.csv", "x"))
    assert store.reject_capture(rejection("r1/a1/2026-03-02.csv", "x", "lra"))
    assert [(r.path, r.file_hash) for r in store.rejections("pca")] == [
        ("r1/a1/2026-03-09.csv", "x"),
        ("r1/a1/2026-03-09.csv", "y"),
        ("r1/a1/2026-03-02.csv", "x"),
    ]
    table = store.rejection_table()
    assert list(table.columns) == [
        "robot", "axis", "capture", "method", "path", "error", "rejected_at", "acknowledged_at",
        "removed_at",
    ]  # fmt: skip
    assert table[["path", "method"]].values.tolist() == [
        ["r1/a1/2026-03-02.csv", "lra"],
        ["r1/a1/2026-03-02.csv", "pca"],
        ["r1/a1/2026-03-09.csv", "pca"],
        ["r1/a1/2026-03-09.csv", "pca"],
    ]
    assert table.acknowledged_at.isna().all()
    # What the report reads to tell an acknowledged rejection from a new one.
    assert store.acknowledge_problems(["r1/a1/2026-03-02.csv"], "2026-03-10T08:00:00", "lra") == 1
    seen = store.rejection_table()
    assert seen.acknowledged_at.iloc[0] == "2026-03-10T08:00:00"
    assert seen.acknowledged_at.notna().tolist() == [True, False, False, False]


@WHOLE
def test_an_acknowledged_rejection_is_news_again_only_when_its_reason_key_changes(
    store: StoreBackend,
) -> None:
    """A misnamed folder's line carries its file count; its acknowledgement is of the reason
    without it (before: a new file in the folder changed the line and cleared the
    acknowledgement)."""

    def folder(error: str, key: str | None) -> Rejection:
        return Rejection(
            "r 1", "", "pca", "", "r 1/", "", error, "layout", transient=True, reason_key=key
        )

    key = "r 1/: robot folder name 'r 1' is not an identifier"
    store.reject_capture(folder(f"{key}; its 5 capture file(s) are not scored", key))
    assert store.acknowledge_problems(["r 1/"], "2026-03-02T00:00:00") == 1
    store.reject_capture(folder(f"{key}; its 6 capture file(s) are not scored", key))
    (kept,) = store.rejections("pca")
    assert kept.error == f"{key}; its 6 capture file(s) are not scored"  # the count as it is now
    assert kept.acknowledged_at is not None
    store.reject_capture(folder("r 1/: another reason", "r 1/: another reason"))
    assert store.rejections("pca")[0].acknowledged_at is None  # news again
    plain = Rejection("r1", "a1", "pca", "c.csv", "r1/a1/c.csv", "x", "r1/a1/c.csv: bad")
    store.reject_capture(plain)
    assert store.acknowledge_problems(["r1/a1/c.csv"], "2026-03-02T00:00:00") == 1
    store.reject_capture(dataclasses.replace(plain, error="r1/a1/c.csv: worse"))
    assert store.rejections("pca")[1].acknowledged_at is None  # no key: the whole line


def test_a_rejection_under_a_baseline_needs_it_active_and_the_capture_unscored(
    store: StoreBackend,
) -> None:
    baseline_id = add(store, new_baseline())
    store.record_score(new_score(baseline_id, 2), fixed(CALIBRATING), window=1)
    scored = Rejection("r1", "a1", "pca", "2026-03-02.csv", "r1/a1/2026-03-02.csv", "z", "bad")
    assert not store.reject_capture(scored, baseline_id=baseline_id)
    fresh = Rejection("r1", "a1", "pca", "2026-03-03.csv", "r1/a1/2026-03-03.csv", "z", "bad")
    store.retire_baselines("r1", "a1")
    assert not store.reject_capture(fresh, baseline_id=baseline_id)
    assert store.rejections("pca") == []
    assert store.reject_capture(fresh)


@WHOLE
def test_alarms_are_acknowledged_until_raised_again(store: StoreBackend) -> None:
    baseline_id = add(store, new_baseline())
    threshold = alarm_threshold([1.0, 2.0])
    store.record_score(
        new_score(baseline_id, 2),
        fixed(Decision("calibration", threshold.value, False, False, "", calibrated=threshold)),
        window=1,
    )
    summary = store.summary_table()
    assert summary.threshold_origin.tolist() == [threshold.describe()]
    assert summary[["alarm_since", "acknowledged_by"]].values.tolist() == [[None, None]]
    with pytest.raises(StoreError, match="is not in alarm"):
        store.acknowledge("r1", "a1", by="ana", note="seen")
    with pytest.raises(StoreError, match="no active baseline"):
        store.acknowledge("r1", "a9", by="ana", note="seen")
    with pytest.raises(ValueError, match="'by'"):
        store.acknowledge("r1", "a1", by=" ", note="seen")
    alarmed = Decision("monitor", threshold.value, True, True, "")
    store.record_score(new_score(baseline_id, 3, 50.0), fixed(alarmed), window=1)
    store.record_score(new_score(baseline_id, 4, 50.0), fixed(alarmed), window=1)
    [alarm] = store.alarms()
    assert (alarm.robot, alarm.axis, alarm.method, alarm.raised_capture) == (
        "r1", "a1", "pca", "2026-03-03.csv",
    )  # fmt: skip
    assert alarm.raised_at.startswith("2026-03-03")
    assert not alarm.acknowledged
    assert store.alarms("lra") == []
    assert store.acknowledge("r1", "a1", by="ana", note="gearbox noisy") == ["pca"]
    [alarm] = store.alarms("pca")
    assert (alarm.acknowledged_by, alarm.note) == ("ana", "gearbox noisy")
    assert store.summary_table()[["alarm_since", "acknowledged_by"]].values.tolist() == [
        ["2026-03-03.csv", "ana"]
    ]
    # Cleared and raised again: a new alarm, not acknowledged.
    store.record_score(
        new_score(baseline_id, 5), fixed(Decision("monitor", 1.0, False, False, "")), window=1
    )
    assert store.alarms() == []
    store.record_score(new_score(baseline_id, 6, 50.0), fixed(alarmed), window=1)
    [alarm] = store.alarms()
    assert (alarm.raised_capture, alarm.acknowledged) == ("2026-03-06.csv", False)
    # A re-baseline after maintenance is recorded (naming the alarm it ends).
    store.retire_baselines("r1", "a1")
    assert store.acknowledge("r1", "a1", by="bo", note="replaced", rebaseline=True) == ["pca"]
    assert store.alarms() == []
    table = store.acknowledgements()
    assert list(table.columns) == [
        "robot", "axis", "method", "capture", "rebaseline", "acknowledged_by", "note",
        "acknowledged_at", "verdict",
    ]  # fmt: skip
    assert table[["capture", "rebaseline", "acknowledged_by"]].values.tolist() == [
        ["2026-03-03.csv", False, "ana"],
        ["2026-03-06.csv", True, "bo"],
    ]
    assert table.verdict.isna().all()
    assert store.acknowledgements(robot="r2").empty
    requests = store.rebaseline_requests()
    assert list(requests.columns) == [
        "robot", "axis", "method", "retired_epoch", "from_capture", "requested_at",
    ]  # fmt: skip
    assert requests[["robot", "axis", "method", "retired_epoch"]].values.tolist() == [
        ["r1", "a1", "pca", 1]
    ]


@WHOLE
def test_an_acknowledgement_keeps_the_engineers_verdict(store: StoreBackend) -> None:
    """The verdict given with an acknowledgement is kept with it and on the alarm it names."""
    baseline_id = add(store, new_baseline())
    threshold = alarm_threshold([1.0, 2.0])
    store.record_score(
        new_score(baseline_id, 2),
        fixed(Decision("calibration", threshold.value, False, False, "", calibrated=threshold)),
        window=1,
    )
    alarmed = Decision("monitor", threshold.value, True, True, "")
    store.record_score(new_score(baseline_id, 3, 50.0), fixed(alarmed), window=1)
    with pytest.raises(ValueError, match="'verdict' parameter must be one of fault-confirmed"):
        store.acknowledge("r1", "a1", by="ana", note="x", verdict="fault confirmed")
    assert store.acknowledgements().empty  # a refused verdict records nothing
    store.acknowledge("r1", "a1", by="ana", note="new gripper", verdict="task-changed")
    store.acknowledge("r1", "a1", by="bo", note="friction up", verdict="fault-confirmed")
    [alarm] = store.alarms()
    assert (alarm.acknowledged_by, alarm.verdict) == ("bo", "fault-confirmed")
    assert store.acknowledgements().verdict.tolist() == ["task-changed", "fault-confirmed"]


@WHOLE
def test_a_confirmed_fault_stays_in_alarm_until_rebaselined(store: StoreBackend) -> None:
    """A fault the engineer confirmed is not cleared by clean captures after it (before: the
    axis read OK again); a false alarm is, and a re-baseline ends the confirmed one."""
    threshold = alarm_threshold([1.0, 2.0])
    calibrated = Decision("calibration", threshold.value, False, False, "", calibrated=threshold)
    alarmed = Decision("monitor", threshold.value, True, True, "")
    clean = Decision("monitor", threshold.value, False, False, "")
    for axis, verdict in (("a1", "fault-confirmed"), ("a2", "false-alarm")):
        baseline_id = add(store, new_baseline(axis=axis))
        store.record_score(new_score(baseline_id, 2, axis=axis), fixed(calibrated), window=1)
        store.record_score(new_score(baseline_id, 3, 50.0, axis=axis), fixed(alarmed), window=1)
        store.acknowledge("r1", axis, by="bo", note="looked", verdict=verdict)
        for n in (4, 5):
            store.record_score(new_score(baseline_id, n, 0.5, axis=axis), fixed(clean), window=1)
    [alarm] = store.alarms()
    assert (alarm.axis, alarm.raised_capture, alarm.verdict) == (
        "a1",
        "2026-03-03.csv",
        "fault-confirmed",
    )
    store.retire_baselines("r1", "a1")
    assert store.alarms() == []


@WHOLE
def test_baseline_checks_last_until_acknowledged_or_retired(store: StoreBackend) -> None:
    """A baseline's checks are stored with it (one transaction) and stay until someone
    acknowledges them by the baseline's path or the axis is re-baselined (before: the monitor
    reported them once, from the memory of the run that fitted the baseline)."""
    faulty = "the baseline capture disagrees with the 5 calibration captures after it"
    checked = dataclasses.replace(new_baseline(method="indicators"), checks={"baseline": faulty})
    first = add(store, checked)
    assert store.add_baseline(checked) == AddedBaseline(first, added=False)  # not twice
    add(store, new_baseline(axis="a2", method="indicators"))  # no check
    path = "r1/a1/2026-03-01.csv"

    def listed(method: str | None = "indicators") -> list[tuple[str, str, str | None]]:
        return [(c.kind, c.note, c.acknowledged_at) for c in store.baseline_checks(method)]

    (stored,) = store.baseline_checks("indicators")
    assert stored == BaselineCheck(
        first, "r1", "a1", "indicators", path, "baseline", faulty, stored.detected_at
    )
    assert store.baseline_checks("pca") == []
    store.record_baseline_check(first, "fleet", "differs from its fleet's")
    store.record_baseline_check(first, "fleet", "differs from its fleet's")  # the same again
    assert (
        listed()
        == listed(None)
        == [
            ("baseline", faulty, None),
            ("fleet", "differs from its fleet's", None),
        ]
    )
    table = store.problem_table("indicators")
    assert table[["kind", "method", "path", "error"]].values.tolist() == [
        ["baseline check", "indicators", path, faulty],
        ["baseline check", "indicators", path, "differs from its fleet's"],
    ]
    assert store.problem_table("pca").empty
    assert store.acknowledge_problems([path], "2026-03-09T00:00:00", "pca") == 0
    assert store.acknowledge_problems([path], "2026-03-09T00:00:00") == 2
    assert store.acknowledge_problems([path], "2026-03-10T00:00:00") == 0  # seen already
    assert listed() == [
        ("baseline", faulty, "2026-03-09T00:00:00"),
        ("fleet", "differs from its fleet's", "2026-03-09T00:00:00"),
    ]
    assert store.problem_table().acknowledged_at.tolist() == ["2026-03-09T00:00:00"] * 2
    store.record_baseline_check(first, "fleet", "differs from its fleet's")  # kept as seen
    assert listed()[1][2] == "2026-03-09T00:00:00"
    store.record_baseline_check(first, "fleet", "differs more from its fleet's")  # news again
    assert listed()[1:] == [("fleet", "differs more from its fleet's", None)]
    assert listed()[0][2] == "2026-03-09T00:00:00"
    store.retire_baselines("r1", "a1")
    assert listed() == []
    assert store.problem_table().empty
    assert store.acknowledge_problems([], "2026-03-11T00:00:00") == 0


@WHOLE
def test_changed_files_are_recorded_once(store: StoreBackend) -> None:
    change = ChangedFile("r1", "a1", "2026-03-02.csv", "r1/a1/2026-03-02.csv", "old", "new")
    store.record_changed_file(change)
    store.record_changed_file(change)
    store.record_changed_file(
        ChangedFile("r1", "a1", "2026-03-01.csv", "r1/a1/2026-03-01.csv", "o", "n")
    )
    table = store.changed_file_table()
    assert list(table.columns) == ["robot", "axis", "path", "detected_at", "acknowledged_at"]
    assert table.path.tolist() == ["r1/a1/2026-03-01.csv", "r1/a1/2026-03-02.csv"]
    assert table.acknowledged_at.isna().all()
    # What the report reads to tell an acknowledged change from a new one.
    assert store.acknowledge_problems(["r1/a1/2026-03-02.csv"], "2026-03-10T08:00:00") == 1
    seen = store.changed_file_table()
    assert seen.acknowledged_at.notna().tolist() == [False, True]
    assert seen.acknowledged_at.iloc[1] == "2026-03-10T08:00:00"


def test_the_monitor_reaches_the_same_results_on_any_backend(
    small_fleet: Path, tmp_path: Path
) -> None:
    """The driver needs nothing but the protocol: on the in-memory double it writes what it
    writes to SQLite, re-baselining included."""
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    config = MonitorConfig(method="pca", calibration_size=3)
    results = []
    for name, make in sorted(BACKENDS.items()):
        (tmp_path / name).mkdir()
        store = make(tmp_path / name)
        first = monitor_fleet(fleet, store, config)
        store.retire_baselines("robot01", "axis1", from_capture="2026-03-04.parquet")
        second = monitor_fleet(fleet, store, config)
        results.append((first, second, fleet_results(store)))
        store.close()
    (first_a, second_a, table_a), (first_b, second_b, table_b) = results
    assert first_a == first_b
    # The SQLite store keeps the times of finished axis folders: its second run lists only the
    # re-baselined axis's folder; the double keeps nothing between runs and lists both.
    assert (second_a.n_files, second_a.unchanged_folders) == (18, 0)
    assert (second_b.n_files, second_b.unchanged_folders) == (9, 1)
    no_counts = {"n_files": 0, "unchanged_folders": 0}
    assert dataclasses.replace(second_a, **no_counts) == dataclasses.replace(second_b, **no_counts)
    assert second_a.new_baselines == 1
    pd.testing.assert_frame_equal(table_a, table_b)
    assert (table_a.epoch == 2).sum() == 6  # baseline 03-04, three calibrating, two monitored


SQL = re.compile(
    r"\b(SELECT\s+\S.*\bFROM|INSERT\s+(OR\s+\w+\s+)?INTO|UPDATE\s+\w+\s+SET|DELETE\s+FROM|"
    r"CREATE\s+(TABLE|INDEX)|PRAGMA\s+\w+|BEGIN\s+IMMEDIATE)\b|\bsqlite3\b",
    re.IGNORECASE,
)


def test_no_sql_outside_the_store_sqlite_modules() -> None:
    source = Path(axiswatch.__file__).parent.parent
    store = source / "axiswatch" / "monitor" / "store"
    names = ("sqlite.py", "sqlite_tables.py", "sqlite_retention.py", "upgrades.py")
    sql_modules = {store / name for name in names}
    offenders = [
        f"{path.relative_to(source)}:{number}: {line.strip()}"
        for path in sorted(source.rglob("*.py"))
        if path not in sql_modules
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
        if SQL.search(line)
    ]
    assert offenders == []
    for module in sql_modules:  # the pattern finds their SQL
        assert SQL.search(module.read_text(encoding="utf-8")), module
