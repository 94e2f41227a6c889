"""Backlash as the drive's ringing after the gear crosses its gap (issue 13, i14a).

Research study (docs/evaluation.md, "Backlash as ringing after the gap crossings"). The product's
backlash indicator, ``reversal_bursts``, looks within +-0.02 s of the sign changes of the
*commanded* torque, in a band set by the logging rate (``[0.04, 0.4] x rate``); its backlash
AUROC on the development robots is about 0.46. In the simulator (and in a gearbox) the gap is
crossed when the *transmitted* torque changes sign; the motor then strikes the other flank and
the drive rings at its own resonance (10-20 Hz on the development robots, for 0.05-0.3 s,
5-30 % of the peak torque), whatever the logging rate. :func:`gap_ringing` reads that ringing:

* **crossings**: where the transmitted torque changes sign is not measured; it lies between two
  estimates made from the capture, and both are used: the sign changes of the *rigid part* of a
  least-squares fit of the torque (inertia x acceleration + a cubic in the position, i.e. the
  torque minus its friction terms: what the gear would carry if the motor had no inertia), and
  those of the commanded torque low-passed at 10 Hz (what it would carry if the motor had
  neither inertia nor friction; the smoothing of ``reversal_bursts``);
* **residual**: the torque minus the whole fit (friction ``sign(speed)`` saturated over the
  lowest 10 % of the speed, viscous, inertia, position cubic), band-passed to
  :data:`RINGING_BAND_HZ` (cut at :data:`NYQUIST_MARGIN` of the rate): the rigid motion and its
  friction are removed, the resonance is kept;
* **reading**: the mean square of that residual over the moving samples within
  :data:`RINGING_WINDOW_S` of a crossing, over the square of its robust level over all the
  moving samples (``1.4826 x`` its median absolute value: the noise and mesh ripple of that
  capture, hardly moved by ringing that fills a minority of the motion). A ratio of one signal's
  powers, so free of the torque's unit and of the task's torque scale.

Nothing in it depends on the simulator: the band is a physical range of drive resonances, the
windows a few periods of it. Chosen on development robots 0-7 only (the probe of the study's
docs section); the held-out robots were never run for it here.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any, Literal
from unittest import mock

import numpy as np
import pandas as pd
import scipy.linalg
from numpy.typing import NDArray
from scipy.signal import butter, sosfiltfilt
from threadpoolctl import threadpool_limits

import axiswatch._indicator_model as indicator_model
from axiswatch._capture import Capture
from axiswatch._indicator_model import IndicatorModel, pool_fleet, pool_fleet_without
from axiswatch._readings import (
    INDICATORS,
    MOVING_FRACTION,
    Indicator,
    Motion,
    Readings,
    motion,
    read_indicators,
)
from axiswatch.datasets import DEVELOPMENT_ROBOTS, draw_robot
from axiswatch.datasets._robot import Fault
from axiswatch_lab._task_envelope import _AXES, _FIT
from axiswatch_lab._transfer import TransferDesign, _profile, robot_transfer

__all__ = [
    "GAP_RINGING",
    "RINGING_BAND_HZ",
    "RINGING_WINDOW_S",
    "VARIANTS",
    "gap_crossings",
    "gap_ringing",
    "ringing_study",
]

#: Band of the drive-train resonance (Hz): the first (gear-stiffness) mode of robot axes lies
#: within it (10-20 Hz on the development robots, whose stiffness is drawn over a factor 4, i.e.
#: a factor 2 in frequency); the lower edge is above the rigid motion left in the fit's residual
#: (moves of 0.35 s and longer), the upper edge keeps the mesh ripple of fast logs out.
RINGING_BAND_HZ: tuple[float, float] = (5.0, 50.0)
#: Upper band edge at most this share of the rate (a margin under the Nyquist frequency).
NYQUIST_MARGIN = 0.45
#: Least torque rate (Hz): the band is then 5-9 Hz. A ringing above the Nyquist frequency
#: reaches it aliased when the logger keeps every n-th sample without an anti-alias filter (the
#: simulator's and many drives' trace buffers); behind an anti-alias filter it is lost, and the
#: reading is then that of a healthy axis, not an alarm.
MIN_RINGING_RATE_HZ = 20.0
#: Window around each estimated gap crossing (s before, s after): the estimate's uncertainty
#: before, a few periods of a 10-20 Hz ring decaying within 0.05-0.3 s after.
RINGING_WINDOW_S: tuple[float, float] = (0.05, 0.3)
#: Low-pass of the commanded torque whose sign changes are the second crossing estimate (Hz),
#: as ``reversal_bursts``' (the rate's share 0.05 below 200 Hz).
CROSSING_SMOOTHING_HZ = 10.0
#: 1 / Phi^-1(3/4): the median absolute value of Gaussian noise -> its standard deviation.
MAD_TO_SD = 1.4826

#: The candidates compared (docs/evaluation.md): ``v1`` every sign change and the robust level
#: of the motion (the first full run); ``v2`` passages through +-10 % of each estimate's peak
#: and the residual away from the windows (chosen on the probe after ``v1`` failed the rule).
CANDIDATES: dict[str, dict[str, Any]] = {
    "v1": {"hysteresis": 0.0, "reference": "motion"},
    "v2": {"hysteresis": 0.1, "reference": "away"},
}

GAP_RINGING = Indicator(
    "gap_ringing",
    f"a torque rate >= {MIN_RINGING_RATE_HZ:g} Hz and gap crossings (sign changes of the "
    "transmitted torque's estimates) while moving",
    component="gear backlash",
    log=True,
)


def _fit(m: Motion, moving: NDArray[np.bool_]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(whole fit, rigid part) of the torque on every sample, fitted on the moving ones.

    The friction column is ``sign(speed)`` saturated linearly below :data:`MOVING_FRACTION` of
    the peak speed, so that the fit can be evaluated at rest (where ``sign`` would follow the
    speed's noise); on the moving samples it is ``sign(speed)``, as the friction reading's.
    """
    peak = float(np.max(np.abs(m.speed)))
    span = float(np.ptp(m.position[moving])) or 1.0
    q = (m.position - float(np.mean(m.position[moving]))) / span
    saturated = np.clip(m.speed / (MOVING_FRACTION * peak), -1.0, 1.0)
    design = np.column_stack([saturated, m.speed, m.acceleration, np.ones_like(q), q, q**2, q**3])
    coefficients, *_ = scipy.linalg.lstsq(design[moving], m.torque[moving])
    return design @ coefficients, design[:, 2:] @ coefficients[2:]


