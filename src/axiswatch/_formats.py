"""Capture file formats: one registry from file suffix to reader and writer.

Built in: ``.parquet``, ``.csv`` and ``.npz``. A new format is a reader and a writer registered
with :func:`register_format`. The table form: docs/internals.md, "Capture formats".
"""

from __future__ import annotations

import codecs
import csv
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from axiswatch.exceptions import CaptureError

__all__ = [
    "NOMINAL_RATE_HZ",
    "UNITS_ROW_KEY",
    "CaptureFormat",
    "NpzRecording",
    "capture_format",
    "capture_suffixes",
    "read_npz",
    "register_format",
]

#: Rate given to ``.npz`` recordings whose ``fs`` is NaN: frequencies become cycles per sample.
NOMINAL_RATE_HZ = 1.0

#: Reads a file into (table, metadata).
Reader = Callable[[Path], tuple[pd.DataFrame, dict[str, str]]]
#: Writes (table, metadata) to a file.
Writer = Callable[[pd.DataFrame, Mapping[str, str], Path], None]
#: Reads a text file in a declared encoding into (table, metadata).
TextReader = Callable[[Path, str], tuple[pd.DataFrame, dict[str, str]]]

_METADATA_KEY = b"axiswatch"


@dataclass(frozen=True)
class CaptureFormat:
    """A capture file format: its suffix, a name for messages, a reader and a writer; a text
    format also reads a file in the encoding an axis profile declares (``read_text``)."""

    suffix: str
    description: str
    read: Reader
    write: Writer
    read_text: TextReader | None = None


_FORMATS: dict[str, CaptureFormat] = {}


def register_format(
    suffix: str,
    *,
    read: Reader,
    write: Writer,
    description: str,
    read_text: TextReader | None = None,
) -> None:
    """Register (or replace) the reader and writer of capture files ending in ``suffix``.

    Parameters
    ----------
    suffix : str
        File suffix with its dot, matched in any case, e.g. ``".feather"``.
    read : callable ``(path) -> (DataFrame, dict of str to str)``
        The file as the table form (module docstring) and its metadata. Raise
        :class:`~axiswatch.CaptureError` naming the file for a file that is not of the format;
        any other exception is reported as an unreadable file.
    write : callable ``(DataFrame, metadata, path) -> None``
        Writes the table form.
    description : str
        Name of the format in messages, e.g. ``"Feather"``.
    read_text : callable ``(path, encoding) -> (DataFrame, dict of str to str)``, optional
        For a text format: reads the file in the encoding an axis profile declares
        (``encoding = "cp1250"``). Without it the declared encoding is not used.

    Examples
    --------
    >>> import pandas as pd
    >>> register_format(".tsv", description="TSV",
    ...     read=lambda path: (pd.read_csv(path, sep="\\t"), {}),
    ...     write=lambda frame, metadata, path: frame.to_csv(path, sep="\\t", index=False))
    >>> ".tsv" in capture_suffixes()
    True
    >>> _ = _FORMATS.pop(".tsv")  # keep the doctest's format out of the registry
    """
    if not (isinstance(suffix, str) and suffix.startswith(".") and len(suffix) > 1):
        raise ValueError(
            f"The 'suffix' parameter must be a file suffix with its dot, such as '.feather'. "
            f"Got {suffix!r} instead."
        )
    _FORMATS[suffix.lower()] = CaptureFormat(suffix.lower(), description, read, write, read_text)


def capture_suffixes() -> tuple[str, ...]:
    """Suffixes of the registered capture formats, sorted.

    Examples
    --------
    >>> capture_suffixes()
    ('.csv', '.npz', '.parquet')
    """
    return tuple(sorted(_FORMATS))


