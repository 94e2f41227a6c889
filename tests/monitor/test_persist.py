"""Fitted models stored as arrays and JSON: exact round trips, refusals, reuse by the monitor."""

from __future__ import annotations

import io
import json
import os
import shutil
import sqlite3
import zipfile
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.monitor._index
import axiswatch.monitor._models
import axiswatch.monitor._monitor
import axiswatch.monitor._planning
import axiswatch.monitor._run
import axiswatch.monitor._scoring
from axiswatch.datasets import simulate_capture
from axiswatch.monitor._config import MonitorConfig
from axiswatch.monitor._models import ModelRef, resolve_model
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor._persist import dump_model, load_model, model_digest
from axiswatch.monitor.report.results import fleet_results
from axiswatch.monitor.store import NewBaseline, SavedModel, Store


def _fitted(method: str) -> aw.HealthModel:
    config = MonitorConfig(method=method)
    model = config.model().fit(simulate_capture("heavy", seed=1, duration_s=3.0))
    return model.calibrate([simulate_capture("heavy", seed=s, duration_s=3.0) for s in (2, 3)])


@pytest.mark.parametrize("method", ["lra", "pca"])
def test_round_trip_gives_identical_distances(method: str) -> None:
    model = _fitted(method)
    back = load_model(dump_model(model, params={"method": method}))
    assert type(back) is aw.HealthModel
    assert type(back.detector_) is type(model.detector_)
    tests = [simulate_capture(task, seed=7, duration_s=3.0) for task in ("heavy", "palletize")]
    for capture in tests:
        # Exact: the stored model is the fitted one, bit for bit.
        assert back.distance(capture) == model.distance(capture)
        assert back.assess(capture) == model.assess(capture)
    assert back.fingerprint() == model.fingerprint()
    assert model_digest(dump_model(back)) == model_digest(dump_model(model))


def test_an_lra_model_stored_with_its_baseline_features_still_scores() -> None:
    # Written by the previous layout, which kept the baseline's |STFT| features in the model
    # and in its detector; the distances and fingerprint it gave then. A stored blob of a model
    # fitted on simulated captures (an .npz archive, named .blob: it is no recorded data).
    blob = (Path(__file__).parents[1] / "data" / "lra-model-format10.blob").read_bytes()
    model = load_model(blob)
    assert isinstance(model.detector_.baseline_, np.ndarray)  # the stored form, as it was
    expected = {0.3: 0.05487800949954262, 0.25: 0.06274353083066554}  # 0.25 s: shorter
    for seconds, distance in expected.items():
        capture = simulate_capture("palletize", seed=4, duration_s=seconds)
        assert model.distance(capture) == pytest.approx(distance, rel=1e-9)
    fingerprint = "12a638fd47d19de413696970d4a979771edc591a0b9176a8a58c7d4f90916cb8"
    assert model.fingerprint() == fingerprint
    refitted = aw.HealthModel(aw.FeatureSpec(segment_length=16, hop=8), aw.LRADetector())
    assert refitted.fit(simulate_capture("heavy", seed=1, duration_s=0.3)).fingerprint() == (
        fingerprint
    )


def test_blob_is_arrays_and_json_only() -> None:
    blob = dump_model(_fitted("pca"), params={"method": "pca"})
    with zipfile.ZipFile(io.BytesIO(blob)) as archive:
        assert all(name.endswith(".npy") for name in archive.namelist())
    with np.load(io.BytesIO(blob), allow_pickle=False) as arrays:
        meta = json.loads(arrays["__meta__"].tobytes())
    assert meta["params"] == {"method": "pca"}
    assert meta["model"]["__object__"] == "axiswatch.HealthModel"
    assert isinstance(meta["library_version"], str)


def test_non_finite_floats_and_containers_survive() -> None:
    detector = aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    detector.extra_ = {"nan": float("nan"), "inf": -np.inf, "pair": (1, np.float64(2.5))}
    back = load_model(dump_model(detector))
    assert np.isnan(back.extra_["nan"])
    assert back.extra_["inf"] == -np.inf
    assert back.extra_["pair"] == (1, 2.5)
    assert type(back.extra_["pair"][1]) is np.float64


