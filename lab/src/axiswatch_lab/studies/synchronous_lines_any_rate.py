"""Angle-synchronous (equivalent-time) lines of a tooth or bearing fault at any logging rate:
how far they can be seen.

Research study (docs/evaluation.md, "Synchronous lines at any logging rate"). The product's
kinematic lines (``tooth_lines:*``, ``bearing_lines:*``) band-pass the torque and need the
component's highest order below ``0.45 x`` rate at the fast motor speeds, so on 20-250 Hz logs
they are unavailable. A logger without an anti-alias filter still samples an angle-locked impact
at unrelated motor angles, so the Fourier coefficient at order ``o``,
``c(o) = mean(r * exp(-1j * o * theta))`` over the moving samples (``theta`` the motor angle,
``r`` a residual of the torque), is a non-uniform DFT at exactly the component's orders, valid
beyond Nyquist as long as the samples spread over the order's phase.

:func:`feasibility` measures, per development robot and fault (tooth, bearing, severity 0.6), the
fault's synchronous line amplitude (healthy and faulty captures with the same seed: the
difference of their residuals projected on the component's orders) against the floor of each
residual (the RMS ``|c|`` at nearby orders no line sits at) and against the torque sensor's own
noise floor (the simulator's noise and resolution, read here only to measure, never by an
indicator), and the motor-angle error of the logged position (PCHIP onto the torque's instants,
times the gear ratio) against the truth of a noiseless position logged at the torque's rate.
The candidate reading (:func:`synchronous_line_ratio`, two variants in :data:`CANDIDATES`) is
compared with the product's rate-band lines by :func:`comparison` (the transfer design, the
same captures, the readings of the same names replaced); neither met the rule fixed before its
run, so nothing here is used by the product.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
import scipy.linalg
from numpy.typing import NDArray
from scipy.interpolate import BSpline

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import DEVELOPMENT_ROBOTS, Fault, SimulatedRobot, draw_robot
from axiswatch_lab._product import MIN_REVOLUTIONS, Motion, Readings, bearing_orders, motion
from axiswatch_lab._transfer import TransferDesign, _profile, robot_transfer
from axiswatch_lab.studies.order_lines_without_kinematics import _simulated_once

#: Share of the peak speed above which samples enter the synchronous sums (as the product's
#: kinematic lines: the motor angle moves, the lines have a phase that changes).
FAST_FRACTION = 0.2
#: Floor orders: each line order shifted by these many resolution cells (1 / revolutions), the
#: :data:`FLOOR_PER_LINE` nearest that stay :data:`FLOOR_GAP_CELLS` from every line and whole order.
FLOOR_CELLS: tuple[float, ...] = tuple(s * (k + 0.5) for k in range(1, 11) for s in (-1, 1))
FLOOR_PER_LINE = 6
FLOOR_GAP_CELLS = 1.5
#: Whole orders projected out by the ``harmonic`` residual (mesh, ripple: healthy lines whose
#: leakage through the irregular sampling of the angle would otherwise fill every order).
WHOLE_ORDERS: tuple[int, ...] = tuple(range(1, 9))
#: Knot spacing of the time spline of the ``spline`` residual (s), at least this many samples.
SPLINE_KNOT_S = 0.1
SPLINE_MIN_SAMPLES = 8
#: Lags of the causal ``lagged`` residual (samples of the torque's rate).
LAGS: tuple[int, ...] = (1, 2, 3, 4, 6, 8)


def tooth_orders(stage: float) -> list[float]:
    """The product's tooth orders: ``k / stage`` up to order 8, whole orders excluded."""
    return [
        k / stage for k in range(1, int(8 * stage) + 1) if abs(k / stage - round(k / stage)) > 1e-9
    ]


def synchronous(
    residual: NDArray[np.float64], angle: NDArray[np.float64], orders: Sequence[float]
) -> NDArray[np.complex128]:
    """``c(o) = mean(residual * exp(-1j * o * angle))`` for every order (a non-uniform DFT)."""
    return np.asarray(
        [np.mean(residual * np.exp(-1j * o * angle)) for o in orders], dtype=np.complex128
    )


def span_revolutions(angle: NDArray[np.float64]) -> float:
    """The span of the motor angle over the samples, in revolutions: what sets the resolution
    of the synchronous sums (``1 / span`` orders). Not the revolutions travelled: strokes back
    and forth revisit the same angles, and waves of orders ``o`` and ``o + d`` stay alike over
    them until ``d x span`` reaches a turn."""
    return float(np.ptp(angle)) / (2 * math.pi) if angle.size else 0.0


