"""The monitor's commands run as a user runs them, on simulated fleets in temporary folders."""

from __future__ import annotations

import json
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch._capture
from axiswatch.cli import app
from axiswatch.monitor.store.packing import unpack
from tests._cli import run
from tests.conftest import settle

runner = CliRunner()


def _run(*args: object) -> subprocess.CompletedProcess[str]:
    """``python -m axiswatch ARGS``: where the claim is about the process (tests/_cli.py runs
    the command line in this process otherwise)."""
    return subprocess.run(
        [sys.executable, "-m", "axiswatch", *map(str, args)], capture_output=True, text=True
    )


def _results(store: Path) -> pd.DataFrame:
    """Everything a run decides, without the wall-clock columns."""
    connection = sqlite3.connect(store)
    frame = pd.read_sql(
        "SELECT b.epoch, b.capture AS baseline, b.threshold AS baseline_threshold, s.robot, "
        "s.axis, s.method, s.capture, s.role, s.distance, s.threshold, s.over, s.alarm, "
        "s.baseline_id, s.packed, s.primed FROM scores s JOIN baselines b ON b.id = s.baseline_id "
        "ORDER BY s.robot, s.axis, s.method, b.epoch, s.captured_at, s.capture",
        connection,
    )
    primers = dict(connection.execute("SELECT baseline_id, dictionary FROM score_dictionaries"))
    connection.close()
    columns = (frame.pop("baseline_id"), frame.pop("packed"), frame.pop("primed"))
    texts = [
        unpack(p, primers[b] if primed else None) for b, p, primed in zip(*columns, strict=True)
    ]
    return frame.assign(reason=[r for r, _ in texts], details=[d for _, d in texts])


@pytest.fixture
def fleet(small_fleet: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(small_fleet, tmp_path / "fleet"))


def test_every_command_has_help() -> None:
    for command in (
        ["monitor"],
        ["results"],
        ["report"],
        ["rebaseline"],
        ["ack"],
        ["simulate", "fleet"],
        ["demo"],
    ):
        result = runner.invoke(app, [*command, "--help"])
        assert result.exit_code == 0, result.output
        assert "Usage" in result.output


