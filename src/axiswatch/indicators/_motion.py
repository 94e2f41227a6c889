"""A capture's motion on the torque's time base, and the task it runs.

:func:`motion` puts position, speed, acceleration and torque on the torque's instants.
:func:`task_signature` summarises the commanded motion; :func:`signature_distance` compares two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import PchipInterpolator
from scipy.signal import savgol_coeffs

from axiswatch._capture import Capture, speed_from_position
from axiswatch._quantiles import quantiles
from axiswatch.exceptions import CaptureError
from axiswatch.indicators._signals import whole_samples

__all__ = [
    "MOVING_FRACTION",
    "SIGNATURE_MOVING_QUANTILES",
    "SIGNATURE_POSITION_QUANTILES",
    "SIGNATURE_TOP_QUANTILE",
    "Motion",
    "motion",
    "signature_distance",
    "task_signature",
]
#: Share of the peak speed above which the axis counts as moving.
MOVING_FRACTION = 0.1
#: A task signature (:func:`task_signature`) holds the top speed (this quantile of ``|speed|``,
#: away from the extreme one noisy sample sets), these quantiles of ``|speed|`` while moving,
#: these of the position (the two ends of the stroke) and the share of time moving. Quantiles
#: that fall where the axis passes from moving to dwelling (the median ``|speed|``, the median
#: position) were left out: on the development robots they jumped by up to a third of the top
#: speed or of the stroke with the capture's phase.
SIGNATURE_TOP_QUANTILE = 0.98
SIGNATURE_MOVING_QUANTILES: tuple[float, ...] = (0.5, 0.9)
SIGNATURE_POSITION_QUANTILES: tuple[float, ...] = (0.02, 0.98)


@dataclass(frozen=True)
class Motion:
    """A capture's signals on the torque's time base, in SI units (rad or m, per s)."""

    time_s: NDArray[np.float64]
    position: NDArray[np.float64]
    speed: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    torque: NDArray[np.float64]
    rate_hz: float


def _on_times(
    values: NDArray[np.float64], rate: float, start: float, times: NDArray[np.float64]
) -> NDArray[np.float64]:
    own = start + np.arange(values.size) / rate
    if values.size < 2:
        return np.full(times.shape, float(values[0]))
    if own.size >= times.size and np.array_equal(own[: times.size], times):
        # Sampled on these instants already (a speed logged with the torque): PCHIP passes
        # through its knots, and cost a quarter of the motion's time.
        return np.asarray(values[: times.size], dtype=np.float64)
    return pchip(own, np.asarray(values, dtype=np.float64), times)


def _end_slope(
    h0: NDArray[np.float64],
    h1: NDArray[np.float64],
    m0: NDArray[np.float64],
    m1: NDArray[np.float64],
) -> NDArray[np.float64]:
    """SciPy's PCHIP slope at an end: a one-sided three-point estimate, kept monotone."""
    d = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
    flipped = np.sign(d) != np.sign(m0)
    overshot = (np.sign(m0) != np.sign(m1)) & (np.abs(d) > 3.0 * np.abs(m0))
    d[flipped] = 0.0
    d[~flipped & overshot] = 3.0 * m0[~flipped & overshot]
    return d


