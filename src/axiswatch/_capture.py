"""A capture: the signals of one robot axis over a few seconds, each at its own rate.

The file format is the monitor manual's "Capture files". Readers are in :mod:`axiswatch._formats`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from axiswatch._formats import UNITS_ROW_KEY, capture_format
from axiswatch._profiles import AxisProfile
from axiswatch._quantiles import median
from axiswatch._timebase import (
    RATE_TOLERANCE,
    check_increasing,
    check_stamp_unit,
    date_stamps,
    rate_at_least,
    sampling_period,
)
from axiswatch.exceptions import CaptureError

__all__ = [
    "DEFAULT_SIGNALS",
    "RATE_TOLERANCE",
    "Capture",
    "as_capture",
    "capture_to_frame",
    "check_increasing",
    "check_stamp_unit",
    "date_stamps",
    "rate_at_least",
    "read_capture",
    "sampling_period",
    "speed_from_position",
    "with_speed",
    "write_capture",
]

DEFAULT_SIGNALS: tuple[str, ...] = ("position", "speed", "torque")

#: Relative tolerance on the spacing of time stamps of one signal: loggers jitter a little, but a
#: step that is 1.5 periods or more means a missing (NaN) sample.
_SPACING_RTOL = 0.25
#: Up to this many periods, a step in the stamps is called a skipped sample that the profile's
#: ``resample_irregular`` can interpolate over (the message's advice only; nothing is read by it).
_SHORT_GAP_PERIODS = 10.0


@dataclass(frozen=True)
class Capture:
    """Signals of one robot axis recorded over one capture window.

    Parameters
    ----------
    signals : mapping of str to array-like of shape (n_samples_of_that_signal,)
        Signal values, converted to float64. Each must be finite and non-empty.
    rates_hz : mapping of str to float
        Sampling rate of every signal, in Hz.
    start_s : float, default=0.0
        Time of the first sample of every signal, in seconds.
    source : str, default="<memory>"
        Where the capture comes from (a file path); used in error messages.
    metadata : mapping of str to str, default={}
        Free-form labels (robot, axis, task, ...). Stored in Parquet files.

    Examples
    --------
    >>> import numpy as np
    >>> cap = Capture({"position": np.zeros(250), "torque": np.ones(2000)},
    ...               {"position": 250.0, "torque": 2000.0})
    >>> cap.names
    ('position', 'torque')
    >>> cap.duration_s("position")
    1.0
    """

    signals: Mapping[str, NDArray[np.float64]]
    rates_hz: Mapping[str, float]
    start_s: float = 0.0
    source: str = "<memory>"
    metadata: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.signals:
            raise CaptureError(f"{self.source}: a capture needs at least one signal; got none.")
        missing = [name for name in self.signals if name not in self.rates_hz]
        if missing:
            raise CaptureError(
                f"{self.source}: no sampling rate given for signal(s) {missing}; "
                f"rates_hz has {sorted(self.rates_hz)}."
            )
        converted: dict[str, NDArray[np.float64]] = {}
        for name, values in self.signals.items():
            array = np.asarray(values, dtype=np.float64)
            if array.ndim != 1:
                raise CaptureError(
                    f"{self.source}: signal '{name}' must be 1-D; got shape {array.shape}."
                )
            if array.size == 0:
                raise CaptureError(f"{self.source}: signal '{name}' is empty.")
            bad = np.flatnonzero(~np.isfinite(array))
            if bad.size:
                raise CaptureError(
                    f"{self.source}: signal '{name}' has {bad.size} non-finite value(s) "
                    f"(NaN or inf), first at sample {bad[0]}; expected finite numbers."
                )
            rate = float(self.rates_hz[name])
            if not (math.isfinite(rate) and rate > 0):
                raise CaptureError(
                    f"{self.source}: rate of signal '{name}' must be a positive number of Hz; "
                    f"got {self.rates_hz[name]!r}."
                )
            array.setflags(write=False)
            converted[name] = array
        object.__setattr__(self, "signals", converted)
        object.__setattr__(
            self, "rates_hz", {name: float(self.rates_hz[name]) for name in converted}
        )
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def names(self) -> tuple[str, ...]:
        """Signal names, in insertion order."""
        return tuple(self.signals)

    def duration_s(self, name: str) -> float:
        """Length of signal ``name`` in seconds (number of samples / rate)."""
        return len(self.signals[name]) / self.rates_hz[name]

    def select(self, names: Sequence[str]) -> Capture:
        """Return a capture with only the signals ``names``, in that order.

        Raises
        ------
        CaptureError
            If a name is not a signal of this capture.
        """
        missing = [name for name in names if name not in self.signals]
        if missing:
            raise CaptureError(
                f"{self.source}: missing signal column(s) {missing}; "
                f"the capture has {list(self.names)}."
            )
        return Capture(
            {name: self.signals[name] for name in names},
            {name: self.rates_hz[name] for name in names},
            start_s=self.start_s,
            source=self.source,
            metadata=self.metadata,
        )


def _time_grid(capture: Capture) -> NDArray[np.int64]:
    """Union of every signal's sample instants, in integer nanoseconds."""
    stamps = [
        np.round((capture.start_s + np.arange(len(v)) / capture.rates_hz[n]) * 1e9).astype(np.int64)
        for n, v in capture.signals.items()
    ]
    return np.unique(np.concatenate(stamps))


