"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success, 1 failure, 2 usage error. ``monitor`` adds 4 for an unacknowledged alarm
and 8 for a new problem. The monitor manual lists them.
"""

from __future__ import annotations

import difflib
import re
import shlex
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import timedelta
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import typer
from typer.core import TyperCommand, TyperGroup, TyperOption

from axiswatch_launcher import INTERRUPTED, INTERRUPTED_STATUS

if TYPE_CHECKING:  # imported where used: `axiswatch --help` imports neither pandas nor SciPy
    import pandas as pd

#: Entry-point group through which installed packages add command groups to ``axiswatch``
#: (the research package adds ``experiment``); the CLI never imports them by name.
PLUGIN_GROUP = "axiswatch.commands"


class _Commands(TyperGroup):
    """The commands, with those of installed packages (:data:`PLUGIN_GROUP`) loaded when used:
    ``axiswatch --help`` does not import the research package and its scikit-learn."""

    def _plugins(self) -> dict[str, Any]:
        from importlib.metadata import entry_points

        return {e.name: e for e in entry_points(group=PLUGIN_GROUP) if e.name not in self.commands}

    def list_commands(self, ctx: Any) -> list[str]:
        return [*super().list_commands(ctx), *self._plugins()]

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        plugin = self._plugins().get(cmd_name)
        if plugin is not None:
            command = typer.main.get_command(plugin.load())
            command.name = cmd_name
            self.add_command(command, cmd_name)
        return super().get_command(ctx, cmd_name)

    def format_commands(self, ctx: Any, formatter: Any) -> None:
        described = {
            name: TyperGroup(
                name=name,
                help=f"Commands of {entry.module.partition('.')[0]} ('axiswatch {name} -h').",
            )
            for name, entry in self._plugins().items()
        }
        self.commands.update(described)
        try:
            super().format_commands(ctx, formatter)
        finally:
            for name in described:
                del self.commands[name]


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

DEBUG = typer.Option(False, "--debug", help="Show Python tracebacks of failures.")
StorePath = Annotated[
    Path, typer.Option("--store", help="SQLite store of the monitor (created if new).")
]
# Every command but `monitor` reads a store a monitor run wrote and refuses a missing one
# (_require_store): its help must not promise to create it.
ExistingStorePath = Annotated[
    Path,
    typer.Option("--store", help="SQLite store written by 'axiswatch monitor' (must exist)."),
]


#: Characters a terminal acts on, as the escapes printed instead: C0 but the newline, DEL, C1,
#: the bidirectional overrides and isolates (they reorder what is shown), the line separators.
_CONTROLS = {
    code: f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"
    for code in (
        *range(0x20), 0x7F, *range(0x80, 0xA0), *range(0x202A, 0x202F), *range(0x2066, 0x206A),
        0x2028, 0x2029,
    )
    if code != 0x0A
}  # fmt: skip


def printable(text: str) -> str:
    """``text`` with the characters a terminal acts on written as escapes, lines kept.

    A file name can hold ``ESC [ 2 J`` (clear the screen) or set the terminal's title: every
    line a command prints goes through here.

    Examples
    --------
    >>> print(printable("r1/a1/2026-03-01_\x1b[2J.csv: empty"))
    r1/a1/2026-03-01_\\x1b[2J.csv: empty
    """
    return text.translate(_CONTROLS)


def echo(message: str = "", *, err: bool = False, nl: bool = True) -> None:
    """Print one message to stdout (``err``: stderr), escaped by :func:`printable`."""
    typer.echo(printable(message), err=err, nl=nl)


@contextmanager
def _failures(debug: bool) -> Iterator[None]:
    """Turn expected failures into one line on stderr and exit status 1 (unless ``--debug``);
    Ctrl-C into one line and exit status 130 (128 + SIGINT), as a shell reports it."""
    from axiswatch.exceptions import AxiswatchError

    try:
        yield
    except BrokenPipeError:
        raise  # the reader went away (`| head`): Click exits quietly, nothing failed
    except KeyboardInterrupt:
        if debug:
            raise
        echo(INTERRUPTED, err=True)
        raise typer.Exit(INTERRUPTED_STATUS) from None
    except (AxiswatchError, ValueError, OSError, NotImplementedError) as exc:
        if debug:
            raise
        echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from None


@contextmanager
def _usage(debug: bool) -> Iterator[None]:
    """Turn an invalid option value into one line on stderr and exit status 2."""
    try:
        yield
    except ValueError as exc:
        if debug:
            raise
        echo(f"usage error: {exc}", err=True)
        raise typer.Exit(2) from None


_DURATION = re.compile(r"(?P<value>\d+(?:\.\d+)?)\s*(?P<unit>[smhd])")
_UNIT_S = {"s": 1, "m": 60, "h": 3600, "d": 86400}


def _duration(text: str, option: str) -> timedelta | None:
    """``3d``, ``12h``, ``30m``, ``45s`` or ``off``."""
    if text.strip().lower() == "off":
        return None
    match = _DURATION.fullmatch(text.strip())
    if match is None:
        raise ValueError(
            f"The '{option}' option must be a duration such as 3d, 12h, 30m, 45s, or 'off'. "
            f"Got {text!r} instead."
        )
    return timedelta(seconds=float(match["value"]) * _UNIT_S[match["unit"]])


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


def _registered_method(name: str | None) -> str | None:
    """``--method``: a method registered when the command runs (plugins included)."""
    from axiswatch.monitor._methods import methods

    if name is not None and name not in methods():
        raise typer.BadParameter(
            f"expected one of {', '.join(methods())}; got {name!r}.", param_hint="'--method'"
        )
    return name


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


def monitor_defaults() -> dict[str, Any]:
    """The value of each ``monitor`` option left out: the field of :class:`MonitorConfig` it sets.

    The options default to None, so that the CLI imports the scoring stack only when a command
    needs it; the help shows these values.
    """
    from axiswatch.monitor._scoring import MonitorConfig

    config = MonitorConfig()
    return {
        "method": config.method,
        "percentile": config.percentile,
        "calibration": config.calibration_size,
        "alarm_k": config.alarm_k,
        "alarm_n": config.alarm_n,
        "clear_m": config.clear_m,
        "signals": ",".join(config.features.signals),
        "hop": config.features.hop,
        "segment_length": config.features.segment_length,
        "lra_noise_level": str(config.lra_noise_level),
        "align": config.align_phase,
        "order_lines": config.order_lines,
        "whole_moves": config.whole_moves,
    }


class _MonitorCommand(TyperCommand):
    """``monitor``: its help shows the monitor's defaults and methods, read when it is shown."""

    def format_help(self, ctx: Any, formatter: Any) -> None:
        from axiswatch.monitor._methods import methods

        defaults = monitor_defaults()
        options = [p for p in self.params if isinstance(p, TyperOption)]
        saved = [(p, p.default, p.show_default, p.help) for p in options]
        advanced = bool(ctx.meta.get(_ADVANCED))
        for param in options:
            if param.name in defaults:
                param.default, param.show_default = defaults[param.name], True
            if param.name == "method":
                described = (
                    "; ".join(f"{name}: {preset.summary}" for name, preset in methods().items())
                    if advanced
                    else ", ".join(methods()) + " ('--advanced' describes them)"
                )
                param.help = f"Distance method: {described}."
        try:
            super().format_help(ctx, formatter)
        finally:
            for param, default, show, text in saved:
                param.default, param.show_default, param.help = default, show, text


_ADVANCED = "axiswatch.advanced"


def _advanced_help(ctx: typer.Context, param: Any, shown: bool) -> None:
    """``--advanced``: the help with the research options, then exit."""
    if not shown or ctx.resilient_parsing:
        return
    hidden = [p for p in ctx.command.params if isinstance(p, TyperOption) and p.hidden]
    ctx.meta[_ADVANCED] = True
    for option in hidden:
        option.hidden = False
    try:
        typer.echo(ctx.get_help(), color=ctx.color)
    finally:
        for option in hidden:
            option.hidden = True
    ctx.exit()


class Format(StrEnum):
    table = "table"
    csv = "csv"
    json = "json"


def _echo_summary(store: Any, stale_after: timedelta | None, method: str) -> pd.DataFrame:
    """Print the fleet's summary of ``method`` (the columns that fit a terminal); return it."""
    from axiswatch.monitor._results import fleet_summary

    summary = fleet_summary(store, stale_after=stale_after)
    summary = summary[summary.method == method].reset_index(drop=True)
    if summary.empty:
        echo("No axis has a baseline yet.")
        return summary
    # What fits a terminal; `axiswatch report` and `fleet_summary` have every column.
    columns = ["robot", "axis", "method", "state", "alarm_since", "scored", "over",
               "last_capture", "last_distance", "threshold", "rejected"]  # fmt: skip
    if summary.acknowledged_by.notna().any():
        columns.insert(5, "acknowledged_by")
    if summary.bad_data_acknowledged.notna().any():
        columns.insert(columns.index("state") + 1, "bad_data_acknowledged")
    shown = summary[columns].fillna(
        {"alarm_since": "", "acknowledged_by": "", "bad_data_acknowledged": ""}
    )
    echo(shown.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    origins = summary.threshold_origin.dropna().unique()
    if len(origins) == 1:
        echo(f"threshold of every axis: {origins[0]}.")
    return summary


def _verdict_lines(store: Any, method: str, stale_after: timedelta | None) -> list[str]:
    """The axes needing attention and their verdicts (the report's first screen), in lines."""
    from axiswatch.monitor._verdict import attention_lines, fleet_verdicts

    return attention_lines(fleet_verdicts(store, method, stale_after=stale_after), method)


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
    from axiswatch.monitor._monitor import check_request, monitor_fleet
    from axiswatch.monitor._parallel import connect_dask
    from axiswatch.monitor._scoring import MonitorConfig
    from axiswatch.monitor.store import Store

    given: dict[str, Any] = {
        "method": method, "percentile": percentile, "calibration": calibration,
        "alarm_k": alarm_k, "alarm_n": alarm_n, "clear_m": clear_m, "signals": signals,
        "hop": hop, "segment_length": segment_length, "lra_noise_level": lra_noise_level,
        "align": align, "order_lines": order_lines, "whole_moves": whole_moves,
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
                # n_files counts only the folders this run listed: say so, or a second run
                # seems to have lost the files of the unchanged folders.
                unchanged = (
                    f" in the axis folders listed ({result.unchanged_folders} axis folder(s) "
                    "unchanged since the last run, not listed)"
                    if result.unchanged_folders
                    else ""
                )
                echo(
                    f"{result.method}: {result.n_files} capture files{unchanged}, "
                    f"{result.new_baselines} new baseline(s), {result.scored} capture(s) scored "
                    "in this run."
                )
                _echo_summary(opened, silence, result.method)
                verdicts = _verdict_lines(opened, result.method, silence)
        finally:
            if client is not None:
                client.close()
        if result.waiting:
            echo(
                f"\n{result.waiting} capture file(s) modified less than {settle:g} s ago: "
                "waiting (scored by a later run)."
            )
        for title, lines in (
            ("Rejected captures", fold_same_reason(result.rejected)),
            ("Changed files", result.changed),
            ("Axes not scored", result.axis_problems),
            ("Baselines to check", result.baseline_checks),
            ("Axes calibrating", result.calibrating),
            ("Fleet allowances now applied", result.fleet_priors),
            ("Stale axes", result.stale),
        ):
            if lines:
                count = len(result.rejected) if title == "Rejected captures" else len(lines)
                echo(f"\n{title} ({count}):")
                for line in lines:
                    echo(f"  {line}")
                if title == "Rejected captures":
                    echo(
                        "A rejected capture is tried again when its file, the options or its "
                        "axis profile change; to try again now: axiswatch rejections --store "
                        f"{shlex.quote(str(store))} --retry [PATH ...]"
                    )
        if result.acknowledged:
            echo(
                f"\n{result.acknowledged} acknowledged problem(s) not shown "
                "('axiswatch rejections' lists them)."
            )
        if result.acknowledged_alarms:
            echo(f"\nAcknowledged alarms ({result.method}), not counted in the exit status:")
            for seen in result.acknowledged_alarms:
                echo(
                    f"  {seen.robot}/{seen.axis} since {seen.raised_capture}: seen by "
                    f"{seen.acknowledged_by} at {seen.acknowledged_at}: {seen.note}"
                )
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
    force: bool = typer.Option(False, "--force", help="Replace an axis.toml with other content."),
    debug: bool = DEBUG,
) -> None:
    """Detect how capture files are written; show it; with --fleet, write what monitor reads.

    A file holding several axes (A1_*, A2_*) is linked into one folder per axis, each with an
    axis.toml; run it again on new files to link them.
    """
    from axiswatch._profile_detection import detect_file
    from axiswatch.monitor._layout_plan import plan_layout

    with _failures(debug):
        guesses = [detect_file(path) for path in files]
        plan = plan_layout(guesses, fleet or Path("fleet"), robot)
        _show_guesses(guesses)
        if plan.unplaced:
            echo(f"\nFiles not placed ({len(plan.unplaced)}):")
            for line in fold_same_reason([f"{path}: {why}" for path, why in plan.unplaced]):
                echo(f"  {line}")
        if fleet is None:
            echo("\nNothing written: --fleet FOLDER writes the profiles and links.")
            return
        from axiswatch.monitor._layout_plan import apply_plan

        for line in apply_plan(plan, force=force):
            echo(line)
        if plan.placed:
            echo(f"Next: axiswatch monitor {fleet} --store STORE.db")
    if not plan.placed:
        raise typer.Exit(1)


def _show_guesses(guesses: list[Any]) -> None:
    """What the files hold: one table row per axis and way of writing it, with its file count."""
    from rich.console import Console
    from rich.table import Table

    rows: dict[tuple[str, ...], list[str]] = {}
    for guess in guesses:
        layout = guess.layout
        written = (
            f"{layout.encoding}, {layout.separator!r}, decimal {layout.decimal!r}"
            f"{', units row' if layout.units else ''}"
            if layout is not None
            else guess.path.suffix
        )
        for axis in guess.axes:
            by_role = {role: column for column, role in axis.columns.items()}
            cells = [
                f"{by_role[role]} ({axis.how[role]})" if role in by_role else "-"
                for role in ("position", "speed", "torque")
            ]
            if "position" in by_role:
                cells[0] += f" in {axis.position_unit}{'?' if axis.unit_assumed else ''}"
            rates = ", ".join(sorted({f"{rate:.6g}" for rate in axis.rates_hz.values()}))
            time = f"{guess.time_column} ({guess.time_kind} {guess.time_unit})"
            key = (written, axis.axis or "-", time, *cells, rates)
            rows.setdefault(key, []).append(guess.path.name)
    table = Table(title="What the files hold", title_justify="left")
    for heading in ("files", "written", "axis", "time", "position", "speed", "torque", "Hz"):
        table.add_column(heading, overflow="fold")
    for key, names in rows.items():
        more = f" +{len(names) - 1}" if len(names) > 1 else ""
        table.add_row(names[0] + more, *key)
    Console(width=max(_terminal_width(), 100)).print(table)
    notes = {note for guess in guesses for axis in guess.axes for note in axis.notes}
    for note in sorted(notes):
        echo(f"note: {note}")


def _terminal_width() -> int:
    import shutil

    return shutil.get_terminal_size().columns


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
    top_indicator, feedback (the verdict of an acknowledged alarm). The table shows the first
    seven, role, feedback (when any) and top_indicator.
    """
    import json

    from axiswatch.monitor._results import fleet_results, indicator_spreads
    from axiswatch.monitor.store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store, read_only=True) as opened:
            frame = fleet_results(opened, robot=robot, axis=axis)
        if method is not None:
            frame = frame[frame["method"] == method].reset_index(drop=True)
        columns = ["robot", "axis", "capture", "method", "distance", "threshold", "alarm"]
        if output is Format.csv:
            echo(frame.to_csv(index=False, float_format="%.17g"), nl=False)
        elif output is Format.json:
            records = frame.assign(details=frame["details"].map(json.loads))
            echo(records.to_json(orient="records", indent=1))
        elif frame.empty:
            echo("No scored captures.")
        else:
            # The engineer's feedback on an acknowledged alarm (ack --false-alarm, ...).
            said = ["feedback"] if frame.feedback.notna().any() else []
            table = frame[[*columns, "role", *said, "top_indicator"]].fillna(
                {"top_indicator": "", "feedback": ""}
            )
            if indicators:
                table = table.join(indicator_spreads(frame))
            echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))


def fold_same_reason(lines: list[str]) -> list[str]:
    """Rejection lines ``PATH: reason`` with one reason said once, naming how many files share it.

    A broken axis profile rejects every capture below it with the same line but for the path.
    Reasons that differ only in their numbers (each file's first stamp) are one reason too.
    ``axiswatch rejections`` still lists every file. Lines keep the order of their reason's
    first file; a line without ``": "`` is its own.

    Parameters
    ----------
    lines : list of str
        Rejection lines, each ``PATH: reason``.

    Returns
    -------
    list of str
        One line per reason: the first file's line, or with more files of the same reason
        ``FIRST (and N more capture files with this reason): reason``.

    Examples
    --------
    >>> fold_same_reason([
    ...     "r1/a1/d1.csv: r1/robot.toml: bad key", "r1/a2/d1.csv: empty file",
    ...     "r1/a1/d2.csv: r1/robot.toml: bad key", "r1/a2/d1.csv: r1/robot.toml: bad key",
    ... ])  # doctest: +NORMALIZE_WHITESPACE
    ['r1/a1/d1.csv (and 2 more capture files with this reason): r1/robot.toml: bad key',
     'r1/a2/d1.csv: empty file']
    """
    groups: dict[tuple[str, int], list[tuple[str, str]]] = {}  # (key, 0) or (line, its index)
    for index, line in enumerate(lines):
        path, sep, reason = line.partition(": ")
        key = (_NUMBER.sub("#", reason), 0) if sep else (line, index + 1)
        groups.setdefault(key, []).append((path, reason))
    folded = []
    for (_, alone), members in groups.items():
        (path, reason), more = members[0], len(members) - 1
        if alone:
            folded.append(reason if reason else path)
        elif not more:
            folded.append(f"{path}: {reason}")
        else:
            # Unix milliseconds read as seconds: each file's message names its own first stamp.
            aside = "" if len({r for _, r in members}) == 1 else ", numbers aside"
            folded.append(
                f"{path} (and {more} more capture files with this reason{aside}): {reason}"
            )
    return folded


#: A date or a measured number in a rejection reason (a stamp, a time, a rate: a decimal
#: point, an exponent or 3 digits): reasons that differ only in these are folded together.
_NUMBER = re.compile(
    r"\d{4}-\d{2}-\d{2}(?:[T ]\d{2}:\d{2}:\d{2})?|\d+\.\d+(?:e[+-]?\d+)?|\d+e[+-]?\d+|\d{3,}"
)


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
    from axiswatch.monitor._report import write_report
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
    false_alarm: bool = typer.Option(False, "--false-alarm", help="Verdict: the axis is fine."),
    task_changed: bool = typer.Option(
        False, "--task-changed", help="Verdict: the axis's task or payload changed."
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
            methods = opened.acknowledge(
                robot, axis, by=by, note=note, method=chosen, rebaseline=rebaseline,
                verdict=verdict,
            )  # fmt: skip
        said = f": {verdict}" if verdict else ""
        echo(f"{robot}/{axis}: acknowledged ({', '.join(methods)}) by {by}{said}.")
        if rebaseline:
            start = from_capture or "the next capture that arrives"
            echo(f"Baseline retired; the next monitor run starts a new baseline at {start}.")


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
    from axiswatch.datasets._robot import simulate_fleet

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


@app.command()
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

    from axiswatch.datasets._robot import simulate_fleet
    from axiswatch.monitor._methods import DEFAULT_METHOD
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor._report import write_report
    from axiswatch.monitor._scoring import MonitorConfig
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
            for line in _verdict_lines(opened, DEFAULT_METHOD, None):
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


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    sys.exit(app())
