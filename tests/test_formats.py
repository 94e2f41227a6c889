"""Capture formats: one registry for reading, writing and the monitor's discovery."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import axiswatch as aw
import axiswatch._formats
from axiswatch.exceptions import CaptureError, ProfileError
from axiswatch.monitor._fleet import discover_fleet


@pytest.fixture
def registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """A copy of the registry for the test, so a format it adds does not outlive it."""
    monkeypatch.setattr(axiswatch._formats, "_FORMATS", dict(axiswatch._formats._FORMATS))


def _one_rate_capture(rng: np.random.Generator) -> aw.Capture:
    return aw.Capture(
        {"speed": rng.normal(size=400), "torque": rng.normal(size=400)},
        {"speed": 2000.0, "torque": 2000.0},
        metadata={"robot": "r1"},
    )


def test_builtin_suffixes() -> None:
    assert axiswatch._formats.capture_suffixes() == (".csv", ".npz", ".parquet")


@pytest.mark.parametrize("suffix", [".parquet", ".csv", ".npz"])
def test_every_format_round_trips_through_one_interface(
    suffix: str, tmp_path: Path, rng: np.random.Generator
) -> None:
    capture = _one_rate_capture(rng)
    back = aw.read_capture(aw.write_capture(capture, tmp_path / f"2026-03-01{suffix}"))
    assert back.names == ("speed", "torque")
    for name in back.names:
        np.testing.assert_array_equal(back.signals[name], capture.signals[name])
        assert back.rates_hz[name] == pytest.approx(2000.0, rel=1e-9)
    if suffix != ".csv":  # CSV keeps no metadata
        assert back.metadata["robot"] == "r1"


def test_npz_holds_one_rate(tmp_path: Path, robot_capture: aw.Capture) -> None:
    # position at 250 Hz, speed and torque at 2 kHz
    with pytest.raises(CaptureError, match=r"cap\.npz: a \.npz capture holds every signal at one"):
        aw.write_capture(robot_capture, tmp_path / "cap.npz")


def test_npz_recording_of_unknown_rate_reads_at_the_nominal_rate(tmp_path: Path) -> None:
    path = tmp_path / "r1.npz"
    np.savez(path, signals=np.ones((1, 8)), channels=np.array(["a1"]), fs=np.float64("nan"))
    capture = aw.read_capture(path)
    assert capture.rates_hz == {"a1": pytest.approx(1.0, rel=1e-12)}
    assert capture.metadata["fs_stated"] == "false"


def test_corrupt_npz_is_a_capture_error(tmp_path: Path) -> None:
    path = tmp_path / "r1.npz"
    path.write_bytes(b"not a zip archive")
    with pytest.raises(CaptureError, match=r"r1\.npz: cannot read \.npz recording"):
        aw.read_capture(path)


def test_unknown_suffix_names_the_registered_ones(tmp_path: Path) -> None:
    with pytest.raises(CaptureError, match=r"'\.txt'; expected \.csv, \.npz or \.parquet\."):
        aw.read_capture(tmp_path / "cap.txt")


@pytest.mark.usefixtures("registry")
def test_a_registered_format_reaches_reading_writing_and_the_monitor(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    aw.register_format(
        ".tsv",
        description="TSV",
        read=lambda path: (pd.read_csv(path, sep="\t"), {}),
        write=lambda frame, metadata, path: frame.to_csv(path, sep="\t", index=False),
    )
    folder = tmp_path / "fleet" / "r1" / "a1"
    folder.mkdir(parents=True)
    capture = _one_rate_capture(rng)
    written = aw.write_capture(capture, folder / "2026-03-01.TSV")
    assert written.read_text().startswith("time\tspeed\ttorque")
    np.testing.assert_allclose(
        aw.read_capture(written).signals["speed"], capture.signals["speed"], rtol=1e-15
    )
    aw.write_capture(capture, folder / "2026-03-02.npz")
    (folder / "notes.txt").write_text("not a capture")
    files, problems = discover_fleet(tmp_path / "fleet")
    assert [f.path.name for f in files] == ["2026-03-01.TSV", "2026-03-02.npz"]
    assert problems == []


def test_a_reader_failure_names_the_format(tmp_path: Path, registry: None) -> None:
    def broken(path: Path) -> tuple[pd.DataFrame, dict[str, str]]:
        raise OSError("disk said no")

    aw.register_format(".bad", description="Broken", read=broken, write=lambda *args: None)
    path = tmp_path / "cap.bad"
    path.write_text("x")
    with pytest.raises(CaptureError, match=r"cap\.bad: cannot read Broken file .*: disk said no"):
        aw.read_capture(path)


@pytest.mark.parametrize("suffix", ["tsv", ".", 3])
def test_register_format_needs_a_suffix_with_its_dot(suffix: object) -> None:
    with pytest.raises(ValueError, match=r"'suffix' parameter must be a file suffix with its dot"):
        aw.register_format(
            suffix,  # type: ignore[arg-type]
            description="x",
            read=lambda path: (pd.DataFrame(), {}),
            write=lambda *args: None,
        )


def _spreadsheet_text(separator: str, decimal: str, units: str | None = None) -> str:
    t = np.arange(40) / 100.0
    frame = pd.DataFrame({"time": t, "position": np.degrees(np.sin(t)), "torque": np.cos(t)})
    lines = frame.to_csv(index=False, sep=separator, decimal=decimal).splitlines()
    if units is not None:
        lines.insert(1, units)
    return "\ufeff" + "\n".join(lines) + "\n"  # a spreadsheet's byte order mark


@pytest.mark.parametrize(("separator", "decimal"), [(";", ","), (";", "."), ("\t", ",")])
def test_csv_separator_and_decimal_comma_are_taken_from_the_file(
    tmp_path: Path, separator: str, decimal: str
) -> None:
    # Before: "missing column 'time'; found columns ['time;position;torque']".
    path = tmp_path / "c.csv"
    path.write_text(_spreadsheet_text(separator, decimal), encoding="utf-8")
    capture = aw.read_capture(path)
    assert capture.rates_hz["position"] == pytest.approx(100.0)
    assert capture.signals["torque"][1] == pytest.approx(np.cos(0.01), rel=1e-12)


@pytest.mark.parametrize("units", [None, "s;rad;Nm"])
def test_a_decimal_comma_after_a_first_line_of_whole_numbers_is_read(
    tmp_path: Path, units: str | None
) -> None:
    # An axis at rest writes 0;0;1 first: "column 'torque' must be numeric; found '0,99995'".
    lines = _spreadsheet_text(";", ",", units).splitlines()
    first = 2 if units else 1
    lines[first] = "0;0;1"
    path = tmp_path / "c.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    capture = aw.read_capture(path)
    assert capture.signals["torque"][1] == pytest.approx(np.cos(0.01), rel=1e-12)


def test_a_units_row_is_not_read_as_values_and_is_checked(tmp_path: Path) -> None:
    # Before: "column 'time' must be numeric; found non-numeric value 's'".
    path = tmp_path / "c.csv"
    path.write_text(_spreadsheet_text(";", ",", "s;deg;Nm"), encoding="utf-8")
    with pytest.raises(
        CaptureError,
        match=r"units row gives 'deg' for column 'position' \(position\), but the capture is "
        r"read in rad \(the default, without an axis profile\); declare \[units\] position",
    ):
        aw.read_capture(path)
    profile = aw.AxisProfile(position_unit="deg")
    capture = aw.read_capture(path, profile=profile)
    assert capture.signals["position"][1] == pytest.approx(np.sin(0.01), rel=1e-9)  # rad
    assert capture.metadata == {}
    path.write_text(_spreadsheet_text(",", ".", "[s],[°],[Nm]"), encoding="utf-8")
    with pytest.raises(CaptureError, match=r"units row gives '\[°\]' for column 'position'"):
        aw.read_capture(path)
    path.write_text(_spreadsheet_text(",", ".", "sec,rad,%"), encoding="utf-8")  # torque: a label
    assert aw.read_capture(path).names == ("position", "torque")


@pytest.mark.parametrize("word", ["counts", "inc", "[Incr]"])
def test_encoder_counts_in_the_units_row_need_a_profile_with_counts(
    tmp_path: Path, word: str
) -> None:
    # Before: read as rad, silently (a 14-bit encoder's counts: 2608 times too large).
    path = tmp_path / "c.csv"
    path.write_text(_spreadsheet_text(";", ",", f"s;{word};Nm"), encoding="utf-8")
    with pytest.raises(
        CaptureError,
        match=rf"c\.csv: the units row gives '{re.escape(word)}' for column 'position' "
        r"\(position\), but the capture is read in rad \(the default, without an axis profile\); "
        r'declare \[units\] position = "counts" and counts_per_revolution \(encoder counts',
    ):
        aw.read_capture(path)
    profile = aw.AxisProfile(position_unit="counts", counts_per_revolution=360.0)
    capture = aw.read_capture(path, profile=profile)  # the file's values are degrees: 360 a turn
    assert capture.signals["position"][1] == pytest.approx(np.sin(0.01), rel=1e-9)


@pytest.mark.parametrize(
    ("units", "column", "expected"),
    [
        (
            "s;gon;Nm",  # a gradian (German "Grad" is a degree: read)
            "position",
            r"not a position unit axiswatch reads; expected one of \[.*'deg'",
        ),
        ("s;deg;Nm", "time", r"not a time unit axiswatch reads; expected one of \['ms', 'msec'"),
        ("s;rpm;Nm", "speed", r"not a speed unit axiswatch reads; expected one of \[.*'deg/s'"),
    ],
)
def test_an_unknown_unit_word_for_time_position_or_speed_is_an_error(
    tmp_path: Path, units: str, column: str, expected: str
) -> None:
    # Before: an unknown word was not checked and the column read in rad (or s), silently.
    text = _spreadsheet_text(";", ",", units)
    if column == "time":
        text = text.replace("s;deg;Nm", "deg;rad;Nm")
    elif column == "speed":
        text = text.replace("time;position;torque", "time;speed;torque")
    path = tmp_path / "c.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(
        CaptureError, match=rf"c\.csv: the units row gives .* for column '{column}' .*{expected}"
    ):
        aw.read_capture(path)


def test_a_parquet_file_indexed_by_its_time_stamps_is_read(tmp_path: Path) -> None:
    # Before: "missing column 'time'; found columns ['speed', 'torque']".
    t = np.arange(40) / 100.0
    frame = pd.DataFrame({"time": t, "speed": np.sin(t), "torque": np.cos(t)})
    path = tmp_path / "c.parquet"
    frame.set_index("time").to_parquet(path)
    assert aw.read_capture(path).rates_hz["speed"] == pytest.approx(100.0)
    dated = frame.set_index(pd.Timestamp("2026-03-01") + pd.to_timedelta(frame.pop("time"), "s"))
    dated.rename_axis("time").to_parquet(path)
    assert aw.read_capture(path).rates_hz["torque"] == pytest.approx(100.0)


@pytest.mark.parametrize("separator", [",", ";"])
def test_a_csv_file_cut_off_in_a_row_is_a_capture_error(tmp_path: Path, separator: str) -> None:
    # A logger that died mid-write, or a copy cut short, leaves a file that ends inside a row.
    # Before: read as a shorter capture, which a monitor scored (an ALARM on its drive load).
    path = tmp_path / "c.csv"
    text = _spreadsheet_text(separator, ".")
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    cut = text[: len(text) - 1 - len(last) + last.index(separator) + 3]  # inside the last row
    path.write_text(cut, encoding="utf-8")
    with pytest.raises(CaptureError, match=r"ends inside a row .* cut off"):
        aw.read_capture(path)
    path.write_text(text, encoding="utf-8")  # complete now
    assert len(aw.read_capture(path).signals["torque"]) == len(text.splitlines()) - 1
    path.write_text(text.rstrip("\n"), encoding="utf-8")  # whole, but without a final line break
    assert len(aw.read_capture(path).signals["torque"]) == len(text.splitlines()) - 1


def _windows_text() -> str:
    """A German controller's export: a units row with '°' and a header with 'ü' and '°C'."""
    t = np.arange(40) / 100.0
    frame = pd.DataFrame(
        {"time": t, "position": np.sin(t), "torque": np.cos(t), "Temperatur Gehäuse °C": 40.0}
    )
    lines = frame.to_csv(index=False, sep=";", decimal=",").splitlines()
    lines.insert(1, "s;rad;N·m;°C")
    return "\r\n".join(lines) + "\r\n"


