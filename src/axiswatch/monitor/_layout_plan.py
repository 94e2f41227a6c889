"""A fleet layout plan: where detected captures go in ``ROOT/<robot>/<axis>/`` and their profiles.

The monitor reads one axis per file. A file holding several axes (``A1_*``, ``A2_*``) is linked
into each axis's folder, and each folder gets an ``axis.toml`` mapping that axis's columns; a file
whose name lacks a date is linked under its first time stamp's date-time.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from axiswatch._capture import read_capture
from axiswatch._profile_detection import TEXT_SUFFIXES, AxisGuess, FileGuess, profile_toml
from axiswatch._profiles import PROFILE_FILES, AxisProfile, find_profile
from axiswatch.exceptions import AxiswatchError, ProfileError
from axiswatch.monitor._fleet import _IDENTIFIER, parse_capture_time

__all__ = ["LayoutPlan", "apply_plan", "plan_layout"]

#: Axis folder name of a file of one axis whose columns name none.
SINGLE_AXIS = "axis1"


@dataclass
class LayoutPlan:
    """Links to make, profiles to write and files left out, with the reason; ``kept``: axis
    folders read with a profile already there (``axis.toml``, ``robot.toml`` or the fleet's
    ``axiswatch.toml``), which is never replaced without ``force``."""

    root: Path
    links: dict[Path, Path] = field(default_factory=dict)  # fleet path -> source file
    profiles: dict[Path, AxisProfile] = field(default_factory=dict)  # axis.toml -> profile
    placed: list[tuple[Path, str, str]] = field(default_factory=list)  # file, robot, axis
    unplaced: list[tuple[Path, str]] = field(default_factory=list)
    kept: dict[tuple[str, str], str] = field(default_factory=dict)  # (robot, axis) -> profile


def _in_place(path: Path, root: Path) -> tuple[str, str] | None:
    """``(robot, axis)`` of a file that already lies at ``ROOT/<robot>/<axis>/<date...>``."""
    try:
        parts = path.resolve().relative_to(root.resolve()).parts
        parse_capture_time(path.name)
    except ValueError:
        return None
    return (parts[0], parts[1]) if len(parts) == 3 else None


def _capture_name(guess: FileGuess) -> str | None:
    """The name in the fleet: dated by the first stamp when the name has no date; a text export
    (``.txt``, ``.tsv``) as ``.csv``, which the monitor reads."""
    name = guess.path.name
    if guess.path.suffix.lower() in TEXT_SUFFIXES:
        name = guess.path.with_suffix(".csv").name
    try:
        parse_capture_time(name)
    except ValueError:
        if guess.first_stamp_s is None:
            return None
        start = datetime.fromtimestamp(guess.first_stamp_s, UTC)
        return f"{start:%Y-%m-%dT%H-%M-%S}_{name}"
    return name


def _read_back(path: Path, profile: AxisProfile) -> None:
    """Read ``path`` as the monitor will: a text export through a ``.csv`` link to it."""
    if path.suffix.lower() == ".csv" or path.suffix.lower() not in TEXT_SUFFIXES:
        read_capture(path, profile=profile)
        return
    with tempfile.TemporaryDirectory() as folder:
        link = Path(folder) / path.with_suffix(".csv").name
        link.symlink_to(path.resolve())
        try:
            read_capture(link, profile=profile)
        except AxiswatchError as exc:
            raise type(exc)(str(exc).replace(str(link), str(path))) from None


def _placement(
    guess: FileGuess, root: Path, robot: str | None
) -> tuple[str, list[tuple[tuple[str, str], AxisGuess]]] | str:
    """The file's name in the fleet and its axes' folders, or why it cannot be placed."""
    if guess.problem is not None:
        return guess.problem
    here = _in_place(guess.path, root) if len(guess.axes) == 1 else None
    name = guess.path.name if here else _capture_name(guess)
    if name is None:
        return ("no date in its name and relative time stamps: rename it to start with its "
                "date, such as 2026-03-01T06-00-00_")  # fmt: skip
    owner = robot or guess.path.resolve().parent.name
    folders = [(here or (owner, axis.axis or SINGLE_AXIS), axis) for axis in guess.axes]
    for folder, _ in folders:
        bad = [part for part in folder if not _IDENTIFIER.fullmatch(part)]
        if bad:
            return (f"folder name {bad[0]!r} is not an identifier (letters, digits, _ - .): "
                    "give --robot")  # fmt: skip
    return name, folders


def plan_layout(
    guesses: Sequence[FileGuess], root: Path, robot: str | None = None, *, force: bool = False
) -> LayoutPlan:
    """Place each guessed file's axes in the fleet ``root``; each capture is read back with its
    axis's profile first, by the monitor's own reader, and left out with the reason if it fails.

    An axis folder that a profile already covers (yours, edited: :func:`find_profile`) is read
    with it, and it is kept. Otherwise the guess most of its files give is written; irregular
    time steps in one of the axis's files make it resample all of them.

    Parameters
    ----------
    guesses : sequence of FileGuess
        :func:`~axiswatch._profile_detection.detect_file` of each file.
    root : Path
        The fleet folder ``monitor`` reads.
    robot : str, optional
        Robot folder of files outside ``root``; default: the folder each file lies in.
    force : bool, default=False
        Use the guesses, not the profiles already there (:func:`apply_plan` replaces them).
    """
    plan = LayoutPlan(root)
    placements = []
    for guess in guesses:
        placement = _placement(guess, root, robot)
        if isinstance(placement, str):
            plan.unplaced.append((guess.path, placement))
        else:
            placements.append((guess, *placement))
    irregular = {
        folder for guess, _, folders in placements if guess.irregular for folder, _ in folders
    }
    # One guess per axis folder, the one most of its files give: a column placed by content
    # can differ from file to file, and each file is read back with the folder's anyway.
    votes: dict[tuple[str, str], Counter[str]] = {}
    guessed: dict[str, AxisProfile] = {}
    for guess, _, folders in placements:
        for folder, axis in folders:
            profile = guess.profile(axis, resample_irregular=folder in irregular)
            key = profile_toml(profile)
            guessed.setdefault(key, profile)
            votes.setdefault(folder, Counter())[key] += 1
    chosen = {folder: guessed[count.most_common(1)[0][0]] for folder, count in votes.items()}
    found: dict[tuple[str, str], AxisProfile | ProfileError | None] = {}
    for guess, name, folders in placements:
        here = _in_place(guess.path, root) if len(guess.axes) == 1 else None
        for folder, axis in folders:
            if folder not in found and not force:
                try:
                    found[folder] = find_profile(root, *folder)
                except ProfileError as exc:
                    found[folder] = exc
            existing = found.get(folder)
            if isinstance(existing, ProfileError):
                plan.unplaced.append((guess.path, f"axis {axis.axis or '-'}: {existing}"))
                continue
            if existing is not None:
                profile = existing
                plan.kept[folder] = existing.source
            else:
                profile = chosen[folder]
                plan.profiles[root.joinpath(*folder) / PROFILE_FILES[0]] = profile
            try:
                _read_back(guess.path, profile)
            except (AxiswatchError, ValueError, OSError) as exc:
                why = str(exc).removeprefix(f"{guess.path}: ")
                plan.unplaced.append((guess.path, f"axis {axis.axis or '-'}: {why}"))
                continue
            link = root.joinpath(*folder) / name
            if not here and plan.links.setdefault(link, guess.path) != guess.path:
                plan.unplaced.append((guess.path, f"same capture name as {plan.links[link]}"))
                continue
            plan.placed.append((guess.path, *folder))
    kept = {root.joinpath(robot_, axis_) for _, robot_, axis_ in plan.placed}
    plan.profiles = {p: v for p, v in plan.profiles.items() if p.parent in kept}
    return plan


def _conflicts(plan: LayoutPlan, force: bool) -> list[str]:
    found = []
    for toml, profile in plan.profiles.items():
        if toml.is_file() and not force and toml.read_text(encoding="utf-8") != _text(profile):
            found.append(f"{toml} exists with other content (--force replaces it)")
    for link, source in plan.links.items():
        if link.exists() and not os.path.samefile(link, source):
            found.append(f"{link} exists and is another file than {source}")
    return found


def _text(profile: AxisProfile) -> str:
    return profile_toml(profile, "Written by 'axiswatch profile'; edit freely.")


def _link(source: Path, link: Path) -> None:
    """A hard link (the monitor reads it as the file itself); else a symbolic link; else a copy."""
    try:
        os.link(source, link)
    except OSError:
        try:
            link.symlink_to(source.resolve())
        except OSError:
            shutil.copy2(source, link)


def apply_plan(plan: LayoutPlan, *, force: bool = False) -> list[str]:
    """Write the plan's profiles and links; nothing is written if a file in the way differs.

    Returns
    -------
    list of str
        One line per profile written or kept, and the count of captures linked.

    Raises
    ------
    ProfileError
        A profile with other content is in the way (without ``force``), or another file sits
        where a capture would be linked.
    """
    conflicts = _conflicts(plan, force)
    if conflicts:
        raise ProfileError(f"nothing written: {'; '.join(conflicts)}.")
    done = [
        f"kept {source}: {'/'.join(folder)}'s captures were read with it (--force replaces it "
        "with the detected profile)"
        for folder, source in sorted(plan.kept.items())
    ]
    for toml, profile in plan.profiles.items():
        text = _text(profile)
        toml.parent.mkdir(parents=True, exist_ok=True)
        if toml.is_file() and toml.read_text(encoding="utf-8") == text:
            done.append(f"kept {toml}")
            continue
        toml.write_text(text, encoding="utf-8")
        done.append(f"wrote {toml}")
    linked = 0
    for link, source in plan.links.items():
        if link.exists():
            continue
        link.parent.mkdir(parents=True, exist_ok=True)
        _link(source, link)
        linked += 1
    if plan.links:
        done.append(f"linked {linked} capture file(s) into {plan.root} "
                    f"({len(plan.links) - linked} already there)")  # fmt: skip
    return done