def floor_orders(lines: Sequence[float], avoid: Sequence[float], revolutions: float) -> list[float]:
    """Orders beside ``lines`` (:data:`FLOOR_CELLS` cells of ``1 / revolutions``) that stay
    :data:`FLOOR_GAP_CELLS` cells away from every line of ``avoid`` and every whole order, the
    :data:`FLOOR_PER_LINE` nearest per line."""
    cell = 1.0 / revolutions
    out: set[float] = set()
    keep_off = np.asarray([*avoid, *range(0, 64)], dtype=np.float64)
    for o in lines:
        found = [
            o + k * cell
            for k in sorted(FLOOR_CELLS, key=abs)
            if o + k * cell > 0
            and float(np.min(np.abs(keep_off - o - k * cell))) > FLOOR_GAP_CELLS * cell
        ]
        out.update(round(f, 12) for f in found[:FLOOR_PER_LINE])
    return sorted(out)


def _crude(m: Motion, keep: NDArray[np.bool_], gear_ratio: float) -> NDArray[np.float64]:
    v = m.speed[keep]
    span = float(np.ptp(m.position[keep])) or 1.0
    q = (m.position[keep] - float(np.mean(m.position[keep]))) / span
    return np.column_stack([np.sign(v), v, m.acceleration[keep], np.ones_like(v), q, q**2, q**3])


def _spline(m: Motion, keep: NDArray[np.bool_], gear_ratio: float) -> NDArray[np.float64]:
    """Cubic B-splines in time (knots every :data:`SPLINE_KNOT_S`), each also times
    ``sign(speed)``: anything smooth in time, the reference's dynamics, the payload, gravity,
    the controller's slow response, and the friction's sign."""
    t = m.time_s
    spacing = max(SPLINE_KNOT_S, SPLINE_MIN_SAMPLES / m.rate_hz)
    n_inner = max(1, int((t[-1] - t[0]) / spacing))
    inner = np.linspace(t[0], t[-1], n_inner + 1)
    knots = np.concatenate([[t[0]] * 3, inner, [t[-1]] * 3])
    basis = BSpline.design_matrix(np.clip(t, t[0], t[-1]), knots, 3).toarray()
    sign = np.sign(m.speed)[:, None]
    return np.concatenate([basis, basis * sign], axis=1)[keep]


def _lagged(m: Motion, keep: NDArray[np.bool_], gear_ratio: float) -> NDArray[np.float64]:
    """The spline basis plus the measured speed and acceleration now and at :data:`LAGS`
    earlier samples (a causal linear model of the controller's response)."""
    columns = [_spline(m, np.ones(m.time_s.size, dtype=bool), gear_ratio)]
    for signal in (m.speed, m.acceleration):
        for lag in (0, *LAGS):
            shifted = np.concatenate([np.full(lag, signal[0]), signal[: signal.size - lag]])
            columns.append(shifted[:, None])
    return np.concatenate(columns, axis=1)[keep]


