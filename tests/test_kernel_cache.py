"""numba's kernel cache (``core.jit``): keyed on every kernel source, so stale machine code never runs,
and compiled once per source before the processes that load it start (``runner.kernels``)."""

from __future__ import annotations

import ast
import importlib
import os
import re
import subprocess
import sys
import textwrap
from collections import namedtuple
from pathlib import Path

import numpy as np

from conftest import REPO, keepaway_command
from keepaway.core.jit import (
    KERNEL_SOURCES,
    NOT_KERNEL_SOURCES,
    ROOT,
    Kernel,
    borrowing,
    configure_cache,
    njit,
    source_digest,
    source_files,
)
from test_imports import MODULES, PROJECT, imported_names

# Runs pkg.a.f() with numba's cache in CACHE_ROOT/numba-<digest of pkg's source>, as core.jit does.
RUN_KERNEL = textwrap.dedent("""
    import sys
    from pathlib import Path
    import numba.core.config
    from keepaway.core.jit import source_digest
    root, cache_root = Path(sys.argv[1]), Path(sys.argv[2])
    numba.core.config.CACHE_DIR = str(cache_root / f"numba-{source_digest(root, ('pkg',))}")
    sys.path.insert(0, str(root))
    from pkg.a import f
    print(f())
""")


def write_package(root: Path, g_value: int) -> None:
    pkg = root / "pkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "b.py").write_text(f"from numba import njit\n\n\n@njit(cache=True)\ndef g():\n    return {g_value}\n")
    (pkg / "a.py").write_text("from numba import njit\n\nfrom pkg.b import g\n\n\n"
                              "@njit(cache=True)\ndef f():\n    return g() + 10\n")


def run_kernel(root: Path, cache_root: Path) -> int:
    out = subprocess.run([sys.executable, "-c", RUN_KERNEL, str(root), str(cache_root)], cwd=REPO,
                         capture_output=True, timeout=300, check=True)
    return int(out.stdout)


def test_editing_a_file_a_kernel_calls_into_never_runs_stale_code(tmp_path):
    """numba's own cache checks only the caller's file (a.py): after an edit of b.py it would still
    return 11. Keyed on the package's source, the edit selects a fresh cache."""
    root, cache_root = tmp_path / "src", tmp_path / "cache"
    root.mkdir()
    write_package(root, 1)
    assert run_kernel(root, cache_root) == 11
    assert run_kernel(root, cache_root) == 11  # now from the cache
    cached = list(cache_root.glob("numba-*/*/a.f-*.nbi"))
    assert len(cached) == 1
    write_package(root, 2)
    assert run_kernel(root, cache_root) == 12
    assert len(list(cache_root.glob("numba-*"))) == 2


def test_the_digest_follows_content_and_timestamps(tmp_path):
    write_package(tmp_path, 1)
    first = source_digest(tmp_path, ("pkg",))
    assert source_digest(tmp_path, ("pkg",)) == first
    b = tmp_path / "pkg" / "b.py"
    stat = b.stat()
    b.write_text(b.read_text().replace("1", "7"))  # same size
    os.utime(b, ns=(stat.st_atime_ns, stat.st_mtime_ns))  # same timestamp
    assert source_digest(tmp_path, ("pkg",)) != first


def imports_njit(tree: ast.AST, module: str) -> bool:
    """Whether ``tree`` imports a kernel decorator (``njit``, or ``core.jit``'s ``borrowing``) from ``module``."""
    return any(isinstance(node, ast.ImportFrom) and node.module == module
               and any(a.name in ("njit", "borrowing") for a in node.names) for node in ast.walk(tree))


def imports_numba_njit(tree: ast.AST) -> bool:
    if imports_njit(tree, "numba"):
        return True
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and node.attr == "njit"
                and getattr(node.value, "id", None) in ("numba", "nb")):
            return True
    return False


