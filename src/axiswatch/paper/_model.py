"""A health model of one robot axis: features, a detector and a calibrated threshold.

It composes a :class:`~axiswatch.FeatureStage`, a :class:`~axiswatch.BaselineDetector` and
:func:`~axiswatch.alarm_threshold`. docs/library.md shows it in one screen.
"""

from __future__ import annotations

import copy
import hashlib
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray
from sklearn.base import clone

from axiswatch._axis_model import Assessment, MonitoredModel
from axiswatch._calibration import (
    HalfLaplaceFit,
    Threshold,
    alarm_threshold,
)
from axiswatch._capture import Capture
from axiswatch._profiles import AxisProfile
from axiswatch.exceptions import CalibrationError
from axiswatch.paper._detectors import BaselineDetector, LRADetector, PCADetector
from axiswatch.paper._features import Features, FeatureSpec
from axiswatch.paper._stages import FeatureStage, StftStage

__all__ = ["HealthModel"]


class HealthModel:
    """Baseline, threshold and verdicts for one robot axis: stage -> detector -> threshold.

    One feature path: a :class:`~axiswatch.FeatureStage` turns every capture into features (the
    paper's |STFT| with phase alignment, :class:`~axiswatch.StftStage`, unless another stage is
    given), the detector measures their distance to the baseline's, and
    :func:`~axiswatch.alarm_threshold` of healthy distances sets the threshold. The one-call
    constructor :meth:`paper` builds the paper's method (the product default is
    :class:`~axiswatch.IndicatorModel`, the monitor's ``indicators``).

    Parameters
    ----------
    features : FeatureSpec, optional
        Signals and |STFT| parameters of the default stage, ``StftStage(features,
        align=align_phase)``. Default :class:`FeatureSpec()`. With another ``stage`` it only
        names the signals to read.
    detector : BaselineDetector, optional
        Default :class:`LRADetector()`. Cloned, never modified.
    percentile : float in (0, 100), default=99.0
        Threshold percentile of the half-Laplace fit of healthy distances.
    align_phase : bool, default=True
        The default stage's ``align``: shift every capture circularly to line up with the
        baseline before taking features (captures start at arbitrary phases of the task cycle;
        the paper's distances pair rows by index). Ignored with a ``stage``.
    min_threshold : float, default=0.0
        Floor of the threshold (what healthy task changes do to the distance, which same-task
        calibration captures cannot show).
    stage : FeatureStage, optional
        The feature stage: fitted on the baseline (a
        copy; never modified), then it reads every capture.

    Attributes
    ----------
    stage_ : FeatureStage
        The fitted stage.
    detector_ : BaselineDetector
        The fitted detector. With the |STFT| stage, a detector that reads the baseline's rows only
        for a shorter test (LRA's) keeps them as the baseline's signals, recomputed when needed.
    baseline_fingerprint_ : str
        :meth:`fingerprint`, taken in ``fit``.
    alarm_threshold_ : Threshold
        The threshold and where it came from (after :meth:`calibrate`).

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
    >>> model.alarm_threshold_.describe()
    '99th pct of half-Laplace fit of 5 healthy captures'
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

    @classmethod
    def paper(
        cls,
        method: Literal["lra", "pca"] = "lra",
        *,
        features: FeatureSpec | None = None,
        percentile: float = 99.0,
        align_phase: bool = True,
    ) -> HealthModel:
        """The paper's method: |STFT| features (aligned to the baseline's phase) with Low Rank
        Alignment (``"lra"``) or the PCA subspace distance (``"pca"``), library defaults.

        Examples
        --------
        >>> type(HealthModel.paper("pca").detector).__name__
        'PCADetector'
        """
        detectors: dict[str, type[BaselineDetector]] = {"lra": LRADetector, "pca": PCADetector}
        if method not in detectors:
            raise ValueError(
                f"The 'method' parameter of HealthModel.paper must be 'lra' or 'pca'. "
                f"Got {method!r} instead."
            )
        return cls(features, detectors[method](), percentile=percentile, align_phase=align_phase)

    def featurize(self, capture: Capture) -> tuple[Features, int]:
        """Features of a capture (after phase alignment to the baseline, where the stage aligns)
        and the lag used."""
        features = self.stage_.transform(capture)
        return features, features.phase_lag

    #: Kept by a model stored before it kept its fingerprint: the baseline's features.
    baseline_features_: Features

    #: The monitor fits on the baseline alone and calibrates from the next captures' distances.
    fits_calibration: ClassVar[bool] = False
    #: Each axis's model is its own: no fleet prior.
    pooled: ClassVar[bool] = False

    @property
    def signals(self) -> tuple[str, ...]:
        """The columns read from a capture file."""
        return self.features.signals

    def fit(
        self, baseline: Capture, calibration: Sequence[Capture] = (), *, fleet: Sequence[Any] = ()
    ) -> HealthModel:
        """Take ``baseline`` as the healthy reference (the paper's commissioning capture) and,
        when given, :meth:`calibrate` on ``calibration``; ``fleet`` is not used."""
        self._fit(baseline)
        return self.calibrate(calibration) if len(calibration) else self

    def _fit(self, baseline: Capture) -> HealthModel:
        self.stage_: FeatureStage = (
            StftStage(self.features, align=self.align_phase)
            if self.stage is None
            else copy.deepcopy(self.stage)
        )
        features = self.stage_.fit_transform(baseline)
        self.detector_ = clone(self.detector).fit(features.X)
        # The array's own buffer: tobytes() would copy the features.
        self.baseline_fingerprint_ = hashlib.sha256(
            np.ascontiguousarray(features.X).data
        ).hexdigest()
        rows = getattr(self.stage_, "baseline_rows_", None)
        if rows is not None and not self.detector_.reads_baseline_rows:
            # The features are not kept: a shorter test capture's baseline rows are recomputed.
            self.detector_.baseline_ = rows
        self.calibration_: HalfLaplaceFit | None = None
        return self

    def distance(self, capture: Capture) -> float:
        """Distance of ``capture`` to the baseline."""
        features, _ = self.featurize(capture)
        return self._measure(features.X, reused=False)[0]

    def _measure(
        self, X: NDArray[np.float64], *, reused: bool
    ) -> tuple[float, dict[str, float | bool]]:
        """The detector's distance and diagnostics of features the model made; LRA may build
        its test basis in their memory when they are not ``reused`` afterwards."""
        detector = self.detector_
        if isinstance(detector, LRADetector) and not reused:
            distance, diagnostics = detector.distance_and_diagnostics(X, overwrite_x=True)
        else:
            distance, diagnostics = detector.distance_and_diagnostics(X)
        return float(distance), diagnostics

    def calibrate(
        self, healthy: Sequence[Capture] | NDArray[np.float64], *, percentile: float | None = None
    ) -> HealthModel:
        """Fit the threshold on healthy captures (or on their distances): :func:`alarm_threshold`
        at ``percentile``, floored at ``min_threshold``."""
        if percentile is not None:
            self.percentile = percentile
        if len(healthy) and isinstance(healthy[0], Capture):
            distances = np.array([self.distance(c) for c in healthy])
        else:
            distances = np.asarray(healthy, dtype=np.float64)
        self.alarm_threshold_: Threshold = alarm_threshold(
            distances, percentile=self.percentile, floor=self.min_threshold or None
        )
        self.calibration_ = self.alarm_threshold_.fit
        self.healthy_distances_ = distances
        self.threshold_ = self.alarm_threshold_.value
        return self

    def assess(self, capture: Capture) -> Assessment:
        """Distance, threshold and alarm flag of one capture."""
        if getattr(self, "calibration_", None) is None:
            raise CalibrationError(
                "The model is not calibrated: call calibrate() with healthy captures first."
            )
        features, lag = self.featurize(capture)
        distance = self._measure(features.X, reused=False)[0]
        assert self.calibration_ is not None
        return Assessment(
            distance=distance,
            threshold=self.threshold_,
            alarm=bool(distance > self.threshold_),
            pvalue=self.calibration_.pvalue(distance),
            phase_lag=lag,
        )

    # --- what the monitor needs (axiswatch._axis_model.MonitoredModel) ---------------------

    def check_baseline(self, capture: Capture) -> None:
        """Every capture the reader accepts can be a baseline."""

    def baseline_note(self, rates_hz: Mapping[str, float]) -> str | None:
        """No stored baseline needs replacing for its rates."""
        return None

    def read(self, capture: Capture, profile: AxisProfile | None) -> tuple[Capture, str | None]:
        """The capture itself: the model reads it when it is fitted."""
        return capture, None

    def fit_read(self, read: Sequence[Capture], names: Sequence[tuple[str, str]]) -> HealthModel:
        """A fitted copy on the baseline (``read[0]``)."""
        return copy.deepcopy(self)._fit(read[0])

    def fingerprint(self) -> str:
        """SHA-256 of the baseline's features."""
        fingerprint = getattr(self, "baseline_fingerprint_", None)
        if fingerprint is None:  # a model stored with its baseline's features
            return hashlib.sha256(self.baseline_features_.X.tobytes()).hexdigest()
        return str(fingerprint)

    def summary(self) -> None:
        """Nothing beyond the stored model."""
        return None

    def score(self, capture: Capture, file_hash: str, profile: AxisProfile | None) -> Assessment:
        """Distance and the detector's diagnostics; the threshold is NaN until calibrated (the
        monitor calibrates from its calibration captures' distances)."""
        features, lag = self.featurize(capture)
        details: dict[str, Any] = {
            "phase_lag_samples": int(lag),
            "phase_lag_s": float(lag / features.rate_hz),
            "n_rows": int(features.X.shape[0]),
        }
        # A stage that can say why (the lab's ``mechanics``) adds each indicator's share.
        explain = getattr(self.stage_, "explain", None)
        distance, diagnostics = self._measure(features.X, reused=explain is not None)
        details.update(diagnostics)
        explanation = None if explain is None else explain(self.detector_, features.X)
        if explanation is not None:
            details["indicators"] = explanation
        threshold = getattr(self, "threshold_", math.nan)
        return Assessment(
            distance, threshold, bool(distance > threshold), phase_lag=lag, details=details
        )

    def fleet_key(self, profile: AxisProfile | None) -> str:
        """No fleet: every axis on its own."""
        return ""

    def fleet_axes(self) -> int:
        """No fleet prior."""
        return 0

    def checks(self) -> dict[str, str]:
        """No check of the baseline."""
        return {}

    def with_fleet(
        self, models: Sequence[HealthModel], others: Sequence[HealthModel]
    ) -> list[HealthModel]:
        """``models`` unchanged: nothing is learnt from the fleet."""
        return list(models)


if TYPE_CHECKING:  # checked by mypy: the paper's model is a model of an axis, monitored too
    _CONFORMS: type[MonitoredModel] = HealthModel