def capture_format(path: str | Path) -> CaptureFormat:
    """The registered format of ``path``, by its suffix (any case).

    Raises
    ------
    CaptureError
        No format is registered for the suffix.

    Examples
    --------
    >>> capture_format("fleet/r1/a1/2026-03-01.PARQUET").description
    'Parquet'
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _FORMATS:
        known = capture_suffixes()
        raise CaptureError(
            f"{path}: unknown capture file type '{suffix}'; expected "
            f"{', '.join(known[:-1])} or {known[-1]}."
        )
    return _FORMATS[suffix]


def _read_parquet(path: Path) -> tuple[pd.DataFrame, dict[str, str]]:
    import pyarrow.parquet as pq

    # One file: read_table's dataset machinery (partitions, many files) doubled the read's cost.
    # On one thread, without pre-buffering (for remote stores): half the CPU time of a capture's
    # read. The monitor scores captures in parallel processes, not a capture's columns.
    try:
        with pq.ParquetFile(path, pre_buffer=False) as parquet:
            table = parquet.read(use_threads=False)
    except Exception:  # pyarrow raises many types for a corrupt file
        # read_table's error says the same and names the file, as the rejections list it.
        table = pq.read_table(path)
    raw = (table.schema.metadata or {}).get(_METADATA_KEY)
    metadata = {str(k): str(v) for k, v in json.loads(raw).items()} if raw else {}
    frame = _float_frame(table)
    if frame is None:
        frame = table.to_pandas()
    if not isinstance(frame.index, pd.RangeIndex):
        # Written from a DataFrame indexed by its time stamps (df.set_index("time").to_parquet()):
        # the index is a column of the file, not a row number.
        frame = frame.reset_index()
    return frame, metadata


def _float_frame(table: Any) -> pd.DataFrame | None:
    """The frame of a table of float64 columns without an index column, built from its columns
    (``to_pandas`` costs twice as much); None for any other table. Equal to ``to_pandas``'s
    frame: the same names, values (NaN for nulls) and row numbers (tested)."""
    import pyarrow as pa

    names = table.column_names
    if (
        not names
        or len(set(names)) != len(names)
        or any(t != pa.float64() for t in table.schema.types)
    ):
        return None
    pandas = table.schema.pandas_metadata
    if pandas is not None and (
        pandas.get("index_columns")
        or any(c.get("name") != c.get("field_name") for c in pandas.get("columns", []))
    ):
        return None  # an index to restore, or names pandas wrote otherwise
    # One block of columns: pandas frames a 2-D array in a third of the time it takes to join
    # separate columns into one.
    block = np.empty((len(names), table.num_rows))
    for row, name in zip(block, names, strict=True):
        row[:] = table.column(name).to_numpy()
    # Names as Python text: pandas looks them up (each column, by name, several times a read)
    # faster than in its default Arrow-backed text index.
    return pd.DataFrame(block.T, columns=pd.Index(names, dtype=object), copy=False)


def _write_parquet(frame: pd.DataFrame, metadata: Mapping[str, str], path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[_METADATA_KEY] = json.dumps(dict(metadata)).encode()
    pq.write_table(table.replace_schema_metadata(meta), path)


#: Metadata key of a CSV file's units row (JSON: column -> unit), checked by ``read_capture``
#: against the units the capture is read in.
UNITS_ROW_KEY = "units_row"


def _is_number(cell: str, decimal: str) -> bool:
    try:
        float(cell.strip().replace(decimal, "."))
    except ValueError:
        return False
    return True


def decimal_commas(frame: pd.DataFrame) -> bool:
    """Whether a text column of a table read with a decimal point holds decimal commas.

    Examples
    --------
    >>> decimal_commas(pd.DataFrame({"a": [0, 1], "b": ["0", "1,5"]}))
    True
    """
    for column in frame.columns:
        values = frame[column]
        if pd.api.types.is_numeric_dtype(values):
            continue
        with_comma = values[values.astype(str).str.contains(",", regex=False)]
        if not with_comma.empty and _is_number(str(with_comma.iloc[0]), ","):
            return True
    return False


#: Bytes read from a CSV file's end to find its last row (rows are far shorter).
_TAIL_BYTES = 65536

#: Bytes read from a CSV file's start to tell its encoding (the header and the units row, where
#: the only non-ASCII text of a capture is: the values are digits).
_HEAD_BYTES = 65536

#: Encoding of a CSV file that is not UTF-8: what Windows in Western Europe and the Americas
#: writes (a spreadsheet's "CSV" export, a controller's PC), with its ``°`` and ``ü``.
FALLBACK_ENCODING = "cp1252"

#: Byte order marks of UTF-16 text -> the codec that reads what follows the mark.
_UTF16_MARKS = {codecs.BOM_UTF16_LE: "utf-16-le", codecs.BOM_UTF16_BE: "utf-16-be"}


def csv_encoding(path: Path) -> str:
    """The encoding of a CSV capture: UTF-16 by its byte order mark, else UTF-8 (a UTF-8 mark
    skipped), else :data:`FALLBACK_ENCODING` when the head is not UTF-8.

    Raises
    ------
    CaptureError
        The head is neither UTF-8 nor Windows-1252 text: the message names both and says how
        to declare the file's encoding in the axis profile.
    """
    with path.open("rb") as stream:
        head = stream.read(_HEAD_BYTES)
    for mark, codec in _UTF16_MARKS.items():
        if head.startswith(mark):
            return codec
    try:
        # Incremental: a character cut by the head's end is not an error.
        codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError as utf8:
        try:
            head.decode(FALLBACK_ENCODING)
        except UnicodeDecodeError:
            raise CaptureError(
                f"{path}: the text is neither UTF-8 (byte 0x{head[utf8.start]:02x} at "
                f"{utf8.start}) nor Windows-1252; declare its encoding in the axis profile, "
                'such as encoding = "cp1250" above the first [table] line.'
            ) from None
        return FALLBACK_ENCODING
    return "utf-8-sig"


def _check_last_row(path: Path, header: str, separator: str, encoding: str) -> None:
    """Raise :class:`CaptureError` when the file ends inside a row: no final line break, and its
    last line has fewer fields than the header. A logger that died mid-write or a copy cut short
    leaves such a file; read, it would be a shorter capture, scored as if whole. A whole file
    without a final line break passes (its last row has every field)."""
    width = 2 if encoding.startswith("utf-16") else 1  # the tail starts on a character
    with path.open("rb") as stream:
        stream.seek(max(0, path.stat().st_size - _TAIL_BYTES) // width * width)
        tail = stream.read().decode(encoding, errors="replace")
    if tail.endswith(("\n", "\r")):
        return
    last = tail.rsplit("\n", 1)[-1]

    def fields(line: str) -> int:
        return len(next(csv.reader([line], delimiter=separator), []))

    if fields(last) < fields(header):
        raise CaptureError(
            f"{path}: ends inside a row (its last line has {fields(last)} of the header's "
            f"{fields(header)} fields): the file was cut off, still being written or its copy "
            "cut short"
        )


def _read_csv(path: Path) -> tuple[pd.DataFrame, dict[str, str]]:
    """A CSV capture: separator ``,``, ``;`` or tab and decimal point or comma (a European
    spreadsheet's ``;`` with ``0,5``) taken from the header and the first data line, the
    encoding from the file (:func:`csv_encoding`), and a units row under the header (every cell
    text, such as ``s;deg;A``) kept as metadata (:data:`UNITS_ROW_KEY`) instead of read as
    values."""
    return _read_csv_as(path, csv_encoding(path))


def _read_csv_as(path: Path, encoding: str) -> tuple[pd.DataFrame, dict[str, str]]:
    """A CSV capture in ``encoding`` (:func:`_read_csv`; an axis profile's ``encoding``)."""
    try:
        with path.open(encoding=encoding, newline="") as stream:
            lines = [stream.readline() for _ in range(3)]
    except UnicodeDecodeError as exc:
        raise CaptureError(
            f"{path}: not {encoding} text (byte 0x{exc.object[exc.start]:02x} at {exc.start} of "
            "its head), the encoding the axis profile declares; declare the file's own."
        ) from None
    header = lines[0].removeprefix("\ufeff")
    separator = max((",", ";", "\t"), key=header.count)
    first = next(csv.reader([lines[1]], delimiter=separator), [])
    cells = [cell for cell in first if cell.strip()]
    units_row = bool(cells) and not any(_is_number(c, ".") or _is_number(c, ",") for c in cells)
    data = lines[2] if units_row else lines[1]
    decimal = "," if separator != "," and "," in data else "."
    _check_last_row(path, header, separator, encoding)
    frame = pd.read_csv(
        path,
        sep=separator,
        decimal=decimal,
        encoding="utf-8-sig" if encoding == "utf-8" else encoding,
        skiprows=[1] if units_row else None,
    )
    if decimal == "." and separator != "," and decimal_commas(frame):
        # The first data line held whole numbers only (an axis at rest: 0;0): read again.
        frame = pd.read_csv(
            path,
            sep=separator,
            decimal=",",
            encoding="utf-8-sig" if encoding == "utf-8" else encoding,
            skiprows=[1] if units_row else None,
        )
    frame.columns = [str(c).removeprefix("\ufeff") for c in frame.columns]
    if not units_row:
        return frame, {}
    units = {str(c): u.strip() for c, u in zip(frame.columns, first, strict=False) if u.strip()}
    return frame, {UNITS_ROW_KEY: json.dumps(units)}


def _write_csv(frame: pd.DataFrame, metadata: Mapping[str, str], path: Path) -> None:
    frame.to_csv(path, index=False, float_format="%.17g")


@dataclass(frozen=True)
class NpzRecording:
    """The arrays of one ``.npz`` recording (:func:`read_npz`).

    Attributes
    ----------
    signals : ndarray of shape (n_channels, n_samples)
    channels : tuple of str
    fs : float
        Rate in Hz; NaN when the source does not state it.
    metadata : dict of str to str
        The ``meta`` JSON's fields, as strings.
    """

    signals: NDArray[np.generic]
    channels: tuple[str, ...]
    fs: float
    metadata: dict[str, str]


def _field(archive: np.lib.npyio.NpzFile, key: str, path: Path) -> NDArray[np.generic]:
    if key not in archive.files:
        raise CaptureError(
            f"{path}: missing array '{key}'; expected 'signals', 'channels' and 'fs' "
            f"(found {sorted(archive.files)})."
        )
    return np.asarray(archive[key])


def read_npz(path: str | Path) -> NpzRecording:
    """Read and check the arrays of one ``.npz`` recording.

    Raises
    ------
    CaptureError
        Naming the file: not a readable ``.npz``, a missing array, ``signals`` not 2-D with one
        row per channel name, a rate that is neither positive nor NaN, non-JSON ``meta``.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "r1.npz"
    >>> np.savez(path, signals=np.ones((2, 8)), channels=np.array(["a", "b"]), fs=2000.0)
    >>> recording = read_npz(path)
    >>> recording.channels, recording.fs, recording.signals.shape
    (('a', 'b'), 2000.0, (2, 8))
    """
    path = Path(path)
    try:
        archive = np.load(path, allow_pickle=False)
    except Exception as exc:  # numpy raises several types for a truncated or foreign file
        raise CaptureError(
            f"{path}: cannot read .npz recording (truncated or corrupt?): {exc}"
        ) from exc
    with archive:
        signals = _field(archive, "signals", path)
        channels = tuple(str(c) for c in np.atleast_1d(_field(archive, "channels", path)))
        fs_values = _field(archive, "fs", path)
        meta_raw = str(archive["meta"]) if "meta" in archive.files else "{}"
    if signals.ndim != 2 or signals.shape[0] != len(channels):
        raise CaptureError(
            f"{path}: 'signals' must have shape [n_channels, n_samples] with one row per name in "
            f"'channels' ({len(channels)}); got shape {signals.shape}."
        )
    fs = float(fs_values) if fs_values.size == 1 else math.inf
    if not ((math.isfinite(fs) and fs > 0) or math.isnan(fs)):
        raise CaptureError(
            f"{path}: 'fs' must be a positive number of Hz, or NaN when unknown; got {fs_values!r}."
        )
    try:
        meta = json.loads(meta_raw)
    except json.JSONDecodeError as exc:
        raise CaptureError(f"{path}: 'meta' must be a JSON object; {exc}.") from exc
    if not isinstance(meta, dict):
        raise CaptureError(f"{path}: 'meta' must be a JSON object; got {type(meta).__name__}.")
    return NpzRecording(signals, channels, fs, {str(k): str(v) for k, v in meta.items()})


def _read_npz_table(path: Path) -> tuple[pd.DataFrame, dict[str, str]]:
    recording = read_npz(path)
    stated = not math.isnan(recording.fs)
    rate = recording.fs if stated else NOMINAL_RATE_HZ
    columns = {"time": np.arange(recording.signals.shape[1]) / rate}
    columns.update({name: recording.signals[j] for j, name in enumerate(recording.channels)})
    return pd.DataFrame(columns), {**recording.metadata, "fs_stated": str(stated).lower()}


def _write_npz(frame: pd.DataFrame, metadata: Mapping[str, str], path: Path) -> None:
    channels = [str(c) for c in frame.columns if c != "time"]
    values = frame[channels].to_numpy(dtype=np.float64)
    slower = [
        name for name, gaps in zip(channels, np.isnan(values).any(axis=0), strict=True) if gaps
    ]
    if slower:
        raise CaptureError(
            f"{path}: a .npz capture holds every signal at one rate; signal(s) {slower} are "
            "sampled more slowly than the others (write .parquet or .csv instead)."
        )
    time_s = frame["time"].to_numpy(dtype=np.float64)
    fs = (time_s.size - 1) / (time_s[-1] - time_s[0]) if time_s.size > 1 else math.nan
    meta = json.dumps(dict(metadata))
    np.savez(path, signals=values.T, channels=np.array(channels), fs=np.float64(fs), meta=meta)


register_format(".parquet", read=_read_parquet, write=_write_parquet, description="Parquet")
register_format(".csv", read=_read_csv, write=_write_csv, description="CSV", read_text=_read_csv_as)
register_format(".npz", read=_read_npz_table, write=_write_npz, description="NumPy .npz")
