"""Fitted models between the driver, the store and the workers: shipped once, kept where used.

A job carries a :class:`ModelRef`, the model's hash and its store. Each worker caches the models
it has used, so a model is read at most once per worker and run.
A worker opens the store only to read a model, and closes it at once.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from axiswatch._axis_model import MonitoredModel
from axiswatch.monitor._persist import dump_model, load_model, model_digest
from axiswatch.monitor.store import Store

__all__ = ["MODELS_PER_WORKER", "Fitted", "ModelRef", "keep_model", "resolve_model"]

#: A fitted model of the monitor (any method's).
Fitted = MonitoredModel

#: Fitted models a worker keeps (least recently used dropped first). An LRA model of a 3 s
#: capture at hop 8 is about 3 MB, a mechanics model a few kB.
MODELS_PER_WORKER = 128


@dataclass(frozen=True)
class ModelRef:
    """Where a job finds its fitted model: the model's content hash, and the store holding it.

    Attributes
    ----------
    key : str
        :func:`~axiswatch.monitor._persist.model_digest` of the model's blob.
    store_path : str
        The SQLite store (absolute path) whose ``fitted_models`` table holds the blob.
    inline : MonitoredModel, optional
        The model itself, sent with every job: a model that cannot be stored (a class outside
        ``_persist.ALLOWED_CLASSES``, e.g. a detector registered by a user) travels as before.
    """

    key: str
    store_path: str
    inline: Fitted | None = None


_cache: OrderedDict[str, Fitted] = OrderedDict()


def keep_model(model: Fitted, *, params: dict[str, Any] | None = None) -> tuple[str, bytes | None]:
    """Serialise a fitted model, keep it in this process's cache; return its hash and blob
    (``("", None)`` when the model holds a class that cannot be stored)."""
    try:
        blob = dump_model(model, params=params)
    except TypeError:
        return "", None
    key = model_digest(blob)
    _remember(key, model)
    return key, blob


def _remember(key: str, model: Fitted) -> None:
    _cache[key] = model
    _cache.move_to_end(key)
    while len(_cache) > MODELS_PER_WORKER:
        _cache.popitem(last=False)


def _stored_blob(store_path: str, key: str) -> bytes | None:
    """The blob of a stored model, read through a connection closed at once.

    A worker never holds the store open: a connection kept between runs kept the store's
    write-ahead log alive, and a backup restored over the file then met the old file's log
    ("database disk image is malformed"). A model is read once per worker, so opening is cheap.
    """
    with Store(store_path, read_only=True) as store:
        return store.model_blob(key)


def resolve_model(ref: ModelRef) -> Fitted:
    """The model a job refers to: from this process's cache, else read once from the store.

    Raises
    ------
    LookupError
        If the store holds no model with that hash (it was replaced while the run went on).
    """
    if ref.inline is not None:
        return ref.inline
    model = _cache.get(ref.key)
    if model is not None:
        _cache.move_to_end(ref.key)
        return model
    blob = _stored_blob(ref.store_path, ref.key)
    if blob is None:
        raise LookupError(
            f"store '{ref.store_path}' holds no fitted model {ref.key[:12]}; run monitor again."
        )
    model = load_model(blob)
    _remember(ref.key, model)
    return model  # type: ignore[no-any-return]
