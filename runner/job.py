"""What a job is, whichever backend plays it: the game, the policies, the episodes that come back, the seeds.

A job is "play ``episodes`` episodes of these :class:`Behaviours` in this Sarsa mode, from this seed" in
arenas of one :class:`Game`. A :class:`Backend` plays jobs; the trainer (``trainer.train``), ``keepaway
evaluate`` and ``keepaway experiment`` ask for nothing else, so each runs on every backend:

* ``runner.batched_backend.BatchedBackend``: in-process arenas stepped together by compiled kernels;
* ``runner.embedded.EmbeddedBackend``: one in-process arena of the server's ``Arena`` and the players'
  ``PlayerAgent`` objects, served as a coach serves a trainer;
* ``runner.distributed.DistributedBackend``: arenas of server, coach and player processes, started here,
  attached to, or placed on a Ray cluster (``runner.ray_backend``).

Every backend cuts a job into the same chunks of at most :data:`CHUNK_EPISODES` episodes, chunk j seeded
``derive_seed(seed, j)`` (:func:`chunk_seeds`), and plays each chunk as a fresh arena with that seed plays
its first episodes; a learning job's chunks follow one another, the keepers' weights carried over. So
every backend plays the same episodes and learns the same weights from one seed.

A leaf of the runner: it imports no other module of ``runner`` (nor ``trainer``), so every backend and
every learner can build on it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple, Protocol

import numpy as np

from keepaway.agents.config import AgentConfig
from keepaway.agents.getopen import InputScaling
from keepaway.agents.player import LEARNED
from keepaway.agents.sarsa import SarsaConfig
from keepaway.protocol.params import ServerParams
from keepaway.runner import MODES  # the backends (module docstring)
from keepaway.server.episode_log import EpisodeRecord
from keepaway.server.referee import END_OUT

LEARN = "learn"  # Sarsa modes (agents.sarsa.MODE_NAMES): learning, ...
GREEDY = "greedy"  # ... and the frozen Pass policy: greedy actions, no updates (docs/players.md §6.3)
# The Sarsa sizes every backend's learners use by default: a 2^16 weight table per keeper, 4,096 live
# traces (ample for lambda = 0: one action's 416 tiles at a time), a 64-transition log (the batched mode
# reports none); the table size is argued in runner/batched.py's docstring.
BATCHED_SARSA = SarsaConfig(table_size=1 << 16, max_traces=4096, transition_log_size=64)

# The registry of random streams: derive_seed(seed, trial, stream, index) for a trial's streams, so no
# two uses of a training's seed draw the same numbers. New streams take the next free number.
STREAM_CEM = 0
STREAM_GENERATION = 1  # index: generation
STREAM_PASS_BLOCK = 2  # index: episodes trained when the block starts
STREAM_EVALUATION = 3  # index: episodes trained at the evaluation
STREAM_INITIAL_NET = 4
STREAM_CROSS_TEST = 5  # Table 2's cross-tests of a trial's policies (trainer.experiments)

CHUNK_EPISODES = 25  # episodes per chunk: a coached arena's request (progress granularity vs. overhead)


def derive_seed(seed: int, *path: int) -> int:
    """An arena or CEM seed below 2^31 for the random stream ``path`` of the run seeded ``seed`` (a
    trial's streams: the registry above; a job's chunks: :func:`chunk_seeds`)."""
    return int(np.random.SeedSequence([int(seed), *map(int, path)]).generate_state(1, dtype=np.uint32)[0] >> 1)


def chunk_seeds(seed: int, episodes: int, chunk_episodes: int = CHUNK_EPISODES) -> list[tuple[int, int]]:
    """A job's chunks as (episodes, seed) pairs: chunk j is seeded ``derive_seed(seed, j)``."""
    sizes = [min(chunk_episodes, episodes - start) for start in range(0, episodes, chunk_episodes)]
    return [(n, derive_seed(seed, j)) for j, n in enumerate(sizes)]


@dataclass(frozen=True)
class Game:
    """What every arena of a backend is built from, besides the policies: the same for every job."""

    params: ServerParams
    keepers: int = 3
    takers: int = 2
    sarsa: SarsaConfig = BATCHED_SARSA  # the learning keepers' constants and sizes
    # the players' constants (the policies are set per job); in-process backends only: the player
    # processes of the distributed backend use the defaults
    agent: AgentConfig = AgentConfig()

    def learning_at(self, alpha: float | None) -> Game:
        """This game with the learning keepers' Sarsa step size ``alpha`` (None: this game's)."""
        return self if alpha is None else replace(self, sarsa=replace(self.sarsa, alpha=alpha))


PassArrays = dict[str, np.ndarray]  # one keeper's Pass policy (agents.sarsa.policy_arrays)
Transitions = dict[int, dict[str, np.ndarray]]  # keeper uniform number -> its SMDP transitions as arrays


@dataclass
class Behaviours:
    """The policies the keepers play in a job: a policy name each, with the learned parameters if any:
    ``getopen_theta`` the GO:L net on the inputs scaled by ``getopen_inputs`` (None: raw inputs; the net
    that plays is :attr:`getopen_net`); ``pass_arrays`` holds every keeper's own Pass policy, None with
    Pass learned means fresh learners."""

    pass_policy: str
    getopen_policy: str
    getopen_theta: np.ndarray | None = None
    pass_arrays: list[PassArrays] | None = None
    getopen_inputs: InputScaling | None = None

    @property
    def getopen_net(self) -> np.ndarray | None:
        """The GO:L parameters on the raw state variables (the scaling folded in): what the arenas and
        the coach's advice take."""
        if self.getopen_theta is None or self.getopen_inputs is None:
            return self.getopen_theta
        return self.getopen_inputs.fold(self.getopen_theta)


