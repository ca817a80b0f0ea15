"""Arenas on a Ray cluster: ``keepaway train|evaluate|experiment --mode distributed --backend ray`` and
``keepaway run --backend ray`` (``pip install 'keepaway[ray]'``).

Ray only places the arenas. Each arena of a trainer is a Ray actor that starts the arena's processes
(server, coach, five players) on its node exactly as the local backend does, with the coach's arena
port bound on the node's address; the trainer then drives every arena over ZeroMQ like any other
(``runner.distributed``). So results do not depend on where the arenas run. Every node needs this
package installed (same version), and the trainer must reach the nodes' ports. The default backend
needs no Ray; this module imports it only when asked.

``keepaway run``'s arena is an actor too (:class:`RunHost`), which plays the run on its node as ``keepaway
run`` plays it here (``runner.run.distributed_episodes``): the same processes, seed and logs, so the
same games. Nothing of it listens beyond the node's loopback; the episodes, one-line notes and the logs
as they grow come back through Ray (:func:`ray_run`), into the run's ``--out`` (:class:`LogMirror`).

Every actor's constructor only keeps its arguments (a run's starts its thread), so an actor is ready as
soon as Ray has placed it; a cluster with no free CPU leaves it waiting, which the command says in one
line instead of falling silent (:func:`wait_placed`).
"""

from __future__ import annotations

import logging
import os
import re
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

from keepaway.protocol.endpoints import parse_endpoint
from keepaway.runner.distributed import ARENA_PLAYER_ARGS, DistributedBackend, arena_server_args, dead_process
from keepaway.runner.job import Game
from keepaway.runner.kernels import CompileError, ensure_compiled, kernel_sets
from keepaway.runner.launch import ArenaFailure, ArenaProcesses
from keepaway.runner.run import Elsewhere, Ended, RunOptions, distributed_episodes
from keepaway.server.episode_log import set_aside

ARENA_CPUS = 1.0  # a synchronous arena's seven processes mostly wait for one another


class ArenaHost:
    """The actor behind one arena: starts its processes on the node it lands on and stops them."""

    def __init__(self, game: Game, parameter_set: str, index: int, keys: Path | None = None) -> None:
        self.game, self.parameter_set, self.keys = game, parameter_set, keys
        self.log_dir = Path(tempfile.mkdtemp(prefix=f"keepaway-arena-{index:02d}-"))
        self.processes = ArenaProcesses(self.log_dir, batch_scheduled=True)  # a synchronous arena

    def start(self) -> str:
        """Start the arena's processes; its coach's arena endpoint, bound on the node's address."""
        import ray

        game = self.game
        self.processes.__enter__()
        try:
            endpoints = self.processes.start_arena(arena_server_args(game, self.parameter_set, self.log_dir),
                                                   list(ARENA_PLAYER_ARGS), game.keepers, game.takers,
                                                   arena_host=ray.util.get_node_ip_address(), keys=self.keys)
        except BaseException:
            self.processes.stop()
            raise
        return endpoints.arena

    def death(self) -> str | None:
        """The first of the arena's processes that died, in one line with the node and directory of its
        logs (``runner.distributed.dead_process``), or None."""
        import ray

        return dead_process(self.processes, f"{ray.util.get_node_ip_address()}:")

    def stop(self) -> None:
        self.processes.stop()


def watcher(ray, host) -> Callable[[], str | None]:
    """An ``Arena.watch`` for the arena of the actor ``host``: whether one of its processes died
    (``ArenaHost.death``), or the actor itself (its node gone, say)."""

    def watch() -> str | None:
        try:
            return ray.get(host.death.remote())
        except ray.exceptions.RayActorError as exc:
            return f"the Ray actor that started it died: {error_line(exc, last=False)}"

    return watch


