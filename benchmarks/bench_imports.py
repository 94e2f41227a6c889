"""Imports of a command line start: ``axiswatch --help`` and a monitor run with nothing new
(the default method, ``lra`` and ``pca``).

Run: ``.venv/bin/python benchmarks/bench_imports.py [repeats]``. Each start runs in a fresh
``python -X importtime``; its import time is the sum of the top-level modules' cumulative
times. Printed: the median over repeats, the heavy modules the start imported, and the ratio to
two references measured in the same run: importing ``typer`` alone (the CLI's own floor) and
importing every public name of the library (what every start paid when ``import axiswatch``
imported everything). The target is under 0.5 s for both starts.

Last run (2026-11-28 08:01, 2 cores, load 2.8-3.8, medians of 5): ``--help`` 0.065 s; idle
runs 0.38-0.44 s for the three methods (``lra`` and ``pca`` 1.00 s before, with SciPy and
scikit-learn). pandas and pyarrow remain: the capture, profile and store records import pandas
at module top.
"""

from __future__ import annotations

import contextlib
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

#: Modules a start should import only when a command needs them.
HEAVY = ("scipy", "sklearn", "pandas", "matplotlib", "plotly", "dask", "pyarrow")

_CLI = (
    "import sys\nsys.argv = ['axiswatch', *{args!r}]\n"
    "from axiswatch.cli import main\n"
    "try:\n    main()\nexcept SystemExit:\n    pass\n"
)
_EAGER = "import axiswatch as aw\nfor name in aw.__all__:\n    getattr(aw, name)\n"
_REPORT = f"\nimport sys\nprint('heavy:', [m for m in {HEAVY!r} if m in sys.modules])\n"


def import_seconds(code: str) -> tuple[float, str]:
    """Seconds of imports of ``code`` in a fresh interpreter, and its last line of output."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", code + _REPORT],
        capture_output=True,
        text=True,
        check=True,
    )
    total_us = 0
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line.removeprefix("import time:").split("|")
        if not name.startswith("  "):  # a top-level import (nested ones are indented)
            total_us += int(cumulative)
    return total_us / 1e6, done.stdout.strip().splitlines()[-1]


def _small_fleet(folder: Path, method: str = "indicators") -> tuple[Path, Path]:
    """A fleet of 2 robots x 2 axes x 8 days, monitored once with ``method``: a second run finds
    nothing new."""
    from axiswatch.cli import main

    root, store = folder / "fleet", folder / f"fleet-{method}.db"
    monitor = ["monitor", str(root), "--store", str(store), "--settle", "0", "--no-progress"]
    simulate = ["simulate", "fleet", str(root), "--robots", "2", "--days", "8", "--duration", "1"]
    for args in ([] if root.exists() else [simulate]) + [[*monitor, "--method", method]]:
        sys.argv = ["axiswatch", *args]
        with contextlib.suppress(SystemExit):
            main()
    return root, store


def main(repeats: int = 5) -> None:
    with tempfile.TemporaryDirectory() as folder:
        cases = {
            "floor: import typer": "import typer\n",
            "reference: every public name of axiswatch": _EAGER,
            "axiswatch --help": _CLI.format(args=["--help"]),
        }
        for method in ("indicators", "lra", "pca"):
            root, store = _small_fleet(Path(folder), method)
            idle = ["monitor", str(root), "--store", str(store), "--settle", "0", "--no-progress"]
            case = f"axiswatch monitor --method {method}, nothing new (2x2 axes)"
            cases[case] = _CLI.format(args=[*idle, "--method", method])
        results = {}
        for case, code in cases.items():
            runs = [import_seconds(code) for _ in range(repeats)]
            results[case] = (statistics.median(s for s, _ in runs), runs[0][1])
    floor = results["floor: import typer"][0]
    eager = results["reference: every public name of axiswatch"][0]
    print(f"{'case':<60} {'imports s':>9} {'/ floor':>8} {'/ eager':>8}  heavy modules")
    for case, (seconds, heavy) in results.items():
        print(f"{case:<60} {seconds:9.3f} {seconds / floor:8.1f} {seconds / eager:8.2f}  {heavy}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
