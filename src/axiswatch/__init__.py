"""axiswatch: predictive maintenance of robot axes that does not cry wolf when the task changes.

A capture of one axis (position, speed, torque) becomes |STFT| features; a detector compares them
with a healthy baseline (PCA subspace distance, or the paper's Low Rank Alignment); a half-Laplace
fit of healthy distances gives the alarm threshold.

>>> import axiswatch as aw
>>> day1, *rest = aw.lab_dataset(seed=0)
>>> spec = aw.FeatureSpec(combinations="none")
>>> model = aw.HealthModel(spec, aw.LRADetector()).fit(day1.capture)
>>> model = model.calibrate([d.capture for d in rest if not d.anomalous])
>>> [(d.label, model.assess(d.capture).alarm) for d in rest][:4]
[('O1', False), ('O1', False), ('A', True), ('O1', False)]
"""

from axiswatch._alignment import (
    LowRankBasis,
    LRAResult,
    low_rank_basis,
    low_rank_representation,
    lra_dense,
    lra_embedding,
    lra_structured,
)
from axiswatch._attribution import (
    attribute,
    difference_spectrogram,
    pca_contributions,
    plot_difference_spectrogram,
)
from axiswatch._calibration import HalfLaplaceFit, fit_half_laplace, half_laplace_threshold
from axiswatch._capture import (
    DEFAULT_SIGNALS,
    Capture,
    as_capture,
    capture_to_frame,
    read_capture,
    write_capture,
)
from axiswatch._datasets import (
    NOMINAL_RATE_HZ,
    Segment,
    default_data_dir,
    read_dataset,
    read_recording,
)
from axiswatch._detectors import BaselineDetector, IndicatorDetector, LRADetector, PCADetector
from axiswatch._domain_adaptation import (
    CORALDetector,
    EnergyDetector,
    SubspaceAlignmentDetector,
    energy_distance,
)
from axiswatch._experiments import alarm_summary
from axiswatch._features import (
    Features,
    FeatureSpec,
    extract_features,
    features_from_signals,
    stft_features,
)
from axiswatch._fleet import FleetFile, discover_fleet, parse_capture_time
from axiswatch._indicators import (
    STATES,
    AxisModel,
    FeatureStage,
    OrderStage,
    ResidualStage,
    StateStage,
    StftStage,
    fit_axis_model,
    operating_states,
)
from axiswatch._ledger import rebaseline
from axiswatch._mechanics import (
    COLUMNS,
    INDICATORS,
    MECHANICS_SCALES,
    MECHANICS_TASK_CHANGE_SCALE,
    MechanicsStage,
    angle_locked_f,
    bearing_lines,
    line_ratio,
    moves,
    reversal_bursts,
    viscous_friction,
)
from axiswatch._model import Assessment, HealthModel
from axiswatch._monitor import MonitorSummary, monitor_fleet
from axiswatch._paired import (
    DEVELOPMENT_DESIGN,
    PairedDesign,
    development_scales,
    development_task_change_scale,
    paired_evaluation,
    select_default,
)
from axiswatch._parallel import parallel_map
from axiswatch._plotting import plot_distance_trend
from axiswatch._preprocessing import (
    align_phase,
    integer_factor,
    phase_lag,
    resample_capture,
    upsample_pchip,
)
from axiswatch._realdata import (
    CWRU_FEATURES,
    GEARBOX_FEATURES,
    REAL_DATA_METHODS,
    bearing_line_readings,
    evaluate_dataset,
    plot_distances,
    segment_distances,
    summarize_distances,
    summarize_line_readings,
)
from axiswatch._report import write_report
from axiswatch._results import fleet_results, fleet_summary
from axiswatch._robot import (
    DEFAULT_FLEET_FAULTS,
    TASKS,
    Fault,
    FleetFault,
    Task,
    simulate_capture,
    simulate_fleet,
)
from axiswatch._scoring import MonitorConfig
from axiswatch._simulate import LAB_DAYS, LabDay, lab_dataset
from axiswatch._store import Store
from axiswatch.exceptions import (
    AxiswatchError,
    CalibrationError,
    CaptureError,
    DataNotFoundError,
    StoreError,
)

__version__ = "0.1.0"

__all__ = [
    "Assessment",
    "AxisModel",
    "AxiswatchError",
    "BaselineDetector",
    "COLUMNS",
    "CORALDetector",
    "CWRU_FEATURES",
    "CalibrationError",
    "Capture",
    "CaptureError",
    "DEFAULT_FLEET_FAULTS",
    "DEFAULT_SIGNALS",
    "DEVELOPMENT_DESIGN",
    "DataNotFoundError",
    "EnergyDetector",
    "Fault",
    "FeatureSpec",
    "FeatureStage",
    "Features",
    "FleetFault",
    "FleetFile",
    "GEARBOX_FEATURES",
    "HalfLaplaceFit",
    "HealthModel",
    "INDICATORS",
    "IndicatorDetector",
    "LAB_DAYS",
    "LRADetector",
    "LRAResult",
    "LabDay",
    "LowRankBasis",
    "MECHANICS_SCALES",
    "MECHANICS_TASK_CHANGE_SCALE",
    "MechanicsStage",
    "MonitorConfig",
    "MonitorSummary",
    "NOMINAL_RATE_HZ",
    "OrderStage",
    "PCADetector",
    "PairedDesign",
    "REAL_DATA_METHODS",
    "ResidualStage",
    "STATES",
    "Segment",
    "StateStage",
    "StftStage",
    "Store",
    "StoreError",
    "SubspaceAlignmentDetector",
    "TASKS",
    "Task",
    "alarm_summary",
    "align_phase",
    "angle_locked_f",
    "as_capture",
    "attribute",
    "bearing_line_readings",
    "bearing_lines",
    "capture_to_frame",
    "default_data_dir",
    "development_scales",
    "development_task_change_scale",
    "difference_spectrogram",
    "discover_fleet",
    "energy_distance",
    "evaluate_dataset",
    "extract_features",
    "features_from_signals",
    "fit_axis_model",
    "fit_half_laplace",
    "fleet_results",
    "fleet_summary",
    "half_laplace_threshold",
    "integer_factor",
    "lab_dataset",
    "line_ratio",
    "low_rank_basis",
    "low_rank_representation",
    "lra_dense",
    "lra_embedding",
    "lra_structured",
    "monitor_fleet",
    "moves",
    "operating_states",
    "paired_evaluation",
    "parallel_map",
    "parse_capture_time",
    "pca_contributions",
    "phase_lag",
    "plot_difference_spectrogram",
    "plot_distance_trend",
    "plot_distances",
    "read_capture",
    "read_dataset",
    "read_recording",
    "rebaseline",
    "resample_capture",
    "reversal_bursts",
    "segment_distances",
    "select_default",
    "simulate_capture",
    "simulate_fleet",
    "stft_features",
    "summarize_distances",
    "summarize_line_readings",
    "upsample_pchip",
    "viscous_friction",
    "write_capture",
    "write_report",
]
