"""Fitted models between the driver, the store and the workers: shipped once, kept where used.

Pipeline side-stage of the monitor. The driver never sends a fitted model with a job: a job
carries a :class:`ModelRef` (the model's content hash and the store that holds it), and each
worker process keeps the models it has used or fitted in a small cache keyed by that hash,
reading a missing one from the store once (read-only). A model is therefore deserialised at
most once per worker and run, whatever the number of captures it scores, and a model fitted in
a worker is never read back there.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from axiswatch._axis_model import MonitoredModel
from axiswatch.monitor._persist import dump_model, load_model, model_digest
from axiswatch.monitor._store import Store

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
_stores: dict[tuple[int, str], tuple[int, Store]] = {}


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


def _read_only(store_path: str) -> Store:
    # One connection per process and store (a forked worker must not use its parent's), and per
    # file: a store deleted and made anew at the same path (a long-lived process, a notebook)
    # gets a new connection instead of reading the old file's models through the old one.
    key = (os.getpid(), store_path)
    file_id = os.stat(store_path).st_ino
    opened = _stores.get(key)
    if opened is None or opened[0] != file_id:
        if opened is not None:
            opened[1].close()
        opened = _stores[key] = (file_id, Store(store_path, read_only=True))
    return opened[1]


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
    blob = _read_only(ref.store_path).model_blob(ref.key)
    if blob is None:
        raise LookupError(
            f"store '{ref.store_path}' holds no fitted model {ref.key[:12]}; run monitor again."
        )
    model = load_model(blob)
    _remember(ref.key, model)
    return model  # type: ignore[no-any-return]
