"""Console-script entry point of ``axiswatch`` (the lab's ``axiswatch-lab`` has its own).

A module of its own, outside the ``axiswatch`` package, on purpose: importing anything inside the
package first runs ``axiswatch/__init__.py``, which imports NumPy, SciPy and pandas (1-2 s). A
script whose entry point were ``axiswatch.cli:main`` would do that import in the script wrapper
itself, where a Ctrl-C ends in a Python traceback. Here the import happens inside the handler,
so a Ctrl-C at any time is one line on stderr and exit status 130 (128 + SIGINT), as the
commands report it once they run. ``import axiswatch`` is unchanged.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from importlib import import_module
from types import ModuleType

#: The one line a Ctrl-C prints (the commands' own handler prints it too). True at any moment:
#: the monitor commits each capture on its own.
INTERRUPTED = (
    "interrupted: stopped before the end; a monitor store keeps every capture committed so far "
    "(run monitor again to go on)"
)

#: Exit status after a Ctrl-C: 128 + SIGINT, as a shell reports a process it interrupted.
INTERRUPTED_STATUS = 130


def launch(target: str, importer: Callable[[str], ModuleType] = import_module) -> None:
    """Import ``module:function`` and call it, turning a Ctrl-C at any moment into one line.

    Parameters
    ----------
    target : str
        The command's entry function, ``"package.module:function"``.
    importer : callable, default importlib.import_module
        Imports a module by name (a test passes one that is interrupted).

    Raises
    ------
    SystemExit
        With status 130 after a Ctrl-C (the traceback only with ``--debug`` on the command
        line), else whatever the command exits with.

    Examples
    --------
    >>> def interrupted_import(name):
    ...     raise KeyboardInterrupt
    >>> launch("axiswatch.cli:main", importer=interrupted_import)
    Traceback (most recent call last):
    SystemExit: 130
    """
    module_name, _, function_name = target.partition(":")
    try:
        entry = getattr(importer(module_name), function_name)
        entry()
    except KeyboardInterrupt:
        if "--debug" in sys.argv[1:]:
            raise
        print(INTERRUPTED, file=sys.stderr)
        forget_the_interrupt()
        raise SystemExit(INTERRUPTED_STATUS) from None


def forget_the_interrupt() -> None:
    """Clear CPython's record of a ``KeyboardInterrupt`` that left an ``exec`` of a string.

    Under ``python -m``, that record makes the interpreter end by SIGINT (status -2 to its
    parent) instead of exit status 130, even though the interrupt was caught here. Running a
    string clears the record; the record is CPython's ``_Py_UnhandledKeyboardInterrupt``.
    """
    exec("")  # runs nothing; its only effect is clearing that record


def axiswatch() -> None:
    """Entry point of the ``axiswatch`` script: :func:`axiswatch.cli.main`."""
    launch("axiswatch.cli:main")
