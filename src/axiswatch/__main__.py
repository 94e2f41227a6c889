"""``python -m axiswatch``: the command-line tool, through the console scripts' launcher.

Python imports the package before this module runs, so a Ctrl-C then ends in a traceback. From
here on, a Ctrl-C is one line and exit status 130, as with the ``axiswatch`` script.
"""

from axiswatch_launcher import axiswatch

axiswatch()