def test_unregistered_class_is_refused_with_its_path() -> None:
    detector = aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    detector.helper_ = Path("somewhere")
    with pytest.raises(TypeError, match=r"IndicatorDetector\.helper_: .*Path is not in .*ALLOWED"):
        dump_model(detector)


def test_object_arrays_and_foreign_classes_in_a_blob_are_refused() -> None:
    detector = aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    detector.rows_ = np.array([object()])
    with pytest.raises(TypeError, match=r"IndicatorDetector\.rows_: an object array"):
        dump_model(detector)
    blob = dump_model(aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]]))
    with np.load(io.BytesIO(blob)) as archive:
        arrays = {name: archive[name] for name in archive.files}
    meta = json.loads(arrays["__meta__"].tobytes())
    meta["model"]["__object__"] = "os.system"
    arrays["__meta__"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    forged = io.BytesIO()
    np.savez(forged, **arrays)
    with pytest.raises(ValueError, match=r"names class 'os.system', which is not in ALLOWED"):
        load_model(forged.getvalue())


# --- the monitor reuses stored models, and refits when they no longer apply --------------------


def _count_fits(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    fitted: list[str] = []
    original = axiswatch.monitor._scoring.fit_baseline

    def counting(job: axiswatch.monitor._scoring.FitJob) -> object:
        fitted.append(job.file.capture)
        return original(job)

    monkeypatch.setattr(axiswatch.monitor._planning, "fit_baseline", counting)
    return fitted


def test_monitor_scores_with_stored_models_and_refits_on_a_new_version(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    held = tmp_path / "held"
    held.mkdir()
    late = sorted(fleet.glob("*/*/*-09.parquet"))
    for path in late:
        path.rename(held / f"{path.parent.name}.parquet")
    fitted = _count_fits(monkeypatch)
    config = MonitorConfig(method="lra")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
        assert len(fitted) == 2  # one baseline per axis
        for path in late:
            (held / f"{path.parent.name}.parquet").rename(path)
        summary = monitor_fleet(fleet, store, config)
        assert summary.scored == 2
        assert len(fitted) == 2  # the stored models scored the new captures: no refit
        with_stored = fleet_results(store)
    # Same results as a run that fits everything afresh (no store, no cache).
    with Store(tmp_path / "fresh.db") as fresh:
        monitor_fleet(fleet, fresh, config)
        columns = ["robot", "axis", "capture", "role", "distance", "threshold", "alarm"]
        assert fleet_results(fresh)[columns].equals(with_stored[columns])
    # A new library version or blob format (model_version) invalidates the stored models:
    # refitted once, then reused.
    for module in (axiswatch.monitor._planning, axiswatch.monitor._run):
        monkeypatch.setattr(module, "model_version", lambda: "99.0, format 9")
    new_day = [p.with_name(p.name.replace("-09", "-10")) for p in late]
    for source, target in zip(late, new_day, strict=True):
        shutil.copy(source, target)
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
    assert len(fitted) == 4 + 2  # 2 by the fresh store, 2 refits


def test_worker_reads_a_missing_model_from_the_store_once(tmp_path: Path) -> None:
    model = _fitted("pca")
    blob = dump_model(model)
    key = model_digest(blob)
    with Store(tmp_path / "s.db") as store:
        added = store.add_baseline(
            NewBaseline(
                robot="r", axis="a", method="pca", epoch=1, capture="c.csv",
                captured_at=datetime(2026, 3, 1), path="r/a/c.csv", file_hash="h",
                features_hash="f", params="{}", library_version="v", file_size=1,
                file_mtime_ns=1, reason="baseline", details={},
            )
        )  # fmt: skip
        assert added is not None
        baseline_id = added.id
        store.save_model(baseline_id, SavedModel("h", "{}", "v", key, {}), blob)
        assert store.saved_model(baseline_id) == SavedModel("h", "{}", "v", key, {})
    ref = ModelRef(key, str(tmp_path / "s.db"))
    loaded = resolve_model(ref)
    assert resolve_model(ref) is loaded  # kept by the worker after the first read
    capture = simulate_capture("palletize", seed=3, duration_s=3.0)
    assert loaded.distance(capture) == model.distance(capture)
    with pytest.raises(LookupError, match=r"holds no fitted model 000000000000"):
        resolve_model(ModelRef("0" * 64, str(tmp_path / "s.db")))


# --- incremental discovery ---------------------------------------------------------------------


def test_run_with_nothing_new_lists_no_folder_and_hashes_nothing(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    config = MonitorConfig(method="pca")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
        before = fleet_results(store)
        hashed: list[Path] = []
        original = axiswatch.monitor._index.file_hash
        monkeypatch.setattr(
            axiswatch.monitor._index, "file_hash", lambda p: hashed.append(p) or original(p)
        )
        listed: list[tuple[str, str]] = []
        discover = axiswatch.monitor._monitor.discover_fleet

        def spying(root: Path, *, skip: object) -> object:
            def watching(robot: str, axis: str) -> bool:
                skipped = skip(robot, axis)  # type: ignore[operator]
                if not skipped:
                    listed.append((robot, axis))
                return bool(skipped)

            return discover(root, skip=watching)

        monkeypatch.setattr(axiswatch.monitor._monitor, "discover_fleet", spying)
        # The folders really read from the disk (os.walk lists a folder before yielding it).
        scanned: list[Path] = []
        scandir = os.scandir

        def scanning(path: str | Path = ".") -> object:
            scanned.append(Path(path))
            return scandir(path)

        monkeypatch.setattr(os, "scandir", scanning)
        summary = monitor_fleet(fleet, store, config)
        assert (summary.scored, summary.exit_code, hashed, listed) == (0, 0, [], [])
        axis_folders_read = [p for p in scanned if len(p.relative_to(fleet).parts) == 2]
        assert axis_folders_read == []
        assert fleet_results(store).equals(before)
        # A new capture changes its folder: that folder alone is listed, the file hashed.
        source = fleet / "robot01/axis1/2026-03-09.parquet"
        shutil.copy(source, source.with_name("2026-03-10.parquet"))
        summary = monitor_fleet(fleet, store, config, settle_s=0.0)  # just written
    assert summary.scored == 1
    assert listed == [("robot01", "axis1")]
    assert [p.name for p in hashed] == ["2026-03-10.parquet"]


def test_files_changed_in_place_are_found_a_slice_at_a_time(
    small_fleet: Path, tmp_path: Path
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    config = MonitorConfig(method="pca")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
        assert len(store.files_to_verify(run=10**9, limit=1000)) == 18
        target = fleet / "robot01/axis2/2026-03-08.parquet"
        capture = aw.read_capture(target)
        aw.write_capture(
            aw.Capture({k: 2.0 * v for k, v in capture.signals.items()}, capture.rates_hz),
            target,
        )
        found_after = None
        for run in range(1, 7):
            if monitor_fleet(fleet, store, config, verify_per_run=4).changed:
                found_after = run
                break
    # 18 files, 4 verified per run, least recently verified first: within ceil(18 / 4) runs.
    assert found_after is not None
    assert found_after <= 5


def test_a_store_made_before_the_index_indexes_its_scored_files(
    small_fleet: Path, tmp_path: Path
) -> None:
    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    config = MonitorConfig(method="pca")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
    with sqlite3.connect(tmp_path / "s.db") as db:  # as a store made before the caches
        for table in ("file_index", "axis_folders", "fitted_models"):
            db.execute(f"DROP TABLE {table}")
    target = fleet / "robot01/axis2/2026-03-08.parquet"
    capture = aw.read_capture(target)
    aw.write_capture(
        aw.Capture({k: 2.0 * v for k, v in capture.signals.items()}, capture.rates_hz), target
    )
    with Store(tmp_path / "s.db") as store:
        summary = monitor_fleet(fleet, store, config)
    assert summary.changed == [
        "robot01/axis2/2026-03-08.parquet: content changed after it was scored; the stored "
        "result is kept (re-baseline the axis to score it afresh)"
    ]
    assert summary.scored == 0


def test_a_model_that_cannot_be_stored_travels_with_its_jobs(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = MonitorConfig(method="pca")
    columns = ["robot", "axis", "capture", "role", "distance", "threshold", "alarm"]
    with Store(tmp_path / "stored.db") as store:
        monitor_fleet(small_fleet, store, config)
        stored = fleet_results(store)[columns]

    def refuse(model: object, **_: object) -> bytes:
        raise TypeError("cannot store HealthModel.detector_: not in ALLOWED_CLASSES")

    monkeypatch.setattr(axiswatch.monitor._models, "dump_model", refuse)
    with Store(tmp_path / "inline.db") as store:
        monitor_fleet(small_fleet, store, config)
        assert [store.saved_model(i) for i in (1, 2)] == [None, None]
        assert fleet_results(store)[columns].equals(stored)


def test_a_stored_model_keeps_the_baselines_data_quality_reference(
    small_fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A run that scores with a stored model (no refit) still judges "no motion" against the
    baseline capture's spans: the reference is stored with the model."""
    import os

    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    late = sorted(fleet.glob("*/*/*-09.parquet"))
    captures = {path: aw.read_capture(path) for path in late}
    for path in late:
        path.unlink()
    fitted = _count_fits(monkeypatch)
    config = MonitorConfig(method="pca")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
        assert len(fitted) == 2
        for path, capture in captures.items():
            for name, values in capture.signals.items():
                if name != "torque":  # position and speed barely move: an idle robot
                    capture.signals[name] = values.mean() + 1e-3 * (values - values.mean())
            aw.write_capture(capture, path)
            os.utime(path, (path.stat().st_atime - 3600, path.stat().st_mtime - 3600))
        summary = monitor_fleet(fleet, store, config)
    assert len(fitted) == 2  # scored with the stored models
    assert summary.scored == 0
    assert len([r for r in summary.rejected if "bad data (no motion" in r]) == len(late) == 2, (
        summary
    )


def test_packed_arrays_keep_dtype_shape_and_bytes() -> None:
    detector = aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    detector.extra_ = {
        "ints": np.arange(7, dtype=np.int32),
        "flags": np.array([[True, False]]),
        "scalar": np.array(2.5),
        "empty": np.zeros((0, 3)),
        "big_endian": np.arange(3, dtype=">f8"),
    }
    back = load_model(dump_model(detector))
    for name, array in detector.extra_.items():
        got = back.extra_[name]
        assert got.dtype == array.dtype, name
        assert got.shape == array.shape, name
        assert got.tobytes() == array.tobytes(), name
        assert got.flags.writeable, name


def test_structured_arrays_are_refused() -> None:
    detector = aw.IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    detector.table_ = np.zeros(2, dtype=[("a", "<f8"), ("b", "<i8")])
    with pytest.raises(TypeError, match="structured array cannot be stored"):
        dump_model(detector)


def test_a_fleet_folder_emptied_after_runs_is_still_an_unmounted_share(
    small_fleet: Path, tmp_path: Path
) -> None:
    # A store that knows finished folders proves the fleet folder mounted with one stat of an
    # unchanged axis folder; once the share is gone (its folders too) it looks again and fails.
    from axiswatch.exceptions import DataNotFoundError

    fleet = Path(shutil.copytree(small_fleet, tmp_path / "fleet"))
    config = MonitorConfig(method="pca")
    with Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, config)
        assert monitor_fleet(fleet, store, config).scored == 0
        shutil.rmtree(fleet)
        (fleet / "robot01").mkdir(parents=True)  # the mount point's leftovers, no captures
        with pytest.raises(DataNotFoundError, match="holds no capture file"):
            monitor_fleet(fleet, store, config)
