"""Order lines against the baseline's own order spectrum (issue 13, item 3; the product's)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from axiswatch import AxisProfile, Capture, IndicatorModel, write_capture
from axiswatch.cli import app
from axiswatch.indicators._fleet import pool_fleet
from axiswatch.indicators._order_lines import (
    CELLS_PER_DECADE,
    MIN_COMMON_CELLS,
    TOP_LINES,
    OrderProfile,
    OrderSpectrum,
    grown_lines,
    order_profile,
    order_reference,
)
from axiswatch.indicators._readings import read_indicators
from axiswatch.monitor import MonitorConfig, SQLiteStore
from axiswatch.monitor._monitor import monitor_fleet
from axiswatch.monitor._persist import dump_model, load_model
from tests.conftest import settle
from tests.memory_store import MemoryStore
from tests.naive import grown_lines_naive, order_profile_naive, order_reference_naive

runner = CliRunner()


def _strokes(
    seed: int,
    *,
    comb: float = 0.0,
    speed: float = 2.0,
    rate_hz: float = 1000.0,
    seconds: float = 8.0,
) -> Capture:
    """Constant-speed strokes of 3 rad back and forth; torque: friction, a healthy line at order
    300 of the position, noise and, with ``comb``, new lines at the orders 185, 222 and 259 (a
    fault's comb; pure lines, which no other indicator reads)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    period = 6.0 / speed
    phase = ((t + rng.uniform(0, period)) % period) / period
    position = np.where(phase < 0.5, 6.0 * phase, 6.0 * (1.0 - phase))
    velocity = np.gradient(position, 1.0 / rate_hz)
    torque = 2.0 * np.sign(velocity) + 0.3 * np.sin(300 * position)
    torque += rng.normal(0, 0.05, t.size)
    torque += comb * sum(np.cos(37 * k * position) for k in range(5, 8))
    return Capture(
        {"position": position, "speed": velocity, "torque": torque},
        {"position": rate_hz, "speed": rate_hz, "torque": rate_hz},
        source=f"strokes{seed}",
    )


def _as_dict(profile: OrderProfile) -> dict[int, float]:
    return {int(k): float(v) for k, v in zip(profile.cells, profile.values, strict=True) if v == v}


def test_order_profile_matches_its_naive_twin() -> None:
    rng = np.random.default_rng(0)
    orders = np.sort(rng.uniform(20.0, 900.0, 400))
    power, floor = rng.exponential(1.0, 400), rng.uniform(0.5, 1.5, 400)
    floor[7] = 0.0  # a bin without floor is left out
    profile = order_profile(OrderSpectrum(orders, power, floor, 40.0, 1.0))
    expected = order_profile_naive(list(orders), list(power), list(floor), CELLS_PER_DECADE)
    assert _as_dict(profile).keys() == expected.keys()
    for k, v in expected.items():
        assert _as_dict(profile)[k] == pytest.approx(v, rel=1e-12, abs=1e-12)


def test_reference_and_growth_match_their_naive_twins() -> None:
    rng = np.random.default_rng(1)
    profiles = []
    for first, size in ((100, 40), (104, 38), (98, 30), (110, 35)):
        values = rng.normal(0.2, 0.1, size)
        values[rng.integers(size)] = np.nan  # a cell without bins
        profiles.append(OrderProfile(first, values))
    reference = order_reference(profiles)
    assert reference is not None
    expected = order_reference_naive([_as_dict(p) for p in profiles])
    assert _as_dict(reference) == pytest.approx(expected, rel=1e-12)
    capture = OrderProfile(102, rng.normal(0.2, 0.1, 33))
    naive = grown_lines_naive(_as_dict(capture), expected, TOP_LINES, MIN_COMMON_CELLS)
    assert grown_lines(capture, reference) == pytest.approx(naive, rel=1e-12)
    # Too few cells in common: no reading, in both.
    apart = OrderProfile(140, rng.normal(0.2, 0.1, 30))
    assert math.isnan(grown_lines(apart, reference))
    assert math.isnan(grown_lines_naive(_as_dict(apart), expected, TOP_LINES, MIN_COMMON_CELLS))


def test_a_new_comb_of_order_lines_alarms_without_kinematics() -> None:
    model = IndicatorModel(order_lines=True)
    model.fit(_strokes(0), [_strokes(k) for k in range(1, 6)])
    assert model.order_reference_ is not None
    healthy = model.assess(_strokes(10))
    faulty = model.assess(_strokes(11, comb=0.05))
    assert not healthy.alarm
    assert faulty.alarm
    assert faulty.top == "order_lines"
    # The reason says where: the three new lines are at the orders 185, 222 and 259.
    assert faulty.component is not None
    order = float(faulty.component.rsplit(" ", 1)[1])
    assert any(abs(math.log(order / line)) < 0.05 for line in (185, 222, 259))
    # The healthy line at order 300 is in the baseline too: it does not count as grown.
    assert healthy.indicators["order_lines"]["spreads"] < 3.0
    # Without order lines the same fault is not seen: the other indicators do not move.
    plain = IndicatorModel().fit(_strokes(0), [_strokes(k) for k in range(1, 6)])
    assert not plain.assess(_strokes(11, comb=0.05)).alarm


def test_with_kinematics_the_grown_lines_name_the_component() -> None:
    # With a gear ratio of 37, the new lines at 5, 6 and 7 x 37 are a bearing's defect order 6
    # and its sidebands; a bearing of order 11.5 has no line there.
    profile = AxisProfile(gear_ratio=37.0, bearing_orders={"motor": 6.0})
    model = IndicatorModel(profile, order_lines=True)
    model.fit(_strokes(0), [_strokes(k) for k in range(1, 6)])
    faulty = model.assess(_strokes(11, comb=0.05))
    assert faulty.top == "order_lines"
    assert faulty.component is not None
    assert faulty.component.endswith(": bearing motor")
    elsewhere = IndicatorModel(
        AxisProfile(gear_ratio=37.0, bearing_orders={"motor": 11.5}), order_lines=True
    )
    elsewhere.fit(_strokes(0), [_strokes(k) for k in range(1, 6)])
    verdict = elsewhere.assess(_strokes(11, comb=0.05))
    assert verdict.component is not None
    assert verdict.component.endswith("(no component's line there)")


def test_order_lines_unavailable_below_100_hz_with_the_reason() -> None:
    slow = _strokes(3, rate_hz=50.0)
    read = read_indicators(slow, order_lines=True)
    assert read.order_profile is None
    assert read.reasons["order_lines"] == "needs a torque rate >= 100 Hz (got 50 Hz)"
    model = IndicatorModel(order_lines=True).fit(
        _strokes(0, rate_hz=50.0), [_strokes(k, rate_hz=50.0) for k in range(1, 6)]
    )
    verdict = model.assess(slow)
    assert verdict.scored  # the other indicators still are
    assert verdict.unavailable["order_lines"] == "needs a torque rate >= 100 Hz (got 50 Hz)"
    # Readings taken without order lines say so.
    plain = model.assess_readings(read_indicators(slow))
    assert "taken without order_lines" in plain.unavailable["order_lines"]


def test_the_fleet_allowance_of_order_lines_comes_from_cross_readings() -> None:
    # Three axes at three speeds: each axis's reference reads the others' captures.
    models = []
    for a, speed in enumerate((1.5, 2.0, 2.5)):
        model = IndicatorModel(order_lines=True)
        model.fit(
            _strokes(100 * a, speed=speed), [_strokes(100 * a + k, speed=speed) for k in (1, 2, 3)]
        )
        models.append(model)
    prior = pool_fleet(models)
    shifts = []
    for i, a in enumerate(models):
        for j, b in enumerate(models):
            if i == j:
                continue
            assert a.order_reference_ is not None
            seen = [
                grown_lines(r.order_profile, a.order_reference_)
                for r in b.fit_readings_
                if r.order_profile is not None
            ]
            shifts.append(float(np.median(seen)) - a.centre_["order_lines"])
    expected = 1.4826 * float(np.median(np.abs(shifts)))
    assert prior.task_spreads["order_lines"] == pytest.approx(expected, rel=1e-12)
    assert prior.indicator_pairs["order_lines"] == 6  # both ways of 3 pairs


def test_a_model_with_order_lines_is_stored_and_loaded() -> None:
    model = IndicatorModel(order_lines=True).fit(_strokes(0), [_strokes(k) for k in range(1, 6)])
    back = load_model(dump_model(model))
    probe = _strokes(11, comb=0.05)
    assert back.assess(probe).distance == model.assess(probe).distance
    assert np.array_equal(
        back.order_reference_.values, model.order_reference_.values, equal_nan=True
    )


@pytest.fixture(scope="module")
def stroke_fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two axes at two speeds (no fleet prior: fewer than 3 axes), 8 days; axis a0 has new
    order lines from day 6 (no kinematics anywhere)."""
    root = tmp_path_factory.mktemp("strokes") / "fleet"
    for a, speed in enumerate((1.5, 2.0)):
        folder = root / "r1" / f"a{a}"
        folder.mkdir(parents=True)
        for day in range(8):
            comb = 0.05 if a == 0 and day >= 6 else 0.0
            capture = _strokes(10 * a + day, comb=comb, speed=speed)
            write_capture(capture, folder / f"2026-03-{day + 1:02d}.parquet")
    settle(root)
    return root


def test_the_monitor_scores_order_lines_when_asked(stroke_fleet: Path, tmp_path: Path) -> None:
    store = MemoryStore()
    monitor_fleet(stroke_fleet, store, MonitorConfig(order_lines=True), settle_s=0)
    scores = store.score_table()
    alarms = scores[scores["alarm"].fillna(False).astype(bool)]
    assert set(zip(alarms["axis"], alarms["capture"], strict=True)) == {
        ("a0", "2026-03-07.parquet"),
        ("a0", "2026-03-08.parquet"),
    }
    for reason in alarms["reason"]:
        assert "top indicator order_lines (new or grown order lines, most at order" in reason
    # The command's option is the library's.
    result = runner.invoke(
        app, ["monitor", str(stroke_fleet), "--store", str(tmp_path / "o.sqlite"),
              "--order-lines", "--no-progress", "--settle", "0"],
    )  # fmt: skip
    assert result.exit_code == 4, result.output
    with SQLiteStore(tmp_path / "o.sqlite") as opened:
        by_command = opened.score_table()
    columns = ["robot", "axis", "capture", "role", "distance", "alarm", "reason"]
    key = ["robot", "axis", "capture"]
    pd.testing.assert_frame_equal(
        by_command[columns].sort_values(key).reset_index(drop=True),
        scores[columns].sort_values(key).reset_index(drop=True),
    )
    refused = runner.invoke(
        app, ["monitor", str(stroke_fleet), "--store", str(tmp_path / "x.sqlite"),
              "--method", "pca", "--order-lines"],
    )  # fmt: skip
    assert refused.exit_code == 2
    assert "for the method 'indicators' only" in refused.output
