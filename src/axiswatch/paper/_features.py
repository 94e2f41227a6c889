"""|STFT| features of a capture (paper, section "Feature Extraction").

A row is one STFT time slice. Columns are every bin of every channel, channel by channel. A
"combination" is the sample-wise product of two signals (docs/paper-notes.md).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from axiswatch._capture import Capture
from axiswatch.exceptions import CaptureError
from axiswatch.paper._preprocessing import resample_capture

__all__ = [
    "FeatureSpec",
    "Features",
    "extract_features",
    "features_from_signals",
    "stft_features",
]

Padding = Literal["circular", "zeros", "valid"]

#: Frame values windowed and transformed at a time (2 MB of float64): bounds the temporaries of a
#: long capture at hop=1, where the frames overlap ``segment_length`` times, and stays in cache.
_BLOCK_VALUES = 1 << 18
Scaling = Literal["magnitude", "psd", "none"]


def _combined_channels(
    signals: NDArray[np.float64],
    names: Sequence[str],
    combinations: Literal["products", "none"] | Sequence[tuple[str, str]],
) -> tuple[NDArray[np.float64], list[str]]:
    if isinstance(combinations, str):
        if combinations == "none":
            pairs: list[tuple[str, str]] = []
        elif combinations == "products":
            pairs = list(itertools.combinations(names, 2))
        else:
            raise ValueError(
                "The 'combinations' parameter must be 'products', 'none' or a sequence of "
                f"(name, name) pairs. Got {combinations!r} instead."
            )
    else:
        pairs = [tuple(p) for p in combinations]  # type: ignore[misc]
    index = {name: j for j, name in enumerate(names)}
    extra, labels = [], []
    for pair in pairs:
        if len(pair) != 2 or any(p not in index for p in pair):
            raise ValueError(f"Combination {pair!r} must name two of the channels {list(names)}.")
        a, b = pair
        extra.append(signals[:, index[a]] * signals[:, index[b]])
        labels.append(f"{a}*{b}")
    if extra:
        return np.column_stack([signals, *extra]), [*names, *labels]
    return signals, list(names)


def stft_features(
    signals: NDArray[np.float64],
    rate_hz: float,
    *,
    segment_length: int = 128,
    hop: int = 1,
    window: str = "hann",
    padding: Padding = "circular",
    scaling: Scaling = "magnitude",
    max_rows: int | None = None,
) -> NDArray[np.float64]:
    """|STFT| of every channel, one row per time slice, channels side by side.

    Parameters
    ----------
    signals : ndarray of shape (n_samples, n_channels)
        Channels on one common rate.
    rate_hz : float
        That rate.
    segment_length : int, default=128
        Window length in samples; ``segment_length // 2 + 1`` frequency bins per channel.
    hop : int, default=1
        Samples between slices. ``hop=1`` gives one row per sample, as in the paper.
    window : str, default="hann"
        Any name :func:`scipy.signal.get_window` knows.
    padding : {"circular", "zeros", "valid"}, default="circular"
        Edge handling. ``"circular"`` wraps the capture around (a row per sample, no artificial
        edge: right for captures holding whole task cycles); ``"zeros"`` pads with zeros (a row
        per sample, but edge rows see a step to zero that LRA treats as structure); ``"valid"``
        keeps only windows fully inside the capture (``n_samples - segment_length + 1`` rows
        at ``hop=1``).
    scaling : {"magnitude", "psd", "none"}, default="magnitude"
        Window scaling, as :class:`scipy.signal.ShortTimeFFT`'s ``scale_to`` (``"magnitude"``
        divides by ``sum(w)``, ``"psd"`` by ``sqrt(rate_hz * sum(w**2))``); ``"magnitude"`` makes a
        unit sine give a peak of 0.5 whatever the window length, which keeps the LRA noise level
        ``lambda`` meaningful across settings.
    max_rows : int, optional
        Compute only the first ``max_rows`` rows (the same values as the whole matrix's).

    Returns
    -------
    ndarray of shape (n_rows, n_channels * (segment_length // 2 + 1))

    Notes
    -----
    Channel by channel, the frames are strided views into the padded signal, windowed a block of
    rows at a time into one reused buffer and transformed by :func:`scipy.fft.rfft`; only the
    float64 magnitudes are written into the preallocated result. Peak memory is the result plus a
    few MB, whatever the capture's length (a 60 s capture at 2 kHz with 6 channels: 375 MB).
    Values equal those of :class:`scipy.signal.ShortTimeFFT` within 1e-12 of the largest (tested).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(256) / 256.0
    >>> X = stft_features(np.sin(2 * np.pi * 32 * t)[:, None], 256.0, segment_length=64)
    >>> X.shape, int(X[0].argmax()), round(float(X[0].max()), 3)
    ((256, 33), 8, 0.5)
    """
    data = np.asarray(signals, dtype=np.float64)
    if data.ndim != 2:
        raise CaptureError(
            f"signals must have shape (n_samples, n_channels); got shape {data.shape}."
        )
    if not np.isfinite(data).all():
        raise CaptureError("signals contain NaN or inf; expected finite values.")
    if not (isinstance(segment_length, int | np.integer) and segment_length >= 2):
        raise ValueError(
            f"The 'segment_length' parameter must be an int >= 2. Got {segment_length!r} instead."
        )
    if not (isinstance(hop, int | np.integer) and hop >= 1):
        raise ValueError(f"The 'hop' parameter must be an int >= 1. Got {hop!r} instead.")
    if padding not in ("circular", "zeros", "valid"):
        raise ValueError(
            "The 'padding' parameter must be one of 'circular', 'zeros', 'valid'. "
            f"Got {padding!r} instead."
        )
    if scaling not in ("magnitude", "psd", "none"):
        raise ValueError(
            "The 'scaling' parameter must be one of 'magnitude', 'psd', 'none'. "
            f"Got {scaling!r} instead."
        )
    n_samples = data.shape[0]
    if n_samples < segment_length:
        raise CaptureError(
            f"capture too short for one STFT window: {n_samples} samples at {rate_hz:g} Hz, "
            f"expected at least segment_length={segment_length}."
        )
    import scipy.fft  # imported by the first transform: FeatureSpec alone stays light
    from scipy.signal import get_window

    window_values = get_window(window, segment_length)
    if scaling == "magnitude":
        window_values = window_values / abs(window_values.sum())
    elif scaling == "psd":
        window_values = window_values / np.sqrt(np.sum(window_values**2) * float(rate_hz))
    half = segment_length // 2
    if padding == "valid":
        first = -(-half // hop) * hop - half
        n_rows = (n_samples - segment_length + half) // hop - -(-half // hop) + 1
    else:
        first, n_rows = 0, -(-n_samples // hop)
    n_bins = segment_length // 2 + 1
    if n_rows == 0:
        raise CaptureError(
            f"no STFT slice fits inside the capture with padding='valid': {n_samples} samples, "
            f"segment_length={segment_length}, hop={hop}; expected a slice centre (a multiple of "
            "hop) with the whole window inside. Use a smaller hop or padding='circular'."
        )
    if max_rows is not None:
        n_rows = min(n_rows, max_rows)
    # Frames are views into the (padded) channel; they are windowed into one reused buffer, a
    # block of rows at a time, and only the magnitudes are written: no frame matrix and no
    # complex spectrum of the whole capture is ever held.
    X = np.empty((n_rows, data.shape[1] * n_bins))
    rows_per_block = max(1, min(n_rows, _BLOCK_VALUES // segment_length))
    windowed = np.empty((rows_per_block, segment_length))
    for c, channel in enumerate(data.T):
        frames = sliding_window_view(_extended(channel, segment_length, padding), segment_length)
        frames = frames[first :: int(hop)][:n_rows]
        for start in range(0, n_rows, rows_per_block):
            stop = min(start + rows_per_block, n_rows)
            block = windowed[: stop - start]
            np.multiply(frames[start:stop], window_values, out=block)
            spectrum = scipy.fft.rfft(block, axis=1)
            np.abs(spectrum, out=X[start:stop, c * n_bins : (c + 1) * n_bins])
    return X


def _extended(
    channel: NDArray[np.float64], segment_length: int, padding: Padding
) -> NDArray[np.float64]:
    """The channel with its edges padded: frame ``p`` is ``extended[start_p : start_p + m]``.

    Frame ``p`` is centred on sample ``p * hop`` and covers samples ``p * hop - m // 2`` ...
    ``p * hop - m // 2 + m - 1`` (the layout of :class:`scipy.signal.ShortTimeFFT`).
    """
    if padding == "valid":
        return np.ascontiguousarray(channel)
    half = segment_length // 2
    if padding == "circular":
        before, after = channel[channel.size - half :], channel[: segment_length - half - 1]
    else:
        before, after = np.zeros(half), np.zeros(segment_length - half - 1)
    return np.concatenate([before, channel, after])


@dataclass(frozen=True)
class FeatureSpec:
    """How a capture becomes a feature matrix: signals, rate, combinations and STFT settings.

    Parameters
    ----------
    signals : tuple of str, default=("position", "speed", "torque")
        Signals used, in column order.
    combinations : "products", "none" or tuple of (str, str), default="products"
        Extra channels: products of two signals (every pair for ``"products"``).
    segment_length, hop, window, padding, scaling
        As in :func:`stft_features`.
    target_rate_hz : float or None, default=None
        Common rate; default the fastest signal's.

    Examples
    --------
    >>> FeatureSpec(signals=("speed", "torque")).channel_names()
    ['speed', 'torque', 'speed*torque']
    """

    signals: tuple[str, ...] = ("position", "speed", "torque")
    combinations: Literal["products", "none"] | tuple[tuple[str, str], ...] = "products"
    segment_length: int = 128
    hop: int = 1
    window: str = "hann"
    padding: Padding = "circular"
    scaling: Scaling = "magnitude"
    target_rate_hz: float | None = None

    def channel_names(self) -> list[str]:
        """Names of the feature channels: the signals, then their combinations."""
        dummy = np.zeros((1, len(self.signals)))
        return _combined_channels(dummy, self.signals, self.combinations)[1]


@dataclass(frozen=True)
class Features:
    """A feature matrix and what its columns are.

    Attributes
    ----------
    X : ndarray of shape (n_rows, n_features)
    channels : tuple of str
        Feature channels (signals then combinations); column ``j`` belongs to channel
        ``channels[j // n_bins]``.
    frequencies_hz : ndarray of shape (n_bins,) or None
        Frequency of each bin within a channel, for spectral features; None for a stage whose
        columns are not frequency bins (then ``column_names`` says what they are).
    rate_hz : float
        Common rate of the signals.
    column_names : tuple of str, optional
        Name of every column, for stages whose columns are named measurements.
    phase_lag : int, default=0
        Samples the capture was shifted by (circularly) to line up with the baseline's phase
        before the features were taken; 0 without alignment.

    Examples
    --------
    >>> import numpy as np
    >>> Features(np.ones((2, 3)), ("stats",), None, 100.0, ("mean", "std", "peak")).column_channel
    array(['stats', 'stats', 'stats'], dtype='<U5')
    """

    X: NDArray[np.float64]
    channels: tuple[str, ...]
    frequencies_hz: NDArray[np.float64] | None
    rate_hz: float
    column_names: tuple[str, ...] | None = None
    phase_lag: int = 0

    @property
    def column_channel(self) -> NDArray[np.str_]:
        """Channel of every column, shape (n_features,)."""
        return np.repeat(np.array(self.channels), self.X.shape[1] // len(self.channels))

    @property
    def column_frequency_hz(self) -> NDArray[np.float64]:
        """Frequency of every column, shape (n_features,); only for spectral features."""
        return np.tile(self.spectral_frequencies_hz(), len(self.channels))

    def spectral_frequencies_hz(self) -> NDArray[np.float64]:
        """``frequencies_hz``, or a ValueError saying that these features have no frequency bins."""
        if self.frequencies_hz is None:
            raise ValueError(
                f"These features have no frequency bins (channels {list(self.channels)}, columns "
                f"{list(self.column_names or ())}); expected spectral features such as the "
                "|STFT| stage's."
            )
        return self.frequencies_hz


def extract_features(capture: Capture, spec: FeatureSpec | None = None) -> Features:
    """Resample a capture (PCHIP), add combinations and take |STFT| features.

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import Capture
    >>> rng = np.random.default_rng(0)
    >>> cap = Capture({"position": rng.normal(size=250), "speed": rng.normal(size=2000),
    ...                "torque": rng.normal(size=2000)},
    ...               {"position": 250.0, "speed": 2000.0, "torque": 2000.0})
    >>> feats = extract_features(cap, FeatureSpec(segment_length=64))
    >>> feats.X.shape, feats.channels
    ((1993, 198), ('position', 'speed', 'torque', 'position*speed', 'position*torque', 'speed*torque'))
    """
    spec = FeatureSpec() if spec is None else spec
    signals, rate = resample_capture(capture, spec.signals, target_rate_hz=spec.target_rate_hz)
    return features_from_signals(signals, rate, spec, source=capture.source)


def features_from_signals(
    signals: NDArray[np.float64],
    rate_hz: float,
    spec: FeatureSpec,
    *,
    source: str = "<memory>",
    max_rows: int | None = None,
) -> Features:
    """Features of signals already on one rate, columns in the order of ``spec.signals``
    (only the first ``max_rows`` rows when given).

    Examples
    --------
    >>> import numpy as np
    >>> spec = FeatureSpec(signals=("speed", "torque"), segment_length=16)
    >>> features_from_signals(np.ones((100, 2)), 2000.0, spec).X.shape
    (100, 27)
    """
    combined, channels = _combined_channels(signals, spec.signals, spec.combinations)
    if combined.shape[0] < spec.segment_length:
        raise CaptureError(
            f"{source}: capture too short for one STFT window: {combined.shape[0]} samples "
            f"at {rate_hz:g} Hz, expected at least segment_length={spec.segment_length}."
        )
    X = stft_features(
        combined,
        rate_hz,
        segment_length=spec.segment_length,
        hop=spec.hop,
        window=spec.window,
        padding=spec.padding,
        scaling=spec.scaling,
        max_rows=max_rows,
    )
    frequencies = np.fft.rfftfreq(spec.segment_length, d=1.0 / rate_hz).astype(np.float64)
    return Features(X, tuple(channels), frequencies, rate_hz)
