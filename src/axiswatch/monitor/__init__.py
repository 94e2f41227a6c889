"""The fleet service: monitor a folder of capture files, remember every score, raise alarms.

:func:`monitor_fleet` scores new captures into a store. :func:`fleet_summary`,
:func:`fleet_results` and :func:`write_report` read them back. docs/monitor.md is the manual.
"""

from importlib import import_module as _import_module
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any

if _TYPE_CHECKING:  # the names as type checkers and IDEs see them
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.monitor._fleet import (
        FleetFile,
        discover_fleet,
        parse_capture_time,
    )
    from axiswatch.monitor._ledger import (
        rebaseline,
    )
    from axiswatch.monitor._methods import (
        MethodPreset,
        methods,
        register_method,
    )
    from axiswatch.monitor._monitor import (
        MonitorSummary,
        monitor_fleet,
    )
    from axiswatch.monitor._parallel import (
        parallel_map,
    )
    from axiswatch.monitor.report.html import (
        write_report,
    )
    from axiswatch.monitor.report.results import (
        fleet_results,
        fleet_summary,
    )
    from axiswatch.monitor.store import (
        SQLiteStore,
        Store,
        StoreBackend,
    )

#: Public name -> the module it is imported from, on first use (PEP 562): the CLI imports
#: the scoring stack only for a command that scores.
_EXPORTS: dict[str, str] = {
    "FleetFile": "axiswatch.monitor._fleet",
    "MethodPreset": "axiswatch.monitor._methods",
    "MonitorConfig": "axiswatch.monitor._config",
    "MonitorSummary": "axiswatch.monitor._monitor",
    "SQLiteStore": "axiswatch.monitor.store",
    "Store": "axiswatch.monitor.store",
    "StoreBackend": "axiswatch.monitor.store",
    "discover_fleet": "axiswatch.monitor._fleet",
    "fleet_results": "axiswatch.monitor.report.results",
    "fleet_summary": "axiswatch.monitor.report.results",
    "methods": "axiswatch.monitor._methods",
    "monitor_fleet": "axiswatch.monitor._monitor",
    "parallel_map": "axiswatch.monitor._parallel",
    "parse_capture_time": "axiswatch.monitor._fleet",
    "rebaseline": "axiswatch.monitor._ledger",
    "register_method": "axiswatch.monitor._methods",
    "write_report": "axiswatch.monitor.report.html",
}

__all__ = [
    "FleetFile",
    "MethodPreset",
    "MonitorConfig",
    "MonitorSummary",
    "SQLiteStore",
    "Store",
    "StoreBackend",
    "discover_fleet",
    "fleet_results",
    "fleet_summary",
    "methods",
    "monitor_fleet",
    "parallel_map",
    "parse_capture_time",
    "rebaseline",
    "register_method",
    "write_report",
]


def __getattr__(name: str) -> _Any:
    """Import a public name's module on first use and keep the name here."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
