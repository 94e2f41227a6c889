"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success; 1 a command failed (message on stderr; traceback only with ``--debug``);
2 usage error (unknown option). ``monitor`` adds 4 when an axis is in alarm and 8 when a capture
was rejected, a scored file changed or an axis cannot be scored (so 4, 8 or 12).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any, Literal

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
simulate_app = typer.Typer(
    help="Write simulated captures in the fleet layout.", no_args_is_help=True
)
app.add_typer(simulate_app, name="simulate")

DEBUG = typer.Option(False, "--debug", help="Show Python tracebacks of failures.")
StorePath = Annotated[
    Path, typer.Option("--store", help="SQLite store of the monitor (created if new).")
]


@contextmanager
def _failures(debug: bool) -> Iterator[None]:
    """Turn expected failures into one line on stderr and exit status 1 (unless ``--debug``)."""
    from axiswatch.exceptions import AxiswatchError

    try:
        yield
    except (AxiswatchError, ValueError, OSError, NotImplementedError) as exc:
        if debug:
            raise
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from None


@contextmanager
def _progress(enabled: bool) -> Iterator[Callable[[str, int, int], None]]:
    """A rich progress bar on stderr, shown only when stderr is a terminal."""
    from rich.console import Console
    from rich.progress import Progress

    console = Console(stderr=True)
    with Progress(console=console, disable=not (enabled and console.is_terminal)) as bar:
        tasks: dict[str, Any] = {}

        def update(stage: str, done: int, total: int) -> None:
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
            bar.update(tasks[stage], completed=done, total=total)

        yield update


class Method(StrEnum):
    lra = "lra"
    pca = "pca"
    mechanics = "mechanics"


class Format(StrEnum):
    table = "table"
    csv = "csv"
    json = "json"


def _print_lab(seed: int) -> None:
    from axiswatch._experiments import lab_distances

    table = lab_distances(seed=seed)
    typer.echo("Lab dataset (paper): day 1 is the baseline; day 4 carries the torque anomaly;")
    typer.echo("days 6-8 run the second operation (must not alarm).\n")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    flagged = table[table.alarm].groupby("method").label.apply(list).to_dict()
    for method in ("lra", "pca"):
        typer.echo(f"{method}: alarms on {flagged.get(method, [])}")


def _echo_summary(store: Any) -> None:
    from axiswatch._results import fleet_summary

    summary = fleet_summary(store)
    if summary.empty:
        typer.echo("No axis has a baseline yet.")
        return
    typer.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.4g}"))


