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
same games. Nothing of it listens beyond the node's loopback; the episodes, one-line notes and at the
end the logs come back through Ray (:func:`ray_run`), into the run's ``--out``.
"""

from __future__ import annotations

import signal
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

from runner.distributed import ARENA_PLAYER_ARGS, DistributedBackend, arena_server_args
from runner.job import Game
from runner.kernels import CompileError, ensure_compiled, kernel_sets
from runner.launch import ArenaFailure, ArenaProcesses
from runner.run import Elsewhere, Ended, RunOptions, distributed_episodes

ARENA_CPUS = 1.0  # a synchronous arena's seven processes mostly wait for one another


class ArenaHost:
    """The actor behind one arena: starts its processes on the node it lands on and stops them."""

    def __init__(self, game: Game, parameter_set: str, index: int, keys: Path | None = None) -> None:
        import ray

        log_dir = Path(tempfile.mkdtemp(prefix=f"keepaway-arena-{index:02d}-"))
        self.processes = ArenaProcesses(log_dir, batch_scheduled=True).__enter__()  # a synchronous arena
        try:
            endpoints = self.processes.start_arena(arena_server_args(game, parameter_set, log_dir),
                                                   list(ARENA_PLAYER_ARGS),
                                                   game.keepers, game.takers,
                                                   arena_host=ray.util.get_node_ip_address(), keys=keys)
        except BaseException:
            self.processes.stop()
            raise
        self.arena_endpoint = endpoints.arena

    def endpoint(self) -> str:
        return self.arena_endpoint

    def stop(self) -> None:
        self.processes.stop()


Launcher = Callable[[Game, str, int, int], DistributedBackend]


def ray_launcher(address: str | None = None, keys: Path | None = None) -> Launcher:
    """A ``launcher`` for ``runner.backends.open_backend``: joins the Ray cluster at ``address`` (None:
    ``RAY_ADDRESS`` or a new local Ray); ``launch(game, parameter_set, arenas, chunk_episodes)`` places that
    many arenas of ``game`` on it (jobs cut into chunks of ``chunk_episodes``), with ``keys`` (a keys directory at that path on every node) over CURVE. Raises
    RuntimeError in one line when Ray is not installed."""
    ray = _import_ray()

    def launch(game: Game, parameter_set: str, arenas: int, chunk_episodes: int) -> DistributedBackend:
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
        actor = ray.remote(num_cpus=ARENA_CPUS)(ArenaHost)
        hosts = [actor.remote(game, parameter_set, i, keys) for i in range(arenas)]

        def stop_hosts() -> None:
            ray.get([host.stop.remote() for host in hosts])
            for host in hosts:
                ray.kill(host)

        try:
            endpoints = ray.get([host.endpoint.remote() for host in hosts])
        except BaseException:
            stop_hosts()
            raise
        backend = DistributedBackend.attach(game, endpoints, chunk_episodes, keys=keys)
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
LOG_PIECE = 1 << 23  # bytes of a log brought back from the node at a time
POLICY_NAME = "policy.npz"  # the run's policy file, as the node's players read it (beside, not in, its logs)


class RunHost:
    """The actor behind ``keepaway run --backend ray``: plays the run's arena on the node it lands on
    (module docstring) in a thread of its own, compiling the kernels there first if the node lacks
    them, and keeps what the driver asks for: the episodes as they end, with the node's time of each,
    one-line notes, whether the run is over and why it failed, and at the end the logs."""

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

    def log_names(self) -> list[str]:
        """The files the run wrote (its logs and its processes' logs), relative to its ``--out``."""
        return sorted(str(path.relative_to(self.opts.out)) for path in self.opts.out.rglob("*") if path.is_file())

    def log(self, name: str, offset: int) -> bytes:
        """Up to LOG_PIECE bytes of the file ``name`` from ``offset`` (a game log can be gigabytes)."""
        with open(self.opts.out / name, "rb") as f:
            f.seek(offset)
            return f.read(LOG_PIECE)


def _init_keeping_sigterm(ray, address: str | None) -> None:
    """Join Ray, keeping this process's SIGTERM handler: a Ray driver otherwise exits on SIGTERM at once,
    where ``keepaway run`` stops its arena, keeps its logs and prints the summary of what finished
    (``runner.launch.interrupt_on_sigterm``). Only the main thread can set a handler."""
    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    if main and before is not None:
        signal.signal(signal.SIGTERM, before)


def ray_run(address: str | None = None) -> Elsewhere:
    """``keepaway run``'s ``elsewhere`` for a Ray cluster (``runner.run.run``): joins the cluster at
    ``address`` (None: ``RAY_ADDRESS`` or a new local Ray) and plays the run's arena in a
    :class:`RunHost` on one of its nodes. Raises RuntimeError in one line when Ray is not installed."""
    ray = _import_ray()

    def play(opts: RunOptions, announce: Callable[[str], None] | None) -> Iterator[Ended]:
        policy = opts.policy_path.read_bytes() if opts.policy_path is not None else None
        _init_keeping_sigterm(ray, address)
        host = ray.remote(num_cpus=ARENA_CPUS)(RunHost).remote(replace(opts, out=Path("."), policy_path=None),
                                                              policy)
        try:
            where = ray.get(host.where.remote())
            if announce is not None:
                announce(f"the arena plays on a Ray node, its logs in {where}; they come to {opts.out} when it ends")
            seen, finished = 0, False
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
        finally:
            try:
                ray.get(host.stop.remote())
                for name in ray.get(host.log_names.remote()):
                    path = opts.out / name
                    path.parent.mkdir(parents=True, exist_ok=True)
                    with open(path, "wb") as f:
                        while piece := ray.get(host.log.remote(name, f.tell())):
                            f.write(piece)
            finally:
                ray.kill(host)

    return play


__all__ = ["ARENA_CPUS", "ArenaHost", "Launcher", "RunHost", "ray_launcher", "ray_run"]
