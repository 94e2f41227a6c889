"""Detecting an axis profile from capture files: layout, time stamps, roles by name and content."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from axiswatch._profile_detection import detect_file, guess_roles, sniff_csv, stamp_kind
from axiswatch.exceptions import ProfileError
from axiswatch.monitor._layout_plan import apply_plan, plan_layout

START_MS = 1_772_344_800_000  # 2026-03-01 06:00 UTC


def _rows(n: int = 200) -> dict[str, np.ndarray]:
    t = np.arange(n) / 1000.0
    rng = np.random.default_rng(0)
    return {
        "position": np.degrees(np.sin(2 * np.pi * t)),
        "current": 3.0 * np.cos(2 * np.pi * t) + rng.normal(scale=0.3, size=n),
    }


def test_sniff_reads_a_european_export_and_windows_1252() -> None:
    data = "Zeit;Winkel;Strom\nms;°;A\n0;1,5;0,2\n".encode("cp1252")
    layout, text = sniff_csv(data)
    assert (layout.encoding, layout.separator, layout.decimal) == ("cp1252", ";", ",")
    assert dict(layout.units) == {"Zeit": "ms", "Winkel": "°", "Strom": "A"}
    assert text.startswith("Zeit;Winkel")


@pytest.mark.parametrize(
    ("stamps", "unit_word", "expected"),
    [
        ([START_MS / 1000.0, START_MS / 1000.0 + 0.001], None, ("unix", "s")),
        ([START_MS, START_MS + 1], None, ("unix", "ms")),
        ([START_MS * 1000, START_MS * 1000 + 1000], None, ("unix", "us")),
        ([START_MS * 1_000_000, START_MS * 1_000_000 + 10**6], None, ("unix", "ns")),
        (["2026-03-01T06:00:00.000", "2026-03-01T06:00:00.001"], None, ("iso", "s")),
        ([0, 1, 2], None, ("relative", "ms")),
        ([0.0, 0.001, 0.002], None, ("relative", "s")),
        ([0, 1, 2], "s", ("relative", "s")),  # the units row wins over the step
    ],
)
def test_stamp_kind(stamps: list[object], unit_word: str | None, expected: tuple[str, str]) -> None:
    assert stamp_kind(pd.Series(stamps), unit_word) == expected


def test_roles_by_name_per_axis_with_german_words() -> None:
    values = _rows()
    frame = pd.DataFrame({
        "Zeit": np.arange(200), "A1_Winkel": values["position"], "A1_Strom": values["current"],
        "A2_Lage_Grad": values["position"], "A2_Drehmoment": values["current"],
        "A2_Drehzahl": values["current"],
    })  # fmt: skip
    roles = guess_roles(frame, {}, "Zeit")
    assert {axis: {r: c for r, (c, _) in slot.items()} for axis, slot in roles.items()} == {
        "A1": {"position": "A1_Winkel", "torque": "A1_Strom"},
        "A2": {"position": "A2_Lage_Grad", "torque": "A2_Drehmoment", "speed": "A2_Drehzahl"},
    }


def test_roles_by_content_when_the_names_say_nothing() -> None:
    values = _rows()
    frame = pd.DataFrame({"t": np.arange(200), "ch1": values["current"], "ch2": values["position"]})
    roles = guess_roles(frame, {}, "t")
    assert roles[""]["position"] == ("ch2", "content")
    assert roles[""]["torque"] == ("ch1", "content")


def _export(path: Path, *, names: tuple[str, str] = ("A2_Pos_deg", "A2_Cur_A")) -> Path:
    values = _rows()
    frame = pd.DataFrame(
        {"Timestamp": START_MS + np.arange(200), names[0]: values["position"],
         names[1]: values["current"]}
    )  # fmt: skip
    text = frame.to_csv(sep=";", decimal=",", index=False)
    header, rest = text.split("\n", 1)
    path.write_text(f"{header}\nms;deg;A\n{rest}", encoding="utf-8")
    return path


def test_a_controller_export_is_detected(tmp_path: Path) -> None:
    guess = detect_file(_export(tmp_path / "trace.csv"))
    assert guess.problem is None
    assert (guess.time_column, guess.time_kind, guess.time_unit) == ("Timestamp", "unix", "ms")
    (axis,) = guess.axes
    assert axis.axis == "A2"
    assert dict(axis.columns) == {"A2_Pos_deg": "position", "A2_Cur_A": "torque"}
    assert axis.position_unit == "deg"
    assert axis.rates_hz["torque"] == pytest.approx(1000.0, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("a;b\n1;2\n", "fewer than 2 rows"),
        ("Note;Value\nx;1\ny;2\nz;3\n", "no time column"),
        ("time;A1_Pos_deg\n0;1\n1;2\n2;3\n", "no axis with both a position (or speed) and a"),
    ],
)
def test_files_it_cannot_place_say_why(tmp_path: Path, text: str, reason: str) -> None:
    path = tmp_path / "x.csv"
    path.write_text(text, encoding="utf-8")
    guess = detect_file(path)
    assert guess.problem is not None
    assert reason in guess.problem


def test_the_plan_names_files_it_leaves_out_and_never_overwrites(tmp_path: Path) -> None:
    exports = tmp_path / "cell1"
    exports.mkdir()
    good = _export(exports / "trace.csv")
    relative = exports / "relative.csv"
    relative.write_text(
        good.read_text().replace(str(START_MS), "0", 1).replace(str(START_MS + 1), "1", 1)
    )
    fleet = tmp_path / "fleet"
    plan = plan_layout([detect_file(good), detect_file(relative)], fleet)
    assert [p for p, *_ in plan.placed] == [good]
    (left_out,) = plan.unplaced
    assert left_out[0] == relative
    assert "no date in its name" in left_out[1]
    toml = fleet / "cell1" / "A2" / "axis.toml"
    assert apply_plan(plan)[0] == f"wrote {toml}"
    assert (fleet / "cell1" / "A2" / f"2026-03-01T06-00-00_{good.name}").is_file()
    toml.write_text('name = "mine"\n', encoding="utf-8")
    with pytest.raises(
        ProfileError, match=r"nothing written: .*axis.toml exists with other content"
    ):
        apply_plan(plan)
    assert toml.read_text(encoding="utf-8") == 'name = "mine"\n'


def test_a_position_without_a_unit_is_read_in_rad_and_said_so(tmp_path: Path) -> None:
    values = _rows()
    path = tmp_path / "2026-03-01.csv"
    pd.DataFrame(
        {"Timestamp": START_MS + np.arange(200), "J2_ActPos": values["position"],
         "J2_Current": values["current"]}
    ).to_csv(path, index=False)  # fmt: skip
    (axis,) = detect_file(path).axes
    assert (axis.axis, axis.position_unit, axis.unit_assumed) == ("J2", "rad", True)
    assert any('position = "deg"' in note for note in axis.notes)


def test_a_speed_is_kept_only_in_the_positions_unit_per_second(tmp_path: Path) -> None:
    values = _rows()
    frame = pd.DataFrame({
        "Zeit": START_MS + np.arange(200), "A1_Pos": values["position"],
        "A1_Vel": values["current"], "A1_Cur": values["current"],
        "A2_Pos": values["position"], "A2_Drehzahl": values["current"],
        "A2_Strom": values["current"],
    })  # fmt: skip
    header, rest = frame.to_csv(sep=";", index=False).split("\n", 1)
    path = tmp_path / "trace.csv"
    path.write_text(f"{header}\nms;deg;deg/s;A;deg;U/min;A\n{rest}", encoding="utf-8")
    first, second = detect_file(path).axes
    assert dict(first.columns) == {"A1_Pos": "position", "A1_Vel": "speed", "A1_Cur": "torque"}
    assert dict(second.columns) == {"A2_Pos": "position", "A2_Strom": "torque"}
    assert any("'A2_Drehzahl' left out" in note for note in second.notes)


def test_flags_set_points_and_constants_get_no_role() -> None:
    values = _rows()
    n = values["position"].size
    frame = pd.DataFrame({
        "Timestamp": START_MS + np.arange(n),
        "Motor_Pos1reached": (np.arange(n) % 50 > 25).astype(float),  # a PLC bit named "Pos"
        "SetSpeed": values["current"], "target_position": values["position"],
        "ActCurrent": values["current"], "Lim_1": np.zeros(n), "Angle": values["position"],
    })  # fmt: skip
    roles = guess_roles(frame, {}, "Timestamp")
    assert {r: c for r, (c, _) in roles[""].items()} == {
        "torque": "ActCurrent",
        "position": "Angle",
    }
    unnamed = pd.DataFrame({"t": np.arange(n), "ch1": values["position"], "ch2": np.zeros(n)})
    assert "torque" not in guess_roles(unnamed, {}, "t")[""]  # a constant is no torque


def test_axis_numbers_ending_names_are_axes_and_sensor_numbers_are_not() -> None:
    values = _rows()
    frame = pd.DataFrame({
        "time": np.arange(200) / 100.0, "robot_current": values["current"],
        **{f"{name}_{k}": values[key] for k in (1, 2)
           for name, key in (("target_position", "position"), ("motor_position", "position"),
                             ("joint_position", "position"), ("motor_torque", "current"))},
    })  # fmt: skip
    roles = guess_roles(frame, {}, "time")
    assert {axis: {r: c for r, (c, _) in roles[axis].items()} for axis in ("axis1", "axis2")} == {
        "axis1": {"position": "joint_position_1", "torque": "motor_torque_1"},
        "axis2": {"position": "joint_position_2", "torque": "motor_torque_2"},
    }
    assert "position" not in roles.get("", {})  # the robot's current: no axis of its own
    sensors = pd.DataFrame({
        "Time": np.arange(200), "Angle": values["position"],
        **{f"{name}_{k}": values["current"] for k in (1, 2, 3) for name in ("PG", "Accel")},
    })  # fmt: skip
    assert set(guess_roles(sensors, {}, "Time")) == {""}


def _plc_log(path: Path, *, gap_at: int | None = None) -> Path:
    """A PLC's log: Unix seconds, a speed and a current, no position; one step 5x longer."""
    values = _rows()
    steps = np.full(199, 0.047)
    if gap_at is not None:
        steps[gap_at] = 0.25
    pd.DataFrame({
        "Timestamp": 1_500_000_000.0 + np.concatenate([[0.0], np.cumsum(steps)]),
        "MotorData.ActSpeed": values["current"] * 1000.0, "MotorData.ActCurrent": values["position"],
    }).to_csv(path, index=False)  # fmt: skip
    return path


