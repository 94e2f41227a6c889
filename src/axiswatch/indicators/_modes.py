"""A capture's operating mode: declared by the user, else read from its motion and load.

A mode is what the axis runs (its program) and what it carries (its payload). The same motion
at another payload is another mode. See :class:`~axiswatch.indicators._mode_library.ModeLibrary`.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.signal import welch

from axiswatch._capture import Capture
from axiswatch._mode_declaration import ModeDeclaration
from axiswatch.exceptions import CaptureError
from axiswatch.indicators._readings import (
    MOVING_FRACTION,
    SIGNATURE_MOVING_QUANTILES,
    SIGNATURE_POSITION_QUANTILES,
    Motion,
    Readings,
    friction_design,
    motion,
    read_indicators,
    task_signature,
)

__all__ = [
    "PRIOR_MODE_TOLERANCE",
    "CaptureDescription",
    "declared_mode",
    "describe_capture",
    "load_level",
    "mode_differences",
    "mode_distance",
    "mode_tolerance",
    "torque_spectrum",
]

#: How far two captures' mode signatures may be and still be one mode, before the axis's own
#: modes give a tolerance (:func:`mode_tolerance`): a fifth of the top speed, of the stroke, of
#: the time moving or of the torque level. An engineering prior, not a measured figure.
PRIOR_MODE_TOLERANCE = 0.2
#: The tolerance in units of the largest leave-one-out signature distance within a mode, as the
#: task envelope of :class:`~axiswatch.IndicatorModel` (``TASK_ENVELOPE_FACTOR``).
TOLERANCE_FACTOR = 2.0
#: The least tolerance of a signature's reading (8 % of the top speed, the stroke, the time or
#: the torque range): a bearing or backlash fault moved the carried load by up to 5 %
#: on development robots, a payload of 5 kg on an arm by 11-36 %.
MIN_MODE_TOLERANCE = 0.08
#: Bands of the torque's log spectrum (:func:`torque_spectrum`), equal in width up to Nyquist.
SPECTRUM_BANDS = 32
#: Welch segment length (samples) of the torque spectrum, at most.
SPECTRUM_SEGMENT = 256
#: Readings of the motion signature (:func:`~axiswatch.indicators._readings.task_signature`).
_N_SPEED = 1 + len(SIGNATURE_MOVING_QUANTILES)
_N_MOTION = _N_SPEED + len(SIGNATURE_POSITION_QUANTILES) + 1
#: The signature's motion readings, ahead of the carried load.
MOTION_READINGS = _N_MOTION


def _column_value(capture: Capture, name: str) -> str:
    if name not in capture.signals:
        raise CaptureError(
            f"{capture.source}: the mode column {name!r} is missing; columns are "
            f"{list(capture.names)}."
        )
    values = np.asarray(capture.signals[name], dtype=np.float64)
    values = values[np.isfinite(values)]
    if not values.size:
        raise CaptureError(f"{capture.source}: the mode column {name!r} has no finite value.")
    uniques, counts = np.unique(values, return_counts=True)
    return f"{float(uniques[int(np.argmax(counts))]):g}"


def _metadata_value(capture: Capture, key: str) -> str:
    if key not in capture.metadata:
        raise CaptureError(
            f"{capture.source}: the mode's metadata key {key!r} is missing; keys are "
            f"{sorted(capture.metadata)}."
        )
    return str(capture.metadata[key])


def declared_mode(capture: Capture, declaration: ModeDeclaration) -> str:
    """The mode a capture declares, as ``program`` or ``program@payload``.

    Raises
    ------
    CaptureError
        When the declared column, key or pattern is not found in the capture.

    Examples
    --------
    >>> from axiswatch import Capture
    >>> c = Capture({"torque": [0.0, 1.0]}, {"torque": 10.0}, source="/d/prog7_5kg.csv")
    >>> declared_mode(c, ModeDeclaration(file_pattern=r"prog(?P<program>\\d+)_(?P<payload>\\w+)"))
    '7@5kg'
    """
    payload: str | None = None
    if declaration.column is not None:
        program = _column_value(capture, declaration.column)
    elif declaration.metadata is not None:
        program = _metadata_value(capture, declaration.metadata)
    else:
        pattern = declaration.file_pattern or ""
        found = re.search(pattern, PurePath(capture.source).name)
        if found is None:
            raise CaptureError(
                f"{capture.source}: the file name does not match the mode's file_pattern "
                f"{pattern!r}."
            )
        groups = found.groupdict()
        program = groups.get("program") or found.group(0)
        payload = groups.get("payload")
    if declaration.payload_column is not None:
        payload = _column_value(capture, declaration.payload_column)
    elif declaration.payload_metadata is not None:
        payload = _metadata_value(capture, declaration.payload_metadata)
    return program if payload is None else f"{program}@{payload}"


def load_level(m: Motion) -> NDArray[np.float64]:
    """What the axis carries, read so that friction hardly enters.

    A payload carried one way adds inertia and gravity to the moves of that direction only.
    The torque while moving is fitted by least squares to friction (``sign(v)``, ``v``), the
    inertia (the acceleration), gravity (a cubic in the position) and what the positive
    direction adds: inertia (``acc``) and gravity (``q``, ``q^2``). The carried load is the
    root mean square of the added inertia's torque over the positive moves. The added gravity
    is fitted but not read: a backlash fault moved it by up to a third of the torque's range
    on development robots, the added inertia by a fortieth. Friction, equal both ways, is
    left in its own columns. The mean torque over steady moves, and the median torque while
    dwelling, were tried first: both moved by a tenth to a fifth of the torque's range with the
    capture's phase. NaN when either direction has fewer than 10 moving samples.

    Examples
    --------
    >>> t = np.arange(0, 8, 0.01)
    >>> q = np.sin(np.pi * t)
    >>> v, a = np.pi * np.cos(np.pi * t), -np.pi**2 * q
    >>> carried = lambda kg: Motion(t, q, v, a, 2 * np.sign(v) + (1 + kg * (v > 0)) * a, 100.0)
    >>> [round(float(load_level(carried(kg))[0]), 1) for kg in (0.0, 1.0)]
    [0.0, 6.7]
    """
    speed = np.abs(m.speed)
    top = float(np.quantile(speed, 0.98)) if speed.size >= 2 else 0.0
    moving = speed > MOVING_FRACTION * top
    forward = m.speed[moving] > 0
    if not top > 0 or min(forward.sum(), (~forward).sum()) < 10:
        return np.full(1, np.nan)
    design, _ = friction_design(m, moving)
    q, acceleration = design[:, 4], design[:, 2]
    added = np.column_stack([acceleration, q, q**2]) * forward[:, None]
    full = np.column_stack([design, added])
    coefficients = np.linalg.lstsq(full, m.torque[moving], rcond=None)[0]
    carried = (acceleration * coefficients[design.shape[1]])[forward]
    return np.asarray([float(np.sqrt(np.mean(carried**2)))], dtype=np.float64)


def torque_spectrum(torque: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    """Log10 power of the torque in :data:`SPECTRUM_BANDS` equal bands up to Nyquist (Welch).

    Examples
    --------
    >>> t = np.arange(4000) / 1000.0
    >>> torque_spectrum(np.sin(2 * np.pi * 50 * t), 1000.0).shape
    (32,)
    """
    torque = np.asarray(torque, dtype=np.float64)
    segment = int(min(SPECTRUM_SEGMENT, max(16, torque.size // 4)))
    _, power = welch(torque - np.mean(torque), fs=rate_hz, nperseg=min(segment, torque.size))
    power = np.asarray(power[1:], dtype=np.float64)
    edges = np.linspace(0, power.size, SPECTRUM_BANDS + 1)
    bands = np.asarray(
        [np.mean(power[int(a) : max(int(a) + 1, int(b))]) for a, b in itertools.pairwise(edges)]
    )
    floor = max(float(np.max(bands)) * 1e-12, np.finfo(np.float64).tiny)
    return np.asarray(np.log10(np.maximum(bands, floor)), dtype=np.float64)


@dataclass(frozen=True)
class CaptureDescription:
    """What a mode library reads of one capture.

    Attributes
    ----------
    source : str
    signature : ndarray of shape (7,)
        The motion signature (:func:`~axiswatch.indicators._readings.task_signature`) and the carried load
        (:func:`load_level`).
    torque_scale : float
        The 98th percentile of ``|torque|``: the unit of the load level's differences.
    readings : Readings
        The physical indicators.
    spectrum : ndarray of shape (SPECTRUM_BANDS,)
    declared : str or None
        The declared mode, when the profile declares one.
    """

    source: str
    signature: NDArray[np.float64] = field(compare=False)
    torque_scale: float
    readings: Readings
    spectrum: NDArray[np.float64] = field(compare=False)
    declared: str | None = None

    @property
    def moving(self) -> bool:
        """Whether the axis moved (its signature was read)."""
        return bool(np.isfinite(self.signature[:_N_MOTION]).all())


def describe_capture(
    capture: Capture,
    declaration: ModeDeclaration | None = None,
    reading_options: Mapping[str, Any] | None = None,
    *,
    readings: Readings | None = None,
) -> CaptureDescription:
    """Read a capture's mode signature, physical indicators and torque spectrum.

    ``readings``: the capture's indicators when already read (``reading_options`` then unused).

    Raises
    ------
    CaptureError
        Without torque and motion signals, or when a declared mode is not found.
    """
    declared = declared_mode(capture, declaration) if declaration is not None else None
    m = motion(capture)
    signature = np.concatenate([task_signature(m), load_level(m)])
    scale = float(np.quantile(np.abs(m.torque), 0.98)) if m.torque.size else math.nan
    if readings is None:
        readings = read_indicators(capture, **dict(reading_options or {}))
    spectrum = torque_spectrum(m.torque, m.rate_hz)
    return CaptureDescription(capture.source, signature, scale, readings, spectrum, declared)


def mode_differences(
    signature: NDArray[np.float64], reference: NDArray[np.float64], torque_scale: float
) -> NDArray[np.float64]:
    """How far one mode signature is from another, per reading, as a share of the reference's
    scales: speeds of its top speed, the stroke's ends of its stroke, the share moving as it
    is, the carried load of ``torque_scale``. A load read in one and not the other is 1.

    Examples
    --------
    >>> ref = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5, 3.0])
    >>> mode_differences(ref + [0, 0, 0, 0, 0, 0, 1.0], ref, 10.0).round(3).tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.1]
    """
    top = float(reference[0])
    stroke = float(reference[_N_MOTION - 2] - reference[_N_SPEED])
    n = signature.size
    if not (np.isfinite(signature[:_N_MOTION]).all() and np.isfinite(reference[:_N_MOTION]).all()):
        return np.full(n, np.nan)
    if not (top > 0 and stroke > 0 and torque_scale > 0):
        return np.full(n, np.nan)
    difference = np.abs(signature - reference)
    scaled = [
        *(difference[:_N_SPEED] / top),
        *(difference[_N_SPEED : _N_MOTION - 1] / stroke),
        difference[_N_MOTION - 1],
    ]
    for k in range(_N_MOTION, n):
        read = (math.isfinite(signature[k]), math.isfinite(reference[k]))
        scaled.append(difference[k] / torque_scale if all(read) else 1.0 if any(read) else 0.0)
    return np.asarray(scaled, dtype=np.float64)


def mode_distance(differences: NDArray[np.float64], tolerances: NDArray[np.float64]) -> float:
    """The largest difference (:func:`mode_differences`) in units of its tolerance: at most 1
    is the same mode. NaN when the differences are not read.

    Examples
    --------
    >>> mode_distance(np.array([0.01, 0.3]), np.array([0.02, 0.25]))
    1.2
    """
    if not np.isfinite(differences).all():
        return math.nan
    return float(np.max(differences / tolerances))


def mode_tolerance(
    within_mode_differences: Sequence[NDArray[np.float64]], size: int
) -> NDArray[np.float64]:
    """How far each reading of a capture's signature may be from a mode's and still be that
    mode: :data:`TOLERANCE_FACTOR` x its largest leave-one-out difference within the axis's
    modes (``within_mode_differences``, pooled over its modes), at least
    :data:`MIN_MODE_TOLERANCE`; :data:`PRIOR_MODE_TOLERANCE` before 3 are known.

    Examples
    --------
    >>> mode_tolerance([np.array([0.01, 0.0])] * 3, 2).tolist(), mode_tolerance([], 2).tolist()
    ([0.08, 0.08], [0.2, 0.2])
    """
    finite = [d for d in within_mode_differences if np.isfinite(d).all()]
    if len(finite) < 3:
        return np.full(size, PRIOR_MODE_TOLERANCE)
    largest = np.max(np.stack(finite), axis=0)
    return np.asarray(np.maximum(TOLERANCE_FACTOR * largest, MIN_MODE_TOLERANCE), np.float64)