def _sign_changes(x: NDArray[np.float64], hysteresis: float) -> NDArray[np.intp]:
    """Indices ``i`` where ``x`` changes sign between samples ``i`` and ``i + 1``, counting only
    passages from below ``-h`` to above ``h`` or back (``h = hysteresis x max |x|``), each at its
    last sign change; with ``hysteresis=0`` every sign change."""
    level = hysteresis * float(np.max(np.abs(x))) if x.size else 0.0
    side = np.where(x > level, 1, np.where(x < -level, -1, 0))
    outside = np.flatnonzero(side != 0)
    changes = np.flatnonzero(np.sign(x[1:]) * np.sign(x[:-1]) < 0)
    out = []
    for a, b in zip(outside[:-1].tolist(), outside[1:].tolist(), strict=True):
        if side[a] != side[b]:
            between = changes[(changes >= a) & (changes < b)]
            out.append(int(between[-1]))
    return np.asarray(out, dtype=np.intp)


def _filtered(sos: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    # The default pad (3 x the filter's order) exceeds a short capture at a slow rate.
    padlen = min(3 * (2 * sos.shape[0] + 1), x.size - 1)
    return np.asarray(sosfiltfilt(sos, x, padlen=padlen), dtype=np.float64)


def gap_crossings(
    m: Motion, moving: NDArray[np.bool_], hysteresis: float = 0.0
) -> NDArray[np.intp]:
    """Sample indices where the transmitted torque is estimated to change sign (sorted, unique).

    The union of the sign changes of the fit's rigid part (inertia x acceleration + position
    cubic) and of the commanded torque low-passed at :data:`CROSSING_SMOOTHING_HZ`; with a
    ``hysteresis`` (share of each estimate's largest magnitude) only its passages through that
    band around zero, not its noise while it hovers at zero (a wrist cruising at constant speed).
    """
    _, rigid = _fit(m, moving)
    smoothing = min(CROSSING_SMOOTHING_HZ, 0.25 * m.rate_hz)
    sos = butter(2, smoothing, fs=m.rate_hz, output="sos")
    commanded = _filtered(sos, m.torque)
    return np.unique(
        np.concatenate([_sign_changes(rigid, hysteresis), _sign_changes(commanded, hysteresis)])
    )


def gap_ringing(
    m: Motion, *, hysteresis: float = 0.0, reference: Literal["motion", "away"] = "motion"
) -> tuple[float, str | None]:
    """The drive's ringing after the gap crossings over its level in the motion.

    Parameters
    ----------
    m : Motion
        From :func:`~axiswatch._readings.motion`.
    hysteresis : float, default=0.0
        Of the crossings (:func:`gap_crossings`).
    reference : {"motion", "away"}, default="motion"
        The level the ringing is divided by: the residual's robust level over all moving
        samples (``1.4826 x`` median absolute value; the first candidate), or its mean square
        over the moving samples outside every window (the second).

    Returns
    -------
    (float, str or None)
        The reading (a ratio of powers, about 1 when the crossings ring no more than the rest of
        the motion) and None; or NaN and why it cannot be read.

    Examples
    --------
    >>> import numpy as np
    >>> rate = 500.0
    >>> t = np.arange(0, 4, 1 / rate)
    >>> q = np.sin(np.pi * t)
    >>> v, a = np.pi * np.cos(np.pi * t), -np.pi**2 * np.sin(np.pi * t)
    >>> noise = np.random.default_rng(0).normal(scale=0.01, size=t.size)
    >>> tau = 2.0 * a + 0.5 * np.sign(v) + noise
    >>> m = Motion(t, q, v, a, tau, rate)
    >>> quiet, _ = gap_ringing(m)
    >>> ring = np.zeros_like(t)
    >>> for c in (0.0, 1.0, 2.0, 3.0):  # the inertial torque changes sign at t = 0, 1, 2, 3
    ...     after = np.clip(t - c, 0, None)
    ...     ring += np.where(t > c, 0.2 * np.exp(-after / 0.1) * np.sin(2 * np.pi * 15 * after), 0)
    >>> loud, _ = gap_ringing(Motion(t, q, v, a, tau + ring, rate))
    >>> bool(quiet < 3), bool(loud > 10 * quiet)
    (True, True)
    """
    if m.rate_hz < MIN_RINGING_RATE_HZ:
        return math.nan, f"needs a torque rate >= {MIN_RINGING_RATE_HZ:g} Hz (got {m.rate_hz:g} Hz)"
    peak = float(np.max(np.abs(m.speed))) if m.speed.size else 0.0
    moving = np.abs(m.speed) > MOVING_FRACTION * peak
    if peak <= 0 or int(moving.sum()) < 8:
        return math.nan, "needs motion"
    low, high = RINGING_BAND_HZ[0], min(RINGING_BAND_HZ[1], NYQUIST_MARGIN * m.rate_hz)
    whole, _ = _fit(m, moving)
    sos = butter(4, [low, high], btype="bandpass", fs=m.rate_hz, output="sos")
    residual = _filtered(sos, m.torque - whole)
    crossings = gap_crossings(m, moving, hysteresis)
    near = np.zeros(m.time_s.size, dtype=bool)
    before, after = RINGING_WINDOW_S
    for i in crossings.tolist():
        near |= (m.time_s >= m.time_s[i] - before) & (m.time_s <= m.time_s[i] + after)
    near &= moving
    if int(near.sum()) < 3:
        return (
            math.nan,
            "needs gap crossings while moving (no sign change of the transmitted torque)",
        )
    if reference == "away":
        away = moving & ~near
        if int(away.sum()) < 3:
            return math.nan, "needs motion away from the gap crossings"
        power = float(np.mean(residual[away] ** 2))
    else:
        power = (MAD_TO_SD * float(np.median(np.abs(residual[moving])))) ** 2
    if not power > 0:
        return math.nan, "needs torque noise in the resonance band (the residual is flat)"
    return float(np.mean(residual[near] ** 2)) / power, None


# --- the study --------------------------------------------------------------------------------

#: The product as it is; ``reversal_bursts`` replaced by :func:`gap_ringing` (its reading under
#: the old name, so the model's declarations hold); :func:`gap_ringing` added beside it.
VARIANTS: tuple[str, ...] = ("product", "replaced", "added")


def _variant(base: Readings, ringing: float, why: str | None, variant: str) -> Readings:
    values, reasons = dict(base.values), dict(base.reasons)
    if variant == "replaced":
        values["reversal_bursts"] = ringing
        reasons.pop("reversal_bursts", None)
        if why is not None:
            reasons["reversal_bursts"] = why
    elif variant == "added":
        values[GAP_RINGING.name] = ringing
        if why is not None:
            reasons[GAP_RINGING.name] = why
    return Readings(values, reasons, base.source, base.signature, base.order_profile)


class _Cached:
    """Readings of a capture, read once whatever the variant (captures are simulated again per
    variant, bit for bit the same; keyed by their signals)."""

    def __init__(self, read: Callable[[Capture], Readings], candidate: str) -> None:
        self.read, self.options = read, CANDIDATES[candidate]
        self.cache: dict[bytes, tuple[Readings, float, str | None]] = {}

    def __call__(self, capture: Capture, variant: str) -> Readings:
        key = b"".join(np.asarray(s).tobytes() for s in capture.signals.values())
        if key not in self.cache:
            ringing, why = gap_ringing(motion(capture), **self.options)
            self.cache[key] = (self.read(capture), ringing, why)
        return _variant(*self.cache[key], variant)


def _read(cached: _Cached, variant: str, capture: Capture) -> Readings:
    return cached(capture, variant)


def _declared() -> AbstractContextManager[object]:
    """The model's declarations with :data:`GAP_RINGING` (the study only: the product's model
    declares its own indicators)."""
    return mock.patch.object(indicator_model, "INDICATORS", (*INDICATORS, GAP_RINGING))


def _monitor_rows(seed: int, cached: _Cached) -> list[dict[str, object]]:
    """The monitor study's scenarios (:func:`axiswatch_lab._task_envelope._scenario`: 4 axes,
    two task changes; a friction fault on axis 0's own task), scored by the product's model."""
    robot = draw_robot(seed)
    rows: list[dict[str, object]] = []
    for scenario in ("healthy", "fault"):
        captures = []
        for a in range(_AXES):
            fitting: list[tuple[Capture, bool]] = []
            monitored: list[tuple[Capture, bool]] = []
            for day in range(_FIT + (12 if scenario == "healthy" else 8)):
                task, fault = a, None
                if scenario == "healthy" and day >= _FIT + 4:
                    task = (a + 1 + (day - _FIT - 4) // 4) % 5
                if scenario == "fault" and a == 0 and day >= _FIT:
                    fault = Fault("friction", 0.6)
                capture = robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}")
                (fitting if day < _FIT else monitored).append((capture, fault is not None))
            captures.append((fitting, monitored))
        for variant in VARIANTS:
            models = [
                IndicatorModel().fit_readings([cached(c, variant) for c, _ in fitting])
                for fitting, _ in captures
            ]
            prior = pool_fleet(models)
            for k, model in enumerate(models):
                model.use_fleet(prior, check_against=pool_fleet_without(models, k))
            counts = {"false_alarms": 0, "healthy": 0, "detected": 0, "faulty": 0}
            for model, (_, monitored) in zip(models, captures, strict=True):
                for capture, faulty in monitored:
                    over = model.assess_readings(cached(capture, variant)).alarm
                    counts["faulty" if faulty else "healthy"] += 1
                    counts["detected" if faulty else "false_alarms"] += int(over)
            rows.append({"robot": robot.name, "scenario": scenario, "variant": variant, **counts})
    return rows


def ringing_study(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    design: TransferDesign | None = None,
    *,
    monitor: bool = True,
    candidate: str = "v1",
    progress: Callable[[str], None] = print,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(transfer rows, monitor-scenario rows): one per robot and variant (and scenario)."""
    transfer: list[dict[str, object]] = []
    monitor_rows: list[dict[str, object]] = []
    with threadpool_limits(1), _declared():
        for seed in seeds:
            design_ = design or TransferDesign()
            reader = IndicatorModel(_profile(draw_robot(seed), design_.kinematics)).readings
            cached = _Cached(reader, candidate)
            for variant in VARIANTS:
                record = robot_transfer(
                    seed, design_, read=functools.partial(_read, cached, variant)
                )
                transfer.append({"variant": variant, **record})
            if monitor:
                monitor_rows += _monitor_rows(seed, _Cached(read_indicators, candidate))
            progress(f"robot {seed} done")
    return pd.DataFrame(transfer), pd.DataFrame(monitor_rows)


def main(out: Path, seeds: Sequence[int] = DEVELOPMENT_ROBOTS, candidate: str = "v1") -> None:
    """Write ``transfer.csv`` and ``monitor.csv`` under ``out`` and print the summaries."""
    out.mkdir(parents=True, exist_ok=True)
    transfer, monitor = ringing_study(seeds, candidate=candidate)
    transfer.to_csv(out / "transfer.csv", index=False)
    monitor.to_csv(out / "monitor.csv", index=False)
    print(summary(transfer, monitor))


def summary(transfer: pd.DataFrame, monitor: pd.DataFrame) -> str:
    """The figures the decision rule reads, per variant."""
    numeric = transfer.select_dtypes("number").assign(variant=transfer["variant"])
    grouped = numeric.groupby("variant", sort=False)
    table = grouped.mean()
    table["robot_a_false_alarms"] = grouped["robot_a_false_alarms"].sum()
    table["robots_a_clean"] = grouped["robot_a_false_alarms"].apply(lambda s: int((s == 0).sum()))
    lines = [table.T.to_string(float_format=lambda v: f"{v:.3f}")]
    lines.append(
        transfer.pivot(index="robot", columns="variant", values="auroc_backlash").to_string()
    )
    lines.append(
        transfer.pivot(index="robot", columns="variant", values="robot_a_false_alarms").to_string()
    )
    if not monitor.empty:
        counts = monitor.drop(columns=["robot"]).groupby(["scenario", "variant"], sort=False)
        lines.append(counts.sum().to_string())
    return "\n\n".join(lines)


if __name__ == "__main__":  # python -m axiswatch_lab._gap_ringing OUT CANDIDATE [SEED ...]
    import sys

    seeds = tuple(int(s) for s in sys.argv[3:]) or DEVELOPMENT_ROBOTS
    main(Path(sys.argv[1]), seeds, sys.argv[2])
