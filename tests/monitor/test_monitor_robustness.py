"""The monitor against hostile conditions (issue 11), each case through the real command line.

Every test runs the ``axiswatch`` command line as a user or a scheduler would, on a tiny simulated
fleet (1 robot x 1 axis x 5 captures of 0.5 s, PCA with 2 calibration captures), and checks that
no Python traceback reaches the user. The commands run in this process (tests/_cli.py: the same
command tree, exit status, stdout and stderr) except where the claim is about the process: signals
and a killed driver, a file-size limit, the Dask connection timeout.
"""

from __future__ import annotations

import errno
import itertools
import os
import resource
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
import axiswatch.monitor as awm
from tests._cli import Ran, run
from tests.conftest import settle

FAST = ("--method", "pca", "--calibration", "2")
AXIS = "robot01/axis1"


def _process(*args: object, **kwargs: object) -> subprocess.CompletedProcess[str]:
    """``python -m axiswatch ARGS`` in a process of its own: for claims about the process (a
    resource limit, a network timeout); every other command runs in this process (:func:`_run`)."""
    result = subprocess.run(
        [sys.executable, "-m", "axiswatch", *map(str, args)],
        capture_output=True,
        text=True,
        **kwargs,  # type: ignore[call-overload]
    )
    assert "Traceback" not in result.stdout + result.stderr, result.stderr
    return result  # type: ignore[no-any-return]


def _run(*args: object) -> Ran:
    result = run(*args)
    if "--debug" not in args:
        assert "Traceback" not in result.stdout + result.stderr, result.stderr
    return result


def _monitor(root: Path, store: Path, *extra: object) -> Ran:
    return _run("monitor", root, "--store", store, *FAST, *extra)


def _query(store: Path, sql: str) -> list[tuple[object, ...]]:
    connection = sqlite3.connect(store)
    try:
        return list(connection.execute(sql))
    finally:
        connection.close()


@pytest.fixture(scope="module")
def tiny_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("tiny") / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=5, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / "labels.csv").unlink()
    settle(root)
    return root


@pytest.fixture
def fleet(tiny_fleet: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(tiny_fleet, tmp_path / "fleet"))


def _variant(fleet: Path, name: str, change: object, source: str = "2026-03-04.parquet") -> Path:
    """A copy of one capture with its signals changed by ``change(name, values)``."""
    capture = aw.read_capture(fleet / AXIS / source)
    signals = {k: change(k, v.copy()) for k, v in capture.signals.items()}  # type: ignore[operator]
    path = aw.write_capture(aw.Capture(signals, capture.rates_hz), fleet / AXIS / name)
    settle(path.parent)
    return path


# --- row 1: an unreadable capture ------------------------------------------------------------


def test_unreadable_capture_is_rejected_others_go_on_and_it_is_retried(
    fleet: Path, tmp_path: Path
) -> None:
    # Reading /proc/self/mem at offset 0 fails with EIO: a genuine I/O error, even for root.
    target = fleet / AXIS / "2026-03-03.parquet"
    kept = tmp_path / "kept.parquet"
    shutil.move(target, kept)
    os.symlink("/proc/self/mem", target)
    store = tmp_path / "s.db"
    first = _monitor(fleet, store, "--settle", "0")
    assert first.returncode == 8, first.stdout + first.stderr
    assert f"{AXIS}/2026-03-03.parquet: cannot be read (Input/output error); tried again" in (
        first.stdout
    )
    assert "3 capture(s) scored" in first.stdout  # every other capture went on
    target.unlink()
    shutil.copy2(kept, target)  # the share is back
    second = _monitor(fleet, store, "--settle", "0")
    assert second.returncode == 0, second.stdout
    assert "1 capture(s) scored" in second.stdout
    assert _query(store, "SELECT count(*) FROM rejections") == [(0,)]


