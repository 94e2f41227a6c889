"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success, 1 failure, 2 usage error. ``monitor`` adds 4 for an unacknowledged alarm
and 8 for a new problem. The monitor manual lists them.
"""

from __future__ import annotations

import difflib
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from axiswatch.cli._demo import demo, simulate_fleet_command
from axiswatch.cli._options import (
    DEBUG,
    PLUGIN_GROUP,
    ExistingStorePath,
    Format,
    StorePath,
    monitor_defaults,
)
from axiswatch.cli._options import Commands as _Commands
from axiswatch.cli._options import MonitorCommand as _MonitorCommand
from axiswatch.cli._options import advanced_help as _advanced_help
from axiswatch.cli._options import duration as _duration
from axiswatch.cli._options import noise_level as _noise_level
from axiswatch.cli._options import registered_method as _registered_method
from axiswatch.cli._terminal import echo, printable
from axiswatch.cli._terminal import failures as _failures
from axiswatch.cli._terminal import progress as _progress
from axiswatch.cli._terminal import show_guesses as _show_guesses
from axiswatch.cli._terminal import usage as _usage

__all__ = ["PLUGIN_GROUP", "app", "echo", "main", "monitor_defaults", "printable"]

if TYPE_CHECKING:  # imported where used: `axiswatch --help` imports neither pandas nor SciPy
    import pandas as pd

app = typer.Typer(
    cls=_Commands,
    help="axiswatch: predictive maintenance of robot axes that does not cry wolf on a task change.",
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
    # Plain help: rich's tables cut option names at 80 columns and took 4x the lines.
    rich_markup_mode=None,
)
simulate_app = typer.Typer(
    help="Write simulated captures in the fleet layout.", no_args_is_help=True
)
app.add_typer(simulate_app, name="simulate")


def _version(shown: bool) -> None:
    if shown:
        from axiswatch import __version__

        typer.echo(f"axiswatch {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", is_eager=True, callback=_version, help="Print the version and exit."
    ),
) -> None:
    """axiswatch: predictive maintenance of robot axes that does not cry wolf on a task change."""


@app.command(cls=_MonitorCommand)
def monitor(
    root: Annotated[Path, typer.Argument(help="Fleet folder ROOT/<robot>/<axis>/<capture>.<ext>.")],
    store: StorePath,
    method: str | None = typer.Option(None, help="Distance method.", callback=_registered_method),
    profile: Annotated[
        Path | None,
        typer.Option(
            help="Axis profile (TOML) of every axis; default: each axis's axis.toml, its "
            "robot's robot.toml or the fleet's axiswatch.toml ('axiswatch profile' writes them)."
        ),
    ] = None,
    calibration: int | None = typer.Option(
        None, help="Captures after the baseline that set the threshold."
    ),
    percentile: float | None = typer.Option(None, help="Threshold percentile."),
    alarm_k: int | None = typer.Option(
        None, help="Alarm when K of the last N captures are over the threshold..."
    ),
    alarm_n: int | None = typer.Option(None, help="...(K = N = 1 as in the paper)."),
    clear_m: int | None = typer.Option(
        None, help="An alarm clears after M clean captures in a row."
    ),
    baseline: str | None = typer.Option(
        None, help="File name of the baseline capture of new axes (default: their first)."
    ),
    max_capture_rows: int | None = typer.Option(
        None,
        min=1,
        help="A capture file of more rows is rejected before it is loaded (memory stays "
        "bounded; the default is 16.7 min at 2 kHz).",
        hidden=True,
    ),
    workers: int = typer.Option(1, min=1, help="Local worker processes for scoring."),
    settle: float = typer.Option(
        10.0, min=0.0, help="Seconds a capture file must go unmodified before it is scored."
    ),
    stale_after: str = typer.Option(
        "3d", help="An axis without a new capture for this long is stale (3d, 12h, ... or off)."
    ),
    dask: str | None = typer.Option(
        None, help="Dask scheduler address for scoring (traffic is unauthenticated: README)."
    ),
    progress: bool = typer.Option(True, help="Progress bar on stderr (only on a terminal)."),
    debug: bool = DEBUG,
    advanced: bool = typer.Option(
        False,
        "--advanced",
        is_eager=True,
        expose_value=False,
        callback=_advanced_help,
        help="Show the help with the research and tuning options, and exit.",
    ),
    signals: str | None = typer.Option(None, help="Signal columns, comma-separated.", hidden=True),
    hop: int | None = typer.Option(None, help="Samples between STFT slices.", hidden=True),
    segment_length: int | None = typer.Option(
        None, help="STFT window length in samples.", hidden=True
    ),
    lra_noise_level: str | None = typer.Option(
        None,
        help="LRA's lambda: a number (1 is the paper's form) or 'auto' (from the baseline).",
        hidden=True,
    ),
    align: bool | None = typer.Option(
        None,
        "--align/--no-align",
        help="Align each capture's phase to the baseline's.",
        hidden=True,
    ),
    task_envelope: float | None = typer.Option(
        None,
        help="Method indicators: allow for a task change only when the motion is not the "
        "baseline's task, with this envelope factor (2 was chosen on development robots; "
        "default: off, every capture gets the fleet's allowance; docs/evaluation.md).",
        hidden=True,
    ),
    order_lines: bool | None = typer.Option(
        None,
        "--order-lines/--no-order-lines",
        help="Method indicators: also score the torque's order lines against each baseline's "
        "own order spectrum (no kinematics needed; 100 Hz or more; docs/evaluation.md).",
        hidden=True,
    ),
    whole_moves: bool | None = typer.Option(
        None,
        "--whole-moves/--no-whole-moves",
        help="Method indicators, opt-in: drive loads from whole moves and loose friction "
        "readings widened: fewer false alarms after task changes, dr99 up to 0.03 lower "
        "(docs/evaluation.md, 'An opt-in operating point').",
        hidden=True,
    ),
    modes: bool | None = typer.Option(
        None,
        "--modes/--no-modes",
        help="Method indicators, opt-in: learn each axis's operating modes; every capture "
        "of a moving axis is scored in its mode, or by a guard while a new mode is learned "
        "(docs/evaluation.md, 'Modes').",
        hidden=True,
    ),
    dask_timeout: float = typer.Option(
        10.0, min=0.1, help="Seconds the Dask scheduler has to answer.", hidden=True
    ),
) -> None:
    """Score every capture not scored yet; print the fleet's state.

    Exit status: 0 nothing to report; 4 an axis is in alarm; 8 a capture was rejected, a scored
    file changed, an axis cannot be scored or is stale, a baseline needs checking
    (acknowledged ones aside: see 'axiswatch rejections'); 12 both; 1 failure; 2 usage error.
    """
    import dataclasses

    from axiswatch._profiles import AxisProfile
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor._parallel import connect_dask
    from axiswatch.monitor._requests import check_request
    from axiswatch.monitor.report.summary import (
        cleared_alarm_lines,
        fleet_table,
        run_header,
        run_problems,
        verdict_lines,
    )
    from axiswatch.monitor.store import Store

    given: dict[str, Any] = {
        "method": method, "percentile": percentile, "calibration": calibration,
        "alarm_k": alarm_k, "alarm_n": alarm_n, "clear_m": clear_m, "signals": signals,
        "hop": hop, "segment_length": segment_length, "lra_noise_level": lra_noise_level,
        "align": align, "order_lines": order_lines, "whole_moves": whole_moves,
        "modes": modes, "max_capture_rows": max_capture_rows,
    }  # fmt: skip
    value: dict[str, Any] = {
        name: default if given[name] is None else given[name]
        for name, default in monitor_defaults().items()
    }
    with _failures(debug):
        with _usage(debug):
            defaults = MonitorConfig()
            config = MonitorConfig(
                method=value["method"],
                percentile=value["percentile"],
                calibration_size=value["calibration"],
                alarm_k=value["alarm_k"],
                alarm_n=value["alarm_n"],
                clear_m=value["clear_m"],
                baseline=baseline,
                features=dataclasses.replace(
                    defaults.features,
                    signals=tuple(s.strip() for s in value["signals"].split(",")),
                    hop=value["hop"],
                    segment_length=value["segment_length"],
                ),
                lra_noise_level=_noise_level(value["lra_noise_level"]),
                align_phase=value["align"],
                profile=None if profile is None else AxisProfile.from_toml(profile),
                task_envelope=task_envelope,
                order_lines=value["order_lines"],
                whole_moves=value["whole_moves"],
                modes=value["modes"],
                max_capture_rows=value["max_capture_rows"],
            )
            silence = _duration(stale_after, "--stale-after")
            check_request(root, config)
        # Connect before the store is opened: a wrong address leaves nothing behind.
        client = None if dask is None else connect_dask(dask, dask_timeout)
        try:
            with Store(store) as opened, _progress(progress) as update:
                result = monitor_fleet(
                    root, opened, config, workers=workers, dask=client, progress=update,
                    settle_s=settle, stale_after=silence,
                )  # fmt: skip
                echo(run_header(result))
                for line in fleet_table(opened, silence, result.method):
                    echo(line)
                verdicts = verdict_lines(opened, result.method, silence)
                cleared = cleared_alarm_lines(opened, result.method, result.alarmed_before, store)
        finally:
            if client is not None:
                client.close()
        for line in [*cleared, *run_problems(result, store=store, settle_s=settle)]:
            echo(line)
        echo("")
        for line in verdicts:
            echo(line)
    raise typer.Exit(result.exit_code)


@app.command()
def profile(
    files: Annotated[list[Path], typer.Argument(help="A few capture files of your robot(s).")],
    fleet: Annotated[
        Path | None,
        typer.Option(help="Fleet folder to write: axis.toml per axis, captures linked in."),
    ] = None,
    robot: str | None = typer.Option(
        None, help="Robot folder of files outside --fleet (default: the folder they lie in)."
    ),
    force: bool = typer.Option(
        False, "--force", help="Replace the axis profiles there with the detected ones."
    ),
    debug: bool = DEBUG,
) -> None:
    """Detect how capture files are written; show it; with --fleet, write what monitor reads.

    FILES may be folders: their capture files (.csv, .txt, .tsv, .parquet, .npz) are read. A
    file holding several axes (A1_*, A2_*) is linked into one folder per axis, each with an
    axis.toml. Run it again on new files to link them: an axis profile already there, edited
    or not, is kept and reads them.
    """
    from axiswatch._profile_detection import detect_file, export_files
    from axiswatch.monitor._layout_plan import plan_layout
    from axiswatch.monitor.report.summary import fold_same_reason

    with _failures(debug):
        paths, empty = export_files(files)
        guesses = [detect_file(path) for path in paths]
        plan = plan_layout(guesses, fleet or Path("fleet"), robot, force=force)
        if any(guess.axes for guess in guesses):  # an empty table says nothing
            _show_guesses(guesses)
        unplaced = [*((path, "a folder without capture files") for path in empty),
                    *plan.unplaced]  # fmt: skip
        if unplaced:
            echo(f"\nFiles not placed ({len(unplaced)}):")
            # The reason names no path: fold_same_reason then folds files of one reason.
            lines = [f"{path}: {why.replace(f'{path}: ', '')}" for path, why in unplaced]
            for line in fold_same_reason(lines):
                echo(f"  {line}")
        if fleet is None:
            echo("\nNothing written: --fleet FOLDER writes the profiles and links.")
        else:
            from axiswatch.monitor._layout_plan import apply_plan

            for line in apply_plan(plan, force=force):
                echo(line)
            if plan.placed:
                echo(f"Next: axiswatch monitor {fleet} --store STORE.db")
    if not plan.placed:
        raise typer.Exit(1)


@app.command()
def results(
    store: ExistingStorePath,
    robot: str | None = typer.Option(None, help="Only this robot."),
    axis: str | None = typer.Option(None, help="Only this axis."),
    method: str | None = typer.Option(
        None, help="Only this method (default: all).", callback=_registered_method
    ),
    output: Annotated[Format, typer.Option("--format", help="table, csv or json.")] = Format.table,
    indicators: bool = typer.Option(
        False, help="Table: one column per indicator, its shift in healthy spreads."
    ),
    debug: bool = DEBUG,
) -> None:
    """One row per scored capture: robot, axis, capture, method, distance, threshold, alarm.

    Then captured_at, epoch, role, over, reason, details (JSON: for the indicator methods each
    indicator's value, baseline, shift in healthy spreads and share of the distance) and
    top_indicator, feedback (the verdict of an acknowledged alarm), mode (with --modes). The
    table shows the first seven, role, feedback and mode (when any) and top_indicator; below
    it, once per axis, the indicators its captures could not give.
    """
    import json

    from axiswatch.monitor._unread import UnreadIndicators
    from axiswatch.monitor.report.results import fleet_results, indicator_spreads
    from axiswatch.monitor.report.summary import unread_lines
    from axiswatch.monitor.store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store, read_only=True) as opened:
            frame = fleet_results(opened, robot=robot, axis=axis)
            if method is not None:
                frame = frame[frame["method"] == method].reset_index(drop=True)
            # What the store holds, read only to say it when the filters matched nothing.
            known = opened.summary_table()[["robot", "axis", "method"]] if frame.empty else None
        columns = ["robot", "axis", "capture", "method", "distance", "threshold", "alarm"]
        if output is Format.csv:
            echo(frame.to_csv(index=False, float_format="%.17g"), nl=False)
        elif output is Format.json:
            records = frame.assign(details=frame["details"].map(json.loads))
            echo(records.to_json(orient="records", indent=1))
        elif known is not None:
            echo(_no_results(known, robot=robot, axis=axis, method=method))
        else:
            # The engineer's feedback on an acknowledged alarm (ack --false-alarm, ...).
            said = ["feedback"] if frame.feedback.notna().any() else []
            said += ["mode"] if frame["mode"].notna().any() else []
            table = frame[[*columns, "role", *said, "top_indicator"]].fillna(
                {"top_indicator": "", "feedback": "", "mode": ""}
            )
            if indicators:
                table = table.join(indicator_spreads(frame))
            echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
            unread = unread_lines(UnreadIndicators.from_results(frame))
            if unread:
                echo("\nIndicators not read:")
                for line in unread:
                    echo(f"  {line}")


def _no_results(
    known: pd.DataFrame, *, robot: str | None, axis: str | None, method: str | None
) -> str:
    """No scored captures, and the robots and axes the store holds when a filter named none."""
    asked = {"--robot": robot, "--axis": axis, "--method": method}
    given = {option: value for option, value in asked.items() if value is not None}
    if not given or known.empty:
        return "No scored captures."
    filters = ", ".join(f"{option} {value}" for option, value in given.items())
    held = sorted({f"{r}/{a} ({m})" for r, a, m in known.itertuples(index=False)})
    shown = ", ".join(held[:10]) + (f" and {len(held) - 10} more" if len(held) > 10 else "")
    return f"No scored captures for {filters}; the store holds {shown}."


def _require_store(store: Path) -> None:
    if not store.is_file():
        raise FileNotFoundError(f"store '{store}' does not exist; run 'axiswatch monitor' first.")


@app.command()
def report(
    store: ExistingStorePath,
    out: Annotated[
        Path,
        typer.Option(help="Folder for the report: one self-contained file, index.html."),
    ],
    stale_after: str = typer.Option(
        "3d", help="An axis without a new capture for this long is shown stale (or off)."
    ),
    debug: bool = DEBUG,
) -> None:
    """Write a self-contained HTML report (fleet summary, one trend figure per axis)."""
    from axiswatch.monitor.report.html import write_report
    from axiswatch.monitor.store import Store

    with _failures(debug):
        with _usage(debug):
            silence = _duration(stale_after, "--stale-after")
        _require_store(store)
        with Store(store, read_only=True) as opened:
            page = write_report(opened, out, stale_after=silence)
        echo(f"Report: {page}")


@app.command()
def rebaseline(
    store: ExistingStorePath,
    robot: str = typer.Option(..., help="Robot folder name."),
    axis: str = typer.Option(..., help="Axis folder name."),
    method: str | None = typer.Option(
        None, help="Only this method (default: all).", callback=_registered_method
    ),
    from_capture: str | None = typer.Option(
        None, "--from", help="File name of the new baseline (default: the next new capture)."
    ),
    debug: bool = DEBUG,
) -> None:
    """Retire an axis's baseline after maintenance; the next monitor run fits a new one."""
    from axiswatch.monitor._ledger import rebaseline as retire
    from axiswatch.monitor.store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            methods = retire(
                opened,
                robot,
                axis,
                method=method,
                from_capture=from_capture,
            )
        start = from_capture or "the next capture that arrives"
        echo(
            f"{robot}/{axis}: baseline retired ({', '.join(methods)}); the next monitor run "
            f"starts a new baseline at {start}."
        )


def _without_path(paths: pd.Series, errors: pd.Series) -> list[str]:
    """Each error line without its leading ``PATH: `` (shown beside a path column)."""
    return [
        str(error).removeprefix(f"{path}: ") if isinstance(error, str) else error
        for path, error in zip(paths, errors, strict=True)
    ]


def _known_problem_paths(paths: list[str], listed: list[str], method: str | None) -> None:
    """Refuse paths that name no listed problem (a typo, or the fleet folder in front): before,
    `--ack` said "0 problem(s) acknowledged" and exited 0, so nothing told the user."""
    unknown = [path for path in paths if path not in set(listed)]
    if not unknown:
        return
    advice = []
    for path in unknown:
        meant = [p for p in listed if path.endswith("/" + p)] or difflib.get_close_matches(
            path, sorted(set(listed)), n=1
        )
        advice.append(f"{path!r}" + (f" (did you mean {meant[0]!r}?)" if meant else ""))
    whose = f" of method {method!r}" if method else ""
    raise ValueError(
        f"no rejected capture, changed file or baseline check{whose} at {', '.join(advice)}; "
        "paths are as 'axiswatch rejections' lists them, relative to the fleet folder. "
        "Nothing was changed."
    )


@app.command()
def rejections(
    store: ExistingStorePath,
    paths: Annotated[
        list[str] | None,
        typer.Argument(
            help="Paths as listed (ROOT-relative; a baseline check by its baseline capture's); "
            "default: every one."
        ),
    ] = None,
    method: str | None = typer.Option(
        None, help="Only this method (default: all).", callback=_registered_method
    ),
    retry: bool = typer.Option(False, "--retry", help="Forget them: the next run tries again."),
    ack: bool = typer.Option(
        False, "--ack", help="Acknowledge them: seen, no longer a reason for exit status 8."
    ),
    debug: bool = DEBUG,
) -> None:
    """List rejected captures, changed files and baselines to check; retry (rejections) or
    acknowledge them. A rejected file a monitor run found gone from the fleet folder is kept as
    history, with when ('removed'), and no longer sets exit status 8."""
    from axiswatch.monitor.store import Store, now

    with _failures(debug):
        if retry and ack:
            with _usage(debug):
                raise ValueError("choose one of --retry and --ack.")
        _require_store(store)
        chosen = method
        with Store(store, read_only=not (retry or ack)) as opened:
            if (retry or ack) and paths:
                _known_problem_paths(paths, list(opened.problem_table(chosen)["path"]), chosen)
            if retry:
                count = opened.retry_rejections(paths or [], chosen)
                echo(f"{count} rejection(s) forgotten; the next monitor run tries them again.")
                return
            if ack:
                count = opened.acknowledge_problems(paths or [], now(), chosen)
                echo(f"{count} problem(s) acknowledged; they no longer set exit status 8.")
                return
            frame = opened.problem_table(chosen)
        if frame.empty:
            echo("No rejected captures, changed files or baselines to check.")
            return
        # The stored error line starts with the path (it is printed alone by monitor); beside
        # the path column that doubled every row's width.
        frame["error"] = _without_path(frame["path"], frame["error"])
        frame["acknowledged"] = frame.pop("acknowledged_at").fillna("")
        removed = frame.pop("removed_at")
        if removed.notna().any():  # rejected files a run found gone: history, not a problem
            frame["removed"] = removed.fillna("")
        echo(frame.to_string(index=False))


@app.command()
def ack(
    store: ExistingStorePath,
    robot: str | None = typer.Option(None, help="Robot folder name (required unless --list)."),
    axis: str | None = typer.Option(None, help="Axis folder name (required unless --list)."),
    method: str | None = typer.Option(
        None, help="Only this method (default: every one in alarm).", callback=_registered_method
    ),
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
    fault_confirmed: bool = typer.Option(
        False, "--fault-confirmed", help="Verdict: the fault is real."
    ),
    false_alarm: bool = typer.Option(
        False,
        "--false-alarm",
        help="Verdict: the axis is fine (with --modes, its mode learns the alarm's captures).",
    ),
    task_changed: bool = typer.Option(
        False,
        "--task-changed",
        help="Verdict: the axis's task or payload changed (with --modes, a new mode).",
    ),
    list_: bool = typer.Option(
        False, "--list", help="List the acknowledgements (of --robot/--axis if given) instead."
    ),
    debug: bool = DEBUG,
) -> None:
    """Record that an alarm was seen: it no longer makes monitor exit 4 until raised again.

    The report shows who saw it and their verdict, if given (at most one of --fault-confirmed,
    --false-alarm, --task-changed). With --rebaseline (after maintenance) the axis's baseline is
    also retired; the next monitor run starts a new one (see 'axiswatch rebaseline').
    """
    from axiswatch.monitor._ledger import rebaseline as retire
    from axiswatch.monitor._mode_decision import teach_mode
    from axiswatch.monitor.store import Store

    if list_:
        with _failures(debug):
            _require_store(store)
            with Store(store, read_only=True) as opened:
                frame = opened.acknowledgements(robot, axis)
            if frame.empty:
                echo("No acknowledgements.")
            else:
                echo(frame.fillna("").to_string(index=False))
        return
    robot, axis, by, note = (
        _required(value, hint)
        for value, hint in ((robot, "--robot"), (axis, "--axis"), (by, "--by"), (note, "--note"))
    )
    if from_capture is not None and not rebaseline:
        raise typer.BadParameter("only with --rebaseline.", param_hint="'--from'")
    given = [name for name, flag in (("fault-confirmed", fault_confirmed),
             ("false-alarm", false_alarm), ("task-changed", task_changed)) if flag]  # fmt: skip
    if len(given) > 1:
        raise typer.BadParameter(
            f"give at most one verdict; got {', '.join('--' + g for g in given)}.",
            param_hint="'--fault-confirmed / --false-alarm / --task-changed'",
        )
    verdict = given[0] if given else None
    chosen = method
    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            if rebaseline:
                # Retire first: it checks the request (active baseline, --from not alarmed)
                # before anything is written, so a refused request records nothing.
                retire(opened, robot, axis, method=chosen, from_capture=from_capture)
            alarms = [a for a in opened.alarms(chosen) if (a.robot, a.axis) == (robot, axis)]
            methods = opened.acknowledge(
                robot, axis, by=by, note=note, method=chosen, rebaseline=rebaseline,
                verdict=verdict,
            )  # fmt: skip
            taught: dict[str, str] = {}
            if verdict in ("task-changed", "false-alarm") and not rebaseline:
                for alarm in alarms:
                    taught |= teach_mode(
                        opened, alarm.baseline_id, alarm.raised_capture,
                        new_mode=verdict == "task-changed",
                    )  # fmt: skip
        said = f": {verdict}" if verdict else ""
        echo(f"{robot}/{axis}: acknowledged ({', '.join(methods)}) by {by}{said}.")
        for capture, mode in taught.items():
            echo(f"  {capture}: learned as healthy, mode {mode}.")
        if rebaseline:
            start = from_capture or "the next capture that arrives"
            echo(f"Baseline retired; the next monitor run starts a new baseline at {start}.")


def _required(value: str | None, hint: str) -> str:
    if value is None:
        raise typer.BadParameter("required unless --list.", param_hint=f"'{hint}'")
    return value


@app.command()
def backup(
    store: ExistingStorePath,
    destination: Annotated[Path, typer.Argument(help="The new file (never overwritten).")],
    debug: bool = DEBUG,
) -> None:
    """Write a consistent copy of the store, also while monitor runs (SQLite's online backup)."""
    from axiswatch.monitor.store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store, read_only=True) as opened:
            copy = opened.backup(destination)
        with Store(copy, read_only=True) as restored:
            rows = len(restored.score_table())
        echo(f"Backup: {copy} ({rows} score rows); open it with --store to use it.")


