"""Why an alarm fired: the share of a capture's distance carried by each channel and band.

It is exact for PCA (paper, "Detection"), by occlusion for every other detector.
The decomposition is in docs/internals.md, "Attribution".
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import check_is_fitted

from axiswatch._likely_faults import LIKELY_FAULTS, describe_top_indicator
from axiswatch.paper._detectors import BaselineDetector, PCADetector
from axiswatch.paper._features import Features

__all__ = [
    "LIKELY_FAULTS",
    "attribute",
    "describe_top_indicator",
    "difference_spectrogram",
    "pca_contributions",
    "plot_difference_spectrogram",
]


def pca_contributions(
    baseline: NDArray[np.float64], test: NDArray[np.float64], components: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Exact per-column contributions to the PCA distance; they sum to the distance.

    Parameters
    ----------
    baseline : ndarray of shape (n_rows, n_features)
    test : ndarray of shape (n_rows, n_features)
        Rows paired with the baseline's by index.
    components : ndarray of shape (n_features, n_components)
        ``P``, orthonormal columns.

    Returns
    -------
    ndarray of shape (n_features,)
        ``c_j = sum_rows D_j (D P P^T)_j`` with ``D = baseline - test``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> P = np.linalg.qr(rng.normal(size=(5, 2)))[0]
    >>> Xs, Xt = rng.normal(size=(2, 30, 5))
    >>> c = pca_contributions(Xs, Xt, P)
    >>> bool(np.isclose(c.sum(), np.sum(((Xs - Xt) @ P) ** 2)))
    True
    """
    difference = np.asarray(baseline, np.float64) - np.asarray(test, np.float64)
    projected = (difference @ components) @ components.T
    return np.asarray(np.sum(difference * projected, axis=0))


def _bands(n_bins: int, n_bands: int) -> list[NDArray[np.intp]]:
    if not (isinstance(n_bands, int | np.integer) and 1 <= n_bands <= n_bins):
        raise ValueError(
            f"The 'n_bands' parameter must be an int in the range [1, {n_bins}] (the number of "
            f"frequency bins). Got {n_bands!r} instead."
        )
    return [np.asarray(b, dtype=np.intp) for b in np.array_split(np.arange(n_bins), n_bands)]


def _check_pair(baseline: Features, test: Features) -> None:
    baseline_hz, test_hz = baseline.spectral_frequencies_hz(), test.spectral_frequencies_hz()
    if baseline.channels != test.channels or not np.array_equal(baseline_hz, test_hz):
        raise ValueError(
            f"baseline and test features must have the same channels and frequencies; got "
            f"channels {list(baseline.channels)} ({baseline_hz.size} bins) and "
            f"{list(test.channels)} ({test_hz.size} bins)."
        )


def attribute(
    detector: BaselineDetector, baseline: Features, test: Features, *, n_bands: int = 8
) -> pd.DataFrame:
    """Share of the test capture's distance carried by each channel and frequency band.

    Parameters
    ----------
    detector : BaselineDetector
        Fitted on ``baseline.X`` (an unfitted one is cloned and fitted on it).
    baseline, test : Features
        Same channels and frequencies.
    n_bands : int, default=8
        Contiguous bands per channel, of (nearly) equal numbers of bins.

    Returns
    -------
    DataFrame
        Columns ``channel``, ``band_lo_hz``, ``band_hi_hz`` (centre frequencies of the band's first
        and last bins), ``share``; one row per cell, largest share first. ``attrs`` holds
        ``method`` (``"exact"`` or ``"occlusion"``) and ``distance``.

    Raises
    ------
    ValueError
        Features of different channels or frequencies; ``n_bands`` not in ``[1, n_bins]``.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import FeatureSpec, PCADetector
    >>> from axiswatch.paper._features import features_from_signals
    >>> rng = np.random.default_rng(0)
    >>> spec = FeatureSpec(signals=("a", "b"), combinations="none", segment_length=16, hop=8)
    >>> quiet = features_from_signals(rng.normal(size=(800, 2)), 100.0, spec)
    >>> loud = rng.normal(size=(800, 2))
    >>> loud[:, 1] += np.sin(2 * np.pi * 40 * np.arange(800) / 100.0)
    >>> table = attribute(PCADetector(), quiet, features_from_signals(loud, 100.0, spec), n_bands=3)
    >>> top = table.iloc[0]
    >>> top.channel, float(top.band_lo_hz), float(top.band_hi_hz), table.attrs["method"]
    ('b', 37.5, 50.0, 'exact')
    >>> round(float(table.share.sum()), 12)
    1.0
    """
    _check_pair(baseline, test)
    n_bins = baseline.spectral_frequencies_hz().size
    bands = _bands(n_bins, n_bands)
    try:
        check_is_fitted(detector)
    except NotFittedError:
        detector = clone(detector).fit(baseline.X)
    total = float(detector.distance(test.X))
    n = min(baseline.X.shape[0], test.X.shape[0])
    cells: list[tuple[str, NDArray[np.intp]]] = [
        (channel, k * n_bins + band) for k, channel in enumerate(test.channels) for band in bands
    ]
    if isinstance(detector, PCADetector):
        method = "exact"
        per_column = pca_contributions(baseline.X[:n], test.X[:n], detector.components_)
        contributions = np.array([per_column[columns].sum() for _, columns in cells])
    else:
        method = "occlusion"
        # Baseline rows standing in for the test's: the leading ones, repeated if the baseline is
        # shorter than the test (detectors that do not pair rows see every test row).
        stand_in = baseline.X[np.arange(test.X.shape[0]) % baseline.X.shape[0]]
        contributions = np.empty(len(cells))
        for i, (_, columns) in enumerate(cells):
            occluded = test.X.copy()
            occluded[:, columns] = stand_in[:, columns]
            contributions[i] = total - float(detector.distance(occluded))
    shares = contributions / total if total > 0 else np.zeros(len(cells))
    frequencies = baseline.spectral_frequencies_hz()
    table = pd.DataFrame(
        {
            "channel": [channel for channel, _ in cells],
            "band_lo_hz": [float(frequencies[band[0]]) for _ in test.channels for band in bands],
            "band_hi_hz": [float(frequencies[band[-1]]) for _ in test.channels for band in bands],
            "share": shares,
        }
    )
    table = table.sort_values("share", ascending=False, kind="stable").reset_index(drop=True)
    table.attrs.update(method=method, distance=total)
    return table


