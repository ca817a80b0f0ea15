"""The arena port: a trainer's requests to one arena's coach (architecture, "Channels": arena port).

A trainer (DEALER) asks a coach (ROUTER) to run episodes, optionally first advising the keepers (a
GetOpen net, a Pass learning mode); the coach answers with the ground-truth episode records and the
players' reports collected meanwhile. Advice applies from the next episode boundary, so an arena's
results depend only on its seed and the requests it was sent.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

from protocol.codec import Message, decode, fixed, integer, message, optional, payload_value, sequence, wire, choice
from protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES
from protocol.messages import CYCLE, EPISODE_ENDS, MAX_CYCLE, Error, Shutdown, _by_type

MAX_EPISODES_PER_REQUEST = 1_000_000
MAX_RECORDS = 1_000_000
EPISODE_RECORD = fixed(integer(1, MAX_CYCLE), CYCLE, CYCLE, choice(*EPISODE_ENDS))


@message
class RunEpisodes(Message):
    """Run ``episodes`` more episodes; ``advice`` (if any) goes to the keepers first."""

    TYPE: ClassVar[str] = "run_episodes"
    episodes: int = wire(integer(1, MAX_EPISODES_PER_REQUEST))
    advice: Any = wire(optional(payload_value), default=None)


@message
class EpisodesDone(Message):
    """The answer to :class:`RunEpisodes`: ``[episode, start_cycle, end_cycle, end]`` per episode and the
    players' reports (``[side, unum, payload]``) that arrived while they ran."""

    TYPE: ClassVar[str] = "episodes_done"
    cycle: int = wire(CYCLE)
    episodes: tuple = wire(sequence(EPISODE_RECORD, MAX_RECORDS))
    reports: tuple = wire(sequence(payload_value, MAX_RECORDS), default=())


@message
class StopArena(Message):
    """Stop the arena: the coach tells the server to stop, which ends every player."""

    TYPE: ClassVar[str] = "stop_arena"


TRAINER_TO_COACH: Mapping[str, type[Message]] = _by_type(RunEpisodes, StopArena)
COACH_TO_TRAINER: Mapping[str, type[Message]] = _by_type(EpisodesDone, Error, Shutdown)


def decode_from_trainer(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    return decode(data, TRAINER_TO_COACH, max_bytes)


def decode_for_trainer(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    return decode(data, COACH_TO_TRAINER, max_bytes)
