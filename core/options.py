"""Option types every command shares, below every package so that each package's ``cli`` can use them."""

from __future__ import annotations

import logging
import math
import sys
from typing import Any

import click


class FiniteFloatRange(click.FloatRange):
    """click's ``FloatRange`` that also refuses ``nan`` and ``inf``: ``nan`` compares false with every
    bound, so a plain range lets it through to a parameter check that names the parameter, not the
    option typed."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> float:
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{number} is not a finite number", param, ctx)
        return number


def configure_logging(verbose: int) -> None:
    """Log to stderr at WARNING, or INFO and DEBUG for ``-v`` and ``-vv`` (every command's ``--verbose``)."""
    logging.basicConfig(level=logging.WARNING - 10 * min(verbose, 2),
                        format="%(asctime)s %(name)s %(levelname)s %(message)s", stream=sys.stderr)


__all__ = ["FiniteFloatRange", "configure_logging"]
