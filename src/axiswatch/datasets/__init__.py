"""Data: the paper's lab data set, the robot-axis simulator and simulated fleets, recorded data.

As ``sklearn.datasets``: everything here produces or reads captures; nothing here decides health.
"""

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
    DEFAULT_FLEET_FAULTS,
    TASKS,
    Fault,
    FleetFault,
    Task,
    simulate_capture,
    simulate_fleet,
)

__all__ = [
    "DEFAULT_FLEET_FAULTS",
    "Fault",
    "FleetFault",
    "LAB_DAYS",
    "LabDay",
    "NOMINAL_RATE_HZ",
    "Segment",
    "TASKS",
    "Task",
    "default_data_dir",
    "lab_dataset",
    "read_dataset",
    "read_recording",
    "simulate_capture",
    "simulate_fleet",
]
