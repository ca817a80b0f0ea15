"""The distributed backend of ``keepaway train``: arenas of separate processes (server, coach, keepers,
takers) driven through their coaches' arena ports (architecture, "Channels"; ``protocol.arena``).

Work is cut into chunks of at most ``chunk_episodes`` episodes. A chunk is one ``run_episodes`` request
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
own policy from its own experience, online in its process). The snapshots become the block's result,
the transitions its trace.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import zmq

from agents.pass_wire import pass_arrays_from_payloads, sparse_pass_payloads
from agents.player import report_arrays
from agents.sarsa import SarsaLearner
from protocol import configure, encode
from protocol import messages as m
from protocol.arena import ARENA_MAX_MESSAGE_BYTES, EpisodesDone, RunEpisodes, StopArena, decode_for_trainer
from server.episode_log import EpisodeRecord
from trainer.launch import ArenaFailure, ArenaProcesses
from trainer.run import RunResult

CHUNK_EPISODES = 25  # episodes per request: progress granularity vs. per-request overhead
# SMDP transitions a keeper keeps between two reports: a chunk's worth with room to spare (a keeper
# decides a few times per second of hold time); the size does not change what is learned.
TRANSITION_LOG = 1 << 14
LEARNED = "learned"
POLL_MS = 200
ARENA_CYCLE_TIMEOUT_S = 60.0
# An arena this trainer did not start cannot be watched for dead processes: one that has not answered a
# chunk after this long is given up (a chunk takes seconds to a minute).
ATTACHED_TIMEOUT_S = 900.0
STOP_TIMEOUT_S = 10.0

Progress = Callable[[int], None]


@dataclass(frozen=True)
class Chunk:
    """One request: ``episodes`` episodes from ``seed`` with ``advice``, then ``reports``."""

    episodes: int
    seed: int
    advice: tuple = ()
    reports: tuple = ()

    def request(self) -> RunEpisodes:
        return RunEpisodes(episodes=self.episodes, seed=self.seed, advice=self.advice, reports=self.reports)


@dataclass
class Arena:
    """One arena the trainer drives: its coach's arena endpoint and, if the trainer started it, its
    processes (checked for deaths while a request runs)."""

    name: str
    endpoint: str
    socket: zmq.Socket
    processes: ArenaProcesses | None = None

    def check(self, waited_s: float) -> None:
        """Raise ArenaFailure naming the first dead process of an arena this trainer started, or for an
        attached arena that has not answered for :data:`ATTACHED_TIMEOUT_S`."""
        if self.processes is not None:
            dead = self.processes.first_death(run_finished=arena_never_finishes)
            if dead is not None:
                raise ArenaFailure(f"{self.name}: {dead.describe_exit()}; logs in {self.processes.log_dir}")
        elif waited_s > ATTACHED_TIMEOUT_S:
            raise ArenaFailure(f"{self.name}: no answer for {waited_s:.0f} s; is its coach still running?")


def arena_never_finishes() -> bool:
    """A training arena plays until the trainer stops it: any exit while a request runs is a death."""
    return False


def chunk_seeds(seed: int, episodes: int, chunk_episodes: int) -> list[tuple[int, int]]:
    """A job's chunks as (episodes, seed) pairs: chunk j is seeded ``derive_seed(seed, j)``."""
    from trainer.train import derive_seed

    sizes = [min(chunk_episodes, episodes - start) for start in range(0, episodes, chunk_episodes)]
    return [(n, derive_seed(seed, j)) for j, n in enumerate(sizes)]


def behaviour_advice(game: Any, behaviours: Any, pass_mode: str) -> tuple:
    """The advice that makes an arena's keepers play ``behaviours`` (``trainer.train.Behaviours``):
    :func:`policy_advice`, then with Pass learned :func:`pass_load_advice`."""
    learned = behaviours.pass_policy == LEARNED
    return policy_advice(behaviours) + (pass_load_advice(game, behaviours, pass_mode) if learned else ())


