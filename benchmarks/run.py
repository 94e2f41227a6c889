"""Speed and memory of axiswatch's scoring path (``make bench``; ``--quick`` for a smoke run).

Every case runs in a subprocess of its own so that its peak memory (``ru_maxrss``) is its own.
Times are medians of repeats measured in that subprocess; the dense reference solver is timed in
the same subprocess as the fast one, and their ratio printed. BLAS runs on one thread
(``OPENBLAS_NUM_THREADS=1`` etc.) except in the fleet case, which uses 2 worker processes of one
thread each.

Data: the project's robot simulator (``axiswatch.datasets.simulate_capture`` and
``simulate_fleet``) for the realistic cases (``job-3s-*``, ``lra-60s-robot``, the fleet cases of
``benchmarks/fleet.py``), and synthetic captures from a cheap model (a task cycle plus two motor
harmonics plus noise) for the solver cases, whose features keep a low rank (6-11) that robot
captures do not (72-150). Features are the real ones.

**Physical floor**: reading the same Parquet file with the same reader plus one ``rfft`` per
signal, timed in the same process as the case; every realistic case prints its ratio to it.

Modes: ``--fleet-robots 10,30,90`` (fleet days of several sizes, a linear fit and its
extrapolation to 10,000 robots), ``--history 7,365`` (a run with nothing new after a year of
kept files), ``--workers-curve`` (1-16 processes and a Dask LocalCluster; writes a CSV),
``--memory`` (peak memory of ``monitor`` against one capture's length, 3 s to 4 h; ``--quick``:
3 s and 60 s).
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
import pyarrow.parquet as pq
import scipy.fft
from threadpoolctl import threadpool_limits

import axiswatch as aw
import axiswatch.datasets as awd
import axiswatch.paper._alignment
from axiswatch.monitor._methods import DEFAULT_METHOD

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fleet
import memory

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


def _cpu_time(fn: Callable[[], Any], repeats: int = 1) -> float:
    """Median CPU seconds of ``fn`` in this process: the machine is shared, so wall time is not
    the figure; BLAS runs on one thread, so CPU time is the work done."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return statistics.median(times)


def _lra_features(n_rows: int, source: str) -> tuple[Any, Any]:
    """Baseline and test features of ``n_rows`` rows (hop 1): synthetic captures, or 2 robot
    tasks of the simulator (``heavy`` against ``palletize``)."""
    seconds = n_rows / 2000.0 + 0.1
    if source == "robot":
        captures = [
            awd.simulate_capture(task, seed=seed, duration_s=seconds)
            for task, seed in (("heavy", 1), ("palletize", 2))
        ]
    else:
        captures = [synthetic_capture(seconds, seed) for seed in (1, 2)]
    X_s, X_t = (aw.extract_features(c).X[:n_rows] for c in captures)
    return X_s, X_t


def case_lra(n_rows: int, quick: bool, source: str = "synthetic") -> dict[str, Any]:
    """Fast solver (both bases + alignment) against the dense 2N x 2N reference, in CPU seconds
    measured in the same process; features from :func:`_lra_features`."""
    X_s, X_t = _lra_features(n_rows, source)

    def fast() -> float:
        return aw.paper._alignment.lra_structured(
            aw.low_rank_basis(X_s), aw.low_rank_basis(X_t)
        ).delta

    fast_s = _cpu_time(fast, 1 if quick else 7)
    fast_result = aw.paper._alignment.lra_structured(aw.low_rank_basis(X_s), aw.low_rank_basis(X_t))
    ranks = f"ranks {fast_result.rank_source}/{fast_result.rank_target}"
    label = "robot" if source == "robot" else "synthetic"
    out: dict[str, Any] = {
        "case": f"LRA N={n_rows:,} (K={X_s.shape[1]}, {label}, {ranks}), CPU s",
        "fast_s": fast_s,
    }
    if quick and n_rows > QUICK_DENSE_MAX:
        out["note"] = f"dense skipped in --quick (N > {QUICK_DENSE_MAX})"
        return out
    dense_deltas: list[float] = []
    dense_s = _cpu_time(
        lambda: dense_deltas.append(aw.paper._alignment.lra_dense(X_s, X_t).delta),
        1 if n_rows >= 2000 else 3,
    )
    out.update(dense_s=dense_s, ratio=dense_s / fast_s, delta=fast_result.delta)
    out["delta_error"] = abs(fast_result.delta - dense_deltas[-1])
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