def _write_bad_captures(axis: Path, root: Path) -> dict[str, str]:
    """One file per bad-input case; returns the expected part of each rejection reason."""
    good = aw.read_capture(axis / "2026-03-02.parquet")
    frame = aw._capture.capture_to_frame(good)
    cases: dict[str, str] = {}

    def csv(name: str, table: pd.DataFrame, expected: str) -> None:
        table.to_csv(axis / name, index=False)
        cases[f"robot01/axis1/{name}"] = expected

    (axis / "2026-03-02T01-00-00_unreadable.parquet").write_bytes(b"PAR1 this is not parquet")
    cases["robot01/axis1/2026-03-02T01-00-00_unreadable.parquet"] = "cannot read Parquet file"
    (axis / "2026-03-02T02-00-00_empty.csv").write_bytes(b"")
    cases["robot01/axis1/2026-03-02T02-00-00_empty.csv"] = "file is empty (0 bytes)"
    whole = (axis / "2026-03-02.parquet").read_bytes()
    (axis / "2026-03-02T03-00-00_truncated.parquet").write_bytes(whole[: len(whole) // 2])
    cases["robot01/axis1/2026-03-02T03-00-00_truncated.parquet"] = "cannot read Parquet file"
    csv("2026-03-02T04-00-00_no-time.csv", frame.drop(columns="time"), "missing column 'time'")
    csv(
        "2026-03-02T05-00-00_no-torque.csv",
        frame.drop(columns="torque"),
        "missing signal column(s) ['torque']",
    )
    text = frame.astype(object)
    text.loc[10, "speed"] = "fast"
    csv("2026-03-02T06-00-00_text.csv", text, "column 'speed' must be numeric")
    holed = frame.copy()
    holed.loc[300, "torque"] = np.nan
    csv("2026-03-02T07-00-00_nan.csv", holed, "column 'torque'")
    backwards = frame.copy()
    backwards.loc[20, "time"] = backwards.loc[19, "time"]
    csv("2026-03-02T08-00-00_time.csv", backwards, "column 'time' must be strictly increasing")
    slow = aw.Capture(
        {name: values[::2] for name, values in good.signals.items()},
        {name: rate / 2 for name, rate in good.rates_hz.items()},
    )
    aw.write_capture(slow, axis / "2026-03-02T09-00-00_rate.parquet")
    cases["robot01/axis1/2026-03-02T09-00-00_rate.parquet"] = (
        "column 'position' is sampled at 125 Hz; expected 250 Hz (the baseline's rate)"
    )
    csv("2026-03-02T10-00-00_short.csv", frame.iloc[:80], "capture too short for one STFT window")
    for name, stored, expected in (  # a misnamed folder is stored once, as the folder
        ("robot 1/axis1/2026-03-02.csv", "robot 1/", "robot folder name 'robot 1' is not an"),
        ("robot01/2026-03-02.csv", None, "capture file at the wrong depth"),
        ("robot01/axis1/monday.csv", None, "does not start with an ISO date"),
    ):
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(root / name, index=False)
        cases[stored or name] = expected
    settle(root)
    return cases


def test_bad_inputs_are_rejected_one_line_each_and_the_rest_goes_on(
    fleet: Path, tmp_path: Path
) -> None:
    cases = _write_bad_captures(fleet / "robot01/axis1", fleet)
    store = tmp_path / "s.db"
    result = run("monitor", fleet, "--store", store, "--method", "pca")
    assert result.returncode == 8, result.stderr
    assert "Traceback" not in result.stdout + result.stderr
    connection = sqlite3.connect(store)
    rejected = dict(connection.execute("SELECT path, error FROM rejections"))
    scored = connection.execute("SELECT count(*) FROM scores WHERE role != 'baseline'").fetchone()
    connection.close()
    assert set(rejected) == set(cases)
    for path, expected in cases.items():
        line = rejected[path]
        assert line.startswith(path), line
        assert expected in line, line
        assert "\n" not in line
        assert line in result.stdout
    assert scored[0] == 16  # every good capture of both axes was scored
    again = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])
    assert again.exit_code == 8  # still rejected (same content): still reported
    assert "0 capture(s) scored in this run" in again.output


def test_failure_is_one_line_unless_debug(tmp_path: Path, fleet: Path) -> None:
    (tmp_path / "not.db").write_text("not a database at all" * 20)
    args = ["monitor", str(fleet), "--method", "lra", "--store", str(tmp_path / "not.db")]
    plain = runner.invoke(app, args)
    assert plain.exit_code == 1
    assert plain.output.startswith("error: store '")
    assert plain.exception is None or isinstance(plain.exception, SystemExit)
    debug = runner.invoke(app, [*args, "--debug"])
    assert isinstance(debug.exception, aw.StoreError)  # re-raised: Python prints the traceback
    missing = runner.invoke(app, ["results", "--store", str(tmp_path / "none.db")])
    assert missing.exit_code == 1
    assert "does not exist; run 'axiswatch monitor' first" in missing.output


