"""Detect an axis profile from a few capture files: what ``axiswatch profile`` shows and writes.

A file's text layout (encoding, separator, decimal mark, units row), its time column and stamp
unit, and per axis (``A1_*``, ``J2_*``, ...) the position, speed and torque columns, by name,
units and content. Each guess becomes an :class:`~axiswatch.AxisProfile`.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from axiswatch._profiles import POSITION_WORDS, SIDED_ROLES, TIME_WORDS, AxisProfile

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "TEXT_SUFFIXES",
    "AxisGuess",
    "CsvLayout",
    "FileGuess",
    "detect_file",
    "export_files",
    "guess_roles",
    "profile_toml",
    "sniff_csv",
    "stamp_kind",
]

#: Words of a column name (lower case) that say its role; German words a controller writes too.
ROLE_WORDS: dict[str, tuple[str, ...]] = {
    "time": ("time", "timestamp", "zeit", "zeitstempel", "stamp", "ts", "datetime", "t"),
    "position": ("pos", "position", "actpos", "angle", "winkel", "lage", "istpos", "q"),
    "speed": ("vel", "velocity", "speed", "drehzahl", "geschwindigkeit", "actvel", "omega", "v"),
    "torque": (
        "torque", "trq", "tq", "moment", "drehmoment", "cur", "current", "strom", "i",
        "actcur", "effort", "load", "amp",
    ),
}  # fmt: skip
#: Words of a column name that say it is not a measurement of the axis: a set point, a
#: controller's model value, a flag. Such a column gets no role.
NOT_MEASURED: tuple[str, ...] = (
    "target", "set", "setpoint", "soll", "cmd", "command", "demand", "desired", "ref",
    "computed", "reached", "ok", "done", "enable", "enabled",
)  # fmt: skip
#: Starts and ends of words that say the same: ``SetSpeed``, ``SollPos``, ``Pos1reached``.
NOT_MEASURED_STARTS: tuple[str, ...] = ("set", "soll", "target", "cmd", "demand", "desired")
NOT_MEASURED_ENDS: tuple[str, ...] = ("reached",)
#: Suffixes of delimited text exports, read as CSV; ``profile`` links them in as ``.csv``.
TEXT_SUFFIXES: tuple[str, ...] = (".csv", ".txt", ".tsv")
#: Span of whole-number positions beyond which they read as encoder counts, not angles.
COUNTS_SPAN = 1000.0
#: A column with fewer distinct values is a flag or a constant, never a signal.
MIN_DISTINCT_VALUES = 3
#: Unit words that may end a column name (``A2_Pos_deg``): unit -> role it implies.
NAME_UNITS: dict[str, str] = {
    "deg": "position", "rad": "position", "grad": "position", "mm": "position",
    "nm": "torque", "a": "torque", "amp": "torque", "ma": "torque",
    "ms": "time", "s": "time", "us": "time", "ns": "time",
}  # fmt: skip
#: An axis prefix: ``A1``, ``J2``, ``Axis3``, ``Achse4``, ``Joint5`` before ``_`` or a space.
AXIS_PREFIX = re.compile(
    r"(?i)^(?P<axis>(?:a|j|axis|achse|joint|ax)\s?\d{1,2})[_ .-]+(?P<rest>.+)$"
)
#: Rough first stamps of Unix time in each unit (the years 2001 to 2286).
UNIX_RANGES: tuple[tuple[str, float, float], ...] = (
    ("s", 1e9, 1e10),
    ("ms", 1e12, 1e13),
    ("us", 1e15, 1e16),
    ("ns", 1e18, 1e19),
)
#: Words of a position or speed column's name that say it is the gear's output's.
OUTPUT_WORDS: tuple[str, ...] = ("joint", "output", "abtrieb", "gelenk", "link", "load")
#: An axis number ending a name: ``joint_position_1``, ``motor_torque_6``.
AXIS_SUFFIX = re.compile(r"^(?P<rest>.*[a-zA-Z].*?)[_ .-](?P<number>\d{1,2})$")
#: Relative deviation of a time step from the median step beyond which the stamps are
#: irregular: the reader's jitter tolerance is a quarter of the period.
IRREGULAR_STEP = 0.25
_ISO = re.compile(r"\s*\d{4}-\d{2}-\d{2}[T ]\d")


@dataclass(frozen=True)
class CsvLayout:
    """How a CSV file is written.

    Attributes
    ----------
    encoding : {"utf-8", "cp1252"}
    separator : {",", ";", "\\t"}
    decimal : {".", ","}
    units : dict of str to str
        The units row under the header (column -> unit); empty without one.
    """

    encoding: str
    separator: str
    decimal: str
    units: Mapping[str, str] = field(default_factory=dict)


def _is_number(cell: str) -> bool:
    try:
        float(cell.strip().replace(",", "."))
    except ValueError:
        return False
    return True


def sniff_csv(data: bytes) -> tuple[CsvLayout, str]:
    """The layout of a CSV file's bytes and its decoded text.

    UTF-8 (a byte order mark ignored), else Windows-1252; the separator that the header holds most
    of; a units row when every cell under the header is text; a decimal comma when the separator
    is not a comma and the first data line holds one.

    Examples
    --------
    >>> layout, _ = sniff_csv("Zeit;A2_Pos\\nms;Grad\\n0;1,5\\n".encode("cp1252"))
    >>> layout.separator, layout.decimal, dict(layout.units), layout.encoding
    (';', ',', {'Zeit': 'ms', 'A2_Pos': 'Grad'}, 'utf-8')
    """
    try:
        text, encoding = data.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError:
        text, encoding = data.decode("cp1252", errors="replace"), "cp1252"
    lines = [*text.splitlines()[:3], "", "", ""]
    separator = max((",", ";", "\t"), key=lines[0].count)
    header = next(csv.reader([lines[0]], delimiter=separator), [])
    first = next(csv.reader([lines[1]], delimiter=separator), [])
    cells = [cell for cell in first if cell.strip()]
    has_units = bool(cells) and not any(_is_number(cell) for cell in cells)
    data_line = lines[2] if has_units else lines[1]
    decimal = "," if separator != "," and "," in data_line else "."
    units = (
        {h.strip(): u.strip() for h, u in zip(header, first, strict=False) if u.strip()}
        if has_units
        else {}
    )
    return CsvLayout(encoding, separator, decimal, units), text


def _words(name: str) -> list[str]:
    """Lower-case words of a column name: ``J2_ActPos[deg]`` -> ``['j2', 'actpos', 'deg']``."""
    return [w for w in re.split(r"[^0-9a-zA-Zäöüß°µ]+", name.lower()) if w]


def _unit_word(name: str, units: Mapping[str, str]) -> str | None:
    """The column's unit: from the units row, else a unit word ending its name."""
    if units.get(name):
        return units[name].strip().strip("[]()").lower()
    bracket = re.search(r"[\[(]([^\])]+)[\])]\s*$", name)
    if bracket:
        return bracket.group(1).strip().lower()
    words = _words(name)
    if len(words) > 1 and words[-1] in NAME_UNITS:
        return words[-1]
    return None


