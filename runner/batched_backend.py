"""The batched backend: every job in fresh in-process arenas stepped together (``runner.batched``).

A job plays its chunks (``runner.job.chunk_seeds``: at most ``chunk_episodes`` episodes each, chunk j
seeded ``derive_seed(seed, j)``) as the coached backends do, each chunk in an arena of its own, fresh
from the chunk's seed: the game a coach's arena restarted with that seed plays (``runner.coached``). A
frozen job's chunks are arenas side by side; a learning job's chunks follow one another, each a fresh
arena whose keepers start from the weights the last chunk ended with, as the keepers of a restarted
coached arena go on learning, and the last chunk's weights are the job's result. So every backend plays
the same episodes and learns the same weights from one seed (``tests/test_backends.py``); the arenas
report no transitions.

Independent jobs (:meth:`BatchedBackend.play_all`) share batches: the learning jobs in one, the frozen
ones in another, whatever their policies, Sarsa modes and step sizes, each arena with its own seed, quota,
policy names, GetOpen net, Pass policies, mode and step size (``runner.batched.ArenaPolicies``). So a CEM
generation's candidates, the same step of every trial of a training, and the steps of several trainings
(the configurations of an experiment) use every thread at once; the learning jobs of a batch play their
k-th chunks side by side. An arena's game depends neither on its neighbours in the batch nor on the thread
that steps it, so each job plays exactly as it would alone. A batch holds at most :data:`MAX_ARENAS`
arenas and :data:`MAX_SARSA_BYTES` of Pass learners' tables; more jobs make more batches.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from keepaway.agents.sarsa import SarsaMemory
from keepaway.runner.batched import BatchedArenas
from keepaway.runner.job import (
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
        """Indices of ``jobs`` grouped into batches, in order, within the limits: the learning jobs (one
        arena at a time each) apart from the frozen ones (an arena per chunk)."""
        max_learners = max(1, MAX_SARSA_BYTES // (self.game.keepers * self.game.sarsa.table_size * 16))
        open_batches: dict[bool, tuple[list[int], int, int]] = {}  # learns -> (members, arenas, learner arenas)
        batches: list[list[int]] = []
        for i, job in enumerate(jobs):
            n = 1 if job.learns else len(self._plan(job))
            learners = n if job.behaviours.pass_policy == LEARNED else 0
            members, arenas, learning = open_batches.get(job.learns, ([], 0, 0))
            if members and (arenas + n > MAX_ARENAS or learning + learners > max_learners):
                members, arenas, learning = [], 0, 0
            if not members:
                batches.append(members)
            members.append(i)
            open_batches[job.learns] = (members, arenas + n, learning + learners)
        return batches

    def _arenas(self, owners: list[Job], seeds: list[int], learners: SarsaMemory | None = None) -> BatchedArenas:
        """Fresh arenas, one per seed, arena a playing the policies, GetOpen net, Sarsa mode and step size of
        job ``owners[a]`` (and, if given, going on with ``learners``: ``BatchedArenas``)."""
        game = self.game
        behaviours = [job.behaviours for job in owners]
        learning = ({"sarsa": game.sarsa, "learners": learners}
                    if any(b.pass_policy == LEARNED for b in behaviours) else {})
        thetas = None
        if any(b.getopen_policy == LEARNED for b in behaviours):
            nets = [b.getopen_net for b in behaviours]
            unused = np.zeros_like(next(net for net in nets if net is not None))
            thetas = np.stack([unused if net is None else net for net in nets])
        return BatchedArenas(game.params, len(seeds), seeds, keepers=game.keepers, takers=game.takers,
                             pass_policy=[b.pass_policy for b in behaviours],
                             getopen_policy=[b.getopen_policy for b in behaviours], getopen_theta=thetas,
                             agent_config=game.agent, threads=self.threads, pass_mode=[job.pass_mode for job in owners],
                             alpha=[game.sarsa.alpha if job.alpha is None else job.alpha for job in owners], **learning)

    @staticmethod
    def _load_pass_arrays(batch: BatchedArenas, weights: list[list[PassArrays] | None]) -> None:
        """Load ``weights[a]`` into arena a where given, fresh learners' (zero) weights into the other
        arenas with Pass learners, as a job of fresh learners beside jobs of loaded ones needs."""
        if any(w is not None for w in weights):
            fresh = batch.arena_pass_arrays(int(batch.learner_arenas[0]))
            batch.load_pass_arrays([w or fresh for w in weights])

    def _play_batch(self, jobs: list[Job], progress: Progress | None) -> list[Played]:
        """Frozen jobs side by side in one batch of fresh arenas, an arena per chunk."""
        plans = [self._plan(job) for job in jobs]
        owner = [j for j, plan in enumerate(plans) for _ in plan]
        batch = self._arenas([jobs[j] for j in owner], [s for plan in plans for _, s in plan])
        self._load_pass_arrays(batch, [jobs[j].behaviours.pass_arrays for j in owner])
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
            batch = self._arenas([jobs[j] for j in playing], [plans[j][k][1] for j in playing],
                                 last.sarsa if go_on else None)
            if not go_on:
                self._load_pass_arrays(batch, [weights[j] for j in playing])
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