def test_every_cached_kernel_goes_through_core_jit_and_is_in_the_key():
    """A kernel decorated with numba's own njit would use numba's stale-prone cache; a kernel module
    outside KERNEL_SOURCES would not change the key when edited."""
    keyed = set(source_files(ROOT, KERNEL_SOURCES, NOT_KERNEL_SOURCES))
    for package in PROJECT:
        for path in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text())
            if path.name != "jit.py":
                assert not imports_numba_njit(tree), f"{path}: import njit from core.jit"
            if imports_njit(tree, "keepaway.core.jit"):
                assert path in keyed, f"{path} defines kernels but is not in core.jit.KERNEL_SOURCES"


def test_every_module_a_kernel_module_imports_is_in_the_key():
    """A kernel is compiled with the module-level values it reads (a constant, a table) of any module its
    own module imports, directly or through others: an edit there must select a fresh cache as well."""
    assert all((ROOT / name).is_file() for name in NOT_KERNEL_SOURCES)
    keyed = {path.resolve() for path in source_files(ROOT, KERNEL_SOURCES, NOT_KERNEL_SOURCES)}
    kernel_modules = [name for name, path in MODULES.items()
                      if imports_njit(ast.parse(path.read_text()), "keepaway.core.jit")]
    assert "keepaway.server.physics" in kernel_modules and "keepaway.runner.batched" in kernel_modules
    reached: set[str] = set()
    todo = list(kernel_modules)
    while todo:
        name = todo.pop()
        if name not in reached:
            reached.add(name)
            todo.extend(imported_names(MODULES[name]) & set(MODULES))
    unkeyed = sorted(str(MODULES[name].relative_to(ROOT)) for name in reached if MODULES[name].resolve() not in keyed)
    assert not unkeyed, f"kernel modules import these, which core.jit.KERNEL_SOURCES leaves out: {unkeyed}"


