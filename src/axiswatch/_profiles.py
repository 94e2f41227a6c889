"""AxisProfile: what the library must know about an axis that its files do not say.

Column names, units and kinematics, from a TOML file. Every field is optional. The monitor
manual's "Monitor your own robot" shows one. The full form: docs/internals.md, "Axis profiles".
"""

from __future__ import annotations

import codecs
import difflib
import math
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from axiswatch._mode_declaration import ModeDeclaration, parse_mode_section
from axiswatch._timebase import (
    check_increasing,
    check_stamp_unit,
    date_stamps,
    sampling_period,
)
from axiswatch.exceptions import CaptureError, ProfileError

__all__ = ["AxisProfile", "find_profile"]

ROLES: tuple[str, ...] = ("time", "position", "speed", "torque")
#: Roles a capture must have when a profile maps them (speed is derived from the position).
REQUIRED_ROLES: tuple[str, ...] = ("position", "torque")
#: Roles measured on one side of the gear, and the sides (``[sides]``). The output is the
#: default: the gear ratio is motor turns per turn of the position the file gives.
SIDED_ROLES: tuple[str, ...] = ("position", "speed")
SIDES: tuple[str, ...] = ("motor", "output")
#: Roles a profile may ``ignore``: the motion signals, one of which the indicators need.
IGNORABLE_ROLES: tuple[str, ...] = ("position", "speed")
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Time unit of a logger's sample counter (0, 1, 2, ...); needs ``sample_rate_hz``.
SAMPLES = "samples"
POSITION_UNITS: dict[str, float] = {
    "rad": 1.0,
    "deg": math.pi / 180.0,
    "rev": 2.0 * math.pi,
    "m": 1.0,
    "mm": 1e-3,
}
#: Position unit of raw encoder counts; needs ``counts_per_revolution`` (read in rad).
COUNTS = "counts"
#: Words of a CSV units row for the time column -> the unit of :data:`TIME_UNITS` they name.
TIME_WORDS: dict[str, str] = {
    **{unit: unit for unit in TIME_UNITS},
    "sec": "s",
    "msec": "ms",
    "µs": "us",
}
#: Words of a CSV units row for the position (and, with ``/s``, the speed) -> the unit of
#: :data:`POSITION_UNITS` or :data:`COUNTS` they name, compared in lower case. Encoder
#: increments are counts: read as rad they would be off by counts_per_revolution / 2 pi.
#: ``Grad`` is German for degree (what a German controller's export writes); a gradian, 1/400
#: of a turn, is ``gon`` there and is not read.
POSITION_WORDS: dict[str, str] = {
    **{unit: unit for unit in (*POSITION_UNITS, COUNTS)},
    "°": "deg",
    "degree": "deg",
    "degrees": "deg",
    "grad": "deg",
    "radian": "rad",
    "radians": "rad",
    "count": COUNTS,
    "cnt": COUNTS,
    "cts": COUNTS,
    "inc": COUNTS,
    "incr": COUNTS,
    "increments": COUNTS,
}
#: Names of the profile files, most specific first (:func:`find_profile`).
PROFILE_FILES: tuple[str, ...] = ("axis.toml", "robot.toml")
FLEET_PROFILE = "axiswatch.toml"


#: The profile's keys that are plain values, not tables: written under a ``[table]`` line
#: they belong to that table (TOML), a mistake :func:`_above_tables` names.
TOP_LEVEL_VALUES: tuple[str, ...] = ("name", "resample_irregular", "encoding", "ignore")


def _above_tables(keys: Iterable[str], table: str | None) -> str:
    """Advice for top-level keys read inside ``[table]``: in TOML every line after a ``[table]``
    header belongs to it, so ``resample_irregular = true`` below ``[columns]`` is a column."""
    misplaced = [key for key in keys if key in TOP_LEVEL_VALUES]
    if table is None or not misplaced:
        return ""
    names = ", ".join(repr(key) for key in misplaced)
    return (
        f" ({names} is a top-level key, here read as part of [{table}]: in TOML every line "
        f"after a [table] header belongs to that table; move it above the first [table] line)"
    )


