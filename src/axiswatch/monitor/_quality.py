"""Data quality of a capture: a verdict of its own, judged before any mechanical one.

Bad data is never an alarm nor a healthy score. Rules, first match wins: ``out of range``,
``flat/stuck signal``, ``no motion``. Each is in docs/internals.md, "Data quality".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from axiswatch._capture import Capture
from axiswatch._quantiles import quantiles

__all__ = [
    "GLITCH_SPANS",
    "MIN_MOTION_SHARE",
    "OUT_OF_RANGE",
    "SAME_SCALE",
    "SCALE_CHANGE",
    "STUCK_SHARE",
    "QualityReference",
    "data_quality_problem",
    "isolated_glitches",
    "longest_run",
]

OUT_OF_RANGE = 1e6
STUCK_SHARE = 0.5
MIN_MOTION_SHARE = 0.05
#: ``glitch``: a position, speed or torque sample farther than this many times the signal's
#: range from each of its neighbours (:func:`isolated_glitches`). No motion goes there and back
#: within one sample; a logger or a transmission does. Gaussian noise alone (a range of 4.7
#: sigma, so 9.3 sigma past both neighbours) does once in 2e14 samples, 3,000 years at 2 kHz.
#: Real signals' largest lone samples stay under half this: 0.29 of the range (hydraulic
#: actuators' torque, 250 Hz), 0.57 (linear axis, 21 Hz), 0.81 (a cobot's torque sensor).
GLITCH_SPANS = 2.0
#: ``scale changed``: the torque or the speed spanning this many times more or less than the
#: baseline's while every other signal keeps the baseline's span within ``SAME_SCALE``: a
#: change of unit (N m to mN m, A to mA, rad/s to deg/s). Thirty is halfway, on a log scale,
#: between one unit and a metric prefix (1000). A fault changes a torque by tens of per cent:
#: loads and a damaged gear moved the real hydraulic actuators' torque span 0.71-1.56 times.
#: A change by 8.85 (lbf in per N m) or 9.55 (rpm per rad/s) is left to the model.
SCALE_CHANGE = 30.0
#: A change of task or load moves the signals together; a unit changes one. The position is a
#: witness only: a capture that holds a part of a task's cycle may span far less of it.
SAME_SCALE = 2.0
#: Neighbours on each side whose median a glitch departs from (besides the next samples).
GLITCH_NEIGHBOURS = 3
#: Signals judged for glitches: the motion and the load. Vibration (an accelerometer's
#: channel) is impulsive by nature: a bearing's impacts last a sample or two.
GLITCH_SIGNALS = ("position", "speed", "torque")


@dataclass(frozen=True)
class QualityReference:
    """What the baseline capture showed: the peak-to-peak span of each signal."""

    spans: dict[str, float]

    @classmethod
    def of(cls, capture: Capture) -> QualityReference:
        """The reference of a (baseline) capture."""
        return cls({name: float(np.ptp(v)) for name, v in capture.signals.items()})


def longest_run(values: NDArray[np.float64]) -> tuple[int, int]:
    """Length and start of the longest run of one repeated value (the first such run).

    Examples
    --------
    >>> longest_run(np.array([1.0, 2.0, 2.0, 2.0, 3.0, 3.0]))
    (3, 1)
    """
    differs = values[1:] != values[:-1]
    if differs.all():
        return min(values.size, 1), 0  # no value repeated: every run is one sample
    changes = np.flatnonzero(differs) + 1
    starts = np.concatenate([[0], changes])
    lengths = np.diff(np.concatenate([starts, [values.size]]))
    best = int(np.argmax(lengths))
    return int(lengths[best]), int(starts[best])


def signal_range(values: NDArray[np.float64]) -> float:
    """The range of the middle 98 % of the samples (a few glitches leave it as it is)."""
    low, high = quantiles(values, (0.01, 0.99))  # np.percentile's, bit for bit
    return high - low


def isolated_glitches(values: NDArray[np.float64], spans: float = GLITCH_SPANS) -> NDArray[np.intp]:
    """Samples farther than ``spans`` times :func:`signal_range` from each of their neighbours.

    A Hampel-type test made one-sample wide: sample ``i`` departs, in one direction, from the
    samples next to it and from the medians of the ``GLITCH_NEIGHBOURS`` samples on each side
    (one side only at the capture's ends). Two or more such samples in a row are an event, not
    a glitch, and are kept; so is a step, where the sample sits on one side.

    Examples
    --------
    >>> values = np.sin(np.arange(200) / 20.0)
    >>> values[50] = 40.0
    >>> isolated_glitches(values).tolist()
    [50]
    """
    size = values.size
    if size < 3:
        return np.empty(0, dtype=np.intp)
    limit = spans * signal_range(values)
    # Candidates first, with a few temporaries of the capture's length (a long capture is
    # large): far from both next samples, in one direction, or from the one at an end.
    step = np.diff(values)
    big = np.abs(step) > limit
    inner = np.flatnonzero(big[:-1] & big[1:]) + 1
    inner = inner[np.sign(step[inner - 1]) == -np.sign(step[inner])]
    ends = [index for index, far in ((0, big[0]), (size - 1, big[-1])) if far]
    found = []
    for index in sorted([*ends, *inner.tolist()]):
        direction = np.sign(step[index - 1] if index > 0 else -step[0])
        sides = [
            side
            for side in (
                values[max(0, index - GLITCH_NEIGHBOURS) : index],
                values[index + 1 : index + 1 + GLITCH_NEIGHBOURS],
            )
            if side.size
        ]
        gaps = [values[index] - float(np.median(side)) for side in sides]
        if all(np.sign(gap) == direction and abs(gap) > limit for gap in gaps):
            found.append(index)
    return np.asarray(found, dtype=np.intp)


def _factor(ratio: float) -> str:
    """``1,000`` or ``1/1,000``."""
    return f"{ratio:,.0f}" if ratio >= 1 else f"1/{1 / ratio:,.0f}"


def _scale_change(capture: Capture, reference: QualityReference) -> str | None:
    """The ``scale changed`` verdict (:data:`SCALE_CHANGE`), or None."""
    ratios = {
        name: float(np.ptp(values)) / reference.spans[name]
        for name, values in capture.signals.items()
        if reference.spans.get(name, 0.0) > 0
    }
    moved = _position_unit_change(ratios)
    if moved is not None:
        return moved
    changed = [
        n
        for n, r in ratios.items()
        if n != "position" and (r >= SCALE_CHANGE or r <= 1.0 / SCALE_CHANGE)
    ]
    kept = [n for n, r in ratios.items() if 1.0 / SAME_SCALE <= r <= SAME_SCALE]
    if not changed or len(changed) + len(kept) < len(ratios) or not kept:
        # Every signal changed (another task, another robot), or some by an in-between factor:
        # the signals may still agree with each other, and the model judges the capture.
        return None
    name = changed[0]
    factor = _factor(ratios[name])
    others = " and the ".join(f"{other} ({ratios[other]:.2g}x)" for other in kept)
    return (
        f"scale changed: signal '{name}' scale changed by {factor}x (it spans "
        f"{np.ptp(capture.signals[name]):.4g}, the baseline's {reference.spans[name]:.4g}, "
        f"while the {others} kept the baseline's span): a change of unit, not a fault (a "
        "fault changes it by tens of per cent); a new baseline reads the new scale"
    )


def _position_unit_change(ratios: dict[str, float]) -> str | None:
    """The position's unit changed (rad to degrees): the position and the speed, read in the
    same unit per second, span :data:`SCALE_CHANGE` times more or less together, and the torque
    keeps its span. A task moves the torque with them. The position alone is no witness: a
    capture may hold a part of a task's moves."""
    position, speed, torque = (ratios.get(n) for n in ("position", "speed", "torque"))
    if position is None or speed is None or torque is None:
        return None
    far = position >= SCALE_CHANGE or position <= 1.0 / SCALE_CHANGE
    if not (far and 1.0 / SAME_SCALE <= torque <= SAME_SCALE):
        return None
    if not 1.0 / SAME_SCALE <= speed / position <= SAME_SCALE:
        return None
    return (
        f"scale changed: the position and speed scale changed by {_factor(position)}x while the "
        f"torque ({torque:.2g}x) kept the baseline's span: a change of the position's unit (rad, "
        "degrees, revolutions), not a fault; declare it in the axis profile's [units], or a new "
        "baseline reads the new scale"
    )


def _standstill(capture: Capture, name: str, start: int, run: int) -> bool:
    """Whether a run of one value in ``name`` is the axis standing still (see the rules)."""
    motion = {"position", "speed"}
    if name not in motion:
        return False
    values = capture.signals[name]
    others = [other for other in motion - {name} if other in capture.signals]
    if not others:
        return name == "speed" and values[start] == 0.0
    other = others[0]
    rate, other_rate = capture.rates_hz[name], capture.rates_hz[other]
    first = round(start / rate * other_rate)
    last = round((start + run - 1) / rate * other_rate)
    span = capture.signals[other][first : last + 1]
    if span.size == 0:
        return False
    speed_span = span if other == "speed" else values[start : start + run]
    position_span = span if other == "position" else values[start : start + run]
    return bool(np.all(speed_span == 0.0) and np.ptp(position_span) == 0.0)


def data_quality_problem(capture: Capture, reference: QualityReference | None = None) -> str | None:
    """The data-quality verdict of a capture and its reason, or None when the data are usable.

    Parameters
    ----------
    capture : Capture
    reference : QualityReference, optional
        The baseline's; without it (a baseline candidate) ``no motion`` is not judged.

    Returns
    -------
    str or None
        ``"<verdict>: <reason>"`` with the verdict ``out of range``, ``flat/stuck signal``,
        ``glitch``, ``no motion`` or ``scale changed``.

    Examples
    --------
    >>> import axiswatch as aw
    >>> t = np.arange(2000) / 2000.0
    >>> moving = aw.as_capture({"position": np.sin(6 * t), "torque": np.cos(6 * t)}, 2000.0)
    >>> data_quality_problem(moving) is None
    True
    >>> idle = aw.as_capture({"position": 0.001 * np.sin(6 * t), "torque": np.cos(6 * t)}, 2000.0)
    >>> data_quality_problem(idle, QualityReference.of(moving))[:9]
    'no motion'
    """
    for name, values in capture.signals.items():
        peak = int(np.argmax(np.abs(values)))
        if abs(values[peak]) > OUT_OF_RANGE:
            return (
                f"out of range: signal '{name}' reads {values[peak]:.4g} at sample {peak} (no "
                f"axis signal exceeds {OUT_OF_RANGE:g} in magnitude; a logger glitch?)"
            )
    runs = {name: longest_run(values) for name, values in capture.signals.items()}
    for name, values in capture.signals.items():
        run, start = runs[name]
        if run == values.size:
            return f"flat/stuck signal: '{name}' is {values[0]:.6g} throughout ({run} samples)"
    for name in GLITCH_SIGNALS:
        if name not in capture.signals:
            continue
        values = capture.signals[name]
        glitches = isolated_glitches(values)
        if glitches.size:
            first = int(glitches[0])
            return (
                f"glitch: signal '{name}' reads {values[first]:.4g} at sample {first}, alone "
                f"and more than {GLITCH_SPANS:g} times the signal's range "
                f"({signal_range(values):.4g}) from its neighbours ({glitches.size} such "
                "sample(s); a logger or transmission glitch?)"
            )
    if reference is not None and "position" in capture.signals:
        span = float(np.ptp(capture.signals["position"]))
        expected = reference.spans.get("position", 0.0)
        if expected > 0 and span < MIN_MOTION_SHARE * expected:
            return (
                f"no motion: position spans {span:.4g}, {100 * span / expected:.2g} % of the "
                f"baseline's {expected:.4g} (the robot was idle during the capture?)"
            )
    if reference is not None:
        changed = _scale_change(capture, reference)
        if changed is not None:
            return changed
    for name, values in capture.signals.items():
        run, start = runs[name]
        if run >= STUCK_SHARE * values.size and not _standstill(capture, name, start, run):
            return (
                f"flat/stuck signal: '{name}' repeats {values[start]:.6g} for {run} of "
                f"{values.size} samples from sample {start} (a frozen sensor?)"
            )
    return None
