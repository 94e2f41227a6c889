"""The public namespace: sorted __all__, everything exported exists, importing has no side effects."""

from __future__ import annotations

import doctest
import importlib
import subprocess
import sys
import tomllib
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import axiswatch as aw
import axiswatch.datasets
import axiswatch.monitor

SUBPACKAGES = {"cli", "datasets", "exceptions", "indicators", "monitor", "paper", "report", "store"}


@pytest.mark.parametrize(
    "namespace",
    [aw, axiswatch.monitor, axiswatch.datasets],
    ids=lambda m: m.__name__,
)
def test_all_is_sorted_and_complete(namespace: ModuleType) -> None:
    assert namespace.__all__ == sorted(namespace.__all__)
    for name in namespace.__all__:
        assert hasattr(namespace, name), name
    public = {n for n in dir(namespace) if not n.startswith("_")} - SUBPACKAGES
    assert public - set(namespace.__all__) <= {"annotations"}


def test_top_namespace_is_the_library_in_about_forty_names() -> None:
    # The fleet service and the data sets have namespaces of their own (the lab is apart).
    # 40 after issue 12's layout, plus issue 13's AxisProfile (agreed in the layout plan) and
    # IndicatorModel.
    assert len(aw.__all__) <= 42
    assert not set(aw.__all__) & set(axiswatch.datasets.__all__)


def test_import_has_no_side_effects() -> None:
    code = (
        "import logging, sys, warnings\n"
        "import numpy, scipy.signal, sklearn.base, pandas, pyarrow, typer  # their own filters\n"
        "filters = list(warnings.filters)\n"
        "import axiswatch, axiswatch.monitor, axiswatch.datasets\n"
        "assert 'matplotlib' not in sys.modules, 'matplotlib imported'\n"
        # The library imports no plugin (the CLI loads those registered: the lab's, if installed).
        "lab = [m for m in sys.modules if m.startswith('axiswatch_lab')]\n"
        "assert not lab, f'the lab imported: {lab}'\n"
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


def test_figures_leave_the_users_matplotlib_backend_alone(tmp_path: Path) -> None:
    # Every figure of the library and the fleet report, drawn after the user chose a
    # backend: the choice stands, and pyplot (its window manager) is never imported.
    code = (
        "import sys, matplotlib\n"
        "matplotlib.use('svg')\n"
        "import numpy as np, pandas as pd\n"
        "import axiswatch as aw\n"
        "from axiswatch._plotting import plot_distance_trend\n"
        "from axiswatch.paper._attribution import plot_difference_spectrogram\n"
        "rows = pd.DataFrame({'captured_at': ['2026-03-01', '2026-03-02'], 'epoch': 1,\n"
        "    'role': ['baseline', 'monitor'], 'distance': [None, 1.0], 'threshold': [None, 2.0],\n"
        "    'over': False, 'alarm': False})\n"
        "plot_distance_trend(rows).figure.savefig(sys.argv[1] + '/trend.png')\n"
        "f = aw.Features(np.ones((4, 6)), ('a', 'b'), np.arange(3.0), 10.0)\n"
        "plot_difference_spectrogram(f, f)\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'\n"
    )
    subprocess.run([sys.executable, "-c", code, str(tmp_path)], check=True)
    assert (tmp_path / "trend.png").read_bytes().startswith(b"\x89PNG")


def test_every_library_module_is_under_the_import_contract() -> None:
    # A new library module must join the contract that keeps the library below the fleet service
    # and the data sets (pyproject.toml, checked by lint-imports in make lint).
    root = Path(__file__).resolve().parents[1]
    config = tomllib.loads((root / "pyproject.toml").read_text())
    contract = next(
        c
        for c in config["tool"]["importlinter"]["contracts"]
        if c.get("forbidden_modules") == ["axiswatch.monitor", "axiswatch.datasets"]
    )
    modules = {
        f"axiswatch.{path.stem}"
        for path in (root / "src" / "axiswatch").glob("*.py")
        if path.stem not in {"__init__", "__main__", "cli"}
    } | {"axiswatch.indicators", "axiswatch.paper"}
    assert modules == set(contract["source_modules"])


def _relocated_methods() -> list[tuple[str, object]]:
    """Methods with examples of the classes whose __module__ is their public namespace: doctest
    finds a class's own docstring there, but skips its methods (their globals are the private
    module's), so they are run here."""
    methods = []
    for namespace in (aw, axiswatch.datasets):
        for name in namespace.__all__:
            cls = getattr(namespace, name)
            if not (isinstance(cls, type) and cls.__module__ == namespace.__name__):
                continue
            for attribute, value in vars(cls).items():
                function = getattr(value, "__func__", getattr(value, "fget", value))
                if callable(function) and ">>>" in (function.__doc__ or ""):
                    methods.append((f"{namespace.__name__}.{name}.{attribute}", function))
    return methods


@pytest.mark.parametrize(("name", "function"), _relocated_methods())
def test_examples_of_public_classes_methods(name: str, function: Any) -> None:
    tests = doctest.DocTestFinder(recurse=False).find(function, name, globs=function.__globals__)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
    for test in tests:
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0
    assert runner.summarize(verbose=False).attempted > 0


def test_reprs_show_public_paths() -> None:
    assert repr(aw.HealthModel) == "<class 'axiswatch.HealthModel'>"
    assert repr(aw.HealthModel()).startswith("<axiswatch.HealthModel object at ")
    assert repr(axiswatch.datasets.Fault) == "<class 'axiswatch.datasets.Fault'>"
    for namespace in (aw, axiswatch.datasets):
        for name in namespace.__all__:
            public = getattr(namespace, name)
            if isinstance(public, type):
                assert not public.__module__.startswith(f"{namespace.__name__}._"), name
                # a pickle refers to the class by this path: it must lead back to the class
                module = importlib.import_module(public.__module__)
                assert getattr(module, public.__qualname__) is public


def test_every_error_is_reachable_where_the_readme_says() -> None:
    # The top namespace is capped (above): an error it leaves out lives in axiswatch.exceptions,
    # and the README and the manuals name it there, not as axiswatch.<Error> (which would not
    # import). The monitor manual's "Capture files" names ProfileError.
    import axiswatch.exceptions as errors

    root = Path(__file__).resolve().parents[1]
    readme = "\n".join(
        path.read_text(encoding="utf-8") for path in (root / "README.md", *root.glob("docs/*.md"))
    )
    for name in errors.__all__:
        assert issubclass(getattr(errors, name), errors.AxiswatchError), name
        if name not in aw.__all__:
            assert f"axiswatch.{name}" not in readme, name
    assert "ProfileError" not in aw.__all__
    assert "`axiswatch.exceptions.ProfileError`" in readme
    assert issubclass(errors.ProfileError, aw.CaptureError)
    with pytest.raises(aw.CaptureError):
        aw.AxisProfile.from_dict({"units": {"time": "minutes"}})


def test_no_import_cycle_in_the_product() -> None:
    # Imports for type checking only are left out: they never run.
    import grimp

    graph = grimp.build_graph("axiswatch", cache_dir=None, exclude_type_checking_imports=True)
    cycles = {
        tuple(sorted((module, imported)))
        for module in graph.modules
        for imported in graph.find_modules_directly_imported_by(module)
        if imported != module and graph.chain_exists(importer=imported, imported=module)
    }
    assert cycles == set()
