"""Task-invariant health indicators: feature stages that see the mechanics rather than the task.

Pipeline stage 2b (beside the |STFT| features of ``_features``). The paper's features pair STFT
time slices of the baseline and of a test capture by index; after a task change row ``i`` no
longer means the same motion, so the distance measures the task. The stages here instead produce
matrices whose rows are fixed *operating states* (or motion directions) of the axis, so row ``i``
means the same physical situation in every capture, and whose columns describe the mechanics:

* :class:`ResidualStage` (model residuals): a rigid-body model of the axis,
  ``torque = J a + F_v v + F_c tanh(v / v_s) + G_c cos q + G_s sin q + c``, is identified on the
  baseline by least squares; the residual torque of every capture (whose trajectory the model
  explains) is described per state by band energies and impulsiveness. Friction, backlash at
  reversals, tooth and bearing impacts stay in the residual.
* :class:`OrderStage` (angle domain): the residual torque is resampled against the motor angle, so
  that gear-mesh, tooth and bearing frequencies become fixed orders whatever the speed; rows are
  the two motion directions, columns the log order spectrum.
* :class:`StateStage` (operating-point conditioning): plain statistics of torque and speed taken
  per state, compared state by state.

Every stage follows one small interface: ``fit(baseline_capture)`` then
``transform(capture) -> Features``; any detector (PCA, LRA, the domain-adaptation baselines) is
fitted on the baseline's matrix and scores the others. A state absent from a capture (a task
without a cruise phase, say) takes the baseline's row: no evidence either way.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.signal import savgol_filter

from axiswatch import Capture, Features, FeatureStage, resample_capture, stft_features
from axiswatch.exceptions import CaptureError

__all__ = [
    "STATES",
    "STATE_COLUMNS",
    "AxisModel",
    "OrderStage",
    "ResidualStage",
    "StateStage",
    "fit_axis_model",
    "operating_states",
]

#: Operating states, in row order: dwell, then accelerating, cruising and decelerating in each
#: direction of motion.
STATES: tuple[str, ...] = (
    "dwell",
    "accelerate+",
    "cruise+",
    "decelerate+",
    "accelerate-",
    "cruise-",
    "decelerate-",
)
_REGRESSORS: tuple[str, ...] = ("acceleration", "speed", "coulomb", "cos_q", "sin_q", "offset")


@dataclass(frozen=True)
class _Kinematics:
    position: NDArray[np.float64]
    speed: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    torque: NDArray[np.float64]
    rate_hz: float


def _kinematics(capture: Capture, smoothing_s: float) -> _Kinematics:
    signals, rate = resample_capture(capture, ("position", "speed", "torque"))
    window = max(5, round(smoothing_s * rate) | 1)
    if signals.shape[0] <= window:
        raise CaptureError(
            f"{capture.source}: capture too short for the state analysis: {signals.shape[0]} "
            f"samples, expected more than {window} (smoothing_s={smoothing_s} s at {rate:g} Hz)."
        )
    acceleration = savgol_filter(signals[:, 1], window, 2, deriv=1, delta=1.0 / rate)
    return _Kinematics(signals[:, 0], signals[:, 1], acceleration, signals[:, 2], rate)


def operating_states(
    speed: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    *,
    dwell_fraction: float = 0.05,
    cruise_fraction: float = 0.15,
) -> NDArray[np.int64]:
    """Operating state of every sample, as an index into :data:`STATES`.

    Thresholds are fractions of the capture's own peak speed and peak acceleration, so the states
    mean the same thing for a slow and a fast task.

    Parameters
    ----------
    speed, acceleration : ndarray of shape (n_samples,)
    dwell_fraction : float, default=0.05
        ``|speed|`` below this fraction of the peak is dwell.
    cruise_fraction : float, default=0.15
        Moving samples with ``|acceleration|`` below this fraction of the peak are cruising.

    Returns
    -------
    ndarray of int, shape (n_samples,)

    Examples
    --------
    >>> import numpy as np
    >>> v = np.array([0.0, 0.5, 1.0, 1.0, 0.5, -0.5, -1.0, -1.0, -0.5, 0.0])
    >>> a = np.array([0.0, 5.0, 0.0, 0.0, -5.0, -5.0, 0.0, 0.0, 5.0, 0.0])
    >>> [STATES[s] for s in operating_states(v, a)]  # doctest: +NORMALIZE_WHITESPACE
    ['dwell', 'accelerate+', 'cruise+', 'cruise+', 'decelerate+', 'accelerate-', 'cruise-',
     'cruise-', 'decelerate-', 'dwell']
    """
    v = np.asarray(speed, dtype=np.float64)
    a = np.asarray(acceleration, dtype=np.float64)
    if v.shape != a.shape or v.ndim != 1:
        raise ValueError(
            f"speed and acceleration must be 1-D of one shape; got {v.shape} and {a.shape}."
        )
    v_peak = float(np.max(np.abs(v))) or 1.0
    a_peak = float(np.max(np.abs(a))) or 1.0
    moving = np.abs(v) > dwell_fraction * v_peak
    cruising = np.abs(a) <= cruise_fraction * a_peak
    speeding_up = np.sign(a) == np.sign(v)
    phase = np.where(cruising, 1, np.where(speeding_up, 0, 2))  # 0 accel, 1 cruise, 2 decel
    states = np.where(v > 0, 1 + phase, 4 + phase)
    return np.where(moving, states, 0).astype(np.int64)


@dataclass(frozen=True)
class AxisModel:
    """Rigid-body torque model of an axis, identified by least squares.

    ``torque = J a + F_v v + F_c tanh(v / v_s) + G_c cos q + G_s sin q + c``.

    Attributes
    ----------
    coefficients : ndarray of shape (6,)
        In the order of ``regressors``.
    regressors : tuple of str
    coulomb_speed : float
        ``v_s``, the speed scale of the smoothed Coulomb term.
    r_squared : float
        Share of the baseline torque's variance the model explains.
    """

    coefficients: NDArray[np.float64]
    regressors: tuple[str, ...]
    coulomb_speed: float
    r_squared: float

    def design(
        self,
        position: NDArray[np.float64],
        speed: NDArray[np.float64],
        acceleration: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Regressor matrix, shape (n_samples, 6)."""
        return np.column_stack(
            [
                acceleration,
                speed,
                np.tanh(speed / self.coulomb_speed),
                np.cos(position),
                np.sin(position),
                np.ones_like(speed),
            ]
        )

    def residual(
        self,
        position: NDArray[np.float64],
        speed: NDArray[np.float64],
        acceleration: NDArray[np.float64],
        torque: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Measured minus modelled torque."""
        return np.asarray(torque - self.design(position, speed, acceleration) @ self.coefficients)


def fit_axis_model(
    position: NDArray[np.float64],
    speed: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    torque: NDArray[np.float64],
    *,
    coulomb_fraction: float = 0.02,
) -> AxisModel:
    """Identify :class:`AxisModel` by linear least squares (:func:`scipy.linalg.lstsq`).

    Parameters
    ----------
    position, speed, acceleration, torque : ndarray of shape (n_samples,)
    coulomb_fraction : float, default=0.02
        ``v_s`` as a fraction of the peak speed: the Coulomb term switches over that speed.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2, 4000)
    >>> q, v, a = np.sin(3 * t), 3 * np.cos(3 * t), -9 * np.sin(3 * t)
    >>> tau = 2.0 * a + 0.5 * v + 1.5 * np.cos(q)
    >>> model = fit_axis_model(q, v, a, tau)
    >>> np.round(model.coefficients[[0, 1, 3]], 6).tolist(), round(model.r_squared, 6)
    ([2.0, 0.5, 1.5], 1.0)
    """
    v_scale = coulomb_fraction * (float(np.max(np.abs(speed))) or 1.0)
    template = AxisModel(np.zeros(len(_REGRESSORS)), _REGRESSORS, v_scale, 0.0)
    A = template.design(position, speed, acceleration)
    coefficients, *_ = scipy.linalg.lstsq(A, torque)
    residual = torque - A @ coefficients
    total = float(np.sum((torque - torque.mean()) ** 2)) or 1.0
    return AxisModel(
        np.asarray(coefficients), _REGRESSORS, v_scale, 1.0 - float(np.sum(residual**2)) / total
    )


def _state_rows(
    values: NDArray[np.float64], states: NDArray[np.int64], fallback: NDArray[np.float64] | None
) -> NDArray[np.float64]:
    """Mean of ``values`` rows per state; absent states take ``fallback``'s row (or 0)."""
    rows = np.zeros((len(STATES), values.shape[1]))
    for s in range(len(STATES)):
        members = states == s
        if members.any():
            rows[s] = values[members].mean(axis=0)
        elif fallback is not None:
            rows[s] = fallback[s]
    return rows


