"""The monitor's methods: named presets, each a factory of a fresh model of an axis.

Built in: ``indicators`` (the default) and the paper's ``lra`` and ``pca``. A new method is
registered with :func:`register_method`, or under the entry-point group ``axiswatch.methods``
(the lab's ``mechanics`` is). The model is any :class:`~axiswatch._axis_model.MonitoredModel`.

A preset imports its model's modules when it makes a model, and entry points load when a method
that is not built in is looked up or the methods are listed: a run that scores nothing stays light.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from axiswatch._calibration import half_laplace_threshold

if TYPE_CHECKING:
    from axiswatch._axis_model import MonitoredModel
    from axiswatch.indicators._axis import IndicatorBaseline
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.paper._detectors import BaselineDetector
    from axiswatch.paper._model import HealthModel
    from axiswatch.paper._stages import FeatureStage

__all__ = [
    "DEFAULT_METHOD",
    "METHOD_GROUP",
    "MethodPreset",
    "method_preset",
    "methods",
    "register_method",
]

#: The product default: ``MonitorConfig()`` and ``axiswatch monitor``. It scores captures at any
#: rate >= 20 Hz and estimates every spread and allowance from the axis and its fleet.
DEFAULT_METHOD = "indicators"

#: Entry-point group whose modules register methods when imported.
METHOD_GROUP = "axiswatch.methods"

#: Options of :class:`~axiswatch.monitor.MonitorConfig` that only some methods read.
METHOD_OPTIONS = ("detector", "stage", "task_envelope", "order_lines", "whole_moves", "modes")


def _no_stage(config: MonitorConfig) -> FeatureStage | None:
    return None


@dataclass(frozen=True)
class MethodPreset:
    """How a method name becomes a fresh, unfitted model of an axis.

    Parameters
    ----------
    model : callable (MonitorConfig) -> MonitoredModel, optional
        A fresh, unfitted model for a configuration
        (:class:`~axiswatch._axis_model.MonitoredModel`). Default: the paper's
        :class:`~axiswatch.HealthModel` of ``detector`` and ``stage``.
    detector : callable (MonitorConfig) -> BaselineDetector, optional
        The detector of the default model (give ``model`` or ``detector``, not both).
    stage : callable (MonitorConfig) -> FeatureStage or None, optional
        The default model's feature stage, or None for the |STFT| features of
        ``MonitorConfig.features`` (with phase alignment). Default: none.
    params : callable (MonitorConfig) -> dict, optional
        The parameters stored with every baseline (a changed value refits it). Default: the
        default model's detector, features and stage.
    detector_params : callable (MonitorConfig) -> dict, optional
        The ``get_params()`` of the detector that ``detector`` makes, without making it: the
        default ``params`` then import no scikit-learn (a run that fits nothing stays light).
        Default: the detector is made to read them.
    task_change_scale : float or None, default=None
        Half-Laplace scale of the distances of healthy *task changes* measured in development;
        the threshold floor is its ``percentile`` (None: no floor).
    summary : str, default=""
        One line for ``--help``.
    options : frozenset of str, default=frozenset()
        The options of ``METHOD_OPTIONS`` the method reads (``detector`` and ``stage`` for the
        default model); a configuration that sets another is refused.
    distance_unit : str, default="healthy spreads"
        What a stored distance counts, for the report's axes.
    stores_indicators : bool, default=False
        Whether its scores carry each indicator's shift (``details["indicators"]``), which the
        report charts below the distance.

    Examples
    --------
    >>> from axiswatch import PCADetector
    >>> preset = MethodPreset(detector=lambda config: PCADetector(n_components=3))
    >>> preset.threshold_floor(99.0) is None, sorted(preset.accepts)
    (True, ['detector', 'stage'])
    """

    model: Callable[[MonitorConfig], MonitoredModel] | None = None
    detector: Callable[[MonitorConfig], BaselineDetector] | None = None
    stage: Callable[[MonitorConfig], FeatureStage | None] = _no_stage
    params: Callable[[MonitorConfig], dict[str, Any]] | None = None
    detector_params: Callable[[MonitorConfig], dict[str, Any]] | None = None
    task_change_scale: float | None = None
    summary: str = ""
    options: frozenset[str] = frozenset()
    distance_unit: str = "healthy spreads"
    stores_indicators: bool = False

    def __post_init__(self) -> None:
        if (self.model is None) == (self.detector is None):
            raise ValueError(
                "A method preset needs a 'model' factory or a 'detector' factory (for the "
                f"paper's HealthModel), not both. Got model={self.model!r}, "
                f"detector={self.detector!r} instead."
            )
        unknown = sorted(set(self.options) - set(METHOD_OPTIONS))
        if unknown:
            raise ValueError(
                f"The 'options' parameter must name options of {METHOD_OPTIONS}. "
                f"Got {unknown} instead."
            )

    @property
    def accepts(self) -> frozenset[str]:
        """The options of ``METHOD_OPTIONS`` the method reads."""
        own = {"detector", "stage"} if self.detector is not None else set()
        return frozenset(self.options) | own

    def make(self, config: MonitorConfig) -> MonitoredModel:
        """A fresh, unfitted model for ``config``."""
        if self.model is not None:
            return self.model(config)
        return _health_model(self, config)

    def stored_params(self, config: MonitorConfig) -> dict[str, Any]:
        """What is stored with every baseline: the common parameters and the method's."""
        if self.params is not None:
            return self.params(config)
        return _health_params(self, config)

    def threshold_floor(self, percentile: float) -> float | None:
        """The ``percentile`` of the task-change fit, or None without one."""
        if self.task_change_scale is None:
            return None
        return half_laplace_threshold(self.task_change_scale, percentile)


