"""The commands that need no data of yours: ``simulate fleet`` and ``demo``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from axiswatch.cli._options import DEBUG
from axiswatch.cli._terminal import echo
from axiswatch.cli._terminal import failures as _failures
from axiswatch.cli._terminal import progress as _progress

__all__ = ["demo", "simulate_fleet_command"]


def simulate_fleet_command(
    out: Annotated[Path, typer.Argument(help="Output folder (the fleet ROOT).")],
    robots: int = typer.Option(3, help="Number of robots."),
    axes: int = typer.Option(2, help="Axes per robot."),
    days: int = typer.Option(30, help="Days, one capture per axis and day."),
    start_date: str = typer.Option("2026-03-01", help="ISO date of day 1."),
    seed: int = typer.Option(0, help="Seed of the simulation."),
    file_format: str = typer.Option("parquet", "--format", help="parquet or csv."),
    duration: float = typer.Option(3.0, help="Seconds per capture."),
    debug: bool = DEBUG,
) -> None:
    """Simulate a small fleet (task change on day 15, developing faults); labels in labels.csv."""
    from axiswatch.datasets._robot_fleet import simulate_fleet

    with _failures(debug):
        labels = simulate_fleet(
            out,
            n_robots=robots,
            n_axes=axes,
            n_days=days,
            start_date=start_date,
            seed=seed,
            file_format=file_format,  # type: ignore[arg-type]
            duration_s=duration,
        )
        faulty = labels[labels.fault != "none"].groupby(["robot", "axis"]).fault.first()
        echo(f"Wrote {len(labels)} captures to {out} (labels in {out / 'labels.csv'}).")
        for row in faulty.reset_index().itertuples(index=False):
            echo(f"  developing fault: {row.robot}/{row.axis} {row.fault}")


def demo(
    out: Annotated[
        Path | None, typer.Option(help="Working folder (default: a temporary one).")
    ] = None,
    days: int = typer.Option(30, help="Days of the simulated fleet."),
    seed: int = typer.Option(0, help="Seed of the simulation."),
    debug: bool = DEBUG,
) -> None:
    """Simulate a fleet, monitor it (default method, LRA, PCA), write the report and summary."""
    import tempfile

    from axiswatch.datasets._robot_fleet import simulate_fleet
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.monitor._methods import DEFAULT_METHOD
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor.report.html import write_report
    from axiswatch.monitor.report.summary import verdict_lines
    from axiswatch.monitor.store import Store

    with _failures(debug):
        folder = Path(tempfile.mkdtemp(prefix="axiswatch-demo-")) if out is None else out
        folder.mkdir(parents=True, exist_ok=True)
        root = folder / "fleet"
        echo(f"Simulating a fleet into {root} ...")
        labels = simulate_fleet(root, n_days=days, seed=seed)
        with Store(folder / "fleet.db") as opened, _progress(True) as update:
            for method in (DEFAULT_METHOD, "lra", "pca"):
                # The simulator has just written every file completely: nothing to wait for.
                config = MonitorConfig(method=method)
                monitor_fleet(root, opened, config, progress=update, settle_s=0)
            echo("")
            for line in verdict_lines(opened, DEFAULT_METHOD, None):
                echo(line)
            paper = [a for a in opened.alarms() if a.method != DEFAULT_METHOD]
            runs = 2 * len(labels[["robot", "axis"]].drop_duplicates())
            echo(
                f"The paper's methods (lra, pca), kept for comparison: {len(paper)} of {runs} "
                "axis results in alarm; they alarm on task changes too (the report folds them)."
            )
            page = write_report(opened, folder / "report", labels=labels)
        truth = labels[labels.fault != "none"].groupby(["robot", "axis"]).date.min()
        changes = labels[labels.task.ne(labels.groupby(["robot", "axis"]).task.shift())]
        later = sorted(set(changes.date) - {labels.date.min()})
        echo("\nGround truth (simulator labels, not seen by the monitor):")
        echo(f"  task changes (must not alarm) on {', '.join(later) or 'no day'}")
        echo("  developing faults (should alarm):")
        for row in truth.reset_index().itertuples(index=False):
            echo(f"    {row.robot}/{row.axis} from {row.date}")
        echo(f"\nReport: {page}")
