"""Speed and memory of axiswatch's scoring path (``make bench``; ``--quick`` for a smoke run).

Every case runs in a subprocess of its own so that its peak memory (``ru_maxrss``) is its own.
Times are medians of repeats measured in that subprocess; the dense reference solver is timed in
the same subprocess as the fast one, and their ratio printed. BLAS runs on one thread
(``OPENBLAS_NUM_THREADS=1`` etc.) except in the fleet case, which uses 2 worker processes of one
thread each.

Data: synthetic captures from a cheap model (a task cycle plus two motor harmonics plus noise on
position 250 Hz, speed and torque 2 kHz, as the paper's robots), written as Parquet where a case
reads files; features are the real ones (``FeatureSpec()``: 6 channels x 65 bins = 390 columns,
one row per sample). The fleet case runs the real monitor on the robot simulator's fleet (its
features: the monitor's defaults, one row per 8 samples).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import axiswatch as aw
import axiswatch._alignment
import axiswatch.datasets as awd

ONE_THREAD = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
#: Dense 2N x 2N eigenproblems above this N are skipped in --quick (they take minutes at 4,000).
QUICK_DENSE_MAX = 300


def synthetic_capture(seconds: float, seed: int, *, robot: str = "r0", axis: str = "a1") -> Any:
    """A capture of the paper's rates from a sinusoid-plus-noise model (not a robot recording)."""
    rng = np.random.default_rng(seed)
    slow = np.arange(round(250 * seconds)) / 250.0
    fast = np.arange(round(2000 * seconds)) / 2000.0
    cycle_hz = 1.0 + 0.1 * rng.uniform()
    return aw.Capture(
        {
            "position": np.sin(2 * np.pi * cycle_hz * slow) + 0.01 * rng.normal(size=slow.size),
            "speed": np.cos(2 * np.pi * cycle_hz * fast)
            + 0.3 * np.sin(2 * np.pi * 37 * fast)
            + 0.05 * rng.normal(size=fast.size),
            "torque": 0.5 * np.cos(2 * np.pi * cycle_hz * fast)
            + 0.2 * np.sin(2 * np.pi * 91 * fast)
            + 0.05 * rng.normal(size=fast.size),
        },
        {"position": 250.0, "speed": 2000.0, "torque": 2000.0},
        metadata={"robot": robot, "axis": axis},
    )


def _median_time(fn: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def case_lra(n_rows: int, quick: bool) -> dict[str, Any]:
    """Fast solver (both bases + alignment) against the dense 2N x 2N reference, real features."""
    seconds = n_rows / 2000.0 + 0.1
    X_s = aw.extract_features(synthetic_capture(seconds, 1)).X[:n_rows]
    X_t = aw.extract_features(synthetic_capture(seconds, 2)).X[:n_rows]

    def fast() -> float:
        return aw._alignment.lra_structured(aw.low_rank_basis(X_s), aw.low_rank_basis(X_t)).delta

    fast_s = _median_time(fast, 1 if quick else 5)
    out: dict[str, Any] = {"case": f"LRA N={n_rows:,} (K={X_s.shape[1]})", "fast_s": fast_s}
    if quick and n_rows > QUICK_DENSE_MAX:
        out["note"] = f"dense skipped in --quick (N > {QUICK_DENSE_MAX})"
        return out
    dense_deltas: list[float] = []
    dense_s = _median_time(
        lambda: dense_deltas.append(aw._alignment.lra_dense(X_s, X_t).delta),
        1 if n_rows >= 2000 else 3,
    )
    fast_delta = fast()
    out.update(dense_s=dense_s, ratio=dense_s / fast_s, delta=fast_delta)
    out["delta_error"] = abs(fast_delta - dense_deltas[-1])
    out["tolerance"] = 1e-9 + 1e-6 * dense_deltas[-1]
    return out


def _scored_model(seconds: float) -> Any:
    model = aw.HealthModel(aw.FeatureSpec(), aw.LRADetector())
    model.fit(synthetic_capture(seconds, 1))
    # The threshold comes from distances of healthy captures (half-Laplace fit, paper).
    return model.calibrate(
        np.array([model.distance(synthetic_capture(seconds, s)) for s in (2, 3)])
    )


def case_capture(seconds: float, quick: bool) -> dict[str, Any]:
    """One capture scored end to end: read Parquet, features, LRA, threshold (fitted model)."""
    model = _scored_model(seconds)
    with tempfile.TemporaryDirectory() as folder:
        path = aw.write_capture(synthetic_capture(seconds, 7), Path(folder) / "capture.parquet")

        def score() -> bool:
            return model.assess(aw.read_capture(path)).alarm

        fast_s = _median_time(score, 1 if quick or seconds > 10 else 5)
    return {
        "case": f"{seconds:g} s capture end to end (N={round(seconds * 2000) - 7:,})",
        "fast_s": fast_s,
        "note": "read + features + LRA + threshold; dense not run (2N x 2N: minutes or > RAM)",
    }


def case_fleet(robots: int, quick: bool, method: str = "mechanics") -> dict[str, Any]:
    """One fleet day through the real monitor: robots x 6 axes, one new 3 s capture each, 2 workers.

    Set-up, not timed: a simulated fleet (``simulate_fleet``, 6 days a axis) is commissioned by a
    first ``monitor_fleet`` run (baselines and 5 calibration captures per axis). Timed: a second
    run after a seventh day of captures arrived, exactly what a daily cron job does (discover and
    hash the fleet, fit each axis's baseline from its file, read, align, featurize and score every
    new capture on 2 worker processes, commit each result to the SQLite store).
    """
    from axiswatch.datasets._robot import simulate_fleet
    from axiswatch.monitor._monitor import monitor_fleet
    from axiswatch.monitor._scoring import MonitorConfig
    from axiswatch.monitor._store import Store

    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder) / "fleet"
        simulate_fleet(root, n_robots=robots, n_axes=6, n_days=7, task_change_days=(), faults=[])
        held = Path(folder) / "held"
        new_day = sorted(root.glob("*/*/*-07.parquet"))
        for path in new_day:
            target = held / path.relative_to(root)
            target.parent.mkdir(parents=True, exist_ok=True)
            path.rename(target)
        config = MonitorConfig(method=method)
        with Store(Path(folder) / "fleet.db") as store:
            monitor_fleet(root, store, config, workers=2)
            for path in new_day:
                (held / path.relative_to(root)).rename(path)
            start = time.perf_counter()
            summary = monitor_fleet(root, store, config, workers=2)
            elapsed = time.perf_counter() - start
    assert summary.scored == len(new_day) == robots * 6, summary
    note = f"{len(new_day)} new captures scored into the store"
    if robots != 1000:
        note += f"; 1,000 robots extrapolated (linear): {elapsed * 1000 / robots:.0f} s"
    return {
        "case": f"fleet day: {robots} robots x 6 axes, monitor --workers 2 ({method})",
        "fast_s": elapsed,
        "note": note,
    }


