"""benchmarks/run.py --quick keeps running (no assertion on timings: speed lives in the benchmark)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

RUN = Path(__file__).resolve().parents[1] / "benchmarks" / "run.py"


def test_quick_benchmark_runs() -> None:
    done = subprocess.run(
        [sys.executable, str(RUN), "--quick"], capture_output=True, text=True, check=True
    )
    lines = done.stdout.splitlines()
    assert lines[1].startswith("case")
    assert [line.split()[0] for line in lines[2:]] == ["LRA", "3", "3", "3", "3", "fleet"]
    assert "mechanics indicators" in lines[4]
    assert "scoring job (indicators)" in lines[5]
    assert "(indicators)" in lines[7]  # the fleet case runs the product default


def test_quick_memory_benchmark_runs() -> None:
    done = subprocess.run(
        [sys.executable, str(RUN), "--memory", "--quick"],
        capture_output=True,
        text=True,
        check=True,
    )
    rows = done.stdout.splitlines()[2:]
    assert [row.split()[:2] for row in rows] == [["3", "s"], ["60", "s"]]
    assert all(row.endswith("scored; the other axes' new captures scored") for row in rows)


def test_quick_modes_case_runs() -> None:
    done = subprocess.run(
        [sys.executable, str(RUN), "--quick", "--case", "job-3s-indicators-modes-profile"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "scoring job (indicators --modes, profile) vs floor" in done.stdout
