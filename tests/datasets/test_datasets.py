"""Dataset folders: reading .npz recordings, cutting them per days.csv, clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.datasets as awd
from tests.conftest import SHARED_DATA

_INDEX = "recording_id,condition_id,health\nh0,load0,healthy\nb1,load1,faulty\n"
_DAYS = (
    "day_id,recording_id,start,stop,condition_id,health,role,expected_alarm\n"
    "h0__s0,h0,0,50,load0,healthy,baseline,\n"
    "h0__s1,h0,50,100,load0,healthy,test_healthy_same_condition,0\n"
    "b1__s0,b1,0,100,load1,faulty,test_fault_other_condition,1\n"
)


def _recording(path: Path, *, fs: float = 200.0, n: int = 100, **overrides: object) -> None:
    arrays: dict[str, object] = {
        "signals": np.arange(2 * n, dtype=np.float32).reshape(2, n),
        "channels": np.array(["x", "y"]),
        "fs": np.float64(fs),
        "meta": json.dumps({"recording_id": path.stem}),
    }
    arrays.update(overrides)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    _recording(tmp_path / "h0.npz")
    _recording(tmp_path / "b1.npz", fs=float("nan"))
    (tmp_path / "index.csv").write_text(_INDEX)
    (tmp_path / "days.csv").write_text(_DAYS)
    return tmp_path


def test_segments_follow_days_csv(folder: Path) -> None:
    segments = awd.read_dataset(folder)
    assert [(s.segment_id, s.condition, s.healthy, s.role, s.start) for s in segments] == [
        ("h0__s0", "load0", True, "baseline", 0),
        ("h0__s1", "load0", True, "test_healthy_same_condition", 50),
        ("b1__s0", "load1", False, "test_fault_other_condition", 0),
    ]
    second = segments[1].capture
    np.testing.assert_array_equal(second.signals["y"], np.arange(150, 200))
    assert second.rates_hz == {"x": 200.0, "y": 200.0}
    assert second.start_s == pytest.approx(0.25)


def test_unknown_rate_gets_the_nominal_rate(folder: Path) -> None:
    capture = awd.read_recording(folder / "b1.npz")
    assert capture.rates_hz["x"] == awd.NOMINAL_RATE_HZ
    assert capture.metadata["fs_stated"] == "false"
    assert awd.read_recording(folder / "b1.npz", nominal_rate_hz=5.0).rates_hz["x"] == 5.0


def test_without_days_csv_each_recording_is_one_segment(folder: Path) -> None:
    (folder / "days.csv").unlink()
    segments = awd.read_dataset(folder, recordings=["b1"])
    assert [(s.segment_id, s.role, len(s.capture.signals["x"])) for s in segments] == [
        ("b1", "recording", 100)
    ]


def test_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(
        aw.DataNotFoundError,
        match=r"nope: dataset folder not found; expected a folder with index.csv",
    ):
        awd.read_dataset(tmp_path / "nope")


def test_missing_index(folder: Path) -> None:
    (folder / "index.csv").unlink()
    with pytest.raises(FileNotFoundError, match=r"index.csv: missing; a dataset folder lists"):
        awd.read_dataset(folder)


def test_missing_recording_file(folder: Path) -> None:
    (folder / "b1.npz").unlink()
    with pytest.raises(aw.DataNotFoundError, match=r"b1.npz: no such recording file"):
        awd.read_dataset(folder)


def test_index_without_health_column(folder: Path) -> None:
    (folder / "index.csv").write_text("recording_id,condition_id\nh0,load0\n")
    with pytest.raises(aw.CaptureError, match=r"index.csv: missing column\(s\) \['health'\]"):
        awd.read_dataset(folder)


def test_unknown_health_label(folder: Path) -> None:
    (folder / "index.csv").write_text(_INDEX.replace("faulty", "broken"))
    with pytest.raises(
        aw.CaptureError, match=r"'health' must be 'healthy' or 'faulty'; found 'broken'"
    ):
        awd.read_dataset(folder)


def test_unreadable_csv(folder: Path) -> None:
    (folder / "index.csv").write_text("")
    with pytest.raises(aw.CaptureError, match=r"index.csv: cannot read CSV table"):
        awd.read_dataset(folder)


def test_days_naming_an_unlisted_recording(folder: Path) -> None:
    (folder / "days.csv").write_text(_DAYS.replace("b1__s0,b1", "b1__s0,zz"))
    with pytest.raises(
        aw.CaptureError, match=r"days.csv: recording\(s\) \['zz'\] are not listed in index.csv"
    ):
        awd.read_dataset(folder)


def test_segment_outside_recording(folder: Path) -> None:
    (folder / "days.csv").write_text(_DAYS.replace("0,100,load1", "0,150,load1"))
    with pytest.raises(
        aw.CaptureError, match=r"segment 'b1__s0' covers samples 0..150 but recording 'b1' has 100"
    ):
        awd.read_dataset(folder)


def test_segment_bounds_not_integers(folder: Path) -> None:
    (folder / "days.csv").write_text(_DAYS.replace("0,100,load1", "0,end,load1"))
    with pytest.raises(
        aw.CaptureError, match=r"segment 'b1__s0' has start=0, stop='end'; expected sample numbers"
    ):
        awd.read_dataset(folder)


def test_recording_missing_array(tmp_path: Path) -> None:
    _recording(tmp_path / "r.npz", channels=None)
    with pytest.raises(aw.CaptureError, match=r"r.npz: missing array 'channels'"):
        awd.read_recording(tmp_path / "r.npz")


def test_recording_shape_mismatch(tmp_path: Path) -> None:
    _recording(tmp_path / "r.npz", channels=np.array(["x", "y", "z"]))
    with pytest.raises(
        aw.CaptureError, match=r"one row per name in 'channels' \(3\); got shape \(2, 100\)"
    ):
        awd.read_recording(tmp_path / "r.npz")


def test_recording_bad_rate(tmp_path: Path) -> None:
    _recording(tmp_path / "r.npz", fs=-3.0)
    with pytest.raises(
        aw.CaptureError, match=r"'fs' must be a positive number of Hz, or NaN when unknown"
    ):
        awd.read_recording(tmp_path / "r.npz")


def test_recording_bad_meta(tmp_path: Path) -> None:
    _recording(tmp_path / "r.npz", meta="{not json")
    with pytest.raises(aw.CaptureError, match=r"'meta' must be a JSON object; Expecting"):
        awd.read_recording(tmp_path / "r.npz")
    _recording(tmp_path / "r.npz", meta="[1, 2]")
    with pytest.raises(aw.CaptureError, match=r"'meta' must be a JSON object; got list"):
        awd.read_recording(tmp_path / "r.npz")


def test_recording_not_npz(tmp_path: Path) -> None:
    (tmp_path / "r.npz").write_bytes(b"not a zip file")
    with pytest.raises(aw.CaptureError, match=r"r.npz: cannot read .npz recording"):
        awd.read_recording(tmp_path / "r.npz")


def test_default_data_dir_from_project_root(tmp_path: Path) -> None:
    project = tmp_path / "project"
    (project / "sub").mkdir(parents=True)
    (project / "pyproject.toml").write_text("")
    (tmp_path / "shared" / "data" / "gearbox").mkdir(parents=True)
    assert (
        awd.default_data_dir("gearbox", cwd=project / "sub")
        == tmp_path / "shared" / "data" / "gearbox"
    )


@pytest.mark.realdata
def test_real_folders_load() -> None:
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is absent")
    gearbox = awd.read_dataset(SHARED_DATA / "gearbox_spectraquest", recordings=["healthy_load00"])
    assert len(gearbox) == 4
    assert gearbox[0].capture.names == ("a1", "a2", "a3", "a4")
    assert gearbox[0].capture.rates_hz["a1"] == awd.NOMINAL_RATE_HZ  # the rig's rate is unknown
    voraus = awd.read_dataset(SHARED_DATA / "voraus_ad_test")
    assert [s.healthy for s in voraus] == [False, True, True, True]
    assert voraus[0].capture.rates_hz["motor_torque_1"] == 100.0
