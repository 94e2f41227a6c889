"""Zero-phase Butterworth filters of the indicators, designed once per rate and process."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.signal import butter, sosfilt_zi
from scipy.signal._sosfilt import _sosfilt

__all__ = ["butter_sos", "zero_phase"]


@lru_cache(maxsize=1024)
def butter_sos(
    order: int, cutoff_hz: float | tuple[float, float], rate_hz: float
) -> NDArray[np.float64]:
    """Butterworth low-pass (one cutoff) or band-pass (two) sections, designed once per
    parameters and process (a design costs about as much as filtering a 3 s capture; every
    capture of a fleet uses the same few). Shared by the callers, which must not modify it
    (SciPy's filters need a writeable array, so it cannot be marked read-only).

    Examples
    --------
    >>> butter_sos(2, 10.0, 1000.0).shape
    (1, 6)
    >>> butter_sos(2, 10.0, 1000.0) is butter_sos(2, 10.0, 1000.0)
    True
    """
    btype = "bandpass" if isinstance(cutoff_hz, tuple) else "lowpass"
    return np.asarray(butter(order, cutoff_hz, btype=btype, fs=rate_hz, output="sos"))


@lru_cache(maxsize=1024)
def _initial_state(sections: bytes, count: int) -> tuple[NDArray[np.float64], int]:
    """``sosfilt_zi`` of the sections whose bytes are ``sections`` (``count`` rows), and
    ``sosfiltfilt``'s default pad length for them, once."""
    sos = np.frombuffer(sections).reshape(count, 6)
    taps = 2 * count + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    return np.asarray(sosfilt_zi(sos)), 3 * taps


def zero_phase(
    sos: NDArray[np.float64], x: NDArray[np.float64], padlen: int | None = None
) -> NDArray[np.float64]:
    """``scipy.signal.sosfiltfilt(sos, x, padlen=padlen)`` of a 1-D ``x``, the filter's initial
    state computed once per filter (:func:`butter_sos`'s designs are few; solving for the state
    cost as much as the filtering of a 3 s capture). Bit-identical to SciPy's (tested).

    Examples
    --------
    >>> from scipy.signal import sosfiltfilt
    >>> x = np.sin(np.arange(200) / 5.0)
    >>> sos = butter_sos(2, 10.0, 1000.0)
    >>> bool(np.array_equal(zero_phase(sos, x), sosfiltfilt(sos, x)))
    True
    """
    sections = np.ascontiguousarray(sos, dtype=np.float64)
    zi, default = _initial_state(sections.tobytes(), sos.shape[0])
    padlen = default if padlen is None else padlen
    if x.size <= padlen:
        raise ValueError(f"The length of the input vector x must be greater than padlen, {padlen}.")
    # SciPy's odd extension (odd_ext), written in the array that is filtered in place.
    y = np.empty((1, x.size + 2 * padlen))
    y[0, padlen : padlen + x.size] = x
    if padlen > 0:
        np.subtract(2 * x[0], x[padlen:0:-1], out=y[0, :padlen])
        np.subtract(2 * x[-1], x[-2 : -(padlen + 2) : -1], out=y[0, padlen + x.size :])
    # SciPy's sosfilt of a 1-D signal, without its checks and axis moves (ten calls a capture).
    _sosfilt(sections, y, np.ascontiguousarray(zi * y[0, 0])[None])
    y = np.array(y[:, ::-1], order="C")
    _sosfilt(sections, y, np.ascontiguousarray(zi * y[0, 0])[None])
    y = y[0, ::-1]
    return np.asarray(y[padlen:-padlen] if padlen > 0 else y, dtype=np.float64)
