"""The report's first screen (which axes need attention, and why) and the page itself."""

from __future__ import annotations

import re
import shutil
import sqlite3
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch.cli import app
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.attention import AxisAttention, triage
from axiswatch.monitor.report.html import write_report
from axiswatch.monitor.report.results import fleet_rejections, fleet_results, fleet_summary
from axiswatch.monitor.store import Store, now
from tests.conftest import settle
from tests.monitor.test_monitor import faulty_copy

PCA = MonitorConfig(method="pca")


def _triage(store: Store, method: str = "pca") -> dict[str, AxisAttention]:
    items = triage(
        fleet_summary(store),
        fleet_results(store),
        fleet_rejections(store),
        store.changed_file_table(),
        store.alarms(),
        method=method,
        checks=store.baseline_checks(),
    )
    return {f"{i.robot}/{i.axis}": i for i in items}


@pytest.fixture
def fleet(small_fleet: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(small_fleet, tmp_path / "fleet"))


def _arrived_earlier(store: Store, days: float = 1 / 24) -> None:
    """Date every axis's last new file ``days`` back (an hour): the next run's files arrive
    later."""
    then = (datetime.now(UTC) - timedelta(days=days)).isoformat(timespec="seconds")
    with sqlite3.connect(store.path) as connection:
        connection.execute("UPDATE axis_activity SET last_seen_at=?", (then,))


def test_a_fleet_imported_at_once_is_not_stale(fleet: Path, tmp_path: Path) -> None:
    # Units recorded on different days and imported in one run (the real hydraulic actuators,
    # a linear axis's log of last year). Before: "Stale: no capture since 2026-03-05, 4 days
    # 00:00:00 behind the fleet's newest", and "No new captures: check the logger".
    axis1, axis2 = fleet / "robot01/axis1", fleet / "robot01/axis2"
    for day in (8, 9):  # axis2 was recorded up to 03-07, axis1 up to 03-11
        (axis2 / f"2026-03-0{day}.parquet").unlink()
    shutil.copy(axis1 / "2026-03-09.parquet", axis1 / "2026-03-11.parquet")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        items = _triage(store)
    assert [i.kind for i in items.values()] == ["ok", "ok"]
    assert not any("Stale" in i.line for i in items.values())


def test_an_archive_read_days_later_says_how_to_stop_the_stale_flag(
    fleet: Path, tmp_path: Path
) -> None:
    # Before: "Stale: no new capture file since ...", nothing for a user who imported history.
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        _arrived_earlier(store, days=4)
        items = triage(
            fleet_summary(store, stale_after=timedelta(days=3)), fleet_results(store),
            fleet_rejections(store), store.changed_file_table(), store.alarms(), method="pca",
            checks=store.baseline_checks(),
        )  # fmt: skip
    assert [i.kind for i in items] == ["stale", "stale"]
    assert all(i.line.endswith("An archive imported once gets no new files: --stale-after off.")
               for i in items)  # fmt: skip


def test_stale_and_bad_data_axes_need_attention_until_repaired(fleet: Path, tmp_path: Path) -> None:
    axis1, axis2 = fleet / "robot01/axis1", fleet / "robot01/axis2"
    held = tmp_path / "held"
    held.mkdir()
    for axis in (axis1, axis2):  # the captures after 03-05 arrive later
        for day in (6, 7, 8, 9):
            shutil.move(axis / f"2026-03-0{day}.parquet", held / f"{axis.name}-{day}.parquet")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        _arrived_earlier(store)
        # axis1's next captures arrive, one of them empty; axis2's stop.
        for day in (6, 7, 8, 9):
            shutil.move(held / f"axis1-{day}.parquet", axis1 / f"2026-03-0{day}.parquet")
        (axis1 / "2026-03-09T12-00-00.csv").write_bytes(b"")
        settle(fleet)
        monitor_fleet(fleet, store, PCA, settle_s=0)
        first = _triage(store)
        assert [i.kind for i in first.values()] == ["bad data", "stale"]  # ranked
        assert "1 capture file(s) rejected, latest: robot01/axis1/2026-03-09T12-00-00.csv: " in (
            first["robot01/axis1"].line
        )
        assert first["robot01/axis2"].line.startswith(
            "Stale: no capture since 2026-03-05, while other axes kept arriving: their newest "
            "is 4.0 d later (4 x this axis's usual interval of 1.0 d)."
        )
        # The file is repaired (a good capture under the same name) and axis2 sends again.
        aw.write_capture(
            aw.read_capture(axis1 / "2026-03-02.parquet"), axis1 / "2026-03-09T12-00-00.csv"
        )
        for day in (6, 7, 8, 9):
            shutil.move(held / f"axis2-{day}.parquet", axis2 / f"2026-03-0{day}.parquet")
        monitor_fleet(fleet, store, PCA, settle_s=0)
        second = _triage(store)
    assert [i.kind for i in second.values()] == ["ok", "ok"]
    assert not any(i.needs_attention for i in second.values())


