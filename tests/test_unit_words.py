"""Unit words of a CSV units row as controller exports write them (German ``Grad``, ``°``,
``degrees``, ``rad/s``, in any case), and the one-line error for a word that is not read."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
from axiswatch.exceptions import CaptureError


def _export(path: Path, units: str, second: str = "position") -> Path:
    """A ``;``-separated export with a units row: time in s, ``second`` in degrees, torque."""
    t = np.arange(40) / 100.0
    values = np.degrees(np.sin(t)) if second == "position" else np.degrees(np.cos(t))
    frame = pd.DataFrame({"time": t, second: values, "torque": np.cos(t)})
    lines = frame.to_csv(index=False, sep=";", decimal=",").splitlines()
    lines.insert(1, units)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("word", ["Grad", "GRAD", "[Grad]", "°", "Deg", "degrees", "Degree"])
def test_degree_words_are_read_as_deg(tmp_path: Path, word: str) -> None:
    # Before: a German export's "Grad" was refused as "not a position unit axiswatch reads".
    path = _export(tmp_path / "c.csv", f"s;{word};Nm")
    capture = aw.read_capture(path, profile=aw.AxisProfile(position_unit="deg"))
    assert capture.signals["position"][1] == pytest.approx(np.sin(0.01), rel=1e-9)  # rad
    with pytest.raises(
        CaptureError,
        match=rf"c\.csv: the units row gives '{re.escape(word)}' for column 'position' "
        r"\(position\), but the capture is read in rad \(the default, without an axis profile\); "
        r'declare \[units\] position = "deg" in the axis profile\.',
    ):
        aw.read_capture(path)


@pytest.mark.parametrize("word", ["Grad/s", "°/s", "deg/s", "Degrees/sec"])
def test_degree_speed_words_are_read_as_deg_per_second(tmp_path: Path, word: str) -> None:
    path = _export(tmp_path / "c.csv", f"s;{word};Nm", second="speed")
    capture = aw.read_capture(path, profile=aw.AxisProfile(position_unit="deg"))
    assert capture.signals["speed"][1] == pytest.approx(np.cos(0.01), rel=1e-9)  # rad/s


@pytest.mark.parametrize(("word", "role"), [("Rad", "position"), ("radians", "position"),
                                            ("RAD/S", "speed"), ("Radian/s", "speed")])  # fmt: skip
def test_radian_words_are_read_without_a_profile(tmp_path: Path, word: str, role: str) -> None:
    path = _export(tmp_path / "c.csv", f"s;{word};Nm", second=role)
    assert role in aw.read_capture(path).names


@pytest.mark.parametrize(
    ("word", "role", "expected"),
    [
        ("gon", "position", r"not a position unit axiswatch reads; expected one of \[.*'grad'"),
        ("rpm", "speed", r"not a speed unit axiswatch reads; expected one of \[.*'grad/s'.*"
                         r"a speed per minute \(rpm, U/min\) is not converted"),
        ("U/min", "speed", r"not a speed unit .* a speed per minute \(rpm, U/min\) is not "
                           r"converted: export it per second, or leave the column out"),
    ],
)  # fmt: skip
def test_a_word_that_is_not_read_is_one_line_naming_file_column_and_the_words_read(
    tmp_path: Path, word: str, role: str, expected: str
) -> None:
    path = _export(tmp_path / "c.csv", f"s;{word};Nm", second=role)
    with pytest.raises(
        CaptureError,
        match=rf"c\.csv: the units row gives '{re.escape(word)}' for column "
        rf"'{role}' \({role}\), {expected}",
    ) as raised:
        aw.read_capture(path, profile=aw.AxisProfile(position_unit="deg"))
    assert "\n" not in str(raised.value)
