"""The research package's commands: ``axiswatch-lab ...`` and, as a plugin, ``axiswatch experiment ...``.

Maps options to the experiments of :mod:`axiswatch_lab`; no science here.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

experiment_app = typer.Typer(
    help="Reproduce the paper's experiments and the real-data evaluations.",
    no_args_is_help=True,
)


def _print_lab(seed: int) -> None:
    from axiswatch_lab._experiments import lab_distances

    table = lab_distances(seed=seed)
    typer.echo("Lab dataset (paper): day 1 is the baseline; day 4 carries the torque anomaly;")
    typer.echo("days 6-8 run the second operation (must not alarm).\n")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    flagged = table[table.alarm].groupby("method").label.apply(list).to_dict()
    for method in ("lra", "pca"):
        typer.echo(f"{method}: alarms on {flagged.get(method, [])}")


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


def _save_alarms(table: Any, out: Path) -> None:
    from axiswatch_lab._experiments import alarm_summary

    alarms = alarm_summary(table)
    alarms.to_csv(out / "alarms.csv", index=False)
    typer.echo("\nAlarms (threshold: 99th percentile of days 2-6):")
    typer.echo(alarms.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    typer.echo(f"Wrote {out / 'alarms.csv'}")


@experiment_app.command("roc")
def experiment_roc(
    out: Path = _OUT,
    seed: int = _SEED,
    repetitions: int = typer.Option(10, help="Runs with fresh noise averaged (paper: 10)."),
) -> None:
    """Lab dataset ROC (paper fig. 2): TPR/FPR of LRA and PCA per calibration protocol."""
    from axiswatch_lab._experiments import lab_roc
    from axiswatch_lab._plots import plot_roc

    table = lab_roc(seed=seed, n_repetitions=repetitions)
    _save(table, plot_roc(table), out, "roc")


@experiment_app.command("robot-a")
def experiment_robot_a(
    out: Path = _OUT,
    seed: int = _SEED,
    days: int = typer.Option(190, help="Daily captures (paper: 190)."),
) -> None:
    """Robot A (paper fig. 3): healthy axis, task changes on days 30, 87 and 125."""
    from axiswatch_lab._experiments import robot_a
    from axiswatch_lab._plots import plot_robot_study

    table = robot_a(seed=seed, n_days=days)
    _save(table, plot_robot_study(table, "Robot A"), out, "robot_a")
    _save_alarms(table, out)


@experiment_app.command("robot-b")
def experiment_robot_b(
    out: Path = _OUT,
    seed: int = _SEED,
    days: int = typer.Option(148, help="Daily captures before the breakdown (paper: 148)."),
    fault: str = typer.Option("bearing", help="backlash, friction, tooth or bearing."),
) -> None:
    """Robot B (paper fig. 4): one task, a fault growing until breakdown."""
    from axiswatch_lab._experiments import robot_b
    from axiswatch_lab._plots import plot_robot_study

    table = robot_b(seed=seed, n_days=days, fault=fault)  # type: ignore[arg-type]
    _save(table, plot_robot_study(table, "Robot B"), out, "robot_b")
    _save_alarms(table, out)


def _real_data_experiment(
    name: str,
    data: Path | None,
    out: Path,
    baseline_conditions: list[str] | None,
    methods: list[str] | None,
) -> None:
    from axiswatch.datasets import default_data_dir, read_dataset
    from axiswatch_lab._realdata import (
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


@experiment_app.command("cwru-lines")
def experiment_cwru_lines(
    data: Annotated[
        Path | None, typer.Option("--data", help=_DATA_HELP.format("cwru_12k_de"))
    ] = None,
    out: Annotated[Path, typer.Option("--out", help="Folder for lines.csv, summary.csv.")] = Path(
        "out"
    ),
) -> None:
    """The default's bearing-line indicator on CWRU (raw band and envelope), fault vs healthy."""
    from axiswatch.datasets import default_data_dir
    from axiswatch_lab._realdata import bearing_line_readings, summarize_line_readings

    folder = default_data_dir("cwru_12k_de") if data is None else data
    try:
        readings = bearing_line_readings(folder)
    except (OSError, ValueError) as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from exc
    summary = summarize_line_readings(readings)
    out.mkdir(parents=True, exist_ok=True)
    readings.to_csv(out / "lines.csv", index=False)
    summary.to_csv(out / "summary.csv", index=False)
    typer.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(f"\nwrote {out / 'lines.csv'}, {out / 'summary.csv'}")