def test_results_formats_and_filters(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    assert (
        runner.invoke(
            app, ["monitor", str(fleet), "--method", "lra", "--store", str(store)]
        ).exit_code
        == 0
    )
    table = runner.invoke(app, ["results", "--store", str(store), "--axis", "axis2"])
    assert table.exit_code == 0
    assert "axis1" not in table.output
    assert "2026-03-09.parquet" in table.output
    csv = runner.invoke(app, ["results", "--store", str(store), "--format", "csv"])
    frame = pd.read_csv(pd.io.common.StringIO(csv.output))
    assert list(frame.columns[:7]) == [
        "robot",
        "axis",
        "capture",
        "method",
        "distance",
        "threshold",
        "alarm",
    ]
    assert len(frame) == 18
    records = json.loads(
        runner.invoke(
            app, ["results", "--store", str(store), "--robot", "robot01", "--format", "json"]
        ).output
    )
    assert len(records) == 18
    assert {r["role"] for r in records} == {"baseline", "calibration", "monitor"}
    none = runner.invoke(app, ["results", "--store", str(store), "--robot", "robot09"])
    assert "No scored captures for --robot robot09; the store holds " in none.output
    # A second method in the same store: --method keeps one.
    runner.invoke(app, ["monitor", str(fleet), "--method", "pca", "--store", str(store)])
    both = runner.invoke(app, ["results", "--store", str(store), "--format", "csv"])
    assert set(pd.read_csv(pd.io.common.StringIO(both.output)).method) == {"lra", "pca"}
    for method in ("lra", "pca"):
        one = runner.invoke(
            app, ["results", "--store", str(store), "--method", method, "--format", "csv"]
        )
        kept = pd.read_csv(pd.io.common.StringIO(one.output))
        assert set(kept.method) == {method}
        assert len(kept) == 18
    unknown = runner.invoke(app, ["results", "--store", str(store), "--method", "svm"])
    assert unknown.exit_code == 2


def test_rebaseline_command(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])
    args = ["rebaseline", "--store", str(store), "--robot", "robot01", "--axis", "axis1"]
    done = runner.invoke(app, [*args, "--from", "2026-03-05.parquet"])
    assert done.exit_code == 0, done.output
    assert "starts a new baseline at 2026-03-05.parquet" in done.output
    again = runner.invoke(app, args)
    assert again.exit_code == 1
    assert "has no active baseline" in again.output
    rerun = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])
    assert "1 new baseline(s)" in rerun.output


def test_monitor_prints_a_summary_that_fits_a_terminal(fleet: Path, tmp_path: Path) -> None:
    """The summary printed after a run keeps the columns a service engineer reads first; the
    threshold's origin, the same for every axis, is said once below it."""
    store = tmp_path / "s.db"
    done = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])
    lines = done.output.splitlines()
    assert lines[1].split() == [
        "robot", "axis", "method", "state", "alarm_since", "scored", "over", "last_capture",
        "last_distance", "threshold", "rejected",
    ]  # fmt: skip
    assert max(len(line) for line in lines[1:4]) <= 120
    assert lines[4] == (
        "threshold of every axis: 99th pct of half-Laplace fit of 5 healthy captures."
    )


def test_a_reader_that_goes_away_is_not_an_error(fleet: Path, tmp_path: Path) -> None:
    """`axiswatch monitor ... | head -1`: the pipe closes before the summary is written; the
    command stops quietly (Click's exit status 1 for a broken pipe) instead of printing
    'error: [Errno 32] Broken pipe' as if monitoring had failed."""
    run = subprocess.Popen(
        [sys.executable, "-m", "axiswatch", "monitor", str(fleet), "--store",
         str(tmp_path / "s.db"), "--method", "pca"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert run.stdout is not None
    run.stdout.close()  # the reader is gone before the first line
    _, err = run.communicate(timeout=300)
    assert (run.returncode, err) == (1, "")


def test_backup_command_copies_every_result_and_never_overwrites(
    fleet: Path, tmp_path: Path
) -> None:
    store, copy = tmp_path / "s.db", tmp_path / "backup.db"
    runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "pca"])
    done = runner.invoke(app, ["backup", "--store", str(store), str(copy)])
    assert done.exit_code == 0, done.output
    n_rows = len(_results(store))
    assert n_rows > 0
    assert f"({n_rows} score rows)" in done.output
    pd.testing.assert_frame_equal(_results(copy), _results(store))
    again = runner.invoke(app, ["backup", "--store", str(store), str(copy)])
    assert again.exit_code == 1
    assert again.output.strip().splitlines() == [
        f"error: backup '{copy}' already exists; a backup never overwrites."
    ]


