"""A supervised ceiling of fault detection on the transfer study's captures.

Research study (docs/evaluation.md, "A supervised ceiling"). The target asks every fault's AUROC
to reach 0.95 against healthy captures of other tasks; the default and even its own-task oracle
stay far below for backlash, tooth and bearing faults at the study's severity. Is there enough
in the captures to reach it at all? Per robot and fault, a classifier that is *told* which
captures are faulty is cross-validated on the captures of :mod:`axiswatch_lab._transfer`'s
paired design (the same seeds, :func:`capture_features`), and its out-of-fold AUROC is the
ceiling that no unsupervised monitor reading the same features is expected to beat:

* feature sets: ``readings``, the product's indicator readings (:class:`~axiswatch.Readings`
  on the scale the model compares them in, NaN where unavailable); ``spectral``, a generic set
  of the torque, log band powers of its Welch PSD in bands relative to the rate
  (:func:`spectral_features`) and the largest line of its order profile per quarter decade of
  order (:func:`order_bands`); ``readings+spectral``, both;
* classifiers (:func:`make_classifier`): a logistic regression on standardised features
  (median imputation) and a histogram gradient boosting (NaN handled natively), fixed seeds;
* comparisons: ``all tasks`` (faulty against healthy captures, any task: the out-of-fold
  AUROC), ``other tasks`` (the same out-of-fold scores ranked as the paired study ranks them:
  faulty captures of any task against healthy captures of the tasks other than the baseline's,
  averaged over the baselines), ``same task`` (a classifier per task, faulty against healthy of
  that task, averaged over the tasks: the oracle's analogue) and ``same task, pooled fit`` (the
  all-tasks scores ranked within each task).

The ``other tasks`` scores come from the classifier trained on every task: one trained without
the baseline task's healthy captures would learn "the baseline's task means faulty", a cue the
design hands it and no monitor has. Each capture is one row, and the folds are grouped by
capture (:func:`out_of_fold_scores`), so that no capture is in its own training set.

The ceiling is an estimate at a finite training size (``n_per_cell`` captures per task and
health, 5 folds): a classifier can miss a boundary that more data would show, and the largest of
several classifiers is slightly optimistic. Run on the development robots only; nothing here is
used by the product.
"""

from __future__ import annotations

import itertools
import math
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.signal import welch
from sklearn.base import ClassifierMixin
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.impute import SimpleImputer
from sklearn.inspection import permutation_importance
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import StratifiedGroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from threadpoolctl import threadpool_limits

from axiswatch import Capture, IndicatorModel
from axiswatch.datasets import FAULT_KINDS, Fault, SimulatedRobot, draw_robot
from axiswatch.monitor import parallel_map
from axiswatch_lab._product import CELLS_PER_DECADE, OrderProfile, _transformed
from axiswatch_lab._transfer import TransferDesign, _profile

__all__ = [
    "CLASSIFIERS",
    "COMPARISONS",
    "FEATURE_SETS",
    "CaptureFeatures",
    "capture_features",
    "ceiling_study",
    "ceiling_summary",
    "feature_matrix",
    "make_classifier",
    "order_bands",
    "out_of_fold_scores",
    "robot_ceiling",
    "spectral_features",
]

FEATURE_SETS: tuple[str, ...] = ("readings", "spectral", "readings+spectral")
CLASSIFIERS: tuple[str, ...] = ("logistic", "boosting")
COMPARISONS: tuple[str, ...] = ("other tasks", "all tasks", "same task", "same task, pooled fit")

#: Edges of the torque's bands in units of its rate: a band below 1/128 of the rate, then 14
#: bands log-spaced (a factor 1.48 each) up to the Nyquist frequency. Relative to the rate so
#: that the set means the same at 20 Hz and at 4 kHz.
RELATIVE_BAND_EDGES: tuple[float, ...] = (0.0, *np.geomspace(1 / 128, 1 / 2, 15).tolist())
#: Welch segment (samples; the capture's length when shorter): 1/256 of the rate per bin.
WELCH_SEGMENT = 256
#: Cells of the common order grid per order band: a quarter decade.
ORDER_BAND_CELLS = CELLS_PER_DECADE // 4
#: Folds of every cross-validation (fewer when a class has fewer captures).
N_SPLITS = 5
#: Permutations per feature and fold of the boosting's permutation importance.
N_REPEATS = 5


