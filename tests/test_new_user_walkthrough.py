"""What a service engineer new to axiswatch stumbled on, following the README and the monitor
manual with real recordings: each message below misled or left out what it was about."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch.monitor as awm
from axiswatch import IndicatorModel
from axiswatch.cli import app
from axiswatch.datasets import draw_robot
from axiswatch.exceptions import ProfileError
from axiswatch.indicators._assessment import IndicatorAssessment
from axiswatch.indicators._axis import IndicatorBaseline
from axiswatch.indicators._readings import read_indicators
from axiswatch.monitor.report.charts import distance_chart
from axiswatch.monitor.report.verdict import attention_lines
from tests.conftest import settle

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


def test_the_reason_without_a_fleet_gives_the_thresholds_unit() -> None:
    # Before: "load_forward (drive load) 24.6 spreads from its baseline (threshold 7.7)": 7.7
    # what? Without a fleet the distance and the threshold are both in within-task spreads.
    verdict = IndicatorAssessment(
        distance=24.6,
        threshold=7.7,
        alarm=True,
        top="load_forward",
        component="drive load",
        indicators={"load_forward": {"value": 1.0, "baseline": 0.5, "spreads": 24.6}},
        case="no task envelope: no fleet prior",
    )
    assert verdict.reason() == (
        "load_forward (drive load) 24.6 spreads from its baseline (threshold 7.7 spreads)"
    )


def test_a_reason_shared_by_every_indicator_is_said_once() -> None:
    # Before: "not scored: coulomb_friction needs motion (...); viscous_friction needs motion
    # (...); ..." six times the same words.
    why = "needs motion (the axis did not move)"
    verdict = IndicatorAssessment(
        distance=math.nan,
        threshold=1.0,
        alarm=False,
        top=None,
        component=None,
        indicators={},
        unavailable={"coulomb_friction": why, "load_forward": why, "impulsiveness": "needs X"},
    )
    assert verdict.reason() == (
        "not scored: coulomb_friction, load_forward: each needs motion (the axis did not move); "
        "impulsiveness needs X"
    )


def _capture(position: np.ndarray, rate: float = 250.0) -> aw.Capture:
    speed = np.gradient(position, 1.0 / rate)
    torque = 0.1 * np.sign(speed) + np.sin(np.arange(position.size) / 7.0)
    rates = {"position": rate, "speed": rate, "torque": rate}
    return aw.Capture({"position": position, "speed": speed, "torque": torque}, rates)


def test_a_step_in_the_position_is_not_called_no_motion() -> None:
    # Two strokes of a hydraulic actuator joined end to end where the second starts at the
    # other end: one sample jumps half a turn, the speed's peak is that jump and the real
    # stroke stays under 10 % of it. Before: "needs motion (the axis did not move for 0.2 s)".
    t = np.arange(0, 8, 1 / 250)
    stroke = np.clip((t - 1.0) / 2.0, 0, 1) * 1.6  # 1.6 rad in 2 s
    position = np.where(t < 4, stroke, 1.6 - np.clip((t - 5.0) / 2.0, 0, 1) * 1.6)
    position[t >= 4] -= 1.6  # the second record starts 1.6 rad below where the first ended
    reasons = read_indicators(_capture(position)).reasons
    assert reasons
    assert all("a step in the position" in why for why in reasons.values())
    assert not any("did not move" in why for why in reasons.values())
    still = read_indicators(_capture(np.zeros_like(t))).reasons
    assert all(why == "needs motion (the axis did not move)" for why in still.values())


@pytest.mark.parametrize("command", ["results", "report", "rejections", "ack", "rebaseline"])
def test_commands_that_refuse_a_missing_store_do_not_promise_to_create_one(command: str) -> None:
    # Before: every --store said "(created if new)", but all but `monitor` refuse a missing one
    # ("store 'typo.db' does not exist; run 'axiswatch monitor' first.").
    shown = _plain(runner.invoke(app, [command, "--help"], terminal_width=200).output)
    assert "created if new" not in shown
    assert "written by 'axiswatch monitor' (must exist)" in shown


def test_monitor_still_creates_its_store() -> None:
    shown = _plain(runner.invoke(app, ["monitor", "--help"], terminal_width=200).output)
    assert "SQLite store of the monitor (created if new)" in shown


def test_a_second_run_says_its_file_count_covers_only_the_folders_it_listed(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: the first run said "18 capture files", the second "0 capture files (2 axis
    # folder(s) unchanged since the last run)": the files seemed gone.
    root = tmp_path / "fleet"
    shutil.copytree(small_fleet, root)
    store = str(tmp_path / "s.db")
    args = ["monitor", str(root), "--store", store, "--method", "pca"]
    first = runner.invoke(app, args)
    assert first.exit_code == 0, first.output
    assert "in the axis folders listed" not in first.output
    second = runner.invoke(app, args)
    assert second.exit_code == 0, second.output
    assert (
        "0 capture files in the axis folders listed (2 axis folder(s) unchanged since the last "
        "run, not listed)" in second.output
    )


def test_report_help_names_the_one_file_it_writes(tmp_path: Path) -> None:
    # Before: "--out: Folder for index.html and the PNG figures.", but the report is one file,
    # index.html, with its charts inline (docs/monitor.md, "The report").
    shown = _plain(runner.invoke(app, ["report", "--help"], terminal_width=200).output)
    assert "PNG" not in shown
    assert "one self-contained file, index.html" in shown


def test_acknowledging_a_path_that_names_no_problem_is_refused_with_the_likely_one(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: `rejections --ack fleet/robot01/axis1/...` (the path as the shell completes it)
    # printed "0 problem(s) acknowledged" and exited 0: the problem stayed, nothing said why.
    root = tmp_path / "fleet"
    shutil.copytree(small_fleet, root)
    bad = root / "robot01" / "axis1" / "2026-03-09T12-00-00_garbage.csv"
    bad.write_text("not a capture\n")
    settle(root)
    store = str(tmp_path / "s.db")
    scored = runner.invoke(app, ["monitor", str(root), "--store", store, "--method", "pca"])
    assert scored.exit_code == 8, scored.output
    listed = "robot01/axis1/2026-03-09T12-00-00_garbage.csv"
    for given in (f"fleet/{listed}", listed.replace("garbage", "garbge")):
        refused = runner.invoke(app, ["rejections", "--store", store, "--ack", given])
        assert refused.exit_code == 1, refused.output
        assert f"at {given!r} (did you mean {listed!r}?)" in refused.output
        assert "Nothing was changed." in refused.output
    both = runner.invoke(app, ["rejections", "--store", store, "--retry", listed, "nowhere.csv"])
    assert both.exit_code == 1  # one unknown path: nothing is forgotten either
    done = runner.invoke(app, ["rejections", "--store", store, "--ack", listed])
    assert done.exit_code == 0, done.output
    assert "1 problem(s) acknowledged" in done.output


def test_a_few_skipped_samples_point_to_resample_irregular_and_say_where(tmp_path: Path) -> None:
    # The real linear axis's PLC log (~21 Hz) skips ~5 samples now and then. Before: "step of
    # 0.253 s after t=1.79083e+09 s ... (a gap in time)": no word of resample_irregular, which
    # reads it, and an absolute stamp that says nothing about where in the capture it is.
    t = 1_790_000_000.0 + np.arange(200) * 0.05
    t[100:] += 0.2  # four samples skipped
    q = np.sin(t - t[0])
    path = tmp_path / "2026-10-01.csv"
    pd.DataFrame({"time": t, "position": q, "torque": np.cos(t - t[0])}).to_csv(path, index=False)
    with pytest.raises(aw.CaptureError) as raised:
        aw.read_capture(path)
    message = str(raised.value)
    assert "(4.95 s into the capture)" in message
    assert "a gap of 5.0 periods" in message
    assert "resample_irregular = true in the axis profile" in message
    # Read through a profile that says so, the same file is read.
    profile = aw.AxisProfile(resample_irregular=True)
    assert 19.0 < aw.read_capture(path, profile=profile).rates_hz["position"] <= 20.0


def test_the_report_counts_one_healthy_axis_and_explains_shifts_without_a_fleet(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: "No action needed (1 axes)", and the charts' legend explained the indicator
    # shifts only with a fleet's task-change allowances, which an axis with fewer than 3 axes
    # of its profile (two hydraulic actuators, one linear axis) does not have.
    root = tmp_path / "fleet"
    shutil.copytree(small_fleet, root)
    shutil.rmtree(root / "robot01" / "axis2")
    with aw.Store(tmp_path / "s.db") as store:
        aw.monitor_fleet(root, store, aw.MonitorConfig(method="pca"), settle_s=0)
        awm.write_report(store, tmp_path / "report")
    page = (tmp_path / "report" / "index.html").read_text()
    assert "No action needed (1 axis)" in page
    assert "without one: spreads of its calibration captures" in page


def test_a_capture_not_compared_says_what_its_task_distance_is_in() -> None:
    # Before: "task signature 0.64 beyond its envelope 0.17": 0.64 of what? The signature
    # distance is a share of the baseline's top speed, stroke or time moving.
    robot = draw_robot(0)
    lone = aw.IndicatorModel().fit(
        robot.capture(0, seed=0), [robot.capture(0, seed=k) for k in range(1, 6)]
    )
    reasons = [lone.assess(robot.capture(task, seed=30)).reason() for task in (1, 2, 3)]
    not_compared = [why for why in reasons if "not compared" in why]
    assert not_compared  # a development robot (seed 0) and its own tasks
    assert all(
        "as shares of the baseline's top speed, stroke or time moving" in why
        for why in not_compared
    )


def test_rejections_listed_beside_their_path_do_not_repeat_it(
    small_fleet: Path, tmp_path: Path
) -> None:
    # Before: every row of `rejections` and of the report's table held the path twice, in its
    # column and at the start of the error ("r/a/x.csv  r/a/x.csv: ..."), 400 characters wide.
    root = tmp_path / "fleet"
    shutil.copytree(small_fleet, root)
    listed = "robot01/axis1/2026-03-09T12-00-00_garbage.csv"
    (root / listed).write_text("not a capture\n")
    settle(root)
    store = tmp_path / "s.db"
    with aw.Store(store) as opened:
        aw.monitor_fleet(root, opened, aw.MonitorConfig(method="pca"), settle_s=0)
        awm.write_report(opened, tmp_path / "report")
    shown = runner.invoke(app, ["rejections", "--store", str(store)], terminal_width=400)
    assert shown.exit_code == 0, shown.output
    (row,) = [line for line in shown.output.splitlines() if listed in line]
    assert row.count(listed) == 1
    page = (tmp_path / "report" / "index.html").read_text()
    table = page[page.index("<h2 id='rejected'>") :]
    assert listed in table
    assert f"{listed}: " not in table
    assert "file has a header but no rows" in table


def test_the_indicator_distance_panel_names_its_unit() -> None:
    # Before: the panel was titled "distance (indicators)" with values such as 1.55 and a
    # dashed line at 1, while the panel below said its shifts were "in thresholds".
    rows = pd.DataFrame(
        {
            "captured_at": ["2026-10-01", "2026-10-02", "2026-10-03"],
            "capture": ["a.csv", "b.csv", "c.csv"],
            "method": "indicators",
            "epoch": 1,
            "role": ["baseline", "calibration", "monitor"],
            "distance": [np.nan, 0.3, 1.55],
            "threshold": [np.nan, 1.0, 1.0],
            "over": [False, False, True],
            "alarm": [False, False, True],
            "reason": ["", "", "x"],
            "details": "{}",
        }
    )
    chart = distance_chart(rows, div_id="g-l", indicators=False)
    assert "distance (indicators) in thresholds" in chart


def test_a_capture_too_short_for_motion_names_the_time_unit() -> None:
    # Seconds declared as milliseconds: 4 s of motion read as 4 ms. Before: "needs motion (the
    # speed was above 5 % of its peak for 0.00 s, ...)", six times, no word of the unit.
    t = np.arange(0, 4, 1 / 250)
    rates = dict.fromkeys(("position", "speed", "torque"), 250_000.0)
    signals = {"position": np.sin(t), "speed": np.cos(t), "torque": np.sign(np.cos(t))}
    read = IndicatorBaseline(IndicatorModel()).read(aw.Capture(signals, rates), None)[1]
    assert read is not None
    assert read.startswith("no indicator can be read (coulomb_friction, viscous_friction, ")
    assert read.count("needs 0.2 s of motion, and the capture spans 0.004 s at 2.5e+05 Hz") == 1
    assert "check the time unit: the profile's [units] time" in read


def test_a_report_folder_that_is_a_file_is_named_as_such(tmp_path: Path) -> None:
    # `report --out rep/index.html`, the page's own path. Before: "error: [Errno 17] File
    # exists: 'rep/index.html'".
    with aw.Store(tmp_path / "s.db"):
        pass
    page = tmp_path / "index.html"
    page.write_text("an older report")
    shown = runner.invoke(app, ["report", "--store", str(tmp_path / "s.db"), "--out", str(page)])
    assert shown.exit_code == 1
    assert f"report folder '{page}' is a file; expected a folder" in shown.output
    assert "Errno" not in shown.output
    assert page.read_text() == "an older report"


def test_a_run_without_any_baseline_does_not_count_zero_of_zero_axes() -> None:
    # The cobot sample: 6 axes calibrating, none with a baseline yet. Before: the run ended
    # with "Needs attention (indicators): 0 of 0 axes" below "Axes calibrating (6)".
    assert attention_lines([], "indicators") == [
        "Needs attention (indicators): none; no axis has a baseline yet."
    ]


def test_results_for_a_robot_the_store_lacks_names_what_it_holds(
    small_fleet: Path, tmp_path: Path
) -> None:
    # `results --robot act9` (a typo): before, "No scored captures." as for an empty store.
    root = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    store = tmp_path / "s.db"
    with aw.Store(store) as opened:
        aw.monitor_fleet(root, opened, aw.MonitorConfig(method="pca"), settle_s=0)
    shown = runner.invoke(app, ["results", "--store", str(store), "--robot", "robot9"])
    assert shown.exit_code == 0, shown.output
    assert shown.output.strip() == (
        "No scored captures for --robot robot9; the store holds robot01/axis1 (pca), "
        "robot01/axis2 (pca)."
    )


def test_profile_of_a_missing_file_says_so_without_an_empty_table(tmp_path: Path) -> None:
    # Before: an empty table, then "cannot be read: [Errno 2] No such file or directory".
    missing = tmp_path / "nothere.csv"
    shown = runner.invoke(app, ["profile", str(missing)])
    assert shown.exit_code == 1
    assert f"{missing}: no such file or folder" in shown.output
    assert "What the files hold" not in shown.output


def test_files_of_one_axis_whose_rates_differ_past_three_digits_share_a_row(
    tmp_path: Path,
) -> None:
    # The linear axis's PLC log cut into 20 s files: each file's rate differs in the fourth
    # digit (21.3354, 21.3363, ...). Before: the table had one row per file, 21 of one axis.
    for k, step in enumerate((0.04690, 0.04688, 0.04685)):
        t = 1_750_000_000.0 + k * 3600 + np.arange(400) * step
        frame = pd.DataFrame({"time": t, "position": np.sin(t - t[0]), "current": np.cos(t)})
        frame.to_csv(tmp_path / f"2025-06-02T0{k}-00-00.csv", index=False)
    shown = runner.invoke(app, ["profile", str(tmp_path)], env={"COLUMNS": "200"})
    assert shown.exit_code == 0, shown.output
    rows = [line for line in shown.output.splitlines() if "2025-06-02T0" in line]
    assert len(rows) == 1, shown.output
    assert "+2" in rows[0]
    assert "21.3" in rows[0]


def test_a_file_without_a_whole_axis_names_the_columns_it_found(tmp_path: Path) -> None:
    # The cobot sample's index.csv. Before: "... column; found {'-': ['torque']}": a Python
    # dict that named no column.
    from axiswatch._profile_detection import detect_file

    path = tmp_path / "x.csv"
    path.write_text("time;A1_Pos_deg\n0;1\n1;2\n2;3\n", encoding="utf-8")
    problem = detect_file(path).problem
    assert problem is not None
    assert problem.endswith("column; found axis A1: position 'A1_Pos_deg'")
    path.write_text("time;Note\n0;a\n1;b\n2;c\n", encoding="utf-8")
    assert str(detect_file(path).problem).endswith("column; found none of them")