def _role_by_name(name: str, unit: str | None) -> str | None:
    return _role_and_how(name, unit)[0]


def _not_measured(words: Sequence[str]) -> bool:
    """A name that says set point, model value or flag (:data:`NOT_MEASURED`)."""
    return any(
        word in NOT_MEASURED
        or word.startswith(NOT_MEASURED_STARTS)
        or word.endswith(NOT_MEASURED_ENDS)
        for word in words
    )


def _role_and_how(name: str, unit: str | None) -> tuple[str | None, str]:
    """The role a column's name or unit says, and which of them said it."""
    words = _words(name)
    match = AXIS_PREFIX.match(name.strip())
    if match:
        words = _words(match["rest"])
    if _not_measured(words):
        return None, ""
    for role, known in ROLE_WORDS.items():
        if any(word in known for word in words):
            return role, "name"
    for role, known in ROLE_WORDS.items():  # words inside words: "ActPosition", "MotorCurrent"
        if any(len(k) > 2 and k in word for word in words for k in known):
            return role, "name"
    if unit is not None:
        base = unit.removesuffix("/s").removesuffix("/sec")
        if unit != base and base in POSITION_WORDS:
            return "speed", "unit"
        return NAME_UNITS.get(unit), "unit"
    return None, ""


def stamp_kind(stamps: pd.Series, unit_word: str | None) -> tuple[str, str]:
    """The time column's kind (``"iso"``, ``"unix"``, ``"relative"``) and unit.

    A unit the units row or name gives wins; else Unix stamps are told by their size and
    relative ones by their step (whole steps of 1 or more: milliseconds).

    Examples
    --------
    >>> import pandas as pd
    >>> stamp_kind(pd.Series([1772344800000, 1772344800001]), None)
    ('unix', 'ms')
    >>> stamp_kind(pd.Series([0.0, 0.0005]), None)
    ('relative', 's')
    """
    import pandas as pd

    first = stamps.iloc[0]
    if isinstance(first, str) and _ISO.match(first):
        return "iso", "s"
    values = pd.to_numeric(stamps, errors="coerce").to_numpy(dtype=np.float64)
    declared = TIME_WORDS.get(unit_word) if unit_word else None
    start = float(values[0])
    for unit, low, high in UNIX_RANGES:
        if low <= start < high and declared in (None, unit):
            return "unix", unit
    if declared is not None:
        return "relative", declared
    steps = np.diff(values[np.isfinite(values)])
    step = float(np.median(steps)) if steps.size else math.nan
    whole = bool(steps.size) and bool(np.all(steps == np.round(steps)))
    return "relative", "ms" if whole and step >= 1 else "s"


