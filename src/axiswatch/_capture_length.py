"""How many rows a capture file holds, read before the file is loaded.

A capture is held in memory whole while it is read and scored. A file of hours (a whole
shift's log exported as one capture) would take gigabytes, so the monitor refuses a file longer
than its limit from the file's own header: a Parquet footer, a count of a CSV's lines, a
``.npz`` array's header.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from axiswatch.exceptions import CaptureError

__all__ = ["MAX_CAPTURE_ROWS", "capture_rows", "check_capture_length"]

#: Rows a capture file may hold for the monitor (``--max-capture-rows``): 16.7 minutes at 2 kHz,
#: 28 hours at 20 Hz. The default method holds about 0.5 KB a row, so a capture at the limit
#: stays well under 2 GB of memory (``benchmarks/run.py --memory``).
MAX_CAPTURE_ROWS = 2_000_000

#: Bytes read at a time when counting a CSV file's lines.
_BLOCK_BYTES = 1 << 22


def _csv_rows(path: Path) -> int:
    """Lines after the header (a units row included: the limit is far from one row)."""
    lines, last = 0, b"\n"
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(_BLOCK_BYTES), b""):
            lines += block.count(b"\n")
            last = block[-1:]
    if last != b"\n":
        lines += 1  # a last row without a line break
    return max(lines - 1, 0)


def _npz_rows(path: Path) -> int | None:
    """Columns of the ``signals`` array, from its header inside the archive."""
    with zipfile.ZipFile(path) as archive:
        if "signals.npy" not in archive.namelist():
            return None
        with archive.open("signals.npy") as member:
            version = np.lib.format.read_magic(member)
            read_header = (
                np.lib.format.read_array_header_1_0
                if version == (1, 0)
                else np.lib.format.read_array_header_2_0
            )
            shape, _, _ = read_header(member)
    return int(shape[-1]) if shape else None


def capture_rows(path: str | Path) -> int | None:
    """Rows of a capture file, read without loading it (None for a format it cannot tell).

    Parameters
    ----------
    path : str or Path
        A ``.parquet``, ``.csv`` or ``.npz`` capture.

    Returns
    -------
    int or None
        Rows of the table (a CSV's lines after its header); None for another format, or a
        file whose header cannot be read (the reader then says why).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "c.csv"
    >>> _ = path.write_text("time,torque\\n0,1\\n0.5,2\\n1,3\\n")
    >>> capture_rows(path)
    3
    """
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".parquet":
            import pyarrow.parquet as pq

            return int(pq.ParquetFile(path).metadata.num_rows)
        if suffix == ".csv":
            return _csv_rows(path)
        if suffix == ".npz":
            return _npz_rows(path)
    except (OSError, ValueError, zipfile.BadZipFile):
        return None  # not this format, or cut short: the reader gives the one-line reason
    return None


def check_capture_length(path: str | Path, max_rows: int, shown: str | None = None) -> None:
    """Refuse a capture file of more than ``max_rows`` rows before it is loaded.

    Parameters
    ----------
    path : str or Path
    max_rows : int
        The limit (:data:`MAX_CAPTURE_ROWS` by default in the monitor).
    shown : str, optional
        The file's name in the message (default: ``path``).

    Raises
    ------
    CaptureError
        One line naming the file, its rows and the limit, and how to go on.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "c.csv"
    >>> _ = path.write_text("time,torque\\n0,1\\n0.5,2\\n1,3\\n")
    >>> check_capture_length(path, 2, "r1/a1/c.csv")
    Traceback (most recent call last):
    ...
    axiswatch.exceptions.CaptureError: r1/a1/c.csv: 3 rows, more than the 2 rows a capture ...
    """
    rows = capture_rows(path)
    if rows is None or rows <= max_rows:
        return
    seconds = max_rows / 2000.0
    at_2khz = f"{seconds:.3g} s" if seconds < 120 else f"{seconds / 60:.3g} min"
    raise CaptureError(
        f"{shown or path}: {rows:,} rows, more than the {max_rows:,} rows a capture may hold "
        f"({at_2khz} at 2 kHz; --max-capture-rows); split it into "
        "captures of the baseline's length, or raise the limit and retry it "
        "(axiswatch rejections --retry)."
    )
