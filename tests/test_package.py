"""The public namespace: sorted __all__, everything exported exists, importing has no side effects."""

from __future__ import annotations

import subprocess
import sys
from types import ModuleType

import pytest

import axiswatch as aw
import axiswatch.datasets
import axiswatch.monitor
import axiswatch_lab

SUBPACKAGES = {"cli", "datasets", "exceptions", "monitor"}


@pytest.mark.parametrize(
    "namespace",
    [aw, axiswatch.monitor, axiswatch.datasets, axiswatch_lab],
    ids=lambda m: m.__name__,
)
def test_all_is_sorted_and_complete(namespace: ModuleType) -> None:
    assert namespace.__all__ == sorted(namespace.__all__)
    for name in namespace.__all__:
        assert hasattr(namespace, name), name
    public = {n for n in dir(namespace) if not n.startswith("_")} - SUBPACKAGES
    assert public - set(namespace.__all__) <= {"annotations"}


def test_top_namespace_is_the_library_in_about_forty_names() -> None:
    # The fleet service, the data sets and the research package have namespaces of their own.
    assert len(aw.__all__) <= 40
    assert not set(aw.__all__) & set(axiswatch.datasets.__all__)
    assert not set(aw.__all__) & set(axiswatch_lab.__all__)


def test_import_has_no_side_effects() -> None:
    code = (
        "import logging, sys, warnings\n"
        "import numpy, scipy.signal, sklearn.base, pandas, pyarrow, typer  # their own filters\n"
        "filters = list(warnings.filters)\n"
        "import axiswatch\n"
        "assert 'matplotlib' not in sys.modules, 'matplotlib imported'\n"
        "assert logging.getLogger().level == logging.WARNING\n"
        "assert warnings.filters == filters\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_exceptions_subclass_builtins() -> None:
    assert issubclass(aw.CaptureError, ValueError)
    assert issubclass(aw.CalibrationError, ValueError)
    assert issubclass(aw.StoreError, RuntimeError)
    assert all(
        issubclass(e, aw.AxiswatchError)
        for e in (aw.CaptureError, aw.CalibrationError, aw.StoreError)
    )
