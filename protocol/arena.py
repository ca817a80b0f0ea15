"""The arena port: a trainer's requests to one arena's coach (architecture, "Channels": arena port).

A trainer (DEALER) asks a coach (ROUTER) to run episodes: the coach first delivers the request's advice
(policies, Pass weights, a Sarsa mode, to keepers or to one keeper), restarts the episode (with a
``seed``: as a fresh arena started with that seed would play, server and players reseeded), lets the
server play exactly ``episodes`` episodes and pause at the boundary, asks the keepers for the
``reports`` wanted (SMDP transitions, weight snapshots) and answers with the ground-truth episode
records and those reports. A request with a seed therefore plays the same whatever the arena played
before (docs/advice.md, docs/design.md "Distributed training").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from keepaway.protocol.advice import REPORTS, advice_value, report_value
from keepaway.protocol.codec import Message, choice, decode, fixed, integer, message, optional, sequence, wire
from keepaway.protocol.messages import (
    CYCLE,
    EPISODE_ENDS,
    MAX_CYCLE,
    SEED,
    SIDE,
    UNUM,
    Error,
    Shutdown,
    _advice_target,
    _by_type,
)

MAX_EPISODES_PER_REQUEST = 1_000_000
MAX_RECORDS = 1_000_000
EPISODE_RECORD = fixed(integer(1, MAX_CYCLE), CYCLE, CYCLE, choice(*EPISODE_ENDS))
MAX_ADVICE = 1024
# The arena port carries whole Pass policies one way and every keeper's reports the other: its frames
# may be far larger than a player's (the trainer is trusted; ZeroMQ still enforces this bound).
ARENA_MAX_MESSAGE_BYTES = 1 << 28


@message
class RunEpisodes(Message):
    """Deliver ``advice`` (``(target, advice)`` pairs, targets as in ``advice``, each advice a message of
    ``protocol.advice``), restart the episode (reseeded if ``seed`` is given), play ``episodes`` episodes,
    then collect ``reports`` (of :data:`~protocol.advice.REPORTS`) from every keeper."""

    TYPE: ClassVar[str] = "run_episodes"
    episodes: int = wire(integer(1, MAX_EPISODES_PER_REQUEST))
    seed: int | None = wire(optional(SEED), default=None)
    advice: tuple = wire(sequence(fixed(_advice_target, advice_value), MAX_ADVICE), default=(),
                         dump=lambda pairs: [[target, advice.to_wire()] for target, advice in pairs])
    reports: tuple = wire(sequence(choice(*REPORTS), len(REPORTS)), default=())


@message
class EpisodesDone(Message):
    """The answer to :class:`RunEpisodes`: ``[episode, start_cycle, end_cycle, end]`` per episode and the
    keepers' reports (``(side, unum, report)``, a report message of ``protocol.advice`` per chunk of every
    report asked for)."""

    TYPE: ClassVar[str] = "episodes_done"
    cycle: int = wire(CYCLE)
    episodes: tuple = wire(sequence(EPISODE_RECORD, MAX_RECORDS))
    reports: tuple = wire(sequence(fixed(SIDE, UNUM, report_value), MAX_RECORDS), default=(),
                          dump=lambda rows: [[side, unum, report.to_wire()] for side, unum, report in rows])


@message
class StopArena(Message):
    """Stop the arena: the coach tells the server to stop, which ends every player."""

    TYPE: ClassVar[str] = "stop_arena"


TRAINER_TO_COACH: Mapping[str, type[Message]] = _by_type(RunEpisodes, StopArena)
COACH_TO_TRAINER: Mapping[str, type[Message]] = _by_type(EpisodesDone, Error, Shutdown)


def decode_from_trainer(data: bytes, max_bytes: int = ARENA_MAX_MESSAGE_BYTES) -> Message:
    return decode(data, TRAINER_TO_COACH, max_bytes)


def decode_for_trainer(data: bytes, max_bytes: int = ARENA_MAX_MESSAGE_BYTES) -> Message:
    return decode(data, COACH_TO_TRAINER, max_bytes)