def test_malformed_robot_profile_rejects_its_robot_only_and_is_retried_once_fixed(
    tmp_path: Path,
) -> None:
    # Before: the profile's ValueError escaped the job and stopped the whole run (exit 1, one
    # line, no axis scored); and a rejection kept for the unchanged capture files would not have
    # been tried again after the profile was fixed.
    root = tmp_path / "fleet"
    awd.simulate_fleet(
        root, n_robots=2, n_axes=1, n_days=5, task_change_days=(), faults=[], duration_s=0.5
    )
    profile = root / "robot02" / "robot.toml"
    profile.write_text('resample_irregular = "no"\n')
    settle(root)
    store = tmp_path / "s.db"
    first = _monitor(root, store, "--settle", "0")
    assert first.returncode == 8, first.stdout + first.stderr
    assert "1 new baseline(s), 4 capture(s) scored" in first.stdout  # robot01's
    # One line for the profile's five captures (it was five identical lines but for the path),
    # the count in the heading still every rejected file.
    assert (
        "Rejected captures (5):\n  robot02/axis1/2026-03-01.parquet (and 4 more capture files "
        "with this reason): robot02/robot.toml: 'resample_irregular' must be true or "
        "false (unquoted); got 'no' (str).\n"
    ) in first.stdout
    profile.write_text("resample_irregular = false\n")
    second = _monitor(root, store, "--settle", "0")
    assert second.returncode == 0, second.stdout
    assert "1 new baseline(s), 4 capture(s) scored" in second.stdout  # robot02's
    assert _query(store, "SELECT count(*) FROM rejections") == [(0,)]


# --- rows 2, 9 and 11: options, rejections that depend on them, acknowledging ---------------


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        (("--signals", "position,speed,torqe"), "names ['torqe'], a column of none"),
        (("--signals", ","), "'signals' parameter must name at least one signal"),
        (("--hop", "0"), "'hop' parameter must be an int in [1, segment_length]"),
        (("--percentile", "100"), "'percentile' parameter must be a float in (0, 100)"),
        (("--alarm-k", "3", "--alarm-n", "2"), "needs 1 <= k <= n"),
        (("--baseline", "nosuch.csv"), "baseline capture 'nosuch.csv' is in no axis folder"),
        (("--stale-after", "soon"), "'--stale-after' option must be a duration"),
    ],
)
def test_invalid_options_exit_2_with_one_line_and_store_nothing(
    fleet: Path, tmp_path: Path, options: tuple[str, ...], expected: str
) -> None:
    store = tmp_path / "s.db"
    result = _run("monitor", fleet, "--store", store, "--method", "pca", *options)
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith("usage error: ")
    assert expected in result.stderr
    assert not store.exists()