@pytest.mark.parametrize("encoding", ["cp1252", "utf-8", "utf-8-sig", "utf-16"])
def test_a_csv_file_is_read_in_its_encoding(tmp_path: Path, encoding: str) -> None:
    # Before, cp1252 and utf-16: "cannot read CSV file (truncated or corrupt?)", a UTF-8 error.
    path = tmp_path / "c.csv"
    path.write_bytes(_windows_text().encode(encoding))
    capture = aw.read_capture(path)
    assert capture.names == ("position", "torque")
    assert capture.signals["torque"][1] == pytest.approx(np.cos(0.01), rel=1e-12)
    assert axiswatch._formats.csv_encoding(path).replace("-le", "") in (encoding, "utf-8-sig")


def test_a_declared_encoding_is_used_and_a_wrong_one_named(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    # Polish "Źródło": byte 0x8f in cp1250, a byte cp1252 leaves undefined.
    path.write_bytes(_windows_text().replace("Gehäuse", "Źródło").encode("cp1250"))
    with pytest.raises(
        CaptureError,
        match=r"c\.csv: the text is neither UTF-8 \(byte 0x8f at 32\) nor Windows-1252; "
        r'declare its encoding in the axis profile, such as encoding = "cp1250"',
    ):
        aw.read_capture(path)
    capture = aw.read_capture(path, profile=aw.AxisProfile(encoding="cp1250"))
    assert capture.signals["torque"][1] == pytest.approx(np.cos(0.01), rel=1e-12)
    with pytest.raises(CaptureError, match=r"c\.csv: not utf-8 text \(byte 0x8f at 32 .*declare"):
        aw.read_capture(path, profile=aw.AxisProfile(encoding="utf-8"))
    with pytest.raises(ProfileError, match=r"encoding 'klingon' is not a text encoding"):
        aw.AxisProfile(encoding="klingon")


def _write_parquet_as(how: str, frame: pd.DataFrame, path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    if how == "no pandas metadata":
        # NaN written as nulls (from_pandas), as a logger writing Arrow itself leaves a gap.
        columns = {k: pa.array(v.to_numpy(), from_pandas=True) for k, v in frame.items()}
        assert columns["speed"].null_count > 0
        pq.write_table(pa.Table.from_pydict(columns), path)
    elif how == "index column":
        frame.set_index("time").to_parquet(path)
    elif how == "float32":
        frame.astype({"speed": np.float32}).to_parquet(path)
    elif how == "text column":
        frame.assign(mode="run").to_parquet(path)
    else:  # pandas' default: a RangeIndex kept as metadata
        frame.to_parquet(path, index=None if how == "range index" else False)


@pytest.mark.parametrize(
    ("how", "fast"),
    [
        ("no index", True),
        ("no pandas metadata", True),
        ("range index", False),
        ("index column", False),
        ("float32", False),
        ("text column", False),
    ],
)
def test_parquet_float_columns_are_read_as_pandas_reads_them(
    tmp_path: Path, how: str, fast: bool
) -> None:
    # A table of float columns is read without to_pandas (half the read's time): the same frame.
    import pyarrow.parquet as pq

    t = np.arange(40) / 100.0
    speed = np.where(np.arange(40) % 7 == 3, np.nan, np.sin(t))  # NaN: nulls or NaN in the file
    frame = pd.DataFrame({"time": t, "speed": speed, "torque": np.cos(t)})
    path = tmp_path / "c.parquet"
    _write_parquet_as(how, frame, path)
    table = pq.read_table(path)
    assert (axiswatch._formats._float_frame(table) is not None) == fast
    expected = table.to_pandas()
    if not isinstance(expected.index, pd.RangeIndex):
        expected = expected.reset_index()
    read, _ = axiswatch._formats._read_parquet(path)
    # The same names; without to_pandas they are Python text (object), looked up faster.
    pd.testing.assert_frame_equal(read, expected, check_exact=True, check_column_type=not fast)
    assert list(read.columns) == list(expected.columns)


def test_a_parquet_capture_is_read_on_one_thread_as_the_default_read_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Decoding a capture's few columns on pyarrow's threads cost twice the CPU time of one
    # thread; the monitor scores captures in parallel processes instead. Same table.
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(5000) / 2000.0
    speed = pa.array(np.where(np.arange(5000) % 9 == 0, np.nan, np.sin(t)), from_pandas=True)
    table = pa.table({"time": t, "speed": speed, "torque": np.cos(t)})
    path = tmp_path / "c.parquet"
    pq.write_table(table, path, row_group_size=1024)  # five row groups, nulls in one column
    threads: list[object] = []
    read = pq.ParquetFile.read

    def spied(self: pq.ParquetFile, *args: object, **kwargs: object) -> pa.Table:
        threads.append(kwargs.get("use_threads", True))
        return read(self, *args, **kwargs)

    monkeypatch.setattr(pq.ParquetFile, "read", spied)
    frame, _ = axiswatch._formats._read_parquet(path)
    assert threads == [False]
    expected = pq.read_table(path).to_pandas()
    pd.testing.assert_frame_equal(frame, expected, check_exact=True, check_column_type=False)
