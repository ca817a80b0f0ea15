"""The batched backend: every job in fresh in-process arenas stepped together (``runner.batched``).

A job of ``episodes`` episodes seeded ``seed`` plays in ``min(arenas, episodes)`` fresh arenas, arena b
seeded ``seed + b`` (the game one arena seeded ``seed + b`` plays in any mode), every arena's keepers
starting from the job's Pass policies, ``episodes // arenas`` episodes per arena plus one in the first
``episodes % arenas``. A learning job returns the first arena's keepers' new policies; the arenas report
no transitions.

Independent jobs (:meth:`BatchedBackend.play_all`) share batches: the arenas of every job that the same
kernels can play (same policy names, Sarsa mode and step size) go into one batch, each arena with its own
seed, quota, GetOpen net and Pass policies, so a CEM generation's candidates, or the same step of every
trial of a training, use every thread at once. An arena's game depends neither on its neighbours in the
batch nor on the thread that steps it, so each job plays exactly as it would alone. A batch holds at most
:data:`MAX_ARENAS` arenas and, with Pass learners, :data:`MAX_SARSA_BYTES` of their tables; more jobs
make more batches.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from runner.batched import BatchedArenas, arena_seed, episode_shares
from runner.job import LEARNED, Behaviours, EpisodeTable, Game, Job, Played, Progress, RunResult

MAX_ARENAS = 1024
# A learning keeper's table costs 16 B a slot (weight, collision check, trace slot; runner/batched.py),
# 1.1 MB at 2^16; a batch of frozen learned-Pass candidates copies its Pass policies into every arena.
MAX_SARSA_BYTES = 1 << 30


class BatchedBackend:
    """A ``runner.job.Backend`` of in-process arenas (module docstring); ``threads`` step them (the results
    do not depend on it)."""

    mode = "batched"

    def __init__(self, game: Game, threads: int | None = None) -> None:
        self.game = game
        self.threads = threads

    def play(self, behaviours: Behaviours, seed: int, episodes: int, arenas: int, pass_mode: str,
             progress: Progress | None = None, alpha: float | None = None) -> Played:
        """``runner.job.Backend.play`` in ``min(arenas, episodes)`` fresh arenas (module docstring)."""
        return self.play_all([Job(behaviours, seed, episodes, arenas, pass_mode, alpha)], progress)[0]

    def play_all(self, jobs: Sequence[Job], progress: Progress | None = None) -> list[Played]:
        """``runner.job.Backend.play_all``: the jobs in shared batches (module docstring)."""
        played: list[Played | None] = [None] * len(jobs)
        for batch in self._batches(jobs):
            for i, outcome in zip(batch, self._play_batch([jobs[i] for i in batch], progress)):
                played[i] = outcome
        return played  # type: ignore[return-value]

    def _batches(self, jobs: Sequence[Job]) -> list[list[int]]:
        """Indices of ``jobs`` grouped into batches the same kernels play, in order, within the limits."""
        arena_bytes = self.game.keepers * self.game.sarsa.table_size * 16
        open_batches: dict[tuple, tuple[list[int], int]] = {}
        batches: list[list[int]] = []
        for i, job in enumerate(jobs):
            b = job.behaviours
            learned = b.pass_policy == LEARNED
            key = (b.pass_policy, b.getopen_policy, job.pass_mode if learned else None, job.alpha if learned else None)
            n = _arenas(job)
            limit = min(MAX_ARENAS, max(1, MAX_SARSA_BYTES // arena_bytes)) if learned else MAX_ARENAS
            members, size = open_batches.get(key, ([], 0))
            if members and size + n > limit:
                members, size = [], 0
            if not members:
                batches.append(members)
            members.append(i)
            open_batches[key] = (members, size + n)
        return batches

    def _play_batch(self, jobs: list[Job], progress: Progress | None) -> list[Played]:
        """Jobs of one kernel configuration side by side in one batch of fresh arenas."""
        first = jobs[0]
        game = self.game.learning_at(first.alpha)
        params = game.params
        behaviours = first.behaviours
        learned = behaviours.pass_policy == LEARNED
        sizes = [_arenas(job) for job in jobs]
        seeds = [arena_seed(job.seed, b) for job, n in zip(jobs, sizes) for b in range(n)]
        thetas = None if behaviours.getopen_policy != LEARNED else np.concatenate(
            [np.broadcast_to(job.behaviours.getopen_net, (n, len(job.behaviours.getopen_net)))
             for job, n in zip(jobs, sizes)])
        quotas = np.concatenate([episode_shares(job.episodes, n) for job, n in zip(jobs, sizes)])
        learning = {"sarsa": game.sarsa, "pass_mode": first.pass_mode} if learned else {}
        batch = BatchedArenas(params, len(seeds), seeds, keepers=game.keepers, takers=game.takers,
                              pass_policy=behaviours.pass_policy, getopen_policy=behaviours.getopen_policy,
                              getopen_theta=thetas, agent_config=game.agent, threads=self.threads, **learning)
        if learned and any(job.behaviours.pass_arrays is not None for job in jobs):
            fresh = batch.arena_pass_arrays(0)  # for jobs of fresh learners beside jobs of loaded ones
            batch.load_pass_arrays([job.behaviours.pass_arrays or fresh for job, n in zip(jobs, sizes)
                                    for _ in range(n)])
        done = 0

        def report(collected: int) -> None:
            nonlocal done
            if progress is not None:
                progress(collected - done)
            done = collected

        start = time.perf_counter()
        table = batch.run(episodes_per_arena=quotas, progress=report)
        elapsed = time.perf_counter() - start
        out, first_arena = [], 0
        for job, n in zip(jobs, sizes):
            own = _arena_rows(table, first_arena, n, int(batch.world.time[first_arena:first_arena + n].sum()))
            result = RunResult(self.mode, job.seed, own.records(params.simulator_step_ms),
                               elapsed * n / len(seeds), own.cycles, len(own))
            out.append(Played(result, batch.arena_pass_arrays(first_arena) if job.learns else None))
            first_arena += n
        return out

    def close(self) -> None:
        """Nothing to stop: the arenas of a job end with it."""


def _arenas(job: Job) -> int:
    return min(job.arenas, job.episodes)


def _arena_rows(table: EpisodeTable, first: int, n: int, cycles: int) -> EpisodeTable:
    """The episodes of arenas ``first .. first + n - 1`` of ``table``, renumbered from arena 0 (their order,
    by end cycle then arena, is the one a batch of just these arenas gives), which simulated ``cycles``."""
    mask = (table.arena >= first) & (table.arena < first + n)
    return EpisodeTable(table.arena[mask] - first, table.episode[mask], table.start_cycle[mask],
                        table.end_cycle[mask], table.end[mask], cycles)


__all__ = ["MAX_ARENAS", "MAX_SARSA_BYTES", "BatchedBackend"]