def pchip(
    knots: NDArray[np.float64], values: NDArray[np.float64], points: NDArray[np.float64]
) -> NDArray[np.float64]:
    """SciPy's ``PchipInterpolator(knots, values, extrapolate=True)(points)``, bit for bit
    (tested), without its input checks and array-namespace dispatch: a third of the motion's
    time on a 3 s capture. The same arithmetic in the same order: Fritsch-Carlson slopes (a
    weighted harmonic mean of the secants, zero where they change sign), the Hermite cubic's
    power-basis coefficients, and each point's polynomial summed lowest power first.

    Parameters
    ----------
    knots : ndarray of shape (m,)
        Strictly increasing; SciPy itself (and its error) where not, or ``m < 3``.
    values : ndarray of shape (m,)
        Finite.
    points : ndarray of shape (r,)

    Returns
    -------
    ndarray of shape (r,)

    Examples
    --------
    >>> knots = np.array([0.0, 1.0, 2.0, 3.0])
    >>> pchip(knots, np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.5, 1.5, 4.0])).tolist()
    [0.6875, 1.0, 3.0]
    """
    h = np.diff(knots)
    if knots.size < 3 or not bool(np.all(h > 0)):
        interpolator = PchipInterpolator(knots, values, extrapolate=True)
        return np.asarray(interpolator(points), dtype=np.float64)
    m = np.diff(values) / h
    slopes = np.zeros_like(values)
    inner = (np.sign(m[1:]) == np.sign(m[:-1])) & (m[1:] != 0) & (m[:-1] != 0)
    w1 = 2 * h[1:] + h[:-1]
    w2 = h[1:] + 2 * h[:-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = (w1 / m[:-1] + w2 / m[1:]) / (w1 + w2)
    slopes[1:-1][inner] = 1.0 / mean[inner]
    slopes[:1] = _end_slope(h[:1], h[1:2], m[:1], m[1:2])
    slopes[-1:] = _end_slope(h[-1:], h[-2:-1], m[-1:], m[-2:-1])
    # CubicHermiteSpline's coefficients, highest power first.
    t = (slopes[:-1] + slopes[1:] - 2 * m) / h
    c0, c1 = t / h, (m - slopes[:-1]) / h - t
    # PPoly's interval: knots[i] <= x < knots[i + 1], the first and last extended outwards.
    i = np.clip(np.searchsorted(knots, points, side="right") - 1, 0, knots.size - 2)
    s = points - knots[i]
    square = s * s
    out = values[:-1][i] + slopes[:-1][i] * s
    out += c1[i] * square
    out += c0[i] * (square * s)
    return out


@lru_cache(maxsize=64)
def _derivative_design(
    window: int, rate_hz: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """SciPy's Savitzky-Golay first derivative of a quadratic over ``window`` samples (mode
    ``interp``), designed once per window and rate: its taps, and the maps from the first and
    the last ``window`` samples to the derivative of the quadratic fitted to them there."""
    half = window // 2
    positions = np.arange(window, dtype=np.float64)
    fit = np.linalg.pinv(np.vander(positions, 3))  # the quadratic's coefficients, t^2 first
    slopes = [
        np.column_stack([2 * p, np.ones(half), np.zeros(half)]) @ fit * rate_hz
        for p in (positions[:half], positions[window - half :])
    ]
    taps = savgol_coeffs(window, 2, deriv=1, delta=1.0 / rate_hz)
    return np.asarray(taps, dtype=np.float64), slopes[0], slopes[1]


def _derivative(values: NDArray[np.float64], window: int, rate_hz: float) -> NDArray[np.float64]:
    """``savgol_filter(values, window, 2, deriv=1, delta=1 / rate_hz)``, equal to it to 1e-12
    of its largest value (tested), with the design kept (:func:`_derivative_design`) and the
    interior convolved by NumPy (a quarter of SciPy's ``convolve1d`` time at 101 taps)."""
    taps, first, last = _derivative_design(window, rate_hz)
    out = np.convolve(values, taps, mode="same")
    half = window // 2
    out[:half] = first @ values[:window]
    out[-half:] = last @ values[-window:]
    return out


def motion(capture: Capture) -> Motion:
    """Position, speed, acceleration and torque of a capture on the torque's instants.

    A missing speed is the derivative of the position; a missing position the integral of the
    speed. Slower signals are interpolated (PCHIP) onto the torque's instants, within their span.
    The acceleration is a Savitzky-Golay derivative of the speed over 50 ms (at least 5 samples).

    Raises
    ------
    CaptureError
        Without a ``torque`` signal, or with neither ``position`` nor ``speed``.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(200) / 100.0
    >>> m = motion(Capture({"position": np.sin(t), "torque": t}, {"position": 100.0,
    ...                                                           "torque": 100.0}))
    >>> round(float(m.speed[100]), 3)  # cos(1)
    0.54
    """
    names = set(capture.names)
    if "torque" not in names or not names & {"position", "speed"}:
        raise CaptureError(
            f"{capture.source}: the indicators need a 'torque' signal and a 'position' or "
            f"'speed' signal; the capture has {list(capture.names)} (map other column names "
            "with an AxisProfile)."
        )
    torque = np.asarray(capture.signals["torque"], dtype=np.float64)
    rate = capture.rates_hz["torque"]
    times = capture.start_s + np.arange(torque.size) / rate
    if "position" in names:
        position = _on_times(
            capture.signals["position"], capture.rates_hz["position"], capture.start_s, times
        )
    if "speed" in names:
        speed = _on_times(
            capture.signals["speed"], capture.rates_hz["speed"], capture.start_s, times
        )
    else:
        own_rate = capture.rates_hz["position"]
        derivative = speed_from_position(capture.signals["position"], own_rate)
        speed = _on_times(derivative, own_rate, capture.start_s, times)
    if "position" not in names:
        position = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / rate)])
    # Keep the instants every signal covers: interpolation beyond a slower signal's last sample
    # would invent motion.
    end = min(
        capture.start_s
        + capture.duration_s(n)
        - (1.0 / capture.rates_hz[n] if n != "torque" else 0)
        for n in names & {"position", "speed", "torque"}
    )
    # The instants are increasing: those kept are the first ones, taken as views.
    keep = slice(int(np.searchsorted(times, end + 1e-12, side="right")))
    window = max(5, whole_samples(0.05, rate) | 1)
    speed_kept = speed[keep]
    if speed_kept.size > window:
        acceleration = _derivative(speed_kept, window, rate)
    else:
        acceleration = np.gradient(speed_kept, 1.0 / rate) if speed_kept.size > 1 else speed_kept
    return Motion(times[keep], position[keep], speed_kept, acceleration, torque[keep], rate)