@experiment_app.command("paired")
def experiment_paired(
    out: Path = _OUT,
    seed: int = _SEED,
    per_cell: int = typer.Option(3, help="Captures per (task, health) cell."),
    oracle: bool = typer.Option(True, help="Also fit on each test task's own healthy capture."),
) -> None:
    """Paired evaluation: does a detector see the fault rather than the task? (beyond the paper)"""
    from axiswatch_lab._paired import PairedDesign, paired_evaluation
    from axiswatch_lab._plots import plot_paired

    table = paired_evaluation(PairedDesign(n_per_cell=per_cell, seed=seed), oracle=oracle)
    _save(table, plot_paired(table), out, "paired")


@experiment_app.command("select")
def experiment_select(out: Path = _OUT) -> None:
    """Choose the product default: rank every feature stage x detector on the development design."""
    from axiswatch_lab._paired import development_scales, select_default

    ranking = select_default()
    out.mkdir(parents=True, exist_ok=True)
    ranking.to_csv(out / "selection.csv", index=False)
    typer.echo(ranking.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    scales = ", ".join(f"{v:.4g}" for v in development_scales())
    typer.echo(f"\nMechanics indicator scales on the development design: ({scales})")
    typer.echo(f"Wrote {out / 'selection.csv'}")


@experiment_app.command("transfer")
def experiment_transfer(
    out: Annotated[Path, typer.Option("--out", help="Folder for the tables (CSV).")],
    robots: Annotated[
        str, typer.Option(help="'held-out' (reported), 'development' (for choices) or seeds 1,2.")
    ] = "held-out",
    fast: Annotated[bool, typer.Option(help="Small configuration (seconds per robot).")] = False,
    data: Annotated[
        Path | None, typer.Option("--data", help="Folder of the real data sets (../shared/data).")
    ] = None,
    workers: Annotated[int, typer.Option(help="Processes for the robots.")] = 1,
    kinematics: Annotated[
        bool,
        typer.Option(help="Give the model each robot's true kinematics (an AxisProfile)."),
    ] = True,
    order_lines: Annotated[
        bool,
        typer.Option(help="Also score the order lines against each baseline's order spectrum."),
    ] = False,
    whole_moves: Annotated[
        bool,
        typer.Option(
            help="Models at the opt-in operating point IndicatorModel(whole_moves=True): loads "
            "from whole moves, loose friction readings widened (docs/evaluation.md)."
        ),
    ] = False,
    real_data: Annotated[
        bool | None,
        typer.Option(
            "--real-data/--no-real-data",
            help="Also score the real data sets (default: only with --robots held-out, so that "
            "a development run never reads them).",
        ),
    ] = None,
    unit_spread: Annotated[
        float,
        typer.Option(
            min=0.0,
            help="Each fleet axis, Robot A and each baseline's test captures a unit of its own, "
            "friction, backlash, stiffness, damping and motor inertia varying by this log "
            "standard deviation (0: one unit, docs/evaluation.md 'A fleet of distinct units').",
        ),
    ] = 0.0,
) -> None:
    """Transfer study: held-out simulated robots and the real data sets."""
    from axiswatch.datasets import default_data_dir
    from axiswatch_lab._transfer import (
        FAST_DESIGN,
        TransferDesign,
        real_data_transfer,
        transfer_study,
    )

    seeds = _robot_seeds(robots)
    design = dataclasses.replace(
        FAST_DESIGN if fast else TransferDesign(),
        kinematics=kinematics,
        order_lines=order_lines,
        whole_moves=whole_moves,
        unit_spread=unit_spread,
    )
    table = transfer_study(seeds, design, workers=workers)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "robots.csv", index=False)
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.2f}"))
    if not (robots == "held-out" if real_data is None else real_data):
        typer.echo(f"\nwrote {out / 'robots.csv'} (real data not read: --real-data reads it)")
        return
    folder = data if data is not None else default_data_dir("hydraulic_actuator").parent
    real = real_data_transfer(folder, order_lines=order_lines, whole_moves=whole_moves)
    real.to_csv(out / "real.csv", index=False)
    if len(real):
        typer.echo("\n" + real.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(f"\nwrote {out / 'robots.csv'}, {out / 'real.csv'}")


def _robot_seeds(robots: str, *, held_out: bool = True) -> tuple[int, ...]:
    """``--robots``: 'held-out' (when ``held_out``), 'development' (robots 0-7) or
    comma-separated seeds; else exit 2, one line."""
    from axiswatch.datasets import DEVELOPMENT_ROBOTS, HELD_OUT_ROBOTS

    if robots == "held-out" and held_out:
        return HELD_OUT_ROBOTS
    if robots == "development":
        return DEVELOPMENT_ROBOTS
    try:
        return tuple(int(s) for s in robots.split(","))
    except ValueError:
        words = "'held-out', 'development'" if held_out else "'development'"
        typer.echo(
            f"error: --robots must be {words} or seeds such as 1,2; got {robots!r}.", err=True
        )
        raise typer.Exit(2) from None


def _development_or_seeds(robots: str) -> tuple[int, ...]:
    """``--robots`` of a study for choices: 'development' or seeds, never the held-out set."""
    return _robot_seeds(robots, held_out=False)


@experiment_app.command("nearest-task")
def experiment_nearest_task(
    out: Annotated[Path, typer.Option("--out", help="Folder for the table (CSV).")],
    robots: Annotated[
        str,
        typer.Option(help="'development' (robots 0-7, the only ones for choices) or seeds 1,2."),
    ] = "development",
    unit_spread: Annotated[
        float,
        typer.Option(
            min=0.0,
            help="Log standard deviation between the units (--units-per-task per task in the "
            "fleet; 0: one unit, where the variant is the oracle by construction).",
        ),
    ] = 0.1,
    units_per_task: Annotated[
        int, typer.Option(min=2, help="Distinct units per task in the fleet (same-task pairs).")
    ] = 2,
    fast: Annotated[bool, typer.Option(help="Small configuration (seconds per robot).")] = False,
    workers: Annotated[int, typer.Option(help="Processes for the robots.")] = 1,
) -> None:
    """Nearest task (lab): a task change scored against the fleet axis that runs that task."""
    from axiswatch_lab._transfer import FAST_DESIGN, TransferDesign
    from axiswatch_lab.studies.nearest_task_not_adopted import nearest_task_study

    seeds = _development_or_seeds(robots)
    design = dataclasses.replace(
        FAST_DESIGN if fast else TransferDesign(robot_a_days=48),
        degradation_days=0,
        unit_spread=unit_spread,
    )
    table = nearest_task_study(seeds, design, workers=workers, units_per_task=units_per_task)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "robots.csv", index=False)
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(f"\nwrote {out / 'robots.csv'}")


