"""The public namespace: sorted __all__, everything exported exists, importing has no side effects."""

from __future__ import annotations

import subprocess
import sys

import axiswatch as aw


def test_all_is_sorted_and_complete() -> None:
    assert aw.__all__ == sorted(aw.__all__)
    for name in aw.__all__:
        assert hasattr(aw, name), name
    public = {n for n in dir(aw) if not n.startswith("_") and n not in ("exceptions", "cli")}
    assert public - set(aw.__all__) <= {"annotations"}


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
