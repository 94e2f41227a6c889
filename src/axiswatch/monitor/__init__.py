"""The fleet service: monitor a folder of capture files, remember every score, raise alarms.

:func:`monitor_fleet` scores new captures into a store. :func:`fleet_summary`,
:func:`fleet_results` and :func:`write_report` read them back. docs/monitor.md is the manual.
"""

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
from axiswatch.monitor._report import (
    write_report,
)
from axiswatch.monitor._results import (
    fleet_results,
    fleet_summary,
)
from axiswatch.monitor._scoring import (
    MonitorConfig,
)
from axiswatch.monitor._store import (
    SQLiteStore,
    Store,
    StoreBackend,
)

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
