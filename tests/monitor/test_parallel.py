"""parallel_map: serial, local processes and a Dask cluster give identical results."""

from __future__ import annotations

import os
import platform
import resource
import sys

import numpy as np
import pytest

import axiswatch as aw
import axiswatch.monitor as awm


def _score(seed: int) -> tuple[int, float, int]:
    """The real scoring path on a small synthetic capture: features, LRA distance to a baseline."""
    rng = np.random.default_rng(seed)
    t = np.arange(600) / 600.0
    speed = np.sin(2 * np.pi * 3 * t) + 0.1 * seed * np.sin(2 * np.pi * 40 * t)
    capture = aw.Capture({"speed": speed + 0.01 * rng.normal(size=600)}, {"speed": 600.0})
    spec = aw.FeatureSpec(signals=("speed",), combinations="none", segment_length=32)
    baseline = aw.extract_features(
        aw.Capture({"speed": np.sin(2 * np.pi * 3 * t)}, {"speed": 600.0}), spec
    ).X
    distance = (
        aw.LRADetector(noise_level=0.01)
        .fit(baseline)
        .distance(aw.extract_features(capture, spec).X)
    )
    return seed, distance, os.getpid()


def _fail_on_three(value: int) -> int:
    if value == 3:
        raise ArithmeticError(f"item {value} failed")
    return value


ITEMS = list(range(6))


@pytest.fixture(scope="module")
def serial() -> dict[int, tuple[int, float]]:
    results = list(awm.parallel_map(_score, ITEMS))
    assert [index for index, _ in results] == ITEMS  # in order
    assert {pid for _, (_, _, pid) in results} == {os.getpid()}  # in process
    return {index: (seed, distance) for index, (seed, distance, _) in results}


def test_processes_give_identical_results(serial: dict[int, tuple[int, float]]) -> None:
    results = dict(awm.parallel_map(_score, iter(ITEMS), workers=2))
    assert {i: (seed, distance) for i, (seed, distance, _) in results.items()} == serial
    assert os.getpid() not in {pid for _, _, pid in results.values()}


def test_dask_local_cluster_gives_identical_results(serial: dict[int, tuple[int, float]]) -> None:
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        by_client = dict(awm.parallel_map(_score, ITEMS, dask=client))
        by_address = dict(awm.parallel_map(_score, ITEMS, dask=cluster.scheduler_address))
        assert client.status == "running"  # a given client is left open
    for results in (by_client, by_address):
        assert {i: (seed, distance) for i, (seed, distance, _) in results.items()} == serial


#: Elements of the array :func:`_freed_array_faults` makes and frees: 1 MB of float64 (NumPy
#: asks for huge pages from 4 MB, which would hide the faults counted).
_ARRAY_SIZE = 128 * 1024
_ARRAY_PAGES = _ARRAY_SIZE * 8 // resource.getpagesize()


def _freed_array_faults(_: int) -> int:
    """Minor page faults of this thread while it makes and frees a 1 MB array ten times."""
    before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
    for _ in range(10):
        np.ones(_ARRAY_SIZE)
    return resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's allocator only")
def test_dask_workers_reuse_freed_arrays_while_they_run_a_batch() -> None:
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        if not any(client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_").values()):
            pytest.skip("this Dask's nanny sets no trim threshold")
        ours = dict(awm.parallel_map(_freed_array_faults, [0], dask=client))[0]
        after = client.submit(_freed_array_faults, 0, pure=False).result()
    assert ours < 2 * _ARRAY_PAGES  # its pages faulted in once, then reused
    assert after > 5 * _ARRAY_PAGES  # the worker's own thresholds back once the batch ended


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's allocator only")
def test_pool_workers_reuse_freed_arrays_from_their_start() -> None:
    # An untuned glibc maps a large array afresh until a free raises its threshold, and trims
    # the heap back to the OS: the first arrays of each size fault their pages in twice.
    faults = dict(awm.parallel_map(_freed_array_faults, [0, 1], workers=2))
    assert max(faults.values()) < 2 * _ARRAY_PAGES


@pytest.mark.parametrize("workers", [1, 2])
def test_errors_reach_the_caller(workers: int) -> None:
    with pytest.raises(ArithmeticError, match=r"item 3 failed"):
        dict(awm.parallel_map(_fail_on_three, range(5), workers=workers))


@pytest.mark.parametrize("workers", [0, 1.5, True])
def test_bad_workers(workers: object) -> None:
    with pytest.raises(ValueError, match=r"'workers' parameter must be an int >= 1. Got"):
        awm.parallel_map(abs, [1], workers=workers)  # type: ignore[arg-type]


def test_bad_dask_option() -> None:
    pytest.importorskip("distributed")
    with pytest.raises(TypeError, match=r"'dask' parameter must be a scheduler address"):
        awm.parallel_map(abs, [1], dask=8786)


def test_dask_not_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError, match=r"The 'dask' option needs dask.distributed"):
        awm.parallel_map(abs, [1], dask="tcp://127.0.0.1:8786")
