"""Where a capture declares its operating mode: a column, a metadata key or its file name.

A profile's ``[mode]`` table says where (:func:`parse_mode_section`); the indicators wing
reads it (:func:`~axiswatch.indicators._modes.declared_mode`) and learns each mode.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["MODE_KEYS", "ModeDeclaration", "parse_mode_section"]

#: The keys of a profile's ``[mode]`` table.
MODE_KEYS: tuple[str, ...] = (
    "column",
    "metadata",
    "file_pattern",
    "payload_column",
    "payload_metadata",
)


@dataclass(frozen=True)
class ModeDeclaration:
    """Where a capture says its mode: a column, a metadata key or its file name.

    Attributes
    ----------
    column, metadata : str or None
        A numeric signal (its most frequent value) or a metadata key naming the program.
    file_pattern : str or None
        A regular expression searched in the file name; its group ``program`` (else the whole
        match) names the program, its group ``payload``, when present, the payload.
    payload_column, payload_metadata : str or None
        Where the payload is, when not in the file name.
    """

    column: str | None = None
    metadata: str | None = None
    file_pattern: str | None = None
    payload_column: str | None = None
    payload_metadata: str | None = None


def parse_mode_section(section: Mapping[str, Any], *, source: str = "<memory>") -> ModeDeclaration:
    """A profile's ``[mode]`` table as a :class:`ModeDeclaration`.

    Examples
    --------
    >>> parse_mode_section({"file_pattern": r"prog(?P<program>\\d+)"}).file_pattern
    'prog(?P<program>\\\\d+)'
    """
    unknown = sorted(set(section) - set(MODE_KEYS))
    if unknown:
        raise ValueError(
            f"{source} [mode]: unknown key {unknown[0]!r}; expected some of {list(MODE_KEYS)}."
        )
    for key, value in section.items():
        if not isinstance(value, str) or not value:
            raise ValueError(f"{source} [mode]: {key} must be a non-empty string; got {value!r}.")
    programs = [k for k in ("column", "metadata", "file_pattern") if k in section]
    if len(programs) != 1:
        raise ValueError(
            f"{source} [mode]: give exactly one of column, metadata, file_pattern; got {programs}."
        )
    if "file_pattern" in section:
        try:
            re.compile(section["file_pattern"])
        except re.error as error:
            raise ValueError(
                f"{source} [mode]: file_pattern is not a regular expression ({error})."
            ) from None
    return ModeDeclaration(**{key: section[key] for key in section})
