"""numba's compiled-kernel cache, keyed on the source of every kernel and everything it calls into.

numba's own ``cache=True`` checks only the timestamp of the file that defines a kernel: after an edit
to a file the kernel calls into (``agents/geometry.py`` under ``agents/kicks.py``, say) it would load
stale machine code. So every kernel module imports :func:`njit` from here, which first points numba's
cache at a directory named after a digest of the kernel packages' source (content, size and mtime of
every ``.py`` file of ``protocol``, ``core``, ``server``, ``agents``, ``runner/batched.py`` and the
``runner`` modules it imports, but the few that no kernel module imports, such as the server's socket
loop) and of the numba, llvmlite and Python versions and the CPU. Any change there selects a fresh
directory, so stale code can never run; the few most recently used directories are kept, older ones
deleted.

The directory lives under ``$NUMBA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/keepaway`` (default
``~/.cache/keepaway``). It also holds one marker per kernel set that ``keepaway compile`` has warmed
(:func:`is_warm`, :func:`mark_warm`), so a launcher can compile each kernel once before it starts the
processes that load them.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import sys
import tempfile
import time
from functools import lru_cache
from pathlib import Path
from types import CodeType, FunctionType

import llvmlite
import numba
import numba.core.config
import numpy as np
from llvmlite import binding as llvm_binding
from numba.core.registry import CPUDispatcher
from numba.core.types import unliteral
from numba.core.typing.typeof import Purpose, typeof

ROOT = Path(__file__).resolve().parent.parent
# Every file a kernel is defined in, calls into or reads a module-level value of: the kernel modules and
# every module they import, directly or through others (tests/test_kernel_cache.py checks it) ...
KERNEL_SOURCES = ("protocol", "core", "server", "agents", "runner/__init__.py", "runner/job.py", "runner/batched.py",
                  "rcss/param_text.py", "rcss/see_text.py")
# ... but these files of those packages, which no kernel module imports (socket loops, command lines,
# configuration, security): an edit there leaves the compiled kernels as they are. (The files that list
# the kernels a set compiles, server/game_log.py and agents/player.py, stay in: a new kernel call there
# warms the set anew.)
NOT_KERNEL_SOURCES = ("agents/cli.py", "core/exits.py", "core/log_limit.py", "protocol/arena.py",
                      "protocol/security.py", "server/app.py", "server/cli.py", "server/config.py", "server/intake.py",
                      "server/trace_replay.py")
KEEP_DIRECTORIES = 5  # the most recently used cache directories kept (a developer switching branches)
LAST_USED = "last-used"


def source_files(root: Path, entries: tuple[str, ...], excluded: tuple[str, ...] = ()) -> list[Path]:
    """The ``.py`` files of ``entries`` (packages or single files) under ``root`` but the ``excluded``
    ones, in a fixed order."""
    files: list[Path] = []
    for entry in entries:
        path = root / entry
        files.extend(sorted(path.rglob("*.py")) if path.is_dir() else [path])
    skip = {root / name for name in excluded}
    return [path for path in files if path not in skip]


def source_digest(root: Path, entries: tuple[str, ...], excluded: tuple[str, ...] = ()) -> str:
    """A digest of the source files of ``entries`` but the ``excluded`` (path, size, mtime and content of
    each) and of the compiler and machine that compile them."""
    digest = hashlib.sha256()
    for item in (numba.__version__, llvmlite.__version__, sys.version, platform.machine(),
                 llvm_binding.get_host_cpu_name()):
        digest.update(item.encode() + b"\0")
    for path in source_files(root, entries, excluded):
        stat = path.stat()
        digest.update(f"{path.relative_to(root)}\0{stat.st_size}\0{stat.st_mtime_ns}\0".encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


@lru_cache(maxsize=1)
def cache_key() -> str:
    """The digest of this installation's kernel sources (:data:`KERNEL_SOURCES`, :data:`NOT_KERNEL_SOURCES`)."""
    return source_digest(ROOT, KERNEL_SOURCES, NOT_KERNEL_SOURCES)


def cache_root() -> Path:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "keepaway"


@lru_cache(maxsize=1)
def cache_dir() -> Path:
    """This source's cache directory, created (and older ones pruned) on first use; under the system's
    temporary directory if the cache root cannot be written (a read-only home, say)."""
    try:
        return _open_cache_dir(cache_root())
    except OSError:
        return _open_cache_dir(Path(tempfile.gettempdir()) / f"keepaway-{os.getuid()}")


