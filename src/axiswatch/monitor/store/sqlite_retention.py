"""Retention of the SQLite store: old monitored scores thinned to one per axis and period.

What is never thinned: docs/internals.md, "Retention".
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from datetime import timedelta

__all__ = ["RECENT_KEPT", "Compaction", "THINNED_SCORES", "thin"]

#: The latest monitored scores of each baseline kept in full: more than any alarm rule's window.
RECENT_KEPT = 100

THINNED_SCORES = """
CREATE TABLE IF NOT EXISTS thinned_scores (
    id INTEGER PRIMARY KEY,
    baseline_id INTEGER NOT NULL REFERENCES baselines (id),
    capture TEXT NOT NULL,
    path TEXT NOT NULL,
    file_hash TEXT NOT NULL,
    file_size INTEGER NOT NULL,
    file_mtime_ns INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS thinned_scores_baseline ON thinned_scores (baseline_id, capture);
CREATE INDEX IF NOT EXISTS thinned_scores_path ON thinned_scores (path)
"""

#: The ids of the scores to thin: older than the kept period before the newest capture, and
#: not the highest distance of their baseline's period (``?3`` seconds, counted from
#: 1970-01-01, so that days start at midnight); see the module's doc.
_DOOMED = """
CREATE TEMP TABLE doomed AS
WITH monitored AS (
    SELECT s.id, lead(s.alarm) OVER (PARTITION BY s.baseline_id ORDER BY s.id) AS next_alarm,
        row_number() OVER (PARTITION BY s.baseline_id ORDER BY s.id DESC) AS from_last,
        max(?2, coalesce(json_extract(b.params, '$.alarm.n'), 0),
            coalesce(json_extract(b.params, '$.alarm.clear_m'), 0)) AS recent
    FROM scores s JOIN baselines b ON b.id = s.baseline_id WHERE s.role='monitor'
),
old AS (
    SELECT s.id, s.alarm, s.over, s.role, row_number() OVER (
        PARTITION BY s.baseline_id,
            CAST((julianday(s.captured_at) - 2440587.5) * 86400.0 / ?3 AS INTEGER)
        ORDER BY s.distance DESC NULLS LAST, s.id) AS in_period
    FROM scores s
    WHERE s.role IN ('monitor', 'excluded')
        AND julianday(s.captured_at) < (SELECT julianday(max(captured_at)) FROM scores) - ?1
)
SELECT o.id FROM old o LEFT JOIN monitored m ON m.id = o.id
WHERE o.in_period > 1 AND o.alarm = 0 AND o.over = 0
    AND coalesce(m.next_alarm, 0) = 0 AND (m.id IS NULL OR m.from_last > m.recent)
    AND o.id NOT IN (SELECT score_id FROM acknowledgements WHERE score_id IS NOT NULL)
"""


@dataclass(frozen=True)
class Compaction:
    """What :func:`thin` did: scores thinned, and scores left in full."""

    thinned: int
    kept: int


def thin(
    db: sqlite3.Connection, keep: timedelta, every: timedelta, recent: int = RECENT_KEPT
) -> Compaction:
    """Thin the scores older than ``keep`` (before the newest capture) to one per baseline and
    ``every``: the highest distance of the period, besides those the module's doc keeps (the
    last ``recent`` monitored scores of a baseline, or its alarm rule's window if longer)."""
    db.execute("DROP TABLE IF EXISTS temp.doomed")
    db.execute(_DOOMED, (keep.total_seconds() / 86400.0, recent, every.total_seconds()))
    db.execute(
        "INSERT INTO thinned_scores (id, baseline_id, capture, path, file_hash, file_size, "
        "file_mtime_ns) SELECT id, baseline_id, capture, path, file_hash, file_size, "
        "file_mtime_ns FROM scores WHERE id IN (SELECT id FROM temp.doomed)"
    )
    thinned = db.execute("DELETE FROM scores WHERE id IN (SELECT id FROM temp.doomed)").rowcount
    db.execute("DROP TABLE temp.doomed")
    kept = db.execute("SELECT count(*) FROM scores").fetchone()[0]
    return Compaction(thinned=int(thinned), kept=int(kept))