@dataclass(frozen=True)
class AxisGuess:
    """One axis found in a file: its columns by role, units and rates.

    Attributes
    ----------
    axis : str
        The axis prefix (``A2``); empty for a file of one axis without one.
    columns : dict of str to str
        File column -> role.
    position_unit : str
        A unit of :data:`~axiswatch._profiles.POSITION_UNITS` (``rad`` when nothing says).
    rates_hz : dict of str to float
        Role -> rate read from the time stamps.
    how : dict of str to str
        Role -> how it was found (``name``, ``units row``, ``content``).
    notes : list of str
        What was left out or assumed, and why.
    unit_assumed : bool
        Nothing in the file gives the position's unit.
    """

    axis: str
    columns: Mapping[str, str]
    position_unit: str
    rates_hz: Mapping[str, float]
    how: Mapping[str, str]
    notes: Sequence[str] = ()
    unit_assumed: bool = False


@dataclass(frozen=True)
class FileGuess:
    """What one file holds: its layout, time column and axes, or why it cannot be placed;
    ``irregular``: its time steps are irregular (a PLC's logger)."""

    path: Path
    layout: CsvLayout | None = None
    time_column: str | None = None
    time_kind: str = ""
    time_unit: str = "s"
    first_stamp_s: float | None = None
    axes: tuple[AxisGuess, ...] = ()
    problem: str | None = None
    irregular: bool = False

    def profile(self, axis: AxisGuess, *, resample_irregular: bool = False) -> AxisProfile:
        """The axis profile of one of this file's axes; ``resample_irregular`` for a logger whose
        steps are irregular in this file or another of the axis's."""
        assert self.time_column is not None
        columns = {self.time_column: "time", **axis.columns}
        return AxisProfile(
            columns=columns, time_unit=self.time_unit, position_unit=axis.position_unit,
            resample_irregular=resample_irregular or self.irregular,
        )  # fmt: skip


