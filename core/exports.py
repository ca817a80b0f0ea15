"""A package's public surface, imported on first use (PEP 562).

A package's ``__init__`` names what it exports and from which module; each name is imported when it is
first asked for, so loading the command line (which imports every package's ``cli``) does not import
numba or the kernels.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from importlib import import_module
from typing import Any


def lazy_exports(package: str, exports: dict[str, tuple[str, ...]]) -> tuple[list[str], Callable[[str], Any],
                                                                              Callable[[], list[str]]]:
    """``__all__``, ``__getattr__`` and ``__dir__`` for the package named ``package`` that exports, for
    each module of ``exports``, the names it lists."""
    module_of = {name: module for module, names in exports.items() for name in names}
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str) -> Any:
        module = module_of.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(module_of))

    return sorted(module_of), __getattr__, __dir__


__all__ = ["lazy_exports"]
