"""Order lines without kinematics (lab candidates of issue 13, item 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from axiswatch import Capture
from axiswatch_lab._product import motion
from axiswatch_lab.studies.order_lines_without_kinematics import (
    LINE_PROMINENCE,
    STATISTICS,
    OrderSpectrum,
    order_spectrum,
    order_statistics,
    reader,
)


def _strokes(rate_hz: float, comb: float = 0.0, seconds: float = 8.0) -> Capture:
    """Constant-speed strokes of 3 rad at 2 rad/s back and forth; torque: friction, noise, a
    healthy line at order 300 of the position and, with ``comb``, lines at every 37th order from
    185 (inside both bands at 1 kHz: 126-1257 and 17-1257)."""
    rng = np.random.default_rng(5)
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    period = 3.0
    phase = (t % period) / period
    position = np.where(phase < 0.5, 6.0 * phase, 6.0 * (1.0 - phase))
    speed = np.gradient(position, 1.0 / rate_hz)
    torque = 2.0 * np.sign(speed) + 0.3 * np.sin(300 * position) + rng.normal(0, 0.05, t.size)
    torque += comb * sum(np.cos(37 * k * position) for k in range(5, 21))
    return Capture(
        {"position": position, "speed": speed, "torque": torque},
        {"position": rate_hz, "speed": rate_hz, "torque": rate_hz},
    )


@pytest.mark.parametrize("band", ["rate", "wide"])
def test_a_new_comb_of_lines_raises_the_third_line(band: str) -> None:
    healthy = order_spectrum(motion(_strokes(1000.0)), band)
    faulty = order_spectrum(motion(_strokes(1000.0, comb=0.1)), band)
    assert isinstance(healthy, OrderSpectrum)
    assert isinstance(faulty, OrderSpectrum)
    before, after = order_statistics(healthy), order_statistics(faulty)
    # The healthy line at order 300 alone does not make three lines; the comb does.
    assert before["third_line"] < LINE_PROMINENCE < after["third_line"]
    assert after["top_prominence"] > before["top_prominence"]


def test_the_healthy_line_stands_at_its_order() -> None:
    spectrum = order_spectrum(motion(_strokes(1000.0)), "wide")
    assert isinstance(spectrum, OrderSpectrum)
    top = spectrum.orders[np.argmax(spectrum.power / spectrum.floor)]
    # Orders are cycles per 2 pi of position, as cos(order * angle) in _mechanics.
    assert top == pytest.approx(300, abs=2.5)


def test_unavailable_with_a_reason() -> None:
    assert order_spectrum(motion(_strokes(50.0)), "wide") == (
        "needs a torque rate >= 100 Hz (got 50 Hz)"
    )
    short = order_spectrum(motion(_strokes(1000.0, seconds=0.06)), "wide")
    assert isinstance(short, str)
    assert short.startswith("needs steady runs resolving")
    still = np.zeros(2000)
    capture = Capture({"position": still, "torque": still}, {"position": 1000.0, "torque": 1000.0})
    assert order_spectrum(motion(capture), "rate") == "needs steady motion"


def test_reader_adds_the_candidate_or_its_reason() -> None:
    read = reader("third_line@wide")(_strokes(1000.0))
    assert math.isfinite(read.values["third_line@wide"])
    low = reader("third_line@wide")(_strokes(50.0))
    assert math.isnan(low.values["third_line@wide"])
    assert low.reasons["third_line@wide"].startswith("needs a torque rate")
    assert "third_line@wide" not in reader(None)(_strokes(1000.0)).values


def test_a_spectrum_without_a_floor_reads_nan() -> None:
    zeros = np.zeros(40)
    flat = OrderSpectrum(np.arange(40.0), zeros, zeros, 40.0, 1.0)
    values = order_statistics(flat)
    assert set(values) == set(STATISTICS)
    assert all(math.isnan(v) for v in values.values())


def test_the_baseline_relative_study_compares_the_product_with_and_without_order_lines() -> None:
    from axiswatch_lab._transfer import TransferDesign, robot_transfer
    from axiswatch_lab.studies.order_lines_without_kinematics import baseline_relative_study

    # No degradation runs (degradation_days=1): none of the figures read below depends on them
    # (they are computed before the runs, from the models the runs only assess); with the
    # default 12 days the same figures came out bit for bit, in 37 s of CPU instead of 8 s.
    design = TransferDesign(
        n_per_cell=1, n_calibration=3, robot_a_days=12, kinematics=False, degradation_days=1
    )
    table = baseline_relative_study([3], design)  # a 500 Hz development robot: lines are read
    assert table["candidate"].tolist() == ["none", "order_lines"]
    plain = robot_transfer(3, design)
    for key in ("auroc_bearing", "far99", "robot_a_false_alarms"):
        assert table.loc[0, key] == pytest.approx(plain[key], rel=1e-12)
    # The lines score no fewer captures (since gap_ringing, every capture of this design is
    # scored without them too), and the bearing fault's lines move the ranking (a fixed seed).
    assert table.loc[1, "share_scored"] >= table.loc[0, "share_scored"]
    assert table.loc[1, "auroc_bearing"] > table.loc[0, "auroc_bearing"]
