"""Recorded datasets: folders of ``.npz`` recordings cut into capture-sized segments.

A folder holds ``index.csv``, one ``.npz`` per recording and optionally ``days.csv``.
docs/internals.md, "Recorded datasets", gives the layout and the nominal 1 Hz rate.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from axiswatch._capture import Capture
from axiswatch._formats import NOMINAL_RATE_HZ, read_npz
from axiswatch.exceptions import CaptureError, DataNotFoundError

__all__ = ["NOMINAL_RATE_HZ", "Segment", "default_data_dir", "read_dataset", "read_recording"]

_DAYS_COLUMNS = ("day_id", "recording_id", "start", "stop", "condition_id", "health", "role")
_INDEX_COLUMNS = ("recording_id", "condition_id", "health")
_HEALTH = ("healthy", "faulty")


@dataclass(frozen=True)
class Segment:
    """One capture-sized piece of a recording, with its labels.

    Attributes
    ----------
    segment_id : str
        ``day_id`` of ``days.csv`` (the recording id when there is no ``days.csv``).
    recording_id, condition : str
    healthy : bool
    role : str
        Suggested role from ``days.csv`` (``baseline``, ``test_healthy_same_condition``, ...), or
        ``"recording"`` without one. Experiments may reassign roles for another baseline.
    start : int
        First sample of the segment in its recording.
    capture : Capture
    """

    segment_id: str
    recording_id: str
    condition: str
    healthy: bool
    role: str
    start: int
    capture: Capture


def default_data_dir(name: str, *, cwd: str | Path | None = None) -> Path:
    """Where dataset ``name`` lives by default: ``../shared/data/<name>`` from the project root.

    The project root is the current directory (or ``cwd``) or the nearest parent holding a
    ``pyproject.toml``; the first candidate folder that exists is returned, else the first one.

    Examples
    --------
    >>> import tempfile
    >>> default_data_dir("gearbox_spectraquest", cwd=tempfile.gettempdir()).parts[-3:]
    ('shared', 'data', 'gearbox_spectraquest')
    """
    here = Path(os.getcwd() if cwd is None else cwd).resolve()
    roots = [here, *[p for p in here.parents if (p / "pyproject.toml").is_file()][:1]]
    candidates = [root.parent / "shared" / "data" / name for root in roots]
    return next((c for c in candidates if c.is_dir()), candidates[0])


def read_recording(path: str | Path, *, nominal_rate_hz: float = NOMINAL_RATE_HZ) -> Capture:
    """Read one ``.npz`` recording into a :class:`Capture` (every channel at ``fs``).

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file.
    nominal_rate_hz : float, default=NOMINAL_RATE_HZ
        Rate used when ``fs`` is NaN (see the module docstring).

    Returns
    -------
    Capture
        ``metadata`` holds the ``meta`` JSON's fields (as strings) and ``fs_stated``
        (``"true"``/``"false"``).

    Raises
    ------
    DataNotFoundError
        The file does not exist.
    CaptureError
        Naming the file: not a readable ``.npz``, a missing array, ``signals`` not 2-D with one
        row per channel name, a rate that is neither positive nor NaN, non-JSON ``meta``.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "r1.npz"
    >>> np.savez(path, signals=np.ones((2, 8), np.float32), channels=np.array(["a", "b"]),
    ...          fs=np.float64("nan"), meta='{"recording_id": "r1"}')
    >>> cap = read_recording(path)
    >>> cap.names, cap.rates_hz["a"], cap.metadata["fs_stated"]
    (('a', 'b'), 1.0, 'false')
    """
    path = Path(path)
    if not path.is_file():
        raise DataNotFoundError(f"{path}: no such recording file (expected a .npz recording).")
    recording = read_npz(path)
    stated = not math.isnan(recording.fs)
    metadata = {**recording.metadata, "fs_stated": "true" if stated else "false"}
    rate = recording.fs if stated else float(nominal_rate_hz)
    return Capture(
        {name: recording.signals[j] for j, name in enumerate(recording.channels)},
        dict.fromkeys(recording.channels, rate),
        source=str(path),
        metadata=metadata,
    )


def _read_table(path: Path, required: Sequence[str]) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, dtype={"day_id": str, "recording_id": str})
    except Exception as exc:  # pandas raises many types for empty or broken CSV files
        raise CaptureError(f"{path}: cannot read CSV table: {exc}") from exc
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise CaptureError(
            f"{path}: missing column(s) {missing}; found columns {list(map(str, table.columns))}."
        )
    bad = table.loc[~table["health"].isin(_HEALTH), "health"]
    if len(bad):
        raise CaptureError(
            f"{path}: column 'health' must be 'healthy' or 'faulty'; found {bad.iloc[0]!r}."
        )
    return table


def read_dataset(
    folder: str | Path,
    *,
    recordings: Sequence[str] | None = None,
    nominal_rate_hz: float = NOMINAL_RATE_HZ,
) -> list[Segment]:
    """Read a dataset folder into labelled segments, cut as ``days.csv`` says.

    Parameters
    ----------
    folder : str or Path
        Folder with ``index.csv``, the ``.npz`` recordings and optionally ``days.csv``.
    recordings : sequence of str, optional
        Read only these recordings (default: every one in ``index.csv``).
    nominal_rate_hz : float, default=NOMINAL_RATE_HZ
        Rate of recordings whose ``fs`` is NaN.

    Returns
    -------
    list of Segment
        In the order of ``days.csv`` (or ``index.csv``).

    Raises
    ------
    DataNotFoundError
        The folder, its ``index.csv`` or a listed recording file is absent.
    CaptureError
        A table lacks a column, has an unknown health label, a segment lies outside its
        recording, or a recording file is malformed (see :func:`read_recording`).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> np.savez(folder / "h0.npz", signals=np.zeros((1, 40)), channels=np.array(["a1"]),
    ...          fs=np.float64(100.0))
    >>> _ = (folder / "index.csv").write_text("recording_id,condition_id,health\\nh0,load0,healthy\\n")
    >>> [(s.segment_id, s.condition, s.healthy, s.capture.duration_s("a1"))
    ...  for s in read_dataset(folder)]
    [('h0', 'load0', True, 0.4)]
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DataNotFoundError(
            f"{folder}: dataset folder not found; expected a folder with index.csv and .npz "
            "recordings (see the data README)."
        )
    index_path = folder / "index.csv"
    if not index_path.is_file():
        raise DataNotFoundError(
            f"{index_path}: missing; a dataset folder lists its recordings there."
        )
    index = _read_table(index_path, _INDEX_COLUMNS)
    days_path = folder / "days.csv"
    if days_path.is_file():
        days = _read_table(days_path, _DAYS_COLUMNS)
        unknown = sorted(set(days["recording_id"]) - set(index["recording_id"]))
        if unknown:
            raise CaptureError(
                f"{days_path}: recording(s) {unknown[:3]} are not listed in {index_path.name}."
            )
    else:
        days = index.assign(day_id=index["recording_id"], start=0, stop=-1, role="recording")
    wanted = set(index["recording_id"] if recordings is None else recordings)
    days = days[days["recording_id"].isin(wanted)]
    captures = {
        rid: read_recording(folder / f"{rid}.npz", nominal_rate_hz=nominal_rate_hz)
        for rid in dict.fromkeys(days["recording_id"])
    }
    segments = []
    for row in days.to_dict("records"):
        whole = captures[str(row["recording_id"])]
        n_samples = min(len(v) for v in whole.signals.values())
        try:
            start, stop = int(row["start"]), int(row["stop"])
        except (TypeError, ValueError) as exc:
            raise CaptureError(
                f"{days_path}: segment '{row['day_id']}' has start={row['start']!r}, "
                f"stop={row['stop']!r}; expected sample numbers (integers)."
            ) from exc
        stop = n_samples if stop < 0 else stop
        if not 0 <= start < stop <= n_samples:
            raise CaptureError(
                f"{days_path}: segment '{row['day_id']}' covers samples {start}..{stop} but recording "
                f"'{row['recording_id']}' has {n_samples}; expected 0 <= start < stop <= {n_samples}."
            )
        capture = Capture(
            {name: values[start:stop] for name, values in whole.signals.items()},
            whole.rates_hz,
            start_s=start / next(iter(whole.rates_hz.values())),
            source=f"{whole.source}[{start}:{stop}]",
            metadata={**whole.metadata, "segment_id": str(row["day_id"])},
        )
        segments.append(
            Segment(
                segment_id=str(row["day_id"]),
                recording_id=str(row["recording_id"]),
                condition=str(row["condition_id"]),
                healthy=bool(row["health"] == "healthy"),
                role=str(row["role"]),
                start=start,
                capture=capture,
            )
        )
    return segments