def export_files(paths: Sequence[Path]) -> tuple[list[Path], list[Path]]:
    """The files to profile: each file as given, and the capture files under each folder
    (hidden ones left out), in name order; and the folders that hold none.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("b.txt", "a.csv", "notes.md", ".a.csv.tmp"):
    ...     _ = (folder / name).write_text("")
    >>> [p.name for p in export_files([folder])[0]]
    ['a.csv', 'b.txt']
    """
    from axiswatch._formats import capture_suffixes

    suffixes = {*capture_suffixes(), *TEXT_SUFFIXES}
    files: list[Path] = []
    empty: list[Path] = []
    for path in map(Path, paths):
        if not path.is_dir():
            files.append(path)
            continue
        found = sorted(
            p for p in path.rglob("*")
            if p.is_file() and p.suffix.lower() in suffixes
            and not any(part.startswith(".") for part in p.relative_to(path).parts)
        )  # fmt: skip
        files += found
        if not found:
            empty.append(path)
    return files, empty


def _smoothness(values: np.ndarray) -> float:
    spread = float(np.ptp(values)) if values.size else 0.0
    return float(np.median(np.abs(np.diff(values)))) / spread if spread > 0 else math.inf


def _output_side(column: str) -> int:
    """How surely a position or speed column is the gear's output's: 2 by a word such as
    joint, 0 by motor, else 1 (:data:`OUTPUT_WORDS`)."""
    words = _words(column)
    if any(word in OUTPUT_WORDS for word in words):
        return 2
    return 0 if any(word.startswith("motor") for word in words) else 1


def _suffix_axes(columns: Sequence[str]) -> set[str]:
    """Axis numbers that end names (``joint_position_1`` .. ``_6``): two or more numbers, each
    with a column whose name says position. ``PG_1``, ``Accel_1`` number sensors, not axes."""
    numbers = set()
    for column in columns:
        match = AXIS_SUFFIX.match(column.strip())
        if match and _role_by_name(match["rest"], None) == "position":
            numbers.add(match["number"])
    return numbers if len(numbers) >= 2 else set()


def _axis_of(column: str, suffix_axes: set[str]) -> str:
    """The axis a column belongs to: its prefix (``A2``), its number (``axis2``), or none."""
    match = AXIS_PREFIX.match(column.strip())
    if match:
        return match["axis"].replace(" ", "").upper()
    suffix = AXIS_SUFFIX.match(column.strip())
    if suffix and suffix["number"] in suffix_axes:
        return f"axis{suffix['number']}"
    return ""


def guess_roles(
    frame: pd.DataFrame, units: Mapping[str, str], time_column: str
) -> dict[str, dict[str, tuple[str, str]]]:
    """Columns by axis and role: ``{axis: {role: (column, how)}}`` (axis ``""``: none).

    A name or unit says the role; a set point, a model value or a flag by its name
    (:data:`NOT_MEASURED`) gets none. Columns left over in an axis without a motion or a torque
    are placed by content, a flag or a constant (fewer than :data:`MIN_DISTINCT_VALUES` values)
    never: the smoothest is the position, the rest the torque. Beside named axes, the others
    are the robot's and get no role.
    """
    axes: dict[str, dict[str, tuple[str, str]]] = {}
    unplaced: dict[str, list[str]] = {}
    suffix_axes = _suffix_axes([str(c) for c in frame.columns if str(c) != time_column])
    for column in map(str, frame.columns):
        if column == time_column:
            continue
        values = frame[column]
        if not _numeric(values) or _not_measured(_words(column)):
            continue
        axis = _axis_of(column, suffix_axes)
        unit = _unit_word(column, units)
        role, how = _role_and_how(column, unit)
        slot = axes.setdefault(axis, {})
        if (
            role in SIDED_ROLES
            and role in slot
            and _output_side(column) > _output_side(slot[role][0])
        ):
            # joint_position beside motor_position: the profile reads the output's by default.
            unplaced.setdefault(axis, []).append(slot[role][0])
            slot[role] = (column, how)
            continue
        if role is None or role == "time" or role in slot:
            unplaced.setdefault(axis, []).append(column)
            continue
        slot[role] = (column, how)
    named_axes = any(axes)
    for axis, columns in unplaced.items():
        if named_axes and not axis:
            continue  # beside named axes, the other columns are the robot's (a supply voltage)
        slot = axes.setdefault(axis, {})
        taken = {col for col, _ in slot.values()}
        left = [
            c for c in columns
            if c not in taken and np.unique(_values(frame[c])).size >= MIN_DISTINCT_VALUES
        ]  # fmt: skip
        if not {"position", "speed"} & set(slot) and left:  # a named speed is the motion
            smooth = min(left, key=lambda c: _smoothness(_values(frame[c])))
            slot["position"] = (smooth, "content")
            left.remove(smooth)
        if "torque" not in slot and left:
            slot["torque"] = (max(left, key=lambda c: _smoothness(_values(frame[c]))), "content")
    return {axis: slot for axis, slot in axes.items() if slot}


