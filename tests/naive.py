"""Slow, obvious references for the fast or clever computations of axiswatch.

Each one is written from the paper's (or the cited method's) formulas, with NumPy only, without
calling axiswatch or the SciPy routine it wraps.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


def pchip_upsample(values: np.ndarray, factor: int) -> np.ndarray:
    """Fritsch-Carlson monotone cubic Hermite interpolation on a unit grid, written out.

    Slopes: weighted harmonic mean of neighbouring secants (0 at extrema), one-sided three-point
    ends clipped for monotonicity (Fritsch & Butland 1984, as in SciPy's PCHIP and Moler's pchip).
    """
    y = np.asarray(values, dtype=float)
    n = y.size
    h = np.ones(n - 1)
    m = np.diff(y) / h
    d = np.zeros(n)
    for k in range(1, n - 1):
        if m[k - 1] * m[k] > 0:
            w1, w2 = 2 * h[k] + h[k - 1], h[k] + 2 * h[k - 1]
            d[k] = (w1 + w2) / (w1 / m[k - 1] + w2 / m[k])
    for end, (m0, m1, h0, h1) in (
        (0, (m[0], m[1] if n > 2 else m[0], h[0], h[1] if n > 2 else h[0])),
        (n - 1, (m[-1], m[-2] if n > 2 else m[-1], h[-1], h[-2] if n > 2 else h[-1])),
    ):
        if n == 2:
            d[end] = m0
            continue
        slope = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
        if np.sign(slope) != np.sign(m0):
            slope = 0.0
        elif np.sign(m0) != np.sign(m1) and abs(slope) > abs(3 * m0):
            slope = 3 * m0
        d[end] = slope
    out = []
    for k in range(n - 1):
        for j in range(factor):
            t = j / factor
            h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
            h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
            out.append(h00 * y[k] + h10 * d[k] + h01 * y[k + 1] + h11 * d[k + 1])
    out.append(y[-1])
    return np.array(out)


def stft_magnitude(x: np.ndarray, m: int, hop: int, padding: str) -> np.ndarray:
    """|STFT| of one channel frame by frame, Hann window, magnitude scaling (divide by sum(w)).

    Frame ``p`` is centred on sample ``p * hop``: it covers samples ``p*hop - m//2 ...``.
    """
    n = x.size
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(m) / m)  # periodic Hann, as get_window
    if padding == "valid":
        centres = [c for c in range(0, n, hop) if c - m // 2 >= 0 and c - m // 2 + m <= n]
    else:
        centres = list(range(0, n, hop))
    rows = []
    for c in centres:
        idx = np.arange(c - m // 2, c - m // 2 + m)
        if padding == "circular":
            seg = x[idx % n]
        else:
            seg = np.where((idx >= 0) & (idx < n), x[np.clip(idx, 0, n - 1)], 0.0)
        frame = seg * w
        bins = np.arange(m // 2 + 1)
        dft = np.array([np.sum(frame * np.exp(-2j * np.pi * f * np.arange(m) / m)) for f in bins])
        rows.append(np.abs(dft) / w.sum())
    return np.array(rows)


def lra_delta(
    X_s: np.ndarray, X_t: np.ndarray, mu: float, d: int, lam: float = 1.0, tol: float = 1e-9
) -> tuple[float, np.ndarray]:
    """Paper eqs. 2-8 literally: R from the right-singular vectors of X^T, M, its eigenvectors.

    Returns (delta, eigenvalues). Degenerate clusters of M are resolved by taking the eigenvectors
    of least correspondence cost f^T L f first (the documented tie-break).
    """
    N = X_s.shape[0]

    def reconstruction(X: np.ndarray) -> np.ndarray:
        _, s, vh = np.linalg.svd(X.T, full_matrices=False)  # X^T = U S V^T; V: N x rank
        R = np.zeros((N, N))
        for sigma, v in zip(s, vh, strict=True):
            if sigma > np.sqrt(lam):
                R += (1 - lam / sigma**2) * np.outer(v, v)
        return R

    R = np.zeros((2 * N, 2 * N))
    R[:N, :N] = reconstruction(X_s)
    R[N:, N:] = reconstruction(X_t)
    C = np.zeros((2 * N, 2 * N))
    for i in range(N):
        C[i, N + i] = C[N + i, i] = 1.0
    L = np.diag(C.sum(axis=1)) - C
    eye = np.eye(2 * N)
    M = (1 - mu) * (eye - R).T @ (eye - R) + 2 * mu * L
    values, vectors = np.linalg.eigh(M)
    start = 0
    while start < values.size:
        stop = start + 1
        while stop < values.size and values[stop] - values[stop - 1] <= tol:
            stop += 1
        if stop - start > 1:
            block = vectors[:, start:stop]
            _, rot = np.linalg.eigh(block.T @ L @ block)
            vectors[:, start:stop] = block @ rot
        start = stop
    F = vectors[:, 1 : d + 1]
    return float(np.linalg.norm(F[:N] - F[N:])), values


def pca_distance(X_s: np.ndarray, X_t: np.ndarray, n_components: int) -> float:
    """d = ||X_s P - X_t P||_F^2 with P the top principal axes of the centred baseline."""
    centred = X_s - X_s.mean(axis=0)
    _, _, vh = np.linalg.svd(centred, full_matrices=False)
    P = vh[:n_components].T
    return float(np.sum((X_s @ P - X_t @ P) ** 2))


def exponential_quantile(scale: float, q: float) -> float:
    """Quantile q in (0, 1) of the exponential distribution, from its CDF 1 - exp(-x / scale)."""
    return -scale * np.log(1 - q)


def alarm_states_naive(overs: list[bool], *, k: int, n: int, m: int) -> list[bool]:
    """Alarm state after each capture, spelled out: raise on k of the last n over, clear after m
    clean captures in a row."""
    states: list[bool] = []
    alarm = False
    for i in range(len(overs)):
        window = overs[max(0, i - n + 1) : i + 1]
        if not alarm:
            alarm = sum(window) >= k
        else:
            clean_run = 0
            for value in reversed(overs[: i + 1]):
                if value:
                    break
                clean_run += 1
            if clean_run >= m:
                alarm = False
        states.append(alarm)
    return states


def marchenko_pastur_median(beta: float, *, n: int = 2000, seed: int = 0) -> float:
    """Median eigenvalue of Y^T Y / n for one n x (beta n) Gaussian matrix (Monte Carlo)."""
    rng = np.random.default_rng(seed)
    Y = rng.normal(size=(n, round(beta * n)))
    return float(np.median(np.linalg.eigvalsh(Y.T @ Y / n)))


def least_squares_normal_equations(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from the normal equations (A^T A) x = A^T b, written out."""
    return np.linalg.solve(A.T @ A, A.T @ b)


