"""``python -m axiswatch``: the command-line tool."""

from axiswatch.cli import main

main()
