"""Choosing a backend: one ``runner.job.Backend`` per mode, for ``keepaway train``, ``evaluate`` and
``experiment`` alike (``--mode``, ``--arena``, ``--backend ray``, ``--threads``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from keepaway.runner.batched_backend import BatchedBackend
from keepaway.runner.distributed import DistributedBackend
from keepaway.runner.embedded import EmbeddedBackend
from keepaway.runner.job import CHUNK_EPISODES, MODES, Backend, Game
from keepaway.runner.kernels import kernel_sets
from keepaway.runner.ray_backend import Launcher


@dataclass(frozen=True)
class Placement:
    """Where a mode's arenas run, which no result depends on: the threads that step batched arenas; for
    the distributed mode, running arenas to attach to (their coaches' arena endpoints) or a launcher that
    places new ones (``runner.ray_backend``), else arenas of processes started on this machine; and the
    keys directory their connections use, if any."""

    threads: int | None = None
    attach: tuple[str, ...] = ()
    launcher: Launcher | None = None
    keys: Path | None = None  # a keys directory: CURVE on every connection (protocol.security)

    def kernel_sets(self, mode: str) -> tuple[str, ...]:
        """The kernel sets to compile on this machine before ``mode``'s arenas start (``runner.kernels``):
        none when they all run elsewhere."""
        elsewhere = mode == "distributed" and (bool(self.attach) or self.launcher is not None)
        return () if elsewhere else kernel_sets(mode)


def open_backend(mode: str, game: Game, parameter_set: str, arenas: int, log_dir: Path,
                 placement: Placement = Placement(), chunk_episodes: int = CHUNK_EPISODES) -> Backend:
    """The backend of ``mode`` for ``game`` (``parameter_set`` names its parameter table for the server
    processes), cutting jobs into chunks of ``chunk_episodes`` (``runner.job``): batched; embedded;
    distributed on ``arenas`` arenas placed as ``placement`` says (those started here log under
    ``log_dir``). Close it when done. ValueError (one line) for a placement that is not for ``mode``."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    if mode != "distributed" and (placement.attach or placement.launcher is not None):
        raise ValueError(f"running arenas (--arena) and --backend ray are for the distributed mode, not {mode}")
    if mode == "batched":
        return BatchedBackend(game, placement.threads, chunk_episodes)
    if mode == "embedded":
        return EmbeddedBackend(game, chunk_episodes)
    if placement.attach:
        return DistributedBackend.attach(game, placement.attach, chunk_episodes, keys=placement.keys)
    if placement.launcher is not None:
        return placement.launcher(game, parameter_set, arenas, chunk_episodes)
    return DistributedBackend.start_local(game, arenas, log_dir, parameter_set, chunk_episodes, keys=placement.keys)


__all__ = ["Placement", "open_backend"]