@dataclass(frozen=True)
class CaptureFeatures:
    """One test capture of the paired design and its two feature sets.

    Attributes
    ----------
    task : int
    health : str
        ``"healthy"`` or a fault kind.
    index : int
        The capture's number within its (task, health) cell (its seed is ``f"{health}{index}"``).
    readings : dict of str to float
        The product's readings on its comparison scale (decades for ratios), NaN if unavailable.
    spectral : dict of str to float
        :func:`spectral_features` and :func:`order_bands`.
    """

    task: int
    health: str
    index: int
    readings: dict[str, float]
    spectral: dict[str, float]


def spectral_features(torque: NDArray[np.float64], rate_hz: float) -> dict[str, float]:
    """``log10`` of the torque's power in each band of :data:`RELATIVE_BAND_EDGES` (x rate).

    The Welch PSD (Hann, :data:`WELCH_SEGMENT` samples, half overlap, mean removed) summed over
    the bins whose frequency falls in ``[low, high)`` (the top band includes the Nyquist bin),
    times the bin width; NaN where no bin falls in the band (a short capture's low bands).

    Parameters
    ----------
    torque : ndarray of shape (n_samples,)
    rate_hz : float

    Returns
    -------
    dict of str to float
        ``"psd[low-high]"`` (band edges as multiples of the rate) to ``log10`` power.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(2000) / 1000.0
    >>> bands = spectral_features(np.sin(2 * np.pi * 100.0 * t), 1000.0)  # 0.1 x rate
    >>> max(bands, key=bands.get)
    'psd[0.084-0.11]'
    """
    segment = min(WELCH_SEGMENT, torque.size)
    freqs, psd = welch(torque, fs=rate_hz, nperseg=segment)
    relative = freqs / rate_hz
    step = float(freqs[1] - freqs[0]) if freqs.size > 1 else math.nan
    out = {}
    edges = RELATIVE_BAND_EDGES
    for k, (low, high) in enumerate(itertools.pairwise(edges)):
        last = k == len(edges) - 2
        inside = (relative >= low) & ((relative <= high) if last else (relative < high))
        power = float(np.sum(psd[inside]) * step)
        out[f"psd[{low:.2g}-{high:.2g}]"] = (
            math.log10(power) if inside.any() and power > 0 else math.nan
        )
    return out


def order_bands(profile: OrderProfile | None) -> dict[str, float]:
    """The largest value of an order profile in each quarter decade of order it covers.

    Parameters
    ----------
    profile : OrderProfile or None
        :attr:`~axiswatch.Readings.order_profile` (``log10`` of power over floor per cell of
        the common order grid); None gives no bands.

    Returns
    -------
    dict of str to float
        ``"order[low-high]"`` to the band's largest finite cell value (NaN where none).

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch.indicators._order_lines import OrderProfile
    >>> profile = OrderProfile(first_cell=94, values=np.array([0.1, 0.9, np.nan, 0.3]))
    >>> order_bands(profile)  # cells 94-95 in [10 ** (84 / 48), 10 ** (96 / 48)), 96-97 above
    {'order[56-1e+02]': 0.9, 'order[1e+02-1.8e+02]': 0.3}
    """
    if profile is None:
        return {}
    band = np.floor_divide(profile.cells, ORDER_BAND_CELLS)
    out = {}
    for b in np.unique(band):
        values = profile.values[band == b]
        low = 10 ** (b * ORDER_BAND_CELLS / CELLS_PER_DECADE)
        high = 10 ** ((b + 1) * ORDER_BAND_CELLS / CELLS_PER_DECADE)
        finite = values[np.isfinite(values)]
        out[f"order[{low:.2g}-{high:.2g}]"] = float(finite.max()) if finite.size else math.nan
    return out