def _open_cache_dir(root: Path) -> Path:
    path = root / f"numba-{cache_key()}"
    if not path.exists():
        path.mkdir(parents=True, exist_ok=True)
        _prune(root, keep=path)
    (path / LAST_USED).touch()
    return path


def _prune(root: Path, keep: Path) -> None:
    """Delete all but the KEEP_DIRECTORIES most recently used cache directories."""
    def last_used(path: Path) -> float:
        try:
            return (path / LAST_USED).stat().st_mtime
        except OSError:
            return 0.0

    others = sorted((p for p in root.glob("numba-*") if p != keep and p.is_dir()), key=last_used, reverse=True)
    for stale in others[KEEP_DIRECTORIES - 1:]:
        shutil.rmtree(stale, ignore_errors=True)


def configure_cache() -> None:
    """Point numba's cache at :func:`cache_dir` (before any ``cache=True`` kernel is decorated)."""
    directory = str(cache_dir())
    if numba.core.config.CACHE_DIR != directory:
        numba.core.config.CACHE_DIR = directory


def _marker(kernel_set: str) -> Path:
    return cache_dir() / f"warm-{kernel_set}"


def is_warm(kernel_set: str) -> bool:
    """``kernel_set`` was compiled into this source's cache (:func:`mark_warm`)."""
    return _marker(kernel_set).exists()


def mark_warm(kernel_set: str, seconds: float) -> None:
    """Record that ``kernel_set`` is in the cache, and how long compiling it took."""
    _marker(kernel_set).write_text(f"{seconds:.1f} s compile, {time.strftime('%Y-%m-%d %H:%M:%S')}\n")


class Kernel(CPUDispatcher):
    """numba's dispatcher, except that a call from another kernel is typed with the arguments' plain types.

    numba types a constant argument (``0``, ``True``, a module's int constant) as a literal, a type of
    its own, and compiles the callee, and every kernel it calls with that argument, once more for it:
    the server's kernels called with arena 0, a player's with row 0 or with a flag. Typed as plain ints
    and bools, such calls share the version that variables and Python's own calls use (docs/design.md,
    "One version per type"). A kernel that needs a constant argument's value at compile time (to index a
    heterogeneous tuple, say) cannot be one of these; none here does. An omitted optional argument is
    still a type of its own (numba's ``Omitted``): callers pass every argument."""

    def get_call_template(self, args, kws):
        return super().get_call_template(tuple(unliteral(a) for a in args),
                                         {k: unliteral(v) for k, v in kws.items()})


def _kernel(function, options: dict, cache: bool):
    """``function`` as a :class:`Kernel` in numba's nopython mode (as ``numba.njit`` sets one up), with no
    C-callable wrapper (``no_cfunc_wrapper``): nothing takes a kernel's address, and writing and
    optimising one for every kernel is a part of every cold compile."""
    options = {"no_cfunc_wrapper": True, **options, "nopython": True, "boundscheck": None}

    def make(f):
        kernel = Kernel(py_func=f, locals={}, targetoptions=options)
        if cache:
            kernel.enable_caching()
        return kernel

    return make if function is None else make(function)


def njit(function=None, **options):
    """A :class:`Kernel` (``numba.njit``'s options) with its reference counting (NRT) on, stated rather than
    inherited: numba compiles a kernel that does not state it with the setting of the caller that first
    needs it, so a kernel that allocates would fail to compile under a :func:`borrowing` caller."""
    cache = options.pop("cache", False)
    return _kernel(function, {"_nrt": True, **options}, cache)


def borrowing(function=None, **options):
    """``njit(cache=True)`` without numba's reference counting, for the kernels that only borrow arrays.

    numba counts references to every array it takes out of a tuple or hands to a callee, with an atomic
    increment and decrement in a function of its runtime. The players' kernels pass records of dozens
    of arrays (``Belief``, ``ModelState``, ``Players``) down deep call chains, so in the batched mode
    these counts alone took about a fifth of the time (docs/design.md, "Compiled kernels"). A kernel
    compiled without them gives up nothing: every array it touches belongs to its caller for the whole
    call. Hence the rule for a borrowing kernel: it neither creates an array (nor copies into one from
    an array that may overlap it) nor keeps one that a callee created and returned; numba refuses the
    first at compile time, the second would leak. The kernels that allocate scratch arrays, and their
    direct callers when they return one, stay :func:`njit`. Results are the same to the last bit: only
    the bookkeeping goes."""
    cache = options.pop("cache", True)
    return _kernel(function, {**options, "_nrt": False}, cache)


