"""The lab's commands through the product's CLI, run as a user runs it (in this process; the usage
error through ``python -m axiswatch``: the research group reached from the real entry point)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from lab_cli import run


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "axiswatch", *args], capture_output=True, text=True
    )


def test_experiment_lab_prints_lab_verdicts() -> None:
    result = run("experiment", "lab")
    assert result.returncode == 0, result.stderr
    assert "lra: alarms on ['A']" in result.stdout


def test_unknown_option_is_a_usage_error() -> None:
    result = _run("experiment", "lab", "--colour", "red")
    assert result.returncode == 2
    assert "No such option" in result.stderr


def test_the_lab_script_runs_through_the_launcher() -> None:
    installed = Path(sys.executable).parent / "axiswatch-lab"
    done = subprocess.run(
        [str(installed), "--help"], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "Usage:" in done.stdout
    assert "robot-a" in done.stdout
