"""The packed score texts: lossless packing, and the upgrade of a version-2 store.

``tests/data/store-v2.db`` was written by the previous version (scores' reason and details as
text): one robot, two axes, 14 days, an alarm, an acknowledged re-baseline. The hashes below
are of its reads by that version; the upgraded store must read the same.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from axiswatch.monitor.report.results import fleet_results
from axiswatch.monitor.store import SCHEMA_VERSION, Store
from axiswatch.monitor.store.packing import pack, unpack

V2_STORE = Path(__file__).parents[2] / "data" / "store-v2.db"

#: sha256 of each read's CSV (``float_format="%.17g"``), by the version that wrote the store;
#: ``fleet_results`` is also the hash of ``axiswatch results --format csv``.
V2_READS = {
    "score_table": "331a54f3260955afb6922d59069763c549fad753f899606a6764ef19bd2cc88f",
    "fleet_results": "eebd5e77c77bb615b5dbd6fb6c38e0f501f30183acf43a14c58c67c9aedbb55a",
    "summary_table": "2ebc9d43274954d6cd7c331ccaeb1be48fc658dbcd3eca15474d3dfb1b622a24",
    "acknowledgements": "b4242246c1c7ddb7440ef37eebe62b260d6ba429f80481615671060fbade140d",
    "rejection_table": "3fe5716f8fbd7cb9dbfb44603051ac6f621d3fcbbd9296a48c201311b69000b1",
    "alarms": "01ba4719c80b6fe911b091a7c05124b64eeece964e09c058ef8f9805daca546b",
    "scored_files": "e5c930705e0f57c23b32dfe23816dc7c534e4523ebeb4542eefc261fc2bae165",
}


def _reads(store: Store) -> dict[str, str]:
    results = fleet_results(store)
    # Scored without modes: the column added since is empty, and the rest reads as before.
    assert results.pop("mode").isna().all()
    frames = {
        "score_table": store.score_table(),
        "fleet_results": results,
        "summary_table": store.summary_table(),
        "acknowledgements": store.acknowledgements(),
        "rejection_table": store.rejection_table(),
        "alarms": pd.DataFrame(store.alarms()),
        "scored_files": pd.DataFrame(store.scored_files().values()),
    }
    return {
        name: hashlib.sha256(frame.to_csv(index=False, float_format="%.17g").encode()).hexdigest()
        for name, frame in frames.items()
    }


def _columns(path: Path, table: str) -> set[str]:
    with sqlite3.connect(path) as connection:
        return {row[1] for row in connection.execute(f"PRAGMA table_info({table})")}


def test_upgrade_of_a_version_2_store_keeps_every_read(tmp_path: Path) -> None:
    store_path = tmp_path / "fleet.db"
    shutil.copy(V2_STORE, store_path)
    assert {"reason", "details"} <= _columns(store_path, "scores")
    with Store(store_path) as store:
        assert store.version == SCHEMA_VERSION == 3
        assert _reads(store) == V2_READS
    columns = _columns(store_path, "scores")
    assert {"packed", "primed"} <= columns
    assert not {"reason", "details"} & columns
    with Store(store_path, read_only=True) as again:  # the upgraded file, reopened
        assert _reads(again) == V2_READS


def test_read_only_upgrade_reads_the_same_and_writes_nothing(tmp_path: Path) -> None:
    store_path = tmp_path / "fleet.db"
    shutil.copy(V2_STORE, store_path)
    before = store_path.read_bytes()
    with Store(store_path, read_only=True) as store:
        assert _reads(store) == V2_READS
    assert store_path.read_bytes() == before


def test_packing_is_bit_exact_for_float64() -> None:
    values = np.random.default_rng(0).standard_normal(200) * 10.0 ** np.arange(-100, 100)
    details = json.dumps({f"v{i}": float(v) for i, v in enumerate(values)}, sort_keys=True)
    dictionary = json.dumps({"v0": 1.5, "v1": -2.25}).encode()
    for primer in (None, dictionary):
        reason, text = unpack(pack("healthy", details, primer), primer)
        assert (reason, text) == ("healthy", details)
        parsed = json.loads(text)
        restored = np.array([parsed[f"v{i}"] for i in range(len(values))])
        assert restored.tobytes() == values.tobytes()


def test_packing_refuses_a_reason_with_a_nul() -> None:
    with pytest.raises(ValueError, match="reason must not hold a NUL character"):
        pack("bad\x00reason", "{}", None)
