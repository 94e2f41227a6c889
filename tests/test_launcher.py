"""The console scripts' launcher: a Ctrl-C while the packages import is one line, exit 130."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path
from types import ModuleType

import pytest

from axiswatch_launcher import INTERRUPTED, launch


def _interrupted_import(name: str) -> ModuleType:
    raise KeyboardInterrupt  # Ctrl-C while NumPy, SciPy and pandas import


def test_ctrl_c_during_the_import_is_one_line_and_exit_130(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys, "argv", ["axiswatch", "monitor", "fleet"])
    with pytest.raises(SystemExit) as stopped:
        launch("axiswatch.cli:main", importer=_interrupted_import)
    assert stopped.value.code == 130
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == INTERRUPTED + "\n"
    assert captured.err.startswith("interrupted: ")


def test_ctrl_c_inside_the_command_before_its_own_handler_is_one_line_too(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupted_main() -> None:
        raise KeyboardInterrupt  # e.g. while the plugins' commands load

    module = ModuleType("fake_cli")
    module.main = interrupted_main  # type: ignore[attr-defined]
    monkeypatch.setattr(sys, "argv", ["axiswatch", "--help"])
    with pytest.raises(SystemExit) as stopped:
        launch("fake_cli:main", importer=lambda name: module)
    assert stopped.value.code == 130
    assert capsys.readouterr().err == INTERRUPTED + "\n"


def test_debug_shows_the_traceback_of_an_interrupted_import(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(sys, "argv", ["axiswatch", "monitor", "fleet", "--debug"])
    with pytest.raises(KeyboardInterrupt):
        launch("axiswatch.cli:main", importer=_interrupted_import)


def test_the_command_exit_status_passes_through(monkeypatch: pytest.MonkeyPatch) -> None:
    def main() -> None:
        sys.exit(8)

    module = ModuleType("fake_cli")
    module.main = main  # type: ignore[attr-defined]
    with pytest.raises(SystemExit) as stopped:
        launch("fake_cli:main", importer=lambda name: module)
    assert stopped.value.code == 8


@pytest.mark.parametrize(
    ("script", "target"),
    [("axiswatch", "axiswatch_launcher:axiswatch")],
)
def test_the_console_scripts_go_through_the_launcher(script: str, target: str) -> None:
    (entry,) = entry_points(group="console_scripts", name=script)
    assert entry.value == target
    installed = Path(sys.executable).parent / script
    done = subprocess.run(
        [str(installed), "--help"], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "Usage:" in done.stdout


def _run_under_python_m(folder: Path, cli: str, timeout: float) -> subprocess.CompletedProcess[str]:
    """Launch ``interrupted_cli:main`` (source ``cli``) through the launcher, by ``python -m``."""
    (folder / "interrupted_cli.py").write_text(cli, encoding="utf-8")
    (folder / "run_it.py").write_text(
        "from axiswatch_launcher import launch\nlaunch('interrupted_cli:main')\n", encoding="utf-8"
    )
    return subprocess.run(
        [sys.executable, "-m", "run_it"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def test_python_m_exits_130_after_an_interrupt_that_crossed_an_exec(tmp_path: Path) -> None:
    # CPython records a KeyboardInterrupt that leaves an exec() of a string (a dataclass or a
    # namedtuple made while a module imports mid-run), and `python -m` then ended by SIGINT:
    # status -2, not 130, although the launcher had caught it and printed its line.
    cli = "def main():\n    exec('raise KeyboardInterrupt')\n"
    done = _run_under_python_m(tmp_path, cli, timeout=60)
    assert done.returncode == 130, done.stderr
    assert done.stderr == INTERRUPTED + "\n"


def test_a_command_interrupted_across_an_exec_exits_130_under_python_m(tmp_path: Path) -> None:
    # The same, caught by a command's own handler (the monitor's), not by the launcher.
    cli = (
        "import typer\n"
        "from axiswatch.cli._terminal import failures\n"
        "def interrupted():\n"
        "    with failures(debug=False):\n"
        "        exec('raise KeyboardInterrupt')\n"
        "def main():\n"
        "    app = typer.Typer()\n"
        "    app.command()(interrupted)\n"
        "    app()\n"
    )
    done = _run_under_python_m(tmp_path, cli, timeout=120)
    assert done.returncode == 130, done.stderr
    assert done.stderr == INTERRUPTED + "\n"
