"""The monitor's parameters: the method preset, the features, the threshold and alarm rules."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from axiswatch._capture_length import MAX_CAPTURE_ROWS
from axiswatch._profiles import AxisProfile
from axiswatch.monitor._decision import DecisionRule
from axiswatch.monitor._methods import (
    DEFAULT_METHOD,
    METHOD_OPTIONS,
    MethodPreset,
    method_preset,
    methods,
)
from axiswatch.paper._features import FeatureSpec

if TYPE_CHECKING:  # the models' modules are imported by the preset that makes one
    from axiswatch._axis_model import MonitoredModel
    from axiswatch.paper._detectors import BaselineDetector
    from axiswatch.paper._stages import FeatureStage

__all__ = ["MONITOR_FEATURES", "MonitorConfig", "params_hash"]

#: Features of the monitor: the library's defaults (position, speed, torque and their products,
#: Hann window of 128, circular padding, magnitude scaling) with a hop of 8 samples. At 2 kHz a
#: slice every 4 ms still overlaps its neighbour by 94 %, and the 8x fewer rows make scoring a
#: fleet 5-10x cheaper.
MONITOR_FEATURES = FeatureSpec(hop=8)


@dataclass(frozen=True)
class MonitorConfig:
    """Parameters of the monitor; all but ``baseline`` are stored with every baseline.

    Parameters
    ----------
    method : str, default="indicators"
        A registered method (:func:`~axiswatch.monitor.register_method`; built in:
        ``"indicators"``, the product default, an :class:`~axiswatch.IndicatorModel` per axis
        fitted on the baseline and the calibration captures, with its fleet's prior; the paper's
        Low Rank Alignment ``"lra"`` and ``"pca"``, library defaults of :class:`LRADetector` and
        :class:`PCADetector` on ``features``). The method's preset makes the detector, the stage
        and the threshold floor.
    percentile : float in (0, 100), default=99.0
    calibration_size : int >= 2, default=5
        ``K``: captures after the baseline that calibrate the threshold.
    alarm_k, alarm_n : int, default=1, 1
        Alarm when at least ``k`` of the last ``n`` captures are over the threshold.
    clear_m : int, default=1
        An alarm clears after ``m`` captures in a row under the threshold.
    baseline : str or None, default=None
        File name of the capture to use as every new axis's baseline (axes without such a file
        start at their first capture).
    features : FeatureSpec, default=MONITOR_FEATURES
        Signals to read; for a method without a stage, its |STFT| features.
    lra_noise_level : float or "auto", default=1.0
        ``lambda`` of the LRA detector (:class:`LRADetector`'s ``noise_level``): 1 is the paper's
        form; ``"auto"`` estimates it from each baseline's own noise.
    align_phase : bool, default=True
        Align every capture to the baseline's phase of the task cycle (``HealthModel``; methods
        with a stage read directions of motion, not time slices, and are never aligned).
    detector : BaselineDetector or None, default=None
        A detector to use instead of the method's (an unfitted estimator; cloned when fitted).
    stage : FeatureStage or None, default=None
        A feature stage to use instead of the method's.
    profile : AxisProfile, optional
        Column names, units and time stamps of every axis's files (``--profile FILE``). When
        None, each axis's profile is looked up in the fleet folder (:meth:`AxisProfile.find`:
        ``<axis>/axis.toml``, ``<robot>/robot.toml``, ``axiswatch.toml``), and files without one
        are read as the project's format.
    task_envelope : float > 0 or None, default=None
        Method ``"indicators"``: apply the fleet's task-change allowance only to captures whose
        motion is not the baseline's task, with this envelope factor
        (:data:`~axiswatch.indicators._spreads.TASK_ENVELOPE_FACTOR` was chosen on the development
        robots); None: every capture is scored with the allowance. Off by default: on the real
        hydraulic actuators it raised 55 false alarms in 297 healthy captures
        (docs/evaluation.md, "Through the monitor").
    order_lines : bool, default=False
        Method ``"indicators"``: also score ``order_lines``, the torque's order lines against
        each baseline's own order spectrum (no kinematics needed; captures of 100 Hz or more
        with steady motion). See :class:`~axiswatch.IndicatorModel`.
    whole_moves : bool, default=False
        Method ``"indicators"``: an opt-in operating point, ``IndicatorModel(whole_moves=True)``:
        drive loads read on whole moves only, and a friction reading looser than its baseline's
        scored in a wider spread. Fewer false alarms after task changes (Robot A 32 -> 3 days on
        development robots 0-7), slightly fewer detections at the 99 % threshold (``dr99`` up
        to 0.03 lower): docs/evaluation.md, "An opt-in operating point: ``--whole-moves``".
    modes : bool, default=False
        Method ``"indicators"``: learn each axis's operating modes
        (:mod:`axiswatch.monitor._mode_decision`): every capture of a moving axis is scored in
        its mode's normal, or by a guard while a new mode is learned; ``ack --task-changed``
        teaches a mode change. Opt-in while it is measured (docs/evaluation.md, "Modes").
    max_capture_rows : int >= 1, default=MAX_CAPTURE_ROWS
        A capture file of more rows is rejected before it is loaded (one line naming its rows
        and the limit): memory stays bounded whatever a file's length. Not stored with the
        baselines: it decides which files are read, not how they are scored.

    Examples
    --------
    >>> MonitorConfig(alarm_k=2, alarm_n=3).params()["alarm"]
    {'k': 2, 'n': 3, 'clear_m': 1}
    >>> MonitorConfig().method  # the product default
    'indicators'
    >>> type(MonitorConfig(method="pca").model().detector).__name__
    'PCADetector'
    """

    method: str = DEFAULT_METHOD
    percentile: float = 99.0
    calibration_size: int = 5
    alarm_k: int = 1
    alarm_n: int = 1
    clear_m: int = 1
    baseline: str | None = None
    features: FeatureSpec = MONITOR_FEATURES
    lra_noise_level: float | Literal["auto"] = 1.0
    align_phase: bool = True
    detector: BaselineDetector | None = None
    stage: FeatureStage | None = None
    profile: AxisProfile | None = None
    task_envelope: float | None = None
    order_lines: bool = False
    whole_moves: bool = False
    modes: bool = False
    max_capture_rows: int = MAX_CAPTURE_ROWS

    def __post_init__(self) -> None:
        if not (isinstance(self.max_capture_rows, int) and self.max_capture_rows >= 1):
            raise ValueError(
                "The 'max_capture_rows' parameter must be an int >= 1. "
                f"Got {self.max_capture_rows!r} instead."
            )
        preset = method_preset(self.method)
        for name in METHOD_OPTIONS:
            if getattr(self, name) in (None, False) or name in preset.accepts:
                continue
            readers = [m for m, p in methods().items() if name in p.accepts]
            which = ", ".join(map(repr, readers)) or "no method"
            raise ValueError(
                f"The '{name}' parameter is for the method {which} only. Got {name}="
                f"{getattr(self, name)!r} for the method {self.method!r} instead."
            )
        if self.task_envelope is not None and not (
            math.isfinite(self.task_envelope) and self.task_envelope > 0
        ):
            raise ValueError(
                "The 'task_envelope' parameter must be None or a float > 0. "
                f"Got {self.task_envelope!r} instead."
            )
        if not (0.0 < self.percentile < 100.0):
            raise ValueError(
                "The 'percentile' parameter must be a float in (0, 100). "
                f"Got {self.percentile!r} instead."
            )
        if not (isinstance(self.calibration_size, int) and self.calibration_size >= 2):
            raise ValueError(
                "The 'calibration_size' parameter must be an int >= 2 (the half-Laplace fit "
                f"needs two distances). Got {self.calibration_size!r} instead."
            )
        if self.modes and self.calibration_size < 3:
            raise ValueError(
                "The 'modes' parameter needs a 'calibration_size' >= 3: a mode is known after "
                "that many captures (monitor --modes --calibration N). "
                f"Got {self.calibration_size!r} instead."
            )
        if not (1 <= self.alarm_k <= self.alarm_n):
            raise ValueError(
                "The alarm rule needs 1 <= k <= n ('k of the last n captures over'). "
                f"Got k={self.alarm_k!r}, n={self.alarm_n!r} instead."
            )
        if self.clear_m < 1:
            raise ValueError(f"The 'clear_m' parameter must be >= 1. Got {self.clear_m!r} instead.")
        _check_features(self.features)

    @property
    def preset(self) -> MethodPreset:
        """The registered preset of ``method``."""
        return method_preset(self.method)

    def model(self) -> MonitoredModel:
        """A fresh, unfitted model of an axis for the configured method (its preset's factory).

        Examples
        --------
        >>> MonitorConfig(method="indicators", percentile=95.0).model().model.percentile
        95.0
        """
        return self.preset.make(self)

    def threshold_floor(self) -> float:
        """Least threshold: the ``percentile`` of the half-Laplace fit of healthy task changes
        in development, for a method that has one; else 0."""
        floor = self.preset.threshold_floor(self.percentile)
        return 0.0 if floor is None else floor

    def decision_rule(self) -> DecisionRule:
        """What :func:`~axiswatch.monitor._decision.decide` needs of this configuration."""
        return DecisionRule(
            percentile=self.percentile,
            calibration_size=self.calibration_size,
            alarm_k=self.alarm_k,
            alarm_n=self.alarm_n,
            clear_m=self.clear_m,
            floor=self.preset.threshold_floor(self.percentile),
        )

    def params(self) -> dict[str, Any]:
        """JSON-ready parameters stored with every baseline: the method's and the decision
        rule's (a stored baseline made under other parameters is refitted)."""
        return self.preset.stored_params(self)


def _check_features(spec: FeatureSpec) -> None:
    signals = spec.signals
    if not signals or any(not name or name != name.strip() for name in signals):
        raise ValueError(
            "The 'signals' parameter must name at least one signal column, without blanks. "
            f"Got {list(signals)!r} instead."
        )
    if len(set(signals)) != len(signals):
        raise ValueError(f"The 'signals' parameter names a column twice. Got {list(signals)!r}.")
    if not (isinstance(spec.segment_length, int) and spec.segment_length >= 2):
        raise ValueError(
            "The 'segment_length' parameter must be an int >= 2 (samples per STFT window). "
            f"Got {spec.segment_length!r} instead."
        )
    if not (isinstance(spec.hop, int) and 1 <= spec.hop <= spec.segment_length):
        raise ValueError(
            "The 'hop' parameter must be an int in [1, segment_length] (samples between STFT "
            f"windows). Got {spec.hop!r} instead (segment_length {spec.segment_length})."
        )


def params_hash(config: MonitorConfig) -> str:
    """Short hash of the parameters (what a rejection made under them depended on)."""
    text = json.dumps(config.params(), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
