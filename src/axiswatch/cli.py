"""Command-line interface: maps options to library calls, no science here.

Exit codes: 0 success; 1 a command failed (message on stderr; traceback only with ``--debug``);
2 usage error (unknown option, a value out of range). ``monitor`` adds 4 when an axis is in alarm
and 8 when a capture was rejected, a scored file changed, an axis cannot be scored or is stale,
a baseline needs checking (so 4, 8 or 12; acknowledged problems do not count).
"""

from __future__ import annotations

import difflib
import re
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import timedelta
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import typer

from axiswatch.monitor._methods import DEFAULT_METHOD, methods
from axiswatch.monitor._scoring import MonitorConfig
from axiswatch_launcher import INTERRUPTED, INTERRUPTED_STATUS

if TYPE_CHECKING:  # imported where used: the CLI starts without pandas
    import pandas as pd

#: The monitor's defaults: every option of ``monitor`` defaults from these fields.
DEFAULTS = MonitorConfig()

app = typer.Typer(
    help="axiswatch: predictive maintenance of robot axes that does not cry wolf on a task change.",
    no_args_is_help=True,
    add_completion=False,
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
        typer.echo(INTERRUPTED, err=True)
        raise typer.Exit(INTERRUPTED_STATUS) from None
    except (AxiswatchError, ValueError, OSError, NotImplementedError) as exc:
        if debug:
            raise
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from None


@contextmanager
def _usage(debug: bool) -> Iterator[None]:
    """Turn an invalid option value into one line on stderr and exit status 2."""
    try:
        yield
    except ValueError as exc:
        if debug:
            raise
        typer.echo(f"usage error: {exc}", err=True)
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
    if name is not None and name not in methods():
        raise typer.BadParameter(
            f"expected one of {', '.join(methods())}; got {name!r}.", param_hint="'--method'"
        )
    return name


def _method_help() -> str:
    return "; ".join(f"{name}: {preset.summary}" for name, preset in methods().items())


class Format(StrEnum):
    table = "table"
    csv = "csv"
    json = "json"


def _echo_summary(store: Any, stale_after: timedelta | None) -> pd.DataFrame:
    """Print the fleet's summary (the columns that fit a terminal); return it whole."""
    from axiswatch.monitor._results import fleet_summary

    summary = fleet_summary(store, stale_after=stale_after)
    if summary.empty:
        typer.echo("No axis has a baseline yet.")
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
    typer.echo(shown.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    origins = summary.threshold_origin.dropna().unique()
    if len(origins) == 1:
        typer.echo(f"threshold of every axis: {origins[0]}.")
    return summary


def _alarm_reasons(
    store: Any, summary: pd.DataFrame, method: str, axes: list[tuple[str, str]]
) -> list[str]:
    """One line per axis in alarm: why (the report's first-screen line), read from the store."""
    import pandas as pd

    from axiswatch.monitor._attention import triage
    from axiswatch.monitor._results import fleet_rejections, fleet_results

    if not axes:
        return []
    results = pd.concat([fleet_results(store, robot=r, axis=a) for r, a in axes])
    listed = triage(summary, results, fleet_rejections(store), store.changed_file_table(),
                    store.alarms(method), method=method,
                    checks=store.baseline_checks(method))  # fmt: skip
    wanted = set(axes)
    return [f"{i.robot}/{i.axis}: {i.line}" for i in listed if (i.robot, i.axis) in wanted]


@app.command()
def monitor(
    root: Annotated[Path, typer.Argument(help="Fleet folder ROOT/<robot>/<axis>/<capture>.<ext>.")],
    store: StorePath,
    method: str = typer.Option(
        DEFAULTS.method,
        help=f"Distance method ({_method_help()}).",
        callback=_registered_method,
    ),
    percentile: float = typer.Option(
        DEFAULTS.percentile, help="Threshold percentile of the half-Laplace fit."
    ),
    calibration: int = typer.Option(
        DEFAULTS.calibration_size, help="Captures after the baseline that set the threshold."
    ),
    alarm_k: int = typer.Option(
        DEFAULTS.alarm_k, help="Alarm when K of the last N captures are over..."
    ),
    alarm_n: int = typer.Option(
        DEFAULTS.alarm_n, help="...the threshold (K = N = 1 as in the paper)."
    ),
    clear_m: int = typer.Option(
        DEFAULTS.clear_m, help="An alarm clears after M clean captures in a row."
    ),
    baseline: str | None = typer.Option(
        DEFAULTS.baseline,
        help="File name of the baseline capture of new axes (default: their first).",
    ),
    signals: str = typer.Option(
        ",".join(DEFAULTS.features.signals), help="Signal columns, comma-separated."
    ),
    hop: int = typer.Option(DEFAULTS.features.hop, help="Samples between STFT slices."),
    segment_length: int = typer.Option(
        DEFAULTS.features.segment_length, help="STFT window length in samples."
    ),
    lra_noise_level: str = typer.Option(
        str(DEFAULTS.lra_noise_level),
        help="LRA's lambda: a number (1 is the paper's form) or 'auto' (from the baseline).",
    ),
    align: bool = typer.Option(
        DEFAULTS.align_phase, help="Align each capture's phase to the baseline's."
    ),
    profile: Annotated[
        Path | None,
        typer.Option(
            help="Axis profile (TOML: column names, units, kinematics) for every axis; default: "
            "each axis's axis.toml, its robot's robot.toml or the fleet's axiswatch.toml."
        ),
    ] = None,
    task_envelope: float | None = typer.Option(
        DEFAULTS.task_envelope,
        help="Method indicators: allow for a task change only when the motion is not the "
        "baseline's task, with this envelope factor (2 was chosen on development robots; "
        "default: off, every capture gets the fleet's allowance; docs/evaluation.md).",
    ),
    order_lines: bool = typer.Option(
        DEFAULTS.order_lines,
        help="Method indicators: also score the torque's order lines against each baseline's "
        "own order spectrum (no kinematics needed; 100 Hz or more; docs/evaluation.md).",
    ),
    whole_moves: bool = typer.Option(
        DEFAULTS.whole_moves,
        help="Method indicators, opt-in: drive loads from whole moves and loose friction "
        "readings widened: fewer false alarms after task changes, dr99 up to 0.03 lower "
        "(docs/evaluation.md, 'An opt-in operating point').",
    ),
    max_capture_rows: int = typer.Option(
        DEFAULTS.max_capture_rows,
        min=1,
        help="A capture file of more rows is rejected before it is loaded (memory stays "
        "bounded; the default is 16.7 min at 2 kHz).",
    ),
    workers: int = typer.Option(1, min=1, help="Local worker processes for scoring."),
    dask: str | None = typer.Option(
        None, help="Dask scheduler address for scoring (traffic is unauthenticated: README)."
    ),
    dask_timeout: float = typer.Option(
        10.0, min=0.1, help="Seconds the Dask scheduler has to answer."
    ),
    settle: float = typer.Option(
        10.0, min=0.0, help="Seconds a capture file must go unmodified before it is scored."
    ),
    stale_after: str = typer.Option(
        "3d", help="An axis without a new capture for this long is stale (3d, 12h, ... or off)."
    ),
    progress: bool = typer.Option(True, help="Progress bar on stderr (only on a terminal)."),
    debug: bool = DEBUG,
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
    from axiswatch.monitor._store import Store

    with _failures(debug):
        with _usage(debug):
            config = MonitorConfig(
                method=method,
                percentile=percentile,
                calibration_size=calibration,
                alarm_k=alarm_k,
                alarm_n=alarm_n,
                clear_m=clear_m,
                baseline=baseline,
                features=dataclasses.replace(
                    DEFAULTS.features,
                    signals=tuple(s.strip() for s in signals.split(",")),
                    hop=hop,
                    segment_length=segment_length,
                ),
                lra_noise_level=_noise_level(lra_noise_level),
                align_phase=align,
                profile=None if profile is None else AxisProfile.from_toml(profile),
                task_envelope=task_envelope,
                order_lines=order_lines,
                whole_moves=whole_moves,
                max_capture_rows=max_capture_rows,
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
                typer.echo(
                    f"{result.method}: {result.n_files} capture files{unchanged}, "
                    f"{result.new_baselines} new baseline(s), {result.scored} capture(s) scored "
                    "in this run."
                )
                summary = _echo_summary(opened, silence)
                reasons = _alarm_reasons(opened, summary, result.method, list(result.alarms))
        finally:
            if client is not None:
                client.close()
        if result.waiting:
            typer.echo(
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
                typer.echo(f"\n{title} ({count}):")
                for line in lines:
                    typer.echo(f"  {line}")
        if result.acknowledged:
            typer.echo(
                f"\n{result.acknowledged} acknowledged problem(s) not shown "
                "('axiswatch rejections' lists them)."
            )
        if result.acknowledged_alarms:
            typer.echo(f"\nAcknowledged alarms ({result.method}), not counted in the exit status:")
            for seen in result.acknowledged_alarms:
                typer.echo(
                    f"  {seen.robot}/{seen.axis} since {seen.raised_capture}: seen by "
                    f"{seen.acknowledged_by} at {seen.acknowledged_at}: {seen.note}"
                )
        if result.alarms:
            axes = ", ".join(f"{robot}/{axis}" for robot, axis in result.alarms)
            typer.echo(f"\nALARM ({result.method}) on {axes}")
            for line in reasons:
                typer.echo(f"  {line}")
    raise typer.Exit(result.exit_code)


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
    top_indicator. The table shows the first seven, role and top_indicator.
    """
    import json

    from axiswatch.monitor._results import fleet_results, indicator_spreads
    from axiswatch.monitor._store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            frame = fleet_results(opened, robot=robot, axis=axis)
        if method is not None:
            frame = frame[frame["method"] == method].reset_index(drop=True)
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


def fold_same_reason(lines: list[str]) -> list[str]:
    """Rejection lines ``PATH: reason`` with one reason said once, naming how many files share it.

    A broken axis profile rejects every capture below it with the same line but for the path
    (22 identical lines for one misplaced key, i21u); ``axiswatch rejections`` still lists every
    file. Lines keep the order of their reason's first file; a line without ``": "`` is its own.

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
    groups: dict[tuple[str, int], list[str]] = {}  # (reason, 0) or (line, its index)
    for index, line in enumerate(lines):
        path, sep, reason = line.partition(": ")
        groups.setdefault((reason, 0) if sep else (line, index + 1), []).append(path)
    folded = []
    for (reason, alone), paths in groups.items():
        if alone:
            folded.append(reason)
        elif len(paths) == 1:
            folded.append(f"{paths[0]}: {reason}")
        else:
            more = len(paths) - 1
            folded.append(f"{paths[0]} (and {more} more capture files with this reason): {reason}")
    return folded


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
    from axiswatch.monitor._store import Store

    with _failures(debug):
        with _usage(debug):
            silence = _duration(stale_after, "--stale-after")
        _require_store(store)
        with Store(store) as opened:
            page = write_report(opened, out, stale_after=silence)
        typer.echo(f"Report: {page}")


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
    from axiswatch.monitor._store import Store

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
        typer.echo(
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
    from axiswatch.monitor._store import Store, now

    with _failures(debug):
        if retry and ack:
            with _usage(debug):
                raise ValueError("choose one of --retry and --ack.")
        _require_store(store)
        chosen = method
        with Store(store) as opened:
            if (retry or ack) and paths:
                _known_problem_paths(paths, list(opened.problem_table(chosen)["path"]), chosen)
            if retry:
                count = opened.retry_rejections(paths or [], chosen)
                typer.echo(
                    f"{count} rejection(s) forgotten; the next monitor run tries them again."
                )
                return
            if ack:
                count = opened.acknowledge_problems(paths or [], now(), chosen)
                typer.echo(f"{count} problem(s) acknowledged; they no longer set exit status 8.")
                return
            frame = opened.problem_table(chosen)
        if frame.empty:
            typer.echo("No rejected captures, changed files or baselines to check.")
            return
        # The stored error line starts with the path (it is printed alone by monitor); beside
        # the path column that doubled every row's width.
        frame["error"] = _without_path(frame["path"], frame["error"])
        frame["acknowledged"] = frame.pop("acknowledged_at").fillna("")
        removed = frame.pop("removed_at")
        if removed.notna().any():  # rejected files a run found gone: history, not a problem
            frame["removed"] = removed.fillna("")
        typer.echo(frame.to_string(index=False))


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
    list_: bool = typer.Option(
        False, "--list", help="List the acknowledgements (of --robot/--axis if given) instead."
    ),
    debug: bool = DEBUG,
) -> None:
    """Record that an alarm was seen: it no longer makes monitor exit 4 until raised again.

    The report shows who saw it. With --rebaseline (after maintenance) the axis's baseline is
    also retired; the next monitor run starts a new one (see 'axiswatch rebaseline').
    """
    from axiswatch.monitor._ledger import rebaseline as retire
    from axiswatch.monitor._store import Store

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
    chosen = method
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
        typer.echo(f"Wrote {len(labels)} captures to {out} (labels in {out / 'labels.csv'}).")
        for row in faulty.reset_index().itertuples(index=False):
            typer.echo(f"  developing fault: {row.robot}/{row.axis} {row.fault}")


@app.command()
def backup(
    store: ExistingStorePath,
    destination: Annotated[Path, typer.Argument(help="The new file (never overwritten).")],
    debug: bool = DEBUG,
) -> None:
    """Write a consistent copy of the store, also while monitor runs (SQLite's online backup)."""
    from axiswatch.monitor._store import Store

    with _failures(debug):
        _require_store(store)
        with Store(store) as opened:
            copy = opened.backup(destination)
        with Store(copy, read_only=True) as restored:
            rows = len(restored.score_table())
        typer.echo(f"Backup: {copy} ({rows} score rows); open it with --store to use it.")


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
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor._report import write_report
    from axiswatch.monitor._store import Store

    with _failures(debug):
        folder = Path(tempfile.mkdtemp(prefix="axiswatch-demo-")) if out is None else out
        folder.mkdir(parents=True, exist_ok=True)
        root = folder / "fleet"
        typer.echo(f"Simulating a fleet into {root} ...")
        labels = simulate_fleet(root, n_days=days, seed=seed)
        with Store(folder / "fleet.db") as opened, _progress(True) as update:
            for method in (DEFAULT_METHOD, "lra", "pca"):
                # The simulator has just written every file completely: nothing to wait for.
                config = MonitorConfig(method=method)
                monitor_fleet(root, opened, config, progress=update, settle_s=0)
            typer.echo("\nFleet summary (state after the last capture):")
            _echo_summary(opened, None)
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


#: Entry-point group through which installed packages add command groups to ``axiswatch``
#: (the research package adds ``experiment``); the CLI never imports them by name.
PLUGIN_GROUP = "axiswatch.commands"


def _add_plugins() -> None:
    from importlib.metadata import entry_points

    for entry in entry_points(group=PLUGIN_GROUP):
        app.add_typer(entry.load(), name=entry.name)


def main() -> None:
    """Entry point of the ``axiswatch`` script."""
    _add_plugins()
    sys.exit(app())