def _floor(path: Path, *, one_file: bool = False) -> None:
    """The physical floor of scoring a capture file: read its columns (pyarrow, no validation)
    and one ``rfft`` per signal. ``one_file``: read with ``ParquetFile.read``, as the project's
    reader does, without ``read_table``'s dataset machinery (about 0.25 ms less on 3 s)."""
    if one_file:
        with pq.ParquetFile(path) as parquet:
            table = parquet.read()
    else:
        table = pq.read_table(path)
    for name in table.column_names:
        if name != "time":
            scipy.fft.rfft(table[name].to_numpy())


def _reader_floor(path: Path) -> None:
    """Same, through the project's reader (``read_capture``: validation, rates, metadata)."""
    capture = aw.read_capture(path)
    for values in capture.signals.values():
        scipy.fft.rfft(values)


def case_job(
    method: str,
    quick: bool,
    *,
    order_lines: bool = False,
    profile: bool = False,
    modes: bool = False,
) -> dict[str, Any]:
    """The monitor's scoring job on one 3 s robot-simulator capture (warm worker: model kept,
    BLAS limited once), against the physical floor of the same file, in the same process;
    ``order_lines``: the ``indicators`` method with its order-lines option; ``profile``: with
    the axis profile ``axiswatch simulate fleet`` writes (kinematics: tooth and bearing lines);
    ``modes``: with ``--modes``, the job's description and the mode library's decision (score,
    learn, the library pickled for the store) on a library of 4 tasks at their full window."""
    from axiswatch._profiles import AxisProfile
    from axiswatch.datasets._robot_fleet import fleet_profile_toml
    from axiswatch.monitor._config import MonitorConfig
    from axiswatch.monitor._fleet import FleetFile
    from axiswatch.monitor._models import ModelRef, keep_model
    from axiswatch.monitor._scoring import ScoreJob, score_capture

    config = MonitorConfig(method=method, order_lines=order_lines)  # type: ignore[arg-type]
    axis_profile = None
    if profile:
        toml = Path(tempfile.mkdtemp()) / "axiswatch.toml"
        toml.write_text(fleet_profile_toml(), encoding="utf-8")
        axis_profile = AxisProfile.from_toml(toml)
    baseline = awd.simulate_capture("heavy", seed=1)
    # Fitted as the monitor's fit job does: a model that fits its calibration captures on the
    # baseline and K = 5 of them, another on the baseline alone.
    template = config.model()
    fitting = [baseline]
    if template.fits_calibration:
        fitting += [awd.simulate_capture("heavy", seed=s) for s in range(3, 8)]
    model: Any = template.fit_read(
        [template.read(c, None)[0] for c in fitting], [(f"fit{k}", "") for k in range(len(fitting))]
    )
    # A model of a class the store does not take (a plugin's, the lab's mechanics) goes inline.
    key, blob = keep_model(model)
    ref = ModelRef(key, "", inline=model if blob is None else None)
    repeats = 5 if quick else 30
    with tempfile.TemporaryDirectory() as folder, threadpool_limits(1):
        (Path(folder) / "r/a").mkdir(parents=True)
        # Without a fleet an indicators model does not compare another task's capture (it is
        # not scored, in microseconds): its job is timed on a capture of the baseline's task.
        task = "heavy" if template.fits_calibration else "palletize"
        path = aw.write_capture(
            awd.simulate_capture(task, seed=2), Path(folder) / "r/a/2026-03-02.parquet"
        )
        from datetime import datetime

        file = FleetFile("r", "a", path.name, path, datetime(2026, 3, 2))
        job = ScoreJob(
            file, "r/a/" + path.name, 1, ref, dict(baseline.rates_hz),
            profile=axis_profile, modes=modes,
        )  # fmt: skip
        assert score_capture(job).error is None
        work: Callable[[], Any] = lambda: score_capture(job)  # noqa: E731
        if modes:
            work = _mode_decision(job, model, axis_profile, quick)
        # Interleaved, so that a load change on this shared machine hits both alike.
        jobs, floors, readers, files = [], [], [], []
        for _ in range(repeats):
            jobs.append(_cpu_time(work))
            floors.append(_cpu_time(lambda: _floor(path)))
            readers.append(_cpu_time(lambda: _reader_floor(path)))
            files.append(_cpu_time(lambda: _floor(path, one_file=True)))
    job_s, floor_s = statistics.median(jobs), statistics.median(floors)
    reader_s, file_s = statistics.median(readers), statistics.median(files)
    return {
        "case": f"3 s robot capture: scoring job ({method}"
        f"{' --order-lines' if order_lines else ''}{' --modes' if modes else ''}"
        f"{', profile' if profile else ''}) vs floor",
        "fast_s": job_s,
        "dense_s": floor_s,
        "ratio": job_s / floor_s,
        "note": f"CPU s; ratio = job / floor (pyarrow read + rfft per signal); median of "
        f"{repeats} interleaved; through read_capture the floor is {reader_s * 1e3:.2f} ms "
        f"({job_s / reader_s:.1f}x); read as one file (ParquetFile) the floor is "
        f"{file_s * 1e3:.2f} ms ({job_s / file_s:.1f}x)",
        "floor_one_file_s": file_s,
    }


