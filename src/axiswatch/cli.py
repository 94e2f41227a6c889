"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success; 1 a command failed (message on stderr); 2 usage error (unknown option).
"""

from __future__ import annotations

import sys

import typer

app = typer.Typer(
    help="axiswatch: predictive maintenance of robot axes that does not cry wolf on a task change.",
    no_args_is_help=True,
    add_completion=False,
)


@app.command()
def demo(seed: int = typer.Option(0, help="Seed of the lab dataset's noise.")) -> None:
    """Run the paper's lab experiment end to end and print every day's verdict."""
    from axiswatch._experiments import lab_distances

    table = lab_distances(seed=seed)
    typer.echo("Lab dataset (paper): day 1 is the baseline; day 4 carries the torque anomaly;")
    typer.echo("days 6-8 run the second operation (must not alarm).\n")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    flagged = table[table.alarm].groupby("method").label.apply(list).to_dict()
    for method in ("lra", "pca"):
        typer.echo(f"{method}: alarms on {flagged.get(method, [])}")


@app.callback()
def _root() -> None:
    """axiswatch command-line tool."""


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    sys.exit(app())