def capture_features(robot: SimulatedRobot, design: TransferDesign) -> list[CaptureFeatures]:
    """The paired design's test captures (:func:`~axiswatch_lab._transfer.paired_readings`'s
    seeds and severity; ``design.n_per_cell`` per task and health) and their feature sets.

    The readings are the model's with the design's profile (kinematics); the same read also
    takes the order profile (``order_lines=True`` adds it without changing the readings).
    """
    reader = IndicatorModel(_profile(robot, design.kinematics), order_lines=True)
    out = []
    for t in range(len(robot.tasks)):
        for health in ("healthy", *FAULT_KINDS):
            fault = None if health == "healthy" else Fault(health, design.severity)  # type: ignore[arg-type]
            for i in range(design.n_per_cell):
                capture: Capture = robot.capture(t, fault=fault, seed=f"{health}{i}")
                readings = reader.readings(capture)
                spectral = spectral_features(
                    capture.signals["torque"], capture.rates_hz["torque"]
                ) | order_bands(readings.order_profile)
                out.append(CaptureFeatures(t, health, i, _transformed(readings), spectral))
    return out


def feature_matrix(rows: Sequence[Mapping[str, float]]) -> tuple[NDArray[np.float64], list[str]]:
    """Rows of named features as a matrix over the union of names (first-seen order), NaN
    where a row lacks a name.

    Examples
    --------
    >>> matrix, names = feature_matrix([{"a": 1.0}, {"b": 2.0, "a": 3.0}])
    >>> names, matrix.tolist()
    (['a', 'b'], [[1.0, nan], [3.0, 2.0]])
    """
    names = list(dict.fromkeys(n for row in rows for n in row))
    matrix = np.array([[row.get(n, math.nan) for n in names] for row in rows], dtype=np.float64)
    return matrix.reshape(len(rows), len(names)), names


def make_classifier(name: str, seed: int = 0) -> ClassifierMixin:
    """``"logistic"``: median imputation, standardisation and an L2 logistic regression
    (``C = 1``); ``"boosting"``: a histogram gradient boosting sized for tens of rows (leaves
    of 5, 8 leaves a tree, 100 trees, no early stopping), NaN handled natively.

    Raises
    ------
    ValueError
        For another name.
    """
    if name == "logistic":
        return make_pipeline(
            SimpleImputer(strategy="median", keep_empty_features=True),
            StandardScaler(),
            LogisticRegression(C=1.0, max_iter=5000),
        )
    if name == "boosting":
        return HistGradientBoostingClassifier(
            max_iter=100,
            max_leaf_nodes=8,
            min_samples_leaf=5,
            early_stopping=False,
            random_state=seed,
        )
    raise ValueError(f"The classifier must be one of {list(CLASSIFIERS)}; got {name!r}.")


def out_of_fold_scores(
    features: NDArray[np.float64],
    labels: NDArray[np.int64],
    groups: NDArray[np.int64],
    classifier: str,
    *,
    n_splits: int = N_SPLITS,
    seed: int = 0,
) -> NDArray[np.float64]:
    """Every row's score (probability of label 1) from a classifier fitted on the other folds.

    Folds are stratified by label and grouped (``StratifiedGroupKFold``, shuffled with
    ``seed``): rows of one group are never in the training folds of their own score. The
    folds are ``min(n_splits, groups of the rarer label)``.

    Raises
    ------
    ValueError
        When a label has fewer than 2 groups.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.r_[np.zeros(10), np.ones(10)][:, None] + np.arange(20)[:, None] * 1e-3
    >>> y = np.r_[np.zeros(10), np.ones(10)].astype(np.int64)
    >>> scores = out_of_fold_scores(x, y, np.arange(20), "logistic")
    >>> bool(scores[y == 1].min() > scores[y == 0].max())
    True
    """
    per_label = [np.unique(groups[labels == v]).size for v in (0, 1)]
    folds = min(n_splits, *per_label)
    if folds < 2:
        raise ValueError(
            f"Out-of-fold scores need at least 2 groups of each label; got {per_label} "
            "(healthy, faulty)."
        )
    splitter = StratifiedGroupKFold(n_splits=folds, shuffle=True, random_state=seed)
    scores = np.full(labels.size, math.nan)
    for train, test in splitter.split(features, labels, groups):
        used = _varying(features[train])
        model = make_classifier(classifier, seed)
        model.fit(features[train][:, used], labels[train])
        scores[test] = model.predict_proba(features[test][:, used])[:, 1]
    return scores


