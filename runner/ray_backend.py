"""Arenas on a Ray cluster: ``keepaway train --mode distributed --backend ray`` (``pip install
'keepaway[ray]'``).

Ray only places the arenas. Each arena is a Ray actor that starts the arena's processes (server, coach,
five players) on its node exactly as the local backend does, with the coach's arena port bound on the
node's address; the trainer then drives every arena over ZeroMQ like any other
(``runner.distributed``). So results do not depend on where the arenas run. Every node needs this
package installed (same version), and the trainer must reach the nodes' ports. The default backend
needs no Ray; this module imports it only when asked.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from runner.distributed import ARENA_PLAYER_ARGS, DistributedBackend, arena_server_args
from runner.job import Game
from runner.launch import ArenaProcesses

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
    try:
        import ray
    except ImportError:
        raise RuntimeError("--backend ray needs Ray: pip install 'keepaway[ray]'") from None

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


__all__ = ["ARENA_CPUS", "ArenaHost", "Launcher", "ray_launcher"]