def test_missing_or_empty_fleet_folder_is_an_error_and_creates_no_store(tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    missing = _run("monitor", tmp_path / "nowhere", "--store", store)
    assert missing.returncode == 1
    assert (
        missing.stderr
        == f"error: fleet folder '{tmp_path / 'nowhere'}' does not exist or is not a folder.\n"
    )
    (tmp_path / "mnt" / "robot01").mkdir(parents=True)  # an unmounted share: folders, no files
    empty = _run("monitor", tmp_path / "mnt", "--store", store)
    assert empty.returncode == 1
    assert "holds no capture file (an unmounted share or a wrong path?)" in empty.stderr
    assert not store.exists()


def test_rejection_under_other_parameters_is_retried_when_they_change(
    fleet: Path, tmp_path: Path
) -> None:
    store = tmp_path / "s.db"
    wrong = _monitor(fleet, store, "--segment-length", "100000", "--hop", "8")
    assert wrong.returncode == 8
    assert "capture too short for one STFT window" in wrong.stdout
    fixed = _monitor(fleet, store)
    assert fixed.returncode == 0, fixed.stdout
    assert "1 new baseline(s), 4 capture(s) scored" in fixed.stdout


def test_rejections_are_retried_when_the_axis_profile_is_added_or_fixed(tmp_path: Path) -> None:
    # Before: the rejections were kept for the unchanged capture files, so the run after the
    # profile was added (as the message advises) printed the same error; nothing said how to
    # try again.
    root = tmp_path / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=5, task_change_days=(), faults=[],
        duration_s=0.5, file_format="csv",
    )  # fmt: skip
    for path in (root / AXIS).glob("*.csv"):  # the controller's name of the time column
        path.write_text(path.read_text().replace("time,", "Timestamp,", 1))
    settle(root)
    store = tmp_path / "s.db"
    first = _monitor(root, store, "--settle", "0")
    assert first.returncode == 8, first.stdout + first.stderr
    assert "missing column 'time'" in first.stdout
    assert (
        "A rejected capture is tried again when its file, the options or its axis profile "
        f"change; to try again now: axiswatch rejections --store {store} --retry"
    ) in first.stdout
    profile = root / "robot01" / "robot.toml"
    profile.write_text('[columns]\n"Zeit" = "time"\n')  # added, but wrong
    wrong = _monitor(root, store, "--settle", "0")
    assert wrong.returncode == 8, wrong.stdout
    assert "0 capture(s) scored" in wrong.stdout
    profile.write_text('[columns]\n"Timestamp" = "time"\n')  # fixed
    fixed = _monitor(root, store, "--settle", "0")
    assert fixed.returncode == 0, fixed.stdout
    assert "1 new baseline(s), 4 capture(s) scored" in fixed.stdout
    assert _query(store, "SELECT count(*) FROM rejections") == [(0,)]
    again = _monitor(root, store, "--settle", "0")  # an unchanged profile changes nothing
    assert (again.returncode, "0 capture(s) scored" in again.stdout) == (0, True), again.stdout


def test_rejections_are_listed_acknowledged_and_retried(fleet: Path, tmp_path: Path) -> None:
    bad = fleet / AXIS / "2026-03-05T12-00-00_garbage.parquet"
    bad.write_bytes(b"PAR1 not parquet")
    settle(bad.parent)
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 8
    listed = _run("rejections", "--store", store)
    assert listed.returncode == 0
    assert f"{AXIS}/2026-03-05T12-00-00_garbage.parquet" in listed.stdout
    assert "cannot read Parquet file" in listed.stdout
    ack = _run(
        "rejections", "--store", store, "--ack", f"{AXIS}/2026-03-05T12-00-00_garbage.parquet"
    )
    assert ack.stdout.startswith("1 problem(s) acknowledged")
    quiet = _monitor(fleet, store)
    assert quiet.returncode == 0, quiet.stdout  # nothing new: exit 8 means something new
    assert "1 acknowledged problem(s) not shown" in quiet.stdout
    retry = _run("rejections", "--store", store, "--retry")
    assert retry.stdout.startswith("1 rejection(s) forgotten")
    again = _monitor(fleet, store)
    assert again.returncode == 8  # tried again, rejected again: news again
    assert "Rejected captures (1)" in again.stdout


