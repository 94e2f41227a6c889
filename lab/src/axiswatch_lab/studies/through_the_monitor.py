"""The ``indicators`` and ``mechanics`` methods through the monitor, on data never tuned on.

Research study ("Through the monitor", docs/evaluation.md). Every fleet folder is
written in the project's capture format into a scratch folder and scored by
:func:`axiswatch.monitor.monitor_fleet` exactly as ``axiswatch monitor --method M`` would (one
worker, an in-memory store); nothing of the methods is chosen here.

* **Held-out robots** (``draw_robot``, seeds 1000-1011; the development robots 0-7 when given,
  to check a choice through the monitor): per robot model a fleet of 4 axes named by
  one profile (``robot.toml``, so the indicators' fleet prior pools the robot's own axes), axis
  ``a`` on task ``a`` (``indicators-own``: the same with a profile per axis, so no fleet prior:
  each axis's own spreads only). *Healthy* run: baseline and 5 calibration captures, then 4 captures of the
  same task, 4 of task ``(a + 1) mod 5`` and 4 of task ``(a + 2) mod 5`` (two task changes): every
  capture over the threshold is a false alarm. *Fault* run: after calibration, 8 captures of the
  own task, axis 0's with a friction fault of severity 0.6 (the robot's own friction law):
  detection is the share of those over the threshold; the other axes' count as false alarms.
  With ``--faults`` (``monitor_robot(..., faults=)``) one such run per fault kind (backlash,
  tooth, bearing at the same severity; scenario ``fault:<kind>``).
* **Real data** (``../shared/data``): the four hydraulic actuators as one fleet (act3 has gear
  damage from its first record, so the monitor can only note it against the fleet); the linear
  axis's two sessions as two axes, the normal session followed by the impaired-drive windows.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import pandas as pd

from axiswatch import Capture, write_capture
from axiswatch.datasets import Fault, draw_robot
from axiswatch.monitor import MonitorConfig, SQLiteStore, monitor_fleet
from axiswatch_lab._product import TASK_ENVELOPE_FACTOR

__all__ = ["HELD_OUT", "monitor_real_data", "monitor_robot"]

HELD_OUT: tuple[int, ...] = tuple(range(1000, 1012))
#: The runs of each fleet: the method, the method with its task envelope, the method without a
#: fleet prior, the product default.
VARIANTS: tuple[str, ...] = ("indicators", "indicators-envelope", "indicators-own", "mechanics")
_AXES = 4
_CALIBRATION = 6  # the baseline and K = 5


def _write(capture: Capture, root: Path, robot: str, axis: str, index: int) -> None:
    folder = root / robot / axis
    folder.mkdir(parents=True, exist_ok=True)
    day = pd.Timestamp("2026-01-01") + pd.Timedelta(days=index)
    write_capture(capture, folder / f"{day:%Y-%m-%d}.parquet")


def _config(variant: str) -> MonitorConfig:
    """``indicators-envelope``: the method with the task envelope chosen on the development
    robots; ``indicators-order-lines``: with its order-lines option; ``indicators-modes``: with
    its mode libraries; ``indicators-own`` is the method itself (the profiles make the
    difference)."""
    if variant == "indicators-envelope":
        return MonitorConfig(method="indicators", task_envelope=TASK_ENVELOPE_FACTOR)
    if variant == "indicators-order-lines":
        return MonitorConfig(method="indicators", order_lines=True)
    if variant == "indicators-modes":
        return MonitorConfig(method="indicators", modes=True)
    return MonitorConfig(method=variant.split("-")[0])


def _run(root: Path, variant: str) -> tuple[pd.DataFrame, list[str], str]:
    """Scores of a fresh store, the rejections, and why the run stopped."""
    with tempfile.TemporaryDirectory() as folder, SQLiteStore(Path(folder) / "s.db") as store:
        try:
            summary = monitor_fleet(root, store, _config(variant), settle_s=0)
        except ValueError as exc:  # a configuration the method cannot take: the run stops
            return pd.DataFrame(), [], str(exc).splitlines()[0]
        return store.score_table(), summary.rejected, ""


def _monitored(scores: pd.DataFrame) -> pd.Series:
    """The captures after each axis's baseline and calibration: the same captures for every
    method (with modes, the calibration captures are scored too, as a new mode's)."""
    order = scores.sort_values("captured_at", kind="stable").groupby(["robot", "axis"]).cumcount()
    return (order.reindex(scores.index) >= _CALIBRATION) & scores["role"].isin(
        ["monitor", "calibration"]
    )


def _rates(scores: pd.DataFrame, selected: pd.Series) -> tuple[int, int]:
    """Captures among ``selected`` and :func:`_monitored` over the threshold, and how many
    there are."""
    if scores.empty:
        return 0, 0
    monitored = scores[_monitored(scores) & selected]
    return int(monitored["over"].astype(bool).sum()), len(monitored)


def _auroc(scores: pd.DataFrame, faulty: pd.Series) -> float:
    """AUROC of the :func:`_monitored` captures' distances (the threshold's units), ``faulty``
    against the others; a capture without a distance counts 0, as in the library's cases."""
    from sklearn.metrics import roc_auc_score

    monitored = _monitored(scores)
    labels = faulty[monitored].astype(int)
    if labels.nunique() < 2:
        return float("nan")
    return float(roc_auc_score(labels, scores.loc[monitored, "distance"].fillna(0.0)))


def monitor_robot(
    seed: int,
    scratch: Path,
    variants: tuple[str, ...] = VARIANTS,
    faults: tuple[str, ...] = ("friction",),
) -> list[dict[str, object]]:
    """Healthy and fault runs of one robot model, for each of ``variants``: one fault run per
    kind of ``faults`` (scenario ``"fault"`` for the friction fault, ``"fault:<kind>"`` for
    another)."""
    robot = draw_robot(seed)
    rows: list[dict[str, object]] = []
    scenarios = ["healthy", *("fault" if k == "friction" else f"fault:{k}" for k in faults)]
    for scenario in scenarios:
        kind = "friction" if scenario == "fault" else scenario.partition(":")[2]
        root = scratch / f"{robot.name}-{scenario}"
        (root / robot.name).mkdir(parents=True)
        (root / robot.name / "robot.toml").write_text(f'name = "{robot.name}"\n')
        for a in range(_AXES):
            for day in range(_CALIBRATION + (12 if scenario == "healthy" else 8)):
                task, fault = a, None
                if scenario == "healthy" and day >= _CALIBRATION + 4:
                    task = (a + 1 + (day - _CALIBRATION - 4) // 4) % 5
                if scenario != "healthy" and a == 0 and day >= _CALIBRATION:
                    fault = Fault(kind, 0.6)  # type: ignore[arg-type]
                capture = robot.capture(task, fault=fault, seed=f"{scenario}/{a}/{day}")
                _write(capture, root, robot.name, f"a{a}", day)
        n_files = sum(1 for _ in root.rglob("*.parquet"))
        for variant in variants:
            # "own": a profile per axis, so that no fleet is pooled (the axis's own spreads).
            for a in range(_AXES):
                own = root / robot.name / f"a{a}" / "axis.toml"
                if variant.endswith("own"):
                    own.write_text(f'name = "{robot.name}-a{a}"\n')
                else:
                    own.unlink(missing_ok=True)
            scores, rejected, stopped = _run(root, variant)
            axes = scores["axis"] if not scores.empty else pd.Series(dtype=str)
            faulty = scenario != "healthy"
            over, n = _rates(scores, axes != ("a0" if faulty else ""))
            row: dict[str, object] = {
                "robot": robot.name,
                "rate_hz": robot.spec.fast_rate_hz,
                "scenario": scenario,
                "method": variant,
                "files": n_files,
                "scored": 0 if scores.empty else int(scores["distance"].notna().sum()),
                "baselines": 0 if scores.empty else int((scores["role"] == "baseline").sum()),
                "rejected": len(rejected),
                "rejected_stuck": sum("flat/stuck" in line for line in rejected),
                "false_alarms": over,
                "healthy_monitored": n,
                "stopped": stopped,
            }
            if faulty:
                hit, m = _rates(scores, axes == "a0")
                row.update(detected=hit, faulty_monitored=m)
            rows.append(row)
        shutil.rmtree(root)
    return rows


def monitor_real_data(
    data_root: Path, scratch: Path, variants: tuple[str, ...] = VARIANTS
) -> list[dict[str, object]]:
    """The hydraulic actuators and the linear axis, for each method of ``variants`` (absent sets
    skipped; ``indicators-own`` is not run on them)."""
    from axiswatch_lab._transfer import hydraulic_captures, linear_axis_captures

    rows: list[dict[str, object]] = []
    folders: dict[str, tuple[Path, set[str]]] = {}
    hydraulic = data_root / "hydraulic_actuator"
    if hydraulic.is_dir():
        root = scratch / "hydraulic"
        index = pd.read_csv(hydraulic / "index.csv")
        starts = dict(zip(index["recording_id"], index["record_start"], strict=True))
        faulty = set()
        for actuator, health, capture in hydraulic_captures(hydraulic):
            folder = root / "hydraulic" / actuator
            folder.mkdir(parents=True, exist_ok=True)
            stamp = str(starts[capture.source]).replace(":", "-")
            write_capture(capture, folder / f"{stamp}.parquet")
            if health != "healthy":
                faulty.add(actuator)
        folders["hydraulic_actuator"] = (root, faulty)
    linear = data_root / "genesis_linear_axis"
    if linear.is_dir():
        root = scratch / "linear"
        windows = linear_axis_captures(linear)
        series = {
            "normal": windows["normal"] + windows["lineardrive_impaired"],
            "session2016": windows["session2016_jam_labels"],
        }
        for axis, captures in series.items():
            for k, capture in enumerate(captures):
                _write(capture, root, "linear", axis, k)
        folders["genesis_linear_axis"] = (root, set())
        impaired_from = len(windows["normal"])
    for name, (root, faulty) in folders.items():
        n_files = sum(1 for _ in root.rglob("*.parquet"))
        for method in [v for v in variants if v != "indicators-own"]:
            scores, rejected, stopped = _run(root, method)
            row: dict[str, object] = {
                "dataset": name,
                "method": method,
                "files": n_files,
                "scored": 0 if scores.empty else int(scores["distance"].notna().sum()),
                "baselines": 0 if scores.empty else int((scores["role"] == "baseline").sum()),
                "rejected": len(rejected),
                "rejected_stuck": sum("flat/stuck" in line for line in rejected),
                "stopped": stopped,
            }
            if not scores.empty and name == "genesis_linear_axis":
                order = scores.groupby("axis").cumcount()
                impaired = (scores["axis"] == "normal") & (order >= impaired_from)
                row["false_alarms"], row["healthy_monitored"] = _rates(scores, ~impaired)
                row["detected"], row["faulty_monitored"] = _rates(scores, impaired)
                row["auroc"] = _auroc(scores, impaired)
            elif not scores.empty:
                unit_faulty = scores["axis"].isin(faulty)
                row["false_alarms"], row["healthy_monitored"] = _rates(scores, ~unit_faulty)
                row["faulty_axis_over"], row["faulty_monitored"] = _rates(scores, unit_faulty)
                row["auroc"] = _auroc(scores, unit_faulty)
                baselines = scores[(scores["role"] == "baseline") & unit_faulty]
                row["faulty_axis_notes"] = " | ".join(
                    "; ".join(json.loads(d)["indicator_model"]["notes"])
                    for d in baselines["details"]
                    if "indicator_model" in json.loads(d)
                )
            rows.append(row)
    return rows


def main(
    out: Path,
    data_root: Path,
    seeds: tuple[int, ...] = HELD_OUT,
    variants: tuple[str, ...] = VARIANTS,
    faults: tuple[str, ...] = ("friction",),
) -> None:
    """Write ``robots.csv`` and ``real.csv`` under ``out`` (no real data for a ``data_root``
    that does not exist)."""
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        robots = [
            row for seed in seeds for row in monitor_robot(seed, Path(scratch), variants, faults)
        ]
        pd.DataFrame(robots).to_csv(out / "robots.csv", index=False)
        real = monitor_real_data(data_root, Path(scratch), variants)
        pd.DataFrame(real).to_csv(out / "real.csv", index=False)
    print(pd.DataFrame(robots).to_string())
    print(pd.DataFrame(real).to_string())


if __name__ == "__main__":
    # python -m axiswatch_lab.studies.through_the_monitor OUT DATA_ROOT [--variants=A,B] [--faults=K,L]
    #     [SEED ...]
    import sys

    arguments = sys.argv[3:]
    options = {"--variants": ",".join(VARIANTS), "--faults": "friction"}
    while arguments and arguments[0].split("=", 1)[0] in options:
        name, _, value = arguments.pop(0).partition("=")
        options[name] = value
    main(
        Path(sys.argv[1]),
        Path(sys.argv[2]),
        tuple(int(s) for s in arguments) or HELD_OUT,
        tuple(options["--variants"].split(",")),
        tuple(options["--faults"].split(",")),
    )