def test_a_log_with_a_speed_and_no_position_is_placed_and_irregular_steps_resampled(
    tmp_path: Path,
) -> None:
    regular = detect_file(_plc_log(tmp_path / "log1.csv"))
    gapped = detect_file(_plc_log(tmp_path / "log2.csv", gap_at=50))
    (axis,) = regular.axes
    assert dict(axis.columns) == {"MotorData.ActSpeed": "speed", "MotorData.ActCurrent": "torque"}
    assert any("no position column" in note for note in axis.notes)
    assert (regular.irregular, gapped.irregular) == (False, True)
    plan = plan_layout([regular, gapped], tmp_path / "fleet", "cell1")
    assert plan.unplaced == []
    (profile,) = plan.profiles.values()
    assert profile.resample_irregular  # one file's gap: every file of the axis is resampled


def test_an_axis_profile_already_there_reads_new_files_and_is_kept(tmp_path: Path) -> None:
    fleet = tmp_path / "fleet"
    toml = fleet / "cell1" / "axis1" / "axis.toml"
    toml.parent.mkdir(parents=True)
    mine = ('name = "mine"\nresample_irregular = true\n[columns]\n"Timestamp" = "time"\n'
            '"MotorData.ActCurrent" = "torque"\n"MotorData.ActSpeed" = "speed"\n'
            '[units]\nposition = "mm"\n')  # fmt: skip
    toml.write_text(mine, encoding="utf-8")
    guess = detect_file(_plc_log(tmp_path / "log.csv", gap_at=50))
    plan = plan_layout([guess], fleet, "cell1")
    assert (plan.unplaced, plan.profiles) == ([], {})
    assert plan.kept == {("cell1", "axis1"): str(toml)}
    assert apply_plan(plan)[0].startswith(f"kept {toml}")
    assert toml.read_text(encoding="utf-8") == mine
    forced = plan_layout([guess], fleet, "cell1", force=True)
    assert list(forced.profiles) == [toml]