def test_parameter_mismatch_names_the_differing_parameters(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    other = _monitor(fleet, store, "--percentile", "95", "--hop", "16")
    assert other.returncode == 1
    assert other.stderr.count("\n") == 1
    assert "(features.hop: 8 -> 16; percentile: 99.0 -> 95.0)" in other.stderr
    assert len(other.stderr) < 400


# --- row 3: folders, silence, order ----------------------------------------------------------


def test_symlinked_folders_are_followed_loops_and_dangling_links_reported(
    fleet: Path, tmp_path: Path
) -> None:
    elsewhere = Path(shutil.copytree(fleet / "robot01", tmp_path / "share" / "robot02"))
    os.symlink(elsewhere, fleet / "robot02")
    os.symlink(fleet, fleet / "robot01" / "loop")  # a link back to the root
    os.symlink(tmp_path / "unmounted", fleet / "robot03")
    store = tmp_path / "s.db"
    result = _monitor(fleet, store)
    assert result.returncode == 8, result.stdout
    assert "robot01/loop/: link to the folder already read as '.'" in result.stdout
    assert f"robot03/: link to '{tmp_path / 'unmounted'}', which does not exist" in result.stdout
    robots = _query(store, "SELECT DISTINCT robot FROM baselines ORDER BY robot")
    assert robots == [("robot01",), ("robot02",)]


def test_silent_axis_becomes_stale(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    four_days_ago = (datetime.now(UTC) - timedelta(days=4)).isoformat(timespec="seconds")
    connection = sqlite3.connect(store)  # no capture arrived for four days
    connection.execute("UPDATE axis_activity SET last_seen_at=?", (four_days_ago,))
    connection.commit()
    connection.close()
    stale = _monitor(fleet, store)
    assert stale.returncode == 8
    assert "robot01 axis1    pca" in stale.stdout
    assert " stale " in stale.stdout.splitlines()[2]  # the summary's row
    assert f"{AXIS}: stale, no new capture file for 4.0 d" in stale.stdout
    assert _monitor(fleet, store, "--stale-after", "5d").returncode == 0
    report = _run("report", "--store", store, "--out", tmp_path / "r")
    assert report.returncode == 0
    assert "data-kind='stale'" in (tmp_path / "r" / "index.html").read_text()


def test_capture_dated_before_the_baseline_is_reported(fleet: Path, tmp_path: Path) -> None:
    early = fleet / AXIS / "2026-03-01.parquet"
    kept = tmp_path / "early.parquet"
    shutil.move(early, kept)
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    shutil.copy2(kept, early)  # arrives late
    late = _monitor(fleet, store)
    assert late.returncode == 8
    assert (
        f"{AXIS}/2026-03-01.parquet: dated before the baseline 2026-03-02.parquet of epoch 1 and "
        "never scored (it arrived out of order)" in late.stdout
    )


def test_future_dated_capture_does_not_block_rebaselining(fleet: Path, tmp_path: Path) -> None:
    shutil.copy2(fleet / AXIS / "2026-03-04.parquet", fleet / AXIS / "2099-01-01.parquet")
    store = tmp_path / "s.db"
    first = _monitor(fleet, store)
    assert first.returncode == 8
    assert f"{AXIS}/2099-01-01.parquet: dated 2099-01-01T00:00:00, in the future" in first.stdout
    assert (
        _run("rebaseline", "--store", store, "--robot", "robot01", "--axis", "axis1").returncode
        == 0
    )
    shutil.copy2(fleet / AXIS / "2026-03-03.parquet", fleet / AXIS / "2026-03-06.parquet")
    after = _monitor(fleet, store)
    assert "1 new baseline(s)" in after.stdout
    assert _query(store, "SELECT capture FROM baselines WHERE epoch=2") == [("2026-03-06.parquet",)]


# --- row 4: data quality ---------------------------------------------------------------------


def test_degenerate_captures_get_a_data_quality_verdict_never_an_alarm(
    fleet: Path, tmp_path: Path
) -> None:
    def idle(name: str, values: np.ndarray) -> np.ndarray:
        return values.mean() + 1e-3 * (values - values.mean()) if name != "torque" else values

    def glitch(name: str, values: np.ndarray) -> np.ndarray:
        if name == "torque":
            values[500] = 1e300
        return values

    cases = {
        "2026-03-06.parquet": (idle, "bad data (no motion: position spans"),
        "2026-03-07.parquet": (
            lambda n, v: 0.0 * v,
            "bad data (flat/stuck signal: 'position' is 0",
        ),
        "2026-03-08.parquet": (
            lambda n, v: np.full_like(v, v[0]) if n == "torque" else v,
            "bad data (flat/stuck signal: 'torque'",
        ),
        "2026-03-09.parquet": (glitch, "bad data (out of range: signal 'torque' reads 1e+300"),
    }
    for name, (change, _) in cases.items():
        _variant(fleet, name, change)
    store = tmp_path / "s.db"
    result = _monitor(fleet, store)
    assert result.returncode == 8, result.stdout  # attention, not an alarm (4)
    for name, (_, reason) in cases.items():
        assert f"{AXIS}/{name}: {reason}" in result.stdout
    assert _query(store, "SELECT count(*) FROM scores WHERE alarm=1 OR over=1") == [(0,)]
    assert _query(store, "SELECT count(*) FROM scores WHERE capture >= '2026-03-06'") == [(0,)]
    assert " bad data " in result.stdout.splitlines()[2]  # the axis's state in the summary


@pytest.mark.parametrize("method", ["indicators", "pca"])
def test_a_torque_in_another_unit_or_one_glitch_is_bad_data_never_an_alarm(
    fleet: Path, tmp_path: Path, method: str
) -> None:
    # Before: the torque in mN m was a friction ALARM at a thousand times its allowance.
    def glitch(name: str, values: np.ndarray) -> np.ndarray:
        if name == "torque":
            values[300] *= 100.0  # one sample, far under OUT_OF_RANGE
        return values

    cases = {
        "2026-03-06.parquet": (  # 0.5 s of the task's cycle: 0.7 of the baseline's span
            lambda n, v: 1000.0 * v if n == "torque" else v,
            "bad data (scale changed: signal 'torque' scale changed by 701x (it spans",
        ),
        "2026-03-07.parquet": (glitch, "bad data (glitch: signal 'torque' reads "),
    }
    for name, (change, _) in cases.items():
        _variant(fleet, name, change)
    store = tmp_path / "s.db"
    result = _run("monitor", fleet, "--store", store, "--method", method, "--calibration", "2")
    assert result.returncode == 8, result.stdout  # attention, not an alarm (4)
    for name, (_, reason) in cases.items():
        assert f"{AXIS}/{name}: {reason}" in result.stdout
    assert _query(store, "SELECT count(*) FROM scores WHERE alarm=1 OR over=1") == [(0,)]
    assert _query(store, "SELECT count(*) FROM scores WHERE capture >= '2026-03-06'") == [(0,)]


# --- row 5: files still being written --------------------------------------------------------


def test_capture_still_being_written_waits_and_temporary_names_are_ignored(
    fleet: Path, tmp_path: Path
) -> None:
    source = (fleet / AXIS / "2026-03-04.parquet").read_bytes()
    (fleet / AXIS / "2026-03-06.parquet").write_bytes(source[: len(source) // 2])  # half written
    (fleet / AXIS / ".2026-03-07.parquet.tmp").write_bytes(source)
    (fleet / AXIS / "2026-03-08.parquet.partial").write_bytes(source)
    store = tmp_path / "s.db"
    # A settling time of 10 min, not the default 10 s: the half file must still be "being
    # written" when the run looks at it, however slowly a loaded machine starts the run (with
    # 10 s this failed under load); the other files were delivered an hour ago (``settle``).
    first = _monitor(fleet, store, "--settle", 600)
    assert first.returncode == 0, first.stdout
    assert "1 capture file(s) modified less than 600 s ago: waiting" in first.stdout
    assert "6 capture files" in first.stdout  # the temporary names are not captures
    (fleet / AXIS / "2026-03-06.parquet").write_bytes(source)  # complete now
    settle(fleet / AXIS)
    second = _monitor(fleet, store)
    assert second.returncode == 0, second.stdout
    assert "1 capture(s) scored" in second.stdout


def test_csv_capture_cut_off_in_a_row_is_rejected_never_scored_and_scored_once_whole(
    fleet: Path, tmp_path: Path
) -> None:
    # A logger that died mid-write leaves a file that settles but ends inside a row. Before:
    # scored as a shorter capture (seen as an ALARM on a simulated fleet's drive load).
    capture = aw.read_capture(fleet / AXIS / "2026-03-04.parquet")
    whole = aw.write_capture(capture, tmp_path / "whole.csv").read_text()
    target = fleet / AXIS / "2026-03-06.csv"
    row = whole.index("\n", len(whole) // 2) + 1  # a row's start, half-way through the file
    target.write_text(whole[: row + 5])  # five characters of its time stamp, no other field
    settle(target.parent)
    store = tmp_path / "s.db"
    first = _monitor(fleet, store)
    assert first.returncode == 8, first.stdout + first.stderr
    assert f"{AXIS}/2026-03-06.csv: ends inside a row" in first.stdout
    assert "ALARM" not in first.stdout
    assert _query(store, "SELECT count(*) FROM scores WHERE capture = '2026-03-06.csv'") == [(0,)]
    target.write_text(whole)  # the logger's next attempt delivers the whole file
    settle(target.parent)
    second = _monitor(fleet, store)
    assert second.returncode == 0, second.stdout
    assert "1 capture(s) scored" in second.stdout
    assert _query(store, "SELECT count(*) FROM scores WHERE capture = '2026-03-06.csv'") == [(1,)]


# --- row 6: workers end with the driver ------------------------------------------------------


def _children(pid: int) -> set[int]:
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.add(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has ended; only its exit status waits to be collected


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_workers_end_with_the_driver(fleet: Path, tmp_path: Path, sig: signal.Signals) -> None:
    for day in range(6, 10):  # more captures, so that the workers are busy when the driver dies
        shutil.copy2(fleet / AXIS / "2026-03-04.parquet", fleet / AXIS / f"2026-03-0{day}.parquet")
    command = [sys.executable, "-m", "axiswatch", "monitor", str(fleet), "--store"]
    driver = subprocess.Popen(
        [*command, str(tmp_path / "s.db"), "--method", "lra", "--workers", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers: set[int] = set()
    deadline = time.monotonic() + 120
    while len(workers) < 2 and driver.poll() is None and time.monotonic() < deadline:
        workers |= _children(driver.pid)
        time.sleep(0.05)
    assert workers, "the driver ended before its workers were seen"
    driver.send_signal(sig)
    driver.wait(timeout=60)
    deadline = time.monotonic() + 30
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if _alive(pid)]


@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_mid_run_is_one_line_exit_130_and_the_next_run_ends_it(
    fleet: Path, tmp_path: Path, workers: int
) -> None:
    # Many more captures, so that the run is still scoring when stopped: on a loaded machine the
    # polling below can be descheduled long enough for 20 PCA captures to be scored (the signal
    # then met a run already shutting down).
    for month, day in itertools.product(range(3, 7), range(10, 30)):
        name = f"2026-{month:02d}-{day}.parquet"
        shutil.copy2(fleet / AXIS / "2026-03-04.parquet", fleet / AXIS / name)
    reference = tmp_path / "reference.db"
    assert _monitor(fleet, reference).returncode == 0
    store = tmp_path / "s.db"
    command = [sys.executable, "-m", "axiswatch", "monitor", str(fleet), "--store", str(store)]
    # A shell starts a background job with Ctrl-C ignored, and an ignored signal stays ignored
    # across exec: a suite run in the background would start a driver deaf to it. A handled
    # signal is reset to its default by exec, so the driver sees Ctrl-C as a foreground job does.
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        driver = subprocess.Popen(
            [*command, *FAST, "--workers", str(workers)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,  # its own process group, as a terminal's foreground job
        )
    finally:
        signal.signal(signal.SIGINT, inherited)
    deadline = time.monotonic() + 120
    while driver.poll() is None and time.monotonic() < deadline:
        try:
            if store.exists() and _query(store, "SELECT count(*) FROM scores") > [(1,)]:
                break  # scoring: past start-up, imports and the baseline's fit
        except sqlite3.OperationalError:
            pass  # the store is being created
        time.sleep(0.01)
    assert driver.poll() is None, "the run ended before it could be interrupted"
    os.killpg(driver.pid, signal.SIGINT)  # Ctrl-C reaches the driver and its workers
    _, stderr = driver.communicate(timeout=60)
    assert driver.returncode == 130, stderr
    assert stderr.startswith("interrupted: "), stderr
    assert len(stderr.splitlines()) == 1, stderr  # no worker's traceback either
    assert _monitor(fleet, store).returncode == 0
    with aw.Store(store, read_only=True) as resumed, aw.Store(reference, read_only=True) as whole:
        assert resumed.score_table().equals(whole.score_table())
    assert _query(store, "PRAGMA integrity_check") == [("ok",)]


# --- row 7: a wrong Dask address -------------------------------------------------------------


@contextmanager
def _answering(answer: bytes) -> Iterator[int]:
    """A TCP port that answers every connection with ``answer`` (no Dask message)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    stop = threading.Event()

    def serve() -> None:
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except TimeoutError:
                continue
            connection.sendall(answer)
            time.sleep(0.5)
            connection.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield int(server.getsockname()[1])
    stop.set()
    thread.join()
    server.close()


@pytest.fixture
def chatter() -> Iterator[int]:
    with _answering(b"\xff" * 64 + b"HTTP/1.1 400 Bad Request\r\n\r\n") as port:
        yield port


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_wrong_dask_address_fails_within_the_timeout_with_one_line(
    fleet: Path, tmp_path: Path, chatter: int
) -> None:
    pytest.importorskip("distributed")
    store = tmp_path / "s.db"
    for port in (_free_port(), chatter):
        address = f"tcp://127.0.0.1:{port}"
        result = _process(
            "monitor", fleet, "--store", store, "--dask", address, "--dask-timeout", "2",
            timeout=120,
        )  # fmt: skip
        assert result.returncode == 1
        assert result.stderr.startswith(f"error: no Dask scheduler answered at '{address}'")
        assert result.stderr.count("\n") == 1, result.stderr
        assert not store.exists()


def test_another_service_on_the_dask_port_is_named_in_one_line(fleet: Path, tmp_path: Path) -> None:
    # Before: an HTTP answer's first bytes, read as a Dask frame length, gave "Unable to
    # allocate 3.07 EiB for an array ..." as the reason.
    pytest.importorskip("distributed")
    store = tmp_path / "s.db"
    with _answering(b"HTTP/1.1 400 Bad Request\r\n\r\n") as port:
        address = f"tcp://127.0.0.1:{port}"
        result = _process("monitor", fleet, "--store", store, "--dask", address, timeout=120)
    assert result.returncode == 1
    assert result.stderr == (
        f"error: no Dask scheduler answered at '{address}': another service answers there "
        "(its answer is no Dask message); check the host and port of the scheduler.\n"
    )
    assert not store.exists()


# --- row 8: a corrupt store, a full disk -----------------------------------------------------


def test_corrupt_store_is_one_line_and_exit_1_traceback_with_debug(
    fleet: Path, tmp_path: Path
) -> None:
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    data = bytearray(store.read_bytes())
    data[4096:] = b"\x5a" * (len(data) - 4096)  # every page after the first overwritten
    store.write_bytes(bytes(data))
    result = _monitor(fleet, store)
    assert result.returncode == 1
    assert result.stderr.startswith(f"error: store '{store}': ")
    assert "corrupt" in result.stderr or "not a database" in result.stderr
    assert result.stderr.count("\n") == 1
    assert "Traceback" in _monitor(fleet, store, "--debug").stderr


def test_full_disk_is_one_line_and_exit_1(fleet: Path, tmp_path: Path) -> None:
    # A file-size limit makes the store's writes fail as on a full disk (Python ignores SIGXFSZ).
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (60_000, 60_000))

    store = tmp_path / "s.db"
    result = _process("monitor", fleet, "--store", store, *FAST, preexec_fn=limit)
    assert result.returncode == 1
    assert result.stderr.startswith(f"error: store '{store}': ")
    assert "is the disk full or failing?" in result.stderr
    assert result.stderr.count("\n") == 1


# --- row 10: one default ---------------------------------------------------------------------


def test_library_and_command_default_to_the_same_method(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "cli.db"
    by_command = _run("monitor", fleet, "--store", store, "--settle", "0")
    with awm.Store(tmp_path / "lib.db") as opened:
        direct = [awm.monitor_fleet(fleet, opened, settle_s=0).method, awm.MonitorConfig().method]
    assert direct == ["indicators", "indicators"]
    # Five 0.5 s captures: the axis is still calibrating (the baseline and 5 captures are fitted
    # together), so the command's first line is what names its method.
    assert by_command.stdout.startswith("indicators: 5 capture files"), by_command.stdout


# --- row 11: the report is written atomically ------------------------------------------------


def test_report_page_is_replaced_atomically(fleet: Path, tmp_path: Path) -> None:
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    out = tmp_path / "report"
    out.mkdir()
    (out / "index.html").write_text("the previous page")
    os.link(out / "index.html", tmp_path / "reader.html")  # a reader holding the old page
    assert _run("report", "--store", store, "--out", out).returncode == 0
    assert (tmp_path / "reader.html").read_text() == "the previous page"  # never overwritten
    assert "axiswatch fleet report" in (out / "index.html").read_text()
    assert not list(out.glob(".*.tmp"))


def test_a_misnamed_folder_is_one_rejection_and_scored_once_renamed(
    fleet: Path, tmp_path: Path
) -> None:
    bad = fleet / "robot 2"
    shutil.copytree(fleet / "robot01", bad)
    settle(bad / "axis1")
    store = tmp_path / "s.db"
    first = _monitor(fleet, store)
    assert first.returncode == 8, first.stdout + first.stderr
    rows = _query(store, "SELECT path, error FROM rejections")
    assert len(rows) == 1, rows  # one line for the folder, not one per file
    path, error = rows[0]
    assert path == "robot 2/"
    assert str(error).startswith("robot 2/: robot folder name 'robot 2' is not an identifier")
    assert "its 5 capture file(s)" in str(error)
    assert first.stdout.count("robot 2/") == 1, first.stdout
    listed = _run("rejections", "--store", store)
    assert listed.stdout.count("is not an identifier") == 1, listed.stdout
    # A store from before kept one rejection per file of the folder: the folder's replaces them.
    connection = sqlite3.connect(store)
    with connection:
        connection.execute(
            "INSERT INTO rejections (robot, axis, method, capture, path, file_hash, error, "
            "rejected_at, kind, params_hash, transient) VALUES ('robot 2', 'axis1', 'pca', "
            "'2026-03-01.parquet', 'robot 2/axis1/2026-03-01.parquet', 'x', 'old', "
            "'2026-03-01T00:00:00', 'layout', NULL, 0)"
        )
    connection.close()
    again = _monitor(fleet, store)
    assert again.returncode == 8  # still misnamed: still reported, still once
    assert _query(store, "SELECT count(*) FROM rejections") == [(1,)]
    bad.rename(fleet / "robot02")
    fixed = _monitor(fleet, store)
    assert fixed.returncode == 0, fixed.stdout
    assert _query(store, "SELECT count(*) FROM rejections") == [(0,)]
    assert _query(store, "SELECT count(*) FROM scores WHERE robot = 'robot02'") == [(5,)]


def test_report_on_a_full_disk_leaves_nothing_behind(
    fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = tmp_path / "s.db"
    assert _monitor(fleet, store).returncode == 0
    out = tmp_path / "report"
    out.mkdir()
    (out / "index.html").write_text("the previous page")
    written = Path.write_bytes

    def full_disk(path: Path, data: bytes) -> int:
        # The disk fills half-way through the page, as a write of a full disk stops.
        written(path, data[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(Path, "write_bytes", full_disk)
    result = run("report", "--store", store, "--out", out)
    assert result.returncode == 1
    assert "No space left on device" in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["index.html"]  # no temporary file left
    assert (out / "index.html").read_text() == "the previous page"
