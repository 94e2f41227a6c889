"""A score's reason and details in one compressed blob: raw DEFLATE, primed with its baseline's
dictionary (the text of its first monitored score), so that the keys, the baseline values and
the wording every score of a baseline repeats cost a few bytes. Lossless: the text comes back
byte for byte, every float64 in it included."""

from __future__ import annotations

import zlib

__all__ = ["pack", "text_of", "unpack"]

_SEPARATOR = "\x00"


def text_of(reason: str, details: str) -> bytes:
    """The bytes a score's reason and details are packed from (and a dictionary is made of)."""
    return f"{reason}{_SEPARATOR}{details}".encode()


def pack(reason: str, details: str, dictionary: bytes | None) -> bytes:
    """Compress a score's ``reason`` and ``details`` (JSON text), primed with ``dictionary``.

    Examples
    --------
    >>> blob = pack("healthy", '{"pvalue": 0.1}', None)
    >>> unpack(blob, None)
    ('healthy', '{"pvalue": 0.1}')
    """
    if _SEPARATOR in reason:
        raise ValueError(f"A score's reason must not hold a NUL character. Got {reason!r}.")
    # Z_FILTERED: the digits of the floats are near random; 7 % smaller than the default.
    compressor = (
        zlib.compressobj(9, zlib.DEFLATED, -15, 9, zlib.Z_FILTERED)
        if dictionary is None
        else zlib.compressobj(9, zlib.DEFLATED, -15, 9, zlib.Z_FILTERED, zdict=dictionary)
    )
    return compressor.compress(text_of(reason, details)) + compressor.flush()


def unpack(blob: bytes, dictionary: bytes | None) -> tuple[str, str]:
    """The ``(reason, details)`` that :func:`pack` compressed with the same ``dictionary``."""
    decompressor = (
        zlib.decompressobj(-15) if dictionary is None else zlib.decompressobj(-15, zdict=dictionary)
    )
    text = (decompressor.decompress(blob) + decompressor.flush()).decode()
    reason, _, details = text.partition(_SEPARATOR)
    return reason, details