def capture_to_frame(capture: Capture) -> pd.DataFrame:
    """Lay a capture out as the file format's table: ``time`` then one column per signal.

    Examples
    --------
    >>> import numpy as np
    >>> cap = Capture({"position": [0.0, 1.0], "speed": [0.0, 0.5, 1.0, 1.5]},
    ...               {"position": 1.0, "speed": 2.0})
    >>> capture_to_frame(cap)
       time  position  speed
    0   0.0       0.0    0.0
    1   0.5       NaN    0.5
    2   1.0       1.0    1.0
    3   1.5       NaN    1.5
    """
    grid_ns = _time_grid(capture)
    frame = pd.DataFrame({"time": grid_ns / 1e9})
    for name, values in capture.signals.items():
        own_ns = np.round(
            (capture.start_s + np.arange(len(values)) / capture.rates_hz[name]) * 1e9
        ).astype(np.int64)
        column = np.full(grid_ns.shape, np.nan)
        column[np.searchsorted(grid_ns, own_ns)] = values
        frame[name] = column
    return frame


def write_capture(capture: Capture, path: str | Path) -> Path:
    """Write a capture to ``path`` in the project's file format, by its suffix: ``.parquet``,
    ``.csv``, ``.npz`` or a format added with :func:`~axiswatch.register_format`.

    Parquet and ``.npz`` files also keep ``capture.metadata``. Returns the path written.
    """
    path = Path(path)
    capture_format(path).write(capture_to_frame(capture), capture.metadata, path)
    return path


def _read_frame(path: Path, encoding: str | None = None) -> tuple[pd.DataFrame, dict[str, str]]:
    file_format = capture_format(path)
    if not path.is_file():
        raise CaptureError(f"{path}: no such capture file.")
    if path.stat().st_size == 0:
        raise CaptureError(f"{path}: file is empty (0 bytes).")
    try:
        if encoding is not None and file_format.read_text is not None:
            frame, metadata = file_format.read_text(path, encoding)
        else:
            frame, metadata = file_format.read(path)
    except CaptureError:
        raise
    except Exception as exc:  # pyarrow/pandas raise many types for truncated or corrupt files
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CaptureError(
            f"{path}: cannot read {file_format.description} file (truncated or corrupt?): {message}"
        ) from exc
    if frame.shape[0] == 0:
        raise CaptureError(f"{path}: file has a header but no rows.")
    return frame, metadata


