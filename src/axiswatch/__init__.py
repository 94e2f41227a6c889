"""axiswatch: predictive maintenance of robot axes that does not cry wolf when the task changes.

A model is fitted on a healthy baseline of one axis and assesses each new capture: distance,
threshold, alarm and reason. The default is :class:`IndicatorModel`, the paper's method
:class:`HealthModel`. :mod:`axiswatch.monitor` runs a fleet, :mod:`axiswatch.datasets` has data.

>>> import axiswatch as aw
>>> from axiswatch.datasets import simulate_capture
>>> baseline = simulate_capture("short_fast", seed=0)
>>> model = aw.HealthModel(aw.FeatureSpec(combinations="none"), aw.PCADetector(n_components=2))
>>> model = model.fit(baseline).calibrate([simulate_capture("short_fast", seed=s) for s in (1, 2, 3)])
>>> verdict = model.assess(simulate_capture("short_fast", seed=4))
>>> verdict.distance <= verdict.threshold
True
"""

from importlib import import_module as _import_module
from typing import TYPE_CHECKING as _TYPE_CHECKING
from typing import Any as _Any

if _TYPE_CHECKING:  # the names as type checkers and IDEs see them
    from axiswatch._axis_model import Assessment
    from axiswatch._calibration import (
        HalfLaplaceFit,
        Threshold,
        alarm_threshold,
        fit_half_laplace,
        half_laplace_threshold,
    )
    from axiswatch._capture import (
        DEFAULT_SIGNALS,
        Capture,
        as_capture,
        read_capture,
        write_capture,
    )
    from axiswatch._formats import (
        register_format,
    )
    from axiswatch._profiles import AxisProfile
    from axiswatch.exceptions import (
        AxiswatchError,
        CalibrationError,
        CaptureError,
        DataNotFoundError,
        StoreError,
    )
    from axiswatch.indicators import INDICATORS
    from axiswatch.indicators._model import IndicatorModel
    from axiswatch.monitor import (
        MonitorConfig,
        Store,
        monitor_fleet,
    )
    from axiswatch.paper._alignment import (
        low_rank_basis,
        lra_embedding,
    )
    from axiswatch.paper._attribution import (
        attribute,
    )
    from axiswatch.paper._detectors import (
        BaselineDetector,
        IndicatorDetector,
        LRADetector,
        PCADetector,
    )
    from axiswatch.paper._features import (
        Features,
        FeatureSpec,
        extract_features,
        stft_features,
    )
    from axiswatch.paper._model import HealthModel
    from axiswatch.paper._preprocessing import (
        align_phase,
        phase_lag,
        resample_capture,
        upsample_pchip,
    )
    from axiswatch.paper._stages import (
        FeatureStage,
        StftStage,
    )

#: Public name -> the module it is imported from, on first use (PEP 562): ``import axiswatch``
#: stays light, and a command imports SciPy, scikit-learn or pandas only when it needs them.
_EXPORTS: dict[str, str] = {
    "Assessment": "axiswatch._axis_model",
    "AxisProfile": "axiswatch._profiles",
    "AxiswatchError": "axiswatch.exceptions",
    "BaselineDetector": "axiswatch.paper._detectors",
    "CalibrationError": "axiswatch.exceptions",
    "Capture": "axiswatch._capture",
    "CaptureError": "axiswatch.exceptions",
    "DEFAULT_SIGNALS": "axiswatch._capture",
    "DataNotFoundError": "axiswatch.exceptions",
    "FeatureSpec": "axiswatch.paper._features",
    "FeatureStage": "axiswatch.paper._stages",
    "Features": "axiswatch.paper._features",
    "HalfLaplaceFit": "axiswatch._calibration",
    "HealthModel": "axiswatch.paper._model",
    "INDICATORS": "axiswatch.indicators",
    "IndicatorDetector": "axiswatch.paper._detectors",
    "IndicatorModel": "axiswatch.indicators._model",
    "LRADetector": "axiswatch.paper._detectors",
    "MonitorConfig": "axiswatch.monitor",
    "PCADetector": "axiswatch.paper._detectors",
    "StftStage": "axiswatch.paper._stages",
    "Store": "axiswatch.monitor",
    "StoreError": "axiswatch.exceptions",
    "Threshold": "axiswatch._calibration",
    "alarm_threshold": "axiswatch._calibration",
    "align_phase": "axiswatch.paper._preprocessing",
    "as_capture": "axiswatch._capture",
    "attribute": "axiswatch.paper._attribution",
    "extract_features": "axiswatch.paper._features",
    "fit_half_laplace": "axiswatch._calibration",
    "half_laplace_threshold": "axiswatch._calibration",
    "low_rank_basis": "axiswatch.paper._alignment",
    "lra_embedding": "axiswatch.paper._alignment",
    "monitor_fleet": "axiswatch.monitor",
    "phase_lag": "axiswatch.paper._preprocessing",
    "read_capture": "axiswatch._capture",
    "register_format": "axiswatch._formats",
    "resample_capture": "axiswatch.paper._preprocessing",
    "stft_features": "axiswatch.paper._features",
    "upsample_pchip": "axiswatch.paper._preprocessing",
    "write_capture": "axiswatch._capture",
}

__version__ = "0.1.0"

__all__ = [
    "Assessment",
    "AxisProfile",
    "AxiswatchError",
    "BaselineDetector",
    "CalibrationError",
    "Capture",
    "CaptureError",
    "DEFAULT_SIGNALS",
    "DataNotFoundError",
    "FeatureSpec",
    "FeatureStage",
    "Features",
    "HalfLaplaceFit",
    "HealthModel",
    "INDICATORS",
    "IndicatorDetector",
    "IndicatorModel",
    "LRADetector",
    "MonitorConfig",
    "PCADetector",
    "StftStage",
    "Store",
    "StoreError",
    "Threshold",
    "alarm_threshold",
    "align_phase",
    "as_capture",
    "attribute",
    "extract_features",
    "fit_half_laplace",
    "half_laplace_threshold",
    "low_rank_basis",
    "lra_embedding",
    "monitor_fleet",
    "phase_lag",
    "read_capture",
    "register_format",
    "resample_capture",
    "stft_features",
    "upsample_pchip",
    "write_capture",
]


#: Subpackages reachable as attributes (``axiswatch.monitor.Store``) before they are imported.
_SUBPACKAGES: tuple[str, ...] = ("datasets", "exceptions", "indicators", "monitor", "paper")


def __getattr__(name: str) -> _Any:
    """Import a public name's module on first use and keep the name here."""
    if name in _SUBPACKAGES:
        return _import_module(f"{__name__}.{name}")
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_import_module(_EXPORTS[name]), name)
    # Reprs and tracebacks show the public path (``axiswatch.HealthModel``, not the private
    # module); pickles then refer to it too, which every class listed here can be loaded from.
    library = tuple(f"{__name__}.{part}" for part in ("_", "indicators.", "paper."))
    if isinstance(value, type) and value.__module__.startswith(library):
        value.__module__ = __name__
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