def _numeric(values: Any) -> bool:
    import pandas as pd

    return bool(pd.to_numeric(values, errors="coerce").notna().mean() > 0.5)


def _values(values: Any) -> np.ndarray:
    import pandas as pd

    numbers = np.asarray(pd.to_numeric(values, errors="coerce"), dtype=np.float64)
    return numbers[np.isfinite(numbers)]


def _read(path: Path) -> tuple[pd.DataFrame, CsvLayout | None]:
    import pandas as pd

    from axiswatch._formats import capture_format

    if path.suffix.lower() not in TEXT_SUFFIXES:
        frame, _ = capture_format(path).read(path)
        return frame, None
    from axiswatch._formats import decimal_commas

    layout, text = sniff_csv(path.read_bytes())
    frame = pd.read_csv(
        io.StringIO(text),
        sep=layout.separator,
        decimal=layout.decimal,
        skiprows=[1] if layout.units else None,
    )
    if layout.decimal == "." and layout.separator != "," and decimal_commas(frame):
        # Whole numbers on the first data line (an axis at rest) hid the decimal comma.
        layout = dataclasses.replace(layout, decimal=",")
        frame = pd.read_csv(
            io.StringIO(text), sep=layout.separator, decimal=",",
            skiprows=[1] if layout.units else None,
        )  # fmt: skip
    return frame.rename(columns=lambda c: str(c).strip()), layout


def _time_column(frame: pd.DataFrame, units: Mapping[str, str]) -> str | None:
    named = [
        str(c) for c in frame.columns if _role_by_name(str(c), _unit_word(str(c), units)) == "time"
    ]
    if named:
        return named[0]
    first = str(frame.columns[0])  # a logger's first column: increasing numbers or dates
    values = frame[first]
    if isinstance(values.iloc[0], str) and _ISO.match(values.iloc[0]):
        return first
    numbers = _values(values)
    if numbers.size > 1 and bool(np.all(np.diff(numbers) > 0)):
        return first
    return None


def _rate(stamps_s: np.ndarray, values: Any) -> float:
    import pandas as pd

    present = pd.to_numeric(values, errors="coerce").notna().to_numpy()
    times = stamps_s[present]
    return (times.size - 1) / float(times[-1] - times[0]) if times.size > 1 else math.nan


def _stamps_s(stamps: pd.Series, kind: str, unit: str) -> tuple[np.ndarray, float]:
    """Seconds from the first stamp, and the first stamp in seconds (Unix time or relative).

    The first stamp is subtracted before scaling: Unix milliseconds scaled first lose the
    steps' last digits (a 1 kHz log read as 999.999 Hz)."""
    import pandas as pd

    from axiswatch._profiles import TIME_UNITS

    if kind == "iso":
        nanoseconds = pd.DatetimeIndex(pd.to_datetime(stamps, format="ISO8601", utc=True))
        ticks = nanoseconds.as_unit("ns").asi8
        return np.asarray((ticks - ticks[0]) / 1e9, dtype=np.float64), float(ticks[0]) / 1e9
    values = pd.to_numeric(stamps, errors="coerce").to_numpy()
    scale = TIME_UNITS[unit]
    relative = np.asarray(values - values[0], dtype=np.float64) * scale
    return relative, float(values[0]) * scale


