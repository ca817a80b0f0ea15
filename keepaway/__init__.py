"""Entry point of the ``keepaway`` command line (see :mod:`keepaway.cli`)."""