def task_signature(m: Motion) -> NDArray[np.float64]:
    """A phase-invariant signature of the commanded motion of a capture: what task it runs.

    A capture starts at a random phase of the task cycle, so the signature holds only what does
    not depend much on where the capture starts: the top speed (:data:`SIGNATURE_TOP_QUANTILE`
    of ``|speed|``), quantiles of ``|speed|`` while moving (above :data:`MOVING_FRACTION` of the
    top speed; :data:`SIGNATURE_MOVING_QUANTILES`), the ends of the stroke
    (:data:`SIGNATURE_POSITION_QUANTILES` of the position) and the share of time moving. It
    reads the motion only, never the torque: a fault changes the torque, hardly the commanded
    motion; a task change changes the motion.

    Parameters
    ----------
    m : Motion
        From :func:`motion` (SI units, any rate).

    Returns
    -------
    ndarray of shape (6,)
        Top speed and the moving speed quantiles (rad/s or m/s), the position quantiles (rad or
        m), the share moving; all NaN when the axis does not move.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(0, 4, 0.01)
    >>> def cap(phase):
    ...     q = np.sin(2 * np.pi * (t + phase))
    ...     return Capture({"position": q, "torque": q}, {"position": 100.0, "torque": 100.0})
    >>> a, b = task_signature(motion(cap(0.0))), task_signature(motion(cap(0.37)))
    >>> round(float(a[0]), 1), bool(signature_distance(b, a) < 0.02)  # top speed 2 pi
    (6.3, True)
    """
    speed = np.abs(m.speed)
    n = 1 + len(SIGNATURE_MOVING_QUANTILES) + len(SIGNATURE_POSITION_QUANTILES) + 1
    top = quantiles(speed, (SIGNATURE_TOP_QUANTILE,))[0] if speed.size >= 2 else 0.0
    if not top > 0:
        return np.full(n, np.nan)
    moving = speed > MOVING_FRACTION * top
    speeds = quantiles(speed[moving], SIGNATURE_MOVING_QUANTILES)
    positions = quantiles(m.position, SIGNATURE_POSITION_QUANTILES)
    share = float(np.mean(moving))
    return np.asarray([top, *speeds, *positions, share], dtype=np.float64)


def signature_distance(signature: NDArray[np.float64], reference: NDArray[np.float64]) -> float:
    """How far a :func:`task_signature` is from a reference one, as a share of the reference.

    Speeds are compared in units of the reference's top speed, the ends of the stroke in units
    of its stroke, the share moving as it is; the distance is the largest difference (0.1: a
    tenth of the top speed, of the stroke, or of the time). Free of the axis's units and scale.

    Parameters
    ----------
    signature, reference : ndarray of shape (6,)

    Returns
    -------
    float
        NaN when either is not finite or the reference has no speed or no stroke.

    Examples
    --------
    >>> import numpy as np
    >>> reference = np.array([2.0, 1.0, 1.8, -1.0, 1.0, 0.5])
    >>> round(signature_distance(reference * [1.1, 1, 1, 1, 1, 1], reference), 3)  # top +10 %
    0.1
    """
    n_speed = 1 + len(SIGNATURE_MOVING_QUANTILES)
    n_position = len(SIGNATURE_POSITION_QUANTILES)
    top_speed = float(reference[0])
    stroke = float(reference[n_speed + n_position - 1] - reference[n_speed])
    if not (np.isfinite(signature).all() and np.isfinite(reference).all()):
        return math.nan
    if not (top_speed > 0 and stroke > 0):
        return math.nan
    difference = np.abs(np.asarray(signature, dtype=np.float64) - reference)
    scaled = np.concatenate(
        [
            difference[:n_speed] / top_speed,
            difference[n_speed : n_speed + n_position] / stroke,
            difference[n_speed + n_position :],
        ]
    )
    return float(np.max(scaled))