def acknowledged_rejections(fleet: Path, tmp_path: Path) -> Path:
    """A store of ``fleet`` (:func:`small_fleet`) with three rejections, two of them then
    acknowledged with ``rejections --ack``: an empty capture of robot01/axis1 and the misnamed
    folder ``robot 2/`` (no baseline); robot01/axis2's empty capture is not."""
    (fleet / "robot01/axis1/2026-03-09T12-00-00.csv").write_bytes(b"")
    (fleet / "robot01/axis2/2026-03-09T12-00-00.csv").write_bytes(b"")
    shutil.copytree(fleet / "robot01", fleet / "robot 2")
    settle(fleet)
    store = tmp_path / "acked.db"
    with Store(store) as opened:
        assert monitor_fleet(fleet, opened, PCA, settle_s=0).exit_code == 8
        before = _triage(opened)
    assert [before[a].kind for a in ("robot01/axis1", "robot01/axis2", "robot 2/")] == (
        ["bad data"] * 3
    )
    acked = CliRunner().invoke(
        app,
        ["rejections", "--store", str(store), "--ack", "robot01/axis1/2026-03-09T12-00-00.csv",
         "robot 2/"],
    )  # fmt: skip
    assert acked.output.startswith("2 problem(s) acknowledged"), acked.output
    return store


def test_an_acknowledged_rejection_stays_on_the_line_but_needs_no_attention(
    fleet: Path, tmp_path: Path
) -> None:
    # Before: `rejections --ack` made the monitor stop counting a rejection, but the report read
    # no acknowledgement and kept the axis under "Needs attention now" as bad data.
    store = acknowledged_rejections(fleet, tmp_path)
    with Store(store) as opened:
        after = _triage(opened)
        page = write_report(opened, tmp_path / "r").read_text(encoding="utf-8")
        again = monitor_fleet(fleet, opened, PCA, settle_s=0)
    assert (again.acknowledged, len(again.rejected), again.exit_code) == (2, 1, 8)
    seen = after["robot01/axis1"]
    assert (seen.kind, seen.needs_attention) == ("ok", False)
    assert re.search(
        r"^ok: last capture 2026-03-09, .* 1 capture file\(s\) rejected, seen on "
        r"\d{4}-\d\d-\d\d, latest: robot01/axis1/2026-03-09T12-00-00.csv: ",
        seen.line,
    ), seen.line
    folder = after["robot 2/"]
    assert (folder.kind, folder.needs_attention) == ("calibrating", False)
    assert folder.line.startswith("No baseline yet. 1 capture file(s) rejected, seen on ")
    assert "robot folder name 'robot 2' is not an identifier" in folder.line
    unseen = after["robot01/axis2"]  # not acknowledged: still bad data
    assert (unseen.kind, unseen.needs_attention) == ("bad data", True)
    assert unseen.line.startswith("1 capture file(s) rejected, latest: robot01/axis2/")
    attention = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    assert "Needs attention now (1)" in attention
    assert "data-axis='robot01/axis2' data-kind='bad data'" in attention
    assert "robot01/axis1" not in attention
    assert "robot 2" not in attention
    healthy = page.split("<details id='healthy'>")[1].split("</details>")[0]
    assert "1 capture file(s) rejected, seen on " in healthy
    table = page.split("<h2 id='rejected'>Rejected captures</h2>")[1]
    assert "<th>seen</th>" in table
    assert re.search(
        r"robot 2/</td><td class='text'>robot .*?</td><td class='text'>\d{4}-\d\d-\d\d \d\d:",
        table,
    )


def test_an_acknowledged_changed_file_stays_on_the_line_but_needs_no_attention(
    fleet: Path, tmp_path: Path
) -> None:
    # Before: as for rejections, `rejections --ack` of a changed file did not reach the report,
    # which read no acknowledgement and kept its axis under "Needs attention now".
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        for axis in ("axis1", "axis2"):
            target = fleet / f"robot01/{axis}/2026-03-08.parquet"
            faulty_copy(target, target)
        settle(fleet)
        assert len(monitor_fleet(fleet, store, PCA, settle_s=0).changed) == 2
        assert store.acknowledge_problems(["robot01/axis1/2026-03-08.parquet"], now()) == 1
        items = _triage(store)
        page = write_report(store, tmp_path / "r").read_text(encoding="utf-8")
    seen, unseen = items["robot01/axis1"], items["robot01/axis2"]
    assert (seen.kind, seen.needs_attention) == ("ok", False)
    assert re.search(
        r" 1 file\(s\) changed after they were scored \(results kept\), seen on "
        r"\d{4}-\d\d-\d\d: robot01/axis1/2026-03-08.parquet$",
        seen.line,
    ), seen.line
    assert (unseen.kind, unseen.needs_attention) == ("bad data", True)
    assert unseen.line.startswith("1 file(s) changed after they were scored (results kept): ")
    attention = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    assert "Needs attention now (1)" in attention
    assert "data-axis='robot01/axis2' data-kind='bad data'" in attention
    table = page.split("<h2>Files changed after they were scored</h2>")[1]
    assert "<th>seen</th>" in table
    assert re.search(r"axis1/2026-03-08.parquet</td><td class='text'>[^<]+</td><td class='text'>"
                     r"\d{4}-\d\d-\d\d \d\d:", table)  # fmt: skip


