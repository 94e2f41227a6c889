"""The allocator's thresholds on a Dask worker: set for a batch, the environment's back after."""

from __future__ import annotations

from typing import Any

import pytest

from axiswatch.monitor import _malloc


class _FakeGlibc:
    """Records ``mallopt`` and ``malloc_trim`` calls."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []

    def mallopt(self, parameter: int, value: int) -> int:
        self.calls.append(("mallopt", parameter, value))
        return 1

    def malloc_trim(self, pad: int) -> int:
        self.calls.append(("malloc_trim", pad))
        return 1


@pytest.fixture
def glibc(monkeypatch: pytest.MonkeyPatch) -> _FakeGlibc:
    fake = _FakeGlibc()
    monkeypatch.setattr(_malloc, "_glibc", lambda: fake)
    for variable in _malloc._THRESHOLDS:
        monkeypatch.delenv(variable, raising=False)
    return fake


def test_an_environment_without_thresholds_is_left_alone(glibc: _FakeGlibc) -> None:
    with _malloc.arrays_reused():
        pass
    assert glibc.calls == []


def test_the_environments_thresholds_come_back_after_the_last_block(
    glibc: _FakeGlibc, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    reused = [("mallopt", -3, 32 * 1024 * 1024), ("mallopt", -1, 64 * 1024 * 1024)]
    with _malloc.arrays_reused():
        with _malloc.arrays_reused():  # a second task thread of the same worker
            assert glibc.calls == reused
        assert glibc.calls == reused  # the first block still runs
    assert glibc.calls == [
        *reused,
        ("mallopt", -1, 65536),
        ("mallopt", -3, 128 * 1024),
        ("malloc_trim", 0),
    ]