def _mode_decision(job: Any, model: Any, profile: Any, quick: bool) -> Callable[[], Any]:
    """The job with ``--modes`` as the monitor runs it: score the capture, then the library's
    verdict, its learning and its pickle (saved with the score). The library holds 4 tasks of
    the simulator at their full window (``2 x window`` captures each; 8 with ``quick``)."""
    import pickle

    from axiswatch.indicators._mode_library import ModeLibrary
    from axiswatch.indicators._modes import describe_capture
    from axiswatch.monitor._scoring import score_capture

    library = ModeLibrary()
    per_task = 8 if quick else 2 * library.window
    for task in list(awd.TASKS)[:4]:
        for seed in range(per_task):
            capture = awd.simulate_capture(task, seed=100 + seed)
            library.update(describe_capture(capture, readings=model.read(capture, profile)[0]))

    def decide() -> None:
        description = score_capture(job).description
        assert description is not None
        library.learn(description, library.score(description))
        pickle.dumps(library)

    return decide


def case_lra_60s(quick: bool) -> dict[str, Any]:
    """LRA at hop 1 (the paper's one row per sample) on a 60 s robot-simulator capture: fit on
    a ``heavy`` capture, then the distance of a ``palletize`` capture read from Parquet
    (``HealthModel.distance``), in CPU seconds; the floor in the same process."""
    seconds = 10.0 if quick else 60.0
    model = aw.HealthModel(aw.FeatureSpec(), aw.LRADetector())
    baseline = awd.simulate_capture("heavy", seed=1, duration_s=seconds)
    with tempfile.TemporaryDirectory() as folder:
        path = aw.write_capture(
            awd.simulate_capture("palletize", seed=2, duration_s=seconds),
            Path(folder) / "capture.parquet",
        )
        start = time.process_time()
        model.fit(baseline)
        fit_s = time.process_time() - start
        del baseline
        start = time.process_time()
        model.distance(aw.read_capture(path))
        score_s = time.process_time() - start
        floor_s = _cpu_time(lambda: _floor(path), 3)
    return {
        "case": f"{seconds:g} s robot capture, LRA hop 1: score, CPU s (fit in note)",
        "fast_s": score_s,
        "dense_s": floor_s,
        "ratio": score_s / floor_s,
        "note": f"fit {fit_s:.1f} s CPU; baseline rank {model.detector_.basis_.rank}; "
        "ratio = score / floor; peak = fit then score",
    }


