"""Exceptions raised by axiswatch.

Every exception derives from :class:`AxiswatchError` and also from the matching built-in, so
callers can catch either ``axiswatch.AxiswatchError`` or, say, ``ValueError``.
"""

from __future__ import annotations

__all__ = [
    "AxiswatchError",
    "CalibrationError",
    "CaptureError",
    "DataNotFoundError",
    "ProfileError",
    "StoreError",
]


class AxiswatchError(Exception):
    """Base class of every error raised on purpose by axiswatch."""


class CaptureError(AxiswatchError, ValueError):
    """A capture (file or arrays) is malformed: missing column, NaN, wrong rate, too short, ..."""


class ProfileError(CaptureError):
    """An axis profile (TOML) is malformed: unknown key, wrong type, unknown unit or role.

    A :class:`CaptureError` too: the captures it describes cannot be read until it is fixed.
    """


class CalibrationError(AxiswatchError, ValueError):
    """Healthy distances cannot calibrate a threshold (too few, non-finite, negative)."""


class DataNotFoundError(AxiswatchError, FileNotFoundError):
    """A dataset folder, table or recording file that should exist does not."""


class StoreError(AxiswatchError, RuntimeError):
    """The monitoring store cannot be opened, is of another version, or is inconsistent."""
