"""The monitor's methods: one default for library and CLI, a registered method reaches both."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
from numpy.typing import NDArray
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch.monitor._methods
from axiswatch.cli import app
from axiswatch.monitor import MethodPreset, MonitorConfig, methods, register_method
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor._results import fleet_results

runner = CliRunner()


class RmsDetector(aw.BaselineDetector):
    """A new detector, as a user would write one: the change of the features' RMS."""

    def _fit(self, X: NDArray[np.float64]) -> None:
        self.rms_ = float(np.sqrt(np.mean(X**2)))

    def _distance(self, X: NDArray[np.float64]) -> float:
        return abs(float(np.sqrt(np.mean(X**2))) - self.rms_)


@pytest.fixture
def registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Registrations of a test go to a copy of the table, dropped afterwards."""
    monkeypatch.setattr(
        axiswatch.monitor._methods, "_METHODS", dict(axiswatch.monitor._methods._METHODS)
    )


@pytest.fixture
def fleet(small_fleet: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(small_fleet, tmp_path / "fleet"))


def test_a_registered_detector_reaches_the_monitor_and_the_cli(
    registry: None, fleet: Path, tmp_path: Path
) -> None:
    register_method("rms", MethodPreset(detector=lambda config: RmsDetector(), summary="RMS"))
    # Built in first, then plugins (the lab's ``mechanics`` when it is installed), then "rms".
    assert list(methods())[:3] == ["indicators", "lra", "pca"]
    assert list(methods())[-1] == "rms"
    store = tmp_path / "s.db"
    result = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "rms"])
    assert result.exit_code == 0, result.output
    assert "rms: 18 capture files, 2 new baseline(s), 16 capture(s) scored" in result.output
    with aw.Store(store) as opened:
        results = fleet_results(opened)
    assert set(results.method) == {"rms"}
    monitored = results[results.role == "monitor"]
    assert len(monitored) == 6
    assert (monitored.distance > 0).all()
    wrong = runner.invoke(app, ["monitor", str(fleet), "--store", str(store), "--method", "rmz"])
    assert wrong.exit_code == 2
    words = " ".join(wrong.output.replace("│", " ").split())
    assert re.search(r"expected one of indicators, lra, pca, (\S+, )*rms; got 'rmz'", words)


class ExplainedStage(aw.FeatureStage):
    """A stage that says why a capture has its distance: each score keeps its words."""

    def __init__(self, window: int = 100) -> None:
        self.window = window

    def fit(self, baseline: aw.Capture) -> ExplainedStage:
        return self

    def transform(self, capture: aw.Capture) -> aw.Features:
        torque = capture.signals["torque"]
        rows = torque[: torque.size // self.window * self.window].reshape(-1, self.window)
        rms = np.sqrt(np.mean(rows**2, axis=1, keepdims=True))
        rate = float(capture.rates_hz["torque"])
        return aw.Features(rms, ("torque",), None, rate, ("rms",))

    def explain(self, detector: object, X: NDArray[np.float64]) -> dict[str, dict[str, float]]:
        return {"rms": {"value": float(np.mean(X)), "spreads": 1.0, "share": 1.0}}


def test_a_stage_that_explains_its_distance_fills_the_scores_indicators(
    registry: None, fleet: Path, tmp_path: Path
) -> None:
    register_method(
        "explained",
        MethodPreset(
            detector=lambda config: RmsDetector(),
            stage=lambda config: ExplainedStage(),
        ),
    )
    with aw.Store(tmp_path / "s.db") as store:
        monitor_fleet(fleet, store, MonitorConfig(method="explained"))
        results = fleet_results(store)
    monitored = results[results.role == "monitor"]
    assert len(monitored) == 6
    for row in monitored.itertuples():
        (entry,) = json.loads(row.details)["indicators"].values()
        assert entry["value"] > 0
    # A stage without the method stores no indicators.
    register_method("plain", MethodPreset(detector=lambda config: RmsDetector()))
    with aw.Store(tmp_path / "p.db") as store:
        monitor_fleet(fleet, store, MonitorConfig(method="plain"))
        plain = fleet_results(store)
    assert not any("indicators" in json.loads(d) for d in plain.details)


def test_register_method_refuses_bad_and_taken_names(registry: None) -> None:
    preset = MethodPreset(detector=lambda config: RmsDetector())
    with pytest.raises(ValueError, match=r"letters, digits, '_' and '-'. Got 'a b' instead"):
        register_method("a b", preset)
    with pytest.raises(ValueError, match=r"'pca' is registered already; pass replace=True"):
        register_method("pca", preset)
    register_method("pca", preset, replace=True)
    assert isinstance(MonitorConfig(method="pca").model().detector, RmsDetector)


def test_library_and_cli_share_one_default(fleet: Path, tmp_path: Path) -> None:
    defaults = MonitorConfig()
    # The product default since issue 13: every spread and allowance estimated from the axis and
    # its fleet (tests/test_indicator_model.py: nothing in its decision path from a simulator).
    assert defaults.method == "indicators"
    assert defaults.preset.indicator_model
    assert defaults.threshold_floor() == 0.0
    command = typer.main.get_command(app).commands["monitor"]  # type: ignore[attr-defined]
    options = {p.name: p.default for p in command.params}
    assert options["method"] == defaults.method
    assert options["percentile"] == defaults.percentile
    assert options["calibration"] == defaults.calibration_size
    assert (options["alarm_k"], options["alarm_n"], options["clear_m"]) == (
        defaults.alarm_k,
        defaults.alarm_n,
        defaults.clear_m,
    )
    assert options["signals"] == ",".join(defaults.features.signals)
    assert options["hop"] == defaults.features.hop
    assert options["segment_length"] == defaults.features.segment_length
    assert options["align"] is defaults.align_phase
    # The same run by both.
    with aw.Store(tmp_path / "library.db") as store:
        monitor_fleet(fleet, store, settle_s=0)
        by_library = fleet_results(store)
    runner.invoke(
        app, ["monitor", str(fleet), "--store", str(tmp_path / "cli.db"), "--settle", "0"]
    )
    with aw.Store(tmp_path / "cli.db") as store:
        by_cli = fleet_results(store)
    assert set(by_cli.method) == {"indicators"}
    assert len(by_cli) > 0
    columns = ["robot", "axis", "capture", "method", "role", "distance", "threshold", "alarm"]
    pd.testing.assert_frame_equal(by_library[columns], by_cli[columns])