def _tidy_headers(frame: pd.DataFrame, profile: AxisProfile | None, path: Path) -> pd.DataFrame:
    """Column names without surrounding spaces, and in the case the reader looks for: a
    profile's column names, else ``time`` and :data:`DEFAULT_SIGNALS` (``TORQUE``, ``Position ``
    from a spreadsheet); a name that already matches exactly is left alone.

    Examples
    --------
    >>> frame = pd.DataFrame(columns=["Time", "Position ", "TORQUE", "Note"])
    >>> list(_tidy_headers(frame, None, Path("c.csv")).columns)
    ['time', 'position', 'torque', 'Note']
    """
    names = [str(c).strip() for c in frame.columns]
    mapped = dict(profile.columns) if profile is not None else {}
    keys = {key.strip().lower(): key for key in mapped}
    roles = {role.lower(): role for role in ("time", *DEFAULT_SIGNALS)}
    taken = set(names) | set(mapped.values())
    tidy: list[str] = []
    for name in names:
        folded = name.lower()
        if name in mapped:
            tidy.append(name)
        elif folded in keys and keys[folded] not in names:
            tidy.append(keys[folded])
        elif folded in roles and roles[folded] not in taken:
            tidy.append(roles[folded])
        else:
            tidy.append(name)
    repeated = sorted({name for name in tidy if tidy.count(name) > 1})
    if repeated:
        raise CaptureError(
            f"{path}: columns {[str(c) for c in frame.columns]} name {repeated} more than once "
            "(up to case and spaces); expected one column per name."
        )
    if tidy == list(frame.columns):
        return frame  # already tidy: pandas' set_axis copies the frame
    return frame.set_axis(tidy, axis=1)


def _numeric_column(frame: pd.DataFrame, name: str, path: Path) -> NDArray[np.float64]:
    column = frame[name]
    if isinstance(column.dtype, np.dtype) and column.dtype.kind in "iufc":
        # A NumPy number (pandas' checks below cost more than the conversion).
        return np.asarray(column, dtype=np.float64)
    if not (pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column)):
        converted = pd.to_numeric(column, errors="coerce")
        bad = converted.isna() & column.notna()
        first = column[bad].iloc[0] if bool(bad.any()) else None
        raise CaptureError(
            f"{path}: column '{name}' must be numeric; found non-numeric value {first!r} "
            f"(dtype {column.dtype})."
        )
    return np.asarray(column, dtype=np.float64)


def _float_columns(frame: pd.DataFrame) -> dict[str, NDArray[np.float64]] | None:
    """Every column of a table of float64 columns named by text, as views of one array (a
    capture's usual table: pandas' lookup of each column cost more than its checks); None
    for any other table, whose columns :func:`_numeric_column` checks one by one."""
    names = list(frame.columns)
    if not all(isinstance(name, str) for name in names):
        return None
    if not all(dtype == np.float64 for dtype in frame.dtypes):
        return None
    table = frame.to_numpy(dtype=np.float64)
    return {name: table[:, k] for k, name in enumerate(names)}