@app.command()
def compact(
    store: ExistingStorePath,
    keep: str = typer.Option(
        "90d", help="History kept in full, before the newest capture (90d, 12h, ...)."
    ),
    every: str = typer.Option("1d", help="Older scores: one per axis and this period."),
    debug: bool = DEBUG,
) -> None:
    """Thin old history and return the space to the disk; monitor it again as before.

    Scores older than --keep are thinned to the highest distance of each axis and --every
    period. Always kept: alarms and scores over the threshold, the clean score before each
    alarm, acknowledgements, baselines and the captures they were fitted and calibrated on,
    and each axis's last 100 scores. A thinned capture is never scored again. Back the store
    up first ('axiswatch backup'): the thinned details are gone.
    """
    import os

    from axiswatch.monitor.store import Store

    with _failures(debug):
        _require_store(store)
        kept_s = _duration(keep, "--keep")
        period = _duration(every, "--every")
        if kept_s is None or period is None:
            raise ValueError("The '--keep' and '--every' options need a duration, not 'off'.")
        if not os.access(store, os.W_OK) or not os.access(store.parent, os.W_OK):
            raise PermissionError(
                f"store '{store}' is read-only here; compact rewrites it (copy it somewhere "
                "writable, or ask its owner)."
            )
        before = store.stat().st_size
        with Store(store) as opened:
            done = opened.compact(kept_s, period)
        after = store.stat().st_size
        echo(
            f"Compacted {store}: {done.thinned} score(s) thinned, {done.kept} kept; "
            f"{before / 1e6:.2f} MB -> {after / 1e6:.2f} MB."
        )


simulate_app.command("fleet")(simulate_fleet_command)
app.command()(demo)


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    sys.exit(app())