def test_report_command_writes_one_page(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    for method in ("lra", "pca"):
        runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", method])
    result = runner.invoke(app, ["report", "--store", str(store), "--out", str(tmp_path / "r")])
    assert result.exit_code == 0, result.output
    assert result.output == f"Report: {tmp_path / 'r' / 'index.html'}\n"
    page = (tmp_path / "r" / "index.html").read_text()
    assert "Needs attention now" in page
    assert page.count("Plotly.newPlot(") == 4  # per axis: the lead method, the other folded


def test_simulate_fleet_command(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    result = runner.invoke(
        app,
        [
            "simulate",
            "fleet",
            str(out),
            "--robots",
            "1",
            "--axes",
            "1",
            "--days",
            "2",
            "--duration",
            "0.5",
            "--format",
            "csv",
        ],
    )
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (out / "robot01" / "axis1").iterdir()) == [
        "2026-03-01.csv",
        "2026-03-02.csv",
    ]
    assert len(pd.read_csv(out / "labels.csv")) == 2


def _kill_after(seconds: float, fleet: Path, store: Path) -> int:
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "axiswatch",
            "monitor",
            str(fleet),
            "--method",
            "lra",
            "--store",
            str(store),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        return process.wait(timeout=seconds)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGKILL)
        process.wait()
        return -9


def test_killed_runs_resume_to_the_uninterrupted_result(fleet: Path, tmp_path: Path) -> None:
    for day in range(10, 14):  # more captures, so that kills land mid-run
        for axis in ("axis1", "axis2"):
            folder = fleet / "robot01" / axis
            shutil.copy(folder / f"2026-03-0{day - 8}.parquet", folder / f"2026-03-{day}.parquet")
    settle(fleet)
    reference = tmp_path / "reference.db"
    start = time.perf_counter()
    assert _run("monitor", fleet, "--method", "lra", "--store", reference).returncode == 0
    duration = time.perf_counter() - start
    store = tmp_path / "killed.db"
    # Kill points as fractions of an uninterrupted run (start-up included), each run resuming
    # the previous one's store: early (during start-up or the first baseline), mid and late.
    outcomes = [_kill_after(fraction * duration, fleet, store) for fraction in (0.3, 0.55, 0.8)]
    assert -9 in outcomes, outcomes
    final = run("monitor", fleet, "--method", "lra", "--store", store)
    assert final.returncode == 0, final.stderr
    pd.testing.assert_frame_equal(_results(store), _results(reference))
    connection = sqlite3.connect(store)
    assert connection.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    connection.close()


def test_two_monitors_on_one_store(fleet: Path, tmp_path: Path) -> None:
    reference = tmp_path / "reference.db"
    runner.invoke(app, ["monitor", str(fleet), "--store", str(reference), "--method", "pca"])
    store = tmp_path / "shared.db"
    command = [sys.executable, "-m", "axiswatch", "monitor", str(fleet), "--store", str(store)]
    processes = [
        subprocess.Popen([*command, "--method", "pca"], stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    codes = [p.wait(timeout=120) for p in processes]
    for p in processes:
        assert p.stdout is not None
        p.stdout.close()
    assert codes == [0, 0]
    pd.testing.assert_frame_equal(_results(store), _results(reference))
    connection = sqlite3.connect(store)
    assert connection.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    assert connection.execute("SELECT count(*) FROM baselines").fetchone()[0] == 2
    connection.close()


def test_lra_noise_level_option(fleet: Path, tmp_path: Path) -> None:
    store = str(tmp_path / "s.db")
    bad = runner.invoke(
        app, ["monitor", str(fleet), "--method", "lra", "--store", store, "--lra-noise-level=-1"]
    )
    assert bad.exit_code == 2
    words = " ".join(bad.output.replace("│", " ").split())  # rich wraps the message in a box
    assert (
        "Invalid value for '--lra-noise-level': expected a number > 0 or 'auto'; got '-1'" in words
    )
    auto = runner.invoke(
        app,
        ["monitor", str(fleet), "--method", "lra", "--store", store, "--lra-noise-level", "auto"],
    )
    assert auto.exit_code == 0, auto.output
    connection = sqlite3.connect(store)
    params = json.loads(connection.execute("SELECT params FROM baselines").fetchone()[0])
    connection.close()
    assert params["detector"]["noise_level"] == "auto"
