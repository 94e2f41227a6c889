"""The monitor reads a controller's own files through an axis profile (issue 13, item 1)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import axiswatch as aw
from axiswatch._capture import capture_to_frame
from axiswatch.cli import app
from tests.conftest import settle

runner = CliRunner()

PROFILE = """
name = "demo"
[columns]
"ts_us" = "time"
"Pos_deg" = "position"
"Vel_deg_s" = "speed"
"Trq" = "torque"
[units]
time = "us"
position = "deg"
"""


@pytest.fixture
def controller_fleet(small_fleet: Path, tmp_path: Path) -> Path:
    """The small fleet re-exported as a controller would: own column names, absolute Unix
    microseconds, degrees."""
    root = tmp_path / "fleet"
    for path in sorted(small_fleet.rglob("*.parquet")):
        frame = capture_to_frame(aw.read_capture(path))
        day = np.datetime64(path.stem).astype("datetime64[us]").astype(np.int64)
        export = frame.assign(
            ts_us=day + np.round(frame["time"] * 1e6).astype(np.int64),
            Pos_deg=np.degrees(frame["position"]),
            Vel_deg_s=np.degrees(frame["speed"]),
            Trq=frame["torque"],
        )[["ts_us", "Pos_deg", "Vel_deg_s", "Trq"]]
        target = root / path.relative_to(small_fleet).with_suffix(".csv")
        target.parent.mkdir(parents=True, exist_ok=True)
        export.to_csv(target, index=False)
    settle(root)
    return root


def _monitor(root: Path, store: Path, *extra: str) -> tuple[int, str]:
    result = runner.invoke(
        app,
        ["monitor", str(root), "--store", str(store), "--method", "pca", "--no-progress", *extra],
    )
    return result.exit_code, result.output


def test_without_a_profile_every_capture_is_rejected(
    controller_fleet: Path, tmp_path: Path
) -> None:
    code, output = _monitor(controller_fleet, tmp_path / "s.sqlite")
    assert code == 8
    assert "missing column 'time'" in output


def test_the_fleet_folder_profile_is_found(controller_fleet: Path, tmp_path: Path) -> None:
    (controller_fleet / "axiswatch.toml").write_text(PROFILE)
    code, output = _monitor(controller_fleet, tmp_path / "s.sqlite")
    assert code == 0, output
    assert "16 capture(s) scored in this run" in output


def test_profile_option(controller_fleet: Path, tmp_path: Path) -> None:
    profile = tmp_path / "axis.toml"
    profile.write_text(PROFILE)
    code, output = _monitor(controller_fleet, tmp_path / "s.sqlite", "--profile", str(profile))
    assert code == 0, output
    assert "16 capture(s) scored in this run" in output


@pytest.mark.parametrize(("word", "encoding"), [("Gehäuse", None), ("Źródło", "cp1250")])
def test_a_fleet_exported_on_windows_is_read(
    controller_fleet: Path, tmp_path: Path, word: str, encoding: str | None
) -> None:
    # Before: every capture "cannot read CSV file (truncated or corrupt?)", a UTF-8 error.
    for path in sorted(controller_fleet.rglob("*.csv")):
        text = path.read_text(encoding="utf-8").replace("Pos_deg", "Position [°]", 1)
        head, rest = text.split("\n", 1)
        rows = [f"{row},40.5" for row in rest.splitlines()]
        export = "\r\n".join([f"{head},Temperatur {word} [°C]", *rows]) + "\r\n"
        path.write_bytes(export.encode(encoding or "cp1252"))
    settle(controller_fleet)
    profile = PROFILE.replace('"Pos_deg"', '"Position [°]"')
    (controller_fleet / "axiswatch.toml").write_text(profile, encoding="utf-8")
    if encoding is not None:
        # Polish text is not Windows-1252: refused, naming the encoding and how to declare it.
        code, output = _monitor(controller_fleet, tmp_path / "refused.sqlite")
        assert code == 8, output
        assert "neither UTF-8 (byte 0xb0 at 16) nor Windows-1252; declare its" in output
        (controller_fleet / "axiswatch.toml").write_text(
            f'encoding = "{encoding}"\n{profile}', encoding="utf-8"
        )
    code, output = _monitor(controller_fleet, tmp_path / "s.sqlite")
    assert code == 0, output
    assert "16 capture(s) scored in this run" in output


def test_a_profile_edited_after_the_baseline_refits_it_instead_of_alarming(
    tmp_path: Path,
) -> None:
    # The export writes degrees; the first profile said radians, and is fixed once the fleet
    # was scored. Every new capture was then judged against the baseline read before the fix:
    # "bad data (no motion: position spans 1.7 % of the baseline's)", never scored until a
    # re-baseline. The model and its data-quality reference are now refitted from the
    # baseline's own captures, read as the profile now says.
    from axiswatch.datasets import draw_robot
    from axiswatch.monitor import MonitorConfig, SQLiteStore
    from axiswatch.monitor._monitor import monitor_fleet

    robot = draw_robot(4)
    root = tmp_path / "fleet"
    folder = root / "r1" / "a0"
    folder.mkdir(parents=True)
    profile = folder / "axis.toml"
    profile.write_text('[units]\nposition = "rad"\n', encoding="utf-8")

    def write(day: int) -> None:
        capture = robot.capture(0, seed=day)
        signals = dict(capture.signals)
        signals["position"] = np.degrees(signals["position"])
        signals["speed"] = np.degrees(signals["speed"])
        name = f"2026-03-{day:02d}.parquet"
        aw.write_capture(aw.Capture(signals, capture.rates_hz), folder / name)

    for day in range(1, 10):
        write(day)
    settle(root)
    store = tmp_path / "s.db"
    with SQLiteStore(store) as opened:
        monitor_fleet(root, opened, MonitorConfig())
    profile.write_text('[units]\nposition = "deg"\n', encoding="utf-8")
    for day in (10, 11):
        write(day)
    settle(root)
    with SQLiteStore(store) as opened:
        summary = monitor_fleet(root, opened, MonitorConfig())
        scores = opened.score_table()
    new = scores[scores.capture.isin(["2026-03-10.parquet", "2026-03-11.parquet"])]
    assert len(new) == 2, summary.rejected
    assert not new.alarm.any(), new[["capture", "distance", "reason"]].to_string()
