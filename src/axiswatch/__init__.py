"""axiswatch: predictive maintenance of robot axes that does not cry wolf when the task changes.

The library: a capture of one axis (position, speed, torque) becomes features (the paper's |STFT|,
or the product default's physical indicators, :class:`MechanicsStage`); a detector compares them
with a healthy baseline (PCA subspace distance, the paper's Low Rank Alignment, or indicator
spreads); a half-Laplace fit of healthy distances gives the alarm threshold. The fleet service is
:mod:`axiswatch.monitor`, simulators and recorded-data readers are :mod:`axiswatch.datasets`; the
research experiments are the separate package ``axiswatch_lab``.

>>> import axiswatch as aw
>>> from axiswatch.datasets import simulate_capture
>>> baseline = simulate_capture("short_fast", seed=0)
>>> model = aw.HealthModel(aw.FeatureSpec(combinations="none"), aw.PCADetector(n_components=2))
>>> model = model.fit(baseline).calibrate([simulate_capture("short_fast", seed=s) for s in (1, 2, 3)])
>>> verdict = model.assess(simulate_capture("short_fast", seed=4))
>>> verdict.distance <= verdict.threshold
True
"""

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
from axiswatch._mechanics import MechanicsStage
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
    "MechanicsStage",
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


# Reprs and tracebacks show the public path (``axiswatch.HealthModel``, not the private module);
# pickles then refer to it too, which every class listed here can be loaded from.
for _name in __all__:
    _public = globals()[_name]
    _library = tuple(f"{__name__}.{part}" for part in ("_", "indicators.", "paper."))
    if isinstance(_public, type) and _public.__module__.startswith(_library):
        _public.__module__ = __name__
del _name, _public, _library