def case_mechanics(quick: bool) -> dict[str, Any]:
    """The former default (the lab's mechanics indicators, through its registered method) on
    one 3 s simulated capture, against the paper's LRA at the monitor's hop 8 on the same
    capture, in the same process."""
    baseline = awd.simulate_capture("heavy", seed=1)
    capture = awd.simulate_capture("palletize", seed=2)
    model = aw.MonitorConfig(method="mechanics").model()
    assert isinstance(model, aw.HealthModel)
    assert model.stage is not None
    stage = model.stage.fit(baseline)
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


def case_pool(n_axes: int, quick: bool) -> dict[str, Any]:
    """Pooling the fitted indicator models of ``n_axes`` axes of one profile into their fleet
    prior (once per profile and monitor run with new baselines), against the ordered pairs'
    shifts by the loop twin of the tests (the pair loop ``pool_fleet`` had before), in the same
    process.

    The axes: six models fitted on six tasks of a simulated robot, repeated with their centres
    spread by 5 % (a fleet of one robot model on six kinds of task)."""
    import copy

    from axiswatch.indicators._fleet import pool_fleet
    from axiswatch.indicators._spreads import _declared

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests import naive

    robot = awd.draw_robot(0)
    fitted = [
        aw.IndicatorModel().fit(
            robot.capture(t, seed=0), [robot.capture(t, seed=k) for k in range(1, 6)]
        )
        for t in range(6)
    ]
    rng = np.random.default_rng(0)
    models = []
    for i in range(n_axes):
        model = copy.deepcopy(fitted[i % 6])
        model.centre_ = {
            k: v * (1 + 0.05 * rng.standard_normal()) for k, v in model.centre_.items()
        }
        models.append(model)
    prior = pool_fleet(models)
    names = [n for n, v in prior.task_spreads.items() if np.isfinite(v) and v > 0]

    def reference() -> None:
        naive.fleet_pair_shifts_naive(
            [[m.centre_.get(n, np.nan) for n in names] for m in models],
            [[m.within_.get(n, np.nan) for n in names] for m in models],
            [prior.task_spreads[n] for n in names],
            [_declared(n).sided == "up" for n in names],
        )

    repeats = 3 if quick else 7
    fast_s = _median_time(lambda: pool_fleet(models), repeats)
    reference_s = _median_time(reference, 1)  # the loop takes seconds at 500 axes
    return {
        "case": f"fleet prior: {n_axes} axes of one profile pooled",
        "fast_s": fast_s,
        "dense_s": reference_s,
        "ratio": reference_s / fast_s,
        "note": f"reference column = the {n_axes * (n_axes - 1):,} ordered pairs by a Python loop",
    }


CASES: dict[str, Callable[[bool], dict[str, Any]]] = {
    "mechanics-3s": case_mechanics,
    "lra-300": lambda q: case_lra(300, q),
    "lra-1000": lambda q: case_lra(1000, q),
    "lra-2000": lambda q: case_lra(2000, q),
    "lra-4000": lambda q: case_lra(4000, q),
    "lra-1000-robot": lambda q: case_lra(1000, q, "robot"),
    "lra-4000-robot": lambda q: case_lra(4000, q, "robot"),
    "capture-3s": lambda q: case_capture(3.0, q),
    "capture-60s": lambda q: case_capture(60.0, q),
    "job-3s-indicators": lambda q: case_job("indicators", q),
    "job-3s-indicators-profile": lambda q: case_job("indicators", q, profile=True),
    "job-3s-indicators-order-lines": lambda q: case_job("indicators", q, order_lines=True),
    "job-3s-indicators-modes-profile": lambda q: case_job(
        "indicators", q, profile=True, modes=True
    ),
    "job-3s-mechanics": lambda q: case_job("mechanics", q),
    "job-3s-lra": lambda q: case_job("lra", q),
    "job-3s-pca": lambda q: case_job("pca", q),
    "lra-60s-robot": case_lra_60s,
    "pool-500": lambda q: case_pool(500, q),
    "pool-2000": lambda q: case_pool(200 if q else 2000, q),
}


