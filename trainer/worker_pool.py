"""Worker processes of ``keepaway experiment --workers``: tasks run in spawned processes, a few at once,
and an error or an interruption stops them all, each keeping what it wrote (docs/design.md, "Interrupts
and exit codes").

A worker's signal handler raises KeyboardInterrupt once, and never where Python or numba would drop it or
be left half-made (:func:`_in_unsafe_code`): there the interrupt is delivered again a moment later.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as ready_connections
from multiprocessing.process import BaseProcess
from typing import Any, TypeVar

import llvmlite
import numba

log = logging.getLogger("keepaway.experiment")

R = TypeVar("R")


def run_in_processes(tasks: Sequence[tuple[str, Callable[[], R]]], workers: int,
                     on_result: Callable[[R], None]) -> dict[str, R]:
    """Run ``tasks`` (each a name and a picklable callable) in up to ``workers`` processes at once, started
    in the order given, and pass each result to ``on_result`` as it ends; the results by name.

    Workers are spawned (numba's threads do not survive a fork). A worker's error is raised here after
    the others have been interrupted (SIGINT: they keep their checkpoints, as Ctrl-C does); so is an
    interruption of this process. An interrupted worker that ends otherwise than interrupted (its own
    error, or no result: killed, crashed) is named in a warning, with its exit code, since its last
    checkpoint or timing record may then be missing."""
    waiting = list(tasks)
    context = multiprocessing.get_context("spawn")
    # a worker's end of its pipe -> (the worker, its task's name)
    running: dict[Connection, tuple[BaseProcess, str]] = {}
    done: dict[str, R] = {}
    try:
        while waiting or running:
            while waiting and len(running) < workers:
                name, task = waiting.pop(0)
                receive, send = context.Pipe(duplex=False)
                process = context.Process(target=_worker, args=(send, task), name=name)
                process.start()
                send.close()
                running[receive] = (process, name)
            for receive in ready_connections(list(running)):
                process, name = running.pop(receive)
                try:
                    outcome = receive.recv()
                except EOFError:  # it died without a word (killed, out of memory)
                    process.join()
                    outcome = RuntimeError(f"the worker process of {name} ended with exit code {process.exitcode} "
                                           f"and no result")
                process.join()
                if isinstance(outcome, BaseException):
                    raise outcome
                done[name] = outcome
                on_result(outcome)
    finally:
        for process, _ in running.values():
            if process.is_alive():
                os.kill(process.pid, signal.SIGINT)
        for receive, (process, name) in running.items():
            _join_interrupted(receive, process, name)
    return done


def _join_interrupted(receive: Connection, process: BaseProcess, name: str) -> None:
    """Wait for a worker of :func:`run_in_processes` that was told to stop (its result read first, so a
    worker never waits on a full pipe), and warn if it did not end as interrupted or finished. A worker
    that SIGINT ended before it set its handler (exit code -SIGINT, no result) had not begun its work."""
    try:
        outcome: Any = receive.recv()
    except EOFError:
        outcome = None
    process.join()
    if (outcome is None and process.exitcode != -signal.SIGINT) or (
            isinstance(outcome, BaseException) and not isinstance(outcome, KeyboardInterrupt)):
        ending = "no result" if outcome is None else f"{type(outcome).__name__}: {outcome}"
        log.warning("keepaway experiment: the interrupted worker of %s ended with exit code %s and %s",
                    name, process.exitcode, ending)


def _worker(send: Connection, task: Callable[[], Any]) -> None:
    """A worker process of :func:`run_in_processes`: one task, its result or its exception sent back.
    The first SIGINT or SIGTERM interrupts it (Ctrl-C reaches it from the terminal and from the parent);
    later ones are ignored, so it still writes its checkpoint and timing.

    tqdm's bars (hidden here) share a lock across processes by default, a semaphore that an interruption
    can leave to multiprocessing's resource tracker, which then warns after our last line; a worker
    draws nothing, so a thread lock does.

    A parent that dies without interrupting it (killed, out of memory) sends it SIGTERM through Linux's
    parent-death signal, so no worker goes on training alone (a CI run left two doing so for minutes)."""
    from tqdm import tqdm

    from keepaway.runner.launch import die_with_parent

    tqdm.set_lock(threading.RLock())
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _interrupt_once)
    die_with_parent()
    parent = multiprocessing.parent_process()
    try:
        if parent is not None and os.getppid() != parent.pid:  # the parent died before the request
            raise KeyboardInterrupt
        outcome: Any = task()
    except BaseException as exc:  # noqa: BLE001 - every ending, Ctrl-C included, is reported to the parent
        outcome = exc
    send.send(outcome)
    send.close()


def _interrupt_once(signum: int, frame: Any) -> None:
    if _in_unsafe_code(frame):  # raised there, it would be dropped or break numba: deliver it again soon
        threading.Timer(0.05, os.kill, (os.getpid(), signum)).start()
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise KeyboardInterrupt


# numba's and llvmlite's code (their package directories)
_NUMBA_CODE = tuple(os.path.dirname(module.__file__) + os.sep for module in (numba, llvmlite))


def _in_unsafe_code(frame: Any) -> bool:
    """Whether ``frame`` runs where an interrupt must not be raised:
    - inside numba or llvmlite, which a worker's first calls of its kernels go through (loading them
      from the cache; numba's own registries on its first load). Interrupted there, numba keeps half-made
      state: a later kernel call failed with "duplicate registration" in a test, and in a CI run a
      worker died of SIGSEGV at its next kernel's first call and never wrote its timing. This also
      covers llvmlite's object-cache hooks, ctypes callbacks that print an exception raised in them and
      go on;
    - in any finalizer (``__del__``; Python prints "Exception ignored in" and goes on: a CI run lost a
      worker's interrupt in llvmlite's ``ObjectRef.__del__``, and the worker trained on).
    The worker's kernels are compiled before it starts (``prepare_kernels``), so loading them is a
    matter of seconds, and so is the interrupt's delay."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.startswith(_NUMBA_CODE):
            return True
        frame = frame.f_back
    return False


__all__ = ["run_in_processes"]