def _harmonic(m: Motion, keep: NDArray[np.bool_], gear_ratio: float) -> NDArray[np.float64]:
    """The spline basis plus sines and cosines of the motor angle at :data:`WHOLE_ORDERS`, as
    many as leave four samples per column."""
    spline = _spline(m, keep, gear_ratio)
    theta = gear_ratio * m.position[keep]
    room = max(0, (int(keep.sum()) // 4 - spline.shape[1]) // 2)
    waves = [f(k * theta) for k in WHOLE_ORDERS[:room] for f in (np.sin, np.cos)]
    return np.column_stack([spline, *waves]) if waves else spline


#: The residuals' designs: ``(motion, samples kept, gear ratio) -> columns``.
RESIDUALS: dict[str, Callable[[Motion, NDArray[np.bool_], float], NDArray[np.float64]]] = {
    "crude": _crude,
    "spline": _spline,
    "lagged": _lagged,
    "harmonic": _harmonic,
}


def residual(
    m: Motion, keep: NDArray[np.bool_], kind: str, gear_ratio: float
) -> NDArray[np.float64]:
    """The torque at ``keep`` less its least-squares fit on the residual ``kind``'s design."""
    design = RESIDUALS[kind](m, keep, gear_ratio)
    y = m.torque[keep]
    coefficients, *_ = scipy.linalg.lstsq(design, y)
    return np.asarray(y - design @ coefficients, dtype=np.float64)


def _rms(c: NDArray[np.complex128]) -> float:
    return float(np.sqrt(np.mean(np.abs(c) ** 2))) if c.size else math.nan


def _truth_angle(robot: SimulatedRobot, task: int, seed: str) -> NDArray[np.float64]:
    """The motor angle at the torque's instants without noise or quantisation (the same
    phase, temperature and trajectory as the logged capture of that seed)."""
    exact = dataclasses.replace(
        robot.spec,
        position_rate_hz=robot.spec.fast_rate_hz,
        noise_position=0.0,
        position_quantum=0.0,
    )
    twin = dataclasses.replace(robot, spec=exact)
    return robot.spec.gear_ratio * np.asarray(
        twin.capture(task, seed=seed).signals["position"], dtype=np.float64
    )


def capture_rows(
    robot: SimulatedRobot, task: int, seed: str, severity: float = 0.6
) -> list[dict[str, object]]:
    """The measurement on one pair of captures per fault (see the module docstring)."""
    spec = robot.spec
    healthy = robot.capture(task, seed=seed)
    mh = motion(healthy)
    peak = float(np.max(np.abs(mh.speed)))
    keep = np.abs(mh.speed) > FAST_FRACTION * peak
    theta = spec.gear_ratio * mh.position
    truth = _truth_angle(robot, task, seed)[: theta.size]
    error = (theta - truth)[keep]
    travel = float(np.sum(np.abs(np.diff(theta))[keep[1:]])) / (2 * math.pi)
    revolutions = span_revolutions(theta[keep])
    n = int(keep.sum())
    sensor = math.sqrt(spec.noise_torque**2 + spec.torque_quantum**2 / 12)
    components = {
        "tooth": tooth_orders(spec.tooth_stage_ratio),
        "bearing": bearing_orders(spec.bearing_order),
    }
    resid_h = {k: residual(mh, keep, k, spec.gear_ratio) for k in RESIDUALS}
    rows = []
    for fault, lines in components.items():
        other = components["bearing" if fault == "tooth" else "tooth"]
        floors = floor_orders(lines, [*lines, *other], revolutions)
        faulty = robot.capture(task, seed=seed, fault=Fault(fault, severity))  # type: ignore[arg-type]
        mf = motion(faulty)
        difference = (mf.torque - mh.torque)[keep]
        row: dict[str, object] = {
            "robot": robot.name,
            "rate_hz": spec.fast_rate_hz,
            "position_rate_hz": spec.position_rate_hz,
            "task": task,
            "seed": seed,
            "fault": fault,
            "n": n,
            "revolutions": revolutions,
            "travel_revolutions": travel,
            "max_order": max(lines),
            "n_orders": len(lines),
            "fault_rms": float(np.std(difference)),
            "line_true_angle": _rms(synchronous(difference, truth[keep], lines)),
            "line_raw": _rms(synchronous(difference, theta[keep], lines)),
            "sensor_floor": sensor / math.sqrt(n),
            "angle_error_rms": float(np.sqrt(np.mean(error**2))),
            "phase_error_at_max_order": float(np.sqrt(np.mean(error**2))) * max(lines),
            "quantum_phase_at_max_order": spec.position_quantum * spec.gear_ratio * max(lines),
        }
        for kind in RESIDUALS:
            r_f = residual(mf, keep, kind, spec.gear_ratio)
            r_h = resid_h[kind]
            row[f"line_{kind}"] = _rms(synchronous(r_f - r_h, theta[keep], lines))
            row[f"floor_{kind}"] = _rms(synchronous(r_h, theta[keep], floors))
            row[f"healthy_{kind}"] = _rms(synchronous(r_h, theta[keep], lines))
            row[f"std_{kind}"] = float(np.std(r_h))
        rows.append(row)
    return rows


def feasibility(
    seeds: Sequence[int] = DEVELOPMENT_ROBOTS,
    tasks: Sequence[int] = (0, 1, 2, 3, 4),
    n_seeds: int = 2,
) -> pd.DataFrame:
    """:func:`capture_rows` for every robot, two-way task and seed; one row per capture and
    fault."""
    rows = []
    for seed in seeds:
        robot = draw_robot(seed)
        for task in tasks:
            for k in range(n_seeds):
                rows.extend(capture_rows(robot, task, f"sync{k}"))
    return pd.DataFrame(rows)


def needed_snr(n_orders: int, auroc: float = 0.95) -> float:
    """Line-to-floor amplitude ratio at which the debiased line power over ``n_orders`` orders
    separates a faulty from a healthy capture of the same task with ``auroc`` (Gaussian
    approximation: the power sum over ``P`` orders in floor units has mean ``P`` and standard
    deviation ``sqrt(P)`` in health, and a fault adds ``P x snr^2``; equal variances). A lower
    bound: a task change moves the floor, and the model's allowance for it costs more."""
    from scipy.stats import norm

    d_prime = math.sqrt(2) * float(norm.ppf(auroc))
    return math.sqrt(d_prime / math.sqrt(n_orders))


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """Per robot and fault: medians over the captures, amplitudes over floors."""
    out = []
    for (robot, fault), g in rows.groupby(["robot", "fault"], sort=False):
        med = g.median(numeric_only=True)
        record = {
            "robot": robot,
            "fault": fault,
            "rate": f"{med['rate_hz']:g} / {med['position_rate_hz']:g}",
            "n": int(med["n"]),
            "revs": round(float(med["revolutions"]), 0),
            "fault_rms": med["fault_rms"],
            "line": med["line_raw"],
            "line_true": med["line_true_angle"],
            "phase_err": med["phase_error_at_max_order"],
        }
        for kind in RESIDUALS:
            # Median over the captures that have floor orders (a span too short to resolve
            # orders beside the lines has none).
            record[f"snr_{kind}"] = float(np.nanmedian(g[f"line_{kind}"] / g[f"floor_{kind}"]))
        record["share_with_floor"] = float(np.mean(np.isfinite(g["floor_crude"])))
        record["snr_sensor"] = float(np.median(g["line_raw"] / g["sensor_floor"]))
        record["needed"] = needed_snr(int(med["n_orders"]))
        out.append(record)
    return pd.DataFrame(out)


def main(out: str, *args: str) -> None:
    """``python -m axiswatch_lab.studies.synchronous_lines_any_rate OUT``: the feasibility rows and summary
    (``OUT_rows.csv``, ``OUT_summary.csv``); ``OUT --compare [--fast] [--candidates=A,B]
    SEED ...``: the comparison (``OUT_compare.csv``; default the first candidate),
    development robots only while choosing."""
    if "--compare" in args:
        from threadpoolctl import threadpool_limits

        from axiswatch_lab._transfer import FAST_DESIGN
        from axiswatch_lab.studies.order_lines_without_kinematics import summary as compared

        design = FAST_DESIGN if "--fast" in args else TransferDesign()
        chosen = ["synchronous"]
        for arg in args:
            if arg.startswith("--candidates="):
                chosen = arg.split("=", 1)[1].split(",")
        seeds = [int(a) for a in args if not a.startswith("--")]
        with threadpool_limits(1):
            table = comparison(seeds, design, chosen)
        table.to_csv(f"{out}_compare.csv", index=False)
        with pd.option_context("display.width", 250, "display.max_columns", 40):
            print(compared(table).round(4).to_string())
        return
    rows = feasibility()
    rows.to_csv(f"{out}_rows.csv", index=False)
    table = summary(rows)
    table.to_csv(f"{out}_summary.csv", index=False)
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(table.round(4).to_string(index=False))


# --- the candidate reading and its comparison with the product's kinematic lines -------------

#: Least lines of a reading with floor orders beside them.
MIN_LINES = 4
#: Least samples per column of the residual's design (the rest is the residual's freedom).
MIN_SAMPLES_PER_COLUMN = 2


def synchronous_line_ratio(
    m: Motion,
    gear_ratio: float,
    lines: Sequence[float],
    avoid: Sequence[float],
    *,
    min_span: float = MIN_REVOLUTIONS,
    min_line_turns: float = 0.0,
) -> float | str:
    """Median synchronous line power at ``lines`` over the mean at the floor orders beside them.

    Residual: the torque at the fast samples (``|speed|`` above :data:`FAST_FRACTION` of its
    peak) less its least-squares fit on cubic B-splines in time, the same times the direction,
    and the waves of the motor angle's whole orders (the ``harmonic`` residual: a healthy
    mesh or ripple line would leak into the lines near it over a few revolutions). ``c(o) = mean(r * exp(-1j * o * theta))`` with
    ``theta`` the motor angle (``gear_ratio x`` the position, PCHIP onto the torque's
    instants); the reading is the median over the lines of ``|c(o)|^2`` over the mean
    ``|c|^2`` at its own floor orders (:func:`floor_orders`, ``avoid`` holding every component's
    lines): about ``ln 2`` in health on any task (the median of unit exponentials), a unitless
    power ratio. The median, not the mean: a drive-train resonance excited by each move sits
    at a time frequency, so it fills a hump of orders at the fast speed, raising a few lines
    over their floors (robot 7, task 2: lines of 1.2-1.9 at 500-1800 times their floors in
    health); a fault raises most of its lines. The reason (a string) when the capture cannot
    give it.

    ``min_span``: the least span of the motor angle (revolutions; the first candidate's 10, the
    product's travel need). ``min_line_turns``: a line counts only where its phase turns this
    many times over the span (``order x span``), so that its samples spread over its phase
    (the second candidate: no span need but this one at 2 turns, and the free floor orders).
    """
    peak = float(np.max(np.abs(m.speed)))
    keep = np.abs(m.speed) > FAST_FRACTION * peak
    theta = gear_ratio * m.position
    revolutions = span_revolutions(theta[keep])
    if revolutions < min_span or revolutions <= 0:
        return f"needs a motor-angle span of {min_span:g} revolutions (got {revolutions:.3g})"
    lines = [o for o in lines if o * revolutions >= min_line_turns]
    design = _harmonic(m, keep, gear_ratio)
    if keep.sum() < MIN_SAMPLES_PER_COLUMN * design.shape[1]:
        return (
            f"needs {MIN_SAMPLES_PER_COLUMN * design.shape[1]} samples of fast motion "
            f"(got {int(keep.sum())})"
        )
    neighbours = [floor_orders([o], avoid, revolutions) for o in lines]
    if not lines or sum(len(n) > 0 for n in neighbours) < min(MIN_LINES, len(lines)):
        return f"needs {MIN_LINES} lines with orders free of lines beside them"
    y = m.torque[keep]
    coefficients, *_ = scipy.linalg.lstsq(design, y)
    r = np.asarray(y - design @ coefficients, dtype=np.float64)
    ratios = []
    for o, beside in zip(lines, neighbours, strict=True):
        if beside:
            floor = float(np.mean(np.abs(synchronous(r, theta[keep], beside)) ** 2))
            line = float(np.abs(synchronous(r, theta[keep], [o])[0]) ** 2)
            ratios.append(line / floor if floor > 0 else math.nan)
    value = float(np.median(ratios))
    return value if math.isfinite(value) else "needs a residual (the torque is a smooth fit)"


#: The candidates compared with the product: keyword arguments of
#: :func:`synchronous_line_ratio`.
CANDIDATES: dict[str, dict[str, float]] = {
    "synchronous": {},
    "synchronous-resolved": {"min_span": 0.0, "min_line_turns": 2.0},
}


def reader(
    robot: SimulatedRobot, cache: dict[int, Readings], candidate: str | None
) -> Callable[[Capture], Readings]:
    """The product's readings with the robot's kinematics; with a ``candidate`` (a key of
    :data:`CANDIDATES`) its ``tooth_lines:*`` and ``bearing_lines:*`` are
    :func:`synchronous_line_ratio` with that candidate's arguments instead (same names). ``cache`` (keyed by the capture's ``id``: the captures must outlive it, as under
    :func:`~axiswatch_lab.studies.order_lines_without_kinematics._simulated_once`) shares the product's readings."""
    profile = _profile(robot, True)
    model = IndicatorModel(profile)
    spec = robot.spec
    tooth = tooth_orders(spec.tooth_stage_ratio)
    bearing = bearing_orders(spec.bearing_order)

    def read(capture: Capture) -> Readings:
        if id(capture) not in cache:
            cache[id(capture)] = model.readings(capture)
        readings = cache[id(capture)]
        if candidate is None:
            return readings
        m = motion(capture)
        values, reasons = dict(readings.values), dict(readings.reasons)
        for name, lines in (
            ("tooth_lines:tooth stage", tooth),
            ("bearing_lines:motor bearing", bearing),
        ):
            got = synchronous_line_ratio(
                m, spec.gear_ratio, lines, [*tooth, *bearing], **CANDIDATES[candidate]
            )
            reasons.pop(name, None)
            if isinstance(got, str):
                values[name], reasons[name] = math.nan, got
            else:
                values[name] = got
        return dataclasses.replace(readings, values=values, reasons=reasons)

    return read


def comparison(
    seeds: Sequence[int],
    design: TransferDesign | None = None,
    candidates: Sequence[str] = ("synchronous",),
) -> pd.DataFrame:
    """:func:`~axiswatch_lab._transfer.robot_transfer` per seed, the product's kinematic lines
    (``product``) and each of ``candidates`` (keys of :data:`CANDIDATES`) on the same captures
    (``design``: the full :class:`~axiswatch_lab._transfer.TransferDesign` when None)."""
    design = design or TransferDesign()
    rows = []
    for seed in seeds:
        robot = draw_robot(seed)
        with _simulated_once():
            cache: dict[int, Readings] = {}
            for chosen in (None, *candidates):
                record = robot_transfer(seed, design, read=reader(robot, cache, chosen))
                rows.append({"candidate": chosen or "product", **record})
                print(rows[-1], flush=True)
    return pd.DataFrame(rows)


if __name__ == "__main__":
    import sys

    main(*sys.argv[1:])
