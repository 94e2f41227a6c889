"""Shared, seeded fixtures of the lab's tests; one BLAS/OpenMP thread, as the product's tests.

The lab's tests are collected beside the product's (``make test``): the variables are set here
too, before NumPy is first imported, in case the lab's tests run alone.
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

threadpool_limits(1)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