@dataclass(frozen=True)
class EpisodeTable:
    """Episodes of in-process arenas in the order they ended (ties in a cycle: by arena); ``cycles``:
    arena-cycles simulated in total (every arena's cycles summed)."""

    arena: np.ndarray  # int64
    episode: np.ndarray  # int64, per arena from 1
    start_cycle: np.ndarray  # int64
    end_cycle: np.ndarray  # int64
    end: np.ndarray  # int8: 1 out of the region, 2 taken (server.referee END_*)
    cycles: int

    def __len__(self) -> int:
        return len(self.arena)

    @property
    def hold_cycles(self) -> np.ndarray:
        """Episode lengths in cycles (hold time, docs/players.md §1)."""
        return self.end_cycle - self.start_cycle

    @classmethod
    def concatenate(cls, parts: list[EpisodeTable]) -> EpisodeTable:
        """The episodes of consecutive chunks (``runner.batched.BatchedArenas.chunks``), in one table."""
        return cls(*(np.concatenate([getattr(p, name) for p in parts])
                     for name in ("arena", "episode", "start_cycle", "end_cycle", "end")),
                   cycles=sum(p.cycles for p in parts))

    def records(self, simulator_step_ms: float) -> list[EpisodeRecord]:
        """The episodes as records, numbered from 1 in the order they ended."""
        return [EpisodeRecord(i + 1, int(s), int(e), "out" if end == END_OUT else "taken",
                              simulator_step_ms=simulator_step_ms)
                for i, (s, e, end) in enumerate(zip(self.start_cycle, self.end_cycle, self.end))]


@dataclass
class RunResult:
    """The episodes a job (or ``keepaway run``) played, and the wall time and simulated cycles of its rates."""

    mode: str
    seed: int
    episodes: list[EpisodeRecord]
    elapsed_s: float  # wall time over which cycles_per_s / episodes_per_s are measured
    cycles: int  # simulated cycles in that time
    rate_episodes: int  # episodes ended in that time

    @property
    def hold_times(self) -> list[float]:
        return [e.hold_time_s for e in self.episodes]

    def summary(self) -> dict:
        """The machine-readable summary (``runner.run``). A value that is undefined is None, never NaN:
        the mean without episodes, the standard error with fewer than two, the rates without elapsed time."""
        holds = self.hold_times
        n = len(holds)
        mean = sum(holds) / n if n else None
        stderr = None
        if mean is not None and n > 1:
            stderr = math.sqrt(sum((h - mean) ** 2 for h in holds) / (n - 1) / n)
        return {
            "mode": self.mode,
            "seed": self.seed,
            "episodes": [{"episode": e.episode, "start_cycle": e.start_cycle, "end_cycle": e.end_cycle,
                          "hold_time_s": e.hold_time_s, "end": e.end} for e in self.episodes],
            "mean_hold_time_s": mean,
            "stderr_hold_time_s": stderr,
            "cycles_per_s": self.cycles / self.elapsed_s if self.elapsed_s > 0 else None,
            "episodes_per_s": self.rate_episodes / self.elapsed_s if self.elapsed_s > 0 else None,
        }


Progress = Callable[[int], None]  # called with the number of episodes just played


class Played(NamedTuple):
    """A job's outcome: its episodes and, when Pass learned (mode learn), every keeper's new Pass policy
    and (backends whose keepers report them) the SMDP transitions they learned from."""

    result: RunResult
    pass_arrays: list[PassArrays] | None = None
    transitions: Transitions | None = None


class Job(NamedTuple):
    """One job: :meth:`Backend.play`'s arguments, for :meth:`Backend.play_all`."""

    behaviours: Behaviours
    seed: int
    episodes: int
    pass_mode: str
    alpha: float | None = None

    @property
    def learns(self) -> bool:
        """Whether the job's keepers learn Pass (and hand on new policies)."""
        return self.behaviours.pass_policy == LEARNED and self.pass_mode == LEARN


class Backend(Protocol):
    """Plays jobs in arenas of :attr:`game` (module docstring). A job depends only on its arguments:
    never on the jobs played before it, nor on how many arenas or threads share it."""

    game: Game

    def play(self, behaviours: Behaviours, seed: int, episodes: int, pass_mode: str,
             progress: Progress | None = None, alpha: float | None = None) -> Played:
        """``episodes`` episodes of ``behaviours`` from ``seed`` (its chunks: module docstring), the learned
        Pass policy (if any) in Sarsa mode ``pass_mode`` (every keeper starting from
        ``behaviours.pass_arrays``) with step size ``alpha`` (None: the game's)."""
        ...

    def play_all(self, jobs: Sequence[Job], progress: Progress | None = None) -> list[Played]:
        """Independent jobs (e.g. a CEM generation's candidates, the same step of several trials), each
        played as :meth:`play` plays it alone: the same episodes, the same learned policies. The backend
        may play them side by side."""
        ...

    def close(self) -> None:
        """Stop whatever the backend started."""
        ...


__all__ = ["BATCHED_SARSA", "CHUNK_EPISODES", "GREEDY", "LEARN", "LEARNED", "MODES", "STREAM_CEM", "STREAM_CROSS_TEST",
           "STREAM_EVALUATION", "STREAM_GENERATION", "STREAM_INITIAL_NET", "STREAM_PASS_BLOCK", "Backend", "Behaviours",
           "EpisodeTable", "Game", "Job", "PassArrays", "Played", "Progress", "RunResult", "Transitions", "chunk_seeds",
           "derive_seed"]
