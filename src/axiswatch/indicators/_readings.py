"""Physical indicators of an axis that adapt to the capture: its rate, units and motion.

Friction, drive loads, impulsiveness, gap ringing and kinematic lines. Each declares what it
needs. A capture that cannot give one gets NaN and the reason. See docs/internals.md, "Readings".
The motion they read and the task signature live in :mod:`axiswatch.indicators._motion`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from axiswatch._capture import Capture, rate_at_least
from axiswatch._quantiles import quantiles
from axiswatch.indicators._motion import (
    MOVING_FRACTION,
    SIGNATURE_MOVING_QUANTILES,
    SIGNATURE_POSITION_QUANTILES,
    SIGNATURE_TOP_QUANTILE,
    Motion,
    motion,
    signature_distance,
    task_signature,
)
from axiswatch.indicators._order_lines import OrderProfile, order_profile, order_spectrum
from axiswatch.indicators._ringing import MIN_RINGING_RATE_HZ, gap_ringing, torque_design
from axiswatch.indicators._signals import (
    BEARING_OFFSETS,
    LINE_BLOCK_SAMPLES,
    NuisanceProjection,
    bearing_lines,
    bearing_orders,
    butter_sos,
    line_ratio,
    pearson_kurtosis,
    repair_lone_spikes,
    running_rms,
    whole_orders,
    zero_phase,
)
from axiswatch.indicators._wave_sums import Phasors, phasor_base

__all__ = [
    "FRICTION",
    "INDICATORS",
    "MOVING_FRACTION",
    "SIGNATURE_MOVING_QUANTILES",
    "SIGNATURE_POSITION_QUANTILES",
    "SIGNATURE_TOP_QUANTILE",
    "Indicator",
    "Motion",
    "Readings",
    "band_edges",
    "drive_loads",
    "friction_design",
    "least_squares_errors",
    "motion",
    "read_indicators",
    "signature_distance",
    "task_signature",
    "whole_move_mask",
]

#: Relative band of the impulsive indicators, in units of the torque's rate (a decade below a
#: margin under the Nyquist frequency).
BAND_FRACTION: tuple[float, float] = (0.04, 0.4)
#: Least torque rate for the band indicators (Hz): the band then starts at 4 Hz.
MIN_BAND_RATE_HZ = 100.0
#: Least motion of the band indicators (s): a kurtosis needs some 50 samples at 100 Hz.
MIN_BAND_MOTION_S = 0.5
#: Least travel of the kinematic lines (motor revolutions travelled while moving fast). The
#: order resolution (about 1 / revolutions) is set by the motor angle's *span*, which a
#: back-and-forth task keeps smaller than its travel: 7-9 revolutions of span for 26-30
#: travelled on development robots 3 and 7, so 0.11-0.14 order there, not 0.1 (open, see
#: lab/docs/decision-log.md, "Not done / open").
MIN_REVOLUTIONS = 10.0
#: The readings of the friction least squares, which carry a standard error (``whole_moves``).
FRICTION: tuple[str, ...] = ("coulomb_friction", "viscous_friction")
#: The kinematic lines' band edges are rounded to the nearest of a grid of this many cells per
#: decade: each band is then designed once per rate, cell pair and worker (``butter_sos``), not
#: once per capture. An edge moves by at most 2.4 %, well inside the band's margins (half the
#: lowest line's frequency, 1.5 times the highest); a line ratio moved by at most 0.011 decades
#: on simulated captures of six tasks (tested against the exact band in tests/naive.py).
BAND_EDGE_CELLS_PER_DECADE = 48


@dataclass(frozen=True)
class Indicator:
    """What an indicator is and what it needs.

    Attributes
    ----------
    name : str
    needs : str
        What a capture must give (shown when it is unavailable).
    sided : {"up", "both"}
        Whether only an increase is abnormal (impacts, lines) or a change either way (friction:
        more is wear, less is lost motion breaking the balance).
    component : str or None
        The part it watches, when it names one.
    log : bool
        Compared in decades (a positive ratio such as a kurtosis) rather than in its own unit
        (a friction coefficient, which may be negative).
    """

    name: str
    needs: str
    sided: Literal["up", "both"] = "up"
    component: str | None = None
    log: bool = False


#: The indicators read without kinematics, in order.
INDICATORS: tuple[Indicator, ...] = (
    Indicator("coulomb_friction", "motion in both directions", "both", "friction"),
    Indicator(
        "viscous_friction", "motion in both directions at more than one speed", "both", "friction"
    ),
    Indicator("load_forward", "steady motion in the positive direction", "both", "drive load"),
    Indicator("load_backward", "steady motion in the negative direction", "both", "drive load"),
    Indicator(
        "impulsiveness",
        f"a torque rate >= {MIN_BAND_RATE_HZ:g} Hz and {MIN_BAND_MOTION_S:g} s of motion",
        log=True,
    ),
    Indicator(
        "gap_ringing",
        f"a torque rate >= {MIN_RINGING_RATE_HZ:g} Hz and gap crossings (sign changes of the "
        "transmitted torque's estimates) while moving",
        component="gear backlash",
        log=True,
    ),
)


@dataclass(frozen=True)
class Readings:
    """The indicators of one capture.

    Attributes
    ----------
    values : dict of str to float
        NaN where unavailable.
    reasons : dict of str to str
        Why each unavailable indicator is unavailable.
    source : str
    signature : tuple of float
        The capture's :func:`task_signature` (empty when no motion could be read).
    order_profile : OrderProfile or None
        The torque's order spectrum on the common order grid
        (:func:`~axiswatch.indicators._order_lines.order_profile`), when read (``order_lines=True``) and
        the capture gives one; a model compares it with its baseline's (``order_lines``).
        Not part of ``==`` (an array has no single truth value).
    errors : dict of str to float
        Read with ``whole_moves=True``: the least-squares standard errors of
        ``coulomb_friction`` and ``viscous_friction`` (:data:`FRICTION`; NaN where the
        coefficient is not read). Empty otherwise.
    repaired : int
        Lone torque spikes (a logger's glitch) repaired before ``impulsiveness`` was read.
    """

    values: dict[str, float]
    reasons: dict[str, str] = field(default_factory=dict)
    source: str = "<memory>"
    signature: tuple[float, ...] = ()
    order_profile: OrderProfile | None = field(default=None, compare=False)
    errors: dict[str, float] = field(default_factory=dict)
    repaired: int = 0

    def available(self) -> list[str]:
        """Names of the indicators that were read."""
        return [name for name, value in self.values.items() if math.isfinite(value)]


def friction_design(m: Motion, moving: NDArray[np.bool_]) -> tuple[NDArray[np.float64], bool]:
    """The least-squares design of the friction readings over the ``moving`` samples.

    Columns ``sign(v)``, ``v``, the acceleration, 1 and a cubic in the position (centred, over
    its span: gravity and payload), fitted to the torque; and whether ``v`` is told apart from
    ``sign(v)``: the speeds are not all one (their spread above a tenth of their mean). Where
    they are not, the friction reading drops column 1 and reads no viscous coefficient.

    Examples
    --------
    >>> t = np.arange(0, 2, 0.01)
    >>> v = np.cos(np.pi * t)
    >>> m = Motion(t, np.sin(np.pi * t) / np.pi, v, -np.pi * np.sin(np.pi * t), v, 100.0)
    >>> design, separable = friction_design(m, np.abs(v) > 0.1)
    >>> design.shape, separable
    ((186, 7), True)
    """
    v = m.speed[moving]
    position = m.position[moving]
    span = float(np.ptp(position)) or 1.0
    q = (position - float(np.mean(position))) / span
    design = torque_design(np.sign(v), v, m.acceleration[moving], q)
    speeds = np.abs(v)
    return design, float(np.std(speeds)) > 0.1 * float(np.mean(speeds))


def least_squares_errors(
    design: NDArray[np.float64], target: NDArray[np.float64], coefficients: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Standard errors of least-squares coefficients: ``sqrt(diag(sigma^2 (X'X)^+))``.

    ``sigma^2`` is the residual sum of squares over ``n - p``. The pseudo-inverse lets a
    rank-deficient design (a cubic of a position that hardly moves) give the minimum-norm
    solve's errors instead of failing. The residuals of a torque are autocorrelated, so the
    errors understate a coefficient's spread in absolute terms; :class:`~axiswatch.IndicatorModel`
    uses only their ratio to its baseline's (the same regression on the same axis).

    Parameters
    ----------
    design : ndarray of shape (n, p)
    target : ndarray of shape (n,)
    coefficients : ndarray of shape (p,)
        The least-squares solve of ``design @ c = target``.

    Returns
    -------
    ndarray of shape (p,)
        All NaN when ``n <= p`` (no residual degree of freedom).

    Examples
    --------
    >>> x = np.column_stack([np.ones(4), np.arange(4.0)])
    >>> y = np.array([0.0, 1.0, 1.0, 3.0])
    >>> c = np.linalg.lstsq(x, y, rcond=None)[0]
    >>> least_squares_errors(x, y, c).round(4).tolist()  # sigma^2 = 0.7 / 2; slope's 0.35 / 5
    [0.495, 0.2646]
    """
    n, p = design.shape
    if n <= p:
        return np.full(p, np.nan)
    residual = target - design @ coefficients
    sigma2 = float(residual @ residual) / (n - p)
    covariance = sigma2 * np.linalg.pinv(design.T @ design)
    return np.sqrt(np.maximum(np.diag(covariance), 0.0))


def whole_move_mask(speed: NDArray[np.float64], moving_fraction: float) -> NDArray[np.bool_]:
    """The samples of the moves that start and end inside the capture.

    A move is a run of samples with ``|speed| > moving_fraction x max |speed|`` and one sign of
    the speed; it is whole when neither its first nor its last sample is an end of the capture.
    With ``whole_moves=True`` the drive loads are read on whole moves only: a move the capture
    cuts covers only part of its stroke, so its mean gravity torque depends on where the capture
    started.

    Parameters
    ----------
    speed : ndarray of shape (n,)
    moving_fraction : float in [0, 1)
        Share of the peak ``|speed|`` above which a sample moves (:data:`MOVING_FRACTION`).

    Returns
    -------
    ndarray of bool, shape (n,)

    Examples
    --------
    >>> v = np.array([2.0, 2.0, 0.0, -2.0, -2.0, 0.0, 2.0])
    >>> whole_move_mask(v, 0.1).astype(int).tolist()  # the first and last moves are cut
    [0, 0, 0, 1, 1, 0, 0]
    """
    if not speed.size:
        return np.zeros(0, dtype=bool)
    peak = float(np.max(np.abs(speed)))
    moving = np.abs(speed) > moving_fraction * peak
    label = np.where(moving, np.sign(speed), 0.0)
    cuts = np.flatnonzero(np.diff(label) != 0) + 1
    starts, stops = np.r_[0, cuts], np.r_[cuts, speed.size]
    # A run counts when it moves and touches neither end of the capture.
    keep = (label[starts] != 0) & (starts > 0) & (stops < speed.size)
    return np.asarray(np.repeat(keep, stops - starts), dtype=bool)


@dataclass(frozen=True)
class _FrictionFit:
    """The friction reading of a capture and its least-squares solve."""

    coulomb: float
    viscous: float
    why: str | None
    errors: dict[str, float]
    #: The seven coefficients of :func:`friction_design`'s every column; None when the viscous
    #: column was dropped. ``gap_ringing`` fits the same design on the same samples.
    coefficients: NDArray[np.float64] | None


def _friction(m: Motion, moving: NDArray[np.bool_], *, errors: bool) -> _FrictionFit:
    """Coulomb and viscous coefficients, why the viscous one is missing (or None), and, with
    ``errors``, their standard errors from the same design and solve (else empty)."""
    design, separable = friction_design(m, moving)
    if not separable:
        design = np.delete(design, 1, axis=1)
    torque = m.torque[moving]
    coefficients, *_ = scipy.linalg.lstsq(design, torque)
    se: dict[str, float] = {}
    if errors:
        each = least_squares_errors(design, torque, coefficients)
        se = {"coulomb_friction": float(each[0]), "viscous_friction": math.nan}
        if separable:
            se["viscous_friction"] = float(each[1])
    if not separable:
        return _FrictionFit(float(coefficients[0]), math.nan, "moves at one speed only", se, None)
    return _FrictionFit(float(coefficients[0]), float(coefficients[1]), None, se, coefficients)


def drive_loads(
    m: Motion, steady: NDArray[np.bool_], min_samples: int, *, whole_moves: bool
) -> tuple[dict[str, float], dict[str, str]]:
    """``load_forward`` and ``load_backward`` over the ``steady`` samples (NaN and the reason
    where a direction has fewer than ``min(min_samples, 3)``).

    Parameters
    ----------
    m : Motion
    steady : ndarray of bool, shape (n,)
        The samples to average (above half the peak speed; with ``whole_moves`` of whole moves
        only, :func:`whole_move_mask`).
    min_samples : int
        :func:`read_indicators`'s 0.2 s of samples (at least 5); a load needs
        ``min(min_samples, 3)``.
    whole_moves : bool
        Only words the reason ("needs a whole steady move" instead of "needs steady motion").

    Returns
    -------
    values : dict of str to float
        Both loads, NaN where not read.
    reasons : dict of str to str
        Why a load is not read.

    Examples
    --------
    >>> t = np.arange(0, 2, 0.01)
    >>> v = np.cos(np.pi * t)
    >>> m = Motion(t, np.sin(np.pi * t) / np.pi, v, -np.pi * np.sin(np.pi * t), 2 * v, 100.0)
    >>> values, reasons = drive_loads(m, v > 0.5, 20, whole_moves=False)
    >>> round(values["load_forward"], 2), reasons["load_backward"]
    (1.65, 'needs steady motion in the negative direction')
    """
    direction = np.sign(m.speed)
    values: dict[str, float] = {}
    reasons: dict[str, str] = {}
    for d, name, word in ((1.0, "load_forward", "positive"), (-1.0, "load_backward", "negative")):
        mine = steady & (direction == d)
        if mine.sum() >= min(min_samples, 3):
            values[name] = float(np.mean(m.torque[mine] * d))
        else:
            values[name] = math.nan
            reasons[name] = (
                f"needs a whole steady move in the {word} direction"
                if whole_moves
                else f"needs steady motion in the {word} direction"
            )
    return values, reasons


def _band(torque: NDArray[np.float64], rate_hz: float) -> NDArray[np.float64]:
    low, high = (f * rate_hz for f in BAND_FRACTION)
    return zero_phase(butter_sos(4, (low, high), rate_hz), torque)


def band_edges(low_hz: float, high_hz: float, top_hz: float) -> tuple[float, float]:
    """``(low_hz, high_hz)`` rounded to the nearest of :data:`BAND_EDGE_CELLS_PER_DECADE`
    cells per decade, the high edge at most ``top_hz``.

    Examples
    --------
    >>> [round(f, 3) for f in band_edges(3.0, 250.0, 900.0)]  # cells of 4.9 %
    [3.014, 248.79]
    >>> band_edges(3.0, 890.0, 900.0)[1]  # not above the Nyquist margin
    900.0
    """
    cells = BAND_EDGE_CELLS_PER_DECADE
    low, high = (10.0 ** (round(cells * math.log10(f)) / cells) for f in (low_hz, high_hz))
    return low, min(high, top_hz)


def read_indicators(
    capture: Capture,
    *,
    gear_ratio: float | None = None,
    gear_stages: Mapping[str, float] | None = None,
    bearing_orders: Mapping[str, float] | None = None,
    order_lines: bool = False,
    whole_moves: bool = False,
) -> Readings:
    """Read every indicator a capture can give; NaN and the reason for the others.

    Parameters
    ----------
    capture : Capture
        With ``torque`` and ``position`` or ``speed`` (any rates; position in rad or m).
    gear_ratio : float, optional
        Motor revolutions per revolution of the position; enables the kinematic lines.
    gear_stages : mapping of str to float, optional
        Name -> motor revolutions per revolution of a gear whose teeth are watched.
    bearing_orders : mapping of str to float, optional
        Name -> bearing defect frequency in orders of the motor speed.
    order_lines : bool, default=False
        Also read the torque's order spectrum (:attr:`Readings.order_profile`), or why it cannot
        be read (``reasons["order_lines"]``).
    whole_moves : bool, default=False
        Read the drive loads on whole moves only (:func:`whole_move_mask`) and keep the friction
        coefficients' standard errors (:attr:`Readings.errors`): the opt-in operating point of
        :class:`~axiswatch.IndicatorModel`'s ``whole_moves``. False reads as before.

    Returns
    -------
    Readings

    Raises
    ------
    CaptureError
        Only when the capture has no torque or no motion signal (:func:`motion`).

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(0, 4, 0.05)  # 20 Hz
    >>> q = np.sin(np.pi * t / 2)
    >>> v = np.gradient(q, 0.05)
    >>> cap = Capture({"position": q, "speed": v, "torque": 3 * np.sign(v) + 2 * v},
    ...               {"position": 20.0, "speed": 20.0, "torque": 20.0})
    >>> r = read_indicators(cap)
    >>> round(r.values["coulomb_friction"], 2), round(r.values["viscous_friction"], 2)
    (3.0, 2.0)
    >>> r.reasons["impulsiveness"]
    'needs a torque rate >= 100 Hz (got 20 Hz)'
    """
    m = motion(capture)
    signature = tuple(float(v) for v in task_signature(m))
    values = {ind.name: math.nan for ind in INDICATORS}
    reasons: dict[str, str] = {}
    kinematic: dict[str, float] = {}
    if gear_ratio is not None:
        kinematic.update({f"tooth_lines:{n}": r for n, r in (gear_stages or {}).items()})
        kinematic.update({f"bearing_lines:{n}": o for n, o in (bearing_orders or {}).items()})
        values.update(dict.fromkeys(kinematic, math.nan))
    speed = np.abs(m.speed)  # one pass, read four times below
    peak = float(np.max(speed)) if speed.size else 0.0
    moving = speed > MOVING_FRACTION * peak
    min_samples = max(5, round(0.2 * m.rate_hz))
    errors = dict.fromkeys(FRICTION, math.nan) if whole_moves else {}
    if peak <= 0 or moving.sum() < min_samples:
        still = "needs motion (the axis did not move)"
        span = float(m.time_s[-1] - m.time_s[0]) if m.time_s.size else 0.0
        if span < 0.2:
            # Shorter than the least motion read: seconds declared as milliseconds read so.
            still = (
                f"needs 0.2 s of motion, and the capture spans {span:.3g} s at "
                f"{m.rate_hz:.4g} Hz (if it is longer, check the time unit: the profile's "
                "[units] time)"
            )
        elif peak > 0:
            # It moved, but its top speed is a spike (a step in the position, such as two
            # records joined end to end): say so, or "did not move" misleads.
            still = (
                f"needs motion (the speed was above {MOVING_FRACTION * 100:.0f} % of its peak for "
                f"{moving.sum() / m.rate_hz:.2f} s, less than 0.2 s: a move too short, or a "
                "step in the position, such as two records joined end to end, that makes one "
                "high peak)"
            )
        for name in [*values, *(["order_lines"] if order_lines else [])]:
            reasons[name] = still
        return Readings(values, reasons, capture.source, signature, errors=errors)
    profile: OrderProfile | None = None
    if order_lines:
        spectrum = order_spectrum(m.position, m.speed, m.torque, m.rate_hz)
        if isinstance(spectrum, str):
            reasons["order_lines"] = spectrum
        else:
            profile = order_profile(spectrum)
    direction = np.sign(m.speed)
    both = [int(np.sum(moving & (direction == d))) >= min_samples for d in (1.0, -1.0)]
    fit: NDArray[np.float64] | None = None
    if all(both):
        friction = _friction(m, moving, errors=whole_moves)
        values["coulomb_friction"], values["viscous_friction"] = friction.coulomb, friction.viscous
        errors.update(friction.errors)
        fit = friction.coefficients
        if friction.why is not None:
            reasons["viscous_friction"] = f"needs moves at more than one speed ({friction.why})"
    else:
        for name in ("coulomb_friction", "viscous_friction"):
            reasons[name] = "needs motion in both directions (the capture moves one way)"
    steady = speed > 0.5 * peak
    if whole_moves:
        steady &= whole_move_mask(m.speed, MOVING_FRACTION)
    loads, why_not = drive_loads(m, steady, min_samples, whole_moves=whole_moves)
    values.update(loads)
    reasons.update(why_not)
    if kinematic:
        assert gear_ratio is not None
        _kinematic_lines(m, speed, gear_ratio, kinematic, peak, values, reasons)
    ringing, why = gap_ringing(
        m.time_s,
        m.position,
        m.speed,
        m.acceleration,
        m.torque,
        m.rate_hz,
        moving_fraction=MOVING_FRACTION,
        fit=fit,
    )
    values["gap_ringing"] = ringing
    if why is not None:
        reasons["gap_ringing"] = why
    seconds_moving = float(moving.sum()) / m.rate_hz
    fast_enough = rate_at_least(m.rate_hz, MIN_BAND_RATE_HZ)
    if not fast_enough or seconds_moving < MIN_BAND_MOTION_S:
        reasons["impulsiveness"] = (
            f"needs a torque rate >= {MIN_BAND_RATE_HZ:g} Hz (got {m.rate_hz:g} Hz)"
            if not fast_enough
            else f"needs {MIN_BAND_MOTION_S:g} s of motion (got {seconds_moving:.2g} s)"
        )
        return Readings(values, reasons, capture.source, signature, profile, errors)
    # A lone one-sample spike (a logger's glitch) would dominate the fourth moment on its own.
    torque = repair_lone_spikes(m.torque)
    repaired = 0 if torque is m.torque else int(np.count_nonzero(torque != m.torque))
    band = _band(torque, m.rate_hz)
    envelope = running_rms(band, max(8, round(0.1 * m.rate_hz)))
    normalised = band / np.where(envelope > 0, envelope, 1.0)
    values["impulsiveness"] = pearson_kurtosis(normalised[moving])
    return Readings(values, reasons, capture.source, signature, profile, errors, repaired)


def _sides_disagree(
    m: Motion, fast: NDArray[np.bool_], fast_speed: NDArray[np.float64], gear_ratio: float
) -> str | None:
    """Why the lines cannot be read when the position and the speed are on two sides of the gear.

    The position's travel over the ``fast`` samples is compared with the speed's integral there.
    A ratio nearer the gear ratio (or its inverse) than 1, in decades, means one of them is the
    motor's: the lines would be read at orders off by the gear ratio, or beyond the rate.
    ``fast_speed``: ``|m.speed[fast]|``.
    """
    position_travel = float(np.sum(np.abs(np.diff(m.position))[fast[1:]]))
    speed_travel = float(np.sum(fast_speed)) / m.rate_hz
    if not (position_travel > 0 and speed_travel > 0 and gear_ratio > 1):
        return None
    ratio = position_travel / speed_travel
    if abs(math.log(ratio)) <= 0.5 * math.log(gear_ratio):
        return None
    return (
        f"needs the position and the speed on one side of the gear (the position travels "
        f"{ratio:.3g} times what the speed says; the gear ratio is {gear_ratio:g}): declare the "
        "motor's in the axis profile's [sides], or ignore the speed"
    )


@lru_cache(maxsize=64)
def _tooth_orders(stage: float) -> tuple[float, ...]:
    """The orders of a gear stage's tooth lines, once per stage and process: the multiples of
    ``1 / stage`` up to 8 (lines of a once-per-gear-turn impact), but not the whole orders
    (mesh and ripple, whose presence is healthy).

    Examples
    --------
    >>> _tooth_orders(2.0)
    (0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5)
    """
    return tuple(
        k / stage for k in range(1, int(8 * stage) + 1) if abs(k / stage - round(k / stage)) > 1e-9
    )


def _seeded(angle: NDArray[np.float64], kinematic: Mapping[str, float]) -> Phasors:
    """The motor angle's phasors, seeded with the base of its lines' frequencies
    (:func:`phasor_base`: the whole orders, each tooth set's half step, a bearing's shift):
    one ``cis`` for all of them where they share one, each else its own."""
    shifts = [0.5 / p for n, p in kinematic.items() if n.startswith("tooth_lines:")]
    if any(name.startswith("bearing_lines:") for name in kinematic):
        shifts += [abs(d) for d in BEARING_OFFSETS]
    phasors = Phasors(angle)
    base = phasor_base((1.0, *shifts))
    if base is not None and angle.size <= LINE_BLOCK_SAMPLES:  # a longer one keeps none
        phasors(base)
    return phasors


def _kinematic_lines(
    m: Motion,
    speed: NDArray[np.float64],
    gear_ratio: float,
    kinematic: Mapping[str, float],
    peak: float,
    values: dict[str, float],
    reasons: dict[str, str],
) -> None:
    """Line ratios at each component's orders, in a band that holds those orders at the speeds
    of the capture (not the rate's band: a 4 kHz log of a slow axis has its lines far below it).
    ``speed``: ``|m.speed|``.
    """
    fast = speed > 0.2 * peak
    fast_speed = speed[fast]
    why = _sides_disagree(m, fast, fast_speed, gear_ratio)
    if why is not None:
        reasons.update(dict.fromkeys(kinematic, why))
        return
    motor_angle = gear_ratio * m.position
    theta = motor_angle[fast]
    shared: NuisanceProjection | None = None  # one projection for every line
    revs = gear_ratio * fast_speed / (2 * math.pi)
    slow_revs, fast_revs = quantiles(revs, (0.1, 0.9))
    travel = np.abs(np.diff(motor_angle, prepend=motor_angle[0]))
    revolutions = float(np.sum(travel[fast])) / (2 * math.pi)
    nyquist_margin = 0.45 * m.rate_hz
    for name, parameter in kinematic.items():
        if name.startswith("tooth_lines:"):
            orders = list(_tooth_orders(parameter))
        else:
            orders = bearing_orders(parameter)
        low = 0.5 * min(orders) * slow_revs
        high = min(nyquist_margin, 1.5 * max(orders) * fast_revs)
        if max(orders) * fast_revs >= nyquist_margin or revolutions < MIN_REVOLUTIONS or low <= 0:
            reasons[name] = (
                f"needs its order {max(orders):.3g} below {nyquist_margin:g} Hz at "
                f"{fast_revs:.3g} motor rev/s, and {MIN_REVOLUTIONS:g} motor revolutions "
                f"(got {revolutions:.3g})"
            )
            continue
        sos = butter_sos(4, band_edges(low, high, nyquist_margin), m.rate_hz)
        x = zero_phase(sos, m.torque)[fast]
        shared = shared or whole_orders(theta, _seeded(theta, kinematic))
        if name.startswith("tooth_lines:"):
            values[name] = line_ratio(x, theta, orders, [0.5 / parameter], nuisance=shared)
        else:
            values[name] = bearing_lines(x, theta, parameter, nuisance=shared)
