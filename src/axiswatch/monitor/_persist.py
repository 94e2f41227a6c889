"""Fitted models as plain data: NumPy arrays and JSON, never pickle.

A fitted model becomes one ``.npz`` blob and comes back bit for bit. Loading builds only the
classes of :data:`ALLOWED_CLASSES`. The encoding: docs/internals.md, "Stored models".
"""

from __future__ import annotations

import hashlib
import importlib
import io
import json
import math
from functools import cache
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import numpy as np

__all__ = [
    "ALLOWED_CLASSES",
    "PERSIST_FORMAT",
    "dump_model",
    "library_version",
    "load_model",
    "model_digest",
    "model_version",
]

#: Version of the blob's layout (a store refits models written in another format). 2: every
#: array in one packed member (format 1 had one ``.npy`` member per array: reading the zip
#: members was 90 % of loading a model, 2 ms a capture in a fleet day).
#: 3: a fleet prior keeps a task-change allowance per indicator (a model stored before has
#: none, and is refitted). 4: an indicator model may keep its baseline's order spectrum and its
#: readings their order profiles (``order_lines``). 5: an indicator model keeps the allowances
#: of its own pairs (``own_allowances_``). 6: the indicators' backlash reading is
#: ``gap_ringing`` (``reversal_bursts`` before): a stored model's centre and spreads of it mean
#: something else, so it is refitted. 7: an indicator model keeps its baseline's task envelope
#: without ``task_envelope_factor`` too (an axis without a fleet prior does not compare a
#: capture of another task). 8: an indicator model keeps ``whole_moves`` and ``se_ref_``, and
#: its readings their friction standard errors (``errors``; empty without ``whole_moves``): a
#: format-7 blob would come back without them, so it is refitted (to the same model, for the
#: default). 9: a fleet prior's scales are medians over the ordered pairs of its axes, each read
#: in its baseline's spreads (:func:`~axiswatch.indicators._fleet.fleet_pair_shifts`), and its
#: ``n_pairs`` counts them; a format-8 model keeps a prior that depends on the order its fleet
#: was listed in (and counts the pairs one way), so it is refitted and pooled again. 10:
#: ``gap_ringing``'s windows and the rate floors of the indicators are counted in whole samples
#: and compared within the rate's tolerance (:func:`~axiswatch.indicators._signals.whole_samples`,
#: :func:`~axiswatch._capture.rate_at_least`), so a format-9 model's centre and spreads of
#: ``gap_ringing`` were read with windows a sample longer or shorter: it is refitted.
PERSIST_FORMAT = 10

#: Classes a stored model may contain, by the path they are imported from. A new stage or
#: detector whose fitted state should be stored is added here (a test saves and loads each).
ALLOWED_CLASSES: tuple[str, ...] = (
    "axiswatch.FeatureSpec",
    "axiswatch.Features",
    "axiswatch.HalfLaplaceFit",
    "axiswatch.HealthModel",
    "axiswatch.IndicatorDetector",
    "axiswatch.IndicatorModel",
    "axiswatch.LRADetector",
    "axiswatch.PCADetector",
    "axiswatch.StftStage",
    "axiswatch.Threshold",
    "axiswatch._alignment.LowRankBasis",
    "axiswatch._indicator_model.FleetPrior",
    "axiswatch._order_lines.OrderProfile",
    "axiswatch._readings.Readings",
    "axiswatch.monitor._indicators.IndicatorBaseline",
    "axiswatch.paper._stages.RecomputedFeatures",
)

#: Where a stored name's class lives now. A stored name is part of the blob's format: a class
#: that moves keeps the name it was stored under, so stored models load and hash as before.
MOVED_CLASSES: dict[str, str] = {
    "axiswatch._alignment.LowRankBasis": "axiswatch.paper._alignment.LowRankBasis",
    "axiswatch._indicator_model.FleetPrior": "axiswatch.indicators._fleet.FleetPrior",
    "axiswatch._order_lines.OrderProfile": "axiswatch.indicators._order_lines.OrderProfile",
    "axiswatch._readings.Readings": "axiswatch.indicators._readings.Readings",
    "axiswatch.monitor._indicators.IndicatorBaseline": "axiswatch.indicators._axis.IndicatorBaseline",
}