def _varying(features: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Columns with two or more distinct finite values: a constant or unread column carries
    nothing, and the boosting's binning fails on a column of one value."""
    out = np.zeros(features.shape[1], dtype=bool)
    for j in range(features.shape[1]):
        column = features[:, j]
        out[j] = np.unique(column[np.isfinite(column)]).size >= 2
    return out


def _auroc(labels: NDArray[np.int64], scores: NDArray[np.float64]) -> float:
    if np.unique(labels).size < 2:
        return math.nan
    return float(roc_auc_score(labels, scores))


def _columns(rows: Sequence[CaptureFeatures], feature_set: str) -> list[dict[str, float]]:
    if feature_set == "readings":
        return [r.readings for r in rows]
    if feature_set == "spectral":
        return [r.spectral for r in rows]
    return [r.readings | r.spectral for r in rows]


def _top_features(
    features: NDArray[np.float64],
    labels: NDArray[np.int64],
    groups: NDArray[np.int64],
    names: list[str],
    n_top: int,
    n_repeats: int = N_REPEATS,
) -> list[tuple[str, str, float]]:
    """(method, feature, importance) of the ``n_top`` most important features by two methods:
    ``"logistic coef"``, the standardised logistic regression fitted on every row (signed:
    positive means higher in faulty captures); ``"boosting permutation"``, the mean fall of the
    out-of-fold AUROC when the feature is permuted in the test fold (``n_repeats`` repeats),
    averaged over the folds of :func:`out_of_fold_scores`."""
    used = _varying(features)
    kept = [n for n, u in zip(names, used, strict=True) if u]
    model = make_classifier("logistic")
    model.fit(features[:, used], labels)
    coef = model[-1].coef_[0]
    out = [("logistic coef", kept[k], float(coef[k])) for k in np.argsort(-np.abs(coef))[:n_top]]
    folds = min(N_SPLITS, *[np.unique(groups[labels == v]).size for v in (0, 1)])
    splitter = StratifiedGroupKFold(n_splits=folds, shuffle=True, random_state=0)
    drop = np.zeros(features.shape[1])
    for train, test in splitter.split(features, labels, groups):
        in_fold = _varying(features[train])
        booster = make_classifier("boosting")
        booster.fit(features[train][:, in_fold], labels[train])
        result = permutation_importance(
            booster,
            features[test][:, in_fold],
            labels[test],
            scoring="roc_auc",
            n_repeats=n_repeats,
            random_state=0,
        )
        drop[in_fold] += result.importances_mean / folds
    out += [("boosting permutation", names[k], float(drop[k])) for k in np.argsort(-drop)[:n_top]]
    return out


def robot_ceiling(
    seed: int,
    design: TransferDesign,
    *,
    classifiers: Sequence[str] = CLASSIFIERS,
    feature_sets: Sequence[str] = FEATURE_SETS,
    n_top: int = 5,
    permuted: bool = False,
    n_repeats: int = N_REPEATS,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The ceiling on one robot: out-of-fold AUROC per fault, feature set, classifier and
    comparison (see the module docstring), and the top features per fault and feature set.

    With ``permuted`` the health labels are shuffled within each task (seeded): the ceiling
    where there is nothing to find, which shows how optimistic the largest of the estimates is.
    ``n_repeats``: permutations per feature and fold of the permutation importance.

    Returns
    -------
    aurocs : DataFrame
        Columns robot, rate_hz, fault, feature_set, classifier, comparison, auroc.
    top : DataFrame
        Columns robot, fault, feature_set, method, rank, feature, importance: the ``n_top``
        most important features of the all-tasks fit by each method of
        :func:`_top_features` (none with ``n_top=0``, which saves the permutations' time).
    """
    robot = draw_robot(seed)
    taken = capture_features(robot, design)
    n_tasks = len(robot.tasks)
    rows: list[dict[str, object]] = []
    top: list[dict[str, object]] = []
    for fault in FAULT_KINDS:
        chosen = [r for r in taken if r.health in ("healthy", fault)]
        labels = np.array([r.health == fault for r in chosen], dtype=np.int64)
        tasks = np.array([r.task for r in chosen])
        if permuted:
            rng = np.random.default_rng(zlib.crc32(f"{seed}/{fault}".encode()))
            for t in range(n_tasks):
                labels[tasks == t] = rng.permutation(labels[tasks == t])
        groups = np.arange(len(chosen))  # a capture is one row and its own group
        for feature_set in feature_sets:
            features, names = feature_matrix(_columns(chosen, feature_set))
            for classifier in classifiers:
                scores = out_of_fold_scores(features, labels, groups, classifier, seed=0)
                other = [
                    _auroc(labels[keep], scores[keep])
                    for b in range(n_tasks)
                    for keep in [(labels == 1) | (tasks != b)]
                ]
                pooled = [_auroc(labels[tasks == t], scores[tasks == t]) for t in range(n_tasks)]
                own = []
                for t in range(n_tasks):
                    mask = tasks == t
                    own_scores = out_of_fold_scores(
                        features[mask], labels[mask], groups[mask], classifier, seed=0
                    )
                    own.append(_auroc(labels[mask], own_scores))
                values = {
                    "other tasks": float(np.nanmean(other)),
                    "all tasks": _auroc(labels, scores),
                    "same task": float(np.nanmean(own)),
                    "same task, pooled fit": float(np.nanmean(pooled)),
                }
                for comparison in COMPARISONS:
                    rows.append(
                        {
                            "robot": robot.name,
                            "rate_hz": robot.spec.fast_rate_hz,
                            "fault": fault,
                            "feature_set": feature_set,
                            "classifier": classifier,
                            "comparison": comparison,
                            "auroc": values[comparison],
                        }
                    )
            ranked = (
                _top_features(features, labels, groups, names, n_top, n_repeats) if n_top else []
            )
            for k, (method, name, importance) in enumerate(ranked):
                top.append(
                    {
                        "robot": robot.name,
                        "fault": fault,
                        "feature_set": feature_set,
                        "method": method,
                        "rank": k % n_top + 1,
                        "feature": name,
                        "importance": importance,
                    }
                )
    return pd.DataFrame(rows), pd.DataFrame(top)


def _one(args: tuple[int, TransferDesign, bool, int, int]) -> tuple[pd.DataFrame, pd.DataFrame]:
    seed, design, permuted, n_top, n_repeats = args
    with threadpool_limits(1):
        return robot_ceiling(seed, design, permuted=permuted, n_top=n_top, n_repeats=n_repeats)


def ceiling_study(
    seeds: Sequence[int],
    design: TransferDesign,
    *,
    workers: int = 1,
    permuted: bool = False,
    n_top: int = 5,
    n_repeats: int = N_REPEATS,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`robot_ceiling` on every seed (in ``workers`` processes), tables concatenated in
    the seeds' order."""
    done: dict[int, tuple[pd.DataFrame, pd.DataFrame]] = {}
    items = [(s, design, permuted, n_top, n_repeats) for s in seeds]
    for index, result in parallel_map(_one, items, workers=workers):
        done[index] = result
    ordered = [done[i] for i in sorted(done)]
    return (
        pd.concat([a for a, _ in ordered], ignore_index=True),
        pd.concat([t for _, t in ordered if len(t)], ignore_index=True)
        if n_top
        else pd.DataFrame(),
    )


def ceiling_summary(aurocs: pd.DataFrame, target: float = 0.95) -> pd.DataFrame:
    """Per fault and comparison: the mean over robots of each feature set's best classifier,
    and of the ceiling (the best feature set and classifier per robot), with the robots whose
    ceiling reaches ``target``.

    Examples
    --------
    >>> import pandas as pd
    >>> aurocs = pd.DataFrame({"robot": ["r0", "r0", "r1", "r1"], "fault": "tooth",
    ...     "feature_set": ["readings", "spectral"] * 2, "classifier": "logistic",
    ...     "comparison": "all tasks", "auroc": [0.6, 0.97, 0.5, 0.7]})
    >>> row = ceiling_summary(aurocs).iloc[0]
    >>> float(row["ceiling"]), int(row["robots_at_target"]), float(row["readings"])
    (0.835, 1, 0.55)
    """
    keys = ["robot", "fault", "comparison"]
    per_set = aurocs.groupby([*keys, "feature_set"]).auroc.max().unstack("feature_set")
    ceiling = per_set.max(axis=1).rename("ceiling")
    table = per_set.join(ceiling).reset_index()
    out = table.groupby(["fault", "comparison"]).mean(numeric_only=True)
    out["robots_at_target"] = (
        (table.ceiling >= target).groupby([table.fault, table.comparison]).sum()
    )
    out["robots"] = table.groupby(["fault", "comparison"]).robot.nunique()
    return out.reset_index()
