"""Run ``axiswatch`` in this process, as ``python -m axiswatch`` runs it, without its start-up.

A subprocess pays 1-2 s of imports per command (NumPy, SciPy, pandas); most command-line tests
run several commands, so the suite spent minutes starting Python. :func:`run` invokes the same
click command tree (with the entry-point groups, such as ``experiment``) through click's test
runner and returns what a subprocess returns: the exit status, stdout and stderr apart.

Use a real process where the claim is about the process: signals, Ctrl-C, a killed driver,
resource limits, worker processes, the ``python -m`` entry point and the console scripts.

An exception that escapes the command (only with ``--debug``, or a bug) is appended to stderr as
the interpreter prints an uncaught one, with exit status 1, so that the tests' "no traceback
reaches the user" checks read the same text as with a subprocess.
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from importlib.metadata import entry_points

import typer
from typer.core import TyperGroup
from typer.testing import CliRunner

from axiswatch.cli import PLUGIN_GROUP, app


@dataclass(frozen=True)
class Ran:
    """One command's outcome, with the fields of ``subprocess.CompletedProcess`` tests read."""

    args: list[str]
    returncode: int
    stdout: str
    stderr: str


@cache
def command() -> TyperGroup:
    """The click command tree of ``axiswatch``, with the entry-point groups (``experiment``).

    Built once, with every group loaded (the script loads a group when it is used)."""
    tree = typer.main.get_command(app)
    assert isinstance(tree, TyperGroup)
    for entry in entry_points(group=PLUGIN_GROUP):
        tree.add_command(typer.main.get_command(entry.load()), entry.name)
    return tree


def run(*args: object, env: Mapping[str, str] | None = None, input: str | None = None) -> Ran:
    """Run ``axiswatch ARGS...`` here; the words are ``str(arg)`` as a subprocess passes them.

    The terminal is 80 columns wide (``COLUMNS``), as for a subprocess whose output is a pipe;
    ``env`` is set for the command's duration only. Typer's ``CliRunner.invoke`` takes only a
    Typer app, not the tree with the entry-point groups, so its isolation is used directly.
    """
    words = [str(arg) for arg in args]
    escaped = ""
    with CliRunner().isolation(input=input, env={"COLUMNS": "80", **(env or {})}) as streams:
        try:
            command().main(args=words, prog_name="axiswatch")
            status = 0
        except SystemExit as exit_:
            if exit_.code is None or isinstance(exit_.code, int):
                status = exit_.code or 0
            else:  # sys.exit("message"): the interpreter prints it and exits with 1
                print(exit_.code, file=sys.stderr)
                status = 1
        except Exception as exc:  # printed as the interpreter prints an uncaught exception
            escaped = "".join(traceback.format_exception(exc))
            status = 1
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
        stdout, stderr = (stream.getvalue().decode() for stream in streams[:2])
    return Ran(words, status, stdout, stderr + escaped)