def error_line(exc: BaseException, last: bool) -> str:
    """The first or ``last`` non-empty line of a Ray error (whose traceback text carries terminal colours),
    without the colours."""
    lines = [line.strip() for line in re.sub(r"\x1b\[[0-9;]*m", "", str(exc)).splitlines() if line.strip()]
    return (lines[-1] if last else lines[0]) if lines else type(exc).__name__


# After how long without every actor placed the command says it is waiting for the cluster (s).
PLACEMENT_NOTICE_S = 10.0


def wait_placed(ray, ready: list, what: str, announce: Callable[[str], None] | None) -> None:
    """Wait until Ray has placed the actors whose ``__ray_ready__`` answers are ``ready`` (``what`` names
    one of them in the notices: "arena"). If some are still waiting after PLACEMENT_NOTICE_S (a cluster
    without ARENA_CPUS free for each), ``announce`` says so in one line with the cluster's CPUs, and again
    once they are placed; it waits however long that takes (Ctrl-C gives up). Raises ArenaFailure in one
    line if an actor could not be created (its error's last line: on a node without this package, the
    missing module)."""
    start = time.monotonic()
    _, waiting = ray.wait(ready, num_returns=len(ready), timeout=PLACEMENT_NOTICE_S)
    them = f"the {what}" if len(ready) == 1 else f"the {len(ready)} {what}s"
    if waiting and announce is not None:
        cpus, free = ray.cluster_resources().get("CPU", 0.0), ray.available_resources().get("CPU", 0.0)
        some = them if len(waiting) == len(ready) else f"{len(waiting)} of {them}"
        announce(f"the Ray cluster has not placed {some} after {PLACEMENT_NOTICE_S:g} s: each {what} needs "
                 f"{ARENA_CPUS:g} CPU, the cluster has {cpus:g} ({free:g} free); waiting (Ctrl-C gives up)")
    try:
        ray.get(ready)
    except ray.exceptions.RayActorError as exc:
        raise ArenaFailure(f"Ray could not create the {what} on its node: {error_line(exc, last=True)}; every "
                           "node needs this version of keepaway installed (pip install 'keepaway[ray]')") from None
    if waiting and announce is not None:
        announce(f"the Ray cluster placed {them} after {time.monotonic() - start:.0f} s")


def stop_actors(ray, hosts: list, ready: list) -> None:
    """Stop the actors of ``hosts`` that Ray placed (``ready``: their ``__ray_ready__`` answers), waiting
    for their ``stop``, then end every one: an actor still waiting for a CPU is only cancelled (asking it
    to stop would wait for its placement), and one that failed is not waited for."""
    placed = set(ray.wait(ready, num_returns=len(ready), timeout=0)[0])
    stops = [host.stop.remote() for host, answer in zip(hosts, ready) if answer in placed]
    if stops:
        ray.wait(stops, num_returns=len(stops))
    for host in hosts:
        ray.kill(host)


Launcher = Callable[[Game, str, int, int], DistributedBackend]