def _bands(n_bins: int, n_bands: int) -> list[slice]:
    edges = np.unique(np.round(np.linspace(1, n_bins, n_bands + 1)).astype(int))
    return [slice(lo, hi) for lo, hi in itertools.pairwise(edges)]


class ResidualStage(FeatureStage):
    """Per-state description of the torque left unexplained by the axis's own model.

    ``fit`` identifies the axis model (:class:`AxisModel`: inertia, friction, link gravity) on the
    baseline, with payload terms for the forward moves. On every capture only the payload terms
    (``a``, ``cos q`` and ``sin q`` while moving forward, where a pick-and-place axis carries its
    load) are identified again, by least squares on that capture: a new task's payload is thereby
    absorbed, while the axis's inertia, friction and link gravity stay those of the baseline, so a
    change of friction, backlash at reversals and tooth or bearing impacts remain in the residual.

    Rows: the moving states of :data:`STATES` (dwell carries no motion, hence no friction, mesh or
    impact information). Columns per state: log band energies of the residual |STFT|
    (``n_bands`` bands) followed by the residual's mean, standard deviation and crest factor.

    Parameters
    ----------
    segment_length : int, default=64
    n_bands : int, default=8
    smoothing_s : float, default=0.01
        Savitzky-Golay window for the acceleration (derivative of speed).
    payload : bool, default=True
        Re-identify the payload terms on every capture (False: the baseline's model as is).

    Attributes
    ----------
    model_ : AxisModel
    baseline_rows_ : ndarray of shape (6, n_bands + 3)
    """

    def __init__(
        self,
        segment_length: int = 64,
        n_bands: int = 8,
        smoothing_s: float = 0.01,
        payload: bool = True,
        both_directions: bool = False,
        stats_only: bool = False,
    ) -> None:
        self.segment_length = segment_length
        self.n_bands = n_bands
        self.smoothing_s = smoothing_s
        self.payload = payload
        self.both_directions = both_directions
        self.stats_only = stats_only

    def fit(self, baseline: Capture) -> ResidualStage:
        kin = _kinematics(baseline, self.smoothing_s)
        moving = operating_states(kin.speed, kin.acceleration) > 0
        self.model_ = fit_axis_model(
            kin.position[moving], kin.speed[moving], kin.acceleration[moving], kin.torque[moving]
        )
        self.baseline_rows_: NDArray[np.float64] | None = None
        self.baseline_rows_ = self.transform(baseline).X
        return self

    def residual(
        self, capture: Capture
    ) -> tuple[NDArray[np.float64], NDArray[np.int64], _Kinematics]:
        """Residual torque, operating state of every sample, and the kinematics it came from."""
        kin = _kinematics(capture, self.smoothing_s)
        states = operating_states(kin.speed, kin.acceleration)
        residual = self.model_.residual(kin.position, kin.speed, kin.acceleration, kin.torque)
        directions = [kin.speed > 0]
        if self.both_directions:
            directions.append(kin.speed < 0)
        for forward in directions if self.payload else []:
            if forward.sum() <= 3:
                continue
            load = (
                np.column_stack([kin.acceleration, np.cos(kin.position), np.sin(kin.position)])
                * forward[:, None]
            )
            coefficients, *_ = scipy.linalg.lstsq(load[forward], residual[forward])
            residual = residual - load @ coefficients
        return residual, states, kin

    def transform(self, capture: Capture) -> Features:
        residual, states, kin = self.residual(capture)
        rate = kin.rate_hz
        spectrum = stft_features(residual[:, None], rate, segment_length=self.segment_length)
        bands = _bands(spectrum.shape[1], self.n_bands)
        energy = np.column_stack([np.sum(spectrum[:, b] ** 2, axis=1) for b in bands])
        moving_states = range(1, len(STATES))
        columns = np.zeros((len(moving_states), len(bands) + 3))
        for row, s in enumerate(moving_states):
            members = states == s
            if members.sum() < 2:
                columns[row] = self.baseline_rows_[row] if self.baseline_rows_ is not None else 0.0
                continue
            r = residual[members]
            rms = float(np.sqrt(np.mean(r**2))) or 1e-300
            columns[row, : len(bands)] = np.log10(energy[members].mean(axis=0) + 1e-300)
            columns[row, len(bands) :] = [r.mean(), r.std(), np.max(np.abs(r)) / rms]
        centres = np.array([(b.start + b.stop - 1) / 2 for b in bands]) * rate / self.segment_length
        stats = ("residual_mean", "residual_std", "residual_crest")
        if self.stats_only:
            return Features(columns[:, len(bands) :], ("residual",), None, rate, stats)
        names = tuple(f"log_energy_{c:.4g}_hz" for c in centres) + stats
        return Features(columns, ("residual",), None, rate, names)


