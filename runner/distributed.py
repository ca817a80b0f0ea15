"""The distributed backend: arenas of separate processes (server, coach, keepers, takers) driven through
their coaches' arena ports (architecture, "Channels"; ``protocol.arena``).

A job is cut into chunks of requests (``runner.coached``). Frozen jobs spread their chunks over every
free arena; a learning job's chunks run in order in the first arena. The arenas are started here
(:meth:`DistributedBackend.start_local`), placed on a Ray cluster (``runner.ray_backend``), or started
elsewhere and attached to (:meth:`DistributedBackend.attach`, e.g. docker-compose).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import zmq

from keepaway.protocol import configure, encode
from keepaway.protocol import messages as m
from keepaway.protocol.arena import ARENA_MAX_MESSAGE_BYTES, EpisodesDone, StopArena, decode_for_trainer
from keepaway.protocol.security import KeyDir, open_keys, secure_client
from keepaway.runner.coached import Chunk, CoachedBackend
from keepaway.runner.job import CHUNK_EPISODES, Game, Progress
from keepaway.runner.launch import ArenaFailure, ArenaProcesses

# The options a coached arena's players start with (``keepaway player``): every policy comes as advice.
ARENA_PLAYER_ARGS = ("--pass", "handcoded", "--getopen", "handcoded")

POLL_MS = 200
ARENA_CYCLE_TIMEOUT_S = 60.0
# An arena this trainer did not start cannot be watched for dead processes: one that has not answered a
# chunk after this long is given up (a chunk takes seconds to a minute).
ATTACHED_TIMEOUT_S = 900.0
# How often a busy arena whose processes can be watched is asked whether one died (s): a look at its
# processes here, a Ray call to the actor of an arena placed by Ray.
WATCH_EVERY_S = 0.5
STOP_TIMEOUT_S = 10.0


@dataclass
class Arena:
    """One arena the trainer drives: its coach's arena endpoint; if the trainer started it, its processes;
    and if its processes can be watched (started here, or placed by Ray: ``runner.ray_backend``), how to
    learn of one that died (``watch``: the death in one line, or None), asked while a request runs."""

    name: str
    endpoint: str
    socket: zmq.Socket
    processes: ArenaProcesses | None = None
    watch: Callable[[], str | None] | None = None
    watched_at: float = 0.0  # time.monotonic() of the last watch

    def check(self, waited_s: float, at_once: bool = False) -> None:
        """Raise ArenaFailure naming the first dead process of a watched arena (asked at most every
        :data:`WATCH_EVERY_S` unless ``at_once``), or for an arena this trainer did not start that has
        not answered for :data:`ATTACHED_TIMEOUT_S`."""
        now = time.monotonic()
        if self.watch is not None and (at_once or now - self.watched_at >= WATCH_EVERY_S):
            self.watched_at = now
            dead = self.watch()
            if dead is not None:
                raise ArenaFailure(f"{self.name}: {dead}")
        if self.processes is None and waited_s > ATTACHED_TIMEOUT_S:
            raise ArenaFailure(f"{self.name}: no answer for {waited_s:.0f} s; is its coach still running, and "
                               f"is this trainer's key authorised there (--keys)?")


def arena_never_finishes() -> bool:
    """A training arena plays until the trainer stops it: any exit while a request runs is a death."""
    return False


def dead_process(processes: ArenaProcesses, node: str = "") -> str | None:
    """The first process of a training arena that died, named in one line with where its logs are
    (``node``: the machine they are on, for an arena placed elsewhere), or None."""
    dead = processes.first_death(run_finished=arena_never_finishes)
    return None if dead is None else f"{dead.describe_exit()}; logs in {node}{processes.log_dir}"


class DistributedBackend(CoachedBackend):
    """A ``runner.job.Backend`` of arenas of processes (module docstring). Use :meth:`start_local` or
    :meth:`attach`, and :meth:`close` (or ``with``) to stop what it started."""

    mode = "distributed"

    def __init__(self, game: Game, arenas: list[Arena], chunk_episodes: int = CHUNK_EPISODES) -> None:
        if not arenas:
            raise ValueError("the distributed backend needs at least one arena")
        super().__init__(game, arenas[0].name, chunk_episodes)
        self.arenas = arenas
        self.on_close: Callable[[], None] | None = None  # what else stops the arenas (runner.ray_backend)

    # -- arenas --------------------------------------------------------------------------------------
    @classmethod
    def start_local(cls, game: Game, count: int, log_dir: Path, parameter_set: str,
                    chunk_episodes: int = CHUNK_EPISODES, keys: Path | None = None) -> DistributedBackend:
        """Start ``count`` arenas on this machine (their logs under ``log_dir/arena_NN``; with ``keys``
        every connection over CURVE, ``protocol.security``)."""
        ctx = zmq.Context.instance()
        key_dir = open_keys(keys)
        arenas: list[Arena] = []
        try:
            for i in range(count):
                where = log_dir / f"arena_{i:02d}"
                processes = ArenaProcesses(where, batch_scheduled=True).__enter__()  # synchronous arenas
                arenas.append(Arena(f"arena {i}", "", _socket(ctx, key_dir), processes,
                                    watch=lambda processes=processes: dead_process(processes)))
                endpoints = processes.start_arena(arena_server_args(game, parameter_set, where),
                                                  list(ARENA_PLAYER_ARGS), game.keepers, game.takers,
                                                  arena_host="127.0.0.1", keys=keys)
                arenas[-1].endpoint = endpoints.arena
                arenas[-1].socket.connect(endpoints.arena)
        except BaseException:
            cls._close(arenas, stop=True)
            raise
        return cls(game, arenas, chunk_episodes)

    @classmethod
    def attach(cls, game: Game, endpoints: Sequence[str], chunk_episodes: int = CHUNK_EPISODES,
               keys: Path | None = None) -> DistributedBackend:
        """Drive arenas started elsewhere (docker-compose, a Ray cluster) through their arena endpoints
        (with ``keys``, over CURVE); they must play ``game``. :meth:`close` leaves them running."""
        ctx = zmq.Context.instance()
        key_dir = open_keys(keys)
        arenas = []
        for i, endpoint in enumerate(endpoints):
            arena = Arena(f"arena {i} ({endpoint})", endpoint, _socket(ctx, key_dir))
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

    # -- requests ------------------------------------------------------------------------------------
    def serve(self, chunks: list[Chunk], progress: Progress | None, in_order: bool) -> list[EpisodesDone]:
        """``runner.coached.CoachedBackend.serve``: each arena takes the next chunk of the list when it is
        free; ``in_order``, only the first arena plays."""
        arenas = self.arenas[:1] if in_order else self.arenas
        answers: list[EpisodesDone | None] = [None] * len(chunks)
        queue = list(range(len(chunks)))
        busy: dict[int, int] = {}  # arena index -> chunk index
        since: dict[int, float] = {}  # arena index -> when its chunk was handed to it
        unsent: dict[int, bytes] = {}  # busy arena index -> its encoded request, until ZeroMQ takes it
        poller = zmq.Poller()
        for arena in arenas:
            poller.register(arena.socket, zmq.POLLIN)
        while queue or busy:
            for a, arena in enumerate(arenas):
                if a not in busy and queue:
                    busy[a] = queue.pop(0)
                    since[a] = time.monotonic()
                    unsent[a] = encode(chunks[busy[a]].request())
                if a in unsent and _send_now(arena.socket, unsent[a]):
                    del unsent[a]
            events = dict(poller.poll(POLL_MS))
            for a, arena in enumerate(arenas):
                if a in busy and a not in unsent and arena.socket in events:
                    index = busy.pop(a)
                    try:
                        answers[index] = self._answer(arena, arena.socket.recv(), chunks[index])
                    except ArenaFailure:
                        arena.check(0.0, at_once=True)  # a dead process that explains it is the better line
                        raise
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


def arena_server_args(game: Game, parameter_set: str, log_dir: Path) -> list[str]:
    """``keepaway server`` options of a training arena: sync mode, no episode limit (the coach paces
    it), and a player that misses a cycle stops the arena rather than letting it go on without that
    player's command, which would change the game (:data:`ARENA_CYCLE_TIMEOUT_S` is far beyond any
    cycle of a loaded machine; a dead player is noticed at once anyway)."""
    return ["--keepers", str(game.keepers), "--takers", str(game.takers),
            "--field-size", str(game.params.keepaway_length), "--params", parameter_set,
            "--cycle-timeout", str(ARENA_CYCLE_TIMEOUT_S), "--max-missed", "1", "--on-hang", "stop",
            "--log-dir", str(log_dir), "--kwy-name", "keepaway"]


def _send_now(sock: zmq.Socket, data: bytes) -> bool:
    """Hand ``data`` to ZeroMQ without waiting; False if it cannot take it now. A DEALER whose only
    connection has no peer (an arena that refused this trainer's CURVE handshake drops it) would block a
    plain send for ever; retried instead, the wait is bounded by :meth:`Arena.check`."""
    try:
        sock.send(data, zmq.NOBLOCK)
    except zmq.Again:
        return False
    return True


def _socket(ctx: zmq.Context, keys: KeyDir | None) -> zmq.Socket:
    sock = ctx.socket(zmq.DEALER)
    configure(sock, ARENA_MAX_MESSAGE_BYTES)
    secure_client(sock, keys)
    return sock


__all__ = ["ARENA_PLAYER_ARGS", "Arena", "DistributedBackend", "arena_server_args", "dead_process"]
