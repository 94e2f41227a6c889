"""The interface of a model of one axis: fitted on healthy captures, it assesses a new one.

:class:`AxisModel` is what a library user calls; :class:`MonitoredModel` adds what the fleet
monitor needs to fit and score it in worker processes. Both wings satisfy both.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Protocol, Self

from axiswatch._capture import Capture
from axiswatch._profiles import AxisProfile

__all__ = ["Assessment", "AxisModel", "MonitoredModel"]


@dataclass(frozen=True)
class Assessment:
    """Verdict on one capture.

    Attributes
    ----------
    distance : float
        How far the capture is from the healthy reference, in the model's units; NaN when
        nothing could be scored.
    threshold : float
        In the distance's units; NaN while the model has no threshold (the monitor calibrates
        one from its calibration captures' distances).
    alarm : bool
        ``distance > threshold``.
    leading : str or None, default=None
        What moved most (an indicator), when the model can tell.
    explanation : str, default=""
        Why nothing was scored, or what moved, in words (:meth:`reason`).
    pvalue : float, default=NaN
        Probability of a distance at least this large for a healthy capture, under the fit.
    phase_lag : int, default=0
        Samples the capture was shifted by to line up with the baseline.
    details : dict, default={}
        What the monitor stores with the score.

    Examples
    --------
    >>> verdict = Assessment(2.0, 1.0, True, leading="coulomb_friction")
    >>> verdict.scored, verdict.reason()
    (True, 'coulomb_friction moved: distance 2 against a threshold of 1')
    """

    distance: float
    threshold: float
    alarm: bool
    _: KW_ONLY
    leading: str | None = None
    explanation: str = ""
    pvalue: float = math.nan
    phase_lag: int = 0
    details: Mapping[str, Any] = field(default_factory=dict, hash=False)

    @property
    def scored(self) -> bool:
        """Whether any part of the capture was scored."""
        return math.isfinite(self.distance)

    def reason(self) -> str:
        """One line: what moved, or why nothing could be scored."""
        if self.explanation:
            return self.explanation
        if not self.scored:
            return "not scored"
        moved = f"{self.leading} moved: " if self.leading else ""
        return f"{moved}distance {self.distance:.3g} against a threshold of {self.threshold:.3g}"


class AxisModel(Protocol):
    """A model of one axis: ``fit`` on its healthy captures, then ``assess`` new ones."""

    def fit(
        self, baseline: Capture, calibration: Sequence[Capture] = (), *, fleet: Sequence[Any] = ()
    ) -> Self:
        """Fit on the baseline and calibration captures; ``fleet``: fitted models of the other
        axes of its profile, for a model that learns task changes from them."""
        ...

    def assess(self, capture: Capture) -> Assessment:
        """The verdict on one capture."""
        ...


class MonitoredModel(AxisModel, Protocol):
    """What the monitor's one fit job and one score job need of a model.

    A fit job reads the baseline and, one at a time, the captures after it, and :meth:`read`
    takes what the model needs of each, until the monitor's ``calibration_size`` give it
    something (for a model that ``fits_calibration``); then :meth:`fit_read` fits on those. A score job calls :meth:`score`. A model that learns from
    its fleet (``pooled``) is pooled by the driver with :meth:`with_fleet` before it is stored.
    """

    @property
    def signals(self) -> tuple[str, ...] | None:
        """Columns read from a capture file; None: every column."""
        ...

    @property
    def fits_calibration(self) -> bool:
        """Whether the calibration captures after the baseline are fitted on too (else the
        baseline alone, and the monitor calibrates the threshold from their distances)."""
        ...

    @property
    def pooled(self) -> bool:
        """Whether new baselines wait for the other axes of their fleet before they are stored."""
        ...

    def check_baseline(self, capture: Capture) -> None:
        """Refuse a new baseline the model cannot use (raises CaptureError)."""
        ...

    def baseline_note(self, rates_hz: Mapping[str, float]) -> str | None:
        """A note on a stored baseline of these rates that should be replaced, or None."""
        ...

    def read(self, capture: Capture, profile: AxisProfile | None) -> tuple[Any, str | None]:
        """What the model takes of a capture, and why it takes nothing (None: it takes it)."""
        ...

    def fit_read(self, read: Sequence[Any], names: Sequence[tuple[str, str]]) -> Self:
        """A fitted copy from :meth:`read`'s results (baseline first) and the ``(file hash,
        path)`` of each capture."""
        ...

    def fingerprint(self) -> str:
        """A hash of what the fitted model was fitted on."""
        ...

    def summary(self) -> dict[str, Any] | None:
        """What the store keeps of a fitted model with its baseline (None: nothing)."""
        ...

    def score(self, capture: Capture, file_hash: str, profile: AxisProfile | None) -> Assessment:
        """The assessment the monitor stores: its distance, details and, when nothing could be
        scored, the reason."""
        ...

    def fleet_key(self, profile: AxisProfile | None) -> str:
        """The fleet an axis with this profile is pooled with."""
        ...

    def fleet_axes(self) -> int:
        """Axes of the fleet prior the fitted model scores with (0: none)."""
        ...

    def checks(self) -> dict[str, str]:
        """Why the fitted model's baseline is not trusted as it is, by kind (``"baseline"``:
        against the captures after it; ``"fleet"``: against its fleet); empty when it is."""
        ...

    def with_fleet(self, models: Sequence[Self], others: Sequence[Self]) -> list[Self]:
        """``models`` (new, of one fleet) with the prior of the fleet they form with ``others``."""
        ...
