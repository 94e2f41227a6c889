"""Console-script entry point of ``axiswatch-lab``, outside the package.

As :mod:`axiswatch_launcher` does for ``axiswatch``: the package imports NumPy, SciPy and
pandas, so it is imported inside the handler, where a Ctrl-C is one line and exit status 130.
"""

from __future__ import annotations

from axiswatch_launcher import launch


def main() -> None:
    """Entry point of the ``axiswatch-lab`` script: :func:`axiswatch_lab.cli.main`."""
    launch("axiswatch_lab.cli:main")
