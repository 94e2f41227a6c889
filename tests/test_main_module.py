"""``python -m axiswatch`` goes through the console scripts' launcher (``axiswatch_launcher``)."""

from __future__ import annotations

import runpy
import sys

import pytest

import axiswatch.cli
from axiswatch_launcher import INTERRUPTED


def test_ctrl_c_after_the_package_import_is_one_line_and_exit_130(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # Before: __main__ called axiswatch.cli.main directly, so a Ctrl-C while the plugins'
    # commands load (about 1 s of `python -m axiswatch --help`) ended in a traceback. The
    # package's own import runs before __main__ and cannot be covered (see its docstring).
    def interrupted() -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(axiswatch.cli, "main", interrupted)
    monkeypatch.setattr(sys, "argv", ["axiswatch", "--help"])
    monkeypatch.delitem(sys.modules, "axiswatch.__main__", raising=False)
    try:
        with pytest.raises(SystemExit) as stopped:
            runpy.run_module("axiswatch", run_name="__main__")
    except KeyboardInterrupt:  # escaped: a traceback for the user (and it would stop pytest)
        pytest.fail("a Ctrl-C after the package import escaped python -m axiswatch")
    assert stopped.value.code == 130
    assert capsys.readouterr().err == INTERRUPTED + "\n"


def test_the_exit_status_of_the_command_passes_through(monkeypatch: pytest.MonkeyPatch) -> None:
    def done() -> None:
        sys.exit(8)

    monkeypatch.setattr(axiswatch.cli, "main", done)
    monkeypatch.delitem(sys.modules, "axiswatch.__main__", raising=False)
    with pytest.raises(SystemExit) as stopped:
        runpy.run_module("axiswatch", run_name="__main__")
    assert stopped.value.code == 8
