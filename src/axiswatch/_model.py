"""A health model of one robot axis: features + detector + calibrated threshold.

Pipeline stage 6, the public one-screen API::

    model = HealthModel(detector=LRADetector()).fit(baseline_capture)
    model.calibrate(healthy_captures, percentile=99)
    verdict = model.assess(new_capture)   # distance, threshold, alarm

It only composes the lower stages: :func:`~axiswatch.extract_features`, a
:class:`~axiswatch.BaselineDetector` and :func:`~axiswatch.fit_half_laplace`.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from sklearn.base import clone

from axiswatch._calibration import HalfLaplaceFit, fit_half_laplace
from axiswatch._capture import Capture
from axiswatch._detectors import BaselineDetector, LRADetector
from axiswatch._features import Features, FeatureSpec, features_from_signals
from axiswatch._preprocessing import phase_lag, resample_capture
from axiswatch._stages import FeatureStage
from axiswatch.exceptions import CalibrationError

__all__ = ["Assessment", "HealthModel"]


@dataclass(frozen=True)
class Assessment:
    """Verdict on one capture.

    Attributes
    ----------
    distance : float
    threshold : float
    alarm : bool
        ``distance > threshold``.
    pvalue : float
        Probability of a distance at least this large for a healthy capture, under the fit.
    phase_lag : int
        Samples the capture was shifted by to line up with the baseline (0 without alignment).
    """

    distance: float
    threshold: float
    alarm: bool
    pvalue: float
    phase_lag: int


class HealthModel:
    """Baseline, threshold and verdicts for one robot axis.

    Parameters
    ----------
    features : FeatureSpec, optional
        How captures become features. Default :class:`FeatureSpec()`.
    detector : BaselineDetector, optional
        Default :class:`LRADetector()`. Cloned, never modified.
    percentile : float in (0, 100), default=99.0
        Threshold percentile of the half-Laplace fit of healthy distances.
    align_phase : bool, default=True
        Shift every capture circularly to line up with the baseline before taking features
        (captures start at arbitrary phases of the task cycle; the paper's distances pair rows by
        index). Meaningful with circular padding, the default. Ignored with a ``stage``.
    min_threshold : float, default=0.0
        Lower bound of the threshold (``MonitorConfig.threshold_floor``: what healthy task
        changes do to the distance, which same-task calibration captures cannot show).
    stage : FeatureStage, optional
        A feature stage (:class:`~axiswatch.MechanicsStage`, ...) used instead of the |STFT|
        features: fitted on the baseline (a copy; never modified), then it reads every capture.
        ``features`` then only names the signals to read.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture, FeatureSpec, PCADetector
    >>> rng = np.random.default_rng(0)
    >>> def capture(noise):
    ...     t = np.arange(400) / 400.0
    ...     return Capture({"speed": np.sin(2 * np.pi * 5 * t) + noise * rng.normal(size=400)},
    ...                    {"speed": 400.0})
    >>> spec = FeatureSpec(signals=("speed",), combinations="none", segment_length=32)
    >>> model = HealthModel(spec, PCADetector(n_components=3)).fit(capture(0.01))
    >>> model = model.calibrate([capture(0.01) for _ in range(5)])
    >>> model.assess(capture(0.01)).alarm, model.assess(capture(0.5)).alarm
    (False, True)
    """

    def __init__(
        self,
        features: FeatureSpec | None = None,
        detector: BaselineDetector | None = None,
        *,
        percentile: float = 99.0,
        align_phase: bool = True,
        min_threshold: float = 0.0,
        stage: FeatureStage | None = None,
    ) -> None:
        self.features = FeatureSpec() if features is None else features
        self.detector = LRADetector() if detector is None else detector
        self.percentile = percentile
        self.align_phase = align_phase
        self.min_threshold = min_threshold
        self.stage = stage

    def _signals(self, capture: Capture) -> tuple[NDArray[np.float64], float]:
        return resample_capture(
            capture, self.features.signals, target_rate_hz=self.features.target_rate_hz
        )

    def featurize(self, capture: Capture) -> tuple[Features, int]:
        """Features of a capture, after phase alignment to the baseline; and the lag used."""
        if self.stage_ is not None:
            return self.stage_.transform(capture), 0
        signals, rate = self._signals(capture)
        lag = 0
        if self.align_phase:
            reference = self.baseline_signals_
            n = min(signals.shape[0], reference.shape[0])
            lag = phase_lag(reference[:n], signals[:n])
            signals = np.roll(signals[:n], -lag, axis=0)
        return features_from_signals(signals, rate, self.features, source=capture.source), lag

    def fit(self, baseline: Capture) -> HealthModel:
        """Take ``baseline`` as the healthy reference (the paper's commissioning capture)."""
        self.stage_: FeatureStage | None = None
        if self.stage is not None:
            self.stage_ = copy.deepcopy(self.stage)
            self.baseline_features_ = self.stage_.fit_transform(baseline)
        else:
            signals, rate = self._signals(baseline)
            self.baseline_signals_: NDArray[np.float64] = signals
            self.baseline_features_ = features_from_signals(
                signals, rate, self.features, source=baseline.source
            )
        self.detector_ = clone(self.detector).fit(self.baseline_features_.X)
        self.calibration_: HalfLaplaceFit | None = None
        return self

    def distance(self, capture: Capture) -> float:
        """Distance of ``capture`` to the baseline."""
        features, _ = self.featurize(capture)
        return float(self.detector_.distance(features.X))

    def calibrate(
        self, healthy: Sequence[Capture] | NDArray[np.float64], *, percentile: float | None = None
    ) -> HealthModel:
        """Fit the half-Laplace threshold on healthy captures (or on their distances)."""
        if percentile is not None:
            self.percentile = percentile
        if len(healthy) and isinstance(healthy[0], Capture):
            distances = np.array([self.distance(c) for c in healthy])
        else:
            distances = np.asarray(healthy, dtype=np.float64)
        self.calibration_ = fit_half_laplace(distances)
        self.healthy_distances_ = distances
        self.threshold_ = max(self.calibration_.threshold(self.percentile), self.min_threshold)
        return self

    def assess(self, capture: Capture) -> Assessment:
        """Distance, threshold and alarm flag of one capture."""
        if getattr(self, "calibration_", None) is None:
            raise CalibrationError(
                "The model is not calibrated: call calibrate() with healthy captures first."
            )
        features, lag = self.featurize(capture)
        distance = float(self.detector_.distance(features.X))
        assert self.calibration_ is not None
        return Assessment(
            distance=distance,
            threshold=self.threshold_,
            alarm=bool(distance > self.threshold_),
            pvalue=self.calibration_.pvalue(distance),
            phase_lag=lag,
        )
