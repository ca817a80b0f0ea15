"""The packages import downwards only (style guide): core and protocol are leaves, and a player or a coach
knows nothing a real client could not know, so agents/ and coach/ import neither server/ nor trainer/."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROJECT = ("agents", "coach", "core", "keepaway", "protocol", "server", "trainer")
# package -> the project's packages it may import (besides itself)
ALLOWED = {
    "core": set(),
    "protocol": {"core"},
    "agents": {"core", "protocol"},
    "coach": {"core", "protocol"},
}


def imported_packages(path: Path) -> set[str]:
    """The project's top-level packages a module imports, wherever the import statement is."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        found |= {name.split(".")[0] for name in names if name.split(".")[0] in PROJECT}
    return found


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_a_package_imports_only_the_packages_below_it(package):
    for path in sorted((ROOT / package).glob("*.py")):
        wrong = imported_packages(path) - ALLOWED[package] - {package}
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)}"
