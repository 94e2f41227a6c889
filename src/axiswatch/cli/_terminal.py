"""What the CLI prints and how: escaped text, one-line failures, a progress bar, tables."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import typer

from axiswatch_launcher import INTERRUPTED, INTERRUPTED_STATUS, forget_the_interrupt

__all__ = ["echo", "failures", "printable", "progress", "show_guesses", "usage"]


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
def failures(debug: bool) -> Iterator[None]:
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
        forget_the_interrupt()
        raise typer.Exit(INTERRUPTED_STATUS) from None
    except (AxiswatchError, ValueError, OSError, NotImplementedError) as exc:
        if debug:
            raise
        echo(f"error: {exc}", err=True)
        raise typer.Exit(1) from None


@contextmanager
def usage(debug: bool) -> Iterator[None]:
    """Turn an invalid option value into one line on stderr and exit status 2."""
    try:
        yield
    except ValueError as exc:
        if debug:
            raise
        echo(f"usage error: {exc}", err=True)
        raise typer.Exit(2) from None


@contextmanager
def progress(enabled: bool) -> Iterator[Callable[[str, int, int], None]]:
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


def show_guesses(guesses: list[Any]) -> None:
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
            assumed = "?" if axis.unit_assumed else ""
            if "position" in by_role:
                cells[0] += f" in {axis.position_unit}{assumed}"
            elif "speed" in by_role:
                cells[1] += f" in {axis.position_unit}/s{assumed}"
            # To 0.1 Hz: a PLC's irregular steps give each file its own rate in the next digit,
            # and one axis took a row per file.
            rates = ", ".join(sorted({_hz(rate) for rate in axis.rates_hz.values()}))
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
    # One note per cause: six axes of one file differ only in their columns' numbers.
    causes: dict[str, list[str]] = {}
    for note in sorted(notes):
        causes.setdefault(re.sub(r"\d+", "#", note), []).append(note)
    for same in causes.values():
        more = f" (and {len(same) - 1} more like it)" if len(same) > 1 else ""
        echo(f"note: {same[0]}{more}")


def _hz(rate: float) -> str:
    """A rate to 0.1 Hz, without a trailing ``.0``.

    Examples
    --------
    >>> _hz(21.3354), _hz(250.0), _hz(2048.0)
    ('21.3', '250', '2048')
    """
    return f"{rate:.1f}".removesuffix(".0")


def _terminal_width() -> int:
    import shutil

    return shutil.get_terminal_size().columns
