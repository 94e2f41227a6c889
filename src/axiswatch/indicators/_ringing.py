"""Backlash as the drive's ringing after the gear crosses its gap.

The ``gap_ringing`` indicator: the residual's power near estimated crossings over its power
elsewhere. docs/internals.md, "Gap ringing", gives the two crossing estimates and the band.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from axiswatch._capture import rate_at_least
from axiswatch.indicators._signals import butter_sos, whole_samples, zero_phase

__all__ = [
    "CROSSING_HYSTERESIS",
    "CROSSING_SMOOTHING_HZ",
    "MIN_RINGING_RATE_HZ",
    "RINGING_BAND_HZ",
    "RINGING_WINDOW_S",
    "gap_crossings",
    "gap_ringing",
    "sign_passages",
]

#: Band of the drive-train resonance (Hz): the first (gear-stiffness) mode of robot axes lies
#: within it (10-20 Hz on the development robots, whose stiffness is drawn over a factor 4, i.e.
#: a factor 2 in frequency); the lower edge is above the rigid motion left in the fit's residual
#: (moves of 0.35 s and longer), the upper edge keeps the mesh ripple of fast logs out.
RINGING_BAND_HZ: tuple[float, float] = (5.0, 50.0)
#: Upper band edge at most this share of the rate (a margin under the Nyquist frequency).
NYQUIST_MARGIN = 0.45
#: Least torque rate (Hz): the band is then 5-9 Hz. A ringing above the Nyquist frequency
#: reaches it aliased when the logger keeps every n-th sample without an anti-alias filter (the
#: simulator's and many drives' trace buffers); behind an anti-alias filter it is lost, and the
#: reading is then that of a healthy axis, not an alarm.
MIN_RINGING_RATE_HZ = 20.0
#: Window around each estimated gap crossing (s before, s after): the estimate's uncertainty
#: before, a few periods of a 10-20 Hz ring decaying within 0.05-0.3 s after. Taken as the
#: nearest whole number of samples, both ends included.
RINGING_WINDOW_S: tuple[float, float] = (0.05, 0.3)
#: Low-pass of the commanded torque whose sign changes are the second crossing estimate (Hz),
#: as ``reversal_bursts``' smoothing (at most a quarter of the rate).
CROSSING_SMOOTHING_HZ = 10.0
#: Share of an estimate's largest magnitude it must pass through to count as a crossing.
CROSSING_HYSTERESIS = 0.1
#: 1 / Phi^-1(3/4): the median absolute value of Gaussian noise -> its standard deviation.
MAD_TO_SD = 1.4826
#: Least samples in the windows and away from them.
MIN_SAMPLES = 3


def torque_design(
    friction: NDArray[np.float64],
    speed: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    q: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The torque's design: friction (``sign(speed)`` or a saturated one), viscous friction,
    inertia, and gravity as a cubic in the scaled position ``q``.

    The cube as a product (NumPy's ``q**3`` calls ``pow()``, which cost as much as the solve);
    the columns in Fortran order, the layout LAPACK solves in. The friction reading and the
    gap-ringing fit share it: on the moving samples their designs are one.
    """
    square = q**2
    design = np.empty((q.size, 7), order="F")
    columns: tuple[NDArray[np.float64] | float, ...] = (
        friction,
        speed,
        acceleration,
        1.0,
        q,
        square,
        square * q,
    )
    for k, column in enumerate(columns):
        design[:, k] = column
    return design


