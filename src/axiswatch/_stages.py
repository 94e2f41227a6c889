"""The feature-stage interface: a capture becomes a feature matrix a detector can compare.

A stage is fitted on the baseline capture and transforms every capture into
:class:`~axiswatch.Features` (rows of comparable situations, columns of measurements). The
paper's |STFT| features are :class:`StftStage`; the product default's physical indicators are
:class:`~axiswatch.MechanicsStage`; research stages live in ``axiswatch_lab``.
"""

from __future__ import annotations

from typing import Protocol

from axiswatch._capture import Capture
from axiswatch._features import Features, FeatureSpec, extract_features

__all__ = ["FeatureStage", "StftStage"]


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


class StftStage(FeatureStage):
    """The paper's |STFT| features as a stage (no fitting needed).

    Examples
    --------
    >>> StftStage(FeatureSpec(segment_length=32)).spec.segment_length
    32
    """

    def __init__(self, spec: FeatureSpec | None = None) -> None:
        self.spec = FeatureSpec() if spec is None else spec

    def fit(self, baseline: Capture) -> StftStage:
        return self

    def transform(self, capture: Capture) -> Features:
        return extract_features(capture, self.spec)
