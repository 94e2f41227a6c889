"""Bytes per scored capture in the store: the previous layout, the packed one, and after compact.

Run: ``.venv/bin/python benchmarks/bench_store_size.py [robots] [axes] [days]`` (default 3 x 2 x
60). A simulated fleet with the axis profiles the simulator writes is monitored twice: the first
half of its days, then all of them. Each snapshot is copied with ``VACUUM INTO``. The figure is
the growth of the file between the snapshots over the scores added: what a day's captures cost,
without the fixed pages and the fitted models of a new store. The previous layout (schema 2:
reason and details as text) is the same snapshot with its scores unpacked by raw SQL. The last
line is the store after ``compact --keep 7d --every 7d`` (a week thinned to one score).
"""

from __future__ import annotations

import shutil
import sqlite3
import sys
import tempfile
from datetime import timedelta
from pathlib import Path

from axiswatch.datasets import simulate_fleet
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.store import Store
from axiswatch.monitor.store.packing import unpack


def previous_layout(packed: Path, target: Path) -> Path:
    """A copy of ``packed`` in schema 2: each score's reason and details as text, the index of
    scores by axis, and the file index with a row id."""
    shutil.copy(packed, target)
    with sqlite3.connect(target) as db:
        db.execute("ALTER TABLE scores ADD COLUMN reason TEXT NOT NULL DEFAULT ''")
        db.execute("ALTER TABLE scores ADD COLUMN details TEXT NOT NULL DEFAULT ''")
        primers = {b: bytes(d) for b, d in db.execute("SELECT * FROM score_dictionaries")}
        rows = db.execute("SELECT id, baseline_id, packed, primed FROM scores").fetchall()
        for score_id, baseline_id, blob, primed in rows:
            reason, details = unpack(bytes(blob), primers[baseline_id] if primed else None)
            db.execute(
                "UPDATE scores SET reason=?, details=? WHERE id=?", (reason, details, score_id)
            )
        db.execute("ALTER TABLE scores DROP COLUMN packed")
        db.execute("ALTER TABLE scores DROP COLUMN primed")
        db.execute("DROP TABLE score_dictionaries")
        db.execute("DROP TABLE thinned_scores")
        db.execute("CREATE INDEX scores_axis ON scores (robot, axis, method)")
        db.execute("ALTER TABLE file_index RENAME TO file_index_new")
        db.execute(
            "CREATE TABLE file_index (path TEXT PRIMARY KEY, size INTEGER NOT NULL, "
            "mtime_ns INTEGER NOT NULL, hash TEXT NOT NULL, verified_run INTEGER NOT NULL)"
        )
        db.execute("INSERT INTO file_index SELECT * FROM file_index_new")
        db.execute("DROP TABLE file_index_new")
        db.execute("CREATE INDEX file_index_verified_path ON file_index (verified_run, path)")
    vacuumed = target.with_suffix(".vacuumed.db")
    with sqlite3.connect(target) as db:
        db.execute("VACUUM INTO ?", (str(vacuumed),))
    return vacuumed


def snapshot(store: Path, target: Path) -> tuple[int, int]:
    """``VACUUM INTO`` ``target``; its size and number of scores."""
    with sqlite3.connect(store) as db:
        db.execute("VACUUM INTO ?", (str(target),))
    with sqlite3.connect(target) as db:
        scores = int(db.execute("SELECT count(*) FROM scores").fetchone()[0])
    return target.stat().st_size, scores


def size_and_scores(path: Path) -> tuple[int, int]:
    with sqlite3.connect(path) as db:
        scores = int(db.execute("SELECT count(*) FROM scores").fetchone()[0])
    return path.stat().st_size, scores


def main(robots: int = 3, axes: int = 2, days: int = 60) -> None:
    folder = Path(tempfile.mkdtemp())
    fleet, later = folder / "fleet", folder / "later"
    simulate_fleet(fleet, n_robots=robots, n_axes=axes, n_days=days, duration_s=1.0)
    half = sorted({p.name for p in fleet.glob("*/*/*.parquet")})[days // 2 :]
    for capture in fleet.glob("*/*/*.parquet"):
        if capture.name in half:
            target = later / capture.relative_to(fleet)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(capture, target)
    store = folder / "fleet.db"
    config = MonitorConfig()
    snapshots = []
    for part in ("half", "full"):
        with Store(store) as opened:
            monitor_fleet(fleet, opened, config, settle_s=0.0)
        packed = folder / f"{part}-packed.db"
        snapshot(store, packed)
        snapshots.append(
            (size_and_scores(previous_layout(packed, folder / f"{part}-v2.db")),
             size_and_scores(packed))
        )  # fmt: skip
        for capture in later.glob("*/*/*.parquet"):
            shutil.move(capture, fleet / capture.relative_to(later))
    (old_half, new_half), (old_full, new_full) = snapshots
    added = new_full[1] - new_half[1]
    old = (old_full[0] - old_half[0]) / added
    new = (new_full[0] - new_half[0]) / added
    print(f"fleet: {robots} robots x {axes} axes x {days} days, axis profiles, default method")
    print(f"scores added between the snapshots: {added}")
    print(f"previous layout: {old:7.0f} bytes per scored capture")
    print(f"packed layout:   {new:7.0f} bytes per scored capture  ({old / new:.2f}x smaller)")
    with Store(store) as opened:
        done = opened.compact(timedelta(days=7), timedelta(days=7), recent=7)
    size, _ = snapshot(store, folder / "compacted.db")
    print(
        f"after compact --keep 7d --every 7d (7 recent kept): {done.thinned} of {new_full[1]} scores "
        f"thinned; {new_full[0] / 1e3:.0f} kB -> {size / 1e3:.0f} kB"
    )
    shutil.rmtree(folder)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
