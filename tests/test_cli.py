"""The command-line interface, run as a user runs it (in this process, tests/_cli.py; the usage
error through ``python -m axiswatch``: the research group reached from the real entry point)."""

from __future__ import annotations

import subprocess
import sys

from tests._cli import run


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
