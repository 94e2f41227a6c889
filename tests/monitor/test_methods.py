"""The monitor's methods: one default for library and CLI, a registered method reaches both."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
import typer
from numpy.typing import NDArray
from typer.testing import CliRunner

import axiswatch as aw
import axiswatch.monitor._methods
from axiswatch.cli import app, monitor_defaults
from axiswatch.monitor import MethodPreset, MonitorConfig, methods, register_method
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor.report.results import fleet_results

runner = CliRunner()


class RmsDetector(aw.BaselineDetector):
    """A new detector, as a user would write one: the change of the features' RMS."""

    def _fit(self, X: NDArray[np.float64]) -> None:
        self.rms_ = float(np.sqrt(np.mean(X**2)))

    def _distance(self, X: NDArray[np.float64]) -> float:
        return abs(float(np.sqrt(np.mean(X**2))) - self.rms_)


@pytest.fixture
def registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Registrations of a test go to a copy of the table, dropped afterwards (the plugins
    loaded before the copy: loaded into it, they would be dropped with it, and never again)."""
    methods()
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


class TorqueRms:
    """A new kind of model, as a user would write one: the change of the torque's RMS. It
    satisfies axiswatch._axis_model.MonitoredModel and derives from nothing of axiswatch."""

    signals = ("torque",)
    fits_calibration = False
    pooled = False

    def fit(
        self, baseline: aw.Capture, calibration: Sequence[aw.Capture] = (), *, fleet: Any = ()
    ) -> TorqueRms:
        self.rms_ = _rms(baseline)
        return self

    def assess(self, capture: aw.Capture) -> aw.Assessment:
        return aw.Assessment(abs(_rms(capture) - self.rms_), math.nan, False)

    def check_baseline(self, capture: aw.Capture) -> None:
        pass

    def baseline_note(self, rates_hz: Mapping[str, float]) -> str | None:
        return None

    def read(self, capture: aw.Capture, profile: Any) -> tuple[aw.Capture, str | None]:
        return capture, None

    def fit_read(self, read: Sequence[aw.Capture], names: Any) -> TorqueRms:
        return TorqueRms().fit(read[0])

    def fingerprint(self) -> str:
        return repr(self.rms_)

    def summary(self) -> dict[str, Any]:
        return {"torque_rms": self.rms_}

    def checks(self) -> dict[str, str]:
        return {}

    def score(self, capture: aw.Capture, file_hash: str, profile: Any) -> aw.Assessment:
        verdict = self.assess(capture)
        return dataclasses.replace(verdict, details={"rms": _rms(capture)})

    def fleet_key(self, profile: Any) -> str:
        return ""

    def fleet_axes(self) -> int:
        return 0

    def with_fleet(self, models: Sequence[TorqueRms], others: Any) -> list[TorqueRms]:
        return list(models)


def _rms(capture: aw.Capture) -> float:
    return float(np.sqrt(np.mean(capture.signals["torque"] ** 2)))


def test_a_registered_model_reaches_the_monitor_and_the_cli(
    registry: None, fleet: Path, tmp_path: Path
) -> None:
    # One fit job and one score job serve every method: a model that is neither the paper's
    # HealthModel nor the indicators' is fitted, stored and scored by a factory alone.
    register_method(
        "torque-rms",
        MethodPreset(
            model=lambda config: TorqueRms(),
            params=lambda config: {"method": config.method, "model": "TorqueRms"},
        ),
    )
    store = tmp_path / "s.db"
    args = ["monitor", str(fleet), "--store", str(store), "--method", "torque-rms"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "torque-rms: 18 capture files, 2 new baseline(s), 16 capture(s) scored" in result.output
    with aw.Store(store) as opened:
        results = fleet_results(opened)
        baselines = opened.score_table()
    assert set(results.method) == {"torque-rms"}
    monitored = results[results.role == "monitor"]
    assert len(monitored) == 6
    assert (monitored.distance > 0).all()
    scored = baselines[baselines.role != "baseline"]
    assert all("rms" in json.loads(d) for d in scored.details)


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
    # its fleet (tests/indicators/test_indicator_model.py: nothing in its decision path from a simulator).
    assert defaults.method == "indicators"
    assert isinstance(defaults.model().model, aw.IndicatorModel)
    assert defaults.threshold_floor() == 0.0
    command = typer.main.get_command(app).commands["monitor"]  # type: ignore[attr-defined]
    options = {p.name: p.default for p in command.params}
    shown = monitor_defaults()  # what an option left out becomes, and what its help shows
    assert {name: options[name] for name in shown} == dict.fromkeys(shown)
    assert shown["method"] == defaults.method
    assert shown["percentile"] == defaults.percentile
    assert shown["calibration"] == defaults.calibration_size
    assert (shown["alarm_k"], shown["alarm_n"], shown["clear_m"]) == (
        defaults.alarm_k,
        defaults.alarm_n,
        defaults.clear_m,
    )
    assert shown["signals"] == ",".join(defaults.features.signals)
    assert shown["hop"] == defaults.features.hop
    assert shown["segment_length"] == defaults.features.segment_length
    assert shown["align"] is defaults.align_phase
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


@pytest.mark.parametrize(
    "options",
    [
        {"method": "lra"},
        {"method": "lra", "lra_noise_level": "auto"},
        {"method": "lra", "lra_noise_level": 0.25, "align_phase": False},
        {"method": "pca"},
        {"method": "pca", "detector": aw.PCADetector(n_components=3)},
    ],
)
def test_the_paper_methods_store_the_parameters_of_the_detector_they_make(
    options: dict[str, Any],
) -> None:
    # Read without making the detector (no scikit-learn in a run that fits nothing): they are
    # the parameters of the model the preset makes, as before.
    config = MonitorConfig(**options)
    making = dataclasses.replace(config.preset, detector_params=None)
    made = making.stored_params(config)
    assert made["detector"] == config.preset.make(config).detector.get_params()
    assert json.dumps(config.params(), sort_keys=True) == json.dumps(made, sort_keys=True)


def test_a_method_registered_before_the_plugins_load_still_comes_after_them() -> None:
    # In a fresh process the plugins load on first use; registering first used to put them
    # after the user's method, and the order then hung on what a process asked before.
    from importlib.metadata import entry_points

    if not list(entry_points(group=axiswatch.monitor._methods.METHOD_GROUP)):
        pytest.skip("no plugin method installed")
    import subprocess
    import sys

    code = (
        "from axiswatch.monitor import MethodPreset, methods, register_method\n"
        "register_method('rms', MethodPreset(detector=lambda config: None))\n"
        "print(list(methods())[-1])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "rms"