def test_a_time_column_of_whole_steps_without_a_unit_is_said_to_be_read_as_ms(
    tmp_path: Path,
) -> None:
    # A rig's logger writes a sample counter; read as ms it gives 1000 Hz, whatever the rate.
    values = _rows()
    path = tmp_path / "2026-03-01_log.csv"
    frame = {"Time": np.arange(200), "Angle": values["position"], "Torque": values["current"]}
    pd.DataFrame(frame).to_csv(path, index=False)
    (axis,) = detect_file(path).axes
    assert any('if it counts samples, write time = "samples"' in n for n in axis.notes)


def test_an_axis_gets_the_guess_most_of_its_files_give(tmp_path: Path) -> None:
    # Unnamed columns placed by content: the roughest is the torque, and which one that is
    # can change from file to file. Every file is read with the majority's guess.
    rng = np.random.default_rng(1)
    values = _rows()
    guesses = []
    for k, rough in enumerate(("s1", "s2", "s1")):
        slow = np.cos(np.linspace(0.0, 3.0, 200))
        noise = {name: rng.normal(size=200) if name == rough else slow for name in ("s1", "s2")}
        path = tmp_path / "unit1" / f"2026-03-0{k + 1}.csv"
        path.parent.mkdir(exist_ok=True)
        pd.DataFrame({"t": np.arange(200) / 1000.0, "angle": values["position"], **noise}).to_csv(
            path, index=False
        )
        guesses.append(detect_file(path))
    plan = plan_layout(guesses, tmp_path / "fleet")
    assert plan.unplaced == []
    (profile,) = plan.profiles.values()
    assert profile.role_of("s1") == "torque"


def test_a_decimal_comma_after_a_first_line_of_whole_numbers_is_detected(tmp_path: Path) -> None:
    path = _export(tmp_path / "trace.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    lines[2] = f"{START_MS};0;0"  # the axis at rest: no comma on the first data line
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    guess = detect_file(path)
    assert guess.problem is None
    assert guess.layout is not None
    assert guess.layout.decimal == ","
    assert dict(guess.axes[0].columns) == {"A2_Pos_deg": "position", "A2_Cur_A": "torque"}