def ray_launcher(address: str | None = None, keys: Path | None = None,
                 announce: Callable[[str], None] | None = None) -> Launcher:
    """A ``launcher`` for ``runner.backends.open_backend``: joins the Ray cluster at ``address`` (None:
    ``RAY_ADDRESS`` or a new local Ray); ``launch(game, parameter_set, arenas, chunk_episodes)`` places that
    many arenas of ``game`` on it (jobs cut into chunks of ``chunk_episodes``), with ``keys`` (a keys
    directory at that path on every node) over CURVE, telling ``announce`` in one line while the cluster
    has no CPU for some (:func:`wait_placed`). Raises RuntimeError in one line when Ray is not installed
    or the cluster cannot be joined (:func:`join_ray`)."""
    ray = join_ray(address, announce)

    def launch(game: Game, parameter_set: str, arenas: int, chunk_episodes: int) -> DistributedBackend:
        actor = ray.remote(num_cpus=ARENA_CPUS)(ArenaHost)
        hosts = [actor.remote(game, parameter_set, i, keys) for i in range(arenas)]
        ready = [host.__ray_ready__.remote() for host in hosts]

        def stop_hosts() -> None:
            stop_actors(ray, hosts, ready)

        try:
            wait_placed(ray, ready, "arena", announce)
            endpoints = ray.get([host.start.remote() for host in hosts])
            for i, endpoint in enumerate(endpoints):  # else each request would wait ATTACHED_TIMEOUT_S
                if (why := unreachable(*parse_endpoint(endpoint))) is not None:
                    raise ArenaFailure(f"arena {i} ({endpoint}): this machine cannot reach its port: {why}; the "
                                       "trainer must reach the ports of every Ray node (a firewall between them?)")
        except BaseException:
            stop_hosts()
            raise
        backend = DistributedBackend.attach(game, endpoints, chunk_episodes, keys=keys)
        for arena, host in zip(backend.arenas, hosts):
            arena.watch = watcher(ray, host)
        backend.on_close = stop_hosts
        return backend

    return launch


def _import_ray():
    """The ray module, or RuntimeError in one line when it is not installed."""
    try:
        import ray
    except ImportError:
        raise RuntimeError("--backend ray needs Ray: pip install 'keepaway[ray]'") from None
    return ray


# How long a driver's request for news waits on the node before it answers with none (s): episodes
# reach the progress bar this soon, and a Ctrl-C on the driver is seen at least this often.
NEWS_WAIT_S = 0.5
LOG_PIECE = 1 << 23  # bytes of the logs brought back from the node at a time
LOG_COPY_EVERY_S = 1.0  # how often the driver copies what the logs on the node have grown by
POLICY_NAME = "policy.npz"  # the run's policy file, as the node's players read it (beside, not in, its logs)


class LogPiece(NamedTuple):
    """Bytes of a run's file on its node, from ``offset``."""

    name: str  # relative to the run's --out
    offset: int
    data: bytes


class RunHost:
    """The actor behind ``keepaway run --backend ray``: plays the run's arena on the node it lands on
    (module docstring) in a thread of its own, compiling the kernels there first if the node lacks
    them, and keeps what the driver asks for: the episodes as they end, with the node's time of each,
    one-line notes, whether the run is over and why it failed, and its logs as they grow."""

    def __init__(self, opts: RunOptions, policy: bytes | None) -> None:
        work = Path(tempfile.mkdtemp(prefix="keepaway-run-"))
        policy_path = None
        if policy is not None:
            policy_path = work / POLICY_NAME
            policy_path.write_bytes(policy)
        self.opts = replace(opts, out=work / "out", policy_path=policy_path, view=False)
        self.opts.out.mkdir()
        self.news: list[Ended | str] = []  # an ended episode, or a one-line note
        self.finished = False
        self.failure: str | None = None
        self.stopping = False
        self.changed = threading.Condition()
        self.processes = ArenaProcesses(self.opts.out / "processes", batch_scheduled=not opts.realtime)
        self.thread = threading.Thread(target=self._play, name="keepaway run", daemon=True)
        self.thread.start()

    def _note(self, line: str) -> None:
        with self.changed:
            self.news.append(line)
            self.changed.notify_all()

    def _play(self) -> None:
        failure = None
        try:
            ensure_compiled(kernel_sets("distributed"), self._note, log_dir=self.opts.out / "processes")
            with self.processes:
                for record, cycles in distributed_episodes(self.opts, self.processes):
                    with self.changed:
                        self.news.append((record, cycles, time.perf_counter()))
                        self.changed.notify_all()
        except (ArenaFailure, CompileError) as exc:
            failure = str(exc)
        except Exception as exc:  # anything else that stops the run on the node, named in one line
            failure = f"{type(exc).__name__}: {exc}"
        finally:
            with self.changed:
                self.finished = True
                self.failure = None if self.stopping else failure
                self.changed.notify_all()

    def news_since(self, seen: int) -> tuple[list[Ended | str], bool, str | None]:
        """The news after the first ``seen``, waiting up to NEWS_WAIT_S for some; whether the run is
        over; why it failed (None: it did not)."""
        with self.changed:
            self.changed.wait_for(lambda: len(self.news) > seen or self.finished, NEWS_WAIT_S)
            return self.news[seen:], self.finished, self.failure

    def stop(self) -> None:
        """Stop the arena's processes (at once if the run is still under way) and wait for the thread."""
        with self.changed:
            self.stopping = not self.finished
        self.processes.stop()
        self.thread.join()

    def where(self) -> str:
        """The node the arena plays on and the directory of its logs there."""
        import ray

        return f"{ray.util.get_node_ip_address()}:{self.opts.out}"

    def logs_since(self, sizes: dict[str, int]) -> list[LogPiece]:
        """What the run's files (its logs and its processes' logs, named relative to its ``--out``) hold
        beyond ``sizes`` (a file not named there: from its start, even empty), up to LOG_PIECE bytes in
        all (a game log can be gigabytes)."""
        pieces, budget = [], LOG_PIECE
        for path in sorted(path for path in self.opts.out.rglob("*") if path.is_file()):
            name = str(path.relative_to(self.opts.out))
            offset = sizes.get(name, 0)
            if name in sizes and path.stat().st_size <= offset:
                continue
            with open(path, "rb") as f:
                f.seek(offset)
                data = f.read(budget)
            pieces.append(LogPiece(name, offset, data))
            budget -= len(data)
            if budget <= 0:
                break
        return pieces


