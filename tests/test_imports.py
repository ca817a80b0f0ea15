"""The packages import downwards only: core and protocol are leaves, and a player or a coach
knows nothing a real client could not know, so agents/ and coach/ import neither server/ nor the layers
above. runner/ plays games in every mode and knows nothing of learning: trainer/ builds on it, never the
other way round, and its job types (runner/job.py) are a leaf every backend builds on. No module imports
itself back through others, wherever in the module the import statement is (a function-level import
dodges a cycle at import time, not the tangle)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROJECT = ("agents", "coach", "core", "keepaway", "protocol", "rcss", "runner", "server", "trainer", "viewer")
# package -> the project's packages it may import (besides itself)
ALLOWED = {
    "core": set(),
    "protocol": {"core"},
    "rcss": {"core", "protocol"},
    "agents": {"core", "protocol", "rcss"},
    "coach": {"core", "protocol"},
    "server": {"core", "protocol", "rcss"},
    "runner": {"core", "protocol", "agents", "server", "rcss"},
    "trainer": {"core", "protocol", "agents", "server", "runner", "rcss"},
    "viewer": {"core", "protocol", "server"},
}


def module_name(path: Path) -> str:
    """``runner/job.py`` -> ``keepaway.runner.job`` (the folders are the keepaway namespace's subpackages);
    a package's ``__init__.py`` is the package."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    parts = parts[:-1] if parts[-1] == "__init__" else parts
    return ".".join(parts if parts[0] == "keepaway" else ("keepaway", *parts))


MODULES = {module_name(path): path for package in PROJECT for path in sorted((ROOT / package).glob("*.py"))}


def imported_names(path: Path) -> set[str]:
    """The dotted names a module imports, wherever the import statement is: ``import a.b`` gives ``a.b``,
    ``from a import b`` gives ``a`` and ``a.b`` (``b`` may be a module)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found |= {node.module} | {f"{node.module}.{alias.name}" for alias in node.names}
    return found


def package_of(name: str) -> str | None:
    """The project's package a dotted name lies in (``keepaway.server.arena`` -> ``server``;
    ``keepaway.cli`` -> ``keepaway``), or None for a name outside the project."""
    parts = name.split(".")
    if parts[0] != "keepaway":
        return None
    return parts[1] if len(parts) > 1 and parts[1] in PROJECT else "keepaway"


def imported_packages(path: Path) -> set[str]:
    """The project's packages a module imports."""
    return {package_of(name) for name in imported_names(path)} - {None}


def import_graph() -> dict[str, set[str]]:
    """Module -> the project's modules it imports."""
    return {name: (imported_names(path) & set(MODULES)) - {name} for name, path in MODULES.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` as the path that closes it (``[a, b, a]``), or None."""
    done: set[str] = set()
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        path.append(node)
        for target in sorted(graph[node]):
            if target in path:
                return path[path.index(target):] + [target]
            if target not in done:
                cycle = visit(target)
                if cycle is not None:
                    return cycle
        path.pop()
        done.add(node)
        return None

    for node in sorted(graph):
        if node not in done:
            cycle = visit(node)
            if cycle is not None:
                return cycle
    return None


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_a_package_imports_only_the_packages_below_it(package):
    for path in sorted((ROOT / package).glob("*.py")):
        wrong = imported_packages(path) - ALLOWED[package] - {package}
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)}"


def test_no_module_of_the_project_imports_itself_back():
    assert find_cycle(import_graph()) is None, " -> ".join(find_cycle(import_graph()) or [])


def test_the_cycle_check_sees_imports_inside_functions_and_finds_cycles(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from keepaway.trainer.train import derive_seed\n")
    assert imported_names(module) == {"keepaway.trainer.train", "keepaway.trainer.train.derive_seed"}
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_the_job_types_are_the_runners_leaf():
    # runner.job may read the package's own constants (runner.MODES, kept there so that the command line
    # need not import the players' kernels), and the package imports none of its modules itself
    graph = import_graph()
    assert not {name for name in graph["keepaway.runner.job"] if name.startswith("keepaway.runner.")}
    assert not {name for name in graph["keepaway.runner"] if name.startswith("keepaway.runner")}
