"""A profile says which side of the gear a signal is measured on, or ignores a column."""

from __future__ import annotations

import json
import math
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
from axiswatch._profiles import AxisProfile
from axiswatch.datasets._robot_fleet import fleet_profile_toml, simulate_fleet
from axiswatch.exceptions import CaptureError, ProfileError
from axiswatch.indicators._readings import read_indicators
from tests._cli import run
from tests.conftest import settle

GEAR_RATIO = 100.0  # the simulated axis's (fleet_profile_toml)
LINES = ("tooth_lines:intermediate", "bearing_lines:motor_inner_race")


@pytest.fixture(scope="module")
def fleets(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """One simulated axis, 7 daily captures of 1 s: as simulated (the speed at the output), and
    as a drive that logs its motor's speed (the speed times the gear ratio) exports it."""
    output = tmp_path_factory.mktemp("output") / "fleet"
    simulate_fleet(
        output, n_robots=1, n_axes=1, n_days=7, task_change_days=(), faults=[], duration_s=1.0
    )
    motor = tmp_path_factory.mktemp("motor") / "fleet"
    shutil.copytree(output, motor)
    for path in sorted(motor.rglob("*.parquet")):
        capture = aw.read_capture(path)
        signals = {**capture.signals, "speed": capture.signals["speed"] * GEAR_RATIO}
        aw.write_capture(aw.Capture(signals, capture.rates_hz, metadata=capture.metadata), path)
    settle(output)
    settle(motor)
    return output, motor


def _profile(root: Path, extra: str = "", above: str = "") -> Path:
    path = root / "axiswatch.toml"
    path.write_text(above + fleet_profile_toml() + extra, encoding="utf-8")
    return path


def _copy(fleet: Path, tmp_path: Path) -> Path:
    root = tmp_path / "fleet"
    shutil.copytree(fleet, root)
    settle(root)
    return root


def test_a_motor_side_speed_is_read_at_the_output(
    fleets: tuple[Path, Path], tmp_path: Path
) -> None:
    output, motor = fleets
    first = "robot01/axis1/2026-03-01.parquet"
    plain = AxisProfile.from_dict(tomllib.loads(fleet_profile_toml()))
    sided = AxisProfile.from_toml(_profile(tmp_path, '[sides]\nspeed = "motor"\n'))
    assert sided.sides == {"speed": "motor"}
    truth = aw.read_capture(output / first, profile=plain)
    read = aw.read_capture(motor / first, profile=sided)
    np.testing.assert_allclose(read.signals["speed"], truth.signals["speed"], rtol=1e-12)
    np.testing.assert_array_equal(read.signals["position"], truth.signals["position"])
    lines = read_indicators(read, **sided.kinematics()).values
    expected = read_indicators(truth, **plain.kinematics()).values
    for name in LINES:
        assert math.isfinite(lines[name])
        assert lines[name] == pytest.approx(expected[name], rel=1e-6)


def test_a_motor_side_position_is_read_at_the_output(tmp_path: Path) -> None:
    t = np.arange(200) / 100.0
    frame = pd.DataFrame({"time": t, "position": GEAR_RATIO * np.sin(t), "torque": np.cos(t)})
    path = tmp_path / "c.csv"
    frame.to_csv(path, index=False)
    profile = AxisProfile.from_dict(
        {"kinematics": {"gear_ratio": GEAR_RATIO}, "sides": {"position": "motor"}}
    )
    capture = aw.read_capture(path, profile=profile)
    np.testing.assert_allclose(capture.signals["position"], np.sin(t), rtol=1e-12)


def test_an_ignored_speed_is_derived_from_the_position(tmp_path: Path) -> None:
    t = np.arange(200) / 100.0
    frame = pd.DataFrame(
        {"time": t, "position": np.sin(t), "speed": 99.0 * np.cos(t), "torque": np.cos(t)}
    )
    path = tmp_path / "c.csv"
    frame.to_csv(path, index=False)
    capture = aw.read_capture(path, profile=AxisProfile.from_dict({"ignore": ["speed"]}))
    assert capture.names == ("position", "torque")


def test_an_ignored_column_s_units_row_is_not_checked(tmp_path: Path) -> None:
    # A speed in rpm is refused when read; ignored, it is not read at all.
    t = np.arange(40) / 100.0
    frame = pd.DataFrame({"time": t, "position": np.sin(t), "speed": t, "torque": np.cos(t)})
    lines = frame.to_csv(index=False, sep=";", decimal=",").splitlines()
    lines.insert(1, "s;rad;rpm;Nm")
    path = tmp_path / "c.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(CaptureError, match="gives 'rpm' for column 'speed'"):
        aw.read_capture(path)
    capture = aw.read_capture(path, profile=AxisProfile.from_dict({"ignore": ["speed"]}))
    assert capture.names == ("position", "torque")


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (
            {"kinematics": {"gear_ratio": 100.0}, "sides": {"speed": "rotor"}},
            r"p\.toml \[sides\]: speed must be \"motor\" or \"output\" \(the side of the gear "
            r"it is measured on\); got 'rotor' \(str\)\.",
        ),
        (
            {"kinematics": {"gear_ratio": 100.0}, "sides": {"torque": "motor"}},
            r"p\.toml \[sides\]: unknown key\(s\) \['torque'\].*expected some of "
            r"\['position', 'speed'\]",
        ),
        (
            {"sides": {"speed": "motor"}},
            r"axis profile p\.toml: \[sides\] speed = \"motor\" needs \[kinematics\] gear_ratio "
            r"\(motor turns per output turn\) to read it at the output; got none\.",
        ),
        (
            {"ignore": "speed"},
            r"p\.toml: 'ignore' must be a list of roles, such as ignore = \[\"speed\"\]; "
            r"got 'speed' \(str\)\.",
        ),
        (
            {"ignore": ["torque"]},
            r"axis profile p\.toml: ignore lists 'torque'; expected some of "
            r"\['position', 'speed'\]",
        ),
        (
            {"ignore": ["position", "speed"]},
            r"axis profile p\.toml: ignore lists both 'position' and 'speed'; the indicators "
            r"need one of them\.",
        ),
    ],
)
def test_invalid_sides_and_ignore_are_refused_in_one_line(
    data: dict[str, object], expected: str
) -> None:
    with pytest.raises(ProfileError, match=expected) as raised:
        AxisProfile.from_dict(data, source="p.toml")
    assert "\n" not in str(raised.value)


