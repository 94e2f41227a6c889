"""The operating-mode scenarios in time order, as one table (``axiswatch experiment modes``).

The scenarios are the studies' own: the mode library replayed day by day
(:mod:`~axiswatch_lab.studies.mode_library_vs_default`) and the monitor's ``indicators`` with
and without ``--modes`` (:mod:`~axiswatch_lab.studies.through_the_monitor`).
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from axiswatch.datasets import FaultKind, SimulatedRobot, draw_robot
from axiswatch_lab.studies.mode_library_vs_default import (
    FAULT_LAG,
    FAULTS,
    cross_task,
    fault_at_change,
    growing,
    robot_a,
    within_mode,
)
from axiswatch_lab.studies.through_the_monitor import monitor_real_data, monitor_robot

__all__ = ["CASES", "ModesDesign", "modes_experiment", "robot_rows", "summarize"]

#: The scenarios, in the order they are run and listed.
CASES: tuple[str, ...] = (
    "robot-a",
    "growing",
    "fault-at-change",
    "within",
    "cross-task",
    "monitor",
    "real-data",
)
#: Tasks of the ``within`` and ``cross-task`` cases.
_TASKS = 4
#: The monitor's variants compared, and their names in the table.
_METHODS = {"indicators": "default", "indicators-modes": "modes"}
_COUNTS = ("detected", "faulty", "false_alarms", "healthy", "no_verdict")


@dataclass(frozen=True)
class ModesDesign:
    """The scenarios' sizes; the defaults are those of docs/evaluation.md.

    Parameters
    ----------
    robot_a_days : int, default 190
        Robot A's daily captures: tasks 0-3 in quarters, task 1 at +5 kg for the last tenth.
    growing_days : int, default 70
        Days of a growing fault's run: the task changes at 2/7 of it, the fault starts at 3/7
        (days 20 and 30 of 70), or ``fault_lag`` days after the change.
    faults : tuple of str, default all four
        The faults grown in the library's runs.
    monitor_faults : tuple of str, default ("friction", "backlash")
        One fault run through the monitor per kind, at severity 0.6 on the axis's own task.
    fault_lag : int, default :data:`FAULT_LAG`
        Days from the mode change to the fault's onset in ``fault-at-change``.
    teach : bool, default False
        Also replay the library's runs with an engineer who teaches (``ack --task-changed``)
        an alarm within 5 days of a change they made.
    test_captures : int, default 6
        Healthy and faulty captures per task and fault in ``within`` and ``cross-task``.
    """

    robot_a_days: int = 190
    growing_days: int = 70
    faults: tuple[FaultKind, ...] = FAULTS
    monitor_faults: tuple[str, ...] = ("friction", "backlash")
    fault_lag: int = FAULT_LAG
    teach: bool = False
    test_captures: int = 6

    def change_and_onset(self) -> tuple[int, int]:
        """The growing runs' task-change day and fault onset."""
        return round(self.growing_days * 2 / 7), round(self.growing_days * 3 / 7)


def _row(
    scenario: str,
    method: str,
    robot: str,
    *,
    first: float = float("nan"),
    auroc: float = float("nan"),
    **counts: float,
) -> dict[str, object]:
    row: dict[str, object] = {"scenario": scenario, "method": method, "robot": robot}
    row.update({name: round(counts.get(name, 0)) for name in _COUNTS})
    row["first_alarm_severity"] = first
    row["auroc"] = auroc
    return row


def _separation_rows(
    robot: SimulatedRobot, design: ModesDesign, cases: Sequence[str]
) -> list[dict[str, object]]:
    """Within a known mode (every task learned, nothing learned while scored), and the paper's
    cross-task case (a single-task baseline, other tasks shuffled and learned as they come):
    each fault's AUROC against healthy captures, its detection, and the healthy alarms."""
    rows: list[dict[str, object]] = []
    faults = design.faults
    for case, scenario, n_tasks, replays in (
        ("within", "within mode", _TASKS, 1),
        ("cross-task", "cross-task", _TASKS - 1, len(faults)),
    ):
        if case not in cases:
            continue
        if case == "within":
            found = within_mode(robot, design.test_captures, _TASKS, faults)
            far = found["far_library"]
        else:
            found = cross_task(robot, design.test_captures, _TASKS, faults)
            far = found["far"]
        n = design.test_captures * n_tasks
        for fault in faults:
            rows.append(
                _row(
                    f"{scenario} {fault}",
                    "modes",
                    robot.name,
                    auroc=found[f"auroc_{fault}"],
                    detected=found[f"dr_{fault}"] * n,
                    faulty=n,
                )
            )
        rows.append(
            _row(
                f"{scenario} healthy",
                "modes",
                robot.name,
                false_alarms=far * n * replays,
                healthy=n * replays,
            )
        )
    return rows


def _growing_row(
    scenario: str, robot: SimulatedRobot, found: dict[str, float]
) -> dict[str, object]:
    return _row(
        scenario,
        "modes",
        robot.name,
        first=found["first_alarm_severity"],
        detected=found["detected"],
        faulty=found["captures_past"],
        false_alarms=found["false_alarms"],
        healthy=found["captures_before"],
    )


