"""A fleet on disk: ``ROOT/<robot>/<axis>/<capture>.<ext>``, discovered and ordered by date.

Pipeline side-stage of the monitor (it only looks at names, never at file contents).

Rules (documented in the README):

* a capture file ends in a registered capture suffix, ``.parquet``, ``.csv`` or ``.npz`` by default
  (any case; :func:`axiswatch.register_format` adds one); other files are not captures and are
  ignored, as are hidden files and folders (name starting with ``.``) and files directly in
  ``ROOT`` (``labels.csv``, notes);
* ``<robot>`` and ``<axis>`` are identifiers: 1-64 letters, digits, ``_``, ``-`` or ``.``,
  starting with a letter or digit;
* ``<capture>`` starts with an ISO date ``YYYY-MM-DD`` or date-time ``YYYY-MM-DDTHH-MM-SS``
  (``:`` or nothing also accepted between hours, minutes and seconds; ``T``, ``_`` or a space
  before the time); anything after it (``_run2``) is free;
* a capture file at another depth, or with a name breaking these rules, is a *layout problem*:
  the monitor stores it as rejected, with the reason, and goes on.

Captures of one axis are ordered by their date-time, then by file name.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from axiswatch._formats import capture_suffixes

__all__ = ["FleetFile", "LayoutProblem", "discover_fleet", "parse_capture_time"]

_IDENTIFIER = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_STAMP = re.compile(
    r"(?P<date>\d{4}-\d{2}-\d{2})"
    r"(?:[T_ ](?P<hour>\d{2})[-:]?(?P<minute>\d{2})[-:]?(?P<second>\d{2}))?"
    r"(?P<rest>.*)"
)


def parse_capture_time(name: str) -> datetime:
    """Date-time at the start of a capture's file name.

    Parameters
    ----------
    name : str
        File name or stem, e.g. ``"2026-03-01T06-00-00.parquet"``.

    Returns
    -------
    datetime
        Midnight when the name holds only a date.

    Raises
    ------
    ValueError
        If the name does not start with a valid ISO date or date-time.

    Examples
    --------
    >>> parse_capture_time("2026-03-01T06-30-00_after-service.csv")
    datetime.datetime(2026, 3, 1, 6, 30)
    >>> parse_capture_time("2026-03-02.parquet")
    datetime.datetime(2026, 3, 2, 0, 0)
    """
    match = _STAMP.match(name)
    if match is None:
        raise ValueError(
            f"capture name '{name}' does not start with an ISO date such as 2026-03-01 or "
            "2026-03-01T06-00-00."
        )
    text = match["date"]
    if match["hour"] is not None:
        text += f"T{match['hour']}:{match['minute']}:{match['second']}"
    try:
        return datetime.fromisoformat(text)
    except ValueError as exc:
        raise ValueError(
            f"capture name '{name}' starts with '{text}', which is not a valid date-time ({exc})."
        ) from None


@dataclass(frozen=True)
class FleetFile:
    """One capture file of the fleet.

    Attributes
    ----------
    robot, axis : str
        Folder names.
    capture : str
        File name, with extension (unique within its axis folder).
    path : Path
    captured_at : datetime
        Parsed from the file name.
    """

    robot: str
    axis: str
    capture: str
    path: Path
    captured_at: datetime


@dataclass(frozen=True)
class LayoutProblem:
    """A capture file the layout rules reject, and why (one sentence naming the file)."""

    robot: str
    axis: str
    capture: str
    path: Path
    reason: str


def _problem(root: Path, path: Path, reason: str) -> LayoutProblem:
    parts = path.relative_to(root).parts
    robot = parts[0] if len(parts) >= 2 else ""
    axis = parts[1] if len(parts) >= 3 else ""
    relative = path.relative_to(root).as_posix()
    return LayoutProblem(robot, axis, path.name, path, f"{relative}: {reason}")


def discover_fleet(root: str | Path) -> tuple[list[FleetFile], list[LayoutProblem]]:
    """Capture files under ``root``, ordered by robot, axis, date-time and name; and problems.

    Parameters
    ----------
    root : str or Path
        The fleet folder.

    Returns
    -------
    files : list of FleetFile
    problems : list of LayoutProblem

    Raises
    ------
    NotADirectoryError
        If ``root`` is not a folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("r1/a1/2026-03-02.csv", "r1/a1/2026-03-01.csv", "r1/loose.csv"):
    ...     (root / name).parent.mkdir(parents=True, exist_ok=True)
    ...     _ = (root / name).write_text("time,speed\\n")
    >>> files, problems = discover_fleet(root)
    >>> [f.capture for f in files]
    ['2026-03-01.csv', '2026-03-02.csv']
    >>> problems[0].reason
    'r1/loose.csv: capture file at the wrong depth; expected ROOT/<robot>/<axis>/<capture>.<ext>.'
    """
    root = Path(root)
    if not root.is_dir():
        raise NotADirectoryError(f"fleet folder '{root}' does not exist or is not a folder.")
    files: list[FleetFile] = []
    problems: list[LayoutProblem] = []
    suffixes = capture_suffixes()
    for path in sorted(root.rglob("*")):
        relative = path.relative_to(root).parts
        if any(part.startswith(".") for part in relative):
            continue
        if not path.is_file() or path.suffix.lower() not in suffixes or len(relative) == 1:
            continue
        if len(relative) != 3:
            problems.append(
                _problem(
                    root,
                    path,
                    "capture file at the wrong depth; expected ROOT/<robot>/<axis>/<capture>.<ext>.",
                )
            )
            continue
        robot, axis, name = relative
        bad = [
            f"{kind} folder name '{value}' is not an identifier (1-64 letters, digits, '_', '-' "
            "or '.', starting with a letter or digit)"
            for kind, value in (("robot", robot), ("axis", axis))
            if _IDENTIFIER.fullmatch(value) is None
        ]
        if bad:
            problems.append(_problem(root, path, "; ".join(bad) + "."))
            continue
        try:
            captured_at = parse_capture_time(name)
        except ValueError as exc:
            problems.append(_problem(root, path, str(exc)))
            continue
        files.append(FleetFile(robot, axis, name, path, captured_at))
    files.sort(key=lambda f: (f.robot, f.axis, f.captured_at, f.capture))
    return files, problems