def test_invalid_sides_given_in_python_are_refused() -> None:
    with pytest.raises(
        ProfileError,
        match=r"axis profile <memory>: sides maps 'torque' to 'motor'; expected "
        r"\['position', 'speed'\] mapped to one of \['motor', 'output'\]\.",
    ):
        AxisProfile(gear_ratio=GEAR_RATIO, sides={"torque": "motor"})
    assert AxisProfile(ignore=["speed"]).ignore == ("speed",)  # type: ignore[arg-type]


def test_ignore_below_a_table_is_named_as_misplaced(tmp_path: Path) -> None:
    path = _profile(tmp_path, '[sides]\nspeed = "motor"\nignore = ["speed"]\n')
    with pytest.raises(ProfileError, match=re.escape("'ignore' is a top-level key")):
        AxisProfile.from_toml(path)


@pytest.mark.parametrize("signal", ["position", "speed"])
def test_lines_of_signals_on_two_sides_of_the_gear_are_not_read_and_say_why(signal: str) -> None:
    # Before, a motor-side position gave lines at orders off by the gear ratio, and a motor-side
    # speed "needs its order below 900 Hz at 5.07e+03 motor rev/s".
    capture = awd.simulate_capture("short_fast", seed=0)
    signals = {**capture.signals, signal: capture.signals[signal] * GEAR_RATIO}
    kinematics = AxisProfile.from_dict(tomllib.loads(fleet_profile_toml())).kinematics()
    read = read_indicators(aw.Capture(signals, capture.rates_hz), **kinematics)
    as_simulated = read_indicators(capture, **kinematics)
    for name in LINES:
        assert math.isfinite(as_simulated.values[name])
        assert math.isnan(read.values[name])
        assert "declare the motor's in the axis profile's [sides]" in read.reasons[name]


# --- through the command line ------------------------------------------------------------------


def _monitor(root: Path, store: Path) -> tuple[int, str]:
    ran = run("monitor", root, "--store", store, "--no-progress")
    return ran.returncode, ran.stdout + ran.stderr


def _stored_lines(store: Path) -> list[dict[str, float]]:
    ran = run("results", "--store", store, "--format", "json")
    assert ran.returncode == 0, ran.stderr
    rows = [row for row in json.loads(ran.stdout) if row["role"] != "baseline"]
    assert len(rows) == 6  # the 5 calibration captures and the one after
    return [
        {name: row["details"]["indicators"].get(name, {}).get("value", math.nan) for name in LINES}
        for row in rows
    ]


def test_the_monitor_says_which_indicators_it_could_not_read(
    fleets: tuple[Path, Path], tmp_path: Path
) -> None:
    # A motor-side speed without [sides]: the lines cannot be read. Before, they were left out
    # without a word in the monitor's output.
    root = _copy(fleets[1], tmp_path)
    _profile(root)
    code, output = _monitor(root, tmp_path / "s.db")
    assert code in (0, 4), output  # read and scored; the verdict is not the point here
    said = output.split("Axes with indicators not read (1):\n", 1)[1].splitlines()[0]
    assert said.startswith("  robot01/axis1: ")
    assert "bearing_lines:motor_inner_race, tooth_lines:intermediate on 6 of 6 captures" in said
    assert "declare the motor's in the axis profile's [sides]" in said
    assert output.count("tooth_lines:intermediate") == 1  # once for the axis, not per capture
    table = run("results", "--store", tmp_path / "s.db").stdout
    assert table.split("Indicators not read:\n", 1)[1] == f"{said}\n"
    assert all(math.isnan(v) for row in _stored_lines(tmp_path / "s.db") for v in row.values())


@pytest.mark.parametrize(
    ("extra", "above"), [('[sides]\nspeed = "motor"\n', ""), ("", 'ignore = ["speed"]\n')]
)
def test_a_declared_side_or_an_ignored_speed_reads_the_lines(
    fleets: tuple[Path, Path], tmp_path: Path, extra: str, above: str
) -> None:
    root = _copy(fleets[1], tmp_path)
    _profile(root, extra, above)
    code, output = _monitor(root, tmp_path / "s.db")
    assert code in (0, 4), output
    assert "tooth_lines" not in output
    assert all(math.isfinite(v) for row in _stored_lines(tmp_path / "s.db") for v in row.values())