def test_a_warm_cache_is_loaded_not_compiled_again(processes, tmp_path):
    """The test session compiled every kernel set (conftest); nothing says it compiles again."""
    proc = processes.popen(keepaway_command("compile"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()
    assert "already compiled" in out.decode() and "compiling" not in err.decode()
    proc = processes.popen(keepaway_command("run", "--episodes", "1", "--mode", "embedded", "--json",
                                            "--out", str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()
    assert "compiling" not in err.decode()


def test_an_unwritable_cache_root_falls_back_to_the_temporary_directory(tmp_path):
    """A read-only home must not stop every command at import: the cache moves to the temp directory."""
    blocker = tmp_path / "not-a-directory"
    blocker.write_text("")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(blocker / "cache"), "TMPDIR": str(tmp_path / "tmp")}
    (tmp_path / "tmp").mkdir()
    out = subprocess.run([sys.executable, "-c", "from core.jit import cache_dir; print(cache_dir())"], cwd=REPO,
                         env=env, capture_output=True, text=True, timeout=120, check=True)
    assert Path(out.stdout.strip()).parent == tmp_path / "tmp" / f"keepaway-{os.getuid()}"


Rows = namedtuple("Rows", "a b")


@njit
def _scratch_sum(rows, r):
    """Allocates: must keep numba's reference counting."""
    out = np.empty(2)
    out[0] = rows.a[r, 0]
    out[1] = rows.b[r, 1]
    return out.sum()


def _with_scratch(rows):
    t = 0.0
    for r in range(rows.a.shape[0]):
        t += _scratch_sum(rows, r)
    return t


def _switching_walk(rows, first):
    """Switches between the records' arrays: numba's pruning leaves reference counts here."""
    x = rows.a if first else rows.b
    t = 0.0
    for r in range(x.shape[0]):
        t += x[r, 0]
        if t > 2.0:
            x = rows.b
    return t


def _function_body(ir: str, name: str) -> str:
    """The LLVM IR of the numba function ``name`` itself (not its Python wrapper nor its callees)."""
    own = []
    for part in ir.split("\ndefine ")[1:]:
        symbol = re.search(r'@"?([^"(]+)"?\(', part).group(1)
        if f"{len(name)}{name}" in symbol and "cpython" not in symbol and "cfunc" not in symbol:
            own.append(part.split("\n}\n")[0])
    assert len(own) == 1, f"{len(own)} definitions of {name}"
    return own[0]


def test_a_borrowing_kernel_counts_no_references_and_may_call_an_allocating_one():
    """``core.jit.borrowing`` compiles a kernel without numba's reference counting (no NRT_incref or
    NRT_decref in its code, where ``njit`` has them), to the same result; an ``njit`` kernel that
    allocates still compiles when a borrowing one is the first to call it (numba would compile it under
    its caller's setting, which cannot allocate)."""
    rows = Rows(np.arange(8.0).reshape(4, 2), np.arange(8.0, 16.0).reshape(4, 2))
    assert borrowing(cache=False)(_with_scratch)(rows) == sum(rows.a[:, 0] + rows.b[:, 1])
    borrowed, counted = borrowing(cache=False)(_switching_walk), njit(_switching_walk)
    assert borrowed(rows, True) == counted(rows, True) == 0.0 + 2.0 + 4.0 + 14.0  # a, a, a, then b
    borrowed_ir = _function_body(borrowed.inspect_llvm(borrowed.signatures[0]), "_switching_walk")
    counted_ir = _function_body(counted.inspect_llvm(counted.signatures[0]), "_switching_walk")
    assert "NRT_incref" in counted_ir and "NRT_decref" in counted_ir
    assert "NRT_incref" not in borrowed_ir and "NRT_decref" not in borrowed_ir


def _step_of(x, up):
    return x + 1 if up else x - 1


def test_a_kernel_called_with_constants_is_compiled_for_their_plain_types():
    """``core.jit.Kernel`` types a call from another kernel with the arguments' plain types: a callee
    given the constants 0 and True by one call and variables by another is compiled once, where numba's
    own ``njit`` compiles it twice (once for ``Literal[int](0)`` and ``Literal[bool](True)``)."""
    import numba

    for make, versions in ((njit(cache=False), 1), (numba.njit, 2)):
        callee = make(_step_of)

        def both(n):
            return callee(0, True) + callee(n, n > 2)

        assert make(both)(5) == 1 + 6
        assert len(callee.signatures) == versions, callee.signatures


def project_kernels() -> dict[str, Kernel]:
    """Every kernel defined in the kernel sources (the files the cache's key covers), by dotted name."""
    modules = [importlib.import_module(".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"))
               for path in source_files(ROOT, KERNEL_SOURCES, NOT_KERNEL_SOURCES)]
    return {f"{module.__name__}.{attr}": value for module in modules for attr, value in vars(module).items()
            if isinstance(value, Kernel) and value.py_func.__module__ == module.__name__}


def cached_signatures(kernel: Kernel) -> list[tuple]:
    """The argument types of every machine-code version of ``kernel`` in this source's cache."""
    return [key[0] for key in kernel._cache._cache_file._load_index()]  # numba's index: (signature, ...) keys


def test_no_kernel_is_compiled_for_a_literal_or_omitted_argument():
    """A constant passed from one kernel to another (an arena's or a player's row 0, a flag) would be a type
    of its own to numba, and compiling a kernel for it compiles every kernel below it again: the players'
    decision tree was compiled twice, and a fifth of a cold compile went to such versions (docs/design.md,
    "One version per type"). After the session's compile (conftest) no cached version of any kernel takes
    a literal argument (:class:`core.jit.Kernel` types them plainly) or an omitted one (callers pass
    every argument); Python's own calls never make either."""
    import numba

    configure_cache()
    cached = {name: cached_signatures(kernel) for name, kernel in project_kernels().items()
              if getattr(kernel._cache, "_cache_file", None) is not None}
    assert sum(1 for signatures in cached.values() if signatures) > 150  # the compile's kernels, read
    for name, signatures in cached.items():
        for signature in signatures:
            odd = [str(t) for t in signature if isinstance(t, (numba.types.Literal, numba.types.Omitted))]
            assert not odd, f"{name} compiled for {', '.join(odd)}"
