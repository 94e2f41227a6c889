"""Run ``axiswatch`` in this process with the lab's commands, found by their entry point."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib.metadata import entry_points

import typer
from click.testing import CliRunner
from typer.core import TyperGroup

from axiswatch.cli import PLUGIN_GROUP, app


@dataclass(frozen=True)
class Ran:
    """One command's outcome, with the fields of ``subprocess.CompletedProcess`` tests read."""

    returncode: int
    stdout: str
    stderr: str


@cache
def command() -> TyperGroup:
    """The product's command tree with the entry-point groups (the lab's ``experiment``)."""
    tree = typer.main.get_command(app)
    assert isinstance(tree, TyperGroup)
    for entry in entry_points(group=PLUGIN_GROUP):
        tree.add_command(typer.main.get_command(entry.load()), entry.name)
    return tree


def run(*args: object) -> Ran:
    """Run ``axiswatch ARGS...`` here; the words are ``str(arg)`` as a subprocess passes them."""
    result = CliRunner().invoke(command(), [str(arg) for arg in args], env={"COLUMNS": "80"})
    return Ran(result.exit_code, result.stdout, result.stderr)