@experiment_app.command("ceiling")
def experiment_ceiling(
    out: Annotated[Path, typer.Option("--out", help="Folder for the tables (CSV).")],
    robots: Annotated[
        str,
        typer.Option(help="'development' (robots 0-7, the only ones for choices) or seeds 1,2."),
    ] = "development",
    per_cell: Annotated[int, typer.Option(help="Captures per (task, health) cell.")] = 10,
    severity: Annotated[float, typer.Option(help="The faults' severity (the study's: 0.6).")] = 0.6,
    workers: Annotated[int, typer.Option(help="Processes for the robots.")] = 1,
    permuted_labels: Annotated[
        bool,
        typer.Option(help="Shuffle the health labels within each task: the ceiling of no signal."),
    ] = False,
    top: Annotated[
        int,
        typer.Option(help="Most important features listed per fault and set (0: none, faster)."),
    ] = 5,
    repeats: Annotated[
        int,
        typer.Option(
            min=1, help="Permutations per feature and fold of the permutation importance."
        ),
    ] = 5,
) -> None:
    """A supervised ceiling: cross-validated classifiers, faulty vs healthy captures."""
    from axiswatch_lab._transfer import TransferDesign
    from axiswatch_lab.studies.supervised_ceiling import ceiling_study, ceiling_summary

    seeds = _development_or_seeds(robots)
    design = TransferDesign(n_per_cell=per_cell, severity=severity)
    aurocs, features = ceiling_study(
        seeds, design, workers=workers, permuted=permuted_labels, n_top=top, n_repeats=repeats
    )
    summary = ceiling_summary(aurocs)
    out.mkdir(parents=True, exist_ok=True)
    aurocs.to_csv(out / "aurocs.csv", index=False)
    features.to_csv(out / "top_features.csv", index=False)
    summary.to_csv(out / "summary.csv", index=False)
    typer.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    typer.echo(f"\nwrote {out / 'aurocs.csv'}, {out / 'top_features.csv'}, {out / 'summary.csv'}")


