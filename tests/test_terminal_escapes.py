"""File names that hold terminal control sequences are printed escaped, never raw.

A name with ``ESC [ 2 J`` clears a terminal, ``ESC ] 0 ; ... BEL`` sets its title; either, printed
raw by a command, acts on the terminal of whoever reads the fleet's results.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import axiswatch.datasets as awd
from axiswatch.cli import printable
from tests._cli import Ran, run
from tests.conftest import settle

SCORED = "2026-03-04_\x1b[2J\x1b[31mred.parquet"
REJECTED = "2026-03-05_\x1b]0;title\x07.csv"
#: Control characters a terminal acts on: ESC, BEL, CSI (C1), and a right-to-left override.
RAW = ("\x1b", "\x07", "\x9b", "\u202e")


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Ran]:
    """The store of a fleet holding both names, and the monitor run that wrote it."""
    folder = tmp_path_factory.mktemp("escapes")
    root = folder / "fleet"
    awd.simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=4, task_change_days=(), faults=[], duration_s=0.5
    )
    axis = root / "robot01" / "axis1"
    (axis / "2026-03-04.parquet").rename(axis / SCORED)
    (axis / REJECTED).write_text("time,speed\n0,oops\n")
    settle(root)
    path = folder / "s.db"
    monitor = run("monitor", root, "--store", path, "--method", "pca", "--calibration", "2")
    assert monitor.returncode == 8, monitor.stdout + monitor.stderr
    return path, monitor


def _shown(result: Ran) -> str:
    text = result.stdout + result.stderr
    assert not [c for c in RAW if c in text], text
    return text


def test_the_monitor_summary_escapes_file_names(store: tuple[Path, Ran]) -> None:
    # Before: the rejected file's name reached the terminal raw (ESC ] 0 ; title BEL).
    text = _shown(store[1])
    assert "2026-03-05_\\x1b]0;title\\x07.csv" in text


@pytest.mark.parametrize("output", ["table", "csv"])
def test_results_escape_file_names(store: tuple[Path, Ran], output: str) -> None:
    # Before: `results` printed the scored capture's name raw (ESC [ 2 J cleared the screen).
    text = _shown(run("results", "--store", store[0], "--format", output))
    assert "2026-03-04_\\x1b[2J\\x1b[31mred.parquet" in text


def test_rejections_escape_file_names(store: tuple[Path, Ran]) -> None:
    text = _shown(run("rejections", "--store", store[0]))
    assert "2026-03-05_\\x1b]0;title\\x07.csv" in text


def test_printable_keeps_lines_and_text_and_escapes_controls() -> None:
    assert printable("r1/a1: ok\n  naïve 名前\n") == "r1/a1: ok\n  naïve 名前\n"
    assert printable("a\x1b[2Jb\x9b\u202ec\td\r") == "a\\x1b[2Jb\\x9b\\u202ec\\x09d\\x0d"
