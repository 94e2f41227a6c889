"""The former product default ``mechanics``: five physical indicators, in simulator scales.

A capture becomes a ``(2, 6)`` matrix (rows: the two directions of motion; columns
:data:`COLUMNS`): ``log10`` of the viscous friction (from energy integrals of nested windows of
each move), the impulsiveness of the torque's 40-300 Hz band, its bursts at torque reversals and
its angle-locked tooth and bearing lines, each in the spread it shows across healthy tasks of
the simulator's development design. The monitor runs it as ``--method mechanics``
(:func:`register`, declared under the ``axiswatch.methods`` entry point). Its derivation and
results are in the lab's decision log.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.signal import sosfiltfilt

from axiswatch import (
    Capture,
    Features,
    FeatureSpec,
    FeatureStage,
    HealthModel,
    IndicatorDetector,
    half_laplace_threshold,
    resample_capture,
)
from axiswatch.exceptions import CaptureError
from axiswatch_lab._product import (
    BEARING_OFFSETS,
    WHOLE_ORDERS,
    _NuisanceFree,
    bearing_orders,
    butter_sos,
    pearson_kurtosis,
    running_rms,
    whole_samples,
)

if TYPE_CHECKING:
    from axiswatch.monitor import MonitorConfig

__all__ = [
    "COLUMNS",
    "ENERGY_LEVELS",
    "INDICATORS",
    "MECHANICS_SCALES",
    "MECHANICS_TASK_CHANGE_SCALE",
    "MechanicsStage",
    "explain_indicators",
    "mechanics_model",
    "moves",
    "register",
    "reversal_bursts",
    "viscous_friction",
]

#: The indicators, in the order of :meth:`MechanicsStage.indicators` and of ``MECHANICS_SCALES``.
INDICATORS: tuple[str, ...] = (
    "viscous_friction",
    "impulsiveness",
    "reversal_bursts",
    "tooth_lines",
    "bearing_lines",
)

#: Columns of :class:`MechanicsStage`'s features, in order.
COLUMNS: tuple[str, ...] = (
    "viscous_friction",
    "viscous_friction_deficit",
    "impulsiveness",
    "reversal_bursts",
    "tooth_lines",
    "bearing_lines",
)

#: Speed levels (fractions of a move's peak) of the nested energy windows.
ENERGY_LEVELS: tuple[float, ...] = (0.02, 0.15, 0.3, 0.45, 0.6, 0.75)

#: Spread (root mean square of the shift from the baseline, in decades) of each indicator over
#: healthy captures of tasks other than the baseline's, measured by
#: :func:`axiswatch_lab.development_scales` on the development design (tasks and seeds never used in
#: any reported result). Recomputed and checked by lab/tests/test_paired.py.
MECHANICS_SCALES: tuple[float, ...] = (0.0600, 0.0740, 0.219, 0.0996, 0.181)

#: Half-Laplace scale (mean) of the :class:`~axiswatch.IndicatorDetector` distance between
#: healthy captures of different tasks, measured by :func:`axiswatch_lab.development_task_change_scale`
#: on the development design: what a healthy task change does to this method's distance,
#: which calibration captures of the baseline's own task cannot show. Checked by tests.
MECHANICS_TASK_CHANGE_SCALE: float = 2.81


def moves(
    speed: NDArray[np.float64], fraction: float = 0.02, min_gap: int = 40
) -> list[tuple[int, int]]:
    """Stretches of motion: ``[start, stop)`` index pairs where ``|speed|`` exceeds a fraction of
    the capture's peak.

    Stretches in one direction separated by fewer than ``min_gap`` samples (sensor noise around
    the threshold) are one move; a stretch shorter than ``min_gap`` on its own is dropped.

    Examples
    --------
    >>> import numpy as np
    >>> moves(np.array([0.0, 0.5, 1.0, 0.5, 0.0, -1.0, -1.0, 0.0]), min_gap=2)
    [(1, 4), (5, 7)]
    """
    v = np.asarray(speed, dtype=np.float64)
    moving = np.abs(v) > fraction * (float(np.max(np.abs(v))) if v.size else 0.0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(np.int8), [0]])))
    merged: list[list[int]] = []
    for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        if merged and a - merged[-1][1] < min_gap and np.sign(v[a]) == np.sign(v[merged[-1][0]]):
            merged[-1][1] = b
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged if b - a >= min_gap]


def viscous_friction(
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    torque: NDArray[np.float64],
    rate_hz: float,
    *,
    levels: Sequence[float] = ENERGY_LEVELS,
    direction: float | None = None,
) -> float:
    """Viscous friction coefficient from the energy balance of whole moves.

    For every move (from rest to rest; a move cut by the capture's edge keeps the levels above
    its speed at the cut, if its peak is inside) and every level ``x`` of ``levels``, the window
    runs from the first to the last sample whose ``|speed|``
    exceeds ``x`` times the move's peak, so speed, hence kinetic energy, is the same at both ends.
    The motor's work over the window is ``c_move * |dq| + F_v * integral(speed^2 dt)``; ``c_move``
    is free per move (Coulomb friction, gravity and payload), ``F_v`` is shared and returned.
    Gravity thus enters as its mean torque over the move; its variation along a long move is not
    modelled and biases ``F_v`` somewhat (lab/docs/decision-log.md).

    Parameters
    ----------
    position, speed, torque : ndarray of shape (n_samples,)
        On one time base (rad, rad/s, N m, or any consistent units).
    rate_hz : float
    levels : sequence of float in [0, 1), default=ENERGY_LEVELS
    direction : {1.0, -1.0}, optional
        Only moves in that direction; both when None.

    Returns
    -------
    float
        ``F_v`` (torque per speed), NaN when the capture holds no usable move.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 4, 1e-3)
    >>> ramp = lambda t0: 0.5 * (1 - np.cos(np.pi * np.clip(t - t0, 0, 1)))
    >>> q = ramp(0.5) - ramp(2.5)  # out and back, at rest in between
    >>> v, a = np.gradient(q, 1e-3), np.gradient(np.gradient(q, 1e-3), 1e-3)
    >>> tau = 2.0 * a + 3.0 * v + 7.0 * np.sign(v) + 5.0  # inertia, viscous 3, Coulomb, load
    >>> round(viscous_friction(q, v, tau, 1000.0), 2)
    3.0
    """
    dt = 1.0 / rate_hz
    per_move: list[list[float]] = []
    shared: list[float] = []
    work: list[float] = []
    for start, stop in moves(speed):
        magnitude = np.abs(speed[start:stop])
        middle = int(np.argmax(magnitude))
        if direction is not None and np.sign(speed[start + middle]) != direction:
            continue
        if middle in (0, magnitude.size - 1):
            continue  # cut by the capture's edge before or after its peak: the peak is unknown
        # A move cut by the capture's edge keeps the windows whose both ends lie inside it: the
        # levels above its speed at the cut.
        edge = max(
            float(magnitude[0]) if start == 0 else 0.0,
            float(magnitude[-1]) if stop >= speed.size else 0.0,
        )
        usable = [level for level in levels if level * magnitude[middle] > edge]
        if len(usable) < 2:
            continue
        distances = []
        for level in usable:
            above = np.flatnonzero(magnitude > level * magnitude[middle])
            i, j = start + int(above[0]), start + int(above[-1])
            distances.append(abs(float(position[j] - position[i])))
            shared.append(float(np.trapezoid(speed[i : j + 1] ** 2, dx=dt)))
            work.append(float(np.trapezoid(torque[i : j + 1] * speed[i : j + 1], dx=dt)))
        per_move.append(distances)
    if not per_move:
        return float("nan")
    design = np.zeros((len(work), len(per_move) + 1))
    row = 0
    for m, distances in enumerate(per_move):
        design[row : row + len(distances), m] = distances
        row += len(distances)
    design[:, -1] = shared
    coefficients, *_ = scipy.linalg.lstsq(design, np.asarray(work))
    return float(coefficients[-1])


def reversal_bursts(
    torque: NDArray[np.float64],
    band: NDArray[np.float64],
    rate_hz: float,
    where: NDArray[np.bool_],
    *,
    smoothing_hz: float = 10.0,
    window_s: float = 0.02,
) -> float:
    """Mean burst of ``band`` where the torque reverses, over the root of how fast it turns.

    Backlash is crossed when the torque transmitted by the gearbox changes sign: the motor runs
    free through the gap and strikes the other flank. At every sign change of the torque
    low-passed at ``smoothing_hz`` (samples in ``where`` only), the burst is the largest
    ``|band|`` within ``window_s``; the faster the torque turns (``|d torque / dt|``), the faster
    the gap is crossed and the harder it is struck, so each burst is divided by the square root
    of that rate (the exponent chosen on the development design among 0, 1/2 and 1: the healthy
    range over its five tasks was 0.44, 0.36 and 0.41 decades).

    Parameters
    ----------
    torque, band : ndarray of shape (n_samples,)
        The torque and its band-passed version.
    rate_hz : float
    where : ndarray of bool, shape (n_samples,)
        Samples whose reversals count (e.g. one direction of motion).
    smoothing_hz : float, default=10.0
    window_s : float, default=0.02
        Half-width of the window searched for the burst.

    Returns
    -------
    float
        NaN when the torque does not reverse in ``where``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 2, 1e-3)
    >>> torque = 50 * np.sin(2 * np.pi * t)
    >>> band = np.zeros_like(t); band[[500, 1000, 1500]] = 3.0  # a knock at each reversal
    >>> everywhere = np.ones_like(t, dtype=bool)
    >>> round(reversal_bursts(torque, band, 1000.0, everywhere), 3)  # 3 / sqrt(2 pi 50)
    0.169
    """
    smooth = sosfiltfilt(butter_sos(2, smoothing_hz, rate_hz), torque)
    return _bursts(smooth, band, rate_hz, where, window_s)


def _bursts(
    smooth: NDArray[np.float64],
    band: NDArray[np.float64],
    rate_hz: float,
    where: NDArray[np.bool_],
    window_s: float = 0.02,
) -> float:
    """:func:`reversal_bursts` from the low-passed torque (one filter serves both directions)."""
    crossings = np.flatnonzero(np.diff(np.sign(smooth)) != 0)
    crossings = crossings[where[crossings]]
    if crossings.size == 0:
        return float("nan")
    half = max(1, whole_samples(window_s, rate_hz))
    slope = np.abs(np.gradient(smooth, 1.0 / rate_hz))
    magnitude = np.abs(band)
    bursts = [
        magnitude[max(0, c - half) : c + half].max() / np.sqrt(max(slope[c], 1e-12))
        for c in crossings
    ]
    return float(np.mean(bursts))


def _log10(raw: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(np.log10(np.where(raw > 0, raw, np.nan)))


class MechanicsStage(FeatureStage):
    """The five indicators of this module as a feature stage (rows: directions of motion).

    Parameters
    ----------
    gear_ratio : float, default=100.0
        Motor revolutions per revolution of the measured position.
    tooth_period_revs : float, default=5.0
        Motor revolutions per revolution of the gear whose teeth are watched.
    bearing_order : float, default=5.43
        Defect frequency of the watched bearing, in orders of the motor speed.
    min_tooth_order : float, default=3.0
        Lowest order of the tooth lines (up to 8): lower orders fall near the band's lower edge
        at the axis's speeds, where the link's resonance and the control loop leak in (chosen on
        the development design among 2, 3 and 4: tooth-line spread 0.107, 0.100, 0.148 decades).
    band_hz : (float, float), default=(40.0, 300.0)
        Band of the torque in which impacts and lines are looked for (above the control loop and
        the link's resonance, below the sensors' noise).
    moving_fraction : float, default=0.2
        Samples with ``|speed|`` above this fraction of the peak count as moving.
    envelope_s : float, default=0.1
        Length of the moving RMS that normalises the band before its kurtosis.
    scales : sequence of 5 floats, default=MECHANICS_SCALES
        Each indicator's column is ``log10(indicator) / scale``.

    Attributes
    ----------
    baseline_readings_ : ndarray of shape (2, 5)
        :meth:`readings` of the baseline.
    unobserved_ : ndarray of bool, shape (5,)
        Indicators the baseline gives in neither direction.
    baseline_rows_ : ndarray of shape (2, 6)

    Examples
    --------
    >>> from axiswatch.datasets import simulate_capture
    >>> stage = MechanicsStage().fit(simulate_capture("short_fast", seed=0))
    >>> stage.transform(simulate_capture("heavy", seed=1)).X.shape
    (2, 6)
    """

    def __init__(
        self,
        gear_ratio: float = 100.0,
        tooth_period_revs: float = 5.0,
        bearing_order: float = 5.43,
        min_tooth_order: float = 3.0,
        band_hz: tuple[float, float] = (40.0, 300.0),
        moving_fraction: float = 0.2,
        envelope_s: float = 0.1,
        scales: Sequence[float] = MECHANICS_SCALES,
    ) -> None:
        self.envelope_s = envelope_s
        self.gear_ratio = gear_ratio
        self.tooth_period_revs = tooth_period_revs
        self.bearing_order = bearing_order
        self.min_tooth_order = min_tooth_order
        self.band_hz = band_hz
        self.moving_fraction = moving_fraction
        self.scales = scales

    def fit(self, baseline: Capture) -> MechanicsStage:
        logged = _log10(self.indicators(baseline))
        missing = ~np.isfinite(logged)
        if missing[:, 0].any():
            raise CaptureError(
                f"{baseline.source}: the baseline must show a usable move in both directions "
                "(the viscous friction could not be read in direction "
                f"{' and '.join(d for d, m in zip('+-', missing[:, 0], strict=True) if m)}); "
                "expected a capture of at least one task cycle."
            )
        for j in range(1, logged.shape[1]):
            if missing[:, j].any() and not missing[:, j].all():
                logged[missing[:, j], j] = logged[~missing[:, j], j]
        self.unobserved_ = missing.all(axis=0)
        logged[:, self.unobserved_] = 0.0
        self.baseline_readings_ = logged
        self.baseline_rows_ = self._rows(logged)
        return self

    def indicators(self, capture: Capture) -> NDArray[np.float64]:
        """The raw indicators (not logged, not scaled), shape (2, 5); NaN where not measurable."""
        signals, rate = resample_capture(capture, ("position", "speed", "torque"))
        position, speed, torque = signals.T
        low, high = self.band_hz
        if not 0 < low < high:
            raise ValueError(
                f"The 'band_hz' parameter of MechanicsStage must satisfy 0 < low < high. "
                f"Got {self.band_hz!r} instead."
            )
        if high >= rate / 2:
            # A capture too slow for the band is one bad capture to the monitor, not a
            # configuration error that stops the run.
            raise CaptureError(
                f"{capture.source}: the 'band_hz' of MechanicsStage, {self.band_hz!r}, needs a rate "
                f"above {2 * high:g} Hz; the capture's is {rate:g} Hz."
            )
        if signals.shape[0] < 4 * rate / low:
            raise CaptureError(
                f"{capture.source}: capture too short for the mechanics indicators: "
                f"{signals.shape[0]} samples at {rate:g} Hz, expected at least {4 * rate / low:g}."
            )
        band = sosfiltfilt(butter_sos(4, (low, high), rate), torque)
        envelope = running_rms(band, whole_samples(self.envelope_s, rate))
        normalised = band / np.where(envelope > 0, envelope, 1.0)
        angle = self.gear_ratio * position
        sign = np.sign(speed)
        peak = float(np.max(np.abs(speed))) or 1.0
        tooth = [
            k / self.tooth_period_revs
            for k in range(1, int(8 * self.tooth_period_revs) + 1)
            if k / self.tooth_period_revs >= self.min_tooth_order
            and k % round(self.tooth_period_revs)
        ]
        rows = np.full((2, len(INDICATORS)), np.nan)
        smooth = sosfiltfilt(butter_sos(2, 10.0, rate), torque)  # reversal_bursts' default
        for r, direction in enumerate((1.0, -1.0)):
            moving = (sign == direction) & (np.abs(speed) > self.moving_fraction * peak)
            if moving.sum() < 8 * (len(tooth) + 8):
                continue
            # One projection of the whole orders serves the tooth and the bearing lines.
            free = _NuisanceFree(band[moving], angle[moving], WHOLE_ORDERS, None)
            rows[r] = [
                viscous_friction(position, speed, torque, rate, direction=direction),
                pearson_kurtosis(normalised[moving]),
                _bursts(smooth, band, rate, (sign == direction) & (np.abs(speed) > 0.1 * peak)),
                # Tooth orders are 1 / tooth_period_revs apart: the neighbours sit half-way.
                free.line_ratio(tooth, [0.5 / self.tooth_period_revs]),
                free.line_ratio(bearing_orders(self.bearing_order), BEARING_OFFSETS),
            ]
        return rows

    def readings(self, capture: Capture) -> NDArray[np.float64]:
        """``log10`` of :meth:`indicators`, shape (2, 5), unscaled.

        A reading that cannot be taken (a direction without a usable move, a direction in which
        the torque never reverses) is the baseline's: no evidence either way. The baseline
        itself must give the viscous friction in both directions; another indicator it gives in
        one direction only is taken for both, one it gives in neither (``unobserved_``) reads
        the same on every capture.
        """
        logged = _log10(self.indicators(capture))
        missing = ~np.isfinite(logged) | self.unobserved_
        logged[missing] = self.baseline_readings_[missing]
        return logged

    def _rows(self, readings: NDArray[np.float64]) -> NDArray[np.float64]:
        """Feature rows of :meth:`readings`: scaled, the viscous friction also negated."""
        scales = np.asarray(self.scales, dtype=np.float64)
        if scales.shape != (len(INDICATORS),) or not np.all(scales > 0):
            raise ValueError(
                f"The 'scales' parameter of MechanicsStage must be {len(INDICATORS)} positive "
                f"floats, one per indicator {INDICATORS}. Got {self.scales!r} instead."
            )
        scaled = readings / scales
        return np.column_stack([scaled[:, :1], -scaled[:, :1], scaled[:, 1:]])

    def transform(self, capture: Capture) -> Features:
        return self._features(self._rows(self.readings(capture)), capture)

    def fit_transform(self, baseline: Capture) -> Features:
        """Fit on the baseline and return its features (``baseline_rows_``, not read again)."""
        return self._features(self.fit(baseline).baseline_rows_, baseline)

    @staticmethod
    def _features(X: NDArray[np.float64], capture: Capture) -> Features:
        return Features(X, ("mechanics",), None, float(capture.rates_hz["speed"]), COLUMNS)

    def explain(
        self, detector: object, X: NDArray[np.float64]
    ) -> dict[str, dict[str, float]] | None:
        """:func:`explain_indicators` with an :class:`~axiswatch.IndicatorDetector`, else None.

        The monitor stores the result as a score's ``indicators`` details.
        """
        if not isinstance(detector, IndicatorDetector):
            return None
        return explain_indicators(self, detector, X)


def explain_indicators(
    stage: MechanicsStage, detector: IndicatorDetector, X: NDArray[np.float64]
) -> dict[str, dict[str, float]]:
    """Why a capture has its distance: each indicator's reading, shift and share.

    The distance of :class:`~axiswatch.IndicatorDetector` is a sum of one term per column, so
    the shares are exact and add up to 1.

    Parameters
    ----------
    stage : MechanicsStage
        Fitted on the baseline.
    detector : IndicatorDetector
        Fitted on the stage's baseline rows.
    X : ndarray of shape (n_rows, 6)
        The test capture's rows (``stage.transform(capture).X``).

    Returns
    -------
    dict
        One entry per column of :data:`COLUMNS`, in that order: ``value`` and ``baseline``
        (the indicator in its own unit, geometric mean over the two directions of motion; the
        deficit column repeats the viscous friction), ``spreads`` (the mean row's shift from the
        baseline's in that column, in healthy spreads ``MechanicsStage.scales``; positive is
        worse) and ``share`` (the column's term of the distance over the distance, 0 when the
        distance is 0).

    Examples
    --------
    >>> from axiswatch import IndicatorDetector
    >>> from axiswatch.datasets import simulate_capture
    >>> stage = MechanicsStage().fit(simulate_capture("short_fast", seed=0))
    >>> detector = IndicatorDetector().fit(stage.baseline_rows_)
    >>> X = stage.transform(simulate_capture("short_fast", seed=1)).X
    >>> why = explain_indicators(stage, detector, X)
    >>> list(why) == list(COLUMNS), round(sum(v["share"] for v in why.values()), 12)
    (True, 1.0)
    """
    X = np.asarray(X, dtype=np.float64)
    terms = detector.contributions(X)
    total = float(terms.sum())
    shift = X.mean(axis=0) - detector.centre_
    scales = np.asarray(stage.scales, dtype=np.float64)
    baseline_log = stage.baseline_readings_.mean(axis=0)
    explanation = {}
    for j, name in enumerate(COLUMNS):
        indicator = max(j - 1, 0)  # the viscous friction has two columns: up, and negated
        sign = -1.0 if j == 1 else 1.0
        test_log = float(np.mean(sign * X[:, j] * scales[indicator]))
        explanation[name] = {
            "value": 10.0**test_log,
            "baseline": float(10.0 ** baseline_log[indicator]),
            "spreads": float(shift[j]),
            "share": float(terms[j] / total) if total > 0 else 0.0,
        }
    return explanation


def mechanics_model(
    *, percentile: float = 99.0, features: FeatureSpec | None = None
) -> HealthModel:
    """The former product default as a :class:`~axiswatch.HealthModel`.

    :class:`MechanicsStage`, :class:`~axiswatch.IndicatorDetector`, and a threshold floored at
    the ``percentile`` of the half-Laplace fit of healthy task changes on the simulator
    (:data:`MECHANICS_TASK_CHANGE_SCALE`).

    Examples
    --------
    >>> model = mechanics_model()
    >>> type(model.stage).__name__, type(model.detector).__name__, round(model.min_threshold, 2)
    ('MechanicsStage', 'IndicatorDetector', 12.94)
    """
    return HealthModel(
        features,
        IndicatorDetector(),
        percentile=percentile,
        min_threshold=half_laplace_threshold(MECHANICS_TASK_CHANGE_SCALE, percentile),
        stage=MechanicsStage(),
    )


def _detector(config: MonitorConfig) -> IndicatorDetector:
    return IndicatorDetector()


def _stage(config: MonitorConfig) -> MechanicsStage:
    return MechanicsStage()


def register() -> None:
    """Make ``mechanics`` a method of the monitor and of ``axiswatch monitor --method``.

    Called once when this module is imported: the ``axiswatch.methods`` entry point of the lab
    imports it the first time the monitor reads its table of methods.
    """
    from axiswatch.monitor import MethodPreset, methods, register_method

    if "mechanics" not in methods():
        register_method(
            "mechanics",
            MethodPreset(
                detector=_detector,
                stage=_stage,
                task_change_scale=MECHANICS_TASK_CHANGE_SCALE,
                stores_indicators=True,
                summary="the former default: physical indicators in scales measured on the "
                "project's simulator (needs >= 600 Hz; kept for comparison)",
            ),
        )


register()
