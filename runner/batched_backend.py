"""The batched backend: every job in fresh in-process arenas stepped together (``runner.batched``).

A job plays its chunks (``runner.job.chunk_seeds``: at most ``chunk_episodes`` episodes each, chunk j
seeded ``derive_seed(seed, j)``) as the coached backends do, each chunk in an arena of its own, fresh
from the chunk's seed: the game a coach's arena restarted with that seed plays (``runner.coached``). A
frozen job's chunks are arenas side by side; a learning job's chunks follow one another, each a fresh
arena whose keepers start from the weights the last chunk ended with, as the keepers of a restarted
coached arena go on learning, and the last chunk's weights are the job's result. So every backend plays
the same episodes and learns the same weights from one seed (``tests/test_backends.py``); the arenas
report no transitions.

Independent jobs (:meth:`BatchedBackend.play_all`) share batches: the arenas of every job that the same
kernels can play (same policy names, Sarsa mode and step size) go into one batch, each arena with its own
seed, quota, GetOpen net and Pass policies, so a CEM generation's candidates, or the same step of every
trial of a training, use every thread at once; the learning jobs of a batch play their k-th chunks side
by side. An arena's game depends neither on its neighbours in the batch nor on the thread that steps it,
so each job plays exactly as it would alone. A batch holds at most :data:`MAX_ARENAS` arenas and, with
Pass learners, :data:`MAX_SARSA_BYTES` of their tables; more jobs make more batches.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from agents.sarsa import SarsaMemory
from runner.batched import BatchedArenas
from runner.job import (
    CHUNK_EPISODES,
    LEARNED,
    Behaviours,
    EpisodeTable,
    Game,
    Job,
    PassArrays,
    Played,
    Progress,
    RunResult,
    chunk_seeds,
)

MAX_ARENAS = 1024
# A learning keeper's table costs 16 B a slot (weight, collision check, trace slot; runner/batched.py),
# 1.1 MB at 2^16; a batch of frozen learned-Pass candidates copies its Pass policies into every arena.
MAX_SARSA_BYTES = 1 << 30


class BatchedBackend:
    """A ``runner.job.Backend`` of in-process arenas (module docstring); ``threads`` step them (the results
    do not depend on it)."""

    mode = "batched"

    def __init__(self, game: Game, threads: int | None = None, chunk_episodes: int = CHUNK_EPISODES) -> None:
        self.game = game
        self.threads = threads
        self.chunk_episodes = chunk_episodes

    def play(self, behaviours: Behaviours, seed: int, episodes: int, pass_mode: str,
             progress: Progress | None = None, alpha: float | None = None) -> Played:
        """``runner.job.Backend.play`` in fresh arenas, a chunk each (module docstring)."""
        return self.play_all([Job(behaviours, seed, episodes, pass_mode, alpha)], progress)[0]

    def play_all(self, jobs: Sequence[Job], progress: Progress | None = None) -> list[Played]:
        """``runner.job.Backend.play_all``: the jobs in shared batches (module docstring)."""
        played: list[Played | None] = [None] * len(jobs)
        for batch in self._batches(jobs):
            members = [jobs[i] for i in batch]
            play = self._learn_batch if members[0].learns else self._play_batch
            for i, outcome in zip(batch, play(members, progress)):
                played[i] = outcome
        return played  # type: ignore[return-value]

    def _plan(self, job: Job) -> list[tuple[int, int]]:
        return chunk_seeds(job.seed, job.episodes, self.chunk_episodes)

    def _batches(self, jobs: Sequence[Job]) -> list[list[int]]:
        """Indices of ``jobs`` grouped into batches the same kernels play, in order, within the limits
        (a learning job takes one arena at a time, a frozen one an arena per chunk)."""
        arena_bytes = self.game.keepers * self.game.sarsa.table_size * 16
        open_batches: dict[tuple, tuple[list[int], int]] = {}
        batches: list[list[int]] = []
        for i, job in enumerate(jobs):
            b = job.behaviours
            learned = b.pass_policy == LEARNED
            key = (b.pass_policy, b.getopen_policy, job.pass_mode if learned else None, job.alpha if learned else None)
            n = 1 if job.learns else len(self._plan(job))
            limit = min(MAX_ARENAS, max(1, MAX_SARSA_BYTES // arena_bytes)) if learned else MAX_ARENAS
            members, size = open_batches.get(key, ([], 0))
            if members and size + n > limit:
                members, size = [], 0
            if not members:
                batches.append(members)
            members.append(i)
            open_batches[key] = (members, size + n)
        return batches

    def _arenas(self, first: Job, seeds: list[int], nets: list[np.ndarray | None],
                learners: SarsaMemory | None = None) -> BatchedArenas:
        """Fresh arenas, one per seed, playing ``first``'s kernel configuration (the batch's), arena a with
        GetOpen net ``nets[a]`` (and, if given, going on with ``learners``: ``BatchedArenas``)."""
        game = self.game.learning_at(first.alpha)
        behaviours = first.behaviours
        learning = ({"sarsa": game.sarsa, "pass_mode": first.pass_mode, "learners": learners}
                    if behaviours.pass_policy == LEARNED else {})
        thetas = None if behaviours.getopen_policy != LEARNED else np.stack(nets)
        return BatchedArenas(game.params, len(seeds), seeds, keepers=game.keepers, takers=game.takers,
                             pass_policy=behaviours.pass_policy, getopen_policy=behaviours.getopen_policy,
                             getopen_theta=thetas, agent_config=game.agent, threads=self.threads, **learning)

    def _play_batch(self, jobs: list[Job], progress: Progress | None) -> list[Played]:
        """Frozen jobs side by side in one batch of fresh arenas, an arena per chunk."""
        plans = [self._plan(job) for job in jobs]
        owner = [j for j, plan in enumerate(plans) for _ in plan]
        batch = self._arenas(jobs[0], [s for plan in plans for _, s in plan],
                             [jobs[j].behaviours.getopen_net for j in owner])
        if any(job.behaviours.pass_arrays is not None for job in jobs):
            fresh = batch.arena_pass_arrays(0)  # for jobs of fresh learners beside jobs of loaded ones
            batch.load_pass_arrays([jobs[j].behaviours.pass_arrays or fresh for j in owner])
        start = time.perf_counter()
        table = batch.run(episodes_per_arena=np.array([n for plan in plans for n, _ in plan]),
                          progress=_reporter(progress))
        share = (time.perf_counter() - start) / len(owner)
        out, first = [], 0
        for job, plan in zip(jobs, plans):
            out.append(Played(self._result(job.seed, _arena_rows(table, range(first, first + len(plan))),
                                            share * len(plan))))
            first += len(plan)
        return out

    def _learn_batch(self, jobs: list[Job], progress: Progress | None) -> list[Played]:
        """Learning jobs side by side: their k-th chunks, each in a fresh arena whose keepers start from
        the weights the (k-1)-th ended with (taken over in place while the same jobs play on, copied out
        and loaded when some have ended)."""
        plans = [self._plan(job) for job in jobs]
        weights: list[list[PassArrays] | None] = [job.behaviours.pass_arrays for job in jobs]
        tables: list[list[EpisodeTable]] = [[] for _ in jobs]
        last: BatchedArenas | None = None
        last_playing: list[int] = []

        def copy_out() -> None:
            for a, j in enumerate(last_playing):
                weights[j] = last.arena_pass_arrays(a)

        start = time.perf_counter()
        for k in range(max(len(plan) for plan in plans)):
            playing = [j for j, plan in enumerate(plans) if k < len(plan)]
            go_on = last is not None and playing == last_playing
            if last is not None and not go_on:
                copy_out()
            batch = self._arenas(jobs[0], [plans[j][k][1] for j in playing],
                                 [jobs[j].behaviours.getopen_net for j in playing], last.sarsa if go_on else None)
            if not go_on and any(weights[j] is not None for j in playing):
                fresh = batch.arena_pass_arrays(0)
                batch.load_pass_arrays([weights[j] or fresh for j in playing])
            table = batch.run(episodes_per_arena=np.array([plans[j][k][0] for j in playing]),
                              progress=_reporter(progress))
            for j, rows in zip(playing, _arena_rows(table, range(len(playing)))):
                tables[j].append(rows)
            last, last_playing = batch, playing
        copy_out()
        elapsed = time.perf_counter() - start
        return [Played(self._result(job.seed, parts, elapsed / len(jobs)), weights[j])
                for j, (job, parts) in enumerate(zip(jobs, tables))]

    def _result(self, seed: int, chunks: list[EpisodeTable], elapsed_s: float) -> RunResult:
        """A job's result: the episodes of its ``chunks`` (:func:`_arena_rows`) in chunk order, numbered
        from 1 as the coached backends number them, played in ``elapsed_s``."""
        own = EpisodeTable.concatenate(chunks)
        return RunResult(self.mode, seed, own.records(self.game.params.simulator_step_ms), elapsed_s, own.cycles,
                         len(own))

    def close(self) -> None:
        """Nothing to stop: the arenas of a job end with it."""


def _reporter(progress: Progress | None) -> Callable[[int], None]:
    """``BatchedArenas.run``'s progress callback (episodes collected so far) as a ``Progress`` (new ones)."""
    done = 0

    def report(collected: int) -> None:
        nonlocal done
        if progress is not None:
            progress(collected - done)
        done = collected

    return report


def _arena_rows(table: EpisodeTable, arenas: range) -> list[EpisodeTable]:
    """The episodes of each of ``table``'s arenas ``arenas``, in their order, each as arena 0 (the
    arena-cycles it simulated are not known from the table: ``cycles`` counts the episodes' cycles)."""
    order = np.lexsort((table.episode, table.arena))
    arena = table.arena[order]
    bounds = np.searchsorted(arena, [arenas.start, *(a + 1 for a in arenas)])
    out = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        rows = order[lo:hi]
        start, end = table.start_cycle[rows], table.end_cycle[rows]
        out.append(EpisodeTable(np.zeros(len(rows), dtype=np.int64), table.episode[rows], start, end,
                                table.end[rows], int((end - start).sum())))
    return out


__all__ = ["MAX_ARENAS", "MAX_SARSA_BYTES", "BatchedBackend"]
