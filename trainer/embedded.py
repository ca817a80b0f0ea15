"""The embedded mode: one arena in one process, no sockets, the same messages and the same code paths.

The server's :class:`server.arena.Arena` and the players' :class:`agents.player.PlayerAgent` talk
through encoded protocol messages exactly as in the distributed synchronous mode (each message is
encoded and decoded, so the agents see the very values a socket would deliver). With the same seed the
embedded and the distributed runs therefore produce the same episodes (architecture, "Determinism").
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from agents.player import PlayerAgent
from agents.policy_file import Policy
from protocol import encode
from protocol import messages as m
from protocol.messages import decode_for_player, decode_from_player
from protocol.params import ServerParams
from server.arena import Arena
from server.episode_log import EpisodeRecord


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


def embedded_episodes(spec: ArenaSpec) -> Iterator[tuple[EpisodeRecord, int]]:
    """Play the arena forever, yielding each ended episode and the cycle count so far."""
    arena = Arena(spec.params, spec.keepers, spec.takers, spec.seed)
    config = {"mode": "sync", "keepers": spec.keepers, "takers": spec.takers, "seed": spec.seed}
    players = []
    for team, count in (("keepers", spec.keepers), ("takers", spec.takers)):
        for _ in range(count):
            agent = PlayerAgent(team, pass_policy=spec.pass_policy, getopen_policy=spec.getopen_policy,
                                policy=spec.policy, seed=spec.seed)
            slot = arena.connect(team)
            agent.on_message(_wire(arena.init_ok(slot, team, config), decode_for_player))
            players.append((slot, agent))
    arena.start()
    while True:
        cycle = arena.cycle
        percepts = [arena.cycle_percepts(slot, arena.see_due(slot, cycle)) for slot, _ in players]
        for (slot, agent), messages in zip(players, percepts):
            for msg in messages:
                agent.on_message(_wire(msg, decode_for_player))
            command = agent.on_message(_wire(m.Think(cycle=cycle), decode_for_player))
            if command is not None:
                arena.submit(slot.obj, _wire(command, decode_from_player).commands)
        record = arena.step()
        if record is not None:
            yield record, arena.cycle
