"""The monitor's methods: a table of named presets that turn a method name into model objects.

Pipeline stage below :class:`~axiswatch.monitor.MonitorConfig`. A method is a
:class:`MethodPreset`: factories of its detector and (optionally) its feature stage, and the
half-Laplace scale of healthy task changes that sets its threshold floor. The monitor
(``MonitorConfig(method=...)``) and the CLI (``axiswatch monitor --method``) read the table, so a
new detector or stage reaches both through :func:`register_method`, called in its own module (or
in a package that declares the module under the entry-point group ``axiswatch.methods``: it is
imported the first time the table is read).

Built in: ``indicators`` (the product default: :class:`~axiswatch.IndicatorModel` per axis,
fitted on the baseline and the calibration captures, with its fleet's prior:
``axiswatch.indicators._axis``; no number of its decision comes from a simulator), the paper's
``lra`` and ``pca``, and ``mechanics`` (the former default, whose indicator scales and task-change
floor were measured on the project's simulator: kept for comparison, docs/evaluation.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from axiswatch._calibration import half_laplace_threshold
from axiswatch._mechanics import MECHANICS_TASK_CHANGE_SCALE, MechanicsStage
from axiswatch.paper._detectors import BaselineDetector, IndicatorDetector, LRADetector, PCADetector
from axiswatch.paper._stages import FeatureStage

if TYPE_CHECKING:
    from axiswatch.monitor._scoring import MonitorConfig

__all__ = [
    "DEFAULT_METHOD",
    "METHOD_GROUP",
    "MethodPreset",
    "method_preset",
    "methods",
    "register_method",
]

#: The product default: ``MonitorConfig()`` and ``axiswatch monitor``. ``indicators`` since
#: 2026-11-23 (issue 13): it scores captures at any rate >= 20 Hz and estimates every spread and
#: allowance from the axis and its fleet; ``mechanics`` rejects captures below 600 Hz and its
#: scales come from the project's simulator (docs/evaluation.md, "Through the monitor").
DEFAULT_METHOD = "indicators"

#: Entry-point group whose modules register methods when imported.
METHOD_GROUP = "axiswatch.methods"


def _no_stage(config: MonitorConfig) -> FeatureStage | None:
    return None


@dataclass(frozen=True)
class MethodPreset:
    """How a method name becomes the model objects of the monitor.

    Parameters
    ----------
    detector : callable (MonitorConfig) -> BaselineDetector, optional
        A fresh, unfitted detector for a configuration (None only with ``indicator_model``).
    stage : callable (MonitorConfig) -> FeatureStage or None, optional
        A fresh feature stage, or None for the |STFT| features of ``MonitorConfig.features``
        (with phase alignment). Default: none.
    task_change_scale : float or None, default=None
        Half-Laplace scale of the distances of healthy *task changes* measured in development;
        the threshold floor is its ``percentile`` (None: no floor).
    summary : str, default=""
        One line for ``--help``.
    indicator_model : bool, default=False
        The method has no detector and no stage: each axis gets an
        :class:`~axiswatch.IndicatorModel` fitted on its baseline and ``K`` calibration captures
        together, with the fleet prior of its profile (``axiswatch.indicators._axis``).

    Examples
    --------
    >>> from axiswatch import PCADetector
    >>> preset = MethodPreset(detector=lambda config: PCADetector(n_components=3))
    >>> preset.threshold_floor(99.0) is None
    True
    """

    detector: Callable[[MonitorConfig], BaselineDetector] | None = None
    stage: Callable[[MonitorConfig], FeatureStage | None] = _no_stage
    task_change_scale: float | None = None
    summary: str = ""
    indicator_model: bool = False

    def __post_init__(self) -> None:
        if (self.detector is None) != self.indicator_model:
            raise ValueError(
                "A method preset needs a 'detector' factory, or indicator_model=True (and then "
                f"no detector). Got detector={self.detector!r}, "
                f"indicator_model={self.indicator_model!r} instead."
            )

    def threshold_floor(self, percentile: float) -> float | None:
        """The ``percentile`` of the task-change fit, or None without one."""
        if self.task_change_scale is None:
            return None
        return half_laplace_threshold(self.task_change_scale, percentile)


def _lra(config: MonitorConfig) -> BaselineDetector:
    return LRADetector(noise_level=config.lra_noise_level)


_METHODS: dict[str, MethodPreset] = {
    "indicators": MethodPreset(
        indicator_model=True,
        summary="physical indicators at any rate >= 20 Hz, in spreads of the axis's own "
        "calibration captures and of its fleet (default, docs/evaluation.md)",
    ),
    "lra": MethodPreset(detector=_lra, summary="the paper's Low Rank Alignment"),
    "pca": MethodPreset(detector=lambda config: PCADetector(), summary="the paper's PCA"),
    "mechanics": MethodPreset(
        detector=lambda config: IndicatorDetector(),
        stage=lambda config: MechanicsStage(),
        task_change_scale=MECHANICS_TASK_CHANGE_SCALE,
        summary="the former default: physical indicators in scales measured on the project's "
        "simulator (needs >= 600 Hz; kept for comparison)",
    ),
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
    if name in _METHODS and not replace:
        raise ValueError(
            f"The method {name!r} is registered already; pass replace=True to replace it."
        )
    _METHODS[name] = preset


def methods() -> dict[str, MethodPreset]:
    """The registered methods by name (built-in first, then in the order registered)."""
    global _plugins_loaded
    if not _plugins_loaded:
        # Set first: a plugin module that reads the table while it registers must not recurse.
        _plugins_loaded = True
        from importlib.metadata import entry_points

        for entry in entry_points(group=METHOD_GROUP):
            entry.load()
    return dict(_METHODS)


def method_preset(name: str) -> MethodPreset:
    """The preset of a registered method.

    Raises
    ------
    ValueError
        If no method of that name is registered (the message lists those that are).
    """
    table = methods()
    if name not in table:
        raise ValueError(
            f"The 'method' parameter must be one of {', '.join(map(repr, table))}. "
            f"Got {name!r} instead."
        )
    return table[name]
