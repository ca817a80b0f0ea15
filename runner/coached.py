"""Jobs played as a trainer asks an arena's coach: chunks of ``run_episodes`` requests (``protocol.arena``).

Work is cut into chunks of at most ``chunk_episodes`` episodes (``runner.job.chunk_seeds``, as every
backend cuts it). A chunk is one ``run_episodes`` request
carrying everything the keepers need (policy names, the GetOpen net, each keeper's Pass policy and Sarsa
mode) and its own seed, derived from the job's seed and the chunk's index; the coach restarts the arena
from that seed (server and players reseeded), so a chunk plays the same in whichever arena runs it and
whatever that arena played before. Frozen jobs (evaluations, CEM candidates) therefore spread their
chunks over every free arena and still give the same results for any number of arenas: common random
numbers hold across candidates (every candidate plays the same chunk seeds) and a resumed training plays
exactly as an uninterrupted one.

Pass learning is sequential: a Pass block's chunks run one after the other in one arena, the first
loading every keeper's current Pass policy, each asking the keepers for their SMDP transitions since the
last chunk, the last also for a snapshot of their weights (keepaway-task.md 5: each keeper learns its
own policy from its own experience, online). The snapshots become the block's result, the transitions
its trace.

:class:`CoachedBackend` is all of this but the serving of the requests, which its subclasses do: over
sockets to coaches of arena processes (``runner.distributed``) or in this process
(``runner.embedded.EmbeddedBackend``). Both see the same requests and answers, so they play the same
episodes and learn the same weights.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar, Self

import numpy as np

from keepaway.agents.pass_wire import pass_arrays_from_chunks, sparse_pass_chunks
from keepaway.agents.sarsa import SarsaLearner
from keepaway.protocol.advice import (
    REPORT_SNAPSHOT,
    REPORT_TRANSITIONS,
    KeeperReport,
    PassLoadAdvice,
    PassModeAdvice,
    PassSnapshotReport,
    PassTransitionsReport,
    PolicyAdvice,
)
from keepaway.protocol.arena import EpisodesDone, RunEpisodes
from keepaway.runner.job import (
    CHUNK_EPISODES,
    LEARNED,
    Behaviours,
    Game,
    Job,
    Played,
    Progress,
    RunResult,
    Transitions,
    chunk_seeds,
)
from keepaway.runner.launch import ArenaFailure
from keepaway.server.episode_log import EpisodeRecord

# SMDP transitions a keeper keeps between two reports: a chunk's worth with room to spare (a keeper
# decides a few times per second of hold time); the size does not change what is learned.
TRANSITION_LOG = 1 << 14


@dataclass(frozen=True)
class Chunk:
    """One request: ``episodes`` episodes from ``seed`` with ``advice``, then ``reports``."""

    episodes: int
    seed: int
    advice: tuple = ()
    reports: tuple = ()

    def request(self) -> RunEpisodes:
        return RunEpisodes(episodes=self.episodes, seed=self.seed, advice=self.advice, reports=self.reports)


def behaviour_advice(game: Game, behaviours: Behaviours, pass_mode: str) -> tuple:
    """The advice that makes an arena's keepers play ``behaviours``: :func:`policy_advice`, then with Pass
    learned :func:`pass_load_advice`."""
    learned = behaviours.pass_policy == LEARNED
    return policy_advice(behaviours) + (pass_load_advice(game, behaviours, pass_mode) if learned else ())


def policy_advice(behaviours: Behaviours) -> tuple:
    """The policy names and the GetOpen net, to every keeper (its input scaling folded in: the advice
    carries the net on the raw variables, docs/advice.md)."""
    theta = behaviours.getopen_net if behaviours.getopen_theta is not None else None
    return (("keepers", PolicyAdvice(getopen_theta=theta, pass_policy=behaviours.pass_policy,
                                     getopen_policy=behaviours.getopen_policy)),)


def pass_load_advice(game: Game, behaviours: Behaviours, pass_mode: str) -> tuple:
    """Each keeper's own Pass policy (fresh learners: zero weights) as ``pass_load`` chunks with the game's
    Sarsa constants, and the Sarsa mode."""
    config = replace(game.sarsa, transition_log_size=TRANSITION_LOG)
    keepers = behaviours.pass_arrays or [SarsaLearner(game.keepers, game.takers, game.sarsa).save()] * game.keepers
    advice: list = []
    for unum, arrays in enumerate(keepers, start=1):
        advice += [(("l", unum), p) for p in sparse_pass_chunks(arrays, config, PassLoadAdvice)]
    advice.append(("keepers", PassModeAdvice(mode=pass_mode)))
    return tuple(advice)


def keeper_reports(done: list[EpisodesDone], kind: type[KeeperReport]) -> dict[int, list[Any]]:
    """The reports of class ``kind`` each keeper (by uniform number) sent in ``done``, in order."""
    out: dict[int, list[Any]] = {}
    for answer in done:
        for side, unum, report in answer.reports:
            if side == "l" and type(report) is kind:
                out.setdefault(unum, []).append(report)
    return out


def transitions_by_keeper(done: list[EpisodesDone]) -> Transitions:
    """Every keeper's SMDP transitions reported over ``done``, oldest first, as arrays
    (``PassTransitionsReport.arrays``: state, action, reward, next_action, terminal) plus ``dropped``, the
    number lost from a keeper's ring buffer between two reports; keeper by keeper, whatever order their
    reports came in."""
    out = {}
    for unum, reports in sorted(keeper_reports(done, PassTransitionsReport).items()):
        parts = [r.arrays() for r in sorted(reports, key=lambda r: r.first) if r.learner and r.count]
        names = ("state", "action", "reward", "next_action", "terminal")
        arrays = {name: np.concatenate([p[name] for p in parts]) if parts else np.zeros(0) for name in names}
        arrays["dropped"] = np.array(sum(r.dropped for r in reports if r.learner and r.chunk == 0))
        out[unum] = arrays
    return out


class CoachedBackend(ABC):
    """A ``runner.job.Backend`` whose jobs are chunks of requests (module docstring); a subclass serves them
    (:meth:`serve`), names its :attr:`mode` and the arena that plays its learning jobs."""

    mode: ClassVar[str]  # RunResult.mode

    def __init__(self, game: Game, learning_arena: str, chunk_episodes: int = CHUNK_EPISODES) -> None:
        self.game = game
        self.learning_arena = learning_arena
        self.chunk_episodes = chunk_episodes

    @abstractmethod
    def serve(self, chunks: list[Chunk], progress: Progress | None, in_order: bool) -> list[EpisodesDone]:
        """The answers to ``chunks``, in their order; ``in_order``: one arena plays them one after the other
        (learning keepers go on from one chunk to the next), else any arena may take any chunk. Raises
        ArenaFailure naming the arena that failed."""

    def close(self) -> None:
        """Stop whatever the backend started."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def play(self, behaviours: Behaviours, seed: int, episodes: int, pass_mode: str,
             progress: Progress | None = None, alpha: float | None = None) -> Played:
        """``runner.job.Backend.play``. Frozen (any mode but learn), the chunks may spread over the arenas;
        learning, they run in order in one arena and the keepers' final weights and transitions come
        back."""
        return self.play_all([Job(behaviours, seed, episodes, pass_mode, alpha)], progress)[0]

    def play_all(self, jobs: Sequence[Job], progress: Progress | None = None) -> list[Played]:
        """``runner.job.Backend.play_all``: the frozen jobs' chunks all served at once, any arena taking
        any chunk; then the learning jobs one after the other in the learning arena. A Pass policy that
        several frozen jobs share (a CEM generation's candidates) is encoded once."""
        played: list[Played | None] = [None] * len(jobs)
        frozen = [i for i, job in enumerate(jobs) if not job.learns]
        if frozen:
            start = time.perf_counter()
            encoded: dict[tuple, tuple] = {}
            plans, chunks = [], []
            for i in frozen:
                job = jobs[i]
                b = job.behaviours
                advice = policy_advice(b)
                if b.pass_policy == LEARNED:
                    key = (id(b.pass_arrays), job.pass_mode, job.alpha)
                    if key not in encoded:
                        encoded[key] = pass_load_advice(self.game.learning_at(job.alpha), b, job.pass_mode)
                    advice += encoded[key]
                plans.append(chunk_seeds(job.seed, job.episodes, self.chunk_episodes))
                chunks += [Chunk(n, s, advice) for n, s in plans[-1]]
            done = self.serve(chunks, progress, in_order=False)
            share, at = (time.perf_counter() - start) / len(frozen), 0
            for i, plan in zip(frozen, plans):
                played[i] = Played(self._result(jobs[i].seed, done[at:at + len(plan)], share))
                at += len(plan)
        for i, job in enumerate(jobs):
            if job.learns:
                played[i] = self._learn(job, progress)
        return played  # type: ignore[return-value]

    def _learn(self, job: Job, progress: Progress | None) -> Played:
        """A learning job: its chunks in order in one arena, the keepers' final weights and transitions."""
        start = time.perf_counter()
        advice = behaviour_advice(self.game.learning_at(job.alpha), job.behaviours, job.pass_mode)
        plan = chunk_seeds(job.seed, job.episodes, self.chunk_episodes)
        chunks = [Chunk(n, s, advice if j == 0 else (), (REPORT_TRANSITIONS,)) for j, (n, s) in enumerate(plan)]
        chunks[-1] = replace(chunks[-1], reports=(REPORT_TRANSITIONS, REPORT_SNAPSHOT))
        done = self.serve(chunks, progress, in_order=True)
        snapshots = keeper_reports(done[-1:], PassSnapshotReport)
        try:
            learned = [pass_arrays_from_chunks(snapshots.get(unum, []))[1] for unum in range(1, self.game.keepers + 1)]
        except ValueError as exc:
            raise ArenaFailure(f"{self.learning_arena}: a keeper's weight snapshot is unusable: {exc}") from None
        return Played(self._result(job.seed, done, time.perf_counter() - start), learned, transitions_by_keeper(done))

    def _result(self, seed: int, done: list[EpisodesDone], elapsed_s: float) -> RunResult:
        """The episodes of ``done`` (numbered from 1 in chunk order), played in ``elapsed_s`` of wall time."""
        step_ms = self.game.params.simulator_step_ms
        rows = [row for answer in done for row in answer.episodes]
        records = [EpisodeRecord(i + 1, int(start), int(end), cause, simulator_step_ms=step_ms)
                   for i, (_, start, end, cause) in enumerate(rows)]
        cycles = sum(r.end_cycle - r.start_cycle for r in records)
        return RunResult(self.mode, seed, records, elapsed_s, cycles, len(records))


__all__ = ["Chunk", "CoachedBackend", "behaviour_advice", "keeper_reports", "pass_load_advice", "policy_advice",
           "transitions_by_keeper"]