def policy_advice(behaviours: Any) -> tuple:
    """The policy names and the GetOpen net, to every keeper (its input scaling folded in: the advice
    carries the net on the raw variables, docs/advice.md)."""
    policy: dict[str, Any] = {"kind": "policy", "pass": behaviours.pass_policy, "getopen": behaviours.getopen_policy}
    if behaviours.getopen_theta is not None:
        policy["getopen_theta"] = np.ascontiguousarray(behaviours.getopen_net, dtype="<f8").tobytes()
    return (("keepers", policy),)


def pass_load_advice(game: Any, behaviours: Any, pass_mode: str) -> tuple:
    """Each keeper's own Pass policy (fresh learners: zero weights) as ``pass_load`` chunks, and the Sarsa
    mode."""
    config = replace(game.sarsa, transition_log_size=TRANSITION_LOG)
    keepers = behaviours.pass_arrays or [SarsaLearner(game.keepers, game.takers, game.sarsa).save()] * game.keepers
    advice: list = []
    for unum, arrays in enumerate(keepers, start=1):
        advice += [(("l", unum), p) for p in sparse_pass_payloads(arrays, config, {"kind": "pass_load"})]
    advice.append(("keepers", {"kind": "pass_mode", "mode": pass_mode}))
    return tuple(advice)


def keeper_reports(done: list[EpisodesDone], kind: str) -> dict[int, list[dict]]:
    """The report payloads of ``kind`` each keeper (by uniform number) sent in ``done``, in order."""
    out: dict[int, list[dict]] = {}
    for answer in done:
        for side, unum, payload in answer.reports:
            if side == "l" and isinstance(payload, dict) and payload.get("kind") == kind:
                out.setdefault(unum, []).append(payload)
    return out


def transitions_by_keeper(done: list[EpisodesDone]) -> dict[int, dict[str, np.ndarray]]:
    """Every keeper's SMDP transitions reported over ``done``, oldest first, as arrays (agents.player
    ``report_arrays``: state, action, reward, next_action, terminal) plus ``dropped``, the number lost
    from a keeper's ring buffer between two reports."""
    out = {}
    for unum, payloads in keeper_reports(done, "pass_transitions").items():
        parts = [report_arrays(p) for p in payloads if p.get("learner") and p.get("count")]
        parts.sort(key=lambda p: p["first"])
        names = ("state", "action", "reward", "next_action", "terminal")
        arrays = {name: np.concatenate([p[name] for p in parts]) if parts else np.zeros(0) for name in names}
        arrays["dropped"] = np.array(sum(int(p.get("dropped", 0)) for p in payloads if p.get("chunk") == 0))
        out[unum] = arrays
    return out