_META = "__meta__"
_PACKED = "__arrays__"
#: Byte alignment of each array in the packed member.
_ALIGN = 16


@cache
def _registry() -> dict[str, Any]:
    classes = {}
    for path in ALLOWED_CLASSES:
        module, _, name = MOVED_CLASSES.get(path, path).rpartition(".")
        classes[path] = getattr(importlib.import_module(module), name)
    return classes


@cache
def _paths() -> dict[Any, str]:
    return {cls: path for path, cls in _registry().items()}


class _Encoder:
    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def encode(self, value: Any, where: str) -> Any:
        if value is None or isinstance(value, bool | str):
            return value
        if isinstance(value, np.ndarray):
            if value.dtype.hasobject:
                raise TypeError(f"cannot store {where}: an object array (only plain arrays).")
            key = f"a{len(self.arrays)}"
            self.arrays[key] = value
            return {"__array__": key}
        if isinstance(value, np.generic):
            return {"__scalar__": value.dtype.str, "value": self.encode(value.item(), where)}
        if isinstance(value, int):
            return value
        if isinstance(value, float):
            return value if math.isfinite(value) else {"__float__": repr(value)}
        if isinstance(value, tuple):
            return {"__tuple__": [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]}
        if isinstance(value, list):
            return [self.encode(v, f"{where}[{i}]") for i, v in enumerate(value)]
        if isinstance(value, dict):
            if not all(isinstance(k, str) for k in value):
                raise TypeError(f"cannot store {where}: a dict with non-string keys.")
            # Sorted, as the JSON is, so that equal models number their arrays alike.
            return {
                "__dict__": {k: self.encode(value[k], f"{where}[{k!r}]") for k in sorted(value)}
            }
        path = _paths().get(type(value))
        if path is None:
            raise TypeError(
                f"cannot store {where}: {type(value).__module__}.{type(value).__qualname__} is "
                "not in axiswatch.monitor._persist.ALLOWED_CLASSES (add its public path there "
                "if its attributes are plain data)."
            )
        state = vars(value)
        return {
            "__object__": path,
            "state": {name: self.encode(state[name], f"{where}.{name}") for name in sorted(state)},
        }


def _decode(node: Any, arrays: Any) -> Any:
    if node is None or isinstance(node, bool | int | float | str):
        return node
    if isinstance(node, list):
        return [_decode(v, arrays) for v in node]
    if "__array__" in node:
        return arrays[node["__array__"]]
    if "__scalar__" in node:
        return np.dtype(node["__scalar__"]).type(_decode(node["value"], arrays))
    if "__float__" in node:
        return float(node["__float__"])
    if "__tuple__" in node:
        return tuple(_decode(v, arrays) for v in node["__tuple__"])
    if "__dict__" in node:
        return {k: _decode(v, arrays) for k, v in node["__dict__"].items()}
    cls = _registry().get(node["__object__"])
    if cls is None:
        raise ValueError(
            f"stored model names class {node['__object__']!r}, which is not in ALLOWED_CLASSES."
        )
    obj = cls.__new__(cls)
    for name, value in node["state"].items():
        # object.__setattr__ also sets the fields of frozen dataclasses, as their __init__ does.
        object.__setattr__(obj, name, _decode(value, arrays))
    return obj


@cache
def library_version() -> str:
    """The installed axiswatch's version (a model made by another version is refitted).

    Read once per process: ``importlib.metadata`` parses the package's metadata on every call
    (2 ms, once per axis of a run before it was cached)."""
    try:
        return version("axiswatch")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def model_version() -> str:
    """What a stored model must have been written by to be used as it is: the library's version
    and the blob's format (a store made by an earlier build of the same version still refits).

    Examples
    --------
    >>> model_version().endswith(f"model format {PERSIST_FORMAT}")
    True
    """
    return f"{library_version()}, model format {PERSIST_FORMAT}"