def run_case(name: str, quick: bool, robots: int, method: str) -> None:
    """Child process: run one case, print its result as one JSON line."""
    with tempfile.TemporaryDirectory() as folder:
        if name == "fleet":
            result = fleet.case_fleet_day(Path(folder), robots, method, check=robots <= 30)
        elif name == "history":
            result = fleet.case_history(Path(folder), robots, method)
        else:
            result = CASES[name](quick)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux
    if name in ("fleet", "history"):
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


def _child(name: str, quick: bool, robots: int, method: str) -> dict[str, Any]:
    env = {**os.environ, **ONE_THREAD}
    command = [sys.executable, __file__, "--case", name, "--fleet-robots", str(robots)]
    command += ["--fleet-method", method]
    if quick:
        command.append("--quick")
    child = subprocess.run(command, env=env, capture_output=True, text=True)
    if child.returncode:
        sys.exit(f"case {name} failed:\n{child.stderr}")
    return dict(json.loads(child.stdout.strip().splitlines()[-1]))


def _print_row(row: dict[str, Any]) -> None:
    dense = f"{row['dense_s']:9.3f}" if "dense_s" in row else f"{'-':>9}"
    ratio = f"{row['ratio']:7.1f}x" if "ratio" in row else f"{'-':>8}"
    note = row.get("note", "")
    if "delta_error" in row:
        note = (
            f"|delta_fast - delta_dense| = {row['delta_error']:.1e} "
            f"(delta {row['delta']:.4g}, target {row['tolerance']:.1e})"
        )
    if "ratio_to_floor" in row:
        note = (
            f"CPU {row['cpu_s']:.2f} s = {row['per_capture_ms']:.1f} ms per capture = "
            f"{row['ratio_to_floor']:.1f}x the floor ({row['floor_s'] * 1e3 / (row['robots'] * 6):.2f}"
            " ms CPU)"
        )
        if "identical_to_serial_uncached" in row:
            note += (
                f"; rows identical to a serial uncached run: {row['identical_to_serial_uncached']}"
            )
    print(f"{row['case']:<62} {row['fast_s']:9.3f} {dense} {ratio} {row['peak_mb']:8.0f}  {note}")
    sys.stdout.flush()


def _fleet_sizes(sizes: list[int], method: str) -> None:
    rows = [_child("fleet", False, robots, method) for robots in sizes]
    for row in rows:
        _print_row(row)
    if len(rows) >= 2:
        x = np.array([r["robots"] for r in rows], dtype=float)
        for label, key in (("wall", "fast_s"), ("CPU", "cpu_s")):
            y = np.array([r[key] for r in rows])
            slope, intercept = np.polyfit(x, y, 1)
            fitted = slope * x + intercept
            r2 = 1 - float(np.sum((y - fitted) ** 2) / np.sum((y - y.mean()) ** 2))
            worst = float(np.max(np.abs(y - fitted) / y))
            total = intercept + slope * 10_000
            print(
                f"linear fit of {label} time: {intercept:.2f} s + {slope * 1e3:.1f} ms x robots "
                f"(R^2 {r2:.4f}, largest relative residual {100 * worst:.1f} %); 10,000 robots: "
                f"{total / 60:.1f} min"
                + (f" of CPU = {total / 120:.1f} min on 2 cores" if label == "CPU" else "")
            )


