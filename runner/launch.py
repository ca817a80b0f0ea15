"""Starting a whole distributed arena (server, coach, keepers, takers) as separate processes.

Every process gets its own session so the whole arena can be stopped at once; a process that dies is
named in one line; nothing is left running whatever happens (docs/design.md, "Processes and sockets"): on Linux each
process also gets SIGTERM when the process that started it dies, even by SIGKILL.

A synchronous arena's processes run under Linux's ``SCHED_BATCH`` policy (docs/design.md, "Processes
and sockets"): each message wakes its receiver (a player, or a ZeroMQ I/O thread), which otherwise
preempts the sender at once; on a machine with fewer cores than processes the server was switched out
about 30 times a cycle, and every switch costs the caches. Batch tasks do not preempt on wake-up, so
the server sends a cycle's percepts in one go and the players then run. Time slices and fairness are
the same; only a real-time arena, which keeps wall-clock deadlines, is left as it is.

On Linux the players are forked rather than started: a player process used to spend about 2.5 s of CPU
importing its modules and loading its compiled kernels (numba's first cache load imports scipy for its
BLAS check), five times an arena. A fork server (``multiprocessing``'s, started once
per launcher) imports them and loads the kernels once (:mod:`runner.player_preload`); each player is a
fork of it that runs the ``keepaway player`` command line as a process of its own, in its own session
and with its own log, as a started one would (docs/design.md, "Processes and sockets").
"""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.connection
import multiprocessing.forkserver
import multiprocessing.util
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

LISTEN_RE = re.compile(r"players=(tcp://\S+) coach=(tcp://\S+) monitor=(tcp://\S+)")
ARENA_RE = re.compile(r"arena=(tcp://\S+)")
VIEW_RE = re.compile(r"keepaway view: (http://\S+)")
PR_SET_PDEATHSIG, PR_SET_NAME = 1, 15  # linux/prctl.h
# A clean exit (code 0) before the run has finished counts as a death once the server has gone on
# running this long after it: players and coach exit 0 when the server shuts down, a moment before the
# server's own process is gone.
CLEAN_EXIT_GRACE_S = 10.0


class ArenaFailure(RuntimeError):
    """A process of the arena died or could not start; the message names it."""


class ForkedProcess:
    """A player forked by the fork server (module docstring), behind the part of ``subprocess.Popen``
    that :class:`ArenaProcesses` and its callers use: ``pid`` (also its session's id), ``returncode``
    (negative: the signal that killed it), ``poll``, ``wait``, ``send_signal``, ``terminate``, ``kill``."""

    stdout = None

    def __init__(self, process: multiprocessing.process.BaseProcess) -> None:
        self._process = process
        self.pid: int = process.pid

    @property
    def returncode(self) -> int | None:
        return self._process.exitcode

    def poll(self) -> int | None:
        return self._process.exitcode

    def wait(self, timeout: float | None = None) -> int:
        self._process.join(timeout)
        if self._process.exitcode is None:
            raise subprocess.TimeoutExpired(f"player {self.pid}", timeout)
        return self._process.exitcode

    def send_signal(self, sig: int) -> None:
        if self._process.exitcode is None:
            os.kill(self.pid, sig)

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


@dataclass
class Member:
    """One process of the arena."""

    name: str
    proc: subprocess.Popen | ForkedProcess

    def describe_exit(self) -> str:
        code = self.proc.returncode
        how = (f"was killed by {signal.Signals(-code).name}" if code is not None and code < 0
               else f"exited with code {code}")
        return f"{self.name} (pid {self.proc.pid}) {how}"


def keepaway_argv(*args: str) -> list[str]:
    """Run the ``keepaway`` CLI with this interpreter (no dependence on PATH). ``-P``: the current
    directory is not put first on the child's ``sys.path``, so a user's own ``keepaway.py`` (or any module
    there) cannot stand in for the installed package."""
    return [sys.executable, "-P", "-m", "keepaway", *args]


@dataclass(frozen=True)
class ArenaEndpoints:
    """Where an arena's server listens, and its coach's arena port if it serves trainers."""

    players: str
    coach: str
    monitor: str
    arena: str | None = None


