"""The monitor manual's "Monitor your own robot": its code blocks run as written, in order."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from threadpoolctl import threadpool_limits

import axiswatch as aw

MANUAL = Path(__file__).resolve().parents[1] / "docs" / "monitor.md"


def _blocks() -> list[str]:
    text = MANUAL.read_text(encoding="utf-8")
    section = text.split("## Monitor your own robot", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.DOTALL)


def test_the_section_has_its_example() -> None:
    assert len(_blocks()) == 5


def test_the_section_s_profile_with_sides_is_valid() -> None:
    section = MANUAL.read_text(encoding="utf-8").split("## Monitor your own robot", 1)[1]
    (block,) = re.findall(r"```toml\n(.*?)```", section.split("\n## ", 1)[0], flags=re.DOTALL)
    profile = aw.AxisProfile.from_dict(tomllib.loads(block))
    assert profile.sides == {"position": "motor"}
    assert profile.ignore == ("speed",)


def test_readme_example_runs_as_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "readme"}
    with threadpool_limits(1):
        for block in _blocks():
            exec(compile(block, str(MANUAL), "exec"), namespace)
    assert (tmp_path / "fleet" / "cell4" / "J2" / "2026-01-08.csv").is_file()
    assert not list((tmp_path / "fleet").rglob("*.tmp"))