@app.command()
def monitor(
    root: Annotated[Path, typer.Argument(help="Fleet folder ROOT/<robot>/<axis>/<capture>.<ext>.")],
    store: StorePath,
    method: Annotated[
        Method,
        typer.Option(
            help="Distance: the physical indicators (default, docs/evaluation.md), the paper's "
            "LRA, or PCA."
        ),
    ] = Method.mechanics,
    percentile: float = typer.Option(99.0, help="Threshold percentile of the half-Laplace fit."),
    calibration: int = typer.Option(5, help="Captures after the baseline that set the threshold."),
    alarm_k: int = typer.Option(1, help="Alarm when K of the last N captures are over..."),
    alarm_n: int = typer.Option(1, help="...the threshold (K = N = 1 as in the paper)."),
    clear_m: int = typer.Option(1, help="An alarm clears after M clean captures in a row."),
    baseline: str | None = typer.Option(
        None, help="File name of the baseline capture of new axes (default: their first)."
    ),
    signals: str = typer.Option("position,speed,torque", help="Signal columns, comma-separated."),
    hop: int = typer.Option(8, help="Samples between STFT slices."),
    segment_length: int = typer.Option(128, help="STFT window length in samples."),
    lra_noise_level: str = typer.Option(
        "1.0", help="LRA's lambda: a number (1 is the paper's form) or 'auto' (from the baseline)."
    ),
    align: bool = typer.Option(True, help="Align each capture's phase to the baseline's."),
    workers: int = typer.Option(1, help="Local worker processes for scoring."),
    dask: str | None = typer.Option(None, help="Dask scheduler address for scoring."),
    progress: bool = typer.Option(True, help="Progress bar on stderr (only on a terminal)."),
    debug: bool = DEBUG,
) -> None:
    """Score every capture not scored yet; print the fleet's state.

    Exit status: 0 nothing to report; 4 an axis is in alarm; 8 a capture was rejected, a scored
    file changed or an axis cannot be scored; 12 both; 1 failure; 2 usage error.
    """
    from axiswatch._features import FeatureSpec
    from axiswatch._monitor import monitor_fleet
    from axiswatch._scoring import MonitorConfig
    from axiswatch._store import Store

    with _failures(debug):
        config = MonitorConfig(
            method=method.value,
            percentile=percentile,
            calibration_size=calibration,
            alarm_k=alarm_k,
            alarm_n=alarm_n,
            clear_m=clear_m,
            baseline=baseline,
            features=FeatureSpec(
                signals=tuple(s.strip() for s in signals.split(",") if s.strip()),
                hop=hop,
                segment_length=segment_length,
            ),
            lra_noise_level=_noise_level(lra_noise_level),
            align_phase=align,
        )
        with Store(store) as opened, _progress(progress) as update:
            result = monitor_fleet(
                root, opened, config, workers=workers, dask=dask, progress=update
            )
            typer.echo(
                f"{result.method}: {result.n_files} capture files, {result.new_baselines} new "
                f"baseline(s), {result.scored} capture(s) scored in this run."
            )
            _echo_summary(opened)
        for title, lines in (
            ("Rejected captures", result.rejected),
            ("Changed files", result.changed),
            ("Axes not scored", result.axis_problems),
        ):
            if lines:
                typer.echo(f"\n{title} ({len(lines)}):")
                for line in lines:
                    typer.echo(f"  {line}")
        if result.acknowledged:
            typer.echo(f"\nAcknowledged alarms ({result.method}), not counted in the exit status:")
            for seen in result.acknowledged:
                typer.echo(
                    f"  {seen.robot}/{seen.axis} since {seen.raised_capture}: seen by "
                    f"{seen.acknowledged_by} at {seen.acknowledged_at}: {seen.note}"
                )
        if result.alarms:
            axes = ", ".join(f"{robot}/{axis}" for robot, axis in result.alarms)
            typer.echo(f"\nALARM ({result.method}) on {axes}")
    raise typer.Exit(result.exit_code)