def _signal_from_column(
    time_s: NDArray[np.float64],
    column: NDArray[np.float64],
    name: str,
    path: Path,
    rows_periods: tuple[float, float] | None = None,
    time_steps: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], float, float, tuple[float, float]]:
    """Values, rate and start of one signal column (NaN marks instants it does not sample),
    and its median and own sampling periods. ``rows_periods``: those of a column with a value
    in every row, already checked; another such column has the same (its stamps are the rows').
    ``time_steps``: ``np.diff(time_s)``, when the caller has it."""
    if np.isfinite(column).all():  # a value in every row: one pass instead of three
        if rows_periods is not None:
            return column.copy(), 1.0 / rows_periods[1], float(time_s[0]), rows_periods
        present, count = None, column.size
    else:
        if np.isinf(column).any():
            raise CaptureError(
                f"{path}: column '{name}' has an infinite value; expected finite numbers."
            )
        present = ~np.isnan(column)
        count = int(present.sum())
    if count == 0:
        raise CaptureError(
            f"{path}: column '{name}' is blank (no value in any row); expected the signal's values."
        )
    if count < 2:
        raise CaptureError(
            f"{path}: column '{name}' has {count} value(s); a signal needs at least 2 to have a rate."
        )
    first, last = (0, column.size - 1) if present is None else np.flatnonzero(present)[[0, -1]]
    stamps = time_s if present is None else time_s[present]
    steps = time_steps if present is None and time_steps is not None else np.diff(stamps)
    period = median(steps)
    deviation = np.abs(steps - period)
    largest = float(deviation.max())
    if largest > _SPACING_RTOL * period:
        k = int(np.flatnonzero(deviation > _SPACING_RTOL * period)[0])
        between = (time_s > stamps[k]) & (time_s < stamps[k + 1])
        if between.any():  # the file has rows there, blank in this column
            where = time_s[between]
            raise CaptureError(
                f"{path}: column '{name}' is not uniformly sampled: blank (NaN) at "
                f"t={where[0]:.6g} s ({where.size} row(s)) inside the signal, whose period is "
                f"{period:.6g} s; expected a value at each of its sampling instants."
            )
        cause = (
            "a gap in time"
            if steps[k] > 1.5 * period
            else "irregular stamps? resample_irregular = true in the axis profile puts them on "
            "a uniform grid"
        )
        if 1.5 * period < steps[k] <= _SHORT_GAP_PERIODS * period:
            # A PLC that now and then skips a few samples (a real linear axis's log): the
            # profile's resampling interpolates over such a gap, and nothing else said so.
            cause = (
                f"a gap of {steps[k] / period:.1f} periods; a logger that skips samples needs "
                "resample_irregular = true in the axis profile, which interpolates over it"
            )
        # Absolute stamps (Unix seconds) say little: also say where in the capture it is.
        into = f" ({stamps[k] - time_s[0]:.6g} s into the capture)" if time_s[0] != 0 else ""
        raise CaptureError(
            f"{path}: column '{name}' is not uniformly sampled: step of {steps[k]:.6g} s after "
            f"t={stamps[k]:.6g} s{into} where the signal's period is {period:.6g} s ({cause})."
        )
    # A signal sampled on a coarser grid than the file's rows: every row between its first and last
    # sample that lies on its own grid must hold a value. A signal in every row has no hole.
    if present is not None:
        window = slice(first, last + 1)
        steps_in = (time_s[window] - stamps[0]) / period
        on_grid = np.abs(steps_in - np.round(steps_in))
        holes = np.flatnonzero((on_grid < 1e-3) & ~present[window])
        if holes.size:
            raise CaptureError(
                f"{path}: column '{name}' has NaN inside the signal at "
                f"t={time_s[first + holes[0]]:.6g} s; "
                "expected a value at each of the signal's own sampling instants."
            )
    # With the median step, 1 % jitter gave 99.94 Hz against the baseline's 100.06 Hz, and a
    # readable capture was rejected. Exact stamps (every step within 1e-9 of the median, as
    # sampling_period tells them) give the median, known here.
    if largest <= 1e-9 * period:
        own_period = period
    else:
        own_period = sampling_period(stamps, steps=steps, median_step=period)
    values = column.copy() if present is None else column[present]
    return values, 1.0 / own_period, float(stamps[0]), (period, own_period)


def _repeated_rows(frame: pd.DataFrame) -> NDArray[np.bool_]:
    """Rows equal to the row before them, NaN matching NaN (never the first row).

    Examples
    --------
    >>> frame = pd.DataFrame({"time": [0.0, 0.0, 1.0], "x": [np.nan, np.nan, 2.0]})
    >>> _repeated_rows(frame).tolist()
    [False, True, False]
    """
    if all(isinstance(dtype, np.dtype) and dtype.kind == "f" for dtype in frame.dtypes):
        # A capture's usual table: NumPy compares it in a hundredth of pandas' time.
        values = frame.to_numpy(dtype=np.float64)
        repeated = np.zeros(values.shape[0], dtype=bool)
        if not values.size:
            return repeated
        # Rows equal in every column are equal in the first (the time, as written): the
        # others are compared on those rows only.
        first = values[:, 0]
        after, before = first[1:], first[:-1]
        rows = np.flatnonzero((after == before) | (np.isnan(after) & np.isnan(before))) + 1
        after, before = values[rows], values[rows - 1]
        repeated[rows] = ((after == before) | (np.isnan(after) & np.isnan(before))).all(axis=1)
        return repeated
    previous = frame.shift()
    return np.asarray((frame.eq(previous) | (frame.isna() & previous.isna())).all(axis=1))


