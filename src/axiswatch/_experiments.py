"""Paper experiments: the lab-generated dataset (paper, "Experimental Results").

Pipeline top stage for research use; the CLI's ``experiment`` commands call these functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from axiswatch._calibration import fit_half_laplace
from axiswatch._detectors import BaselineDetector, LRADetector, PCADetector
from axiswatch._features import FeatureSpec, extract_features
from axiswatch._simulate import lab_dataset

__all__ = ["LAB_FEATURES", "lab_distances"]

#: Features of the lab experiment: the "stationary" reading under which the paper's claim holds
#: (see docs/paper-notes.md): circular padding, Hann window of 128, one row per sample, no
#: product channels, magnitude ("spectrum") scaling.
LAB_FEATURES = FeatureSpec(combinations="none", segment_length=128, padding="circular")


@dataclass(frozen=True)
class _Method:
    name: str
    detector: BaselineDetector


def lab_distances(
    *,
    seed: int = 0,
    features: FeatureSpec = LAB_FEATURES,
    percentile: float = 99.0,
) -> pd.DataFrame:
    """Distance of every lab day to day 1, for the LRA and PCA detectors, with verdicts.

    The threshold of each method is fitted on the healthy test days of both operations (days
    2, 3, 5-10 except the anomaly), the protocol under which the paper's figure is reproduced.

    Returns
    -------
    DataFrame with columns ``day``, ``label``, ``method``, ``distance``, ``threshold``, ``alarm``.

    Examples
    --------
    >>> table = lab_distances()
    >>> table[table.alarm].groupby("method").label.apply(list).to_dict()
    {'lra': ['A']}
    """
    data = lab_dataset(seed=seed)
    X = [extract_features(day.capture, features).X for day in data]
    rows = []
    for method in (_Method("lra", LRADetector()), _Method("pca", PCADetector())):
        detector = method.detector.fit(X[0])
        distances = np.array([detector.distance(x) for x in X[1:]])
        healthy = np.array([not day.anomalous for day in data[1:]])
        threshold = fit_half_laplace(distances[healthy]).threshold(percentile)
        for day, distance in zip(data[1:], distances, strict=True):
            rows.append(
                {
                    "day": day.day,
                    "label": day.label,
                    "method": method.name,
                    "distance": float(distance),
                    "threshold": threshold,
                    "alarm": bool(distance > threshold),
                }
            )
    return pd.DataFrame(rows)