def _unit_note(column: str, values: np.ndarray) -> str:
    """What to write when the position's unit is not in the file; whole numbers over more
    than :data:`COUNTS_SPAN` read as encoder counts."""
    note = (
        f"position unit of {column!r} not in the file: rad assumed; if it is deg, write "
        'position = "deg" under [units] in the axis.toml'
    )
    span = float(np.ptp(values)) if values.size else 0.0
    if span > COUNTS_SPAN and bool(np.all(values == np.round(values))):
        note += (
            f"; whole numbers spanning more than {COUNTS_SPAN:.0f}: encoder counts? write "
            'position = "counts" and counts_per_revolution = (from the datasheet) under [units]'
        )
    return note


def _axis_guess(
    axis: str, slot: Mapping[str, tuple[str, str]], frame: pd.DataFrame,
    units: Mapping[str, str], stamps_s: np.ndarray,
) -> AxisGuess:  # fmt: skip
    notes: list[str] = []
    position_unit, assumed = "rad", False
    if "position" in slot:
        word = _unit_word(slot["position"][0], units)
        if word is not None and word in POSITION_WORDS:
            position_unit = POSITION_WORDS[word]
        else:
            assumed = True
            notes.append(_unit_note(slot["position"][0], _values(frame[slot["position"][0]])))
    columns = {column: role for role, (column, _) in slot.items()}
    if "speed" in slot and "position" not in slot:
        # The only motion signal: read in the position's unit per second; the position is
        # derived from it.
        word = (_unit_word(slot["speed"][0], units) or "").removesuffix("/s").removesuffix("/sec")
        if word in POSITION_WORDS:
            position_unit = POSITION_WORDS[word]
        else:
            assumed = True
            notes.append(
                f"no position column: the speed {slot['speed'][0]!r} is read in rad/s and the "
                'position derived from it; if it is in mm/s, write position = "mm" under '
                "[units] in the axis.toml"
            )
    elif "speed" in slot:
        # Read only in a stated unit: a Drehzahl column is often in rpm, 6x off if read as deg/s.
        column = slot["speed"][0]
        word = (_unit_word(column, units) or "").removesuffix("/s").removesuffix("/sec")
        if not word or POSITION_WORDS.get(word) != position_unit:
            del columns[column]
            said = "no unit" if not word else "a unit other than the position's per second"
            notes.append(
                f"speed column {column!r} left out ({said}): the indicators derive the speed "
                "from the position"
            )
    rates = {role: _rate(stamps_s, frame[column]) for column, role in columns.items()}
    how = {role: how for role, (column, how) in slot.items() if column in columns}
    return AxisGuess(axis, columns, position_unit, rates, how, tuple(notes), assumed)