def dump_model(model: Any, *, params: dict[str, Any] | None = None) -> bytes:
    """A fitted model as ``.npz`` bytes: its arrays, and a JSON description of everything else.

    Parameters
    ----------
    model : object of a class in ALLOWED_CLASSES
        Typically a fitted :class:`~axiswatch.HealthModel`.
    params : dict, optional
        JSON-ready parameters the model was made with, kept in the blob's header.

    Returns
    -------
    bytes

    Raises
    ------
    TypeError
        If an attribute, at any depth, is of a type that cannot be stored (named in the message).

    Examples
    --------
    >>> import numpy as np
    >>> from axiswatch import PCADetector
    >>> det = PCADetector(n_components=2).fit(np.random.default_rng(0).normal(size=(20, 4)))
    >>> back = load_model(dump_model(det))
    >>> bool(np.array_equal(back.components_, det.components_))
    True
    """
    encoder = _Encoder()
    tree = encoder.encode(model, type(model).__name__)
    packed, index = _pack(encoder.arrays)
    meta = {
        "format": PERSIST_FORMAT,
        "library_version": library_version(),
        "params": params,
        "model": tree,
        "arrays": index,
    }
    text = json.dumps(meta, sort_keys=True, allow_nan=False)
    buffer = io.BytesIO()
    members = {_META: np.frombuffer(text.encode(), dtype=np.uint8), _PACKED: packed}
    np.savez(buffer, **members)  # type: ignore[arg-type]
    return buffer.getvalue()


def _pack(arrays: dict[str, np.ndarray]) -> tuple[np.ndarray, dict[str, Any]]:
    """Every array's bytes in one ``uint8`` array, and where each lies (offset, dtype, shape)."""
    index: dict[str, Any] = {}
    chunks: list[bytes] = []
    offset = 0
    for name, array in arrays.items():
        data = array if array.flags.c_contiguous else array.copy(order="C")  # keeps 0-d shapes
        if data.dtype.fields is not None:
            raise TypeError(f"{name}: a structured array cannot be stored (dtype {data.dtype}).")
        index[name] = {"offset": offset, "descr": data.dtype.str, "shape": list(data.shape)}
        raw = data.tobytes()
        padding = -len(raw) % _ALIGN
        chunks.append(raw + bytes(padding))
        offset += len(raw) + padding
    return np.frombuffer(b"".join(chunks), dtype=np.uint8), index


def _unpack(packed: np.ndarray, index: dict[str, Any]) -> dict[str, np.ndarray]:
    buffer = packed.tobytes()
    arrays = {}
    for name, entry in index.items():
        dtype = np.dtype(entry["descr"])
        if dtype.hasobject:
            raise ValueError(f"stored model's array {name!r} has an object dtype; refused.")
        count = math.prod(entry["shape"])
        flat = np.frombuffer(buffer, dtype=dtype, count=count, offset=int(entry["offset"]))
        arrays[name] = flat.reshape(entry["shape"]).copy()  # writeable, as np.load gave them
    return arrays


def _read(blob: bytes) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    with np.load(io.BytesIO(blob), allow_pickle=False) as archive:
        members = {name: archive[name] for name in archive.files}
    meta = json.loads(members[_META].tobytes().decode())
    if meta.get("format") != PERSIST_FORMAT:
        raise ValueError(
            f"stored model has format {meta.get('format')!r}; this axiswatch reads "
            f"{PERSIST_FORMAT}."
        )
    return meta, _unpack(members[_PACKED], meta.pop("arrays"))


def load_model(blob: bytes) -> Any:
    """The model of :func:`dump_model`'s bytes (attributes and arrays identical).

    Raises
    ------
    ValueError
        If the blob is of another format or names a class outside ALLOWED_CLASSES.
    """
    meta, arrays = _read(blob)
    return _decode(meta["model"], arrays)


def model_digest(blob: bytes) -> str:
    """SHA-256 of a blob's content (header and arrays), the same for the same model whenever it
    was written (the ``.npz`` container's time stamps do not enter it).

    Examples
    --------
    >>> from axiswatch import IndicatorDetector
    >>> det = IndicatorDetector().fit([[1.0, 2.0], [3.0, 4.0]])
    >>> model_digest(dump_model(det)) == model_digest(dump_model(det))
    True
    """
    meta, arrays = _read(blob)
    digest = hashlib.sha256(json.dumps(meta, sort_keys=True).encode())
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}:{array.dtype.str}:{array.shape}".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()