@app.command()
def results(
    store: StorePath,
    robot: str | None = typer.Option(None, help="Only this robot."),
    axis: str | None = typer.Option(None, help="Only this axis."),
    output: Annotated[Format, typer.Option("--format", help="table, csv or json.")] = Format.table,
    indicators: bool = typer.Option(
        False, help="Table: one column per indicator, its shift in healthy spreads."
    ),
    debug: bool = DEBUG,
) -> None:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Then captured_at, epoch, role, over, reason, details (JSON: for the default method each
    indicator's value, baseline, shift in healthy spreads and share of the distance) and
    top_indicator. The table shows the first seven, role and top_indicator.
    """
    import json

    from axiswatch._results import fleet_results, indicator_spreads
    from axiswatch._store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            frame = fleet_results(opened, robot=robot, axis=axis)
        columns = ["robot", "axis", "capture", "method", "distance", "threshold", "alarm"]
        if output is Format.csv:
            typer.echo(frame.to_csv(index=False, float_format="%.17g"), nl=False)
        elif output is Format.json:
            records = frame.assign(details=frame["details"].map(json.loads))
            typer.echo(records.to_json(orient="records", indent=1))
        elif frame.empty:
            typer.echo("No scored captures.")
        else:
            table = frame[[*columns, "role", "top_indicator"]].fillna({"top_indicator": ""})
            if indicators:
                table = table.join(indicator_spreads(frame))
            typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))


def _noise_level(text: str) -> float | Literal["auto"]:
    if text == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0:
        raise typer.BadParameter(
            f"expected a number > 0 or 'auto'; got {text!r}.", param_hint="'--lra-noise-level'"
        )
    return value


def _require_store(store: Path) -> None:
    if not store.is_file():
        raise FileNotFoundError(f"store '{store}' does not exist; run 'axiswatch monitor' first.")


@app.command()
def report(
    store: StorePath,
    out: Annotated[Path, typer.Option(help="Folder for index.html and the PNG figures.")],
    debug: bool = DEBUG,
) -> None:
    """Write a self-contained HTML report (fleet summary, one trend figure per axis)."""
    from axiswatch._report import write_report
    from axiswatch._store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            page = write_report(opened, out)
        typer.echo(f"Report: {page}")


@app.command()
def rebaseline(
    store: StorePath,
    robot: str = typer.Option(..., help="Robot folder name."),
    axis: str = typer.Option(..., help="Axis folder name."),
    method: Annotated[Method | None, typer.Option(help="Only this method (default: all).")] = None,
    from_capture: str | None = typer.Option(
        None, "--from", help="File name of the new baseline (default: the next new capture)."
    ),
    debug: bool = DEBUG,
) -> None:
    """Retire an axis's baseline after maintenance; the next monitor run fits a new one."""
    from axiswatch._ledger import rebaseline as retire
    from axiswatch._store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            methods = retire(
                opened,
                robot,
                axis,
                method=None if method is None else method.value,
                from_capture=from_capture,
            )
        start = from_capture or "the next capture that arrives"
        typer.echo(
            f"{robot}/{axis}: baseline retired ({', '.join(methods)}); the next monitor run "
            f"starts a new baseline at {start}."
        )


@app.command()
def ack(
    store: StorePath,
    robot: str | None = typer.Option(None, help="Robot folder name (required unless --list)."),
    axis: str | None = typer.Option(None, help="Axis folder name (required unless --list)."),
    method: Annotated[
        Method | None, typer.Option(help="Only this method (default: every one in alarm).")
    ] = None,
    by: str | None = typer.Option(None, "--by", help="Who saw the alarm (required)."),
    note: str | None = typer.Option(None, "--note", help="What was seen or done (required)."),
    rebaseline: bool = typer.Option(
        False,
        "--rebaseline",
        help="Maintenance is done: also retire the baseline, as 'axiswatch rebaseline' does.",
    ),
    from_capture: str | None = typer.Option(
        None, "--from", help="With --rebaseline: file name of the new baseline."
    ),
    list_: bool = typer.Option(
        False, "--list", help="List the acknowledgements (of --robot/--axis if given) instead."
    ),
    debug: bool = DEBUG,
) -> None:
    """Record that an alarm was seen: it no longer makes monitor exit 4 until raised again.

    The report shows who saw it. With --rebaseline (after maintenance) the axis's baseline is
    also retired; the next monitor run starts a new one (see 'axiswatch rebaseline').
    """
    from axiswatch._ledger import rebaseline as retire
    from axiswatch._store import Store

    if list_:
        with _failures(debug):
            _require_store(store)
            with Store(store) as opened:
                frame = opened.acknowledgements(robot, axis)
            if frame.empty:
                typer.echo("No acknowledgements.")
            else:
                typer.echo(frame.fillna("").to_string(index=False))
        return
    robot, axis, by, note = (
        _required(value, hint)
        for value, hint in ((robot, "--robot"), (axis, "--axis"), (by, "--by"), (note, "--note"))
    )
    if from_capture is not None and not rebaseline:
        raise typer.BadParameter("only with --rebaseline.", param_hint="'--from'")
    chosen = None if method is None else method.value
    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            if rebaseline:
                # Retire first: it checks the request (active baseline, --from not alarmed)
                # before anything is written, so a refused request records nothing.
                retire(opened, robot, axis, method=chosen, from_capture=from_capture)
            methods = opened.acknowledge(
                robot, axis, by=by, note=note, method=chosen, rebaseline=rebaseline
            )
        typer.echo(f"{robot}/{axis}: acknowledged ({', '.join(methods)}) by {by}.")
        if rebaseline:
            start = from_capture or "the next capture that arrives"
            typer.echo(f"Baseline retired; the next monitor run starts a new baseline at {start}.")


def _required(value: str | None, hint: str) -> str:
    if value is None:
        raise typer.BadParameter("required unless --list.", param_hint=f"'{hint}'")
    return value


@simulate_app.command("fleet")
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
    from axiswatch._robot import simulate_fleet

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
        typer.echo(f"Wrote {len(labels)} captures to {out} (labels in {out / 'labels.csv'}).")
        for row in faulty.reset_index().itertuples(index=False):
            typer.echo(f"  developing fault: {row.robot}/{row.axis} {row.fault}")


@app.command()
def demo(
    out: Annotated[
        Path | None, typer.Option(help="Working folder (default: a temporary one).")
    ] = None,
    days: int = typer.Option(30, help="Days of the simulated fleet."),
    seed: int = typer.Option(0, help="Seed of the simulation."),
    debug: bool = DEBUG,
) -> None:
    """Simulate a fleet, monitor it with LRA and PCA, write the report; print the summary."""
    import tempfile

    from axiswatch._monitor import monitor_fleet
    from axiswatch._report import write_report
    from axiswatch._robot import simulate_fleet
    from axiswatch._scoring import MonitorConfig
    from axiswatch._store import Store

    with _failures(debug):
        folder = Path(tempfile.mkdtemp(prefix="axiswatch-demo-")) if out is None else out
        folder.mkdir(parents=True, exist_ok=True)
        root = folder / "fleet"
        typer.echo(f"Simulating a fleet into {root} ...")
        labels = simulate_fleet(root, n_days=days, seed=seed)
        with Store(folder / "fleet.db") as opened, _progress(True) as update:
            for method in ("mechanics", "lra", "pca"):
                monitor_fleet(root, opened, MonitorConfig(method=method), progress=update)
            typer.echo("\nFleet summary (state after the last capture):")
            _echo_summary(opened)
            page = write_report(opened, folder / "report", labels=labels)
        truth = labels[labels.fault != "none"].groupby(["robot", "axis"]).date.min()
        changes = labels[labels.task.ne(labels.groupby(["robot", "axis"]).task.shift())]
        later = sorted(set(changes.date) - {labels.date.min()})
        typer.echo("\nGround truth (simulator labels, not seen by the monitor):")
        typer.echo(f"  task changes (must not alarm) on {', '.join(later) or 'no day'}")
        typer.echo("  developing faults (should alarm):")
        for row in truth.reset_index().itertuples(index=False):
            typer.echo(f"    {row.robot}/{row.axis} from {row.date}")
        typer.echo(f"\nReport: {page}")


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
    from axiswatch._experiments import alarm_summary

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
    _save_alarms(table, out)


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
    _save_alarms(table, out)


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
    from axiswatch._datasets import default_data_dir
    from axiswatch._realdata import bearing_line_readings, summarize_line_readings

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
    from axiswatch._paired import PairedDesign, paired_evaluation
    from axiswatch._plotting import plot_paired

    table = paired_evaluation(PairedDesign(n_per_cell=per_cell, seed=seed), oracle=oracle)
    _save(table, plot_paired(table), out, "paired")


@experiment_app.command("select")
def experiment_select(out: Path = _OUT) -> None:
    """Choose the product default: rank every feature stage x detector on the development design."""
    from axiswatch._paired import development_scales, select_default

    ranking = select_default()
    out.mkdir(parents=True, exist_ok=True)
    ranking.to_csv(out / "selection.csv", index=False)
    typer.echo(ranking.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    scales = ", ".join(f"{v:.4g}" for v in development_scales())
    typer.echo(f"\nMechanics indicator scales on the development design: ({scales})")
    typer.echo(f"Wrote {out / 'selection.csv'}")


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
