"""``python -m axiswatch``: the command-line tool, through the console scripts' launcher.

Python imports the package ``axiswatch`` (NumPy, SciPy, pandas, scikit-learn: most of the
start-up) before it runs this module, so a Ctrl-C during that import still ends in a traceback:
nothing of the package runs earlier, and a handler installed by ``axiswatch/__init__.py`` would
change global state on every ``import axiswatch``. From here on (the command line's own imports,
the plugins' commands, the command) a Ctrl-C is one line and exit status 130, as with the
``axiswatch`` script, which is protected from its first instruction.
"""

from axiswatch_launcher import axiswatch

axiswatch()
