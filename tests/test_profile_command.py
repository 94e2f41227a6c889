"""`axiswatch profile` to a first verdict; a help a person can read; a start without heavy imports."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer

import axiswatch
from axiswatch.cli import app
from axiswatch.datasets import AxisSpec, simulate_capture
from tests._cli import run

START_MS = 1_772_344_800_000  # 2026-03-01 06:00 UTC
#: Modules a command imports only when it needs them.
HEAVY = ("scipy.signal", "sklearn", "pandas", "matplotlib", "plotly", "dask", "pyarrow")


def _controller_export(folder: Path, days: int = 7) -> list[Path]:
    """A controller's trace: one file per capture holding axes A1 and A2, semicolons, decimal
    commas, a units row, Unix milliseconds, degrees and motor currents, no date in the name."""
    folder.mkdir(parents=True)
    spec = AxisSpec(fast_rate_hz=1000.0, position_rate_hz=1000.0)
    paths = []
    for day in range(days):
        columns = {}
        for axis, task in (("A1", "short_fast"), ("A2", "heavy")):
            capture = simulate_capture(task, seed=10 * day + int(axis[1]), spec=spec)
            n = capture.signals["torque"].size
            columns[f"{axis}_Pos_deg"] = np.degrees(capture.signals["position"][:n])
            columns[f"{axis}_Cur_A"] = capture.signals["torque"] / 0.8
        stamps = START_MS + day * 86_400_000 + np.arange(n)
        frame = pd.DataFrame({"Zeitstempel": stamps, **columns})
        header, rest = frame.to_csv(sep=";", decimal=",", index=False).split("\n", 1)
        path = folder / f"Trace_{day + 1:04d}.csv"
        path.write_text(f"{header}\nms;Grad;A;Grad;A\n{rest}", encoding="utf-8")
        paths.append(path)
    return paths


def test_a_controller_export_reaches_a_verdict_in_one_profile_and_one_monitor_run(
    tmp_path: Path,
) -> None:
    exports = _controller_export(tmp_path / "exports" / "cell1")
    fleet = tmp_path / "fleet"
    profiled = run("profile", *exports, "--fleet", fleet, env={"COLUMNS": "200"})
    assert profiled.returncode == 0, profiled.stdout + profiled.stderr
    assert "Zeitstempel (unix ms)" in profiled.stdout
    assert "A2_Pos_deg" in profiled.stdout
    assert "in deg" in profiled.stdout
    assert "Files not placed" not in profiled.stdout
    monitored = run("monitor", fleet, "--store", tmp_path / "s.db", "--settle", "0")
    assert monitored.returncode == 0, monitored.stdout + monitored.stderr
    assert "14 capture files, 2 new baseline(s), 12 capture(s) scored" in monitored.stdout
    assert "Rejected" not in monitored.stdout
    states = [line.split()[:4] for line in monitored.stdout.splitlines() if "cell1" in line]
    assert states == [["cell1", "A1", "indicators", "ok"], ["cell1", "A2", "indicators", "ok"]]
    again = run("profile", *exports, "--fleet", fleet)  # new exports: run again, nothing lost
    assert "linked 0 capture file(s)" in again.stdout
    assert "kept" in again.stdout


def test_a_rerun_for_new_exports_links_them_with_the_edited_profile(tmp_path: Path) -> None:
    # The README: edit the axis.toml, then rerun `profile` for new exports. An edited profile
    # refused them all ("exists with other content"), and --force would undo the edit.
    first, *later = _controller_export(tmp_path / "exports" / "cell1", days=7)
    fleet = tmp_path / "fleet"
    assert run("profile", first, "--fleet", fleet).returncode == 0
    toml = fleet / "cell1" / "A1" / "axis.toml"
    edited = 'name = "cell-model"\n' + toml.read_text(encoding="utf-8")
    toml.write_text(edited, encoding="utf-8")
    again = run("profile", *later, "--fleet", fleet)
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"kept {toml}: cell1/A1's captures were read with it" in again.stdout
    assert "linked 12 capture file(s)" in again.stdout
    assert toml.read_text(encoding="utf-8") == edited


def test_a_folder_of_tab_separated_text_exports_is_profiled_and_monitored(
    tmp_path: Path,
) -> None:
    exports = tmp_path / "exports" / "unit1"
    exports.mkdir(parents=True)
    spec = AxisSpec(fast_rate_hz=250.0, position_rate_hz=250.0)
    for day in range(7):
        capture = simulate_capture("short_fast", seed=day, spec=spec)
        n = capture.signals["torque"].size
        frame = pd.DataFrame({
            "Time": np.arange(n) / 250.0, "Angle": capture.signals["position"][:n],
            "Torque": capture.signals["torque"],
        })  # fmt: skip
        frame.to_csv(exports / f"2026-03-{day + 1:02d}_log.txt", sep="\t", index=False)
    (exports / "readme.md").write_text("not a capture", encoding="utf-8")
    empty = tmp_path / "exports" / "unit2"
    empty.mkdir()
    fleet = tmp_path / "fleet"
    profiled = run("profile", exports, empty, "--fleet", fleet)
    assert profiled.returncode == 0, profiled.stdout + profiled.stderr
    assert f"{empty}: a folder without capture files" in profiled.stdout
    assert "linked 7 capture file(s)" in profiled.stdout
    assert (fleet / "unit1" / "axis1" / "2026-03-01_log.csv").is_file()
    monitored = run("monitor", fleet, "--store", tmp_path / "s.db", "--settle", "0")
    assert "7 capture files, 1 new baseline(s), 6 capture(s) scored" in monitored.stdout


def test_a_file_of_numbered_axes_is_split_and_its_notes_said_once(tmp_path: Path) -> None:
    # A cobot's export: joint_position_1 .. _3 beside set points and the robot's own current.
    exports = tmp_path / "exports" / "cobot1"
    exports.mkdir(parents=True)
    spec = AxisSpec(fast_rate_hz=1000.0, position_rate_hz=1000.0)
    capture = simulate_capture("short_fast", seed=0, spec=spec)
    n = capture.signals["torque"].size
    columns = {"time": np.arange(n) / 1000.0, "robot_current": capture.signals["torque"]}
    for k in (1, 2, 3):
        columns[f"target_position_{k}"] = capture.signals["position"][:n]
        columns[f"joint_position_{k}"] = capture.signals["position"][:n]
        columns[f"motor_torque_{k}"] = capture.signals["torque"]
    pd.DataFrame(columns).to_csv(exports / "2026-03-01_sample.csv", index=False)
    shown = run("profile", exports, "--fleet", tmp_path / "fleet")
    assert shown.returncode == 0, shown.stdout + shown.stderr
    toml = tmp_path / "fleet" / "cobot1" / "axis2" / "axis.toml"
    assert '"joint_position_2" = "position"' in toml.read_text(encoding="utf-8")
    notes = [line for line in shown.stdout.splitlines() if line.startswith("note: ")]
    assert notes == [
        "note: position unit of 'joint_position_1' not in the file: rad assumed; if it is "
        'deg, write position = "deg" under [units] in the axis.toml (and 2 more like it)'
    ]


def test_profile_names_each_file_it_cannot_place(tmp_path: Path) -> None:
    (good,) = _controller_export(tmp_path / "cell1", days=1)
    notes = tmp_path / "cell1" / "notes.csv"
    notes.write_text("Note;Text\na;b\nc;d\ne;f\n", encoding="utf-8")
    shown = run("profile", good, notes)
    assert shown.returncode == 0, shown.stderr
    assert f"{notes}: no time column" in shown.stdout
    assert "Nothing written" in shown.stdout


def _help_lines(*command: str) -> list[str]:
    shown = run(*command, env={"COLUMNS": "80"})
    assert shown.returncode == 0, shown.stderr
    return shown.stdout.splitlines()


def test_monitor_help_fits_a_screen_and_research_knobs_are_in_advanced() -> None:
    lines = _help_lines("monitor", "--help")
    assert len(lines) <= 60
    assert max(map(len, lines)) <= 80
    knobs = ("--hop", "--segment-length", "--lra-noise-level", "--align", "--task-envelope",
             "--order-lines", "--whole-moves")  # fmt: skip
    assert not any(knob in line for line in lines for knob in knobs)
    advanced = "\n".join(_help_lines("monitor", "--advanced"))
    assert all(knob in advanced for knob in knobs)
    assert "[default: 8]" in advanced  # --hop's default, read from the monitor's config


@pytest.mark.parametrize(
    "command",
    [(), ("monitor",), ("profile",), ("results",), ("report",), ("rejections",), ("ack",),
     ("rebaseline",), ("backup",), ("compact",), ("demo",), ("simulate",), ("simulate", "fleet")],
)  # fmt: skip
def test_every_command_has_a_short_help_without_bool_metavars(command: tuple[str, ...]) -> None:
    lines = _help_lines(*command, "-h")
    assert lines[0].startswith("Usage: axiswatch")
    assert not any("<bool>" in line for line in lines)


def test_version() -> None:
    shown = run("--version")
    assert (shown.returncode, shown.stdout) == (0, f"axiswatch {axiswatch.__version__}\n")


def test_research_knobs_still_work(tmp_path: Path) -> None:
    shown = run("monitor", tmp_path, "--store", tmp_path / "s.db", "--hop", "0")
    assert shown.returncode == 2
    assert "hop" in shown.stderr


@pytest.mark.parametrize(
    "code",
    [
        "import axiswatch",
        "import sys; sys.argv = ['axiswatch', '--help']\n"
        "from axiswatch.cli import main\n"
        "try:\n    main()\nexcept SystemExit:\n    pass",
    ],
    ids=["import", "help"],
)
def test_heavy_modules_are_imported_only_by_the_commands_that_need_them(code: str) -> None:
    check = f"{code}\nimport sys\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))"
    shown = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, check=True
    )
    assert shown.stdout.splitlines()[-1] == "[]"


def _unit_row_in_degrees(k: int, t: np.ndarray) -> str:
    body = "".join(f"{v:.2f},{np.sin(v):.4f},{np.cos(v):.4f}\n" for v in t / 100.0)
    return "time,position,torque\ns,deg,Nm\n" + body


def _unix_milliseconds(k: int, t: np.ndarray) -> str:
    start = START_MS + k * 86_400_000
    body = "".join(f"{start + v},{np.sin(v / 100):.4f},{np.cos(v / 100):.4f}\n" for v in t * 10)
    return "time,position,torque\n" + body


@pytest.mark.parametrize("write", [_unit_row_in_degrees, _unix_milliseconds])
def test_a_first_run_of_400_files_with_one_cause_prints_one_line_for_them(
    tmp_path: Path, write: Callable[[int, np.ndarray], str]
) -> None:
    # Unix milliseconds without a profile: each file's reason names its own first stamp, and a
    # first run of 400 daily captures printed 97 lines of rejections.
    axis = tmp_path / "fleet" / "r1" / "a1"
    axis.mkdir(parents=True)
    t = np.arange(50)
    for k in range(400):
        day = np.datetime64("2025-01-01") + k  # in the past: a future date is another cause
        (axis / f"{day}.csv").write_text(write(k, t), encoding="utf-8")
    shown = run("monitor", tmp_path / "fleet", "--store", tmp_path / "s.db", "--settle", "0")
    assert shown.returncode == 8
    lines = (shown.stdout + shown.stderr).splitlines()
    assert "Rejected captures (400):" in lines
    assert len(lines) <= 8
    assert any("(and 399 more capture files with this reason" in line for line in lines)


def test_a_plugin_group_loads_when_it_is_used() -> None:
    # `axiswatch --help` names the group without importing it (checked above); using it loads it.
    tree = typer.main.get_command(app)
    context = typer.Context(tree)
    assert "experiment" not in tree.commands  # type: ignore[attr-defined]
    assert "experiment" in tree.list_commands(context)  # type: ignore[attr-defined]
    assert tree.get_command(context, "experiment").name == "experiment"  # type: ignore[attr-defined]