def _fit(
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    torque: NDArray[np.float64],
    moving: NDArray[np.bool_],
    moving_speed: float,
    coefficients: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(whole fit, rigid part) of the torque on every sample, fitted on the moving ones.

    The friction column is ``sign(speed)`` saturated linearly below ``moving_speed``, so that the
    fit can be evaluated at rest (where ``sign`` would follow the speed's noise); on the moving
    samples it is ``sign(speed)``, as the friction reading's: the moving rows are its design,
    and its ``coefficients``, when given, are this fit's.
    """
    span = float(np.ptp(position[moving])) or 1.0
    q = (position - float(np.mean(position[moving]))) / span
    saturated = np.clip(speed / moving_speed, -1.0, 1.0)
    design = torque_design(saturated, speed, acceleration, q)
    if coefficients is None:
        coefficients, *_ = scipy.linalg.lstsq(design[moving], torque[moving])
    return design @ coefficients, design[:, 2:] @ coefficients[2:]


def sign_passages(x: NDArray[np.float64], hysteresis: float) -> NDArray[np.intp]:
    """Where ``x`` passes from below ``-h`` to above ``h`` or back, ``h = hysteresis x max |x|``.

    Parameters
    ----------
    x : ndarray of shape (n,)
    hysteresis : float
        0 counts every sign change.

    Returns
    -------
    ndarray of int
        For each passage the index ``i`` of its last sign change (between samples ``i`` and
        ``i + 1``).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([1.0, 0.05, -0.05, 0.05, -1.0, -1.0, 1.0])
    >>> sign_passages(x, 0.0).tolist(), sign_passages(x, 0.1).tolist()
    ([1, 2, 3, 5], [3, 5])
    """
    level = hysteresis * float(np.max(np.abs(x))) if x.size else 0.0
    side = np.where(x > level, 1, np.where(x < -level, -1, 0))
    outside = np.flatnonzero(side != 0)
    changes = np.flatnonzero(np.sign(x[1:]) * np.sign(x[:-1]) < 0)
    # Consecutive samples outside the band on opposite sides: x changed sign between them, and
    # the passage is at the last change before the second one.
    passing = side[outside[:-1]] != side[outside[1:]]
    after = outside[1:][passing]
    return np.asarray(changes[np.searchsorted(changes, after) - 1], dtype=np.intp)


def _filtered(sos: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    # The default pad (3 x the filter's order) exceeds a short capture at a slow rate.
    padlen = min(3 * (2 * sos.shape[0] + 1), x.size - 1)
    return zero_phase(sos, x, padlen)


def gap_crossings(
    rigid: NDArray[np.float64],
    torque: NDArray[np.float64],
    rate_hz: float,
    hysteresis: float = CROSSING_HYSTERESIS,
) -> NDArray[np.intp]:
    """Sample indices where the transmitted torque is estimated to change sign (sorted, unique).

    The union of the :func:`sign_passages` of the fit's rigid part and of the commanded torque
    low-passed at :data:`CROSSING_SMOOTHING_HZ` (at most a quarter of the rate).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 2, 0.01) + 0.005
    >>> gap_crossings(np.cos(np.pi * t), np.cos(np.pi * t), 100.0).tolist()  # t = 0.5, 1.5
    [49, 149]
    """
    commanded = _filtered(
        butter_sos(2, min(CROSSING_SMOOTHING_HZ, 0.25 * rate_hz), rate_hz), torque
    )
    return np.unique(
        np.concatenate([sign_passages(rigid, hysteresis), sign_passages(commanded, hysteresis)])
    )


def gap_ringing(
    time_s: NDArray[np.float64],
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    torque: NDArray[np.float64],
    rate_hz: float,
    *,
    moving_fraction: float = 0.1,
    hysteresis: float = CROSSING_HYSTERESIS,
    reference: Literal["away", "motion"] = "away",
    fit: NDArray[np.float64] | None = None,
) -> tuple[float, str | None]:
    """The drive's ringing after the estimated gap crossings over its level in the motion.

    Parameters
    ----------
    time_s, position, speed, acceleration, torque : ndarray of shape (n,)
        On the torque's instants (:func:`~axiswatch.indicators._readings.motion`), SI units or any
        consistent ones.
    rate_hz : float
    moving_fraction : float, default=0.1
        Share of the peak ``|speed|`` above which a sample counts as moving.
    hysteresis : float, default=CROSSING_HYSTERESIS
        Of the crossings (:func:`gap_crossings`).
    reference : {"away", "motion"}, default="away"
        The level the ringing is divided by: the residual's mean square over the moving samples
        outside every window, or the square of its robust level over all moving samples
        (``1.4826 x`` its median absolute value; the first candidate of lab/docs/decision-log.md).
    fit : ndarray of shape (7,), optional
        The torque fit's coefficients when already solved: the friction reading's
        (:func:`~axiswatch.indicators._readings.friction_design` with ``sign(speed)``, fitted on
        the same moving samples), which are this fit's. Default: solved here.

    Returns
    -------
    (float, str or None)
        The reading and None; or NaN and why it cannot be read.

    Examples
    --------
    >>> import numpy as np
    >>> rate = 500.0
    >>> t = np.arange(0, 4, 1 / rate)
    >>> q = np.sin(np.pi * t)
    >>> v, a = np.pi * np.cos(np.pi * t), -np.pi**2 * np.sin(np.pi * t)
    >>> noise = np.random.default_rng(0).normal(scale=0.01, size=t.size)
    >>> tau = 2.0 * a + 0.5 * np.sign(v) + noise  # the inertial torque turns at t = 1, 2, 3
    >>> ring = sum(np.where(t > c, 0.2 * np.exp(-(t - c) / 0.1) * np.sin(30 * np.pi * (t - c)), 0)
    ...            for c in (1.0, 2.0, 3.0))
    >>> quiet, _ = gap_ringing(t, q, v, a, tau, rate)
    >>> loud, _ = gap_ringing(t, q, v, a, tau + ring, rate)
    >>> bool(quiet < 3), bool(loud > 10 * quiet)
    (True, True)
    """
    if not rate_at_least(rate_hz, MIN_RINGING_RATE_HZ):
        return math.nan, f"needs a torque rate >= {MIN_RINGING_RATE_HZ:g} Hz (got {rate_hz:g} Hz)"
    peak = float(np.max(np.abs(speed))) if speed.size else 0.0
    moving = np.abs(speed) > moving_fraction * peak
    if peak <= 0 or int(moving.sum()) < 8:
        return math.nan, "needs motion"
    whole, rigid = _fit(position, speed, acceleration, torque, moving, moving_fraction * peak, fit)
    low, high = RINGING_BAND_HZ[0], min(RINGING_BAND_HZ[1], NYQUIST_MARGIN * rate_hz)
    residual = _filtered(butter_sos(4, (low, high), rate_hz), torque - whole)
    near = np.zeros(time_s.size, dtype=bool)
    # The window in whole samples (both ends included): compared as times, its ends fall on a
    # sample whenever the rate x the window is whole (100 Hz: 5 and 30 samples), and whether
    # that sample counted turned on the last bit of the rate (a capture's stamps written as
    # text or as Unix seconds moved the reading by 10-17 %).
    before, after = (whole_samples(seconds, rate_hz) for seconds in RINGING_WINDOW_S)
    for i in gap_crossings(rigid, torque, rate_hz, hysteresis).tolist():
        near[max(i - before, 0) : i + after + 1] = True
    near &= moving
    if int(near.sum()) < MIN_SAMPLES:
        return (
            math.nan,
            "needs gap crossings while moving (no sign change of the transmitted torque)",
        )
    if reference == "away":
        away = moving & ~near
        if int(away.sum()) < MIN_SAMPLES:
            return math.nan, "needs motion away from the gap crossings"
        power = float(np.mean(residual[away] ** 2))
    else:
        power = (MAD_TO_SD * float(np.median(np.abs(residual[moving])))) ** 2
    if not power > 0:
        return math.nan, "needs torque noise in the resonance band (the residual is flat)"
    return float(np.mean(residual[near] ** 2)) / power, None
