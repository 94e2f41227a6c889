"""What a service engineer new to axiswatch stumbled on, following the README with real
recordings (lane i21u): each message below misled or left out what it was about."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch.exceptions import ProfileError

runner = CliRunner()


def _plain(text: str) -> str:
    """Help text without Rich's box drawing and line breaks."""
    return " ".join(re.sub(r"[│╭╮╰╯─]", " ", text).split())


@pytest.mark.parametrize(
    ("toml", "table"),
    [
        ('name = "x"\n[columns]\n"T" = "time"\nresample_irregular = true\n', "columns"),
        ('[columns]\n"T" = "time"\nname = "linear"\n', "columns"),
        ('[units]\ntime = "ms"\nresample_irregular = true\n', "units"),
        ('[kinematics]\ngear_ratio = 50\nname = "wrist"\n', "kinematics"),
    ],
)
def test_a_top_level_key_below_a_table_header_is_named_as_misplaced(
    tmp_path: Path, toml: str, table: str
) -> None:
    # Before: "[columns]: 'resample_irregular' must map to a quoted role ...; got True (bool)",
    # with nothing saying that in TOML the line belongs to the table above it.
    path = tmp_path / "axis.toml"
    path.write_text(toml)
    with pytest.raises(ProfileError) as raised:
        aw.AxisProfile.from_toml(path)
    message = str(raised.value)
    assert f"is a top-level key, here read as part of [{table}]" in message
    assert "move it above the first [table] line" in message


def test_a_real_typo_in_units_still_gets_its_likely_key_and_no_toml_advice(
    tmp_path: Path,
) -> None:
    path = tmp_path / "axis.toml"
    path.write_text('[units]\ntme = "ms"\n')
    with pytest.raises(ProfileError, match="did you mean 'time'") as raised:
        aw.AxisProfile.from_toml(path)
    assert "top-level key" not in str(raised.value)
