"""The whole-moves study (lab, i15a): which samples count as whole moves, and that a drive load
read on them does not depend on where the capture cut the task's cycle."""

from __future__ import annotations

import math

import numpy as np
import pytest

import axiswatch as aw
from axiswatch._readings import MOVING_FRACTION, read_indicators
from axiswatch_lab._whole_moves import whole_move_mask, whole_move_readings


def _whole_move_mask_naive(speed: list[float], fraction: float) -> list[bool]:
    peak = max(abs(v) for v in speed)
    sign = [(1 if v > 0 else -1) if abs(v) > fraction * peak else 0 for v in speed]
    out = [False] * len(speed)
    i = 0
    while i < len(sign):
        j = i
        while j + 1 < len(sign) and sign[j + 1] == sign[i]:
            j += 1
        if sign[i] != 0 and i > 0 and j < len(sign) - 1:
            out[i : j + 1] = [True] * (j + 1 - i)
        i = j + 1
    return out


@pytest.mark.parametrize("seed", range(5))
def test_whole_move_mask_matches_the_naive_runs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    speed = np.repeat(rng.normal(size=30), rng.integers(1, 6, size=30)).astype(np.float64)
    expected = _whole_move_mask_naive(speed.tolist(), MOVING_FRACTION)
    assert whole_move_mask(speed, MOVING_FRACTION).tolist() == expected


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
