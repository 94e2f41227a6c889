"""Rejections that no longer need anyone: a rejected file removed from the fleet folder (kept as
history), and acknowledged bad data in the fleet summary's state."""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch.cli import app
from axiswatch.monitor import StoreBackend
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.attention import AxisAttention, triage
from axiswatch.monitor.report.html import write_report
from axiswatch.monitor.report.results import fleet_rejections, fleet_results, fleet_summary
from axiswatch.monitor.store import Rejection, Store, now
from tests.conftest import settle
from tests.monitor.store.test_store_contract import BACKENDS

PCA = MonitorConfig(method="pca")
BAD = "robot01/axis1/2026-03-10.parquet"


def _triage(store: StoreBackend) -> dict[str, AxisAttention]:
    items = triage(
        fleet_summary(store),
        fleet_results(store),
        fleet_rejections(store),
        store.changed_file_table(),
        store.alarms(),
        method="pca",
        checks=store.baseline_checks(),
    )
    return {f"{i.robot}/{i.axis}": i for i in items}


def _state(store: StoreBackend, axis: str = "axis1") -> str:
    summary = fleet_summary(store).set_index("axis")
    return str(summary.loc[axis, "state"])


@pytest.fixture
def fleet(small_fleet: Path, tmp_path: Path) -> Path:
    """:func:`small_fleet` and a flat (bad data) capture of robot01/axis1 after its last one."""
    root = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    capture = aw.read_capture(root / "robot01/axis1/2026-03-04.parquet")
    flat = aw.Capture({k: 0.0 * v for k, v in capture.signals.items()}, capture.rates_hz)
    aw.write_capture(flat, root / BAD)
    settle(root)
    return root


def test_a_rejected_file_removed_from_the_fleet_folder_is_history_not_bad_data(
    fleet: Path, tmp_path: Path
) -> None:
    # Before: the monitor stopped counting the rejection once its file was deleted (exit 0),
    # but the report and the summary read only the store and kept the axis as bad data until
    # someone ran `rejections --retry` (which also forgot the rejection).
    kept = tmp_path / "kept.parquet"
    with Store(tmp_path / "s.db") as store:
        first = monitor_fleet(fleet, store, PCA, settle_s=0)
        assert (first.exit_code, _triage(store)["robot01/axis1"].kind) == (8, "bad data")
        assert _state(store) == "bad data"
        shutil.move(fleet / BAD, kept)  # the user deletes (here: moves away) the bad file
        second = monitor_fleet(fleet, store, PCA, settle_s=0)
        after = _triage(store)
        summary_state = _state(store)
        table = fleet_rejections(store)
        page = write_report(store, tmp_path / "r").read_text(encoding="utf-8")
    assert (second.exit_code, second.rejected) == (0, [])
    assert table.path.tolist() == [BAD]  # kept as history, with when the run found it gone
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", table.removed_at.iloc[0])
    axis = after["robot01/axis1"]
    assert (axis.kind, axis.needs_attention) == ("ok", False)
    assert re.search(
        r"^ok: last capture 2026-03-09, .* 1 rejected capture file\(s\) since removed from the "
        rf"fleet folder \(history\), last on \d{{4}}-\d\d-\d\d: {BAD}\.$",
        axis.line,
    ), axis.line
    assert summary_state == "ok"
    attention = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    assert "robot01/axis1" not in attention
    rejected = page.split("<h2 id='rejected'>Rejected captures</h2>")[1]
    assert "<th>removed</th>" in rejected
    listed = CliRunner().invoke(app, ["rejections", "--store", str(tmp_path / "s.db")])
    assert listed.exit_code == 0, listed.output
    assert re.search(rf"{BAD} .* \d{{4}}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00$", listed.output.strip())
    assert listed.output.splitlines()[0].split()[-1] == "removed"


def test_a_removed_rejected_file_that_comes_back_is_a_problem_again(
    fleet: Path, tmp_path: Path
) -> None:
    kept = tmp_path / "kept.parquet"
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        shutil.move(fleet / BAD, kept)
        assert monitor_fleet(fleet, store, PCA, settle_s=0).exit_code == 0
        shutil.move(kept, fleet / BAD)  # the same content, back (a share mounted again)
        settle(fleet)
        back = monitor_fleet(fleet, store, PCA, settle_s=0)
        table = fleet_rejections(store)
        axis = _triage(store)["robot01/axis1"]
        summary_state = _state(store)
    assert back.exit_code == 8
    assert back.rejected[0].startswith(f"{BAD}: bad data (flat/stuck signal")
    assert table.removed_at.isna().tolist() == [True]
    assert axis.kind == "bad data"
    assert summary_state == "bad data"


