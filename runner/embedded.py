"""The embedded mode: arenas in this process, no sockets, the same messages and the same code paths.

The server's :class:`server.arena.Arena` and the players' :class:`agents.player.PlayerAgent` talk
through encoded protocol messages exactly as in the distributed synchronous mode (each message is
encoded and decoded, so the agents see the very values a socket would deliver). With the same seed the
embedded and the distributed runs therefore produce the same episodes.

:class:`EmbeddedGame` is one such arena with its players, stepped a cycle at a time: ``keepaway run
--mode embedded`` (:func:`embedded_episodes`), and the reference the batched mode's kernels are tested
against. :meth:`EmbeddedGame.serve` answers a trainer's request as the arena's coach and its paused
server do (``coach/coach.py``, ``server/app.py``), so :class:`EmbeddedBackend` plays the distributed
backend's jobs (``runner.coached``) in this process, with the same episodes and the same learned weights.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from pathlib import Path

from keepaway.agents.config import AgentConfig
from keepaway.agents.player import PassLearnerFactory, PlayerAgent
from keepaway.agents.policy_file import Policy
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.advice import ReportRequest, SeedAdvice, decode_report
from keepaway.protocol.arena import EpisodesDone, RunEpisodes, decode_for_trainer, decode_from_trainer
from keepaway.protocol.messages import decode_for_player, decode_from_player
from keepaway.protocol.params import ServerParams
from keepaway.runner.coached import Chunk, CoachedBackend
from keepaway.runner.job import CHUNK_EPISODES, Game, Progress
from keepaway.server.arena import Arena, PlayerSlot
from keepaway.server.episode_log import EpisodeRecord
from keepaway.server.game_log import ArenaGameLog


@dataclass(frozen=True)
class ArenaSpec:
    """What every mode of ``keepaway run`` needs to build an arena and its players."""

    params: ServerParams
    keepers: int = 3
    takers: int = 2
    seed: int = 0
    pass_policy: str = "handcoded"
    getopen_policy: str = "handcoded"
    policy: Policy | None = None


def _wire(msg: m.Message, decode: Callable[[bytes], m.Message]) -> m.Message:
    return decode(encode(msg))


def _take(player: PlayerAgent, frame: bytes) -> bytes | None:
    """A server frame as a player process takes it (``agents.cli.run_player``): straight from its bytes
    if the player can (:meth:`PlayerAgent.take_frame`), else decoded in full; the frame of the command it
    calls for."""
    taken, command = player.take_frame(frame)
    return command if taken else player.message_frame(decode_for_player(frame))


class EmbeddedGame:
    """One arena of ``spec`` and its players in synchronous mode, kicked off: every player plays
    ``spec``'s policies with ``spec``'s seed and the constants ``agent`` (default: the player processes');
    keepers learning Pass take their learners from ``pass_learner`` (default: the player's own); the
    keepers leave the decisions ``outside`` to the caller (``agents.player``, "Decisions made outside":
    :meth:`think` then leaves them waiting, and the caller sends their commands with :meth:`submit`)."""

    def __init__(self, spec: ArenaSpec, pass_learner: PassLearnerFactory | None = None,
                 agent: AgentConfig | None = None, outside: Collection[str] = (),
                 game_log: Path | None = None, getopen_notes: str = "none") -> None:
        self.arena = Arena(spec.params, spec.keepers, spec.takers, spec.seed)
        # the .rcg of every cycle, as the server writes it (server.game_log), with the keepers'
        # GetOpen notes if ``getopen_notes`` asks for them (as ``keepaway server --getopen-notes``)
        self.game_log = ArenaGameLog(game_log, self.arena) if game_log is not None else None
        config = {"mode": "sync", "keepers": spec.keepers, "takers": spec.takers, "seed": spec.seed,
                  "getopen_notes": getopen_notes}
        self.players: list[tuple[PlayerSlot, PlayerAgent]] = []  # in object order
        for team, count in (("keepers", spec.keepers), ("takers", spec.takers)):
            for _ in range(count):
                player = PlayerAgent(team, pass_policy=spec.pass_policy, getopen_policy=spec.getopen_policy,
                                     policy=spec.policy, seed=spec.seed, config=agent,
                                     pass_learner=pass_learner if team == "keepers" else None,
                                     outside=outside if team == "keepers" else ())
                slot = self.arena.connect(team)
                player.on_message(_wire(self.arena.init_ok(slot, team, config), decode_for_player))
                self.players.append((slot, player))
        self.arena.start()
        if self.game_log is not None:
            self.game_log.start_game()

    def hear(self) -> None:
        """Every queued hear, delivered at once and bare, as a paused server sends them (``server/app.py``)."""
        for slot, player in self.players:
            for frame in self.arena.take_hears(slot):
                _take(player, frame)

    def perceive(self) -> None:
        """This cycle's percepts to every player: sense_body, hears, and the see when one is due."""
        arena = self.arena
        for slot, player in self.players:
            for frame in arena.cycle_frames(slot, arena.see_due(slot, arena.cycle)):
                _take(player, frame)

    def think(self) -> None:
        """Every player's think and command for this cycle (none from a keeper left waiting)."""
        think = encode(m.Think(cycle=self.arena.cycle))
        for slot, player in self.players:
            self.submit(slot, _take(player, think))

    def submit(self, slot: PlayerSlot, frame: bytes | None) -> None:
        """A player's command frame for this cycle, taken as the server takes it (``Arena.submit_frame``,
        or decoded in full if its kernel does not read it)."""
        if frame is not None and self.arena.submit_frame(slot.obj, frame) is None:
            self.arena.submit_command(slot.obj, decode_from_player(frame))

    def step(self) -> EpisodeRecord | None:
        """The arena's step (written to the game log, if any); the record of the episode it ended."""
        record = self.arena.step()
        if self.game_log is not None:
            self.game_log.step()
        return record

    def cycle(self) -> EpisodeRecord | None:
        """One synchronous cycle: percepts, think, every player's commands, the step. Returns the record of
        the episode that ended in it, if any."""
        self.perceive()
        self.think()
        return self.step()

    def serve(self, request: RunEpisodes) -> EpisodesDone:
        """A trainer's request answered as the coach answers it with the server paused at an episode
        boundary (``coach/coach.py``, steps 1-3): the advice, the seed and the restart, heard at once; the
        episodes; at the boundary after the last, the keepers asked for the reports, which they send at
        once."""
        arena = self.arena
        for target, advice in request.advice:
            arena.advise(arena.advice_targets(target), advice.to_wire())
        if request.seed is not None:
            arena.advise(arena.advice_targets("all"), SeedAdvice(seed=request.seed).to_wire())
        arena.reset_episode(request.seed, now_ms=arena.cycle * arena.params.simulator_step_ms)
        self.hear()
        episodes = []
        while len(episodes) < request.episodes:
            record = self.cycle()
            if record is not None:
                episodes.append([record.episode, record.start_cycle, record.end_cycle, record.end])
        for what in request.reports:
            arena.advise(arena.advice_targets("keepers"), ReportRequest(what=what).to_wire())
        self.hear()
        reports = [(slot.side, slot.unum, decode_report(_wire(report, decode_from_player).payload))
                   for slot, player in self.players for report in player.pending_reports()]
        return EpisodesDone(cycle=arena.cycle, episodes=episodes, reports=reports)


def embedded_episodes(spec: ArenaSpec, game_log: Path | None = None,
                      getopen_notes: str = "none") -> Iterator[tuple[EpisodeRecord, int]]:
    """Play the arena forever, yielding each ended episode and the cycle count so far; with ``game_log``
    write every cycle's show there, with the keepers' ``getopen_notes`` (closed when the generator is)."""
    game = EmbeddedGame(spec, game_log=game_log, getopen_notes=getopen_notes)
    try:
        while True:
            record = game.cycle()
            if record is not None:
                yield record, game.arena.cycle
    finally:
        if game.game_log is not None:
            game.game_log.close()


class EmbeddedBackend(CoachedBackend):
    """A ``runner.job.Backend`` of one arena in this process, started as the distributed backend's arenas
    are (hand-coded players, every policy coming as advice) and served its requests in order (module
    docstring). ``game.agent`` sets the players' constants (the player processes use the defaults)."""

    mode = "embedded"

    def __init__(self, game: Game, chunk_episodes: int = CHUNK_EPISODES) -> None:
        super().__init__(game, "the embedded arena", chunk_episodes)
        self.arena = EmbeddedGame(ArenaSpec(game.params, game.keepers, game.takers), agent=game.agent)

    def serve(self, chunks: list[Chunk], progress: Progress | None, in_order: bool) -> list[EpisodesDone]:
        """``runner.coached.CoachedBackend.serve``: the one arena plays every chunk in order, each request
        and answer encoded and decoded as a socket would carry it."""
        answers = []
        for chunk in chunks:
            request = _wire(chunk.request(), decode_from_trainer)
            assert isinstance(request, RunEpisodes)
            answer = _wire(self.arena.serve(request), decode_for_trainer)
            assert isinstance(answer, EpisodesDone)
            answers.append(answer)
            if progress is not None:
                progress(chunk.episodes)
        return answers


__all__ = ["ArenaSpec", "EmbeddedBackend", "EmbeddedGame", "embedded_episodes"]
