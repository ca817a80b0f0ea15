"""Compile each set of numba kernels once, before the processes that use them start.

Five player processes and a server started on a cold cache would each compile the same kernels at the
same time (about 5 x 50 + 20 CPU-seconds on a 2-core machine). Instead a launcher calls
:func:`ensure_compiled` first: it compiles every kernel set that this version of the source has not
compiled yet, each in its own ``keepaway compile --only SET`` process (independent sets side by side),
under a lock so that concurrent launchers compile once between them; the processes started afterwards
load the kernels from the cache (``core.jit``) in about a second each.

``core.jit`` (which loads numba, a third of a second) is imported inside the functions that need it: the
command line imports this module for :data:`KERNEL_SETS` and must start without numba.
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

from keepaway.runner.launch import die_with_parent, keepaway_argv

# The players' kernels are two sets, their percepts' and their decisions' (agents.player.compile_kernels'
# halves): compiled side by side, the decisions' process loads most of the kernels the two share (the frame
# reader and the world model under it) from the cache once the percepts' process has written them.
SERVER, PERCEPTS, DECISIONS, BATCHED = "server", "percepts", "decisions", "batched"
PLAYER_SETS = (PERCEPTS, DECISIONS)
KERNEL_SETS = (SERVER, *PLAYER_SETS, BATCHED)
# Sets compiled side by side first, then the rest (the batched loop calls into the other sets' kernels,
# which it then loads instead of compiling them again).
STAGES = ((SERVER, *PLAYER_SETS), (BATCHED,))
# Seconds each set takes to compile on the project's 2-core machine: the four compiled one after another in
# one process on 2026-11-29, each loading what the sets before it had compiled (a fresh `keepaway compile`
# that hour, the first three side by side: 86 s, then the batched set 19 s). The machine's speed varies by
# half, so these are only for telling the user roughly how long the first run waits.
COMPILE_S = {SERVER: 52.0, PERCEPTS: 46.0, DECISIONS: 60.0, BATCHED: 19.0}


class CompileError(RuntimeError):
    """A kernel set did not compile; the message names it and its log."""


def compile_set(kernel_set: str) -> float:
    """Compile (or load) every kernel of ``kernel_set`` in this process; mark it warm; return seconds."""
    start = time.perf_counter()
    if kernel_set == SERVER:
        from keepaway.protocol.params import parameter_set
        from keepaway.server.game_log import compile_kernels

        compile_kernels(parameter_set("classic"), 3, 2)
    elif kernel_set in PLAYER_SETS:
        from keepaway.agents.player import compile_kernels

        compile_kernels(percepts=kernel_set == PERCEPTS, decisions=kernel_set == DECISIONS)
    elif kernel_set == BATCHED:
        _compile_batched()
    else:
        raise ValueError(f"unknown kernel set {kernel_set!r}; choose from {', '.join(KERNEL_SETS)}")
    seconds = time.perf_counter() - start
    from keepaway.core.jit import mark_warm

    mark_warm(kernel_set, seconds)
    return seconds


def _compile_batched() -> None:
    """The batched mode's kernels, with every Pass and GetOpen code path a training uses."""
    from keepaway.agents.getopen import net_size
    from keepaway.agents.state_vars import getopen_state_size
    from keepaway.protocol.params import parameter_set
    from keepaway.runner.batched import BatchedArenas

    theta = np.zeros(net_size(getopen_state_size(3, 2)))
    arenas = BatchedArenas(parameter_set("classic"), 2, 0, pass_policy="learned", getopen_policy="learned",
                           getopen_theta=theta, threads=1)
    arenas.run(total_episodes=2)
    arenas.load_pass_arrays(arenas.pass_policy_arrays()[0])
    arenas.set_pass_mode("greedy")
    arenas.run(total_episodes=2)


def kernel_sets(mode: str) -> tuple[str, ...]:
    """The kernel sets that the arenas of ``mode`` use where they run: the server's and the players' (in
    their processes or, embedded, in this one), and for the batched mode the batched loop as well. The
    loop calls most of the server's and the players' kernels: compiled first, side by side, they leave it
    little of its own (a cold compile on 2026-11-29: every set by stages 110 s, the batched set alone in
    one process 133 s)."""
    return KERNEL_SETS if mode == "batched" else (SERVER, *PLAYER_SETS)


def missing(kernel_sets: Sequence[str]) -> list[str]:
    from keepaway.core.jit import is_warm

    return [s for s in KERNEL_SETS if s in kernel_sets and not is_warm(s)]


def estimate_s(kernel_sets: Sequence[str]) -> float:
    """Rough wall-clock seconds to compile ``kernel_sets`` as :func:`ensure_compiled` does: a stage's
    processes share the cores (while they outnumber the cores, each has a share of one), and none ends
    before its own set is compiled."""
    cores = os.cpu_count() or 1
    total = 0.0
    for stage in STAGES:
        costs = [COMPILE_S[s] for s in stage if s in kernel_sets]
        if costs:
            total += max(max(costs) * max(1.0, len(costs) / cores), sum(costs) / cores)
    return total


def _describe(seconds: float) -> str:
    """``seconds`` to the nearest half minute, at least a minute."""
    halves = max(2, round(seconds / 30))
    return "about a minute" if halves == 2 else f"about {halves / 2:g} min"


@contextmanager
def _compile_lock() -> Iterator[None]:
    from keepaway.core.jit import cache_dir

    with open(cache_dir() / "compile.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def ensure_compiled(kernel_sets: Sequence[str], announce: Callable[[str], None] | None = None,
                    log_dir: Path | None = None) -> list[str]:
    """Compile the sets of ``kernel_sets`` that this source has not compiled yet (each once, in
    ``keepaway compile`` processes, independent sets side by side); return those compiled. ``announce``
    gets one line saying what happens and roughly how long it takes. Raises CompileError in one line."""
    from keepaway.core.jit import cache_dir

    todo = missing(kernel_sets)
    if not todo:
        return []
    with _compile_lock():
        todo = missing(kernel_sets)  # another launcher may have compiled them meanwhile
        if not todo:
            return []
        if announce is not None:
            announce(f"compiling the simulation kernels ({', '.join(todo)}) once for this version of keepaway, "
                     f"{_describe(estimate_s(todo))}; later runs load them from {cache_dir()}")
        logs = log_dir or cache_dir()
        logs.mkdir(parents=True, exist_ok=True)
        for stage in STAGES:
            _compile_side_by_side([s for s in stage if s in todo], logs)
    return todo


def _compile_side_by_side(kernel_sets: list[str], logs: Path) -> None:
    running = []
    for kernel_set in kernel_sets:
        log = logs / f"compile-{kernel_set}.log"
        with open(log, "wb") as stderr:
            proc = subprocess.Popen(keepaway_argv("compile", "--only", kernel_set, "--quiet"),
                                    stdout=subprocess.DEVNULL, stderr=stderr, stdin=subprocess.DEVNULL,
                                    preexec_fn=die_with_parent if sys.platform == "linux" else None)
        running.append((kernel_set, proc, log))
    try:
        for kernel_set, proc, log in running:
            if proc.wait() != 0:
                tail = log.read_text(errors="replace").strip().splitlines()[-1:] or ["no output"]
                raise CompileError(f"compiling the {kernel_set} kernels failed (exit {proc.returncode}): "
                                   f"{tail[0]}; see {log}")
    finally:
        for _, proc, _ in running:
            if proc.poll() is None:
                proc.kill()
                proc.wait()


__all__ = ["KERNEL_SETS", "CompileError", "compile_set", "ensure_compiled", "estimate_s", "kernel_sets"]
