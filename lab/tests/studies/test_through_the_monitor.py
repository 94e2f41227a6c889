"""The through-the-monitor study's AUROC of a real data set's captures."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from axiswatch_lab.studies.through_the_monitor import _auroc


def _scores(distances: list[float]) -> pd.DataFrame:
    n = len(distances)
    return pd.DataFrame(
        {
            "robot": ["r"] * n,
            "axis": ["a"] * n,
            "captured_at": pd.date_range("2026-01-01", periods=n, freq="D"),
            "role": ["baseline", *["calibration"] * 5, *["monitor"] * (n - 6)],
            "distance": distances,
        }
    )


def test_the_auroc_counts_monitored_captures_only() -> None:
    # The first 6 (baseline and calibration) are left out, whatever their distances.
    scores = _scores([9.0] * 6 + [0.1, 0.2, 0.3, 2.0, math.nan, 3.0])
    faulty = pd.Series([True] * 6 + [False, False, False, True, False, True])
    assert _auroc(scores, faulty) == pytest.approx(1.0)
    # A capture without a distance counts 0: faulty {2.0, 0} against healthy {0.1, 0.2, 0.3,
    # 3.0} wins 3 of the 8 pairs.
    faulty_nan = pd.Series([True] * 6 + [False, False, False, True, True, False])
    assert _auroc(scores, faulty_nan) == pytest.approx(3 / 8)
    assert math.isnan(_auroc(scores, pd.Series([False] * 12)))