@dataclass
class ArenaProcesses:
    """The processes of one arena; use as a context manager so they are always stopped."""

    log_dir: Path
    batch_scheduled: bool = False  # start the members under SCHED_BATCH (module docstring)
    members: list[Member] = field(default_factory=list)
    _clean_exit_seen: dict[str, float] = field(default_factory=dict)

    def __enter__(self) -> "ArenaProcesses":
        self.log_dir.mkdir(parents=True, exist_ok=True)
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self, name: str, argv: list[str], capture_stdout: bool = False, cwd: Path | None = None) -> Member:
        """Start ``argv`` as member ``name`` (in ``cwd`` if given: a program that writes beside itself)."""
        stderr = open(self.log_dir / f"{name.replace(' ', '_')}.log", "ab")  # a resumed run appends
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE if capture_stdout else subprocess.DEVNULL,
                                stderr=stderr, start_new_session=True, cwd=cwd,
                                preexec_fn=child_setup(self.batch_scheduled))
        stderr.close()
        member = Member(name, proc)
        self.members.append(member)
        return member

    def start_player(self, name: str, args: list[str]) -> Member:
        """Start ``keepaway player ARGS`` as member ``name``: forked from the players' fork server on
        Linux (module docstring), else as :meth:`start` starts a process."""
        if not forking_players():
            return self.start(name, keepaway_argv("player", *args))
        log = self.log_dir / f"{name.replace(' ', '_')}.log"
        process = _players_fork_server().Process(
            target=_forked_player, args=(name, args, str(log), dict(os.environ), self.batch_scheduled),
            name=name, daemon=True)
        process.start()
        member = Member(name, ForkedProcess(process))
        self.members.append(member)
        return member

    def member(self, name: str) -> Member:
        return next(member for member in self.members if member.name == name)

    def start_server(self, server_args: list[str], timeout_s: float = 120.0) -> tuple[Member, str, str, str]:
        """Start ``keepaway server`` on free ports and return it with its three endpoints."""
        member = self.start("server", keepaway_argv("server", "--players-port", "0", "--coach-port", "0",
                                                    "--monitor-port", "0", *server_args), capture_stdout=True)
        match = self.announced(member, LISTEN_RE, timeout_s)
        return member, match.group(1), match.group(2), match.group(3)

    def start_arena(self, server_args: list[str], player_args: list[str], keepers: int, takers: int,
                    arena_host: str | None = None, keys: Path | None = None) -> ArenaEndpoints:
        """A whole arena: the server on free ports, its coach (serving trainers on a free port of
        ``arena_host`` if given, the game paused until the first request) and ``keepers`` + ``takers``
        players, each with ``player_args``; with ``keys`` every process uses that keys directory
        (``protocol.security``)."""
        secured = ["--keys", str(keys)] if keys is not None else []
        if forking_players():  # the fork server loads the players' kernels while the server starts
            _players_fork_server()
            multiprocessing.forkserver.ensure_running()
        _, players, coach, monitor = self.start_server([*server_args, *secured])
        arena = None
        if arena_host is None:
            self.start("coach", keepaway_argv("coach", "--server", coach, *secured))
        else:
            member = self.start("coach", keepaway_argv("coach", "--server", coach, "--arena-port", "0",
                                                       "--host", arena_host, "--idle", *secured),
                                capture_stdout=True)
            arena = self.announced(member, ARENA_RE, 120.0).group(1)
        for team, count in (("keepers", keepers), ("takers", takers)):
            for i in range(1, count + 1):
                self.start_player(f"{team[:-1]} {i}",
                                  ["--team", team, "--server", players, *player_args, *secured])
        return ArenaEndpoints(players, coach, monitor, arena)

    def announced(self, member: Member, pattern: re.Pattern, timeout_s: float) -> re.Match:
        """The first line of ``member``'s stdout matching ``pattern`` (its endpoints)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            line = member.proc.stdout.readline().decode()
            match = pattern.search(line)
            if match:
                return match
            if not line and member.proc.poll() is not None:
                break
        member.proc.poll()
        log = self.log_dir / f"{member.name}.log"
        raise ArenaFailure(f"the {member.name} did not start: {member.describe_exit()}; see {log}")

    def first_death(self, run_finished: Callable[[], bool], grace_s: float = CLEAN_EXIT_GRACE_S) -> Member | None:
        """A member that died: any non-zero exit, or a clean exit before the run has finished while the
        server keeps running ``grace_s`` seconds longer. Players and the coach exit cleanly when the
        server shuts down, which it does once the run is finished (``run_finished()``, asked only when a
        clean exit is seen): such an exit is never a death, however slowly the server then stops."""
        now = time.monotonic()
        server_running = any(mem.name == "server" and mem.proc.poll() is None for mem in self.members)
        for member in self.members:
            code = member.proc.poll()
            if code is None:
                continue
            if code != 0:
                return member
            if (server_running and now - self._clean_exit_seen.setdefault(member.name, now) > grace_s
                    and not run_finished()):
                return member
        return None

    def wait_all(self, timeout_s: float) -> list[Member]:
        """Wait for every member to exit; return those that did not exit cleanly (code != 0)."""
        deadline = time.monotonic() + timeout_s
        bad = []
        for member in self.members:
            try:
                member.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                bad.append(member)
                continue
            if member.proc.returncode != 0:
                bad.append(member)
        return bad

    def stop(self) -> None:
        """SIGTERM every member's session, then SIGKILL what is left after a grace period."""
        for member in self.members:
            if member.proc.poll() is None:
                _signal_group(member.proc, signal.SIGTERM)
        deadline = time.monotonic() + 5.0
        for member in self.members:
            try:
                member.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                _signal_group(member.proc, signal.SIGKILL)
                member.proc.wait()
            if member.proc.stdout is not None:
                member.proc.stdout.close()