def detect_file(path: str | Path) -> FileGuess:
    """What ``path`` holds, or why it cannot be placed (:attr:`FileGuess.problem`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "trace.csv"
    >>> _ = path.write_text("Zeit;A1_Pos_deg;A1_Cur_A\\nms;deg;A\\n"
    ...     + "".join(f"{1772344800000 + k};{k},5;0,{k}\\n" for k in range(9)))
    >>> guess = detect_file(path)
    >>> guess.time_kind, guess.time_unit, guess.axes[0].axis, dict(guess.axes[0].columns)
    ('unix', 'ms', 'A1', {'A1_Pos_deg': 'position', 'A1_Cur_A': 'torque'})
    """
    path = Path(path)
    if not path.exists():
        return FileGuess(path, problem="no such file or folder")
    try:
        frame, layout = _read(path)
    except Exception as exc:  # pandas, pyarrow and the registry raise many types
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return FileGuess(path, problem=f"cannot be read: {reason}")
    if frame.shape[0] < 2:
        return FileGuess(path, layout, problem="fewer than 2 rows")
    units = dict(layout.units) if layout is not None else {}
    time_column = _time_column(frame, units)
    if time_column is None:
        return FileGuess(
            path, layout,
            problem=f"no time column (a name such as time, Timestamp or Zeit, or increasing "
            f"numbers or dates first); found {list(map(str, frame.columns))}",
        )  # fmt: skip
    kind, unit = stamp_kind(frame[time_column], _unit_word(time_column, units))
    try:
        stamps_s, first_s = _stamps_s(frame[time_column], kind, unit)
    except (ValueError, TypeError) as exc:
        return FileGuess(path, layout, time_column, problem=f"time column {time_column!r}: {exc}")
    first = first_s if kind != "relative" else None
    slots = guess_roles(frame, units, time_column)
    axes = tuple(
        _axis_guess(axis, slot, frame, units, stamps_s) for axis, slot in sorted(slots.items())
    )
    if kind == "relative" and unit == "ms" and _unit_word(time_column, units) is None:
        # Steps of 1 with no unit: milliseconds, or a sample counter whose rate no file says.
        said = (
            f"time column {time_column!r} steps by whole numbers with no unit: read as ms; if "
            'it counts samples, write time = "samples" and sample_rate_hz = (the logger\'s '
            "rate) under [units] in the axis.toml"
        )
        axes = tuple(dataclasses.replace(a, notes=(*a.notes, said)) for a in axes)
    placed = tuple(
        a for a in axes
        if "torque" in a.columns.values() and {"position", "speed"} & set(a.columns.values())
    )  # fmt: skip
    if not placed:
        # In words, with the columns: "found {'-': ['torque']}" named neither.
        found = "; ".join(
            (f"axis {a.axis}: " if a.axis else "")
            + ", ".join(f"{role} {column!r}" for column, role in sorted(a.columns.items()))
            for a in axes
            if a.columns
        )  # fmt: skip
        return FileGuess(
            path, layout, time_column, kind, unit, first,
            problem=f"no axis with both a position (or speed) and a torque (or current) column; "
            f"found {found or 'none of them'}",
        )  # fmt: skip
    return FileGuess(
        path, layout, time_column, kind, unit, first, placed, irregular=_irregular(stamps_s)
    )


def _irregular(stamps_s: np.ndarray) -> bool:
    """Whether time steps stray from their median by more than :data:`IRREGULAR_STEP` of it."""
    steps = np.diff(stamps_s[np.isfinite(stamps_s)])
    if steps.size < 2:
        return False
    step = float(np.median(steps))
    return step > 0 and bool(np.max(np.abs(steps - step)) > IRREGULAR_STEP * step)


def profile_toml(profile: AxisProfile, comment: str = "") -> str:
    """An axis profile as the TOML file :meth:`AxisProfile.from_toml` reads back.

    Examples
    --------
    >>> p = AxisProfile(columns={"Zeit": "time", "A2_Pos_deg": "position"}, time_unit="ms",
    ...                 position_unit="deg")
    >>> import tomllib
    >>> AxisProfile.from_dict(tomllib.loads(profile_toml(p))) == p
    True
    """

    def quoted(text: str) -> str:
        return json.dumps(text, ensure_ascii=False)

    lines = [f"# {line}" for line in comment.splitlines()]
    if profile.name is not None:
        lines.append(f"name = {quoted(profile.name)}")
    if profile.resample_irregular:
        lines.append("resample_irregular = true")
    lines.append("[columns]")
    lines += [f"{quoted(column)} = {quoted(role)}" for column, role in profile.columns.items()]
    lines += ["[units]", f"time = {quoted(profile.time_unit)}"]
    if profile.sample_rate_hz is not None:
        lines.append(f"sample_rate_hz = {profile.sample_rate_hz!r}")
    lines.append(f"position = {quoted(profile.position_unit)}")
    return "\n".join(lines) + "\n"