class LogMirror:
    """The node's run files as they grow, copied into the driver's ``--out`` as a local run keeps them:
    a log of the same name already there (an earlier run's ``keepaway.kwy``, ``.jsonl``, ``.rcg``) is set
    aside first, never overwritten (``server.episode_log.set_aside``, the server's rule); a process's log
    under ``processes/`` is appended to, as a resumed local run's."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.sizes: dict[str, int] = {}  # how much of each node file is copied

    def take(self, pieces: list[LogPiece]) -> bool:
        """Copy ``pieces`` (``RunHost.logs_since(self.sizes)``); whether there were any."""
        for name, offset, data in pieces:
            assert offset == self.sizes.get(name, 0), (name, offset)
            path = self.out / name
            if name not in self.sizes:
                path.parent.mkdir(parents=True, exist_ok=True)
                if path.parent == self.out:
                    set_aside(path)
            with open(path, "ab") as f:
                f.write(data)
            self.sizes[name] = offset + len(data)
        return bool(pieces)


# How long a cluster's address, or an arena's port on a node, may take to answer a connection from here
# (s): Ray itself retries an address where nothing listens for minutes, printing a warning every few
# seconds, and a trainer would wait ATTACHED_TIMEOUT_S for an arena it cannot reach.
CONNECT_TIMEOUT_S = 10.0


def unreachable(host: str, port: int) -> str | None:
    """Why a TCP connection from here to ``host:port`` is not made within CONNECT_TIMEOUT_S (one line),
    or None when it is."""
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


def join_ray(address: str | None, announce: Callable[[str], None] | None = None):
    """Join the Ray cluster at ``address`` (None: ``RAY_ADDRESS``, else a new local Ray; ``auto``: the
    one running on this machine), tell ``announce`` in one line what was joined, and return the ray
    module. Raises RuntimeError in one line when Ray is not installed, when nothing answers at a
    ``HOST:PORT`` address within CONNECT_TIMEOUT_S, or when Ray cannot join. Ray's own start-up lines (its
    INFO and WARNING logs: the dashboard's address, token authentication) are left out; its errors show.

    This process keeps its SIGTERM handler: a Ray driver otherwise exits on SIGTERM at once (a SIGABRT
    report), where ``keepaway run`` stops its arena, keeps its logs and prints the summary of what
    finished, and ``train``, ``evaluate`` and ``experiment`` stop their arenas and keep their checkpoints
    (``runner.launch.interrupt_on_sigterm``, set before or after this). Only the main thread can set one."""
    ray = _import_ray()
    where = address or os.environ.get("RAY_ADDRESS")
    host, _, port = (where or "").removeprefix("ray://").rpartition(":")
    if host and port.isdigit() and (why := unreachable(host, int(port))) is not None:
        raise RuntimeError(f"no Ray cluster answers at {where}: {why}; start one there (ray start --head) or "
                           "give another --ray-address")
    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    joined = f"the Ray cluster at {where}" if where else "a new local Ray"
    already = ray.is_initialized()  # by this process (a test, a notebook): nothing to tell
    try:
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False, logging_level=logging.ERROR)
    except ConnectionError as exc:
        raise RuntimeError(f"cannot join {joined}: {exc}") from None
    if main and before is not None:
        signal.signal(signal.SIGTERM, before)
    if announce is not None and not already:
        nodes = sum(1 for node in ray.nodes() if node["Alive"])
        announce(f"joined {joined}: {nodes} node{'s' * (nodes != 1)}, {ray.cluster_resources().get('CPU', 0.0):g} CPUs")
    return ray


def ray_run(address: str | None = None, announce: Callable[[str], None] | None = None) -> Elsewhere:
    """``keepaway run``'s ``elsewhere`` for a Ray cluster (``runner.run.run``): joins the cluster at
    ``address`` (None: ``RAY_ADDRESS`` or a new local Ray; ``announce`` is told what it joined) and plays
    the run's arena in a :class:`RunHost` on one of its nodes. Raises RuntimeError in one line when Ray is
    not installed or the cluster cannot be joined (:func:`join_ray`)."""
    ray = join_ray(address, announce)

    def play(opts: RunOptions, announce: Callable[[str], None] | None) -> Iterator[Ended]:
        policy = opts.policy_path.read_bytes() if opts.policy_path is not None else None
        host = ray.remote(num_cpus=ARENA_CPUS)(RunHost).remote(replace(opts, out=Path("."), policy_path=None),
                                                              policy)
        ready = [host.__ray_ready__.remote()]
        mirror = LogMirror(opts.out)
        try:
            wait_placed(ray, ready, "arena", announce)
            where = ray.get(host.where.remote())
            if announce is not None:
                announce(f"the arena plays on a Ray node, its logs in {where}, copied into {opts.out} as they grow")
            seen, finished, copied_at = 0, False, time.monotonic()
            while not finished:
                news, finished, failure = ray.get(host.news_since.remote(seen))
                seen += len(news)
                for item in news:
                    if not isinstance(item, str):
                        yield item
                    elif announce is not None:
                        announce(f"on the Ray node: {item}")
                if failure is not None:
                    raise ArenaFailure(f"on the Ray node: {failure}")
                if time.monotonic() - copied_at >= LOG_COPY_EVERY_S:
                    mirror.take(ray.get(host.logs_since.remote(mirror.sizes)))
                    copied_at = time.monotonic()
        finally:
            try:
                if ray.wait(ready, timeout=0)[0]:  # placed: stop its arena, then copy the rest of its logs
                    try:
                        ray.get(host.stop.remote())
                        while mirror.take(ray.get(host.logs_since.remote(mirror.sizes))):
                            pass
                    except ray.exceptions.RayActorError:
                        pass  # it was never created, or died with its node: nothing to stop or bring back
            finally:
                ray.kill(host)

    return play


__all__ = ["ARENA_CPUS", "ArenaHost", "Launcher", "LogMirror", "LogPiece", "RunHost", "error_line", "join_ray",
           "ray_launcher", "ray_run", "stop_actors", "unreachable", "wait_placed", "watcher"]