def _health_model(preset: MethodPreset, config: MonitorConfig) -> HealthModel:
    """The paper's HealthModel of the preset's (or the configuration's) detector and stage."""
    from axiswatch.paper._model import HealthModel

    stage = preset.stage(config) if config.stage is None else config.stage
    detector = config.detector
    if detector is None:
        assert preset.detector is not None
        detector = preset.detector(config)
    floor = preset.threshold_floor(config.percentile)
    return HealthModel(
        config.features,
        detector,
        percentile=config.percentile,
        align_phase=config.align_phase,
        min_threshold=0.0 if floor is None else floor,
        stage=stage,
    )


def _common_params(config: MonitorConfig) -> dict[str, Any]:
    return {
        "percentile": config.percentile,
        "calibration_size": config.calibration_size,
        "alarm": {"k": config.alarm_k, "n": config.alarm_n, "clear_m": config.clear_m},
    }


def _health_params(preset: MethodPreset, config: MonitorConfig) -> dict[str, Any]:
    """Features, detector and (for a stage method) the stage and the threshold floor; the key is
    absent otherwise, so stores made before it still match. Without a stage or a configured
    detector, a preset's ``detector_params`` stand for its detector's (no model is made)."""
    stage = preset.stage(config) if config.stage is None else config.stage
    floor = None
    if stage is None and config.detector is None and preset.detector_params is not None:
        detector = preset.detector_params(config)
    else:
        model = _health_model(preset, config)
        detector, stage, floor = model.detector.get_params(), model.stage, model.min_threshold
    params = {
        "method": config.method,
        "detector": detector,
        "features": dataclasses.asdict(config.features),
        "align_phase": config.align_phase and stage is None,
        **_common_params(config),
    }
    if stage is not None:
        params["stage"] = {"name": type(stage).__name__, **vars(stage)}
        params["threshold_floor"] = floor
    if config.profile is not None:  # absent otherwise, so stores made before it still match
        params["profile"] = config.profile.source
    return params


def _indicators_model(config: MonitorConfig) -> IndicatorBaseline:
    """An unfitted :class:`~axiswatch.IndicatorModel` at the monitor's percentile."""
    from axiswatch.indicators._axis import IndicatorBaseline
    from axiswatch.indicators._model import IndicatorModel

    return IndicatorBaseline(
        IndicatorModel(
            percentile=config.percentile,
            task_envelope_factor=config.task_envelope,
            order_lines=config.order_lines,
            whole_moves=config.whole_moves,
        )
    )


def _indicator_params(config: MonitorConfig) -> dict[str, Any]:
    from axiswatch.indicators._minimums import MIN_AXES, MIN_READINGS

    params: dict[str, Any] = {
        "method": config.method,
        "model": {
            "name": "IndicatorModel",
            "min_readings": MIN_READINGS,
            "fleet_min_axes": MIN_AXES,
        },
        **_common_params(config),
    }
    if config.profile is not None:
        params["profile"] = config.profile.source
    # Each absent when off: earlier stores still match.
    if config.task_envelope is not None:
        params["task_envelope"] = config.task_envelope
    if config.order_lines:
        params["order_lines"] = True
    if config.whole_moves:
        params["whole_moves"] = True
    if config.modes:
        params["modes"] = True
    return params


