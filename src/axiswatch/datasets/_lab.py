"""Synthetic data: the paper's lab-generated dataset (paper, "Lab Generated Dataset").

The paper leaves three gaps: the time base, the 10th day, each day's phase. Each is a
parameter here. docs/paper-notes.md gives the choices and what they change.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from axiswatch._capture import Capture

__all__ = ["LAB_DAYS", "LabDay", "lab_dataset"]

#: The paper's ten days (the tenth is the documented choice, see the module docstring).
LAB_DAYS: tuple[str, ...] = ("O1", "O1", "O1", "A", "O1", "O2", "O2", "O2", "O1", "O1")


@dataclass(frozen=True)
class LabDay:
    """One day of the lab dataset: its capture and labels."""

    day: int
    label: str
    operation: str
    anomalous: bool
    capture: Capture


def lab_dataset(
    *,
    days: Sequence[str] = LAB_DAYS,
    n_samples: int = 300,
    sample_rate_hz: float = 300.0,
    noise_std: float = 1e-4,
    anomaly_start: int = 150,
    anomaly_length: int = 60,
    continuous_time: bool = False,
    seed: int | np.random.Generator | None = 0,
) -> list[LabDay]:
    """Generate the paper's lab dataset.

    Parameters
    ----------
    days : sequence of {"O1", "O2", "A"}, default=LAB_DAYS
        Operation of each day; "A" is O1 with the torque anomaly.
    n_samples : int, default=300
        Samples per day (the paper's N).
    sample_rate_hz : float, default=300.0
        ``n = k / sample_rate_hz``; see the module docstring.
    noise_std : float, default=1e-4
        Standard deviation of the Gaussian noise added to every signal.
    anomaly_start, anomaly_length : int, default=150, 60
        Samples of day "A" that carry the anomaly.
    continuous_time : bool, default=False
        Whether time runs on across days (otherwise each day starts at n = 0).
    seed : int, Generator or None, default=0

    Returns
    -------
    list of LabDay

    Examples
    --------
    >>> data = lab_dataset()
    >>> [d.label for d in data][:5], data[0].capture.signals["torque"].shape
    (['O1', 'O1', 'O1', 'A', 'O1'], (300,))
    """
    rng = np.random.default_rng(seed)
    result = []
    for index, label in enumerate(days):
        if label not in ("O1", "O2", "A"):
            raise ValueError(f"Unknown lab day label {label!r}; expected 'O1', 'O2' or 'A'.")
        k = np.arange(n_samples) + (index * n_samples if continuous_time else 0)
        n = k / sample_rate_hz
        position_hz, motion_hz = (4.0, 5.0) if label == "O2" else (9.0, 10.0)
        position = 2.0 * np.sin(2 * np.pi * position_hz * n)
        speed = 10.0 * np.sin(2 * np.pi * motion_hz * n)
        torque = np.sin(2 * np.pi * motion_hz * n) + 0.05 * np.sin(2 * np.pi * 300.0 * n)
        if label == "A":
            window = slice(anomaly_start, anomaly_start + anomaly_length)
            torque[window] = (
                np.sin(2 * np.pi * 10.0 * n[window])
                + 0.3 * np.sin(2 * np.pi * 100.0 * n[window])
                + 0.3 * np.sin(2 * np.pi * n[window])
            )
        signals = {
            name: values + rng.normal(scale=noise_std, size=n_samples)
            for name, values in (("position", position), ("speed", speed), ("torque", torque))
        }
        capture = Capture(
            signals,
            dict.fromkeys(signals, float(sample_rate_hz)),
            source=f"lab day {index + 1}",
            metadata={"day": str(index + 1), "label": label},
        )
        result.append(
            LabDay(index + 1, label, "O2" if label == "O2" else "O1", label == "A", capture)
        )
    return result
