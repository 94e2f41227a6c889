"""The monitor on local processes and on a Dask cluster gives exactly the serial results.

Only the driver writes the store; workers compute. Each job runs on one BLAS thread, so the
floating-point results do not depend on where they ran.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest

from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.results import fleet_results
from axiswatch.monitor.store import Store

_COMPARED = ["robot", "axis", "capture", "method", "role", "distance", "threshold", "alarm"]


def _run(fleet: Path, store_path: Path, **where: object) -> pd.DataFrame:
    with Store(store_path) as store:
        summary = monitor_fleet(fleet, store, MonitorConfig(method="lra"), **where)  # type: ignore[arg-type]
        assert summary.scored == 16  # 18 files: 2 baselines + 16 scored captures
        return fleet_results(store)[_COMPARED].reset_index(drop=True)


@pytest.fixture(scope="module")
def serial(small_fleet: Path, tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    return _run(small_fleet, tmp_path_factory.mktemp("serial") / "s.db")


def test_two_processes_equal_serial(
    serial: pd.DataFrame, small_fleet: Path, tmp_path: Path
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    pd.testing.assert_frame_equal(_run(fleet, tmp_path / "p.db", workers=2), serial)


def test_dask_local_cluster_equals_serial(
    serial: pd.DataFrame, small_fleet: Path, tmp_path: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        by_client = _run(fleet, tmp_path / "c.db", dask=client)
        by_address = _run(fleet, tmp_path / "a.db", dask=cluster.scheduler_address)
    pd.testing.assert_frame_equal(by_client, serial)
    pd.testing.assert_frame_equal(by_address, serial)


def test_one_axis_per_chunk_equals_serial(
    serial: pd.DataFrame, small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import axiswatch.monitor._monitor

    monkeypatch.setattr(axiswatch.monitor._monitor, "_AXES_PER_CHUNK", 1)
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    pd.testing.assert_frame_equal(_run(fleet, tmp_path / "k.db"), serial)


def test_captures_sent_while_later_axes_are_planned_equal_serial(
    serial: pd.DataFrame, small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A second run (stored models) plans one axis at a time and sends its captures to the
    workers before the next axis is planned; the results are the serial run's."""
    import axiswatch.monitor._monitor

    monkeypatch.setattr(axiswatch.monitor._monitor, "_AXES_PER_PLAN", 1)
    planned: list[int] = []  # stored-model axes per planned slice
    jobs_of = axiswatch.monitor._monitor.score_jobs_of

    def spy(run: object, states: list[object]) -> object:
        planned.append(len(states))
        return jobs_of(run, states)  # type: ignore[arg-type]

    monkeypatch.setattr(axiswatch.monitor._monitor, "score_jobs_of", spy)
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    later = tmp_path / "later"
    for path in sorted(fleet.glob("*/*/*.parquet")):
        if path.stem >= sorted(p.stem for p in path.parent.glob("*.parquet"))[5]:
            target = later / path.relative_to(fleet)
            target.parent.mkdir(parents=True, exist_ok=True)
            path.rename(target)
    with Store(tmp_path / "two.db") as store:
        first = monitor_fleet(fleet, store, MonitorConfig(method="lra"), workers=2)
        for path in sorted(later.rglob("*.parquet")):
            path.rename(fleet / path.relative_to(later))
        planned.clear()
        again = monitor_fleet(fleet, store, MonitorConfig(method="lra"), workers=2)
        assert planned == [1, 1]  # each axis's stored model, one slice each
        results = fleet_results(store)[_COMPARED].reset_index(drop=True)
    assert (first.scored, again.scored) == (8, 8)  # 5 files then 4 more on each of 2 axes
    pd.testing.assert_frame_equal(results, serial)
