"""axiswatch_lab: the research around axiswatch, a distribution of its own (``lab/``).

The paper's experiments (lab ROC, Robot A and B), the paired evaluation and the development
protocol, the real-data studies, the research stages and detectors, and the former default
``mechanics`` (:class:`MechanicsStage`; the monitor's ``--method mechanics``). The one-shot
studies are in :mod:`axiswatch_lab.studies`. Commands: ``axiswatch-lab`` or
``axiswatch experiment``. It uses the product's public names; the internals its studies take
apart come through ``axiswatch_lab._product``. The product never imports it.
"""

from axiswatch_lab._domain_adaptation import (
    CORALDetector,
    EnergyDetector,
    SubspaceAlignmentDetector,
    energy_distance,
)
from axiswatch_lab._experiments import (
    alarm_summary,
)
from axiswatch_lab._indicators import (
    STATES,
    AxisModel,
    OrderStage,
    ResidualStage,
    StateStage,
    fit_axis_model,
    operating_states,
)
from axiswatch_lab._mechanics import (
    MechanicsStage,
    explain_indicators,
    mechanics_model,
)
from axiswatch_lab._paired import (
    DEVELOPMENT_DESIGN,
    PairedDesign,
    development_scales,
    development_task_change_scale,
    paired_evaluation,
    select_default,
)
from axiswatch_lab._plots import (
    plot_paired,
    plot_robot_study,
    plot_roc,
)
from axiswatch_lab._realdata import (
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
from axiswatch_lab._transfer import (
    TransferDesign,
    real_data_transfer,
    robot_transfer,
    transfer_study,
)

__all__ = [
    "AxisModel",
    "CORALDetector",
    "CWRU_FEATURES",
    "DEVELOPMENT_DESIGN",
    "EnergyDetector",
    "GEARBOX_FEATURES",
    "MechanicsStage",
    "OrderStage",
    "PairedDesign",
    "REAL_DATA_METHODS",
    "ResidualStage",
    "STATES",
    "StateStage",
    "SubspaceAlignmentDetector",
    "TransferDesign",
    "alarm_summary",
    "bearing_line_readings",
    "development_scales",
    "development_task_change_scale",
    "energy_distance",
    "evaluate_dataset",
    "explain_indicators",
    "fit_axis_model",
    "mechanics_model",
    "operating_states",
    "paired_evaluation",
    "plot_distances",
    "plot_paired",
    "plot_robot_study",
    "plot_roc",
    "real_data_transfer",
    "robot_transfer",
    "segment_distances",
    "select_default",
    "summarize_distances",
    "summarize_line_readings",
    "transfer_study",
]


# Reprs and tracebacks show the public path (``axiswatch.HealthModel``, not the private module);
# pickles then refer to it too, which every class listed here can be loaded from.
for _name in __all__:
    _public = globals()[_name]
    if isinstance(_public, type) and _public.__module__.startswith(f"{__name__}._"):
        _public.__module__ = __name__
del _name, _public
