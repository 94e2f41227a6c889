"""Check what a run asks for before anything is stored: the fleet folder, signals, baseline."""

from __future__ import annotations

import json
from collections.abc import Mapping
from glob import escape
from pathlib import Path
from typing import Any

from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import ProfileError
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._fleet import (
    FleetFile,
    check_fleet_root,
    discover_fleet,
)
from axiswatch.monitor._scoring import profile_for
from axiswatch.paper._features import FeatureSpec

__all__ = ["check_request", "parameter_differences"]


def parameter_differences(stored: str, asked: str) -> list[str]:
    """The parameters that differ between two ``params`` JSON texts, one ``name: a -> b`` each.

    Examples
    --------
    >>> parameter_differences('{"a": 1, "b": {"c": 2}}', '{"a": 1, "b": {"c": 3}, "d": 4}')
    ['b.c: 2 -> 3', 'd: (none) -> 4']
    """

    def flat(value: Any, prefix: str = "") -> dict[str, Any]:
        if isinstance(value, dict):
            out: dict[str, Any] = {}
            for key, item in value.items():
                out.update(flat(item, f"{prefix}{key}."))
            return out
        return {prefix[:-1]: value}

    old, new = flat(json.loads(stored)), flat(json.loads(asked))
    return [
        f"{name}: {json.dumps(old[name]) if name in old else '(none)'} -> "
        f"{json.dumps(new[name]) if name in new else '(none)'}"
        for name in sorted(set(old) | set(new))
        if old.get(name, ...) != new.get(name, ...)
    ]


def check_request(
    root: str | Path,
    config: MonitorConfig,
    *,
    finished: Mapping[tuple[str, str], int] | None = None,
) -> None:
    """Check what a run asks for before anything is stored.

    ``finished``: axis folders a run with these very parameters finished (``monitor._index``),
    with their modification times then. With any, the signals were columns of the captures it
    scored and are not looked up again, and one unchanged folder shows the fleet folder is not
    an unmounted share (looking again would list folders a run with nothing new never lists).

    Raises
    ------
    NotADirectoryError, DataNotFoundError
        If ``root`` is not a folder or holds no capture file (an unmounted share).
    ValueError
        If ``config.baseline`` names a file that no axis folder holds, or a signal is a column
        of none of the first captures of the first axes (a typo such as ``torqe``).
    """
    root = Path(root)
    check_fleet_root(root, known=finished)
    if not finished:
        _check_signals(root, config)
    if (
        config.baseline is not None
        and next(root.glob(f"*/*/{escape(config.baseline)}"), None) is None
    ):
        raise ValueError(
            f"baseline capture '{config.baseline}' is in no axis folder of '{root}'; expected "
            "the file name of a capture, such as 2026-03-01.parquet."
        )


#: Axes whose first capture's columns are compared with the requested signals.
_AXES_CHECKED = 8


def _check_signals(root: Path, config: MonitorConfig) -> None:
    """Raise when a requested signal is a column of no capture among the first of a few axes
    (axes read through a profile that maps their own column names are not looked at).

    Only signals the user chose are checked: with the default signals, a fleet whose files name
    their columns otherwise is a data problem, rejected per capture with the missing column and
    the hint of an axis profile, not a usage error.
    """
    signals = config.features.signals
    if tuple(signals) == tuple(FeatureSpec().signals):
        return
    listed: set[tuple[str, str]] = set()

    def beyond_checked(robot: str, axis: str) -> bool:
        # Without a profile every axis is looked at: the first few folders are enough.
        if config.profile is None and len(listed) >= _AXES_CHECKED:
            return True
        listed.add((robot, axis))
        return False

    files, _ = discover_fleet(root, skip=beyond_checked)
    files = [f for f in files if not _maps_columns(f, config.profile)]
    firsts = list({(f.robot, f.axis): f for f in reversed(files)}.values())[-_AXES_CHECKED:]
    seen: dict[str, list[str]] = {}
    for file in firsts:
        try:
            seen[file.path.relative_to(root).as_posix()] = _columns(file.path)
        except Exception:
            continue
    if not seen:
        return
    missing = [name for name in signals if not any(name in cols for cols in seen.values())]
    if missing:
        example, columns = next(iter(seen.items()))
        raise ValueError(
            f"The 'signals' parameter names {missing}, a column of none of {len(seen)} capture "
            f"file(s) looked at; {example} has columns {columns}."
        )


def _maps_columns(file: FleetFile, given: AxisProfile | None) -> bool:
    """Whether the file's profile renames its columns (a malformed profile is not looked at
    here: the file's jobs reject it with the profile's error)."""
    try:
        profile = profile_for(file, given)
    except ProfileError:
        return True
    return profile is not None and bool(profile.columns)


def _columns(path: Path) -> list[str]:
    """Column names of a capture file, read from its header only."""
    if path.suffix.lower() == ".parquet":
        import pyarrow.parquet as pq

        return [str(name) for name in pq.read_schema(path).names]
    import pandas as pd

    return [str(name) for name in pd.read_csv(path, nrows=0).columns]
