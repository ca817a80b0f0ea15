"""Choosing a backend: one ``runner.job.Backend`` per mode, for ``keepaway train``, ``evaluate`` and
``experiment`` alike (``--mode``, ``--arena``, ``--backend ray``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from runner.batched_backend import BatchedBackend
from runner.distributed import DistributedBackend
from runner.embedded import EmbeddedBackend
from runner.job import MODES, Backend, Game
from runner.ray_backend import Launcher


def open_backend(mode: str, game: Game, parameter_set: str, arenas: int, log_dir: Path,
                 threads: int | None = None, attach: Sequence[str] = (), launcher: Launcher | None = None) -> Backend:
    """The backend of ``mode`` for ``game``: batched with ``threads``; embedded; distributed on ``arenas``
    arenas of ``parameter_set`` started here (logs under ``log_dir``), placed by ``launcher`` (e.g. on a
    Ray cluster: ``runner.ray_backend``), or attached to running ones at the ``attach`` endpoints. Close it
    when done. ValueError (one line) for a combination that cannot be."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    if mode != "distributed" and (attach or launcher is not None):
        raise ValueError(f"running arenas (--arena) and --backend ray are for the distributed mode, not {mode}")
    if mode == "batched":
        return BatchedBackend(game, threads)
    if mode == "embedded":
        return EmbeddedBackend(game)
    if attach:
        return DistributedBackend.attach(game, attach)
    if launcher is not None:
        return launcher(game, parameter_set, arenas)
    return DistributedBackend.start_local(game, arenas, log_dir, parameter_set)


__all__ = ["open_backend"]