def case_mechanics(quick: bool) -> dict[str, Any]:
    """The product default (mechanics indicators) on one 3 s simulated capture, against the
    paper's LRA at the monitor's hop 8 on the same capture, in the same process."""
    baseline = awd.simulate_capture("heavy", seed=1)
    capture = awd.simulate_capture("palletize", seed=2)
    stage = aw.MechanicsStage().fit(baseline)
    detector = aw.IndicatorDetector().fit(stage.baseline_rows_)
    lra = aw.HealthModel(aw.FeatureSpec(hop=8), aw.LRADetector()).fit(baseline)
    repeats = 3 if quick else 10
    fast_s = _median_time(lambda: detector.distance(stage.transform(capture).X), repeats)
    reference_s = _median_time(lambda: lra.distance(capture), repeats)
    return {
        "case": "3 s capture: mechanics indicators (reference: LRA, hop 8)",
        "fast_s": fast_s,
        "dense_s": reference_s,
        "ratio": reference_s / fast_s,
        "note": "reference column = the paper's LRA with the monitor's |STFT| features",
    }


CASES: dict[str, Callable[[bool], dict[str, Any]]] = {
    "mechanics-3s": case_mechanics,
    "lra-300": lambda q: case_lra(300, q),
    "lra-1000": lambda q: case_lra(1000, q),
    "lra-2000": lambda q: case_lra(2000, q),
    "lra-4000": lambda q: case_lra(4000, q),
    "capture-3s": lambda q: case_capture(3.0, q),
    "capture-60s": lambda q: case_capture(60.0, q),
}


def run_case(name: str, quick: bool, robots: int, method: str) -> None:
    """Child process: run one case, print its result as one JSON line."""
    result = case_fleet(robots, quick, method) if name == "fleet" else CASES[name](quick)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux
    if name == "fleet":
        peak = max(peak, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)
    result["peak_mb"] = peak / 1e6
    print(json.dumps(result))


def machine() -> str:
    cpu = "unknown"
    with open("/proc/cpuinfo") as info:
        for line in info:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    with open("/proc/meminfo") as info:
        memory_gb = int(info.readline().split()[1]) / 1024**2
    import scipy

    blas = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
    return (
        f"{os.cpu_count()} CPUs ({cpu}), {memory_gb:.0f} GiB, Python {platform.python_version()}, "
        f"NumPy {np.__version__}, SciPy {scipy.__version__}, BLAS {blas['name']} "
        f"{blas.get('version', '')}; load average {os.getloadavg()[0]:.1f} at start"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: small cases, seconds")
    parser.add_argument("--case", help=argparse.SUPPRESS)
    parser.add_argument(
        "--fleet-robots",
        type=int,
        default=None,
        help="robots in the fleet case (default 100, extrapolated; 1000 is the full day: ~30 min with set-up)",
    )
    parser.add_argument(
        "--fleet-method",
        default="mechanics",
        choices=["mechanics", "lra", "pca"],
        help="monitor method of the fleet case (default: the product default)",
    )
    args = parser.parse_args()
    robots = args.fleet_robots or (2 if args.quick else 100)
    if args.case:
        run_case(args.case, args.quick, robots, args.fleet_method)
        return
    names = ["lra-300", "capture-3s", "mechanics-3s", "fleet"] if args.quick else [*CASES, "fleet"]
    print(machine())
    print(f"{'case':<62} {'fast s':>9} {'dense s':>9} {'ratio':>8} {'peak MB':>8}  note")
    for name in names:
        env = {**os.environ, **ONE_THREAD}
        command = [sys.executable, __file__, "--case", name, "--fleet-robots", str(robots)]
        command += ["--fleet-method", args.fleet_method]
        if args.quick:
            command.append("--quick")
        child = subprocess.run(command, env=env, capture_output=True, text=True)
        if child.returncode:
            sys.exit(f"case {name} failed:\n{child.stderr}")
        row = json.loads(child.stdout.strip().splitlines()[-1])
        dense = f"{row['dense_s']:9.3f}" if "dense_s" in row else f"{'-':>9}"
        ratio = f"{row['ratio']:7.0f}x" if "ratio" in row else f"{'-':>8}"
        note = row.get("note", "")
        if "delta_error" in row:
            note = (
                f"|delta_fast - delta_dense| = {row['delta_error']:.1e} "
                f"(delta {row['delta']:.4g}, target {row['tolerance']:.1e})"
            )
        print(
            f"{row['case']:<62} {row['fast_s']:9.3f} {dense} {ratio} {row['peak_mb']:8.0f}  {note}"
        )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