def test_alarms_rank_first_and_an_acknowledged_one_last(fleet: Path, tmp_path: Path) -> None:
    for axis in ("axis1", "axis2"):
        folder = fleet / "robot01" / axis
        faulty_copy(folder / "2026-03-09.parquet", folder / "2026-03-10.parquet")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        store.acknowledge("robot01", "axis1", by="ana", note="seen")
        ranked = list(_triage(store).values())
    assert [(i.axis, i.kind) for i in ranked] == [("axis2", "alarm"), ("axis1", "acknowledged")]
    assert ranked[0].line.startswith("ALARM since 2026-03-10 (1 capture in alarm): Distance ")
    assert "(99th pct of half-Laplace fit of 5 healthy captures)." in ranked[0].line
    assert re.search(r" Seen by ana on \d{4}-\d\d-\d\d: seen$", ranked[1].line), ranked[1].line


def test_report_is_one_self_contained_page(fleet: Path, tmp_path: Path) -> None:
    axis = fleet / "robot01/axis1"
    faulty_copy(axis / "2026-03-09.parquet", axis / "2026-03-10.parquet")
    with Store(tmp_path / "s.db") as store:
        for method in ("lra", "pca"):
            monitor_fleet(fleet, store, MonitorConfig(method=method))
        store.acknowledge("robot01", "axis1", by="ana", note="checked the gearbox", method="pca")
        page = write_report(store, tmp_path / "r")
    assert sorted(p.name for p in page.parent.iterdir()) == ["index.html"]
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"<(script|link|img)[^>]+(src|href)\s*=", text)  # nothing fetched
    assert text.count("<script type='text/javascript'>/**\n* plotly.js") == 1  # inlined once
    assert "Method leading this page: <b>lra</b>" in text  # no mechanics in this store
    assert "<details id='paper-methods'><summary>The paper's methods (pca)" in text
    for anchor in ("robot01-axis1", "robot01-axis2"):
        assert f"<section class='axis' id='{anchor}'>" in text
        assert f"href='#{anchor}'" in text
        assert f'id="chart-{anchor}"' in text
    assert "alarm acknowledged (pca)</td><td class='text'>by ana: checked the gearbox" in text


def test_a_large_fleet_lists_the_first_axes_and_charts_only_those(
    fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Before: every axis needing attention was listed and every axis charted, so the first
    # screen and the page grew with the fleet. Limits of 1 stand in for a fleet of 1,000 axes.
    import axiswatch.monitor.report.html as report_html

    for axis in ("axis1", "axis2"):
        folder = fleet / "robot01" / axis
        faulty_copy(folder / "2026-03-09.parquet", folder / "2026-03-10.parquet")
    monkeypatch.setattr(report_html, "LISTED", 1)
    monkeypatch.setattr(report_html, "CHARTED_AXES", 1)
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, PCA, settle_s=0)
        page = write_report(store, tmp_path / "r").read_text(encoding="utf-8")
    attention = page.split("<section id='attention'>")[1].split("<details id='healthy'>")[0]
    assert "Needs attention now (2)" in attention
    listed = re.findall(r"<li class='[^']*' data-axis='([^']+)'", attention)
    assert listed == ["robot01/axis2"]  # the larger excursion first, as ranked
    more = attention.split("<details id='more-attention'><summary>1 more axis needs attention")
    assert len(more) == 2, attention
    assert "<input class='filter' type='search'" in more[1]
    assert "<tr class='row'><td>robot01/axis1</td><td class='text'>act now</td>" in more[1]
    assert "<section class='axis' id='robot01-axis2'>" in page
    assert 'id="chart-robot01-axis2"' in page
    assert "id='robot01-axis1'" not in page
    assert "chart-robot01-axis1" not in page
    assert "href='#robot01-axis1'" not in page  # no link to a section the page lacks
    assert "(1 of 2); every axis is in the tables above" in page