def read_capture(
    path: str | Path,
    signals: Sequence[str] | None = None,
    *,
    expected_rates_hz: Mapping[str, float] | None = None,
    profile: AxisProfile | None = None,
) -> Capture:
    """Read and validate one capture file.

    Parameters
    ----------
    path : str or Path
        A ``.parquet``, ``.csv`` or ``.npz`` file in the project's capture format (or a
        format added with :func:`~axiswatch.register_format`).
    signals : sequence of str, optional
        Signal columns to read, in this order. Default: those of :data:`DEFAULT_SIGNALS` the file
        has (other columns are extras: a controller's mode, an axis number, a row index), or,
        with none of them, every column except ``time`` that holds numbers.
    expected_rates_hz : mapping of str to float, optional
        Rates the signals must have (for instance the baseline's); a mismatch beyond 0.1 % is an
        error.
    profile : AxisProfile, optional
        Column names, units and time stamps of the file (:meth:`AxisProfile.standardise`):
        mapped to the project's format before anything is checked.

    Returns
    -------
    Capture

    Raises
    ------
    CaptureError
        Naming the file, the column and what was expected: unreadable, empty or truncated file,
        missing ``time`` or signal column, non-numeric values, NaN inside a signal, non-increasing
        time, or a rate that differs from ``expected_rates_hz``.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> cap = Capture({"speed": np.arange(4.0)}, {"speed": 2000.0})
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> back = read_capture(write_capture(cap, folder / "2026-03-01.parquet"))
    >>> back.rates_hz["speed"], back.signals["speed"].tolist()
    (2000.0, [0.0, 1.0, 2.0, 3.0])
    """
    path = Path(path)
    frame, metadata = _read_frame(path, None if profile is None else profile.encoding)
    units_row = metadata.pop(UNITS_ROW_KEY, None)
    if units_row is not None:
        (profile or AxisProfile()).check_units_row(json.loads(units_row), path)
    # A row written twice (a logger's double write: the same stamp and the same values) carries
    # nothing new; a repeated stamp with other values is an error below.
    repeated = _repeated_rows(frame)
    if repeated[1:].any():
        frame = frame.loc[~repeated].reset_index(drop=True)
    frame = _tidy_headers(frame, profile, path)
    if profile is not None:
        # Irregular rows are put on the expected (the baseline's) grid: their own mean rate moves
        # by a few per cent from capture to capture (steps of 39-55 ms: 2.4 % over six
        # captures), far beyond the 0.1 % a rate is checked to.
        step_s = None
        if profile.resample_irregular and expected_rates_hz:
            step_s = 1.0 / max(expected_rates_hz.values())
        frame = profile.standardise(frame, path, step_s=step_s)
    elif "time" in frame.columns:
        dates = date_stamps(frame["time"], path)
        if dates is not None:
            frame = frame.assign(time=dates)
        elif pd.api.types.is_numeric_dtype(frame["time"]) and frame.shape[0]:
            check_stamp_unit(float(frame["time"].iloc[0]), "s", path)
    if "time" not in frame.columns:
        raise CaptureError(
            f"{path}: missing column 'time' (seconds, strictly increasing); "
            f"found columns {list(map(str, frame.columns))}."
        )
    floats = _float_columns(frame)
    time_s = floats["time"] if floats is not None else _numeric_column(frame, "time", path)
    if not np.isfinite(time_s).all():
        raise CaptureError(f"{path}: column 'time' has NaN or inf; expected finite seconds.")
    time_steps = check_increasing(time_s, path)
    available = [str(c) for c in frame.columns if c != "time"]
    if signals is None:
        names = [name for name in DEFAULT_SIGNALS if name in available]
        if not names:
            # A column without a single number (a controller's mode text, a blank spare) is not
            # a signal; one with numbers and text is, and is refused below.
            names = [
                name
                for name in available
                if bool(pd.to_numeric(frame[name], errors="coerce").notna().any())
            ]
            if not names:
                raise CaptureError(f"{path}: no signal column besides 'time'.")
    else:
        names = list(signals)
        missing = [name for name in names if name not in available]
        if missing:
            raise CaptureError(
                f"{path}: missing signal column(s) {missing}; found columns {available}."
            )
    values: dict[str, NDArray[np.float64]] = {}
    rates: dict[str, float] = {}
    starts: list[float] = []
    rows_periods: tuple[float, float] | None = None  # of the signals in every row
    for name in names:
        column = floats[name] if floats is not None else _numeric_column(frame, name, path)
        values[name], rates[name], start, periods = _signal_from_column(
            time_s, column, name, path, rows_periods, time_steps
        )
        if values[name].size == time_s.size:
            rows_periods = periods
        starts.append(start)
        if expected_rates_hz is not None and name in expected_rates_hz:
            expected = float(expected_rates_hz[name])
            if abs(rates[name] - expected) > RATE_TOLERANCE * expected:
                raise CaptureError(
                    f"{path}: column '{name}' is sampled at {rates[name]:.6g} Hz; "
                    f"expected {expected:.6g} Hz (the baseline's rate)."
                )
    if max(starts) - min(starts) > 1.0 / min(rates.values()):
        raise CaptureError(
            f"{path}: signals start at different times ({dict(zip(names, starts, strict=True))}); "
            "expected them to start together."
        )
    return Capture(values, rates, start_s=min(starts), source=str(path), metadata=metadata)


