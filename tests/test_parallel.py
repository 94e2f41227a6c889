"""The serial parallel_map hook."""

from __future__ import annotations

import pytest

from axiswatch._parallel import parallel_map


def test_yields_every_index_and_result() -> None:
    assert dict(parallel_map(str.upper, ["a", "b", "c"])) == {0: "A", 1: "B", 2: "C"}


def test_workers_must_be_a_positive_int() -> None:
    with pytest.raises(ValueError, match=r"'workers' parameter must be an int >= 1. Got 0"):
        list(parallel_map(abs, [1], workers=0))


def test_serial_build_refuses_parallel_requests() -> None:
    with pytest.raises(NotImplementedError, match=r"runs scoring serially only: got workers=2"):
        list(parallel_map(abs, [1], workers=2))
