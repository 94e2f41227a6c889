"""Figures of the research experiments (matplotlib imported lazily): ROC, robot studies, paired.

Each function takes its table and an optional ``ax`` (or axes), and never calls ``plt.show``.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

__all__ = ["new_axes", "plot_paired", "plot_roc", "plot_robot_study"]


def new_axes(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **kwargs: Any) -> Any:
    """A new matplotlib figure's axes (``Figure.subplots``), without pyplot.

    The figure belongs to no pyplot window manager: it needs no ``close``.

    Examples
    --------
    >>> axes = new_axes(1, 2, figsize=(4.0, 2.0), squeeze=False)
    >>> axes.shape, type(axes[0, 0].figure).__name__
    ((1, 2), 'Figure')
    """
    from matplotlib.figure import Figure

    return Figure(figsize=figsize).subplots(nrows, ncols, **kwargs)


def plot_roc(table: pd.DataFrame, ax: Any = None) -> Any:
    """ROC points (FPR, TPR) of every method and protocol of :func:`~axiswatch_lab._experiments.lab_roc`.

    Examples
    --------
    >>> table = pd.DataFrame({"method": ["lra"] * 2, "protocol": ["same_run"] * 2,
    ...                       "percentile": [50.0, 99.0], "fpr": [0.4, 0.0], "tpr": [1.0, 1.0],
    ...                       "auroc": [1.0, 1.0]})
    >>> plot_roc(table).axes[0].get_xlabel()
    'false positive rate'
    """
    if ax is None:
        ax = new_axes(figsize=(6, 5))
    markers = dict(zip(sorted(table.protocol.unique()), "osD^v<>", strict=False))
    colours = {"lra": "tab:blue", "pca": "tab:red"}
    for (method, protocol), group in table.groupby(["method", "protocol"], sort=False):
        ordered = group.sort_values("percentile", ascending=False)
        ax.plot(
            ordered.fpr,
            ordered.tpr,
            marker=markers[protocol],
            color=colours.get(str(method)),
            label=f"{method}, {protocol} (AUROC {ordered.auroc.iloc[0]:.2f})",
            alpha=0.8,
        )
    ax.plot([0, 1], [0, 1], color="grey", linestyle=":", label="chance")
    ax.set(xlabel="false positive rate", ylabel="true positive rate", xlim=(-0.02, 1.02))
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize="x-small")
    ax.set_title("Lab dataset: ROC at the half-Laplace percentiles")
    return ax.figure


def plot_robot_study(table: pd.DataFrame, title: str, axes: Any = None) -> Any:
    """delta(t) of each method side by side (paper figs. 3-4), with and without phase alignment.

    Examples
    --------
    >>> table = pd.DataFrame({"day": [2, 3] * 2, "task": ["a", "b"] * 2,
    ...                       "method": ["lra", "lra", "pca", "pca"], "alignment": ["none"] * 4,
    ...                       "distance": [0.1, 0.2, 1.0, 3.0]})
    >>> len(plot_robot_study(table, "demo").axes)
    2
    """
    methods = list(dict.fromkeys(table.method))
    if axes is None:
        axes = new_axes(1, len(methods), figsize=(6 * len(methods), 4), squeeze=False)
        axes = axes[0]
    changes = table.drop_duplicates("day").sort_values("day")
    change_days = changes.day[
        changes.task.ne(changes.task.shift()) & (changes.day > changes.day.min())
    ]
    for ax, method in zip(axes, methods, strict=True):
        for alignment, group in table[table.method == method].groupby("alignment"):
            ax.plot(
                group.day,
                group.distance,
                marker=".",
                linewidth=0.8,
                label=f"alignment: {alignment}",
            )
        for day in change_days:
            ax.axvline(day, color="grey", linestyle="--", linewidth=0.8)
        ax.set(xlabel="day", ylabel="distance delta(t)", title=f"{title}: {method}")
        ax.legend(fontsize="small")
    return axes[0].figure


def plot_paired(table: Any, ax: Any = None) -> Any:
    """AUROC against the oracle's, one point per feature stage x method x fault.

    Points on the diagonal reach the oracle (a detector fitted on the test capture's own task);
    below 0.5 a healthy capture of another task looks sicker than a faulty one.

    Parameters
    ----------
    table : DataFrame
        Output of :func:`axiswatch_lab._paired.paired_evaluation`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib

    if ax is None:
        ax = new_axes(figsize=(6.5, 5.5))
    figure = ax.figure
    markers = {"pca": "o", "lra": "s"}
    colours = dict(
        zip(
            sorted(table.features.unique()),
            matplotlib.rcParams["axes.prop_cycle"].by_key()["color"],
            strict=False,
        )
    )
    for (features, method), group in table.groupby(["features", "method"]):
        ax.scatter(
            group.oracle_auroc,
            group.auroc,
            marker=markers.get(method, "^"),
            color=colours[features],
            label=f"{features} / {method}",
        )
        for row in group.itertuples():
            ax.annotate(
                row.fault[:2],
                (row.oracle_auroc, row.auroc),
                fontsize=7,
                xytext=(3, 2),
                textcoords="offset points",
            )
    ax.plot([0, 1], [0, 1], color="grey", linewidth=0.8)
    ax.axhline(0.5, color="grey", linestyle=":", linewidth=0.8)
    ax.set(
        xlim=(0, 1.02),
        ylim=(0, 1.02),
        xlabel="oracle AUROC (fitted on the test task)",
        ylabel="AUROC: faulty vs healthy other task",
    )
    ax.legend(fontsize=7, loc="lower right")
    return figure