def as_capture(
    signals: Mapping[str, ArrayLike], rates_hz: Mapping[str, float] | float, **kwargs: Any
) -> Capture:
    """Build a capture from arrays; ``rates_hz`` may be one rate shared by every signal.

    Examples
    --------
    >>> as_capture({"speed": [0.0, 1.0], "torque": [1.0, 2.0]}, 2000.0).rates_hz
    {'speed': 2000.0, 'torque': 2000.0}
    """
    if isinstance(rates_hz, Mapping):
        rates = dict(rates_hz)
    else:
        rates = {name: float(rates_hz) for name in signals}
    return Capture(
        {k: np.asarray(v, dtype=np.float64) for k, v in signals.items()}, rates, **kwargs
    )


def speed_from_position(position: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """The derivative of a position sampled at ``rate_hz`` (central differences, one-sided at
    the ends; zero for a single sample).

    Examples
    --------
    >>> speed_from_position(np.array([0.0, 1.0, 4.0]), 10.0).tolist()
    [10.0, 20.0, 30.0]
    """
    if position.size < 2:
        return np.zeros(position.size)
    return np.asarray(np.gradient(position, 1.0 / rate_hz), dtype=np.float64)


def with_speed(capture: Capture) -> Capture:
    """The capture, with a ``speed`` derived from its ``position`` when it has none.

    A drive's export often holds the position and the current only. Every method reads such a
    capture the same way: its speed is the position's derivative at the position's rate
    (:func:`speed_from_position`), as the indicators derive it.

    Examples
    --------
    >>> capture = Capture({"position": np.arange(4.0)}, {"position": 250.0})
    >>> derived = with_speed(capture)
    >>> derived.names, derived.rates_hz["speed"], derived.signals["speed"].tolist()
    (('position', 'speed'), 250.0, [250.0, 250.0, 250.0, 250.0])
    """
    if "speed" in capture.signals or "position" not in capture.signals:
        return capture
    rate = capture.rates_hz["position"]
    signals = dict(capture.signals)
    rates = dict(capture.rates_hz)
    signals["speed"] = speed_from_position(capture.signals["position"], rate)
    rates["speed"] = rate
    return Capture(
        signals, rates, start_s=capture.start_s, source=capture.source, metadata=capture.metadata
    )
