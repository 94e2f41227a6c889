"""Capture objects and the capture file format: round trips and every bad-input path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
import axiswatch._capture
from axiswatch import CaptureError
from axiswatch._capture import sampling_period
from tests.naive import sampling_period_naive


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_round_trip_keeps_values_and_rates(
    robot_capture: aw.Capture, tmp_path: Path, suffix: str
) -> None:
    path = aw.write_capture(robot_capture, tmp_path / f"2026-03-01{suffix}")
    back = aw.read_capture(path)
    assert back.names == ("position", "speed", "torque")
    assert back.rates_hz == pytest.approx(robot_capture.rates_hz, rel=1e-9)
    for name in back.names:
        np.testing.assert_array_equal(back.signals[name], robot_capture.signals[name])
    if suffix == ".parquet":
        assert back.metadata == {"robot": "r1", "axis": "a4"}


def test_slow_signal_is_blank_between_its_instants(robot_capture: aw.Capture) -> None:
    frame = aw._capture.capture_to_frame(robot_capture)
    assert len(frame) == 2000
    assert frame["position"].notna().sum() == 250
    assert frame["position"].iloc[1:8].isna().all()


def _write(tmp_path: Path, frame: pd.DataFrame, name: str = "cap.csv") -> Path:
    path = tmp_path / name
    frame.to_csv(path, index=False)
    return path


def _frame(n: int = 40) -> pd.DataFrame:
    t = np.arange(n) / 2000.0
    return pd.DataFrame({"time": t, "speed": np.sin(t), "torque": np.cos(t)})


def test_missing_time_column(tmp_path: Path) -> None:
    path = _write(tmp_path, _frame().drop(columns="time"))
    with pytest.raises(CaptureError, match=r"cap\.csv: missing column 'time'"):
        aw.read_capture(path)


def test_missing_signal_column(tmp_path: Path) -> None:
    path = _write(tmp_path, _frame())
    with pytest.raises(CaptureError, match=r"missing signal column\(s\) \['position'\]"):
        aw.read_capture(path, ["position", "speed"])


def test_non_numeric_values(tmp_path: Path) -> None:
    frame = _frame().astype({"torque": object})
    frame.loc[5, "torque"] = "oops"
    with pytest.raises(
        CaptureError, match=r"column 'torque' must be numeric; found non-numeric value 'oops'"
    ):
        aw.read_capture(_write(tmp_path, frame))


def test_nan_inside_fast_signal(tmp_path: Path) -> None:
    frame = _frame()
    frame.loc[10, "speed"] = np.nan
    with pytest.raises(CaptureError, match=r"column 'speed' is not uniformly sampled"):
        aw.read_capture(_write(tmp_path, frame))


def test_nan_inside_slow_signal(tmp_path: Path, robot_capture: aw.Capture) -> None:
    frame = aw._capture.capture_to_frame(robot_capture)
    frame.loc[8 * 100, "position"] = np.nan
    with pytest.raises(CaptureError, match=r"column 'position' is not uniformly sampled"):
        aw.read_capture(_write(tmp_path, frame))


def test_non_increasing_time(tmp_path: Path) -> None:
    frame = _frame()
    frame.loc[7, "time"] = frame.loc[6, "time"]
    with pytest.raises(CaptureError, match=r"'time' must be strictly increasing; row 7"):
        aw.read_capture(_write(tmp_path, frame))


def test_time_going_back_is_named_in_plain_numbers(tmp_path: Path) -> None:
    # Before: "row 7 has t=np.float64(0.0025) after t=np.float64(0.003)" (NumPy 2's repr).
    frame = _frame()
    frame.loc[7, "time"] = frame.loc[5, "time"]
    with pytest.raises(
        CaptureError, match=r"row 7 goes back in time: t=0\.0025 s after t=0\.003 s\.$"
    ):
        aw.read_capture(_write(tmp_path, frame))


def test_a_row_written_twice_is_read_once_a_repeated_stamp_is_named(tmp_path: Path) -> None:
    frame = _frame()
    doubled = pd.concat([frame.iloc[:11], frame.iloc[10:]], ignore_index=True)
    capture = aw.read_capture(_write(tmp_path, doubled))  # before: "must be strictly increasing"
    assert capture.signals["speed"].tolist() == frame["speed"].tolist()
    assert capture.rates_hz["speed"] == pytest.approx(2000.0, rel=1e-12)
    doubled.loc[11, "speed"] += 1.0  # the same stamp with another value: which one is true?
    with pytest.raises(CaptureError, match=r"row 11 repeats the time stamp t=0\.005 s after"):
        aw.read_capture(_write(tmp_path, doubled))


def test_jittered_stamps_give_the_rate_of_their_least_squares_slope(tmp_path: Path) -> None:
    # A logger's clock jittering 1 % of the period: before, the rate was the median step's,
    # 0.08 % off, and the capture was rejected against the baseline's rate (0.1 %).
    n = 400
    t = np.arange(n) / 100.0 + np.random.default_rng(3).normal(0.0, 1e-4, n)
    frame = pd.DataFrame({"time": t, "speed": np.sin(t), "torque": np.cos(t)})
    capture = aw.read_capture(_write(tmp_path, frame), expected_rates_hz={"speed": 100.0})
    assert capture.rates_hz["speed"] == pytest.approx(1 / sampling_period_naive(list(t)), rel=1e-12)
    assert capture.rates_hz["speed"] == pytest.approx(100.0, rel=1e-4)


def test_sampling_period_is_the_naive_least_squares_slope_or_the_exact_step() -> None:
    rng = np.random.default_rng(7)
    jittered = np.arange(500) * 0.01 + rng.uniform(-0.002, 0.002, 500)
    assert sampling_period(jittered) == pytest.approx(
        sampling_period_naive(jittered.tolist()), rel=1e-12
    )
    exact = np.arange(500) / 2000.0
    assert sampling_period(exact) == float(np.median(np.diff(exact)))


def test_iso_8601_and_datetime_stamps_are_read_as_seconds_from_the_first(tmp_path: Path) -> None:
    # Before: "column 'time' must be numeric; found non-numeric value '2026-01-01T06:00:00'" and,
    # for a Parquet datetime column, "found non-numeric value None (dtype datetime64[ns])".
    frame = _frame()
    start = pd.Timestamp("2026-01-01T06:00:00")
    dated = frame.assign(time=start + pd.to_timedelta(frame["time"], unit="s"))
    iso = dated.assign(time=dated["time"].map(lambda t: t.isoformat() + "+01:00"))
    for path in (
        _write(tmp_path, iso, "iso.csv"),
        _write(tmp_path, dated.assign(time=dated["time"].astype(str)), "text.csv"),
    ):
        capture = aw.read_capture(path)
        assert capture.rates_hz["speed"] == pytest.approx(2000.0, rel=1e-9)
        assert capture.start_s == 0.0
    parquet = tmp_path / "dated.parquet"
    dated.to_parquet(parquet, index=False)
    assert aw.read_capture(parquet).rates_hz["torque"] == pytest.approx(2000.0, rel=1e-9)
    iso.loc[5, "time"] = "soon"
    with pytest.raises(CaptureError, match=r"starts with the ISO-8601 date-time .* but not every"):
        aw.read_capture(_write(tmp_path, iso, "bad.csv"))


def test_unix_milliseconds_read_as_seconds_are_refused_naming_the_unit(tmp_path: Path) -> None:
    # Before: read as seconds, a 2 kHz capture had a rate of 2 Hz and was scored, silently.
    frame = _frame()
    frame["time"] = 1_767_225_600_000 + np.arange(len(frame)) / 2.0
    with pytest.raises(CaptureError, match=r"starts at 1\.767e\+12 s .* are the stamps in ms\?"):
        aw.read_capture(_write(tmp_path, frame))
    frame["time"] = 1_767_225_600 + np.arange(len(frame)) / 2000.0  # Unix seconds are fine
    assert aw.read_capture(_write(tmp_path, frame)).rates_hz["speed"] == pytest.approx(
        2000.0, rel=1e-6
    )


def test_a_column_blank_inside_a_gap_and_irregular_steps_are_told_apart(tmp_path: Path) -> None:
    frame = _frame()
    frame.loc[10:12, "speed"] = np.nan
    with pytest.raises(CaptureError, match=r"'speed' .* blank \(NaN\) at t=0\.005 s \(3 row"):
        aw.read_capture(_write(tmp_path, frame))
    frame = _frame()
    frame.loc[20:, "time"] += 3.0
    with pytest.raises(CaptureError, match=r"'speed' .* step of 3\.0005 s .*\(a gap in time\)"):
        aw.read_capture(_write(tmp_path, frame))
    frame = _frame()
    frame.loc[20:, "time"] += 0.0002  # a step of 1.4 periods
    with pytest.raises(CaptureError, match=r"irregular stamps\? resample_irregular = true"):
        aw.read_capture(_write(tmp_path, frame))


def test_headers_in_other_case_or_with_spaces_are_the_same_columns(tmp_path: Path) -> None:
    # Before: "missing column 'time' ...; found columns ['Time', 'Speed ', 'TORQUE']".
    frame = _frame().rename(columns={"time": "Time", "speed": "Speed ", "torque": "TORQUE"})
    capture = aw.read_capture(_write(tmp_path, frame))
    assert capture.names == ("speed", "torque")
    assert capture.signals["torque"].tolist() == _frame()["torque"].tolist()
    frame["torque"] = frame["TORQUE"]  # an exact 'torque' is the signal, 'TORQUE' an extra
    assert aw.read_capture(_write(tmp_path, frame)).names == ("speed", "torque")
    frame = frame.drop(columns="torque")
    frame[" Speed"] = 1.0
    with pytest.raises(CaptureError, match=r"name \['speed'\] more than once \(up to case and"):
        aw.read_capture(_write(tmp_path, frame))


def test_columns_beside_the_signals_are_extras(tmp_path: Path) -> None:
    # Before: a position and torque export was refused for its other columns: "column 'mode'
    # must be numeric; found non-numeric value 'AUTO'", and the monitor stored a constant axis
    # number as bad data ("flat/stuck signal: 'axis_id' is 4 throughout").
    frame = _frame().rename(columns={"speed": "position"})
    frame = frame.assign(mode="AUTO", spare=np.nan, axis_id=4, row=np.arange(len(frame)) * 1e7)
    assert aw.read_capture(_write(tmp_path, frame)).names == ("position", "torque")
    # Without any of position, speed and torque, every column holding numbers is a signal.
    named = frame.rename(columns={"position": "v", "torque": "i"}).drop(columns=["axis_id", "row"])
    assert aw.read_capture(_write(tmp_path, named)).names == ("v", "i")
    named.loc[3, "mode"] = "7"  # a number among the text: a signal, refused by name
    with pytest.raises(CaptureError, match=r"column 'mode' must be numeric; found non-numeric"):
        aw.read_capture(_write(tmp_path, named))
    frame = _frame().assign(position=np.nan)  # a blank signal of its own name
    with pytest.raises(CaptureError, match=r"column 'position' is blank \(no value in any row\)"):
        aw.read_capture(_write(tmp_path, frame))


def test_rate_differs_from_expected(tmp_path: Path) -> None:
    path = _write(tmp_path, _frame())
    with pytest.raises(CaptureError, match=r"'speed' is sampled at 2000 Hz; expected 1000 Hz"):
        aw.read_capture(path, ["speed"], expected_rates_hz={"speed": 1000.0})


def test_empty_file(tmp_path: Path) -> None:
    path = tmp_path / "empty.parquet"
    path.write_bytes(b"")
    with pytest.raises(CaptureError, match=r"empty\.parquet: file is empty"):
        aw.read_capture(path)


def test_header_only_file(tmp_path: Path) -> None:
    path = tmp_path / "header.csv"
    path.write_text("time,speed\n")
    with pytest.raises(CaptureError, match=r"header but no rows"):
        aw.read_capture(path)


def test_truncated_parquet(tmp_path: Path, robot_capture: aw.Capture) -> None:
    path = aw.write_capture(robot_capture, tmp_path / "cut.parquet")
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(CaptureError, match=r"cut\.parquet: cannot read Parquet file"):
        aw.read_capture(path)


def test_unknown_suffix(tmp_path: Path) -> None:
    path = tmp_path / "cap.txt"
    path.write_text("x")
    with pytest.raises(CaptureError, match=r"unknown capture file type '\.txt'"):
        aw.read_capture(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(CaptureError, match=r"no such capture file"):
        aw.read_capture(tmp_path / "absent.csv")


def test_signal_with_one_value(tmp_path: Path) -> None:
    frame = _frame()
    frame["torque"] = np.nan
    frame.loc[0, "torque"] = 1.0
    with pytest.raises(CaptureError, match=r"column 'torque' has 1 value\(s\)"):
        aw.read_capture(_write(tmp_path, frame))


def test_capture_rejects_nan_array() -> None:
    with pytest.raises(CaptureError, match=r"signal 'speed' has 1 non-finite value\(s\).*sample 2"):
        aw.Capture({"speed": [0.0, 1.0, np.nan]}, {"speed": 10.0})


def test_capture_rejects_missing_rate() -> None:
    with pytest.raises(CaptureError, match=r"no sampling rate given for signal\(s\) \['torque'\]"):
        aw.Capture({"torque": [0.0, 1.0]}, {"speed": 10.0})


def test_capture_rejects_bad_rate() -> None:
    with pytest.raises(CaptureError, match=r"rate of signal 'speed' must be a positive number"):
        aw.Capture({"speed": [0.0, 1.0]}, {"speed": -1.0})


def test_capture_rejects_2d_and_empty() -> None:
    with pytest.raises(CaptureError, match=r"must be 1-D"):
        aw.Capture({"speed": np.zeros((2, 2))}, {"speed": 1.0})
    with pytest.raises(CaptureError, match=r"signal 'speed' is empty"):
        aw.Capture({"speed": []}, {"speed": 1.0})
    with pytest.raises(CaptureError, match=r"at least one signal"):
        aw.Capture({}, {})


def test_signals_not_starting_together(tmp_path: Path) -> None:
    frame = _frame(80)
    frame.loc[:40, "torque"] = np.nan
    with pytest.raises(CaptureError, match=r"signals start at different times"):
        aw.read_capture(_write(tmp_path, frame))


def test_repeated_rows_by_numpy_equal_pandas_comparison(rng: np.random.Generator) -> None:
    from axiswatch._capture import _repeated_rows

    values = rng.integers(0, 2, size=(400, 3)).astype(float)
    values[rng.random(values.shape) < 0.2] = np.nan
    frame = pd.DataFrame(values, columns=["time", "speed", "torque"])
    previous = frame.shift()
    expected = (frame.eq(previous) | (frame.isna() & previous.isna())).all(axis=1).to_numpy()
    assert expected.sum() > 10  # the case is exercised
    np.testing.assert_array_equal(_repeated_rows(frame), expected)
    mixed = frame.assign(mode=np.where(values[:, 0] == 1, "run", "stop"))
    previous = mixed.shift()
    expected = (mixed.eq(previous) | (mixed.isna() & previous.isna())).all(axis=1).to_numpy()
    np.testing.assert_array_equal(_repeated_rows(mixed), expected)
    # Compared on the rows whose first column repeats: a capture's stamps rarely do.
    stamps = frame.assign(time=np.arange(400.0))
    stamps.loc[[7, 8, 100, 101], "time"] = [7.0, 7.0, np.nan, np.nan]
    previous = stamps.shift()
    expected = (stamps.eq(previous) | (stamps.isna() & previous.isna())).all(axis=1).to_numpy()
    np.testing.assert_array_equal(_repeated_rows(stamps), expected)
    for rows in (0, 1):
        assert _repeated_rows(frame.iloc[:rows]).tolist() == [False] * rows


def test_signals_in_every_row_share_the_rows_period(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Speed and torque in every row have the rows' stamps: their period is found once, and each
    # reads as it did alone (the position, at a quarter of the rate, finds its own).
    t = np.arange(400) / 2000.0
    position = np.where(np.arange(400) % 4 == 0, np.sin(t), np.nan)
    frame = pd.DataFrame({"time": t, "position": position, "speed": np.cos(t), "torque": t})
    path = tmp_path / "c.parquet"
    frame.to_parquet(path, index=False)
    alone = {name: aw.read_capture(path, [name]) for name in ("position", "speed", "torque")}
    calls: list[int] = []
    from axiswatch._quantiles import median as counted

    def counting(steps: np.ndarray) -> float:
        calls.append(steps.size)
        return counted(steps)

    monkeypatch.setattr(axiswatch._capture, "median", counting)
    read = aw.read_capture(path)
    assert sorted(calls) == [99, 399]  # the median step of the position's and the rows' stamps
    for name, capture in alone.items():
        assert read.rates_hz[name] == capture.rates_hz[name]
        np.testing.assert_array_equal(read.signals[name], capture.signals[name], strict=True)
    assert read.start_s == 0.0


def test_a_column_finds_its_period_as_sampling_period_does(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Exact stamps give their median step without a second pass over them; jittered ones the
    # slope, from sampling_period. Either way the rate is sampling_period's, bit for bit.
    from axiswatch._timebase import sampling_period

    rng = np.random.default_rng(5)
    for jitter in (0.0, 1e-10, 1e-5):
        t = np.arange(600) / 1000.0 + rng.normal(0.0, jitter, 600)
        position = np.where(np.arange(600) % 3 == 0, np.sin(t), np.nan)
        frame = pd.DataFrame({"time": t, "position": position, "torque": np.cos(t)})
        read = aw.read_capture(_write(tmp_path, frame))
        assert read.rates_hz["torque"] == 1.0 / sampling_period(t)
        assert read.rates_hz["position"] == 1.0 / sampling_period(t[::3])


def test_a_table_of_floats_gives_its_columns_at_once() -> None:
    from axiswatch._capture import _float_columns, _numeric_column

    frame = pd.DataFrame({"time": [0.0, 0.5], "torque": [1.0, np.nan]})
    columns = _float_columns(frame)
    assert columns is not None
    for name in frame.columns:
        expected = _numeric_column(frame, name, Path("c.csv"))
        np.testing.assert_array_equal(columns[name], expected, strict=True)
    # Any other table: each column checked by _numeric_column, with its one-line error.
    for other in (
        frame.assign(torque=[1, 2]),
        frame.assign(mode=["run", "stop"]),
        frame.rename(columns={"torque": 3}),
    ):
        assert _float_columns(other) is None
