"""The CLI's option types, parsers and help: what each option accepts and shows."""

from __future__ import annotations

import re
from datetime import timedelta
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any, Literal

import typer
from typer.core import TyperCommand, TyperGroup, TyperOption

__all__ = [
    "DEBUG",
    "PLUGIN_GROUP",
    "Commands",
    "ExistingStorePath",
    "Format",
    "MonitorCommand",
    "StorePath",
    "advanced_help",
    "duration",
    "monitor_defaults",
    "noise_level",
    "registered_method",
]

#: Entry-point group through which installed packages add command groups to ``axiswatch``
#: (the research package adds ``experiment``); the CLI never imports them by name.
PLUGIN_GROUP = "axiswatch.commands"


class Commands(TyperGroup):
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


_DURATION = re.compile(r"(?P<value>\d+(?:\.\d+)?)\s*(?P<unit>[smhd])")
_UNIT_S = {"s": 1, "m": 60, "h": 3600, "d": 86400}


def duration(text: str, option: str) -> timedelta | None:
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


def registered_method(name: str | None) -> str | None:
    """``--method``: a method registered when the command runs (plugins included)."""
    from axiswatch.monitor._methods import is_method, methods

    if name is not None and not is_method(name):
        raise typer.BadParameter(
            f"expected one of {', '.join(methods())}; got {name!r}.", param_hint="'--method'"
        )
    return name


def monitor_defaults() -> dict[str, Any]:
    """The value of each ``monitor`` option left out: the field of :class:`MonitorConfig` it sets.

    The options default to None, so that the CLI imports the scoring stack only when a command
    needs it; the help shows these values.
    """
    from axiswatch.monitor._config import MonitorConfig

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
        "modes": config.modes,
        "max_capture_rows": config.max_capture_rows,
    }


class MonitorCommand(TyperCommand):
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


def advanced_help(ctx: typer.Context, param: Any, shown: bool) -> None:
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


def noise_level(text: str) -> float | Literal["auto"]:
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
