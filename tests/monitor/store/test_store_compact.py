"""Retention: ``compact`` thins old scores, keeps what runs and people need, and monitoring
goes on as before (no capture scored twice, alarms and acknowledgements intact)."""

from __future__ import annotations

import os
import shutil
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from typer.testing import CliRunner

from axiswatch.cli import app
from axiswatch.exceptions import StoreError
from axiswatch.monitor import _monitor, _planning
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.store import Store
from tests.conftest import settle
from tests.monitor.test_monitor import faulty_copy

runner = CliRunner()
PCA = MonitorConfig(method="pca")
KEEP, EVERY, RECENT = timedelta(days=2), timedelta(days=3), 2


@pytest.fixture(scope="module")
def monitored(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """1 robot x 2 axes x 16 days; robot01/axis1 in alarm on day 10 only, acknowledged."""
    from axiswatch.datasets import simulate_fleet

    root = tmp_path_factory.mktemp("compact")
    fleet = root / "fleet"
    simulate_fleet(
        fleet, n_robots=1, n_axes=2, n_days=16, task_change_days=(), faults=[], duration_s=0.5
    )
    axis = fleet / "robot01/axis1"
    faulty = faulty_copy(axis / "2026-03-09.parquet", root / "faulty.parquet")
    shutil.move(faulty, axis / "2026-03-10.parquet")
    later = root / "later"
    for day in range(11, 17):  # delivered after the alarm was acknowledged
        for capture in fleet.glob(f"robot01/*/2026-03-{day}.parquet"):
            target = later / capture.relative_to(fleet)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(capture, target)
    settle(fleet)
    store = root / "s.db"
    with Store(store) as opened:
        monitor_fleet(fleet, opened, PCA)
        opened.acknowledge("robot01", "axis1", by="ana", note="seen")
    for capture in later.rglob("*.parquet"):
        shutil.move(capture, fleet / capture.relative_to(later))
    settle(fleet)
    for axis in (fleet / "robot01").iterdir():  # listed again
        os.utime(axis, ns=(1, 1))
    with Store(store) as opened:
        monitor_fleet(fleet, opened, PCA)
    return fleet, store


def _copy(monitored: tuple[Path, Path], tmp_path: Path) -> tuple[Path, Path]:
    fleet = Path(shutil.copytree(monitored[0], tmp_path / "fleet"))
    return fleet, Path(shutil.copy(monitored[1], tmp_path / "s.db"))


def _must_keep(table: pd.DataFrame, acknowledged: set[str]) -> set[tuple[Any, Any]]:
    """(axis, capture) of every score the module's rules keep, from the table before."""
    keep: set[tuple[Any, Any]] = set()
    newest = pd.to_datetime(table.captured_at).max()
    for axis, rows in table.groupby("axis"):
        monitor = rows[rows.role == "monitor"].reset_index(drop=True)
        keep |= {(axis, c) for c in rows.capture[rows.role.isin(["baseline", "calibration"])]}
        keep |= {(axis, c) for c in rows.capture[rows.alarm | rows.over]}
        keep |= {
            (axis, c) for c in rows.capture[rows.capture.isin(acknowledged)] if axis == "axis1"
        }
        before_alarm = monitor.index[monitor.alarm.shift(-1, fill_value=False)]
        keep |= {(axis, monitor.capture[i]) for i in before_alarm}
        keep |= {(axis, c) for c in monitor.capture.iloc[-RECENT:]}
        recent = pd.to_datetime(rows.captured_at) >= newest - KEEP
        keep |= {(axis, c) for c in rows.capture[recent]}
    return keep


def test_compact_keeps_what_is_needed_and_one_score_per_period(
    monitored: tuple[Path, Path], tmp_path: Path
) -> None:
    _, store_path = _copy(monitored, tmp_path)
    with Store(store_path) as store:
        before = store.score_table()
        alarms, acks = store.alarms(), store.acknowledgements()
        summary = store.summary_table()
        assert before.alarm.sum() == 1  # the fixture's alarm, and its acknowledgement
        assert len(acks) == 1
        done = store.compact(KEEP, EVERY, recent=RECENT)
        after = store.score_table()
        assert store.alarms() == alarms
        pd.testing.assert_frame_equal(store.acknowledgements(), acks)
        pd.testing.assert_frame_equal(store.summary_table(), summary)
    assert done.thinned > 0
    assert done.kept == len(after) == len(before) - done.thinned
    kept = set(zip(after.axis, after.capture, strict=True))
    assert _must_keep(before, set(acks.capture)) <= kept
    # Every kept row is as it was, byte for byte.
    index = ["axis", "capture"]
    expected = before.set_index(index).loc[after.set_index(index).index].reset_index()
    pd.testing.assert_frame_equal(after[expected.columns], expected)
    # Each period of the old history keeps its highest distance.
    captured_at = pd.to_datetime(before.captured_at)
    old = before[(before.role == "monitor") & (captured_at < captured_at.max() - KEEP)]
    old = old.assign(period=(captured_at - datetime(1970, 1, 1)) // EVERY)
    highest = old.loc[old.groupby(["axis", "period"]).distance.idxmax()]
    assert set(zip(highest.axis, highest.capture, strict=True)) <= kept


def test_monitoring_after_compact_scores_only_new_captures(
    monitored: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    planned: list[str] = []

    def score_jobs_of(run: Any, states: Any) -> list[Any]:
        jobs = plan(run, states)
        planned.extend(job.relative for job in jobs)
        return jobs

    plan = _planning.score_jobs_of
    monkeypatch.setattr(_planning, "score_jobs_of", score_jobs_of)
    monkeypatch.setattr(_monitor, "score_jobs_of", score_jobs_of)
    fleet, store_path = _copy(monitored, tmp_path)
    with Store(store_path) as store:
        store.compact(KEEP, EVERY, recent=RECENT)
        compacted, alarms = store.score_table(), store.alarms()
    for axis in (fleet / "robot01").iterdir():  # every folder listed again
        os.utime(axis, ns=(2, 2))
    with Store(store_path) as store:
        again = monitor_fleet(fleet, store, PCA)
        pd.testing.assert_frame_equal(store.score_table(), compacted)
        assert store.alarms() == alarms
    assert again.n_files == 32
    assert again.scored == 0
    assert planned == []  # no thinned capture is even read again
    axis = fleet / "robot01/axis2"
    shutil.copy(axis / "2026-03-16.parquet", axis / "2026-03-17.parquet")
    settle(fleet)
    with Store(store_path) as store:
        assert monitor_fleet(fleet, store, PCA).scored == 1
        new = store.score_table()
    assert [path.rsplit("/", 1)[-1] for path in planned] == ["2026-03-17.parquet"]
    assert len(new) == len(compacted) + 1
    assert new.capture[~new.capture.isin(compacted.capture)].tolist() == ["2026-03-17.parquet"]


def test_compact_command_reports_and_refuses_bad_input(
    monitored: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _, store_path = _copy(monitored, tmp_path)
    with monkeypatch.context() as patched:  # a read-only file (root may write any file)
        patched.setattr(os, "access", lambda path, mode: mode != os.W_OK)
        refused = runner.invoke(app, ["compact", "--store", str(store_path)])
    assert refused.exit_code != 0
    assert refused.output.strip().splitlines() == [
        f"error: store '{store_path}' is read-only here; compact rewrites it (copy it somewhere "
        "writable, or ask its owner)."
    ]
    done = runner.invoke(app, ["compact", "--store", str(store_path), "--keep", "1d"])
    assert done.exit_code == 0, done.output
    assert done.output.startswith(f"Compacted {store_path}: ")
    off = runner.invoke(app, ["compact", "--store", str(store_path), "--keep", "off"])
    assert off.exit_code != 0
    assert "need a duration, not 'off'" in off.output
    with (
        Store(store_path, read_only=True) as store,
        pytest.raises(StoreError, match="is opened read-only; compacting writes it"),
    ):
        store.compact(KEEP)
    with Store(store_path) as store, pytest.raises(ValueError, match="'every' parameter"):
        store.compact(KEEP, timedelta(0))
