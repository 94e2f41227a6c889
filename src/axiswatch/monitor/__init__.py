"""The fleet service: monitor a folder of capture files, remember every score, raise alarms.

``monitor_fleet(root, store, config)`` discovers ``ROOT/<robot>/<axis>/<capture>`` files, fits each
axis's baseline, calibrates its threshold, scores new captures and records the results in a
store; ``fleet_summary``, ``fleet_results`` and ``write_report`` read them back.

A store is any :class:`StoreBackend` (the protocol, in domain words); ``Store(path)`` opens the
product's, :class:`SQLiteStore`. A method of the monitor is a :class:`MethodPreset` registered by
name (:func:`register_method`; built in: ``mechanics``, the default, ``lra`` and ``pca``).
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
from axiswatch.monitor.store import (
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
