"""The monitoring store: records in domain words, a protocol per caller, and SQLite, its backend.

Every SQL statement of axiswatch is in this package (``tests/monitor/store/test_store_contract.py`` checks it,
and holds the contract tests any other backend must pass). ``Store`` is the name users open a
store by (``aw.Store("fleet.db")``): the SQLite backend.
"""

from axiswatch.monitor.store.protocols import (
    RunCaches,
    StoreBackend,
    StoreOperator,
    StoreReader,
    StoreWriter,
)
from axiswatch.monitor.store.records import (
    AddedBaseline,
    AlarmState,
    Baseline,
    BaselineCheck,
    ChangedFile,
    IndexedFile,
    NewBaseline,
    NewScore,
    Rejection,
    SavedModel,
    ScoredFile,
    now,
    now_us,
    summary_extras,
)
from axiswatch.monitor.store.sqlite import SQLiteStore, Store
from axiswatch.monitor.store.upgrades import SCHEMA_VERSION

__all__ = [
    "SCHEMA_VERSION",
    "AddedBaseline",
    "AlarmState",
    "Baseline",
    "BaselineCheck",
    "ChangedFile",
    "IndexedFile",
    "NewBaseline",
    "NewScore",
    "Rejection",
    "RunCaches",
    "SQLiteStore",
    "SavedModel",
    "ScoredFile",
    "Store",
    "StoreBackend",
    "StoreOperator",
    "StoreReader",
    "StoreWriter",
    "now",
    "now_us",
    "summary_extras",
]