def _lra_params(config: MonitorConfig) -> dict[str, Any]:
    """The ``lra`` method's detector parameters: the preset makes its detector of these."""
    return {
        "mu": 0.5,
        "n_components": 2,
        "noise_level": config.lra_noise_level,
        "solver": "structured",
    }


def _lra(config: MonitorConfig) -> BaselineDetector:
    from axiswatch.paper._detectors import LRADetector

    return LRADetector(**_lra_params(config))


def _pca_params(config: MonitorConfig) -> dict[str, Any]:
    """The ``pca`` method's detector parameters: the preset makes its detector of these."""
    return {"n_components": 0.95}


def _pca(config: MonitorConfig) -> BaselineDetector:
    from axiswatch.paper._detectors import PCADetector

    return PCADetector(**_pca_params(config))


_METHODS: dict[str, MethodPreset] = {
    "indicators": MethodPreset(
        model=_indicators_model,
        params=_indicator_params,
        options=frozenset({"task_envelope", "order_lines", "whole_moves", "modes"}),
        distance_unit="thresholds",
        stores_indicators=True,
        summary="physical indicators at any rate >= 20 Hz, in spreads of the axis's own "
        "calibration captures and of its fleet (default, docs/evaluation.md)",
    ),
    "lra": MethodPreset(
        detector=_lra,
        detector_params=_lra_params,
        summary="the paper's Low Rank Alignment",
    ),
    "pca": MethodPreset(detector=_pca, detector_params=_pca_params, summary="the paper's PCA"),
}
_plugins_loaded = False


def register_method(name: str, preset: MethodPreset, *, replace: bool = False) -> None:
    """Make ``name`` a method of the monitor and of ``axiswatch monitor --method``.

    Parameters
    ----------
    name : str
        Stored with every score (the ``method`` column): letters, digits, ``_`` and ``-``.
    preset : MethodPreset
    replace : bool, default=False
        Allow replacing a registered method (a store's baselines remember the parameters, so a
        changed preset is noticed on a store made with the old one).

    Raises
    ------
    ValueError
        If ``name`` is not such a name, or is registered already and ``replace`` is False.

    Examples
    --------
    >>> from axiswatch import PCADetector
    >>> register_method("pca", MethodPreset(detector=lambda config: PCADetector(n_components=3)))
    Traceback (most recent call last):
    ...
    ValueError: The method 'pca' is registered already; pass replace=True to replace it.
    """
    if not (name and name.replace("_", "").replace("-", "").isalnum()):
        raise ValueError(
            f"The method name must be letters, digits, '_' and '-'. Got {name!r} instead."
        )
    # The plugins first: a method registered here then comes after them whatever was asked
    # before, and a plugin's own name is never taken unknowingly.
    _load_plugins()
    if name in _METHODS and not replace:
        raise ValueError(
            f"The method {name!r} is registered already; pass replace=True to replace it."
        )
    _METHODS[name] = preset


def _load_plugins() -> None:
    """Import the modules of the entry-point group :data:`METHOD_GROUP`, once."""
    global _plugins_loaded
    if not _plugins_loaded:
        # Set first: a plugin module that reads the table while it registers must not recurse.
        _plugins_loaded = True
        from importlib.metadata import entry_points

        for entry in entry_points(group=METHOD_GROUP):
            entry.load()


def methods() -> dict[str, MethodPreset]:
    """The registered methods by name (built-in first, then in the order registered)."""
    _load_plugins()
    return dict(_METHODS)


def is_method(name: str) -> bool:
    """Whether ``name`` is registered; entry points load only for a name not registered yet."""
    if name not in _METHODS:
        _load_plugins()
    return name in _METHODS


def method_preset(name: str) -> MethodPreset:
    """The preset of a registered method.

    Raises
    ------
    ValueError
        If no method of that name is registered (the message lists those that are).
    """
    if not is_method(name):
        raise ValueError(
            f"The 'method' parameter must be one of {', '.join(map(repr, methods()))}. "
            f"Got {name!r} instead."
        )
    return _METHODS[name]
