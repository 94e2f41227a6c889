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
experiment_app = typer.Typer(
    help="Reproduce the paper's experiments and the real-data evaluations.",
    no_args_is_help=True,
)
app.add_typer(experiment_app, name="experiment")


def _print_lab(seed: int) -> None:
    from axiswatch._experiments import lab_distances

    table = lab_distances(seed=seed)
    typer.echo("Lab dataset (paper): day 1 is the baseline; day 4 carries the torque anomaly;")
    typer.echo("days 6-8 run the second operation (must not alarm).\n")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    flagged = table[table.alarm].groupby("method").label.apply(list).to_dict()
    for method in ("lra", "pca"):
        typer.echo(f"{method}: alarms on {flagged.get(method, [])}")


@app.command()
def demo(seed: int = typer.Option(0, help="Seed of the lab dataset's noise.")) -> None:
    """Run the main job end to end (for now: the paper's lab experiment)."""
    _print_lab(seed)


@experiment_app.command("lab")
def experiment_lab(seed: int = typer.Option(0, help="Seed of the lab dataset's noise.")) -> None:
    """Distance of every day of the paper's lab dataset to day 1, with verdicts."""
    _print_lab(seed)


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    sys.exit(app())
