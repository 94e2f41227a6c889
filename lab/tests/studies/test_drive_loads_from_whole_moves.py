"""The whole-moves study (lab, i15a): a drive load read on whole moves does not depend on where
the capture cut the task's cycle (the mask itself is the product's: tests/test_whole_moves_option.py)."""

from __future__ import annotations

import math

import numpy as np

import axiswatch as aw
from axiswatch_lab._product import read_indicators
from axiswatch_lab.studies.drive_loads_from_whole_moves import whole_move_readings


def _pick_and_place(phase: float, *, rate: float = 200.0, seconds: float = 4.0) -> aw.Capture:
    """Minimum-jerk moves of 1 rad out and back (cycle 3 s), gravity 20 cos(q): a capture of
    ``seconds`` starting ``phase`` s into the cycle."""
    t = phase + np.arange(0, seconds, 1 / rate)
    c = t % 3.0

    def ramp(s: np.ndarray) -> np.ndarray:
        r = np.clip(s, 0.0, 1.0)
        return np.asarray(10 * r**3 - 15 * r**4 + 6 * r**5, dtype=np.float64)

    q = np.where(c < 1.5, ramp(c / 1.0), 1.0 - ramp((c - 1.5) / 1.0))
    v = np.gradient(q, 1 / rate)
    tau = 3.0 * np.sign(v) * (np.abs(v) > 1e-9) + 2.0 * v + 20.0 * np.cos(q)
    return aw.Capture(
        {"position": q, "speed": v, "torque": tau},
        {"position": rate, "speed": rate, "torque": rate},
    )


def test_loads_of_whole_moves_do_not_depend_on_the_phase() -> None:
    product, whole = [], []
    for phase in np.linspace(0.0, 3.0, 13, endpoint=False):
        capture = _pick_and_place(float(phase))
        r = read_indicators(capture)
        product.append(r.values["load_backward"])
        w = whole_move_readings(capture, r)
        whole.append(w.values["load_backward"])
        assert w.values["coulomb_friction"] == r.values["coulomb_friction"]
    # Cut moves average gravity over part of the stroke: the product's reading moves with the
    # phase, the whole moves' not (the same samples of the same move, up to the sampling grid).
    assert np.ptp(product) > 1.0
    assert np.ptp(whole) < 0.05


def test_a_direction_without_a_whole_move_says_so() -> None:
    capture = _pick_and_place(1.0, seconds=1.2)  # the move back, cut by the capture's end
    w = whole_move_readings(capture, read_indicators(capture))
    assert math.isnan(w.values["load_backward"])
    assert w.reasons["load_backward"] == "needs a whole steady move in the negative direction"