def _library_rows(
    robot: SimulatedRobot, design: ModesDesign, cases: Sequence[str], teach: bool
) -> list[dict[str, object]]:
    """Robot A and the growing faults, replayed through the mode library (and Robot A through
    the default, which neither learns nor is taught)."""
    rows: list[dict[str, object]] = []
    suffix = ", taught" if teach else ""
    if "robot-a" in cases:
        a = robot_a(robot, design.robot_a_days, teach=teach)
        alarms = a["library_alarm_days"]
        rows.append(
            _row(
                f"robot A{suffix}",
                "modes",
                robot.name,
                false_alarms=alarms,
                healthy=design.robot_a_days,
            )
        )
        if not teach:
            rows.append(
                _row(
                    "robot A",
                    "default",
                    robot.name,
                    false_alarms=a["default_alarm_days"],
                    healthy=a["default_scored_days"],
                    no_verdict=a["default_not_scored"],
                )
            )
    change, onset = design.change_and_onset()
    days = design.growing_days
    for fault in design.faults if "growing" in cases else ():
        found = growing(robot, fault, onset, days, change=change, teach=teach)
        rows.append(_growing_row(f"growing {fault}{suffix}", robot, found))
    for fault in design.faults if "fault-at-change" in cases else ():
        found = fault_at_change(
            robot, fault, days, change=change, lag=design.fault_lag, teach=teach
        )
        rows.append(_growing_row(f"fault at change {fault}{suffix}", robot, found))
    return rows


def _monitor_row(found: dict[str, object], scenario: str, robot: str) -> dict[str, object]:
    """One run of :mod:`through_the_monitor` in the table's terms."""
    counts = {k: float(v) for k, v in found.items() if isinstance(v, int | float)}
    answered = counts["scored"] + counts["baselines"] + counts["rejected"]
    return _row(
        scenario,
        _METHODS[str(found["method"])],
        robot,
        detected=counts.get("detected", counts.get("faulty_axis_over", 0)),
        faulty=counts.get("faulty_monitored", 0),
        false_alarms=counts.get("false_alarms", 0),
        healthy=counts.get("healthy_monitored", 0),
        no_verdict=counts["files"] - answered,
        auroc=counts.get("auroc", float("nan")),
    )


def robot_rows(
    seed: int, design: ModesDesign, cases: Sequence[str], scratch: Path
) -> list[dict[str, object]]:
    """Every robot scenario of ``cases`` on robot ``seed``: one row per scenario and method."""
    robot = draw_robot(seed)
    rows = _library_rows(robot, design, cases, teach=False)
    rows += _separation_rows(robot, design, cases)
    if design.teach:
        rows += _library_rows(robot, design, cases, teach=True)
    if "monitor" in cases:
        for found in monitor_robot(seed, scratch, tuple(_METHODS), design.monitor_faults):
            kind = str(found["scenario"])
            kind = {"healthy": "healthy", "fault": "friction"}.get(kind, kind.partition(":")[2])
            rows.append(_monitor_row(found, f"monitor {kind}", robot.name))
    return rows


def summarize(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per scenario and method: the counts summed over robots, their rates, the robots
    with no false alarm, the mean severity at the first alarm, the fault runs that alarmed
    before their breakdown and the mean AUROC."""
    groups = rows.groupby(["scenario", "method"], sort=False)
    table = groups[list(_COUNTS)].sum()
    table.insert(0, "robots", groups.size())
    faulty = table["faulty"].where(table["faulty"] > 0)
    healthy = table["healthy"].where(table["healthy"] > 0)
    table.insert(1, "detection", table["detected"] / faulty)
    table.insert(4, "false_alarm_rate", table["false_alarms"] / healthy)
    table.insert(7, "robots_quiet", groups["false_alarms"].apply(lambda s: int((s == 0).sum())))
    table["first_alarm_severity"] = groups["first_alarm_severity"].mean()
    # A fault run alarms before its breakdown (severity 1 on its last day).
    table["alarmed_before_breakdown"] = groups["first_alarm_severity"].apply(
        lambda s: int((s < 1.0).sum())
    )
    table["auroc"] = groups["auroc"].mean()
    return table.reset_index()


def modes_experiment(
    seeds: Sequence[int],
    design: ModesDesign,
    cases: Sequence[str] = CASES,
    data_root: Path | None = None,
) -> pd.DataFrame:
    """Every scenario of ``cases`` on each robot of ``seeds``, then the real data under
    ``data_root`` (sets that are absent skipped): one row per robot, scenario and method."""
    rows: list[dict[str, object]] = []
    with tempfile.TemporaryDirectory() as folder:
        scratch = Path(folder)
        for seed in seeds:
            rows += robot_rows(seed, design, cases, scratch)
        if "real-data" in cases and data_root is not None:
            for found in monitor_real_data(data_root, scratch, tuple(_METHODS)):
                name = str(found["dataset"])
                scenario = "real linear axis" if name.startswith("genesis") else "real hydraulic"
                rows.append(_monitor_row(found, scenario, name))
    columns = ["scenario", "method", "robot", *_COUNTS, "first_alarm_severity", "auroc"]
    return pd.DataFrame(rows, columns=columns)