class DistributedBackend:
    """Plays a training's steps in arenas of processes (module docstring). Use :meth:`start_local` or
    :meth:`attach`, and :meth:`close` (or ``with``) to stop what it started."""

    def __init__(self, game: Any, arenas: list[Arena], chunk_episodes: int = CHUNK_EPISODES) -> None:
        if not arenas:
            raise ValueError("the distributed backend needs at least one arena")
        self.game = game
        self.arenas = arenas
        self.chunk_episodes = chunk_episodes
        self.on_close: Callable[[], None] | None = None  # what else stops the arenas (trainer.ray_backend)

    # -- arenas --------------------------------------------------------------------------------------
    @classmethod
    def start_local(cls, game: Any, count: int, log_dir: Path, parameter_set: str,
                    chunk_episodes: int = CHUNK_EPISODES) -> DistributedBackend:
        """Start ``count`` arenas on this machine (their logs under ``log_dir/arena_NN``)."""
        ctx = zmq.Context.instance()
        arenas: list[Arena] = []
        try:
            for i in range(count):
                where = log_dir / f"arena_{i:02d}"
                processes = ArenaProcesses(where).__enter__()
                arenas.append(Arena(f"arena {i}", "", _socket(ctx), processes))
                endpoints = processes.start_arena(arena_server_args(game, parameter_set, where),
                                                  ["--pass", "handcoded", "--getopen", "handcoded"],
                                                  game.keepers, game.takers, arena_host="127.0.0.1")
                arenas[-1].endpoint = endpoints.arena
                arenas[-1].socket.connect(endpoints.arena)
        except BaseException:
            cls._close(arenas, stop=True)
            raise
        return cls(game, arenas, chunk_episodes)

    @classmethod
    def attach(cls, game: Any, endpoints: Sequence[str], chunk_episodes: int = CHUNK_EPISODES) -> DistributedBackend:
        """Drive arenas started elsewhere (docker-compose, a Ray cluster) through their arena endpoints;
        they must play ``game``. :meth:`close` leaves them running."""
        ctx = zmq.Context.instance()
        arenas = []
        for i, endpoint in enumerate(endpoints):
            arena = Arena(f"arena {i} ({endpoint})", endpoint, _socket(ctx))
            arena.socket.connect(endpoint)
            arenas.append(arena)
        return cls(game, arenas, chunk_episodes)

    def close(self, stop: bool = True) -> None:
        """Stop the arenas this backend started (``stop``; also ``on_close``), close every connection."""
        self._close(self.arenas, stop)
        if stop and self.on_close is not None:
            self.on_close()

    @staticmethod
    def _close(arenas: list[Arena], stop: bool) -> None:
        for arena in arenas:
            if arena.processes is not None and stop:
                try:
                    arena.socket.send(encode(StopArena()), zmq.NOBLOCK)
                except zmq.ZMQError:
                    pass
                arena.processes.wait_all(timeout_s=STOP_TIMEOUT_S)
                arena.processes.stop()
            arena.socket.close(linger=0)

    def __enter__(self) -> DistributedBackend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the backend interface (trainer.train) -------------------------------------------------------
    def play(self, behaviours: Any, seed: int, episodes: int, arenas: int, pass_mode: str,
             progress: Progress | None = None) -> tuple[RunResult, list[dict[str, np.ndarray]] | None, Any]:
        """``episodes`` episodes of ``behaviours`` from ``seed``. Frozen (any mode but learn), the chunks
        spread over the arenas; learning, they run in order in the first arena and the keepers' final
        weights and transitions come back (else None, None). ``arenas`` is the batched mode's batch
        size and does not matter here."""
        start = time.perf_counter()
        learning = behaviours.pass_policy == LEARNED and pass_mode == "learn"
        advice = behaviour_advice(self.game, behaviours, pass_mode)
        plan = chunk_seeds(seed, episodes, self.chunk_episodes)
        if not learning:
            done = self._run([Chunk(n, s, advice) for n, s in plan], progress)
            return self._result(seed, done, time.perf_counter() - start), None, None
        chunks = [Chunk(n, s, advice if j == 0 else (), ("transitions",)) for j, (n, s) in enumerate(plan)]
        chunks[-1] = replace(chunks[-1], reports=("transitions", "snapshot"))
        done = self._run(chunks, progress, self.arenas[:1])
        snapshots = keeper_reports(done[-1:], "pass_snapshot")
        try:
            learned = [pass_arrays_from_payloads(snapshots.get(unum, []))[1] for unum in range(1, self.game.keepers + 1)]
        except ValueError as exc:
            raise ArenaFailure(f"{self.arenas[0].name}: a keeper's weight snapshot is unusable: {exc}") from None
        return self._result(seed, done, time.perf_counter() - start), learned, transitions_by_keeper(done)

    def play_candidates(self, candidates: list[Any], seed: int, episodes: int, arenas: int,
                        progress: Progress | None = None) -> list[RunResult]:
        """Every candidate frozen on the same chunk seeds (common random numbers), all chunks of all
        candidates spread over the arenas at once. The candidates differ in GetOpen only: their Pass
        policies are encoded once."""
        start = time.perf_counter()
        plan = chunk_seeds(seed, episodes, self.chunk_episodes)
        learned = candidates[0].pass_policy == LEARNED
        shared = pass_load_advice(self.game, candidates[0], "greedy") if learned else ()
        chunks = [Chunk(n, s, policy_advice(c) + shared) for c in candidates for n, s in plan]
        done = self._run(chunks, progress)
        per, share = len(plan), (time.perf_counter() - start) / max(1, len(candidates))
        return [self._result(seed, done[i * per:(i + 1) * per], share) for i in range(len(candidates))]

    # -- requests ------------------------------------------------------------------------------------
    def _run(self, chunks: list[Chunk], progress: Progress | None,
             arenas: list[Arena] | None = None) -> list[EpisodesDone]:
        """Run ``chunks`` on ``arenas`` (default all), each arena one at a time, in order of the list;
        return the answers in the order of ``chunks``."""
        arenas = arenas or self.arenas
        answers: list[EpisodesDone | None] = [None] * len(chunks)
        queue = list(range(len(chunks)))
        busy: dict[int, int] = {}  # arena index -> chunk index
        since: dict[int, float] = {}  # arena index -> when its chunk was sent
        poller = zmq.Poller()
        for arena in arenas:
            poller.register(arena.socket, zmq.POLLIN)
        while queue or busy:
            for a, arena in enumerate(arenas):
                if a not in busy and queue:
                    busy[a] = queue.pop(0)
                    since[a] = time.monotonic()
                    arena.socket.send(encode(chunks[busy[a]].request()))
            events = dict(poller.poll(POLL_MS))
            for a, arena in enumerate(arenas):
                if a in busy and arena.socket in events:
                    index = busy.pop(a)
                    answers[index] = self._answer(arena, arena.socket.recv(), chunks[index])
                    if progress is not None:
                        progress(chunks[index].episodes)
                elif a in busy:
                    arena.check(time.monotonic() - since[a])
        return answers  # type: ignore[return-value]

    @staticmethod
    def _answer(arena: Arena, data: bytes, chunk: Chunk) -> EpisodesDone:
        reply = decode_for_trainer(data)
        if isinstance(reply, m.Error):
            raise ArenaFailure(f"{arena.name}: the coach refused a run: {reply.code}: {reply.message}")
        if isinstance(reply, m.Shutdown):
            raise ArenaFailure(f"{arena.name}: the arena shut down: {reply.reason}")
        if len(reply.episodes) != chunk.episodes:
            raise ArenaFailure(f"{arena.name}: asked for {chunk.episodes} episodes, got {len(reply.episodes)}")
        return reply

    def _result(self, seed: int, done: list[EpisodesDone], elapsed_s: float) -> RunResult:
        """The episodes of ``done`` (numbered from 1 in chunk order), played in ``elapsed_s`` of wall time."""
        step_ms = self.game.params.simulator_step_ms
        rows = [row for answer in done for row in answer.episodes]
        records = [EpisodeRecord(i + 1, int(start), int(end), cause, simulator_step_ms=step_ms)
                   for i, (_, start, end, cause) in enumerate(rows)]
        cycles = sum(r.end_cycle - r.start_cycle for r in records)
        return RunResult("distributed", seed, records, elapsed_s, cycles, len(records))


def arena_server_args(game: Any, parameter_set: str, log_dir: Path) -> list[str]:
    """``keepaway server`` options of a training arena: sync mode, no episode limit (the coach paces
    it), and a player that misses a cycle stops the arena rather than letting it go on without that
    player's command, which would change the game (:data:`ARENA_CYCLE_TIMEOUT_S` is far beyond any
    cycle of a loaded machine; a dead player is noticed at once anyway)."""
    return ["--keepers", str(game.keepers), "--takers", str(game.takers),
            "--field-size", str(game.params.keepaway_length), "--params", parameter_set,
            "--cycle-timeout", str(ARENA_CYCLE_TIMEOUT_S), "--max-missed", "1", "--on-hang", "stop",
            "--log-dir", str(log_dir), "--kwy-name", "keepaway"]


def _socket(ctx: zmq.Context) -> zmq.Socket:
    sock = ctx.socket(zmq.DEALER)
    configure(sock, ARENA_MAX_MESSAGE_BYTES)
    return sock


__all__ = ["CHUNK_EPISODES", "Arena", "Chunk", "DistributedBackend", "arena_server_args", "behaviour_advice",
           "chunk_seeds", "keeper_reports", "pass_load_advice", "policy_advice", "transitions_by_keeper"]