def _words(option: str, given: str, allowed: tuple[str, ...]) -> tuple[str, ...]:
    """Comma-separated words of ``allowed``; else exit 2 with one line naming the option."""
    words = tuple(w for w in given.split(",") if w)
    unknown = [w for w in words if w not in allowed]
    if unknown:
        typer.echo(
            f"error: {option} takes some of {', '.join(allowed)}; got {unknown[0]!r}.", err=True
        )
        raise typer.Exit(2)
    return words


@experiment_app.command("modes")
def experiment_modes(
    out: Annotated[Path, typer.Option("--out", help="Folder for modes.csv and robots.csv.")],
    robots: Annotated[
        str, typer.Option(help="'development' (robots 0-7), 'held-out' (reported) or seeds 1,2.")
    ] = "development",
    cases: Annotated[
        str | None,
        typer.Option(
            help="Some of robot-a, growing, fault-at-change, within, cross-task, monitor, "
            "real-data (default: all; real-data only with --robots held-out)."
        ),
    ] = None,
    faults: Annotated[
        str, typer.Option(help="Faults grown in the library's runs.")
    ] = "backlash,friction,tooth,bearing",
    monitor_faults: Annotated[
        str, typer.Option(help="Fault runs through the monitor (none: the healthy run only).")
    ] = "friction,backlash",
    robot_a_days: Annotated[int, typer.Option(min=20, help="Robot A's daily captures.")] = 190,
    growing_days: Annotated[
        int,
        typer.Option(min=21, help="Days of a growing fault's run (task change at 2/7, onset 3/7)."),
    ] = 70,
    teach: Annotated[
        bool, typer.Option(help="Also replay with an engineer teaching alarms after a change.")
    ] = False,
    test_captures: Annotated[
        int,
        typer.Option(min=3, help="Captures per task and fault of the within and cross-task cases."),
    ] = 6,
    data: Annotated[
        Path | None, typer.Option("--data", help="Folder of the real data sets (../shared/data).")
    ] = None,
) -> None:
    """Operating modes: the mode library and --modes against the default, in time order."""
    from axiswatch.datasets import default_data_dir
    from axiswatch_lab._modes_experiment import CASES, ModesDesign, modes_experiment, summarize
    from axiswatch_lab.studies.mode_library_vs_default import FAULTS

    seeds = _robot_seeds(robots)
    if cases is None:
        chosen = CASES if robots == "held-out" else tuple(c for c in CASES if c != "real-data")
    else:
        chosen = _words("--cases", cases, CASES)
    design = ModesDesign(
        robot_a_days=robot_a_days,
        growing_days=growing_days,
        faults=_words("--faults", faults, FAULTS),  # type: ignore[arg-type]
        monitor_faults=_words("--monitor-faults", monitor_faults, FAULTS),
        teach=teach,
        test_captures=test_captures,
    )
    folder = data if data is not None else default_data_dir("hydraulic_actuator").parent
    table = modes_experiment(seeds, design, chosen, folder)
    summary = summarize(table)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "robots.csv", index=False)
    summary.to_csv(out / "modes.csv", index=False)
    typer.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if "real-data" in chosen and not summary["scenario"].str.startswith("real").any():
        typer.echo(f"\nno real data under {folder}: skipped")
    typer.echo(f"\nwrote {out / 'modes.csv'}, {out / 'robots.csv'}")


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
    """Entry point of the ``axiswatch-lab`` script (the same commands as ``axiswatch experiment``)."""
    sys.exit(experiment_app())
