"""A simulated fleet: robots whose axes run pick-and-place tasks day by day, some with faults.

Each axis is :func:`simulate_capture` of the axis simulator; the files follow the monitor's
fleet layout.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import date, timedelta
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from axiswatch._capture import write_capture
from axiswatch._profiles import FLEET_PROFILE
from axiswatch.datasets._robot import (
    NOMINAL_AXIS,
    TASKS,
    AxisSpec,
    Fault,
    FaultKind,
    simulate_capture,
)

__all__ = ["DEFAULT_FLEET_FAULTS", "FleetFault", "fleet_profile_toml", "simulate_fleet"]


@dataclass(frozen=True)
class FleetFault:
    """A fault that develops on one axis of a simulated fleet.

    Its severity is 0 before ``onset_day`` and grows linearly to ``final_severity`` on the last day.

    Parameters
    ----------
    robot, axis : str
        Folder names, e.g. ``"robot02"``, ``"axis1"``.
    kind : {"backlash", "friction", "tooth", "bearing"}
    onset_day : int
        First day (1-based) with a non-zero severity.
    final_severity : float in (0, 1], default=1.0
    """

    robot: str
    axis: str
    kind: FaultKind
    onset_day: int
    final_severity: float = 1.0

    def severity(self, day: int, n_days: int) -> float:
        """Severity on ``day`` (1-based) of an ``n_days`` run."""
        if day < self.onset_day:
            return 0.0
        return self.final_severity * (day - self.onset_day + 1) / (n_days - self.onset_day + 1)


#: The default fleet's faults: a bearing defect and a friction increase over the last days.
DEFAULT_FLEET_FAULTS: tuple[FleetFault, ...] = (
    FleetFault("robot02", "axis1", "bearing", onset_day=20),
    FleetFault("robot03", "axis2", "friction", onset_day=24),
)


def simulate_fleet(
    root: str | Path,
    *,
    n_robots: int = 3,
    n_axes: int = 2,
    n_days: int = 30,
    start_date: str = "2026-03-01",
    task_change_days: Sequence[int] = (15,),
    faults: Sequence[FleetFault] | None = None,
    seed: int = 0,
    file_format: Literal["parquet", "csv"] = "parquet",
    duration_s: float = 3.0,
    profile: bool = True,
) -> pd.DataFrame:
    """Simulate a fleet of robot axes, one capture a day, and write it in the fleet layout.

    Files: ``ROOT/<robot>/<axis>/<YYYY-MM-DD>.<file_format>`` (the project's capture format, via
    :func:`~axiswatch.write_capture`; robots ``robot01``, ..., axes ``axis1``, ...), the labels
    in ``ROOT/labels.csv`` and, with ``profile``, the fleet's axis profile
    ``ROOT/axiswatch.toml`` (:func:`fleet_profile_toml`: the simulated axis's kinematics, as a
    service engineer would copy them from the datasheet). Axis ``j`` (counting over the fleet) starts on task ``j`` of
    :data:`TASKS` (cyclically) and moves on to the next task on each of ``task_change_days``.
    Every capture starts at a random phase of the task cycle.

    Parameters
    ----------
    root : str or Path
        Output folder (created if needed).
    n_robots, n_axes, n_days : int, default=3, 2, 30
    start_date : str, default="2026-03-01"
        ISO date of day 1.
    task_change_days : sequence of int, default=(15,)
        Days (1-based) on which every axis changes task.
    faults : sequence of FleetFault, optional
        Default: those of :data:`DEFAULT_FLEET_FAULTS` whose robot and axis exist in the fleet.
    seed : int, default=0
    file_format : {"parquet", "csv"}, default="parquet"
    duration_s : float, default=3.0
        Length of each capture.
    profile : bool, default=True
        Write ``ROOT/axiswatch.toml``.

    Returns
    -------
    DataFrame
        The labels, one row per capture: ``robot``, ``axis``, ``capture`` (the file name without
        extension), ``date``, ``task``, ``fault`` (``"none"`` when healthy), ``severity``.

    Examples
    --------
    >>> import tempfile
    >>> labels = simulate_fleet(tempfile.mkdtemp(), n_robots=1, n_axes=1, n_days=3,
    ...                         duration_s=0.5)
    >>> labels[["robot", "axis", "capture", "task", "fault"]].iloc[0].tolist()
    ['robot01', 'axis1', '2026-03-01', 'short_fast', 'none']
    """
    for name, value, low in (
        ("n_robots", n_robots, 1),
        ("n_axes", n_axes, 1),
        ("n_days", n_days, 1),
    ):
        if not (isinstance(value, int) and value >= low):
            raise ValueError(
                f"The '{name}' parameter must be an int >= {low}. Got {value!r} instead."
            )
    if file_format not in ("parquet", "csv"):
        raise ValueError(
            f"The 'file_format' parameter must be 'parquet' or 'csv'. Got {file_format!r} instead."
        )
    try:
        first_day = date.fromisoformat(start_date)
    except (TypeError, ValueError):
        raise ValueError(
            f"The 'start_date' parameter must be an ISO date such as '2026-03-01'. "
            f"Got {start_date!r} instead."
        ) from None
    robots = [f"robot{r + 1:02d}" for r in range(n_robots)]
    axes = [f"axis{a + 1}" for a in range(n_axes)]
    if faults is None:
        faults = [f for f in DEFAULT_FLEET_FAULTS if f.robot in robots and f.axis in axes]
    schedule: dict[tuple[str, str], FleetFault] = {}
    for fault in faults:
        if fault.robot not in robots or fault.axis not in axes:
            raise ValueError(
                f"Fault on {fault.robot}/{fault.axis} names an axis outside the fleet "
                f"(robots {robots[0]}..{robots[-1]}, axes {axes[0]}..{axes[-1]})."
            )
        schedule[(fault.robot, fault.axis)] = fault
    root = Path(root)
    task_names = list(TASKS)
    children = np.random.SeedSequence(seed).spawn(n_robots * n_axes)
    rows = []
    for j, (robot, axis) in enumerate(itertools.product(robots, axes)):
        folder = root / robot / axis
        folder.mkdir(parents=True, exist_ok=True)
        rng = np.random.default_rng(children[j])
        developing = schedule.get((robot, axis))
        for day in range(1, n_days + 1):
            task = task_names[(j + sum(day >= c for c in task_change_days)) % len(task_names)]
            severity = developing.severity(day, n_days) if developing is not None else 0.0
            today = Fault(developing.kind, severity) if developing and severity > 0 else None
            stamp = (first_day + timedelta(days=day - 1)).isoformat()
            capture = simulate_capture(
                task,
                fault=today,
                duration_s=duration_s,
                seed=rng,
                metadata={"robot": robot, "axis": axis},
            )
            write_capture(capture, folder / f"{stamp}.{file_format}")
            rows.append(
                {
                    "robot": robot,
                    "axis": axis,
                    "capture": stamp,
                    "date": stamp,
                    "task": task,
                    "fault": today.kind if today is not None else "none",
                    "severity": severity,
                }
            )
    labels = pd.DataFrame(rows)
    labels.to_csv(root / "labels.csv", index=False)
    if profile:
        (root / FLEET_PROFILE).write_text(fleet_profile_toml(), encoding="utf-8")
    return labels


def fleet_profile_toml(spec: AxisSpec = NOMINAL_AXIS, name: str = "simulated-axis") -> str:
    """The axis profile (TOML) of a simulated axis: its name and kinematics.

    The gear ratio, the stage of the gear that may lose a tooth and the bearing's inner-race
    order of ``spec``; read back by :meth:`~axiswatch.AxisProfile.from_toml`.

    Examples
    --------
    >>> print(fleet_profile_toml())
    name = "simulated-axis"
    [kinematics]
    gear_ratio = 100.0
    [kinematics.gear_stages]
    intermediate = 5.0
    [kinematics.bearing_orders]
    motor_inner_race = 5.43
    <BLANKLINE>
    """
    return (
        f'name = "{name}"\n[kinematics]\ngear_ratio = {float(spec.gear_ratio)!r}\n'
        f"[kinematics.gear_stages]\nintermediate = {float(spec.tooth_stage_ratio)!r}\n"
        f"[kinematics.bearing_orders]\nmotor_inner_race = {float(spec.bearing_order)!r}\n"
    )
