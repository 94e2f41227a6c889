"""A fleet on disk: ``ROOT/<robot>/<axis>/<capture>.<ext>``, discovered and ordered by date.

It looks only at names, never at contents. The rules are the monitor manual's "Fleet layout".
Captures of one axis are ordered by date-time, then by file name.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from axiswatch._formats import capture_suffixes
from axiswatch.exceptions import DataNotFoundError

__all__ = [
    "FleetFile",
    "LayoutProblem",
    "check_fleet_root",
    "discover_fleet",
    "misnamed_folder_key",
    "parse_capture_time",
    "split_settled",
]

_IDENTIFIER = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: The end of a misnamed folder's line: its file count changes as files arrive without being
#: news, so it is not part of the line's ``reason_key``.
_MISNAMED_TAIL = "; its {files} capture file(s) are not scored until the folder is renamed."
_MISNAMED_LINE = re.compile(
    r"(?P<key>.+/: (?:robot|axis) folder name '.*' is not an identifier \(.*\))"
    + re.escape(_MISNAMED_TAIL).replace(re.escape("{files}"), r"\d+"),
    re.DOTALL,
)
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
    """A capture file the layout rules reject, and why (one sentence naming the file); or a
    folder (``capture == ""``): one that cannot be read, or, with ``files`` > 0, a robot or axis
    folder whose name is not an identifier, holding ``files`` capture files of ``axes``
    (``reason_key``: its reason without that count, which changes as files arrive)."""

    robot: str
    axis: str
    capture: str
    path: Path
    reason: str
    files: int = 0
    axes: tuple[tuple[str, str], ...] = ()
    reason_key: str | None = None


def _problem(root: Path, path: Path, reason: str) -> LayoutProblem:
    parts = path.relative_to(root).parts
    robot = parts[0] if len(parts) >= 2 else ""
    axis = parts[1] if len(parts) >= 3 else ""
    relative = path.relative_to(root).as_posix()
    return LayoutProblem(robot, axis, path.name, path, f"{relative}: {reason}")


def discover_fleet(
    root: str | Path, *, skip: Callable[[str, str], bool] | None = None
) -> tuple[list[FleetFile], list[LayoutProblem]]:
    """Capture files under ``root``, ordered by robot, axis, date-time and name; and problems.

    Parameters
    ----------
    root : str or Path
        The fleet folder.
    skip : callable (robot, axis) -> bool, optional
        Axis folders not to list (``monitor._index``: folders unchanged since a run handled
        them).

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
    # Folders whose name is not an identifier: one problem each, not one per file it holds.
    misnamed: dict[tuple[str, ...], tuple[str, list[tuple[str, str]]]] = {}
    for path, relative in _candidates(root, problems, skip):
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
            (kind, value)
            for kind, value in (("robot", robot), ("axis", axis))
            if _IDENTIFIER.fullmatch(value) is None
        ]
        if bad:
            kind, value = bad[0]
            folder: tuple[str, ...] = (robot,) if kind == "robot" else (robot, axis)
            why = (
                f"{kind} folder name '{value}' is not an identifier (1-64 ASCII letters, digits, "
                "'_', '-' or '.', starting with a letter or digit)"
            )
            misnamed.setdefault(folder, (why, []))[1].append((robot, axis))
            continue
        try:
            captured_at = parse_capture_time(name)
        except ValueError as exc:
            problems.append(_problem(root, path, str(exc)))
            continue
        files.append(FleetFile(robot, axis, name, path, captured_at))
    for folder, (why, axes) in sorted(misnamed.items()):
        shown = "/".join(folder)
        problems.append(
            LayoutProblem(
                folder[0],
                folder[1] if len(folder) > 1 else "",
                "",
                root.joinpath(*folder),
                f"{shown}/: {why}" + _MISNAMED_TAIL.format(files=len(axes)),
                files=len(axes),
                axes=tuple(sorted(set(axes))),
                reason_key=f"{shown}/: {why}",
            )
        )
    files.sort(key=lambda f: (f.robot, f.axis, f.captured_at, f.capture))
    return files, problems


def misnamed_folder_key(error: str) -> str | None:
    """The ``reason_key`` of a misnamed folder's line (its reason without its file count); None
    for any other line. For the rejections a store kept before it stored the key.

    Parameters
    ----------
    error : str
        A stored rejection's line.

    Returns
    -------
    str or None

    Examples
    --------
    >>> misnamed_folder_key(
    ...     "robot 2/: robot folder name 'robot 2' is not an identifier (1-64 ASCII letters); "
    ...     "its 8 capture file(s) are not scored until the folder is renamed."
    ... )
    "robot 2/: robot folder name 'robot 2' is not an identifier (1-64 ASCII letters)"
    >>> misnamed_folder_key("r1/loose.csv: capture file at the wrong depth") is None
    True
    """
    found = _MISNAMED_LINE.fullmatch(error)
    return None if found is None else found["key"]


def _folder_problem(root: Path, path: Path, reason: str) -> LayoutProblem:
    parts = path.relative_to(root).parts
    robot = parts[0] if parts else ""
    axis = parts[1] if len(parts) >= 2 else ""
    return LayoutProblem(robot, axis, "", path, f"{path.relative_to(root).as_posix()}/: {reason}")


