"""Resampling of a capture's signals onto one common rate (paper, section "Pre-processing").

The paper upsamples 250 Hz position to 2 kHz with monotone cubic (PCHIP) interpolation.
:func:`upsample_pchip` takes any integer factor. :func:`resample_capture` stacks the signals.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from axiswatch._capture import Capture
from axiswatch.exceptions import CaptureError

__all__ = [
    "align_phase",
    "integer_factor",
    "phase_lag",
    "resample_capture",
    "upsample_pchip",
]

_RATE_RTOL = 1e-9


def integer_factor(source_rate_hz: float, target_rate_hz: float, *, name: str = "signal") -> int:
    """Upsampling factor ``target / source``; an error unless it is a positive integer.

    Examples
    --------
    >>> integer_factor(250.0, 2000.0)
    8
    """
    if not (source_rate_hz > 0 and target_rate_hz > 0):
        raise CaptureError(
            f"{name}: rates must be positive; got source {source_rate_hz!r} Hz and "
            f"target {target_rate_hz!r} Hz."
        )
    ratio = target_rate_hz / source_rate_hz
    factor = round(ratio)
    if factor < 1 or abs(ratio - factor) > _RATE_RTOL * ratio:
        raise CaptureError(
            f"{name}: rate {source_rate_hz:g} Hz does not divide the target rate "
            f"{target_rate_hz:g} Hz (ratio {ratio:.6g}); expected an integer ratio such as "
            "250 Hz -> 2000 Hz."
        )
    return int(factor)


def upsample_pchip(
    values: ArrayLike,
    factor: int,
    *,
    time_s: ArrayLike | None = None,
    name: str = "signal",
) -> NDArray[np.float64]:
    """Insert ``factor - 1`` points between each pair of samples, by PCHIP interpolation.

    Follows the paper's pre-processing (Fritsch & Carlson 1980 via
    :class:`scipy.interpolate.PchipInterpolator`): the interpolant is monotone wherever the
    samples are, and it passes through every original sample, which is copied unchanged to
    positions ``0, factor, 2 factor, ...`` of the output.

    Parameters
    ----------
    values : array-like of shape (n,)
        Samples, finite, ``n >= 2``.
    factor : int
        Upsampling factor (8 for 250 Hz -> 2 kHz).
    time_s : array-like of shape (n,), optional
        Sample instants, strictly increasing. Default: uniform. With non-uniform instants the new
        points are spread evenly inside each interval.
    name : str, default="signal"
        Used in error messages.

    Returns
    -------
    ndarray of shape ((n - 1) * factor + 1,)

    Examples
    --------
    >>> upsample_pchip([0.0, 1.0, 1.0], 4)
    array([0.       , 0.3671875, 0.6875   , 0.9140625, 1.       , 1.       ,
           1.       , 1.       , 1.       ])
    """
    samples = np.asarray(values, dtype=np.float64)
    if samples.ndim != 1 or samples.size < 2:
        raise CaptureError(
            f"{name}: expected a 1-D signal with at least 2 samples; got shape {samples.shape}."
        )
    bad = np.flatnonzero(~np.isfinite(samples))
    if bad.size:
        raise CaptureError(
            f"{name}: NaN or inf inside the signal at sample {bad[0]}; expected finite values."
        )
    if not (isinstance(factor, int | np.integer) and factor >= 1):
        raise CaptureError(f"{name}: factor must be a positive integer; got {factor!r}.")
    if time_s is None:
        knots = np.arange(samples.size, dtype=np.float64)
    else:
        knots = np.asarray(time_s, dtype=np.float64)
        if knots.shape != samples.shape:
            raise CaptureError(
                f"{name}: time has shape {knots.shape} but values have shape {samples.shape}."
            )
        steps = np.diff(knots)
        if not (np.isfinite(knots).all() and (steps > 0).all()):
            k = int(np.flatnonzero(~(steps > 0))[0]) if (steps <= 0).any() else 0
            raise CaptureError(
                f"{name}: time must be finite and strictly increasing; "
                f"t[{k + 1}]={float(knots[min(k + 1, knots.size - 1)])!r} follows "
                f"t[{k}]={float(knots[k])!r}."
            )
    if factor == 1:
        return samples.copy()
    fractions = np.arange(factor) / factor
    new_knots = (knots[:-1, None] + np.diff(knots)[:, None] * fractions).ravel()
    out = np.empty((samples.size - 1) * factor + 1)
    from scipy.interpolate import PchipInterpolator  # imported by the first resampling

    out[:-1] = PchipInterpolator(knots, samples)(new_knots)
    # Exactly the original samples at their own instants (the interpolant's value there can be
    # off by one rounding error).
    out[::factor] = samples
    return out


def resample_capture(
    capture: Capture,
    names: Sequence[str] | None = None,
    *,
    target_rate_hz: float | None = None,
) -> tuple[NDArray[np.float64], float]:
    """Bring every signal of ``capture`` to one rate and stack them column-wise.

    Slower signals are upsampled with :func:`upsample_pchip`; all are then cut to the shortest
    common length (the upsampled slow signal ends at its last real sample, up to
    ``factor - 1`` fast samples before the others).

    Parameters
    ----------
    capture : Capture
    names : sequence of str, optional
        Signals to use, in column order. Default: all, in the capture's order.
    target_rate_hz : float, optional
        Common rate. Default: the fastest signal's rate. Every rate must divide it.

    Returns
    -------
    signals : ndarray of shape (n_samples, n_channels)
    rate_hz : float

    Raises
    ------
    CaptureError
        A rate that does not divide the target, or signals whose durations differ by more than
        one sample period of the slowest signal.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> cap = Capture({"position": np.arange(250.0), "speed": np.ones(2000)},
    ...               {"position": 250.0, "speed": 2000.0})
    >>> signals, rate = resample_capture(cap)
    >>> signals.shape, rate
    ((1993, 2), 2000.0)
    """
    chosen = list(capture.names if names is None else names)
    capture = capture.select(chosen)
    rates = capture.rates_hz
    target = max(rates.values()) if target_rate_hz is None else float(target_rate_hz)
    durations = {name: capture.duration_s(name) for name in chosen}
    slowest_period = 1.0 / min(rates.values())
    spread = max(durations.values()) - min(durations.values())
    if spread > slowest_period * (1 + 1e-9):
        raise CaptureError(
            f"{capture.source}: signals have mismatched durations "
            f"({', '.join(f'{n}={d:.6g} s' for n, d in durations.items())}); expected equal "
            f"durations within one period of the slowest signal ({slowest_period:.6g} s)."
        )
    columns = []
    for name in chosen:
        factor = integer_factor(rates[name], target, name=f"{capture.source}: signal '{name}'")
        columns.append(
            upsample_pchip(capture.signals[name], factor, name=f"{capture.source}: signal '{name}'")
            if factor > 1
            else np.asarray(capture.signals[name])
        )
    n_samples = min(len(c) for c in columns)
    if n_samples < 1 or math.isnan(target):
        raise CaptureError(f"{capture.source}: no common samples after resampling.")
    return np.column_stack([c[:n_samples] for c in columns]), target


def phase_lag(reference: NDArray[np.float64], signals: NDArray[np.float64]) -> int:
    """Circular lag (in samples) that best aligns ``signals`` with ``reference``.

    Captures start at arbitrary phases of the robot's task cycle while the paper's distances pair
    row ``i`` of the baseline with row ``i`` of the test capture. The lag maximises the circular
    cross-correlation summed over channels, each channel standardised first so that no signal
    dominates by its unit. ``np.roll(signals, -lag, axis=0)`` is then aligned.

    Parameters
    ----------
    reference, signals : ndarray of shape (n_samples, n_channels)
        Same shape.

    Returns
    -------
    int in [0, n_samples)

    Examples
    --------
    >>> import numpy as np
    >>> x = np.random.default_rng(0).normal(size=(200, 2))
    >>> phase_lag(x, np.roll(x, 7, axis=0))
    7
    """
    ref = np.asarray(reference, dtype=np.float64)
    sig = np.asarray(signals, dtype=np.float64)
    if ref.shape != sig.shape or ref.ndim != 2:
        raise CaptureError(
            "reference and signals must have the same shape (n_samples, n_channels); got "
            f"{ref.shape} and {sig.shape}."
        )

    def standardise(a: NDArray[np.float64]) -> NDArray[np.float64]:
        centred = a - a.mean(axis=0)
        spread = centred.std(axis=0)
        return np.asarray(centred / np.where(spread > 0, spread, 1.0), dtype=np.float64)

    n = ref.shape[0]
    spectrum = np.conj(np.fft.rfft(standardise(ref), axis=0)) * np.fft.rfft(
        standardise(sig), axis=0
    )
    correlation = np.fft.irfft(spectrum, n=n, axis=0).sum(axis=1)
    return int(np.argmax(correlation))


def align_phase(
    reference: NDArray[np.float64], signals: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Circularly shift ``signals`` so that it lines up with ``reference`` (see :func:`phase_lag`).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.random.default_rng(0).normal(size=(200, 2))
    >>> bool(np.allclose(align_phase(x, np.roll(x, 7, axis=0)), x))
    True
    """
    return np.asarray(np.roll(signals, -phase_lag(reference, signals), axis=0), dtype=np.float64)