def difference_spectrogram(baseline: Features, test: Features) -> NDArray[np.float64]:
    """|STFT| of the test minus the baseline's, per channel, rows paired by index.

    Returns
    -------
    ndarray of shape (n_channels, n_rows, n_bins)
        ``n_rows = min(baseline rows, test rows)``.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Features
    >>> f = lambda v: Features(np.full((3, 4), v), ("a", "b"), np.arange(2.0), 10.0)
    >>> difference_spectrogram(f(1.0), f(3.0)).shape, float(difference_spectrogram(f(1.0), f(3.0))[1, 2, 1])
    ((2, 3, 2), 2.0)
    """
    _check_pair(baseline, test)
    n = min(baseline.X.shape[0], test.X.shape[0])
    n_channels, n_bins = len(test.channels), test.spectral_frequencies_hz().size
    difference = test.X[:n] - baseline.X[:n]
    return np.asarray(difference.reshape(n, n_channels, n_bins).transpose(1, 0, 2))


def plot_difference_spectrogram(
    baseline: Features, test: Features, *, hop_s: float | None = None, ax: Any = None
) -> Any:
    """Draw :func:`difference_spectrogram`: time across, channels stacked by frequency.

    Parameters
    ----------
    baseline, test : Features
    hop_s : float, optional
        Seconds between rows (``hop / rate``), for the time axis; default: row numbers.
    ax : matplotlib Axes, optional
        Default: a new figure (Agg backend).

    Returns
    -------
    matplotlib Axes
    """
    from axiswatch._plotting import new_axes

    cube = difference_spectrogram(baseline, test)
    if ax is None:
        ax = new_axes(figsize=(7, 1.2 + 1.1 * cube.shape[0]))
    n_channels, n_rows, n_bins = cube.shape
    image = np.concatenate([cube[k].T for k in range(n_channels)], axis=0)
    limit = float(np.max(np.abs(image))) or 1.0
    width = n_rows * (hop_s if hop_s else 1.0)
    mesh = ax.imshow(
        image,
        aspect="auto",
        origin="lower",
        cmap="RdBu_r",
        vmin=-limit,
        vmax=limit,
        extent=(0.0, width, 0.0, float(n_channels * n_bins)),
        interpolation="nearest",
    )
    top = float(test.spectral_frequencies_hz()[-1])
    ax.set_yticks([(k + 0.5) * n_bins for k in range(n_channels)])
    ax.set_yticklabels([f"{c}\n0-{top:.3g} Hz" for c in test.channels], fontsize=7)
    for k in range(1, n_channels):
        ax.axhline(k * n_bins, color="k", lw=0.6)
    ax.set_xlabel("time (s)" if hop_s else "row (STFT slice)")
    ax.set_title("|STFT| test - baseline", fontsize=9)
    ax.figure.colorbar(mesh, ax=ax, fraction=0.03, pad=0.01)
    return ax
