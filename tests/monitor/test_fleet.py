"""Fleet discovery: layout rules, ISO date prefixes, ordering."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest

from axiswatch.monitor._fleet import discover_fleet, misnamed_folder_key, parse_capture_time


def _touch(root: Path, *names: str) -> None:
    for name in names:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("time,speed\n")


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("2026-03-01.parquet", datetime(2026, 3, 1)),
        ("2026-03-01T06-00-00.csv", datetime(2026, 3, 1, 6)),
        ("2026-03-01T06:30:15_after-service.csv", datetime(2026, 3, 1, 6, 30, 15)),
        ("2026-03-01_063015.csv", datetime(2026, 3, 1, 6, 30, 15)),
    ],
)
def test_parse_capture_time(name: str, expected: datetime) -> None:
    assert parse_capture_time(name) == expected


def test_parse_capture_time_rejects_names_without_a_date() -> None:
    with pytest.raises(ValueError, match=r"'notes.csv' does not start with an ISO date"):
        parse_capture_time("notes.csv")


def test_parse_capture_time_rejects_impossible_dates() -> None:
    with pytest.raises(ValueError, match=r"starts with '2026-13-01', which is not a valid"):
        parse_capture_time("2026-13-01.csv")


def test_discover_orders_by_date_time_then_name(tmp_path: Path) -> None:
    _touch(
        tmp_path,
        "r2/a1/2026-03-01.csv",
        "r1/a1/2026-03-02.csv",
        "r1/a1/2026-03-01T12-00-00.parquet",
        "r1/a1/2026-03-01.parquet",
        "r1/a1/2026-03-01.csv",
    )
    files, problems = discover_fleet(tmp_path)
    assert problems == []
    assert [(f.robot, f.capture) for f in files] == [
        ("r1", "2026-03-01.csv"),
        ("r1", "2026-03-01.parquet"),
        ("r1", "2026-03-01T12-00-00.parquet"),
        ("r1", "2026-03-02.csv"),
        ("r2", "2026-03-01.csv"),
    ]


def test_discover_ignores_non_captures_and_reports_layout_problems(tmp_path: Path) -> None:
    _touch(
        tmp_path,
        "labels.csv",  # files directly in ROOT are not captures
        "r1/a1/notes.txt",  # not a capture type
        ".hidden/a1/2026-03-01.csv",
        "r1/a1/.2026-03-01.csv",
        "r1/a1/2026-03-01.csv",
        "r1/2026-03-01.csv",
        "r1/a1/deep/2026-03-01.csv",
        "bad robot/a1/2026-03-01.csv",
        "bad robot/a2/2026-03-01.csv",
        "r1/-axis/2026-03-01.csv",
        "r1/a1/monday.csv",
    )
    files, problems = discover_fleet(tmp_path)
    assert [f.path.relative_to(tmp_path).as_posix() for f in files] == ["r1/a1/2026-03-01.csv"]
    reasons = sorted(p.reason for p in problems)
    assert reasons == [
        "bad robot/: robot folder name 'bad robot' is not an identifier (1-64 ASCII letters, "
        "digits, '_', '-' or '.', starting with a letter or digit); its 2 capture file(s) are "
        "not scored until the folder is renamed.",
        "r1/-axis/: axis folder name '-axis' is not an identifier (1-64 ASCII letters, "
        "digits, '_', '-' or '.', starting with a letter or digit); its 1 capture file(s) are "
        "not scored until the folder is renamed.",
        "r1/2026-03-01.csv: capture file at the wrong depth; expected "
        "ROOT/<robot>/<axis>/<capture>.<ext>.",
        "r1/a1/deep/2026-03-01.csv: capture file at the wrong depth; expected "
        "ROOT/<robot>/<axis>/<capture>.<ext>.",
        "r1/a1/monday.csv: capture name 'monday.csv' does not start with an ISO date such as "
        "2026-03-01 or 2026-03-01T06-00-00.",
    ]
    # A store's line from before reason_key gets the key a run stores now (its reason without
    # the count); no other line has one.
    assert [misnamed_folder_key(p.reason) for p in problems] == [p.reason_key for p in problems]
    assert sum(p.reason_key is not None for p in problems) == 2


def test_discover_needs_a_folder(tmp_path: Path) -> None:
    with pytest.raises(NotADirectoryError, match=r"fleet folder '.*missing' does not exist"):
        discover_fleet(tmp_path / "missing")
