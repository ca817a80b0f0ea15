"""``python -m keepaway``: the same command line as the ``keepaway`` console script."""

from keepaway.cli import main

main()
