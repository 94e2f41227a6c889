"""Slow, obvious references for the lab's fast or clever computations.

As the product's tests/naive.py (some twins are the same): written from the formulas, with
NumPy only, without calling axiswatch or the routine it wraps.
"""

from __future__ import annotations

import math

import numpy as np


def exponential_quantile(scale: float, q: float) -> float:
    """Quantile q in (0, 1) of the exponential distribution, from its CDF 1 - exp(-x / scale)."""
    return -scale * np.log(1 - q)


def energy_distance(first: np.ndarray, second: np.ndarray) -> float:
    """Szekely & Rizzo's energy distance (V-statistic), every pair written out."""

    def mean_norm(a: np.ndarray, b: np.ndarray) -> float:
        total = 0.0
        for x in a:
            for y in b:
                total += float(np.sqrt(np.sum((x - y) ** 2)))
        return total / (len(a) * len(b))

    return 2 * mean_norm(first, second) - mean_norm(first, first) - mean_norm(second, second)


def least_squares_normal_equations(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from the normal equations (A^T A) x = A^T b, written out."""
    return np.linalg.solve(A.T @ A, A.T @ b)


def reversal_bursts(
    torque: np.ndarray, band: np.ndarray, rate_hz: float, where: np.ndarray, smoothing_hz: float
) -> float:
    """Bursts at sign changes of the low-passed torque, sample by sample."""
    from scipy.signal import butter, sosfiltfilt

    smooth = sosfiltfilt(butter(2, smoothing_hz, fs=rate_hz, output="sos"), torque)
    half = round(0.02 * rate_hz)
    bursts = []
    for k in range(len(smooth) - 1):
        if (smooth[k] > 0) != (smooth[k + 1] > 0) and where[k]:
            if k == 0:
                slope = abs(smooth[1] - smooth[0]) * rate_hz
            else:
                slope = abs(smooth[k + 1] - smooth[k - 1]) * rate_hz / 2
            peak = max(abs(float(b)) for b in band[max(0, k - half) : k + half])
            bursts.append(peak / slope**0.5)
    return float(np.mean(bursts)) if bursts else float("nan")


def alarm_threshold_naive(
    distances: list[float], percentile: float, floor: float | None, prediction: bool = False
) -> float:
    """The alarm threshold spelled out: the exponential quantile at the mean distance (the
    half-Laplace maximum-likelihood scale), or with ``prediction`` the quantile of the next
    distance (:func:`prediction_threshold_naive`); the floor where that is larger."""
    scale = sum(distances) / len(distances)
    fitted = (
        prediction_threshold_naive(distances, percentile)
        if prediction
        else float(exponential_quantile(scale, percentile / 100.0))
    )
    return fitted if floor is None or floor <= fitted else floor


def leave_one_out_distances_naive(
    rows: list[dict[str, float]], scales: dict[str, float], two_sided: set[str]
) -> list[float]:
    """Each row against the median of the others: sort, take the middle, the largest shift."""

    def median(xs: list[float]) -> float:
        xs = sorted(x for x in xs if x == x)
        n = len(xs)
        return xs[n // 2] if n % 2 else (xs[n // 2 - 1] + xs[n // 2]) / 2

    out = []
    for k, row in enumerate(rows):
        shifts = []
        for name, scale in scales.items():
            others = [r.get(name, float("nan")) for j, r in enumerate(rows) if j != k]
            value = row.get(name, float("nan"))
            if value != value or all(o != o for o in others):
                continue
            z = (value - median(others)) / scale
            shifts.append(abs(z) if name in two_sided else max(z, 0.0))
        out.append(max(shifts) if shifts else float("nan"))
    return out


def own_pair_allowances_naive(
    centre: dict[str, float],
    within: dict[str, float],
    others: list[dict[str, float]],
    task_spreads: dict[str, float],
    fleet_allowances: dict[str, float],
    n_fitted: int,
    percentile: float,
) -> dict[str, float]:
    """Per indicator of ``fleet_allowances``: the axis against each other axis by one loop, |z|
    in the axis's own ``sqrt(s_w^2 + s_t^2)``, the middle of the sorted list, the exponential
    quantile ``-b ln(1 - q)`` at Bonferroni's level over ``n_fitted`` indicators (fewer than 3
    pairs, or a median of 0: the fleet's allowance)."""
    nan = float("nan")
    out = {}
    for name, fallback in fleet_allowances.items():
        scale = (task_spreads.get(name, nan) ** 2 + within.get(name, nan) ** 2) ** 0.5
        zs = []
        for other in others:
            z = (centre.get(name, nan) - other.get(name, nan)) / scale
            if z == z and abs(z) != float("inf"):
                zs.append(abs(z))
        zs.sort()
        n = len(zs)
        middle = (zs[n // 2] if n % 2 else (zs[n // 2 - 1] + zs[n // 2]) / 2) if n else 0.0
        level = 1 - (1 - percentile / 100) / max(n_fitted, 1)
        out[name] = (
            -middle / math.log(2.0) * math.log(1 - level) if n >= 3 and middle > 0 else fallback
        )
    return out


def prediction_threshold_naive(distances: list[float], percentile: float) -> float:
    """The ``percentile`` of the next of exponential distances whose scale is their mean, from
    the F(2, 2n) law of ``X / mean``: the F quantile by bisection on its survival function
    ``(1 + x / n)^(-n)``, times the mean."""
    n = len(distances)
    mean = sum(distances) / n
    tail = 1 - percentile / 100
    low, high = 0.0, 1.0
    while (1 + high / n) ** (-n) > tail:
        high *= 2
    for _ in range(200):
        middle = (low + high) / 2
        if (1 + middle / n) ** (-n) > tail:
            low = middle
        else:
            high = middle
    return mean * (low + high) / 2


def friction_standard_errors_naive(
    position: list[float],
    speed: list[float],
    acceleration: list[float],
    torque: list[float],
    fraction: float,
    *,
    viscous: bool = True,
) -> tuple[float, float]:
    """Standard errors of the Coulomb and viscous coefficients: the design written row by row,
    the normal equations' inverse ``(X'X)^-1`` and the residual variance over ``n - p`` (the
    textbook ``sqrt(diag(sigma^2 (X'X)^-1))``). ``viscous=False`` leaves the speed column out
    (its error is then NaN)."""
    peak = max(abs(v) for v in speed)
    moving = [k for k in range(len(speed)) if abs(speed[k]) > fraction * peak]
    mean_q = sum(position[k] for k in moving) / len(moving)
    span = max(position[k] for k in moving) - min(position[k] for k in moving)
    rows, y = [], []
    for k in moving:
        q = (position[k] - mean_q) / span
        v = speed[k]
        speed_column = [v] if viscous else []
        rows.append([math.copysign(1.0, v), *speed_column, acceleration[k], 1.0, q, q**2, q**3])
        y.append(torque[k])
    x = np.array(rows)
    gram_inverse = np.linalg.inv(x.T @ x)
    beta = gram_inverse @ (x.T @ np.array(y))
    residual = np.array(y) - x @ beta
    sigma2 = float(residual @ residual) / (len(y) - x.shape[1])
    coulomb = math.sqrt(sigma2 * gram_inverse[0, 0])
    return coulomb, math.sqrt(sigma2 * gram_inverse[1, 1]) if viscous else math.nan


def relative_band_powers_naive(
    freqs: list[float], psd: list[float], rate_hz: float, edges: list[float]
) -> list[float]:
    """log10 of the PSD summed over the bins of each band ``[low, high)`` of ``edges`` x rate
    (the last band closed), times the bin width, one bin at a time; NaN for an empty band."""
    step = freqs[1] - freqs[0]
    out = []
    for k in range(len(edges) - 1):
        total, hits = 0.0, 0
        for f, p in zip(freqs, psd, strict=True):
            r = f / rate_hz
            last = k == len(edges) - 2
            if edges[k] <= r and (r <= edges[k + 1] if last else r < edges[k + 1]):
                total += p * step
                hits += 1
        out.append(math.log10(total) if hits and total > 0 else math.nan)
    return out


def order_bands_naive(first_cell: int, values: list[float], cells_per_band: int) -> list[float]:
    """The largest finite value per band of ``cells_per_band`` grid cells, in band order, one
    cell at a time (NaN for a band of unread cells)."""
    bands: dict[int, list[float]] = {}
    for offset, v in enumerate(values):
        bands.setdefault((first_cell + offset) // cells_per_band, []).append(v)
    out = []
    for b in sorted(bands):
        finite = [v for v in bands[b] if v == v]
        out.append(max(finite) if finite else math.nan)
    return out


def unit_change_prior_naive(
    centres: list[dict[str, float]],
    within: list[dict[str, float]],
    pairs: list[tuple[int, int]],
    one_sided: dict[str, bool],
) -> tuple[dict[str, float], float, dict[str, float]]:
    """The nearest-task study's unit-change prior by loops over the same-task pairs: per
    indicator ``s_u = 1.4826 x median |c_a - c_b|`` (3 pairs at least); every pair both ways,
    ``z = (c_i - c_j) / sqrt(s_u^2 + s_w,j^2)``; the one allowance scale ``median / ln 2`` of
    the ordered pairs' largest shift (``max(z, 0)`` one sided, ``|z|`` otherwise), each
    indicator's ``median / ln 2`` of its ``|z|`` (3 ordered pairs at least)."""
    nan = float("nan")
    names = sorted({n for c in centres for n in c})
    spreads = {}
    for name in names:
        differences = [abs(centres[a].get(name, nan) - centres[b].get(name, nan)) for a, b in pairs]
        finite = [d for d in differences if d == d]
        spreads[name] = 1.4826 * float(np.median(finite)) if len(finite) >= 3 else nan
    largest: list[float] = []
    shifts: dict[str, list[float]] = {n: [] for n in names}
    for a, b in pairs:
        for i, j in ((a, b), (b, a)):
            top = nan
            for name in names:
                spread = spreads[name]
                if not (spread == spread and spread > 0):
                    continue
                z = (centres[i].get(name, nan) - centres[j].get(name, nan)) / math.hypot(
                    spread, within[j].get(name, nan)
                )
                if z != z:
                    continue
                shifts[name].append(abs(z))
                shift = max(z, 0.0) if one_sided[name] else abs(z)
                top = shift if top != top else max(top, shift)
            if top == top:
                largest.append(top)
    scales = {
        n: float(np.median(v)) / math.log(2.0) if len(v) >= 3 and np.median(v) > 0 else nan
        for n, v in shifts.items()
        if spreads[n] == spreads[n] and spreads[n] > 0
    }
    return spreads, float(np.median(largest)) / math.log(2.0), scales


def viscous_friction(
    position: np.ndarray, speed: np.ndarray, torque: np.ndarray, rate_hz: float, levels: list[float]
) -> float:
    """Energy-window viscous friction, one window at a time with plain loops and normal equations."""
    peak_all = max(abs(float(x)) for x in speed)
    moving = [abs(float(x)) > 0.02 * peak_all for x in speed]
    stretches, i = [], 0
    while i < len(speed):
        if moving[i]:
            j = i
            while j < len(speed) and moving[j]:
                j += 1
            stretches.append((i, j))
            i = j
        else:
            i += 1
    complete = [(a, b) for a, b in stretches if a > 0 and b < len(speed) and b - a >= 40]
    # (Only moves inside the capture: the twin checks the windows, not the edge handling.)
    rows, work = [], []
    for m, (a, b) in enumerate(complete):
        peak = max(abs(float(x)) for x in speed[a:b])
        for level in levels:
            inside = [k for k in range(a, b) if abs(float(speed[k])) > level * peak]
            i0, i1 = inside[0], inside[-1]
            row = [0.0] * (len(complete) + 1)
            row[m] = abs(float(position[i1] - position[i0]))
            # Trapezoid rule over samples i0 .. i1, term by term.
            row[-1] = (
                sum((float(speed[k]) ** 2 + float(speed[k + 1]) ** 2) / 2 for k in range(i0, i1))
                / rate_hz
            )
            rows.append(row)
            work.append(
                sum(
                    (float(torque[k] * speed[k]) + float(torque[k + 1] * speed[k + 1])) / 2
                    for k in range(i0, i1)
                )
                / rate_hz
            )
    return float(least_squares_normal_equations(np.array(rows), np.array(work))[-1])
