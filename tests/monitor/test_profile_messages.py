"""A malformed axis profile in the fleet folder: its captures' one-line rejections name the
profile relative to the fleet folder, as they name the capture, with the key and what it expects."""

from __future__ import annotations

from pathlib import Path

import pytest

from axiswatch.datasets._robot_fleet import simulate_fleet
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.store import Store
from tests.conftest import settle

CAPTURE = "robot01/axis1/2026-03-01.parquet"


@pytest.mark.parametrize(
    ("where", "text", "expected"),
    [
        (
            "robot01/robot.toml",
            'resample_irregular = "no"\n',
            f"{CAPTURE}: robot01/robot.toml: 'resample_irregular' must be true or false "
            "(unquoted); got 'no' (str).",
        ),
        (
            "robot01/axis1/axis.toml",
            '[units]\nposition = "gon"\n',
            f"{CAPTURE}: axis profile robot01/axis1/axis.toml: position unit must be one of "
            "['rad', 'deg', 'rev', 'm', 'mm', 'counts']. Got 'gon' instead.",
        ),
        (
            "robot01/axis1/robot.toml",  # misplaced: the message names where it would be read
            'name = "x"\n',
            f"{CAPTURE}: robot01/axis1/robot.toml: an axis profile is not read under this name "
            "here; expected robot01/axis1/axis.toml (this axis), robot01/robot.toml (the robot's "
            "axes) or axiswatch.toml (the fleet).",
        ),
    ],
)
def test_a_malformed_profile_is_named_relative_to_the_fleet_folder(
    tmp_path: Path, where: str, text: str, expected: str
) -> None:
    # Before: "robot01/axis1/2026-03-01.parquet: <absolute>/fleet/robot01/robot.toml: ...", the
    # profile by its absolute path (only the capture's own path was made relative).
    root = tmp_path / "fleet"
    simulate_fleet(
        root, n_robots=1, n_axes=1, n_days=2, task_change_days=(), faults=[], duration_s=0.5
    )
    (root / where).write_text(text, encoding="utf-8")
    settle(root)
    with Store(tmp_path / "s.db") as store:
        summary = monitor_fleet(root, store, MonitorConfig(method="pca"), settle_s=0)
    assert summary.rejected[0] == expected
    assert not any(str(tmp_path) in line for line in summary.rejected)
