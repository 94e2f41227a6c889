"""A monitor run with nothing new imports none of the model stacks it does not use."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from pathlib import Path

import pytest

from axiswatch.cli import main

#: Modules only fitting and scoring need; a run that does neither must not import them.
MODEL_STACKS = ("scipy", "sklearn", "axiswatch_lab")

_IDLE = """import sys
sys.argv = ['axiswatch', 'monitor', {root!r}, '--store', {store!r}, '--settle', '0',
            '--no-progress', '--method', {method!r}]
from axiswatch.cli import main
try:
    main()
except SystemExit as exit:
    print('exit', exit.code)
print(sorted(m for m in {heavy!r} if m in sys.modules))
"""


def _run(*args: str) -> None:
    sys.argv = ["axiswatch", *args]
    with contextlib.suppress(SystemExit):
        main()


@pytest.mark.parametrize("method", ["indicators", "lra", "pca"])
def test_a_run_with_nothing_new_imports_no_model_stack(tmp_path: Path, method: str) -> None:
    # Every method's stored parameters are read without its model: the paper's methods give
    # their detector's parameters without making the scikit-learn estimator.
    root, store = tmp_path / "fleet", tmp_path / "fleet.db"
    days = "7" if method == "indicators" else "2"  # the paper's methods fit one baseline
    _run("simulate", "fleet", str(root), "--robots", "1", "--days", days, "--duration", "1")
    monitor = ["monitor", str(root), "--store", str(store), "--settle", "0", "--no-progress"]
    _run(*monitor, "--method", method)
    code = _IDLE.format(root=str(root), store=str(store), heavy=MODEL_STACKS, method=method)
    shown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "0 capture(s) scored" in shown.stdout or "0 capture files" in shown.stdout
    exit_line, imported = shown.stdout.splitlines()[-2:]
    assert exit_line in ("exit 0", "exit 4"), shown.stdout + shown.stderr  # 4: an axis alarms
    assert imported == "[]"