def angle_locked_f(
    signal: np.ndarray, angle: np.ndarray, orders: list[float], nuisance_orders: list[float]
) -> float:
    """F statistic of nested regressions on waves of ``angle``, with hat matrices written out."""

    def waves(order_list: list[float]) -> list[np.ndarray]:
        return [f(o * angle) for o in order_list for f in (np.sin, np.cos)]

    def residual_ss(columns: list[np.ndarray]) -> float:
        A = np.column_stack(columns)
        hat = A @ np.linalg.pinv(A)
        r = signal - hat @ signal
        return float(r @ r)

    small = residual_ss(waves(nuisance_orders))
    big = residual_ss(waves(nuisance_orders) + waves(orders))
    p, k = 2 * len(orders), 2 * (len(orders) + len(nuisance_orders))
    return (small - big) / p / (big / (signal.size - k))


def running_rms(values: np.ndarray, width: int) -> np.ndarray:
    """Root of the mean of squares over the window ``[i - width // 2, i + (width - 1) // 2]``,
    each term summed on its own, ends reflected (``d c b a | a b c d | d c b a``)."""
    x = np.asarray(values, dtype=float)
    n = x.size
    out = np.empty(n)
    for i in range(n):
        total = 0.0
        for j in range(i - width // 2, i + (width - 1) // 2 + 1):
            k = j
            while not 0 <= k < n:  # reflect about the edges, repeating the edge sample
                k = -k - 1 if k < 0 else 2 * n - k - 1
            total += x[k] ** 2
        out[i] = np.sqrt(total / width)
    return out


def longest_run_naive(values: list[float]) -> tuple[int, int]:
    """Longest run of one repeated value and its start, by walking the samples."""
    best, best_start, run, start = 0, 0, 0, 0
    for index, value in enumerate(values):
        if index > 0 and value == values[index - 1]:
            run += 1
        else:
            run, start = 1, index
        if run > best:
            best, best_start = run, start
    return best, best_start


def isolated_glitches_naive(values: list[float], spans: float, width: int = 3) -> list[int]:
    """Samples farther than ``spans`` ranges (middle 98 %) from their next samples and from the
    medians of ``width`` samples on each side, all in one direction: sample by sample."""
    low, high = np.percentile(values, [1.0, 99.0])
    limit = spans * (high - low)

    def median(side: list[float]) -> float:
        ordered = sorted(side)
        middle = len(ordered) // 2
        return ordered[middle] if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2

    found = []
    for i, value in enumerate(values):
        left, right = values[max(0, i - width) : i], values[i + 1 : i + 1 + width]
        gaps = [value - side[-1] for side in (left,) if side]
        gaps += [value - side[0] for side in (right,) if side]
        gaps += [value - median(side) for side in (left, right) if side]
        if gaps and (all(g > limit for g in gaps) or all(g < -limit for g in gaps)):
            found.append(i)
    return found


def repair_lone_spikes_naive(values: list[float], factor: float, width: int) -> list[float]:
    """Each sample, ``width`` in from both ends, that departs from the median of its ``width``
    neighbours on each side by more than ``factor`` times the larger of their range and the
    noise (robust deviation of the first difference over sqrt 2, at least the smallest step)
    becomes that median: sample by sample, every sample tested."""
    steps = sorted(abs(b - a) for a, b in itertools.pairwise(values))
    moving = [s for s in steps if s > 0]
    if len(values) < 2 * width + 1 or not moving:
        return list(values)
    middle = len(steps) // 2
    median_step = steps[middle] if len(steps) % 2 else (steps[middle - 1] + steps[middle]) / 2
    noise = max(1.4826 * median_step / math.sqrt(2.0), moving[0])
    out = list(values)
    for i in range(width, len(values) - width):
        near = sorted(values[i - width : i] + values[i + 1 : i + 1 + width])
        centre = (near[width - 1] + near[width]) / 2
        if abs(values[i] - centre) > factor * max(near[-1] - near[0], noise):
            out[i] = centre
    return out


def indicator_terms(baseline: np.ndarray, test: np.ndarray, *, one_sided: bool) -> np.ndarray:
    """Per-column terms of the indicator distance, column by column, row by row."""
    terms = np.zeros(baseline.shape[1])
    for j in range(baseline.shape[1]):
        baseline_mean = sum(baseline[i, j] for i in range(baseline.shape[0])) / baseline.shape[0]
        test_mean = sum(test[i, j] for i in range(test.shape[0])) / test.shape[0]
        shift = test_mean - baseline_mean
        if one_sided and shift < 0:
            shift = 0.0
        terms[j] = shift * shift
    return terms


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


def threshold_origin_naive(distances: list[float], percentile: float, floor: float | None) -> str:
    """Where the alarm threshold of these healthy distances comes from: ``"floor"`` when the
    floor is above the fitted exponential quantile, else ``"fit"``."""
    scale = sum(distances) / len(distances)
    fitted = float(exponential_quantile(scale, percentile / 100.0))
    return "fit" if floor is None or floor <= fitted else "floor"


def axis_decisions_naive(
    distances: list[float],
    alarmed_before: list[bool],
    *,
    calibration_size: int,
    percentile: float,
    floor: float | None,
    k: int,
    n: int,
    m: int,
) -> list[tuple[str, float | None, bool, bool]]:
    """Role, threshold, over and alarm of each capture of one baseline, spelled out: the first
    ``calibration_size`` captures not alarmed before calibrate (the last of them sets the
    threshold: the exponential quantile of their mean, raised to ``floor``), then every capture
    is monitored with the k-of-n / m-clean alarm rule."""
    decisions: list[tuple[str, float | None, bool, bool]] = []
    healthy: list[float] = []
    overs: list[bool] = []
    threshold: float | None = None
    for distance, excluded in zip(distances, alarmed_before, strict=True):
        if threshold is None and excluded:
            decisions.append(("excluded", None, False, False))
        elif threshold is None:
            healthy.append(distance)
            if len(healthy) == calibration_size:
                threshold = alarm_threshold_naive(healthy, percentile, floor)
            decisions.append(("calibration", threshold, False, False))
        else:
            overs.append(distance > threshold)
            alarm = alarm_states_naive(overs, k=k, n=n, m=m)[-1]
            decisions.append(("monitor", threshold, overs[-1], alarm))
    return decisions


def robust_spread(values: list[float]) -> float:
    """1.4826 x the median absolute deviation, by sorting by hand (NaN with fewer than 3)."""
    finite = sorted(v for v in values if v == v and abs(v) != float("inf"))
    if len(finite) < 3:
        return float("nan")

    def median(xs: list[float]) -> float:
        xs = sorted(xs)
        mid = len(xs) // 2
        return xs[mid] if len(xs) % 2 else 0.5 * (xs[mid - 1] + xs[mid])

    centre = median(finite)
    return 1.4826 * median([abs(v - centre) for v in finite])


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


def task_signature_naive(position: list[float], speed: list[float]) -> list[float]:
    """Sort and interpolate between neighbours for each quantile (NumPy's default rule)."""

    def quantile(values: list[float], p: float) -> float:
        xs = sorted(values)
        h = (len(xs) - 1) * p
        low = int(h)
        if low + 1 >= len(xs):
            return xs[low]
        return xs[low] + (h - low) * (xs[low + 1] - xs[low])

    magnitudes = [abs(v) for v in speed]
    top = quantile(magnitudes, 0.98)
    moving = [v for v in magnitudes if v > 0.1 * top]
    return [
        top,
        quantile(moving, 0.5),
        quantile(moving, 0.9),
        quantile(position, 0.02),
        quantile(position, 0.98),
        len(moving) / len(magnitudes),
    ]


def indicator_allowances_naive(
    centres: list[dict[str, float]],
    withins: list[dict[str, float]],
    task_spreads: dict[str, float],
    percentile: float,
    fallback: float,
) -> dict[str, float]:
    """Per indicator: every ordered pair of axes by two loops (``i``'s centre in ``j``'s
    spreads), |z| by hand, the middle of the sorted list, the exponential quantile
    ``-b ln(1 - q)`` at Bonferroni's level (fewer than 3 pairs, or a median of 0:
    ``fallback``)."""
    nan = float("nan")
    shifts: dict[str, list[float]] = {}
    for name, spread in task_spreads.items():
        if not (spread == spread and spread > 0):
            continue
        shifts[name] = []
        for i in range(len(centres)):
            for j in range(len(centres)):
                if i == j:
                    continue
                scale = (spread**2 + withins[j].get(name, nan) ** 2) ** 0.5
                z = (centres[i].get(name, nan) - centres[j].get(name, nan)) / scale
                if z == z and abs(z) != float("inf"):
                    shifts[name].append(abs(z))
    scales = {}
    for name, zs in shifts.items():
        zs = sorted(zs)
        n = len(zs)
        middle = (zs[n // 2] if n % 2 else (zs[n // 2 - 1] + zs[n // 2]) / 2) if n else 0.0
        if n >= 3 and middle > 0:
            scales[name] = middle / math.log(2.0)
    level = 1 - (1 - percentile / 100) / max(len(scales), 1)
    return {
        name: -scales[name] * math.log(1 - level) if name in scales else fallback for name in shifts
    }


def order_profile_naive(
    orders: list[float], power: list[float], floor: list[float], per_decade: int
) -> dict[int, float]:
    """Cell -> log10(power / floor) summed over its bins, one bin at a time (cell ``k`` holds
    the orders from ``10 ** (k / per_decade)`` up to the next cell's)."""
    sums: dict[int, list[float]] = {}
    for order, p, f in zip(orders, power, floor, strict=True):
        if order <= 0 or f <= 0:
            continue
        k = math.floor(per_decade * math.log10(order))
        cell = sums.setdefault(k, [0.0, 0.0])
        cell[0] += p
        cell[1] += f
    return {k: math.log10(p / f) for k, (p, f) in sums.items() if f > 0}


def order_reference_naive(profiles: list[dict[int, float]]) -> dict[int, float]:
    """Per cell the middle of the sorted values of the profiles that read it, then the largest
    of the cell and its two neighbours."""
    cells = sorted({k for p in profiles for k, v in p.items() if v == v})
    median = {}
    for k in cells:
        xs = sorted(p[k] for p in profiles if k in p and p[k] == p[k])
        n = len(xs)
        median[k] = xs[n // 2] if n % 2 else (xs[n // 2 - 1] + xs[n // 2]) / 2
    out = {}
    for k in range(min(cells), max(cells) + 1):
        near = [median[j] for j in (k - 1, k, k + 1) if j in median]
        if near:
            out[k] = max(near)
    return out


def grown_lines_naive(
    profile: dict[int, float], reference: dict[int, float], top: int, min_common: int
) -> float:
    """Growth of every cell both read, sorted by hand, the mean of the ``top`` largest."""
    growth = [profile[k] - reference[k] for k in profile if k in reference]
    growth = [g for g in growth if g == g]
    if len(growth) < min_common:
        return float("nan")
    growth.sort(reverse=True)
    return sum(growth[:top]) / len(growth[:top])


def fleet_difference_naive(
    centre: dict[str, float],
    within: dict[str, float],
    fleet_centre: dict[str, float],
    task_spreads: dict[str, float],
    allowances: dict[str, float],
    one_sided: set[str],
) -> float:
    """The axis's centre against the fleet's, indicator by indicator with a task spread ``s_t``:
    the difference over ``sqrt(s_w^2 + s_t^2)`` and over its allowance, only upwards for
    ``one_sided``; the largest (NaN when no such indicator is read by both)."""
    nan = float("nan")
    largest = nan
    for name, own in within.items():
        mine, theirs = centre.get(name, nan), fleet_centre.get(name, nan)
        task = task_spreads.get(name, nan)
        if mine != mine or theirs != theirs or task != task:
            continue
        z = (mine - theirs) / ((own**2 + task**2) ** 0.5 * allowances[name])
        z = max(z, 0.0) if name in one_sided else abs(z)
        largest = z if largest != largest else max(largest, z)
    return largest


def fleet_pair_shifts_naive(
    centres: list[list[float]],
    within: list[list[float]],
    task_spreads: list[float],
    one_sided: list[bool],
) -> tuple[list[list[float]], list[list[float]]]:
    """Every ordered pair ``i != j`` by two loops: ``z = (c_i - c_j) / sqrt(s_t^2 + s_w,j^2)``
    per indicator with a positive task spread (capture ``i`` in baseline ``j``'s spreads); the
    pair's distance is the largest ``max(z, 0)`` (one sided) or ``|z|`` over the finite ones
    (NaN if none, and on the diagonal); per indicator the list of the finite ``|z|``."""
    nan = float("nan")
    n = len(centres)
    distances = [[nan] * n for _ in range(n)]
    shifts: list[list[float]] = [[] for _ in task_spreads]
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            largest = nan
            for k, spread in enumerate(task_spreads):
                if not (spread == spread and 0 < spread < float("inf")):
                    continue
                scale = (spread**2 + within[j][k] ** 2) ** 0.5
                z = (centres[i][k] - centres[j][k]) / scale
                if z != z:
                    continue
                shifts[k].append(abs(z))
                shift = max(z, 0.0) if one_sided[k] else abs(z)
                largest = shift if largest != largest else max(largest, shift)
            distances[i][j] = largest
    return distances, shifts


def gap_ringing_naive(
    time_s: np.ndarray,
    position: np.ndarray,
    speed: np.ndarray,
    acceleration: np.ndarray,
    torque: np.ndarray,
    rate_hz: float,
    hysteresis: float = 0.1,
    reference: str = "away",
) -> float:
    """:func:`axiswatch.indicators._ringing.gap_ringing`, sample by sample: normal equations for the fit,
    loops for the passages, the windows and the median (the filters are SciPy's)."""
    from scipy.signal import butter, sosfiltfilt

    n = len(torque)
    peak = max(abs(float(v)) for v in speed)
    moving = [abs(float(v)) > 0.1 * peak for v in speed]
    q_moving = [float(position[i]) for i in range(n) if moving[i]]
    mean_q = sum(q_moving) / len(q_moving)
    span = (max(q_moving) - min(q_moving)) or 1.0
    rows = []
    for i in range(n):
        q = (float(position[i]) - mean_q) / span
        s = min(1.0, max(-1.0, float(speed[i]) / (0.1 * peak)))
        rows.append([s, float(speed[i]), float(acceleration[i]), 1.0, q, q**2, q**3])
    design = np.asarray(rows)
    fit_rows = design[np.asarray(moving)]
    coefficients = np.linalg.solve(fit_rows.T @ fit_rows, fit_rows.T @ torque[np.asarray(moving)])
    whole = [sum(r[j] * coefficients[j] for j in range(7)) for r in rows]
    rigid = [sum(r[j] * coefficients[j] for j in range(2, 7)) for r in rows]

    def filtered(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
        return np.asarray(sosfiltfilt(sos, x, padlen=min(3 * (2 * sos.shape[0] + 1), len(x) - 1)))

    smooth = filtered(butter(2, min(10.0, 0.25 * rate_hz), fs=rate_hz, output="sos"), torque)
    crossings = set()
    for x in (rigid, smooth):
        level = hysteresis * max(abs(float(v)) for v in x)
        side, last_change = 0, -1
        for k in range(n):
            if k > 0 and ((x[k - 1] > 0 and x[k] < 0) or (x[k - 1] < 0 and x[k] > 0)):
                last_change = k - 1
            here = 1 if x[k] > level else (-1 if x[k] < -level else 0)
            if here == 0:
                continue
            if side != 0 and here != side:
                crossings.add(last_change)
            side = here
    sos = butter(4, [5.0, min(50.0, 0.45 * rate_hz)], btype="bandpass", fs=rate_hz, output="sos")
    residual = filtered(sos, torque - np.asarray(whole))
    near, away = [], []
    for i in range(n):
        before, after = round(0.05 * rate_hz), round(0.3 * rate_hz)  # whole samples
        if moving[i] and any(k - before <= i <= k + after for k in crossings):
            near.append(float(residual[i]) ** 2)
        elif moving[i]:
            away.append(float(residual[i]) ** 2)
    if reference == "away":
        return (sum(near) / len(near)) / (sum(away) / len(away))
    magnitudes = sorted(abs(float(residual[i])) for i in range(n) if moving[i])
    middle = len(magnitudes) // 2
    median = (
        magnitudes[middle]
        if len(magnitudes) % 2
        else 0.5 * (magnitudes[middle - 1] + magnitudes[middle])
    )
    return (sum(near) / len(near)) / (1.4826 * median) ** 2


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


def whole_move_mask_naive(speed: list[float], fraction: float) -> list[bool]:
    """Runs of one sign of a moving speed, walked sample by sample; a run touching either end of
    the capture is cut (not whole)."""
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


def sampling_period_naive(stamps: list[float]) -> float:
    """Least-squares slope of the stamps on the sample index, sums written out."""
    n = len(stamps)
    mean_index = sum(range(n)) / n
    mean_stamp = sum(stamps) / n
    covariance = sum((i - mean_index) * (t - mean_stamp) for i, t in enumerate(stamps))
    variance = sum((i - mean_index) ** 2 for i in range(n))
    return covariance / variance


def kinematic_lines(
    position: np.ndarray,
    speed: np.ndarray,
    torque: np.ndarray,
    rate_hz: float,
    gear_ratio: float,
    gear_stages: dict[str, float],
    bearing_orders: dict[str, float],
) -> dict[str, float]:
    """The kinematic line ratios of a capture's motion, each in the exact band its speeds set
    (a Butterworth design per line) and each with its own nested least squares, written out.

    The twin of ``_readings._kinematic_lines`` as it read before the bands were put on a grid
    and one projection was shared by every line. Readings the capture cannot give are left out.
    """
    from scipy.signal import butter, sosfiltfilt

    def rss(columns: list[np.ndarray], y: np.ndarray) -> float:
        design = np.column_stack(columns)
        r = y - design @ np.linalg.lstsq(design, y, rcond=None)[0]
        return float(r @ r)

    def f(y: np.ndarray, angle: np.ndarray, orders: list[float]) -> float:
        whole = [g(o * angle) for o in range(1, 9) for g in (np.sin, np.cos)]
        tests = [g(o * angle) for o in orders for g in (np.sin, np.cos)]
        small, big = rss(whole, y), rss(whole + tests, y)
        p, k = len(tests), len(whole) + len(tests)
        return float((small - big) / p / (big / (y.size - k)))

    peak = float(np.max(np.abs(speed)))
    fast = np.abs(speed) > 0.2 * peak
    motor_angle = gear_ratio * position
    revs = gear_ratio * np.abs(speed[fast]) / (2 * math.pi)
    slow_revs, fast_revs = (float(np.quantile(revs, q)) for q in (0.1, 0.9))
    travel = np.abs(np.diff(motor_angle, prepend=motor_angle[0]))
    revolutions = float(np.sum(travel[fast])) / (2 * math.pi)
    nyquist_margin = 0.45 * rate_hz
    lines: dict[str, tuple[list[float], list[float]]] = {}
    for name, stage in gear_stages.items():
        orders = [k / stage for k in range(1, int(8 * stage) + 1) if k % stage]
        lines[f"tooth_lines:{name}"] = (orders, [0.5 / stage])
    for name, defect in bearing_orders.items():
        orders = [defect + k for k in (-2, -1, 0, 1, 2)] + [2 * defect + k for k in (-1, 0, 1)]
        lines[f"bearing_lines:{name}"] = (orders, [-0.25, 0.25])
    out = {}
    for name, (orders, offsets) in lines.items():
        low = 0.5 * min(orders) * slow_revs
        high = min(nyquist_margin, 1.5 * max(orders) * fast_revs)
        if max(orders) * fast_revs >= nyquist_margin or revolutions < 10 or low <= 0:
            continue
        sos = butter(4, [low, high], btype="bandpass", fs=rate_hz, output="sos")
        x = sosfiltfilt(sos, torque)[fast]
        theta = motor_angle[fast]
        shifted = [f(x, theta, [o + d for o in orders]) for d in offsets]
        out[name] = f(x, theta, orders) / float(np.mean(shifted))
    return out
