"""The feature-stage interface: a capture becomes a feature matrix a detector can compare.

The paper's |STFT| features are :class:`StftStage`. A stage may say why a capture has its
distance through an optional ``explain(detector, X)`` method (the lab's ``mechanics`` does).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from axiswatch._capture import Capture
from axiswatch.paper._features import Features, FeatureSpec, features_from_signals
from axiswatch.paper._preprocessing import phase_lag, resample_capture

__all__ = ["FeatureStage", "RecomputedFeatures", "StftStage"]


class FeatureStage(Protocol):
    """What a detector needs from a feature stage: fit on the baseline, then transform captures.

    The stages of the project subclass it to inherit :meth:`fit_transform`, which a stage that
    keeps its baseline's features overrides so that they are not computed twice.
    """

    def fit(self, baseline: Capture) -> FeatureStage: ...

    def transform(self, capture: Capture) -> Features: ...

    def fit_transform(self, baseline: Capture) -> Features:
        """Fit on the baseline and return its features."""
        return self.fit(baseline).transform(baseline)


@dataclass(frozen=True)
class RecomputedFeatures:
    """A feature matrix kept as the signals it comes from: its leading rows on demand.

    A 60 s capture's |STFT| at hop 1 is 374 MB; its resampled signals are 3 MB.

    Attributes
    ----------
    signals : ndarray of shape (n_samples, n_signals)
        Resampled signals, as :func:`~axiswatch.features_from_signals` takes them.
    rate_hz : float
    spec : FeatureSpec
    shape : tuple of int
        Shape of the whole feature matrix.

    Examples
    --------
    >>> import numpy as np
    >>> spec = FeatureSpec(signals=("speed",), combinations="none", segment_length=16)
    >>> signals = np.sin(np.arange(200.0))[:, None]
    >>> X = features_from_signals(signals, 100.0, spec).X
    >>> rows = RecomputedFeatures(signals, 100.0, spec, X.shape)
    >>> bool(np.array_equal(rows[:50], X[:50]))
    True
    """

    signals: NDArray[np.float64]
    rate_hz: float
    spec: FeatureSpec
    shape: tuple[int, ...]

    def __getitem__(self, rows: slice) -> NDArray[np.float64]:
        """Rows ``rows`` (a slice with unit step), computed from the signals."""
        if not isinstance(rows, slice) or rows.step not in (None, 1):
            raise TypeError(f"RecomputedFeatures takes a slice of rows; got {rows!r}.")
        start, stop, _ = rows.indices(self.shape[0])
        X = features_from_signals(self.signals, self.rate_hz, self.spec, max_rows=stop).X
        return X[start:]


class StftStage(FeatureStage):
    """The paper's |STFT| features as a stage, optionally aligned to the baseline's phase.

    Parameters
    ----------
    spec : FeatureSpec, optional
        Signals, combinations and STFT parameters. Default :class:`FeatureSpec()`.
    align : bool, default=False
        Shift every capture circularly to line up with the baseline's phase of the task cycle
        (:func:`~axiswatch.phase_lag`, circular cross-correlation of the resampled signals)
        before taking its features: captures start at arbitrary phases, and the paper's
        distances pair rows by index. Meaningful with circular padding, the default. The
        aligned capture is cut to the shorter of its and the baseline's length; the shift is
        ``Features.phase_lag``.

    Attributes
    ----------
    baseline_signals_ : ndarray of shape (n_samples, n_signals)
        The baseline's resampled signals, the phase reference (only with ``align``).
    baseline_rows_ : RecomputedFeatures
        The baseline's features, kept as its resampled signals (after :meth:`fit_transform`).

    Examples
    --------
    >>> StftStage(FeatureSpec(segment_length=32)).spec.segment_length
    32
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> t = np.arange(400) / 400.0
    >>> def capture(shift):
    ...     return Capture({"speed": np.sin(2 * np.pi * 5 * (t + shift))}, {"speed": 400.0})
    >>> spec = FeatureSpec(signals=("speed",), combinations="none", segment_length=32)
    >>> stage = StftStage(spec, align=True).fit(capture(0.0))
    >>> stage.transform(capture(0.05)).phase_lag  # 20 samples ahead = 60 behind (80-sample cycle)
    60
    """

    def __init__(self, spec: FeatureSpec | None = None, *, align: bool = False) -> None:
        self.spec = FeatureSpec() if spec is None else spec
        self.align = align

    def _signals(self, capture: Capture) -> tuple[NDArray[np.float64], float]:
        return resample_capture(capture, self.spec.signals, target_rate_hz=self.spec.target_rate_hz)

    def fit(self, baseline: Capture) -> StftStage:
        if self.align:
            self.baseline_signals_: NDArray[np.float64] = self._signals(baseline)[0]
        return self

    def transform(self, capture: Capture) -> Features:
        signals, rate = self._signals(capture)
        lag = 0
        if self.align:
            reference = self.baseline_signals_
            n = min(signals.shape[0], reference.shape[0])
            lag = phase_lag(reference[:n], signals[:n])
            signals = np.roll(signals[:n], -lag, axis=0)
        features = features_from_signals(signals, rate, self.spec, source=capture.source)
        return dataclasses.replace(features, phase_lag=lag) if lag else features

    def fit_transform(self, baseline: Capture) -> Features:
        """Fit on the baseline and return its features (its signals resampled once)."""
        signals, rate = self._signals(baseline)
        if self.align:
            self.baseline_signals_ = signals
        features = features_from_signals(signals, rate, self.spec, source=baseline.source)
        self.baseline_rows_ = RecomputedFeatures(signals, rate, self.spec, features.X.shape)
        return features
