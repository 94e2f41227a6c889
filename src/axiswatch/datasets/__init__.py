"""Data: the paper's lab data set, the robot-axis simulator and simulated fleets, recorded data.

As ``sklearn.datasets``: everything here produces or reads captures; nothing here decides health.
"""

from axiswatch.datasets._family import (
    DEVELOPMENT_ROBOTS,
    HELD_OUT_ROBOTS,
    SimulatedRobot,
    draw_robot,
    draw_unit,
)
from axiswatch.datasets._lab import (
    LAB_DAYS,
    LabDay,
    lab_dataset,
)
from axiswatch.datasets._recorded import (
    NOMINAL_RATE_HZ,
    Segment,
    default_data_dir,
    read_dataset,
    read_recording,
)
from axiswatch.datasets._robot import (
    FAULT_KINDS,
    NOMINAL_AXIS,
    TASKS,
    AxisSpec,
    Fault,
    FaultKind,
    Task,
    simulate_capture,
)
from axiswatch.datasets._robot_fleet import (
    DEFAULT_FLEET_FAULTS,
    FleetFault,
    fleet_profile_toml,
    simulate_fleet,
)

__all__ = [
    "AxisSpec",
    "DEFAULT_FLEET_FAULTS",
    "DEVELOPMENT_ROBOTS",
    "FAULT_KINDS",
    "Fault",
    "FaultKind",
    "FleetFault",
    "HELD_OUT_ROBOTS",
    "LAB_DAYS",
    "LabDay",
    "NOMINAL_AXIS",
    "NOMINAL_RATE_HZ",
    "Segment",
    "SimulatedRobot",
    "TASKS",
    "Task",
    "default_data_dir",
    "draw_robot",
    "draw_unit",
    "fleet_profile_toml",
    "lab_dataset",
    "read_dataset",
    "read_recording",
    "simulate_capture",
    "simulate_fleet",
]


# Reprs and tracebacks show the public path (``axiswatch.HealthModel``, not the private module);
# pickles then refer to it too, which every class listed here can be loaded from.
for _name in __all__:
    _public = globals()[_name]
    if isinstance(_public, type) and _public.__module__.startswith(f"{__name__}._"):
        _public.__module__ = __name__
del _name, _public