class OrderStage(FeatureStage):
    """Order spectrum of the residual torque in the motor-angle domain, one row per direction.

    The motor angle is ``gear_ratio * position``. Within every stretch of motion in one direction
    the residual torque is resampled (linear interpolation) at ``samples_per_rev`` points per motor
    revolution; windows of ``window_revs`` revolutions give magnitude spectra over orders (cycles
    per motor revolution), averaged per direction; columns are the log mean magnitude for orders
    ``1 / window_revs ... max_order``.

    Parameters
    ----------
    gear_ratio : float, default=100.0
        Motor revolutions per revolution of the measured position.
    samples_per_rev : int, default=32
    window_revs : int, default=8
    max_order : float, default=12.0
    smoothing_s : float, default=0.01
    min_revs : float, default=1.0
        Shorter stretches of motion are ignored.
    """

    def __init__(
        self,
        gear_ratio: float = 100.0,
        samples_per_rev: int = 32,
        window_revs: int = 8,
        max_order: float = 12.0,
        smoothing_s: float = 0.01,
        min_revs: float = 1.0,
        relative: bool = True,
    ) -> None:
        self.relative = relative
        self.gear_ratio = gear_ratio
        self.min_revs = min_revs
        self.samples_per_rev = samples_per_rev
        self.window_revs = window_revs
        self.max_order = max_order
        self.smoothing_s = smoothing_s

    def fit(self, baseline: Capture) -> OrderStage:
        self.residual_stage_ = ResidualStage(
            smoothing_s=self.smoothing_s, both_directions=True
        ).fit(baseline)
        self.baseline_rows_: NDArray[np.float64] | None = None
        self.baseline_rows_ = self.transform(baseline).X
        return self

    def transform(self, capture: Capture) -> Features:
        residual, _, kin = self.residual_stage_.residual(capture)
        rate = kin.rate_hz
        angle_rev = self.gear_ratio * kin.position / (2 * np.pi)
        window = self.window_revs * self.samples_per_rev
        orders = np.fft.rfftfreq(window, d=1.0 / self.samples_per_rev)
        keep = (orders > 0) & (orders <= self.max_order)
        rows = []
        v_peak = float(np.max(np.abs(kin.speed))) or 1.0
        for direction in (1.0, -1.0):
            moving = direction * kin.speed > 0.05 * v_peak
            spectra = []
            edges = np.flatnonzero(np.diff(np.concatenate([[0], moving.astype(int), [0]])))
            for start, stop in zip(edges[::2], edges[1::2], strict=True):
                theta = np.maximum.accumulate(direction * angle_rev[start:stop])
                if theta.size < 2 or theta[-1] - theta[0] < self.min_revs:
                    continue
                grid = np.arange(theta[0], theta[-1], 1.0 / self.samples_per_rev)
                order_domain = np.interp(grid, theta, residual[start:stop])
                # Whole windows where the stretch is long enough; a shorter stretch (or the
                # tail) is tapered over its own length and zero-padded to the window, which keeps
                # the order axis but widens the peaks.
                for w0 in range(0, max(grid.size - window, 0) + 1, window // 2):
                    segment = order_domain[w0 : w0 + window]
                    taper = np.hanning(segment.size)
                    padded = np.zeros(window)
                    padded[: segment.size] = (segment - segment.mean()) * taper
                    spectra.append(np.abs(np.fft.rfft(padded)) / taper.sum())
            if spectra:
                log_spectrum = np.log10(np.mean(spectra, axis=0)[keep] + 1e-300)
                # Relative to the spectrum's own median: the broadband residual level follows the
                # task (speed, payload); lines at fixed orders stand out of it whatever the task.
                rows.append(
                    log_spectrum - np.median(log_spectrum) if self.relative else log_spectrum
                )
            elif self.baseline_rows_ is not None:
                rows.append(self.baseline_rows_[len(rows)])
            else:
                raise CaptureError(
                    f"{capture.source}: the baseline has no stretch of motion covering "
                    f"{self.min_revs} motor revolution(s) in direction {direction:+.0f}; expected "
                    "longer moves, or a gear_ratio that gives the motor angle."
                )
        return Features(
            np.vstack(rows), ("residual_order",), np.asarray(orders[keep], dtype=np.float64), rate
        )


#: Columns of :class:`StateStage` (one row per operating state).
STATE_COLUMNS: tuple[str, ...] = (
    "mean_torque",
    "torque_std",
    "mean_abs_speed",
    "high_band_torque_rms",
    "share",
)


class StateStage(FeatureStage):
    """Plain statistics of torque and speed per operating state (operating-point conditioning).

    Columns per state: mean torque, torque standard deviation, mean |speed|, torque RMS in the
    band above ``high_hz`` (impacts, ripple) and the state's share of the capture.

    Parameters
    ----------
    high_hz : float, default=100.0
    smoothing_s : float, default=0.01
    """

    def __init__(self, high_hz: float = 100.0, smoothing_s: float = 0.01) -> None:
        self.high_hz = high_hz
        self.smoothing_s = smoothing_s

    def fit(self, baseline: Capture) -> StateStage:
        self.baseline_rows_: NDArray[np.float64] | None = None
        self.baseline_rows_ = self.transform(baseline).X
        return self

    def transform(self, capture: Capture) -> Features:
        from scipy.signal import butter, sosfiltfilt

        kin = _kinematics(capture, self.smoothing_s)
        states = operating_states(kin.speed, kin.acceleration)
        sos = butter(4, self.high_hz, btype="highpass", fs=kin.rate_hz, output="sos")
        high = sosfiltfilt(sos, kin.torque)
        values = np.column_stack([kin.torque, kin.torque, np.abs(kin.speed), high**2])
        rows = _state_rows(values, states, None)
        for s in range(len(STATES)):
            members = states == s
            if members.sum() < 2:
                rows[s, :4] = self.baseline_rows_[s, :4] if self.baseline_rows_ is not None else 0.0
                continue
            rows[s, 1] = kin.torque[members].std()
            rows[s, 3] = np.sqrt(rows[s, 3])
        share = np.bincount(states, minlength=len(STATES)) / states.size
        X = np.column_stack([rows, share])
        return Features(X, ("state_stats",), None, kin.rate_hz, STATE_COLUMNS)