def _check(
    mapping: Mapping[str, Any], allowed: set[str], where: str, table: str | None = None
) -> None:
    unknown = sorted(set(mapping) - allowed)
    if unknown:
        # A typo ([unit], positon) is the usual cause: name the key it likely meant.
        likely = {
            key: close[0]
            for key in unknown
            if key not in TOP_LEVEL_VALUES
            and (close := difflib.get_close_matches(key, sorted(allowed), n=1, cutoff=0.6))
        }
        hint = "".join(f" ({key!r}: did you mean {meant!r}?)" for key, meant in likely.items())
        hint += _above_tables(unknown, table)
        raise ProfileError(
            f"{where}: unknown key(s) {unknown}{hint}; expected some of {sorted(allowed)}."
        )


def _got(value: object) -> str:
    return f"{value!r} ({type(value).__name__})"


def _table(data: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
    """The TOML table ``key`` of ``data`` (empty when absent); anything else is an error."""
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ProfileError(
            f"{where}: '{key}' must be a table ([{key}] with lines such as name = value); "
            f"got {_got(value)}."
        )
    return dict(value)


def _text(data: Mapping[str, Any], key: str, where: str, default: str | None) -> str | None:
    value = data.get(key, default)
    if value is not None and not isinstance(value, str):
        raise ProfileError(f"{where}: '{key}' must be a quoted string; got {_got(value)}.")
    return value


def _mode(data: Mapping[str, Any], source: str) -> ModeDeclaration | None:
    """The ``[mode]`` table as a :class:`ModeDeclaration` (None when absent)."""
    if "mode" not in data:
        return None
    try:
        return parse_mode_section(_table(data, "mode", source), source=source)
    except ValueError as exc:
        raise ProfileError(str(exc)) from None


def _number(value: object, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProfileError(f"{where}: '{key}' must be a number > 0; got {_got(value)}.")
    return float(value)


@dataclass(frozen=True)
class AxisProfile:
    """Units, column names and kinematics of an axis (every field optional).

    Parameters
    ----------
    name : str, optional
        Axes with the same profile name are pooled as one fleet (:func:`~axiswatch.pool_fleet`).
    columns : mapping of str to str, default={}
        File column -> role (``time``, ``position``, ``speed``, ``torque``).
    time_unit : {"s", "ms", "us", "ns", "samples"}, default="s"
        Absolute stamps (Unix time) are allowed: the capture starts at its first stamp.
        ``samples``: a sample counter, read at ``sample_rate_hz``.
    sample_rate_hz : float, optional
        The logger's rate; required with ``time_unit="samples"`` and only then.
    position_unit : {"rad", "deg", "rev", "m", "mm", "counts"}, default="rad"
        Speed is read in the same unit per second. ``counts`` (raw encoder counts) needs
        ``counts_per_revolution`` and is read in rad.
    counts_per_revolution : float, optional
        Encoder counts per turn of the position (16384 for a 14-bit encoder); required with
        ``position_unit="counts"`` and only then.
    resample_irregular : bool, default=False
        Put irregularly stamped rows (a PLC logging every 39-55 ms) on a uniform grid at their
        step (:func:`~axiswatch._timebase.sampling_period`), by linear interpolation, instead of
        rejecting the file.
    gear_ratio : float, optional
        Motor turns per turn of the position; enables the kinematic lines.
    gear_stages : mapping of str to float, default={}
        Name -> motor turns per turn of a gear whose teeth are watched.
    bearing_orders : mapping of str to float, default={}
        Name -> bearing defect frequency in orders of the motor speed.
    sides : mapping of str to str, default={}
        Role (``position``, ``speed``) -> ``"motor"`` or ``"output"``: the side of the gear the
        file's signal is measured on. A motor-side signal is divided by ``gear_ratio`` when
        read, so every reading sees the output. Default: the output.
    ignore : tuple of str, default=()
        Roles (``position`` or ``speed``) whose column is not read. An ignored speed is
        derived from the position, as when the file has none.
    encoding : str, optional
        Text encoding of the axis's CSV files (a Python codec name, such as ``"cp1250"``).
        Without it a CSV file is read as UTF-8, else as Windows-1252.
    mode : ModeDeclaration, optional
        Where a capture names its operating mode (the ``[mode]`` table); without it the modes
        are read from the motion and the load.
    source : str, default="<memory>"

    Examples
    --------
    >>> p = AxisProfile.from_dict({"columns": {"t": "time", "q": "position", "i": "torque"},
    ...                            "units": {"time": "ms", "position": "deg"}})
    >>> p.time_unit, p.position_unit, p.role_of("q")
    ('ms', 'deg', 'position')
    """

    name: str | None = None
    columns: Mapping[str, str] = field(default_factory=dict)
    time_unit: str = "s"
    sample_rate_hz: float | None = None
    position_unit: str = "rad"
    counts_per_revolution: float | None = None
    resample_irregular: bool = False
    gear_ratio: float | None = None
    gear_stages: Mapping[str, float] = field(default_factory=dict)
    bearing_orders: Mapping[str, float] = field(default_factory=dict)
    sides: Mapping[str, str] = field(default_factory=dict)
    ignore: tuple[str, ...] = ()
    encoding: str | None = None
    mode: ModeDeclaration | None = None
    source: str = "<memory>"

    def __post_init__(self) -> None:
        where = f"axis profile {self.source}"
        for column, role in self.columns.items():
            if role not in ROLES:
                raise ProfileError(
                    f"{where}: column {column!r} maps to role {role!r}; expected one of "
                    f"{list(ROLES)}{_above_tables([column], 'columns')}."
                )
        if self.time_unit not in (*TIME_UNITS, SAMPLES):
            raise ProfileError(
                f"{where}: time unit must be one of {[*TIME_UNITS, SAMPLES]}. "
                f"Got {self.time_unit!r} instead."
            )
        if (self.time_unit == SAMPLES) != (self.sample_rate_hz is not None):
            raise ProfileError(
                f'{where}: time = "samples" (a sample counter) and sample_rate_hz (the '
                f"logger's rate) go together in [units]; got time = {self.time_unit!r} and "
                f"sample_rate_hz = {self.sample_rate_hz!r}."
            )
        rate = self.sample_rate_hz
        if rate is not None and not (math.isfinite(rate) and rate > 0):
            raise ProfileError(
                f"{where}: sample_rate_hz must be a number > 0. Got {rate!r} instead."
            )
        if self.position_unit not in (*POSITION_UNITS, COUNTS):
            raise ProfileError(
                f"{where}: position unit must be one of {[*POSITION_UNITS, COUNTS]}. "
                f"Got {self.position_unit!r} instead."
            )
        counts = self.counts_per_revolution
        if self.position_unit == COUNTS and counts is None:
            raise ProfileError(
                f'{where}: position unit "counts" needs counts_per_revolution (a number > 0, '
                "encoder counts per turn, such as 16384 for 14 bits) in [units]; got none."
            )
        if counts is not None and self.position_unit != COUNTS:
            raise ProfileError(
                f'{where}: counts_per_revolution is for position unit "counts"; the position '
                f"unit is {self.position_unit!r}."
            )
        if counts is not None and (
            isinstance(counts, bool)
            or not isinstance(counts, int | float)
            or not (math.isfinite(counts) and counts > 0)
        ):
            raise ProfileError(
                f"{where}: counts_per_revolution must be a number > 0. Got {counts!r} instead."
            )
        if self.encoding is not None:
            try:
                codecs.lookup(self.encoding)
            except LookupError:
                raise ProfileError(
                    f"{where}: encoding {self.encoding!r} is not a text encoding Python knows; "
                    'expected a codec name such as "utf-8", "cp1252" or "cp1250".'
                ) from None
        if self.gear_ratio is not None and not self.gear_ratio > 0:
            raise ProfileError(f"{where}: gear_ratio must be > 0. Got {self.gear_ratio!r} instead.")
        for label, table in (
            ("gear_stages", self.gear_stages),
            ("bearing_orders", self.bearing_orders),
        ):
            for key, value in table.items():
                if isinstance(value, bool) or not (isinstance(value, int | float) and value > 0):
                    raise ProfileError(
                        f"{where}: {label}.{key} must be a number > 0. Got {value!r}."
                    )
        self._check_sides(where)

    def _check_sides(self, where: str) -> None:
        object.__setattr__(self, "ignore", tuple(self.ignore))  # a list given in Python
        for role, side in self.sides.items():
            if role not in SIDED_ROLES or side not in SIDES:
                raise ProfileError(
                    f"{where}: sides maps {role!r} to {side!r}; expected {list(SIDED_ROLES)} "
                    f"mapped to one of {list(SIDES)}."
                )
            if side == "motor" and self.gear_ratio is None:
                raise ProfileError(
                    f'{where}: [sides] {role} = "motor" needs [kinematics] gear_ratio (motor '
                    "turns per output turn) to read it at the output; got none."
                )
        for role in self.ignore:
            if role not in IGNORABLE_ROLES:
                raise ProfileError(
                    f"{where}: ignore lists {role!r}; expected some of {list(IGNORABLE_ROLES)} "
                    "(the indicators need the time and the torque)."
                )
        if set(IGNORABLE_ROLES) <= set(self.ignore):
            raise ProfileError(
                f"{where}: ignore lists both 'position' and 'speed'; the indicators need one of "
                "them."
            )

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "<memory>") -> AxisProfile:
        """A profile from the TOML file's tables (``name``, ``columns``, ``units``,
        ``resample_irregular``, ``encoding``, ``kinematics``, ``sides``, ``ignore``, ``mode``)."""
        _check(
            data,
            {
                "name", "columns", "units", "resample_irregular", "encoding", "kinematics",
                "sides", "ignore", "mode",
            },
            source,
        )  # fmt: skip
        columns = _table(data, "columns", source)
        for column, role in columns.items():
            if not isinstance(role, str):
                raise ProfileError(
                    f"{source} [columns]: {column!r} must map to a quoted role, one of "
                    f"{list(ROLES)}; got {_got(role)}{_above_tables([column], 'columns')}."
                )
        units = _table(data, "units", source)
        _check(
            units,
            {"time", "position", "torque", "counts_per_revolution", "sample_rate_hz"},
            f"{source} [units]",
            "units",
        )
        for key in units:
            if key not in ("counts_per_revolution", "sample_rate_hz"):
                _text(units, key, f"{source} [units]", None)
        counts = units.get("counts_per_revolution")
        rate = units.get("sample_rate_hz")
        resample = data.get("resample_irregular", False)
        if not isinstance(resample, bool):
            raise ProfileError(
                f"{source}: 'resample_irregular' must be true or false (unquoted); "
                f"got {_got(resample)}."
            )
        kinematics = _table(data, "kinematics", source)
        _check(
            kinematics,
            {"gear_ratio", "gear_stages", "bearing_orders"},
            f"{source} [kinematics]",
            "kinematics",
        )
        ratio = kinematics.get("gear_ratio")
        where = f"{source} [kinematics]"
        sides = _table(data, "sides", source)
        _check(sides, set(SIDED_ROLES), f"{source} [sides]", "sides")
        for role, side in sides.items():
            if side not in SIDES:
                raise ProfileError(
                    f'{source} [sides]: {role} must be "motor" or "output" (the side of the gear '
                    f"it is measured on); got {_got(side)}."
                )
        ignore = data.get("ignore", [])
        if not isinstance(ignore, list) or not all(isinstance(r, str) for r in ignore):
            raise ProfileError(
                f"{source}: 'ignore' must be a list of roles, such as ignore = [\"speed\"]; "
                f"got {_got(ignore)}."
            )
        return cls(
            name=_text(data, "name", source, None),
            columns=columns,
            time_unit=units.get("time", "s"),
            sample_rate_hz=(
                None if rate is None else _number(rate, "sample_rate_hz", f"{source} [units]")
            ),
            position_unit=units.get("position", "rad"),
            counts_per_revolution=(
                None
                if counts is None
                else _number(counts, "counts_per_revolution", f"{source} [units]")
            ),
            resample_irregular=resample,
            gear_ratio=None if ratio is None else _number(ratio, "gear_ratio", where),
            gear_stages=_table(kinematics, "gear_stages", where),
            bearing_orders=_table(kinematics, "bearing_orders", where),
            sides=sides,
            ignore=tuple(ignore),
            encoding=_text(data, "encoding", source, None),
            mode=_mode(data, source),
            source=source,
        )

    @classmethod
    def from_toml(cls, path: str | Path) -> AxisProfile:
        """Read a profile file; errors name the file and the key."""
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ProfileError(f"{path}: no such axis profile file.") from None
        except IsADirectoryError:
            raise ProfileError(
                f"{path}: is a folder; expected an axis profile file (TOML)."
            ) from None
        except OSError as exc:
            raise ProfileError(
                f"{path}: the axis profile cannot be read ({exc.strerror or exc})."
            ) from exc
        except UnicodeDecodeError as exc:
            raise ProfileError(
                f"{path}: an axis profile must be UTF-8 text (TOML); {exc}."
            ) from exc
        except tomllib.TOMLDecodeError as exc:
            raise ProfileError(f"{path}: not a valid TOML axis profile: {exc}.") from exc
        return cls.from_dict(data, source=str(path))

    @classmethod
    def find(cls, root: str | Path, robot: str, axis: str) -> AxisProfile | None:
        """The fleet lookup of :func:`find_profile`."""
        return find_profile(root, robot, axis)

    def role_of(self, column: str) -> str:
        """The role a file column plays (the column's own name when the profile does not map it)."""
        return self.columns.get(column, column)

    def check_units_row(self, units: Mapping[str, str], path: Path) -> None:
        """Refuse a file whose units row names another time, position or speed unit than the one
        the capture is read in (``deg`` or encoder ``counts`` under the position while the
        profile, or its absence, says ``rad``), or a word that is none of those units (``rpm``):
        the readings would be in wrong units, silently. The torque's unit is not checked.
        Words are compared in lower case (:data:`TIME_WORDS`, :data:`POSITION_WORDS`: ``Grad``,
        ``°`` and ``degrees`` are ``deg``; the speed's with ``/s``). A speed per minute (``rpm``,
        ``U/min``) is refused: units are never converted from the row.

        Examples
        --------
        >>> AxisProfile().check_units_row({"time": "s", "position": "deg"}, Path("c.csv"))
        Traceback (most recent call last):
        ...
        axiswatch.exceptions.CaptureError: c.csv: the units row gives 'deg' for column ...
        >>> AxisProfile(position_unit="deg").check_units_row(
        ...     {"time": "s", "position": "Grad", "speed": "°/s"}, Path("c.csv")
        ... )
        """
        for column, text in units.items():
            role = self.role_of(column.strip())
            if role.lower() in ROLES and role not in self.columns.values():
                role = role.lower()
            word = text.strip().strip("[]()").lower()
            if role in self.ignore:
                continue  # not read: its unit does not matter (a speed in rpm, say)
            if role == "speed":
                word = word.removesuffix("/s").removesuffix("/sec")
            elif role not in ("time", "position"):
                continue  # the torque is read as given (Nm, A, %): its unit is only a label
            key = "time" if role == "time" else "position"
            words = TIME_WORDS if role == "time" else POSITION_WORDS
            declared = self.time_unit if role == "time" else self.position_unit
            origin = (
                "the default, without an axis profile"
                if self.source == "<memory>"
                else f"axis profile {self.source}"
            )
            said = f"{path}: the units row gives {text!r} for column {column!r} ({role})"
            if word not in words:
                # Read anyway, the values would be in a unit nobody declared: refused, naming
                # the words that are read, so that a typo or a foreign unit (rpm) shows.
                accepted = sorted(words) if role != "speed" else sorted(f"{w}/s" for w in words)
                per_minute = (
                    "; a speed per minute (rpm, U/min) is not converted: export it per second, "
                    "or leave the column out (the indicators derive the speed from the position)"
                    if role == "speed" and (word in ("rpm", "u/min") or word.endswith("/min"))
                    else ""
                )
                raise CaptureError(
                    f"{said}, not a {role} unit axiswatch reads; expected one of {accepted} "
                    f"(the capture is read in {declared}{'/s' if role == 'speed' else ''}, "
                    f"{origin}){per_minute}."
                )
            if words[word] != declared:
                declare = f'[units] {key} = "{words[word]}"'
                if words[word] == COUNTS:
                    declare += (
                        " and counts_per_revolution (encoder counts per turn of the position, "
                        "such as 16384 for 14 bits)"
                    )
                raise CaptureError(
                    f"{said}, but the capture is read in {declared} ({origin}); declare "
                    f"{declare} in the axis profile."
                )

    def position_scale(self) -> float:
        """Radians (or metres) per unit of the position as the file gives it.

        Examples
        --------
        >>> AxisProfile(position_unit="counts", counts_per_revolution=4.0).position_scale()
        1.5707963267948966
        """
        if self.position_unit == COUNTS:
            assert self.counts_per_revolution is not None  # checked on construction
            return 2.0 * math.pi / self.counts_per_revolution
        return POSITION_UNITS[self.position_unit]

    def time_scale(self) -> float:
        """Seconds per unit of the time column.

        Examples
        --------
        >>> AxisProfile(time_unit="samples", sample_rate_hz=250.0).time_scale()
        0.004
        """
        if self.time_unit == SAMPLES:
            assert self.sample_rate_hz is not None  # checked on construction
            return 1.0 / self.sample_rate_hz
        return TIME_UNITS[self.time_unit]

    def kinematics(self) -> dict[str, Any]:
        """Keyword arguments of :func:`~axiswatch.read_indicators`."""
        return {
            "gear_ratio": self.gear_ratio,
            "gear_stages": dict(self.gear_stages),
            "bearing_orders": dict(self.bearing_orders),
        }

    def standardise(
        self, frame: pd.DataFrame, path: Path, *, step_s: float | None = None
    ) -> pd.DataFrame:
        """The file's table in the project's format: roles as column names, time in seconds from
        the first stamp, position in rad (or m) and speed per second, both at the output (a
        motor-side one divided by the gear ratio), ignored roles left out; with
        ``resample_irregular``, on a uniform grid every ``step_s`` seconds (default: the rows'
        own :func:`~axiswatch._timebase.sampling_period`)."""
        # Each step only where it changes something: pandas' rename and drop cost a fifth of
        # reading a 3 s capture even when they change nothing.
        roles = [self.role_of(str(c)) for c in frame.columns]
        renamed = frame.copy(deep=False)
        if roles != list(frame.columns):
            renamed.columns = pd.Index(roles)
        seen: set[str] = set()
        duplicated: list[str] = []
        for role in roles:
            if role in seen:
                duplicated.append(role)
            seen.add(role)
        if duplicated:
            # A mapped column beside one already named for its role ('time_s' -> time beside
            # the file's own 'time'): name both, or the profile seems to map one.
            clash = [
                f"{str(column)!r}"
                + (" (mapped)" if str(column) in self.columns else " (the file's own name)")
                for column, role in zip(frame.columns, roles, strict=True)
                if role in duplicated
            ]
            raise CaptureError(
                f"{path}: the axis profile {self.source} maps two columns to {duplicated}: "
                f"{' and '.join(clash)}; keep one of them in [columns] (a column named after "
                "its role is read as that role)."
            )
        ignored = [role for role in self.ignore if role in seen]
        if ignored:
            renamed = renamed.drop(columns=ignored)
        if "time" not in seen:
            found = list(map(str, frame.columns))
            if not self.columns:  # the file's own names: the same words as without a profile
                raise CaptureError(
                    f"{path}: missing column 'time' (strictly increasing, in "
                    f"{self.time_unit}); found columns {found}."
                )
            raise CaptureError(
                f"{path}: no time column; the axis profile {self.source} maps "
                f"{dict(self.columns)} and the file has {found}."
            )
        for column, role in self.columns.items():
            # A mapped position or torque the file lacks: say which profile line points where,
            # not only that the indicators miss a torque. An optional signal (speed) may be
            # absent: it is derived from the position.
            required = role in REQUIRED_ROLES and role not in self.ignore
            if required and column not in frame.columns and role not in renamed:
                found = list(map(str, frame.columns))
                # A controller update that renames a column (ActCurrent -> ActualCurrent).
                close = difflib.get_close_matches(column, found, n=1, cutoff=0.6)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ProfileError(
                    f"{path}: the axis profile {self.source} maps [columns] {column!r} = "
                    f"{role!r}, but the file has no column {column!r}{hint}; found columns "
                    f"{found}."
                )
        stamps = renamed["time"]
        dates = date_stamps(stamps, path)
        if dates is not None:  # date-times carry their own unit
            relative = dates
        elif not pd.api.types.is_numeric_dtype(stamps):
            raise CaptureError(
                f"{path}: column 'time' must hold numbers in {self.time_unit} or ISO-8601 "
                f"date-times; got {stamps.iloc[0]!r}."
            )
        else:
            # Subtract the first stamp in the file's own integers or floats before scaling: Unix
            # nanoseconds as float64 would lose the sub-microsecond steps.
            first = stamps.iloc[0]
            factor = self.time_scale()
            check_stamp_unit(float(first) * factor, self.time_unit, path)
            if stamps.dtype == np.float64 and first == 0 and factor == 1.0:
                # Seconds from zero already: the subtraction and the scaling would give the same
                # bits, and setting the column costs a tenth of reading a 3 s capture.
                relative = None
            elif isinstance(stamps.dtype, np.dtype) and stamps.dtype.kind in "if":
                difference = stamps.to_numpy() - first  # pandas' subtraction, without its cost
                relative = difference.astype(np.float64) * factor
            else:
                relative = (stamps - first).to_numpy().astype(np.float64) * factor
        if relative is not None:
            renamed["time"] = relative
        position_scale = self.position_scale()
        for role in ("position", "speed"):
            scale = position_scale
            if self.sides.get(role) == "motor":
                assert self.gear_ratio is not None  # checked on construction
                scale /= self.gear_ratio
            if role in renamed.columns and scale != 1.0:
                renamed[role] = pd.to_numeric(renamed[role], errors="coerce") * scale
        if self.resample_irregular and renamed.shape[0] > 2:
            renamed = _uniform(renamed, path, step_s)
        return renamed


def _uniform(frame: pd.DataFrame, path: Path, step_s: float | None) -> pd.DataFrame:
    time_s = frame["time"].to_numpy(dtype=np.float64)
    check_increasing(time_s, path)
    # Not the median step: it moves from capture to capture by a share of the jitter, and every
    # capture's rate is checked against the baseline's to 0.1 % (6 of 7 captures of a 100 Hz
    # logger jittering by 20 % of its period were refused and its axis waited for ever).
    step = sampling_period(time_s) if step_s is None else step_s
    grid = np.arange(0.0, time_s[-1] + 0.5 * step, step)
    grid = grid[grid <= time_s[-1]]
    uniform = {"time": grid}
    for column in frame.columns:
        if column != "time" and pd.api.types.is_numeric_dtype(frame[column]):
            values = frame[column].to_numpy(dtype=np.float64)
            present = ~np.isnan(values)
            uniform[str(column)] = np.interp(grid, time_s[present], values[present])
    return pd.DataFrame(uniform)


def find_profile(root: str | Path, robot: str, axis: str) -> AxisProfile | None:
    """The profile of ``ROOT/<robot>/<axis>``: its ``axis.toml``, else the robot's
    ``robot.toml``, else the fleet's ``axiswatch.toml``; None when there is none.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "r1" / "a1").mkdir(parents=True)
    >>> _ = (root / "axiswatch.toml").write_text('name = "fleet"')
    >>> _ = (root / "r1" / "robot.toml").write_text('name = "r1-model"')
    >>> find_profile(root, "r1", "a1").name
    'r1-model'
    """
    root = Path(root)
    places = (
        root / robot / axis / PROFILE_FILES[0],
        root / robot / PROFILE_FILES[1],
        root / FLEET_PROFILE,
    )
    # A profile under a name the lookup does not read where it lies (robot.toml in the axis
    # folder, axis.toml in the robot's) was silently ignored: the captures were then refused
    # for columns the profile maps.
    for misplaced in (
        *(root / robot / axis / name for name in (PROFILE_FILES[1], FLEET_PROFILE)),
        *(root / robot / name for name in (PROFILE_FILES[0], FLEET_PROFILE)),
    ):
        if misplaced.is_file():
            raise ProfileError(
                f"{misplaced}: an axis profile is not read under this name here; expected "
                f"{places[0]} (this axis), {places[1]} (the robot's axes) or {places[2]} (the "
                "fleet)."
            )
    for candidate in places:
        if candidate.is_file():
            return AxisProfile.from_toml(candidate)
    return None
