"""The batched backend: every job in fresh in-process arenas stepped together (``runner.batched``).

A job of ``episodes`` episodes seeded ``seed`` plays in ``min(arenas, episodes)`` fresh arenas, arena b
seeded ``seed + b`` (the game one arena seeded ``seed + b`` plays in any mode), every arena's keepers
starting from the job's Pass policies. A learning job returns the first arena's keepers' new policies; the
arenas report no transitions.
"""

from __future__ import annotations

import time

from runner.batched import BatchedArenas
from runner.job import GREEDY, LEARN, LEARNED, Behaviours, Game, Played, Progress, RunResult


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
        game = self.game.learning_at(alpha)
        params = game.params
        learning = {"sarsa": game.sarsa, "pass_mode": pass_mode} if behaviours.pass_policy == LEARNED else {}
        batch = BatchedArenas(params, min(arenas, episodes), seed, keepers=game.keepers, takers=game.takers,
                              pass_policy=behaviours.pass_policy, getopen_policy=behaviours.getopen_policy,
                              getopen_theta=behaviours.getopen_net, agent_config=game.agent, threads=self.threads,
                              **learning)
        if behaviours.pass_arrays is not None:
            batch.load_pass_arrays(behaviours.pass_arrays)
        done = 0

        def report(collected: int) -> None:
            nonlocal done
            if progress is not None:
                progress(collected - done)
            done = collected

        start = time.perf_counter()
        table = batch.run(total_episodes=episodes, progress=report)
        result = RunResult(self.mode, seed, table.records(params.simulator_step_ms), time.perf_counter() - start,
                           table.cycles, len(table))
        learned = batch.pass_policy_arrays()[0] if behaviours.pass_policy == LEARNED and pass_mode == LEARN else None
        return Played(result, learned)

    def play_candidates(self, candidates: list[Behaviours], seed: int, episodes: int, arenas: int,
                        progress: Progress | None = None) -> list[RunResult]:
        """Each candidate frozen in fresh arenas with the same seeds (common random numbers)."""
        return [self.play(c, seed, episodes, arenas, GREEDY, progress).result for c in candidates]

    def close(self) -> None:
        """Nothing to stop: the arenas of a job end with it."""


__all__ = ["BatchedBackend"]