def test_acknowledged_bad_data_is_not_the_summary_state_and_is_said_in_a_column(
    fleet: Path, tmp_path: Path
) -> None:
    # Before: `rejections --ack` stopped the monitor's exit status 8 and the report's "bad data",
    # but fleet_summary (and the table `monitor` prints) still gave the axis the state "bad data".
    path = tmp_path / "s.db"
    with Store(path) as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        assert store.acknowledge_problems([BAD], now()) == 1
        summary = fleet_summary(store).set_index("axis")
        axis = _triage(store)["robot01/axis1"]
    assert summary.state.tolist() == ["ok", "ok"]
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00",
                        summary.loc["axis1", "bad_data_acknowledged"])  # fmt: skip
    assert summary.bad_data_acknowledged.isna().tolist() == [False, True]
    assert (axis.kind, axis.needs_attention) == ("ok", False)  # as the report says
    shown = CliRunner().invoke(
        app, ["monitor", str(fleet), "--store", str(path), "--method", "pca", "--settle", "0"]
    )
    assert shown.exit_code == 0, shown.output  # as the monitor says
    lines = shown.output.splitlines()
    header = next(line for line in lines if line.split()[:2] == ["robot", "axis"])
    assert re.search(r" state +bad_data_acknowledged ", header), header
    row = next(line for line in lines if " axis1 " in line)
    assert re.search(r" ok +\d{4}-\d\d-\d\dT", row), row


# --- the store contract of both ------------------------------------------------------------


@pytest.fixture(params=sorted(BACKENDS))
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[StoreBackend]:
    make: Callable[[Path], StoreBackend] = BACKENDS[request.param]
    opened = make(tmp_path)
    yield opened
    opened.close()


def _bad(capture: str, digest: str = "h") -> Rejection:
    return Rejection("r1", "a1", "pca", capture, f"r1/a1/{capture}", digest, f"{capture}: bad data",
                     kind="bad data")  # fmt: skip


# The readers' protocol: SQLite only (the in-memory double implements the writer).
@pytest.mark.parametrize("store", ["sqlite"], indirect=True)
def test_a_removed_rejection_is_kept_and_left_out_of_the_latest_bad_data(
    store: StoreBackend,
) -> None:
    def latest() -> list[tuple[object, ...]]:
        frame = store.latest_bad_data()
        columns = ["bad_capture", "seen_capture", "seen_at"]
        return [tuple(None if v != v else v for v in row) for row in frame[columns].values]

    older, newer = _bad("2026-03-05.csv"), _bad("2026-03-06.csv")
    assert store.reject_capture(older)
    assert store.reject_capture(newer)
    assert latest() == [("2026-03-06.csv", None, None)]
    store.mark_rejection_removed(newer, "2026-03-10T08:00:00+00:00")
    assert [r.removed_at for r in store.rejections("pca")] == [None, "2026-03-10T08:00:00+00:00"]
    assert store.rejection_table().removed_at.tolist()[1] == "2026-03-10T08:00:00+00:00"
    problems = store.problem_table()
    assert problems.removed_at.notna().tolist() == [False, True]
    assert latest() == [("2026-03-05.csv", None, None)]
    assert store.acknowledge_problems(["r1/a1/2026-03-05.csv"], "2026-03-11T09:00:00+00:00") == 1
    assert latest() == [(None, "2026-03-05.csv", "2026-03-11T09:00:00+00:00")]
    store.reject_capture(newer)  # seen again with its content: no longer removed
    assert [r.removed_at for r in store.rejections("pca")] == [None, None]
    assert latest() == [("2026-03-06.csv", "2026-03-05.csv", "2026-03-11T09:00:00+00:00")]
    store.mark_rejection_removed(newer, "2026-03-12T08:00:00+00:00")
    store.mark_rejection_removed(newer, None)  # back
    assert latest()[0][0] == "2026-03-06.csv"
    store.mark_rejection_removed(_bad("2026-03-06.csv", "other"), "2026-03-12T08:00:00+00:00")
    assert store.rejections("pca")[1].removed_at is None  # another content: not this one