def child_setup(batch_scheduled: bool) -> Callable[[], None] | None:
    """What a child runs before exec on Linux (None elsewhere): :func:`die_with_parent`, and with
    ``batch_scheduled`` the ``SCHED_BATCH`` policy (module docstring). The policy is a hint: a system
    that refuses it runs the process as it would have run anyway."""
    if sys.platform != "linux":
        return None

    def setup() -> None:
        die_with_parent()
        if batch_scheduled:
            try:
                os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
            except OSError:
                pass

    return setup


def die_with_parent() -> None:
    """In the child, before exec: ask Linux for SIGTERM when the parent dies."""
    _prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def _prctl(option: int, arg: int | bytes) -> None:
    """Linux's prctl(2) on this process."""
    ctypes.CDLL(None, use_errno=True).prctl(option, arg)


def forking_players() -> bool:
    """Whether players are forked from the fork server (module docstring): on Linux, unless
    ``KEEPAWAY_FORK_PLAYERS=0`` asks for started processes, and only where the fork server listens on a
    file only this user may open (Python 3.11.0 used Linux's abstract socket namespace, which any local
    user can connect to and have the server fork what it is sent: CVE-2022-42919)."""
    if sys.platform != "linux" or os.environ.get("KEEPAWAY_FORK_PLAYERS", "1") == "0":
        return False
    address = multiprocessing.connection.arbitrary_address("AF_UNIX")
    return not multiprocessing.util.is_abstract_socket_namespace(address)


def _players_fork_server() -> multiprocessing.context.ForkServerContext:
    """multiprocessing's fork-server context, preloading the players' modules and kernels."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["keepaway.runner.player_preload"])
    return context


def _forked_player(name: str, args: list[str], log: str, environ: dict[str, str], batch_scheduled: bool) -> None:
    """A forked player (module docstring): set up as :meth:`ArenaProcesses.start` sets up a started
    process (its own session, SIGTERM when its parent, the fork server, dies, which it does when the
    launcher does; the launcher's environment; stderr appended to ``log``; stdin and stdout
    ``/dev/null``; ``SCHED_BATCH`` if asked), then the ``keepaway player`` command line. It keeps the
    fork server's command line, so it takes its member ``name`` ("taker 2") as its process name, which
    ``ps -o comm`` and ``top`` show. It closes every file it inherited: among them multiprocessing's
    pipe that keeps the fork server running while any fork holds it, which would keep the server, and
    with it the player's SIGTERM on its death, waiting for the player after the launcher has died."""
    os.closerange(3, os.sysconf("SC_OPEN_MAX"))
    os.setsid()
    child_setup(batch_scheduled)()
    _prctl(PR_SET_NAME, name.encode()[:15])
    os.environ.clear()
    os.environ.update(environ)
    null = os.open(os.devnull, os.O_RDWR)
    stderr = os.open(log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    for fd, target in ((0, null), (1, null), (2, stderr)):
        os.dup2(target, fd)
    os.close(null)
    os.close(stderr)
    from keepaway.agents.cli import player_command

    player_command.main(args=args, prog_name="keepaway player")


def interrupt_on_sigterm() -> None:
    """Treat SIGTERM like Ctrl-C (KeyboardInterrupt), so a terminated run or training stops its arenas
    and keeps what it has written."""
    signal.signal(signal.SIGTERM, signal.default_int_handler)


def _signal_group(proc: subprocess.Popen, sig: signal.Signals) -> None:
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        pass