def _memory(quick: bool) -> None:
    lengths = memory.QUICK_LENGTHS_S if quick else memory.LENGTHS_S
    print(f"{'capture':>10} {'rows':>11} {'file MB':>8} {'peak MB':>8} {'wall s':>7}  long capture")
    with tempfile.TemporaryDirectory() as folder:
        for row in memory.memory_curve(Path(folder), lengths):
            seconds = row["seconds"]
            length = f"{seconds:g} s" if seconds < 600 else f"{seconds / 60:g} min"
            others = "scored" if row["others_scored"] else "NOT scored"
            print(
                f"{length:>10} {row['rows']:>11,} {row['file_mb']:8.1f} {row['peak_mb']:8.0f} "
                f"{row['wall_s']:7.1f}  {row['long']}; the other axes' new captures {others}"
            )
            sys.stdout.flush()
        if not quick:
            row = memory.csv_row(Path(folder), 600.0)
            print(
                f"{'10 min CSV':>10} {'':>11} {row['file_mb']:8.1f} {row['peak_mb']:8.0f} "
                f"{'':>7}  {'scored' if row['scored'] else 'not scored'}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: small cases, seconds")
    parser.add_argument("--case", help=argparse.SUPPRESS)
    parser.add_argument(
        "--fleet-robots",
        default=None,
        help="robots in the fleet case, or a comma list for a linear fit (default 30)",
    )
    parser.add_argument(
        "--fleet-method",
        default=DEFAULT_METHOD,
        choices=["indicators", "mechanics", "lra", "pca"],
        help="monitor method of the fleet cases (default: the product default)",
    )
    parser.add_argument(
        "--history", help="days of kept files, comma list (e.g. 7,365): nothing-new runs"
    )
    parser.add_argument(
        "--workers-curve",
        action="store_true",
        help="time one fleet day on 1,2,4,8,16 processes and Dask workers; write a CSV",
    )
    parser.add_argument("--curve-robots", type=int, default=200, help="robots of the curve")
    parser.add_argument(
        "--curve-repeats", type=int, default=1, help="rounds of the curve, interleaved"
    )
    parser.add_argument("--csv", default="workers_curve.csv", help="CSV of --workers-curve")
    parser.add_argument(
        "--memory",
        action="store_true",
        help="peak memory of monitor against one capture's length (3 s to 4 h)",
    )
    args = parser.parse_args()
    if args.case:
        robots = int(args.fleet_robots or 2)
        run_case(args.case, args.quick, robots, args.fleet_method)
        return
    print(machine())
    if args.memory:
        _memory(args.quick)
        return
    if args.workers_curve:
        cpus = os.cpu_count() or 1
        counts = [n for n in (1, 2, 4, 8, 16) if n <= cpus]
        with tempfile.TemporaryDirectory() as folder:
            rows = fleet.workers_curve(
                Path(folder), args.curve_robots, counts, args.fleet_method, Path(args.csv),
                machine(), args.curve_repeats,
            )  # fmt: skip
        for row in rows:
            print(
                f"{row['backend']:<9} {row['workers']:>2}: {row['seconds']:8.2f} s "
                f"speed-up {row['speedup']:5.2f}x efficiency {row['efficiency']:.2f} "
                f"CPU of all processes {row['all_cpu_s']:7.2f} s; identical to the curve's "
                f"serial run {row['identical']}, to a serial uncached run "
                f"{row['identical_to_uncached_serial']}"
            )
        print(f"wrote {args.csv}")
        return
    print(f"{'case':<62} {'fast s':>9} {'ref s':>9} {'ratio':>8} {'peak MB':>8}  note")
    if args.history:
        for days in (int(d) for d in args.history.split(",")):
            _print_row(_child("history", False, days, args.fleet_method))
        return
    if args.fleet_robots and "," in args.fleet_robots:
        _fleet_sizes([int(r) for r in args.fleet_robots.split(",")], args.fleet_method)
        return
    robots = int(args.fleet_robots or (2 if args.quick else 30))
    names = (
        ["lra-300", "capture-3s", "mechanics-3s", "job-3s-indicators", "job-3s-mechanics", "fleet"]
        if args.quick
        else [*CASES, "fleet"]
    )
    for name in names:
        _print_row(_child(name, args.quick, robots, args.fleet_method))


if __name__ == "__main__":
    main()