# Argument types that a SteadyCall checks by type (numba types every value of one of these alike: a bytes
# object as a read-only buffer of uint8, whatever its length); any other argument (an array, a record, a
# tuple of arrays) it checks by identity.
_BY_TYPE = (bool, int, float, bytes, np.bool_, np.number)


class SteadyCall:
    """``kernel(*args)`` for a call site that passes the same arrays, records and tuples every time,
    without numba's typing of each argument at each call.

    numba's dispatcher types every argument of a call from Python before it picks the compiled code: for
    a NamedTuple of 21 arrays (a player's ``ModelState``) that alone takes about 5 us, and the players
    and the server of the embedded and distributed modes make a few dozen such calls per cycle, a
    quarter of the embedded mode's time (a ``py-spy`` profile). Here the first call goes through the
    dispatcher (types checked, the kernel compiled or loaded) and binds the compiled entry point of
    exactly those argument types; a later call whose arguments are the same objects (scalars and bytes: of
    the same Python type) calls that entry point directly, which unboxes them as the dispatcher's call does,
    so the kernel runs the same code on the same values. Any other call goes through the dispatcher and
    binds afresh. Binding keeps the arguments alive; an array must not change its dtype or number of
    dimensions in place (nothing here does).

    The test of a call is written out for each binding (:func:`_bound_call`), one ``is`` per argument:
    a loop over the arguments cost more than the entry point's call itself (1.8 against 0.4 us with
    eight arguments, 1.2 us written out)."""

    __slots__ = ("kernel", "_entry", "_call")

    def __init__(self, kernel) -> None:
        self.kernel = kernel
        self._entry = None
        self._call = self._unbound

    def __call__(self, *args):
        return self._call(args)

    def _unbound(self, args: tuple):
        result = self.kernel(*args)
        self._bind(args)
        return result

    def _bind(self, args: tuple) -> None:
        signature = tuple(typeof(arg, Purpose.argument) for arg in args)
        compiled = self.kernel.overloads.get(signature)
        if compiled is None:  # the dispatcher converted an argument: leave such calls to it
            self._entry, self._call = None, self._unbound
            return
        by_type = [isinstance(arg, _BY_TYPE) for arg in args]
        key = tuple(type(arg) if typed else arg for arg, typed in zip(args, by_type))
        self._entry = compiled.entry_point
        self._call = _bound_call(self._entry, key, by_type, self._unbound)  # its names keep the arguments alive


def _bound_call(entry, key: tuple, by_type: list[bool], unbound):
    """``call(args)``: ``entry(*args)`` if ``args`` are ``key``'s objects (where ``by_type``, of its
    types), else ``unbound(args)``; the tests in straight-line code, one per argument. The code is
    compiled once per pattern of tests (:func:`_call_code`); a binding only gives it its objects."""
    names = {"entry": entry, "unbound": unbound, **{f"k{i}": bound for i, bound in enumerate(key)}}
    return FunctionType(_call_code(len(key), tuple(by_type)), names)


@lru_cache(maxsize=None)
def _call_code(n: int, by_type: tuple[bool, ...]) -> CodeType:
    """The code of :func:`_bound_call`'s function for ``n`` arguments, tested by type where ``by_type``."""
    args = [f"a{i}" for i in range(n)]
    tests = [f"type({arg}) is k{i}" if typed else f"{arg} is k{i}" for i, (arg, typed) in enumerate(zip(args, by_type))]
    unpack = f"        ({', '.join(args)},) = args\n" if args else ""
    source = (f"def call(args):\n"
              f"    if len(args) == {n}:\n"
              f"{unpack}"
              f"        if {' and '.join(tests) or 'True'}:\n"
              f"            return entry(*args)\n"
              f"    return unbound(args)\n")
    module = compile(source, f"<SteadyCall of {n} arguments>", "exec")
    return next(const for const in module.co_consts if isinstance(const, CodeType))


configure_cache()

__all__ = ["Kernel", "SteadyCall", "borrowing", "cache_dir", "cache_key", "configure_cache", "is_warm", "mark_warm",
           "njit", "source_digest"]
