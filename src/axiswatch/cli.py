"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success; 1 a command failed (message on stderr); 2 usage error (unknown option).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

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


_OUT = typer.Option(..., "--out", help="Folder for the figure (PNG) and the table (CSV).")
_SEED = typer.Option(0, "--seed", help="Seed of every random draw of the experiment.")


def _save(table: Any, figure: Any, out: Path, stem: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / f"{stem}.csv", index=False)
    figure.savefig(out / f"{stem}.png", dpi=120, bbox_inches="tight")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    typer.echo(f"\nWrote {out / (stem + '.csv')} and {out / (stem + '.png')}")


@experiment_app.command("roc")
def experiment_roc(
    out: Path = _OUT,
    seed: int = _SEED,
    repetitions: int = typer.Option(10, help="Runs with fresh noise averaged (paper: 10)."),
) -> None:
    """Lab dataset ROC (paper fig. 2): TPR/FPR of LRA and PCA per calibration protocol."""
    from axiswatch._experiments import lab_roc
    from axiswatch._plotting import plot_roc

    table = lab_roc(seed=seed, n_repetitions=repetitions)
    _save(table, plot_roc(table), out, "roc")


@experiment_app.command("robot-a")
def experiment_robot_a(
    out: Path = _OUT,
    seed: int = _SEED,
    days: int = typer.Option(190, help="Daily captures (paper: 190)."),
) -> None:
    """Robot A (paper fig. 3): healthy axis, task changes on days 30, 87 and 125."""
    from axiswatch._experiments import robot_a
    from axiswatch._plotting import plot_robot_study

    table = robot_a(seed=seed, n_days=days)
    _save(table, plot_robot_study(table, "Robot A"), out, "robot_a")


@experiment_app.command("robot-b")
def experiment_robot_b(
    out: Path = _OUT,
    seed: int = _SEED,
    days: int = typer.Option(148, help="Daily captures before the breakdown (paper: 148)."),
    fault: str = typer.Option("bearing", help="backlash, friction, tooth or bearing."),
) -> None:
    """Robot B (paper fig. 4): one task, a fault growing until breakdown."""
    from axiswatch._experiments import robot_b
    from axiswatch._plotting import plot_robot_study

    table = robot_b(seed=seed, n_days=days, fault=fault)  # type: ignore[arg-type]
    _save(table, plot_robot_study(table, "Robot B"), out, "robot_b")


def _real_data_experiment(
    name: str,
    data: Path | None,
    out: Path,
    baseline_conditions: list[str] | None,
    methods: list[str] | None,
) -> None:
    from axiswatch._datasets import default_data_dir, read_dataset
    from axiswatch._realdata import (
        CWRU_FEATURES,
        GEARBOX_FEATURES,
        evaluate_dataset,
        plot_distances,
    )

    folder = default_data_dir(name) if data is None else data
    try:
        segments = read_dataset(folder)
        distances, table = evaluate_dataset(
            segments,
            GEARBOX_FEATURES if name.startswith("gearbox") else CWRU_FEATURES,
            baseline_conditions=baseline_conditions or None,
            methods=methods or None,
        )
    except (OSError, ValueError) as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from exc
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "summary.csv", index=False)
    distances.to_csv(out / "distances.csv", index=False)
    plot_distances(distances).savefig(out / "distances.png", dpi=80)
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(f"\nwrote {out / 'summary.csv'}, {out / 'distances.csv'}, {out / 'distances.png'}")


_DATA_HELP = (
    "Dataset folder (index.csv, days.csv, .npz); default ../shared/data/{} from the project root."
)
Out = Annotated[
    Path, typer.Option("--out", help="Folder for summary.csv, distances.csv, distances.png.")
]
BaselineConditions = Annotated[
    list[str] | None,
    typer.Option(
        "--baseline-condition",
        help="Baseline condition (repeat for several); default every condition with enough healthy data.",
    ),
]
Methods = Annotated[
    list[str] | None,
    typer.Option(
        "--method", help="Method (repeat for several): pca, lra, energy, coral, sa; default all."
    ),
]


@experiment_app.command("gearbox")
def experiment_gearbox(
    data: Annotated[
        Path | None, typer.Option("--data", help=_DATA_HELP.format("gearbox_spectraquest"))
    ] = None,
    out: Out = Path("out"),
    baseline_condition: BaselineConditions = None,
    method: Methods = None,
) -> None:
    """Gearbox (healthy vs broken tooth at several loads): baseline on one load, test on all."""
    _real_data_experiment("gearbox_spectraquest", data, out, baseline_condition, method)


@experiment_app.command("cwru")
def experiment_cwru(
    data: Annotated[
        Path | None, typer.Option("--data", help=_DATA_HELP.format("cwru_12k_de"))
    ] = None,
    out: Out = Path("out"),
    baseline_condition: BaselineConditions = None,
    method: Methods = None,
) -> None:
    """CWRU bearings (healthy only at 0 HP): fault sensitivity across loads."""
    _real_data_experiment("cwru_12k_de", data, out, baseline_condition, method)


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    sys.exit(app())
