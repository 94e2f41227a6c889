"""AxisProfile: TOML, column mapping, units, absolute and irregular time stamps, fleet lookup."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
from axiswatch._profiles import AxisProfile, find_profile
from axiswatch.exceptions import ProfileError


def _controller_csv(path: Path, *, irregular: bool = False) -> Path:
    rate = 250.0
    steps = np.full(1000, 1000.0 / rate)  # ms
    if irregular:
        steps = steps * np.random.default_rng(0).uniform(0.8, 1.2, size=steps.size)
    stamps = 1_700_000_000_000 + np.concatenate([[0], np.cumsum(steps[:-1])]).round()
    t = (stamps - stamps[0]) / 1000.0
    q_rad = np.sin(np.pi * t / 2)
    frame = pd.DataFrame(
        {
            "Timestamp": stamps.astype(np.int64),
            "J2_ActPos": np.degrees(q_rad),
            "J2_Current": 3 * np.sign(np.cos(np.pi * t / 2)),
        }
    )
    frame.to_csv(path, index=False)
    return path


PROFILE = AxisProfile.from_dict(
    {
        "name": "cobot-j2",
        "columns": {"Timestamp": "time", "J2_ActPos": "position", "J2_Current": "torque"},
        "units": {"time": "ms", "position": "deg"},
    }
)


def test_controller_export_reads_through_its_profile(tmp_path: Path) -> None:
    capture = aw.read_capture(_controller_csv(tmp_path / "c.csv"), profile=PROFILE)
    assert capture.names == ("position", "torque")
    assert capture.rates_hz["position"] == pytest.approx(250.0)
    assert capture.start_s == 0.0
    assert np.abs(capture.signals["position"]).max() == pytest.approx(1.0, abs=1e-3)  # rad


def test_without_the_profile_the_file_is_not_understood(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    with pytest.raises(aw.CaptureError, match="missing column 'time'"):
        aw.read_capture(path)


def test_a_renamed_column_names_the_one_the_file_has(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    frame = pd.read_csv(path).rename(columns={"J2_Current": "J2_ActCurrent"})
    frame.to_csv(path, index=False)
    with pytest.raises(
        ProfileError,
        match=r"c\.csv: the axis profile <memory> maps \[columns\] 'J2_Current' = 'torque', "
        r"but the file has no column 'J2_Current' \(did you mean 'J2_ActCurrent'\?\); found",
    ):
        aw.read_capture(path, profile=PROFILE)


def test_a_sample_counter_is_read_at_the_declared_rate(tmp_path: Path) -> None:
    # A rig's logger: 'Time' counts samples at 250 Hz; read as ms it was 1000 Hz.
    path = tmp_path / "2026-03-01_log.csv"
    n = np.arange(500)
    frame = {"Time": n, "Angle": np.sin(n / 40.0), "dP": np.cos(n / 40.0)}
    pd.DataFrame(frame).to_csv(path, index=False)
    text = (
        '[columns]\n"Time" = "time"\n"Angle" = "position"\n"dP" = "torque"\n'
        '[units]\ntime = "samples"\nsample_rate_hz = 250\n'
    )
    (tmp_path / "axis.toml").write_text(text, encoding="utf-8")
    profile = AxisProfile.from_toml(tmp_path / "axis.toml")
    capture = aw.read_capture(path, profile=profile)
    assert capture.rates_hz["torque"] == pytest.approx(250.0, rel=1e-12)


def test_irregular_stamps_need_the_option(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv", irregular=True)
    with pytest.raises(aw.CaptureError, match="not uniformly sampled"):
        aw.read_capture(path, profile=PROFILE)
    lenient = AxisProfile.from_dict(
        {
            "columns": dict(PROFILE.columns),
            "units": {"time": "ms", "position": "deg"},
            "resample_irregular": True,
        }
    )
    capture = aw.read_capture(path, profile=lenient)
    assert capture.rates_hz["torque"] == pytest.approx(250.0, rel=0.05)


def test_resampled_captures_of_one_jittering_clock_share_its_rate(tmp_path: Path) -> None:
    # A 100 Hz logger whose stamps jitter by up to 20 % of the period: before, each capture was
    # put on a grid at its median step, which moved by ~0.2 % from capture to capture, and the
    # captures after the baseline were refused for another rate than the baseline's.
    lenient = AxisProfile(resample_irregular=True)
    rng = np.random.default_rng(11)
    rates = []
    for k in range(4):
        t = np.arange(400) / 100.0 + rng.uniform(-0.002, 0.002, 400)
        path = tmp_path / f"c{k}.csv"
        pd.DataFrame({"time": t, "position": np.sin(t), "torque": np.cos(t)}).to_csv(path)
        expected = None if not rates else {"position": rates[0]}
        capture = aw.read_capture(path, expected_rates_hz=expected, profile=lenient)
        rates.append(capture.rates_hz["position"])
    assert rates == pytest.approx([100.0] * 4, rel=2e-4)


def test_profile_reads_iso_stamps_and_refuses_a_unit_too_large(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    frame = pd.read_csv(path)
    iso = frame.assign(
        Timestamp=pd.to_datetime(frame["Timestamp"], unit="ms").dt.strftime("%Y-%m-%dT%H:%M:%S.%f")
    )
    iso.to_csv(path, index=False)
    capture = aw.read_capture(path, profile=PROFILE)  # before: "must hold numbers in ms"
    assert capture.rates_hz["position"] == pytest.approx(250.0)
    frame.to_csv(path, index=False)
    seconds = AxisProfile(columns=dict(PROFILE.columns), position_unit="deg")
    with pytest.raises(aw.CaptureError, match=r"when read in s; are the stamps in ms\?"):
        aw.read_capture(path, profile=seconds)


def test_profile_columns_match_headers_in_other_case_or_with_spaces(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    frame = pd.read_csv(path)
    frame.columns = ["timestamp", " J2_ActPos ", "J2_CURRENT"]
    frame.to_csv(path, index=False)
    capture = aw.read_capture(path, profile=PROFILE)  # before: "no time column"
    assert capture.names == ("position", "torque")
    assert capture.rates_hz["torque"] == pytest.approx(250.0)


def test_a_plc_logging_at_irregular_steps_is_resampled_on_the_baselines_grid(
    tmp_path: Path,
) -> None:
    # Steps of 39-55 ms: each capture's own rate moves by ~2 %; before, every capture after the
    # baseline was refused for "another rate than the baseline's".
    lenient = AxisProfile(resample_irregular=True)
    rng = np.random.default_rng(0)
    rates = []
    for k in range(4):
        t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.039, 0.055, 100))])
        path = tmp_path / f"c{k}.csv"
        pd.DataFrame({"time": t, "position": np.sin(t), "torque": np.cos(t)}).to_csv(path)
        expected = None if not rates else {"position": rates[0], "torque": rates[0]}
        capture = aw.read_capture(path, expected_rates_hz=expected, profile=lenient)
        rates.append(capture.rates_hz["position"])
        assert capture.signals["position"] == pytest.approx(
            np.sin(np.arange(capture.signals["position"].size) / rates[-1]), abs=2e-3
        )
    assert rates[1:] == pytest.approx([rates[0]] * 3, rel=1e-9)


def test_toml_round_trip_and_kinematics(tmp_path: Path) -> None:
    path = tmp_path / "axis.toml"
    path.write_text(
        'name = "arm"\n[units]\nposition = "rev"\n[kinematics]\ngear_ratio = 101.0\n'
        "[kinematics.gear_stages]\noutput = 5.0\n[kinematics.bearing_orders]\ninner = 5.43\n"
    )
    profile = AxisProfile.from_toml(path)
    assert profile.kinematics() == {
        "gear_ratio": 101.0,
        "gear_stages": {"output": 5.0},
        "bearing_orders": {"inner": 5.43},
    }
    assert profile.position_unit == "rev"


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"colums": {}}, r"unknown key\(s\) \['colums'\]"),
        ({"columns": {"x": "angle"}}, "maps to role 'angle'"),
        ({"units": {"time": "min"}}, "time unit must be one of"),
        ({"units": {"position": "grad"}}, "position unit must be one of"),
        ({"kinematics": {"gear_ratio": -1}}, "gear_ratio must be > 0"),
        (
            {"units": {"time": "samples"}},
            r'time = "samples" \(a sample counter\) and sample_rate_hz',
        ),
        ({"units": {"sample_rate_hz": 250}}, r"got time = 's' and sample_rate_hz = 250.0"),
        (
            {"units": {"time": "samples", "sample_rate_hz": 0}},
            "sample_rate_hz must be a number > 0. Got 0.0",
        ),
        ({"kinematics": {"bearing_orders": {"b": "x"}}}, r"bearing_orders\.b must be a number"),
    ],
)
def test_bad_profiles_are_named(data: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        AxisProfile.from_dict(data)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('columns = "time"', r"'columns' must be a table \(\[columns\].*got 'time' \(str\)"),
        ("[columns]\nt = 1", r"\[columns\]: 't' must map to a quoted role.*got 1 \(int\)"),
        ("[units]\nposition = 3", r"\[units\]: 'position' must be a quoted string; got 3"),
        ("[units]\ntorque = 5", r"\[units\]: 'torque' must be a quoted string; got 5"),
        ('resample_irregular = "no"', r"'resample_irregular' must be true or false.*'no' \(str\)"),
        ("name = 3", r"'name' must be a quoted string; got 3 \(int\)"),
        (
            '[kinematics]\ngear_ratio = "abc"',
            r"\[kinematics\]: 'gear_ratio' must be a number > 0; got 'abc' \(str\)",
        ),
        ('[kinematics]\ngear_stages = "x"', r"\[kinematics\]: 'gear_stages' must be a table"),
        ("[kinematics.bearing_orders]\nb = true", r"bearing_orders\.b must be a number > 0"),
        (
            "[colums]\nt = 'time'",
            r"unknown key\(s\) \['colums'\] \('colums': did you mean 'columns'\?\); expected some of",
        ),
    ],
)
def test_wrong_types_in_a_profile_file_name_the_file_and_key(
    tmp_path: Path, text: str, message: str
) -> None:
    # Before: 'columns = "time"' raised "dictionary update sequence element #0 ...", a string
    # gear ratio "could not convert string to float", and "no", 3 or a quoted ratio were
    # silently taken (resample_irregular = "no" turned resampling on).
    path = tmp_path / "robot.toml"
    path.write_text(text + "\n")
    with pytest.raises(ProfileError, match=f"{re.escape(str(path))}.*{message}"):
        AxisProfile.from_toml(path)


def test_a_profile_that_is_not_utf8_text_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "axis.toml"
    path.write_bytes(b"name = '\xff\xfe'\n")
    with pytest.raises(ProfileError, match="axis profile must be UTF-8 text"):
        AxisProfile.from_toml(path)


def test_unreadable_toml_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text("name = ")
    with pytest.raises(aw.CaptureError, match="not a valid TOML axis profile"):
        AxisProfile.from_toml(path)
    with pytest.raises(aw.CaptureError, match="no such axis profile file"):
        AxisProfile.from_toml(tmp_path / "none.toml")


def test_two_columns_for_one_role_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    pd.DataFrame({"time": [0.0, 0.1, 0.2], "a": [1, 2, 3], "b": [1, 2, 3]}).to_csv(path)
    profile = AxisProfile(columns={"a": "torque", "b": "torque"})
    with pytest.raises(aw.CaptureError, match=r"maps two columns to \['torque'\]"):
        aw.read_capture(path, profile=profile)


def test_a_mapped_column_beside_one_named_for_its_role_names_both(tmp_path: Path) -> None:
    # An export with its own 'time' (a sample number) and the stamps in 'time_s'.
    path = tmp_path / "c.csv"
    frame = {"time": [0, 1, 2], "time_s": [0.0, 0.1, 0.2], "torque": [1.0, 2.0, 3.0]}
    pd.DataFrame(frame).to_csv(path, index=False)
    with pytest.raises(
        aw.CaptureError,
        match=r"maps two columns to \['time'\]: 'time' \(the file's own name\) and 'time_s' "
        r"\(mapped\); keep one of them in \[columns\]",
    ):
        aw.read_capture(path, profile=AxisProfile(columns={"time_s": "time"}))


def test_fleet_lookup_takes_the_most_specific_file(tmp_path: Path) -> None:
    (tmp_path / "r1" / "a1").mkdir(parents=True)
    (tmp_path / "r2" / "a1").mkdir(parents=True)
    assert find_profile(tmp_path, "r1", "a1") is None
    (tmp_path / "axiswatch.toml").write_text('name = "fleet"')
    (tmp_path / "r1" / "robot.toml").write_text('name = "model-1"')
    (tmp_path / "r1" / "a1" / "axis.toml").write_text('name = "model-1-wrist"')
    assert find_profile(tmp_path, "r1", "a1").name == "model-1-wrist"  # type: ignore[union-attr]
    assert find_profile(tmp_path, "r2", "a1").name == "fleet"  # type: ignore[union-attr]


def test_a_mapped_torque_the_file_lacks_names_the_profile_line_and_the_file(
    tmp_path: Path,
) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    frame = pd.read_csv(path).rename(columns={"J2_Current": "J2_Torque"})
    frame.to_csv(path, index=False)
    with pytest.raises(ProfileError) as caught:
        aw.read_capture(path, profile=PROFILE)
    message = str(caught.value)
    assert "\n" not in message
    assert str(path) in message
    assert "'J2_Current' = 'torque'" in message
    assert "J2_Torque" in message  # what the file has instead


def test_a_mapped_speed_the_file_lacks_is_derived_as_before(tmp_path: Path) -> None:
    path = _controller_csv(tmp_path / "c.csv")
    profile = AxisProfile.from_dict(
        {
            "columns": {**PROFILE.columns, "J2_ActVel": "speed"},
            "units": {"time": "ms", "position": "deg"},
        }
    )
    capture = aw.read_capture(path, profile=profile)
    assert capture.names == ("position", "torque")


def test_encoder_counts_read_as_the_same_capture_in_rad(tmp_path: Path) -> None:
    from axiswatch._capture import capture_to_frame
    from axiswatch.datasets import draw_robot

    capture = draw_robot(2).capture(0, seed=3)
    frame = capture_to_frame(capture)
    frame.to_parquet(tmp_path / "rad.parquet", index=False)
    per_turn = 16384.0  # a 14-bit encoder
    counts = frame.copy()
    for role in ("position", "speed"):
        if role in counts.columns:
            counts[role] = counts[role] * (per_turn / (2 * np.pi))
    counts.to_parquet(tmp_path / "counts.parquet", index=False)
    kinematics = {"gear_ratio": 101.0}
    in_rad = AxisProfile.from_dict({"kinematics": kinematics})
    in_counts = AxisProfile.from_dict(
        {
            "units": {"position": "counts", "counts_per_revolution": per_turn},
            "kinematics": kinematics,
        }
    )
    assert in_counts == AxisProfile(
        position_unit="counts",
        counts_per_revolution=per_turn,
        gear_ratio=101.0,
        source=in_counts.source,
    )
    read_rad = aw.read_capture(tmp_path / "rad.parquet", profile=in_rad)
    read_counts = aw.read_capture(tmp_path / "counts.parquet", profile=in_counts)
    np.testing.assert_allclose(
        read_counts.signals["position"], read_rad.signals["position"], rtol=1e-12
    )
    from axiswatch.indicators._readings import read_indicators

    expected = read_indicators(read_rad, **in_rad.kinematics())
    got = read_indicators(read_counts, **in_counts.kinematics())
    assert set(got.values) == set(expected.values)
    assert sum(np.isfinite(v) for v in expected.values.values()) >= 5
    for name, value in expected.values.items():
        np.testing.assert_allclose(got.values[name], value, rtol=1e-12, err_msg=name)


@pytest.mark.parametrize(
    ("units", "message"),
    [
        ({"position": "counts"}, r'position unit "counts" needs counts_per_revolution'),
        ({"position": "counts", "counts_per_revolution": 0}, "must be a number > 0"),
        ({"position": "counts", "counts_per_revolution": "16384"}, "must be a number > 0"),
        ({"position": "deg", "counts_per_revolution": 16384}, 'is for position unit "counts"'),
    ],
)
def test_counts_need_a_positive_counts_per_revolution(
    units: dict[str, object], message: str, tmp_path: Path
) -> None:
    path = tmp_path / "axis.toml"
    lines = [
        f"{key} = {value!r}".replace("'", '"') if isinstance(value, str) else f"{key} = {value}"
        for key, value in units.items()
    ]
    path.write_text("[units]\n" + "\n".join(lines) + "\n")
    with pytest.raises(ProfileError, match=message) as caught:
        AxisProfile.from_toml(path)
    assert str(path) in str(caught.value)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "misplaced", ["r1/a1/robot.toml", "r1/a1/axiswatch.toml", "r1/axis.toml", "r1/axiswatch.toml"]
)
def test_a_profile_under_a_name_the_lookup_does_not_read_there_is_named(
    misplaced: str, tmp_path: Path
) -> None:
    (tmp_path / "r1" / "a1").mkdir(parents=True)
    (tmp_path / misplaced).write_text('name = "model-1"')
    with pytest.raises(ProfileError) as caught:
        find_profile(tmp_path, "r1", "a1")
    message = str(caught.value)
    assert message.startswith(f"{tmp_path / misplaced}: an axis profile is not read")
    assert str(tmp_path / "r1" / "a1" / "axis.toml") in message
    assert "\n" not in message


def test_a_typo_in_a_profile_key_names_the_key_it_likely_meant(tmp_path: Path) -> None:
    path = tmp_path / "axiswatch.toml"
    path.write_text('[unit]\ntime = "ms"\n')
    with pytest.raises(ProfileError, match=r"\['unit'\] \('unit': did you mean 'units'\?\)"):
        AxisProfile.from_toml(path)
    path.write_text('[units]\npositon = "deg"\n')
    with pytest.raises(ProfileError, match=r"'positon': did you mean 'position'\?"):
        AxisProfile.from_toml(path)


def test_a_profile_path_that_is_a_folder_is_a_profile_error(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match=r"is a folder; expected an axis profile file"):
        AxisProfile.from_toml(tmp_path)


@pytest.mark.parametrize(
    ("stamps", "unit", "seconds", "kept"),
    [
        (np.arange(5) / 10.0, "s", np.arange(5) / 10.0, True),  # seconds from zero: as they are
        (np.arange(5) / 10.0 + 3.0, "s", np.arange(5) / 10.0, False),
        (np.arange(5) * 100.0, "ms", np.arange(5) / 10.0, False),
        (np.arange(5, dtype=np.int64), "s", np.arange(5.0), False),
    ],
)
def test_standardise_keeps_seconds_from_zero_as_they_are(
    stamps: np.ndarray, unit: str, seconds: np.ndarray, kept: bool
) -> None:
    # Setting the time column again cost a tenth of reading a 3 s capture, for the same bits.
    frame = pd.DataFrame({"time": stamps, "torque": np.ones(5)})
    read = AxisProfile(time_unit=unit).standardise(frame, Path("c.csv"))
    time_s = read["time"].to_numpy()
    assert time_s.dtype == np.float64
    np.testing.assert_allclose(time_s, seconds, rtol=0, atol=1e-15)
    assert np.shares_memory(time_s, frame["time"].to_numpy()) == kept
