"""The lab's namespace and distribution: sorted __all__, public reprs, figures without pyplot,
and the product's wheel without it."""

from __future__ import annotations

import importlib
import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

import axiswatch as aw
import axiswatch_lab


def test_all_is_sorted_complete_and_apart_from_the_product() -> None:
    assert axiswatch_lab.__all__ == sorted(axiswatch_lab.__all__)
    for name in axiswatch_lab.__all__:
        assert hasattr(axiswatch_lab, name), name
    public = {n for n in dir(axiswatch_lab) if not n.startswith("_")} - {"cli", "studies"}
    assert public - set(axiswatch_lab.__all__) <= {"annotations"}
    assert not set(aw.__all__) & set(axiswatch_lab.__all__)


def test_the_lab_is_its_own_distribution_with_the_product_s_entry_points() -> None:
    lab_root = Path(axiswatch_lab.__file__).resolve().parents[2]
    assert (lab_root / "pyproject.toml").is_file()
    assert not (Path(aw.__file__).resolve().parent.parent / "axiswatch_lab").exists()
    (command,) = entry_points(group="axiswatch.commands", name="experiment")
    assert command.dist is not None
    assert command.dist.name == "axiswatch-lab"
    (method,) = entry_points(group="axiswatch.methods", name="mechanics")
    assert method.value == "axiswatch_lab._mechanics"
    (script,) = entry_points(group="console_scripts", name="axiswatch-lab")
    assert script.value == "axiswatch_lab_launcher:main"


def test_reprs_show_public_paths() -> None:
    assert repr(axiswatch_lab.ResidualStage) == "<class 'axiswatch_lab.ResidualStage'>"
    for name in axiswatch_lab.__all__:
        public = getattr(axiswatch_lab, name)
        if isinstance(public, type):
            assert not public.__module__.startswith("axiswatch_lab._"), name
            module = importlib.import_module(public.__module__)
            assert getattr(module, public.__qualname__) is public


def test_figures_leave_the_users_matplotlib_backend_alone(tmp_path: Path) -> None:
    code = (
        "import sys, matplotlib\n"
        "matplotlib.use('svg')\n"
        "import pandas as pd\n"
        "from axiswatch_lab._plots import plot_paired, plot_roc, plot_robot_study\n"
        "plot_roc(pd.DataFrame({'method': ['lra'], 'protocol': ['p'], 'percentile': [99.0],\n"
        "    'fpr': [0.0], 'tpr': [1.0], 'auroc': [1.0]}))\n"
        "plot_robot_study(pd.DataFrame({'day': [1, 2], 'task': 'a', 'method': 'lra',\n"
        "    'alignment': 'none', 'fault': 'none', 'distance': [0.1, 0.2]}), 't')\n"
        "figure = plot_paired(pd.DataFrame({'features': ['stft'], 'method': ['lra'],\n"
        "    'fault': ['tooth'], 'auroc': [0.5], 'oracle_auroc': [0.9]}))\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'\n"
    )
    subprocess.run([sys.executable, "-c", code, str(tmp_path)], check=True)