def _candidates(
    root: Path,
    problems: list[LayoutProblem],
    skip: Callable[[str, str], bool] | None = None,
) -> Iterator[tuple[Path, tuple[str, ...]]]:
    """Capture-like files below ``root`` (not directly in it) and their path's parts relative to
    it, following links to folders once, leaving out the axis folders ``skip(robot, axis)`` names;
    folder problems are appended to ``problems``.

    One ``os.scandir`` per folder: a regular file's type comes with its directory entry, so a
    kept file costs no ``stat`` (a day's run lists the folders that received a file, with all
    the names they keep).
    """
    suffixes = capture_suffixes()
    seen: dict[tuple[int, int], str] = {}

    def unreadable(path: Path, error: OSError) -> None:
        problems.append(
            _folder_problem(root, path, f"folder cannot be read ({error.strerror}); not scored")
        )

    def visit(here: Path, parts: tuple[str, ...]) -> Iterator[tuple[Path, tuple[str, ...]]]:
        try:
            stat = here.stat()
            with os.scandir(here) as listing:
                entries = sorted(listing, key=lambda entry: entry.name)
        except OSError as error:
            unreadable(here, error)
            return
        if (stat.st_dev, stat.st_ino) in seen:
            problems.append(
                _folder_problem(
                    root,
                    here,
                    f"link to the folder already read as '{seen[(stat.st_dev, stat.st_ino)] or '.'}' "
                    "(a symlink loop or a second name); not read twice",
                )
            )
            return
        seen[(stat.st_dev, stat.st_ino)] = "/".join(parts)
        folders = []
        for entry in entries:
            if entry.name.startswith("."):
                continue
            try:
                is_folder = entry.is_dir()  # follows links; a dangling link is not a folder
            except OSError:
                is_folder = False
            if is_folder:
                folders.append(entry)
            elif entry.is_symlink() and not os.path.exists(entry.path):
                problems.append(
                    _folder_problem(
                        root,
                        Path(entry.path),
                        f"link to '{os.readlink(entry.path)}', which does not exist (an unmounted "
                        "share?); not scored",
                    )
                )
            elif parts and os.path.splitext(entry.name)[1].lower() in suffixes and entry.is_file():
                yield Path(entry.path), (*parts, entry.name)
        for entry in folders:
            if skip is not None and len(parts) == 1 and skip(parts[0], entry.name):
                # Pruned before it is listed: an unchanged axis folder costs nothing.
                continue
            yield from visit(Path(entry.path), (*parts, entry.name))

    yield from visit(root, ())


def check_fleet_root(
    root: str | Path, *, known: Mapping[tuple[str, str], int] | None = None
) -> None:
    """Raise unless ``root`` is a folder holding at least one capture file.

    An empty fleet folder is what an unmounted share looks like: monitoring it would show every
    axis as it was, so it is an error rather than a quiet run.

    ``known``: axis folders and the modification time (ns) they had when they held capture
    files (``monitor._index``); one whose time is unchanged still holds them, which one ``stat``
    proves without listing a folder (a run with nothing new lists none).

    Raises
    ------
    NotADirectoryError
        If ``root`` is not a folder.
    DataNotFoundError
        If no capture file lies below it.
    """
    root = Path(root)
    if not root.is_dir():
        raise NotADirectoryError(f"fleet folder '{root}' does not exist or is not a folder.")
    for (robot, axis), mtime_ns in (known or {}).items():
        try:
            if os.stat(root / robot / axis).st_mtime_ns == mtime_ns:
                return
        except OSError:
            continue
    if next(_candidates(root, []), None) is None:
        raise DataNotFoundError(
            f"fleet folder '{root}' holds no capture file (an unmounted share or a wrong path?); "
            "expected ROOT/<robot>/<axis>/<capture>.parquet|.csv."
        )


def split_settled(
    files: Sequence[FleetFile], settle_s: float, now_s: float
) -> tuple[list[FleetFile], list[FleetFile], list[tuple[FleetFile, str]]]:
    """Files settled for ``settle_s`` seconds (by modification time), files still waiting, and
    files that cannot be looked at (with the reason).

    Examples
    --------
    >>> import tempfile, pathlib, time
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "2026-03-01.csv"
    >>> _ = path.write_text("time,speed\\n")
    >>> file = FleetFile("r1", "a1", path.name, path, parse_capture_time(path.name))
    >>> [len(part) for part in split_settled([file], 10.0, time.time())]
    [0, 1, 0]
    >>> [len(part) for part in split_settled([file], 10.0, time.time() + 60)]
    [1, 0, 0]
    """
    ready: list[FleetFile] = []
    waiting: list[FleetFile] = []
    unreadable: list[tuple[FleetFile, str]] = []
    for file in files:
        try:
            modified = file.path.stat().st_mtime
        except OSError as exc:
            unreadable.append((file, f"cannot be read ({exc.strerror})"))
            continue
        (waiting if now_s - modified < settle_s else ready).append(file)
    return ready, waiting, unreadable
