"""Every message of the players, coach and monitor ports (docs/protocol.md).

One frozen dataclass per message type; ``TYPE`` is the wire ``"type"``. Messages the server sends carry
``cycle``, the server time when sent. Sequences are tuples in Python and arrays on the wire. Ranges are
checked here only as far as they describe the *shape* of a message (an id, a uniform number, a finite
number); clamping command arguments is the simulator's job, done exactly as rcssserver does
(docs/rules.md §2).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

from keepaway.protocol.codec import (
    PROTOCOL_VERSION,
    Invalid,
    Loader,
    Message,
    boolean,
    choice,
    decode,
    fixed,
    integer,
    is_finite_float,
    kind,
    message,
    non_negative,
    number,
    optional,
    payload_value,
    protocol_version,
    record,
    row,
    rows,
    sequence,
    show,
    text,
    wire,
)
from keepaway.protocol.endpoints import DEFAULT_MAX_MESSAGE_BYTES, MONITOR_EPISODE_TOPIC, MONITOR_FRAME_TOPIC
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.params import MAX_TEAM_SIZE, ServerParams

# ------------------------------------------------------------------------------------------ vocabulary

TEAMS = ("keepers", "takers")
SIDES = ("l", "r")  # keepers play on the left side, takers on the right (docs/protocol.md §4)
PLAY_MODES = ("before_kick_off", "play_on")
VIEW_WIDTHS = ("narrow", "normal", "wide")
VIEW_QUALITIES = ("high", "low")
COLLISIONS = ("ball", "player", "post")
HEAR_SENDERS = ("referee", "self", "coach", "our", "opp")
PLAYER_HEAR_SENDERS = ("self", "our", "opp")  # the senders that are players
ADVICE_GROUPS = ("keepers", "takers", "all")
EPISODE_ACTIONS = ("reset", "pause", "resume", "stop")
EPISODE_ENDS = ("out", "taken")
WAITING_REASONS = ("players", "coach", "paused")  # why no cycle is played (``waiting``)
WAITING_INTERVAL_S = 1.0  # a ``waiting`` goes to every player this often while no cycle is played
# A joined client gives the server up after this long without a message from it (``keepaway player
# --server-silence``, the attached environment): a playing server sends percepts every cycle, a waiting
# or paused one a ``waiting`` every WAITING_INTERVAL_S.
SERVER_SILENCE_S = 30.0
COMMAND_COUNTS = ("kick", "dash", "turn", "catch", "move", "turn_neck", "change_view", "say")

# ------------------------------------------------------------------------------------------------ limits

MAX_UNUM = MAX_TEAM_SIZE
MAX_CYCLE = 2**31 - 1
MAX_COMMANDS = 16
MAX_CLIENT_CHARS = 64
MAX_SAY_CHARS = 256  # the codec's bound; the server applies say_msg_size (docs/rules.md §2)
MAX_CODE_CHARS = 64
MAX_TEXT_CHARS = 1024
MAX_LANDMARK_NAME_CHARS = 32
MAX_LANDMARKS = 256
MAX_PLAYERS = 2 * MAX_UNUM
PLAYER_NAME_CHARS = 16  # "keeper 11", "taker 11"

# --------------------------------------------------------------------------------------- field loaders

CYCLE = integer(0, MAX_CYCLE)
COUNT = integer(0, MAX_CYCLE)
UNUM = integer(1, MAX_UNUM)
DIRECTION = integer(-180, 180)  # integer degrees in percepts (docs/rules.md §5.2)
LANDMARK_ID = integer(0, MAX_LANDMARKS - 1)  # index into init_ok's landmark lists
TEAM = choice(*TEAMS)
SIDE = choice(*SIDES)
PLAY_MODE = choice(*PLAY_MODES)
CLIENT = text(MAX_CLIENT_CHARS)
TEXT = text(MAX_TEXT_CHARS)
CHANGE = optional(number)

_LANDMARK_LIST = sequence(fixed(text(MAX_LANDMARK_NAME_CHARS), number, number), MAX_LANDMARKS)
LANDMARKS = record(flags=_LANDMARK_LIST, lines=_LANDMARK_LIST)

BALL_STATE = fixed(number, number, number, number)
PLAYER_STATE = fixed(SIDE, UNUM, *(number,) * 10)
PLAYER_STATES = sequence(PLAYER_STATE, MAX_PLAYERS)
STATE = record(
    ball=BALL_STATE, players=PLAYER_STATES, play_mode=PLAY_MODE, episode=COUNT, episode_start=CYCLE,
    take_count=COUNT
)


def _config(value: Any) -> dict:
    """A free map (string keys, payload values)."""
    if type(value) is not dict:
        raise Invalid("bad_type", f"expected a map, got {kind(value)}")
    return payload_value(value)


def _params(value: Any) -> dict:
    """The ``ServerParams.to_dict()`` map: every name known to this side's parameter table."""
    if type(value) is not dict:
        raise Invalid("bad_type", f"expected a map, got {kind(value)}")
    for key, entry in value.items():
        if type(key) is not str:
            raise Invalid("malformed", f"map keys must be strings, got {kind(key)}")
        if type(entry) not in (bool, int, float, str):
            raise Invalid("bad_type", f"parameter {show(key)} is a {kind(entry)}")
    try:
        ServerParams.from_dict(value)
    except (ValueError, TypeError) as exc:
        raise Invalid("bad_value", " ".join(str(exc).split())[:200]) from None
    return value


# ------------------------------------------------------------------------------------- atomic commands


@dataclass(frozen=True, slots=True)
class AtomicCommand:
    """One rcssserver command, e.g. ``AtomicCommand("dash", (100.0, 0.0))``; on the wire
    ``["dash", 100.0, 0.0]``. Numeric arguments are floats after decoding."""

    name: str
    args: tuple = ()

    def to_wire(self) -> list:
        return [self.name, *self.args]

    def __iter__(self) -> Iterator:
        """``name, args = command``: it unpacks as the (name, args) pairs the server's command reader
        gives (``server.command_frame``), so one ``Arena.submit`` takes both."""
        return iter((self.name, self.args))


COMMAND_ARGUMENTS: Mapping[str, tuple[tuple[Loader, ...], tuple[Loader, ...]]] = MappingProxyType({
    # name: (required argument loaders, optional argument loaders); docs/protocol.md §5, "command"
    "dash": ((number,), (number,)),  # power[, direction]
    "turn": ((number,), ()),  # moment
    "kick": ((number, number), ()),  # power, direction
    "turn_neck": ((number,), ()),  # moment
    "tackle": ((number,), ()),  # power
    "move": ((number, number), ()),  # x, y
    "catch": ((number,), ()),  # direction
    "say": ((text(MAX_SAY_CHARS),), ()),  # message
    "change_view": ((choice(*VIEW_WIDTHS),), (choice(*VIEW_QUALITIES),)),  # width[, quality]
    "done": ((), ()),
})


_ARGUMENT_SPECS = {
    name: (len(required), len(required) + len(extra), required + extra)
    for name, (required, extra) in COMMAND_ARGUMENTS.items()
}


def _atomic_command(value: Any) -> AtomicCommand:
    if type(value) is not list and type(value) is not tuple:
        raise Invalid("bad_type", f"expected an array [name, args...], got {kind(value)}")
    if not value:
        raise Invalid("bad_value", "empty command")
    name = value[0]
    if type(name) is not str:
        raise Invalid("bad_type", f"command name must be a str, got {kind(name)}")
    spec = _ARGUMENT_SPECS.get(name)
    if spec is None:
        raise Invalid("unknown_command", f"unknown command {show(name)}")
    fewest, most, loaders = spec
    given = len(value) - 1
    if not fewest <= given <= most:
        expected = f"{fewest}" if fewest == most else f"{fewest} or {most}"
        raise Invalid("bad_value", f"{name} takes {expected} arguments, got {given}")
    args: list = []
    try:
        for load, argument in zip(loaders, value[1:]):
            args.append(load(argument))
    except Invalid as exc:
        raise exc.at(f"[{len(args) + 1}]") from None
    return AtomicCommand(name, tuple(args))


def _commands_to_wire(commands: tuple[AtomicCommand, ...]) -> list[list]:
    return [command.to_wire() for command in commands]


def _advice_target(value: Any) -> str | tuple[str, int]:
    if type(value) is str:
        return choice(*ADVICE_GROUPS)(value)
    if type(value) is list or type(value) is tuple:
        return fixed(SIDE, UNUM)(value)
    raise Invalid("bad_type", f"expected a str or a [side, unum] array, got {kind(value)}")


# ---------------------------------------------------------------------------- players port: from client


@message
class Init(Message):
    """Join a team; answered by ``init_ok`` or ``error`` (rcssserver's ``(init ...)``; docs/protocol.md §5, "init")."""

    TYPE: ClassVar[str] = "init"
    version: int = wire(protocol_version, default=PROTOCOL_VERSION, required=True)
    team: str = wire(TEAM)
    unum: int | None = wire(optional(UNUM), default=None)
    client: str = wire(CLIENT, default="")
    fullstate: bool = wire(boolean, default=False)
    synch_see: bool = wire(boolean, default=False)
    pre_kick_off: bool = wire(boolean, default=False)


@message
class Reconnect(Message):
    """Take over uniform number ``unum`` of ``team`` again after a ``bye`` (docs/protocol.md §5, "reconnect")."""

    TYPE: ClassVar[str] = "reconnect"
    version: int = wire(protocol_version, default=PROTOCOL_VERSION, required=True)
    team: str = wire(TEAM)
    unum: int = wire(UNUM)


GETOPEN_NOTE_MODES = ("none", "target", "values")  # what keepers note, as ``init_ok``'s config asks
MAX_NOTE_POINTS = 121  # grid points one GetOpen note may rate (an 11 x 11 grid)
MAX_NOTE_NUMBERS = 2 + 3 * MAX_NOTE_POINTS  # its target's two, then three a point
_NOTE_NUMBERS = sequence(number, MAX_NOTE_NUMBERS)


def getopen_note(value: Any) -> tuple[float, ...]:
    """A keeper's GetOpen note: ``[]`` (none), or ``[tx, ty]`` (the point its GetOpen moves to) followed
    by ``x, y, value`` per grid point its policy rated (higher is better)."""
    numbers = _NOTE_NUMBERS(value)
    if len(numbers) == 1 or (len(numbers) > 2 and (len(numbers) - 2) % 3):
        raise Invalid("bad_value", f"a GetOpen note is [tx, ty, x1, y1, v1, ...]; got {len(numbers)} numbers")
    return numbers


@message
class Command(Message):
    """The atomic commands answering cycle ``cycle``; a keeper's ``getopen`` note when the server asks
    for notes (``init_ok``'s ``config["getopen_notes"]``) and it ran GetOpen this cycle."""

    TYPE: ClassVar[str] = "command"
    cycle: int = wire(CYCLE)
    commands: tuple[AtomicCommand, ...] = wire(
        sequence(_atomic_command, MAX_COMMANDS), default=(), dump=_commands_to_wire
    )
    getopen: tuple[float, ...] = wire(getopen_note, default=())


@message
class Report(Message):
    """A player's report to its coach (traces, weight snapshots), relayed as ``player_report``."""

    TYPE: ClassVar[str] = "report"
    cycle: int = wire(CYCLE)
    payload: Any = wire(payload_value)


@message
class Bye(Message):
    """Leave the game (rcssserver's ``(bye)``)."""

    TYPE: ClassVar[str] = "bye"


@message
class SynchSee(Message):
    """Switch to rcssserver's synch_see mode for ``see`` from the next cycle on, for good (rcssserver's
    ``(synch_see)``; ``Init.synch_see`` asks for it at the init)."""

    TYPE: ClassVar[str] = "synch_see"


# ------------------------------------------------------------------------------ players port: to client


@message
class InitOk(Message):
    """Accepted: who the player is and everything it must know about the simulation."""

    TYPE: ClassVar[str] = "init_ok"
    version: int = wire(protocol_version, default=PROTOCOL_VERSION, required=True)
    cycle: int = wire(CYCLE)
    side: str = wire(SIDE)
    unum: int = wire(UNUM)
    team: str = wire(TEAM)
    play_mode: str = wire(PLAY_MODE)
    params: dict = wire(_params)
    landmarks: dict = wire(LANDMARKS)
    config: dict = wire(_config)


@message
class Error(Message):
    """A refused message or request, or a warning (e.g. a dropped ``say``)."""

    TYPE: ClassVar[str] = "error"
    cycle: int = wire(CYCLE)
    code: str = wire(text(MAX_CODE_CHARS))
    message: str = wire(TEXT)


@message
class SenseBody(Message):
    """The player's own body, every cycle (rcssserver's ``sense_body``; docs/rules.md §5.3)."""

    TYPE: ClassVar[str] = "sense_body"
    cycle: int = wire(CYCLE)
    view_mode: tuple[str, str] = wire(fixed(choice(*VIEW_QUALITIES), choice(*VIEW_WIDTHS)))
    stamina: tuple[float, float, float] = wire(fixed(non_negative, non_negative, number))
    speed: tuple[float, int] = wire(fixed(non_negative, DIRECTION))
    head_angle: int = wire(DIRECTION)
    counts: dict = wire(record(**{name: COUNT for name in COMMAND_COUNTS}))
    collision: tuple[str, ...] = wire(sequence(choice(*COLLISIONS), len(COLLISIONS)))


def _seen_flag(row: Any) -> bool:
    """A well-formed ``see`` flag row whose values need no conversion (the common case, checked in one
    expression instead of five loader calls)."""
    return (type(row) is list and len(row) == 5
            and (row[0] is None or (type(row[0]) is int and 0 <= row[0] < MAX_LANDMARKS))
            and is_finite_float(row[1], 0.0) and type(row[2]) is int and -180 <= row[2] <= 180
            and (row[3] is None or is_finite_float(row[3])) and (row[4] is None or is_finite_float(row[4])))


def _seen_line(row: Any) -> bool:
    """A well-formed ``see`` line row needing no conversion (as :func:`_seen_flag`)."""
    return (type(row) is list and len(row) == 3 and type(row[0]) is int and 0 <= row[0] < MAX_LANDMARKS
            and is_finite_float(row[1], 0.0) and type(row[2]) is int and -180 <= row[2] <= 180)


def _seen_direction(value: Any) -> bool:
    return type(value) is int and -180 <= value <= 180


def _seen_player(row: Any) -> bool:
    """A well-formed ``see`` player row needing no conversion (as :func:`_seen_flag`)."""
    return (type(row) is list and len(row) == 8
            and (row[0] is None or (type(row[0]) is str and row[0] in SIDES))
            and (row[1] is None or (type(row[1]) is int and 1 <= row[1] <= MAX_UNUM))
            and is_finite_float(row[2], 0.0) and _seen_direction(row[3])
            and (row[4] is None or is_finite_float(row[4])) and (row[5] is None or is_finite_float(row[5]))
            and (row[6] is None or _seen_direction(row[6])) and (row[7] is None or _seen_direction(row[7])))


def _seen_ball(row: Any) -> bool:
    """A well-formed ``see`` ball needing no conversion (as :func:`_seen_flag`)."""
    return (type(row) is list and len(row) == 4 and is_finite_float(row[0], 0.0) and _seen_direction(row[1])
            and (row[2] is None or is_finite_float(row[2])) and (row[3] is None or is_finite_float(row[3])))


@message
class See(Message):
    """A visual percept (rcssserver's ``see``; docs/rules.md §5.2); directions relative to the head. Every row
    kind has a fast path (``protocol.codec.rows``): players decode a see every other cycle."""

    TYPE: ClassVar[str] = "see"
    cycle: int = wire(CYCLE)
    flags: tuple = wire(
        rows(_seen_flag, fixed(optional(LANDMARK_ID), non_negative, DIRECTION, CHANGE, CHANGE), MAX_LANDMARKS)
    )
    lines: tuple = wire(rows(_seen_line, fixed(LANDMARK_ID, non_negative, DIRECTION), MAX_LANDMARKS))
    ball: tuple | None = wire(row(_seen_ball, optional(fixed(non_negative, DIRECTION, CHANGE, CHANGE))))
    players: tuple = wire(
        rows(
            _seen_player,
            fixed(optional(SIDE), optional(UNUM), non_negative, DIRECTION, CHANGE, CHANGE,
                  optional(DIRECTION), optional(DIRECTION)),
            MAX_PLAYERS,
        )
    )


@message
class Hear(Message):
    """An aural percept: the referee, the player itself, the coach's advice, or another player."""

    TYPE: ClassVar[str] = "hear"
    cycle: int = wire(CYCLE)
    sender: str = wire(choice(*HEAR_SENDERS))
    direction: int | None = wire(optional(DIRECTION), default=None)
    unum: int | None = wire(optional(UNUM), default=None)
    message: Any = wire(payload_value)

    def _check(self) -> None:
        """Only the coach's advice is a free payload; everyone else says text."""
        if self.sender != "coach":
            try:
                TEXT(self.message)
            except Invalid as exc:
                raise exc.at("message") from None


@message
class Fullstate(Message):
    """The exact state of the field, for players that asked for it in ``init`` (docs/rules.md §5.4)."""

    TYPE: ClassVar[str] = "fullstate"
    cycle: int = wire(CYCLE)
    ball: tuple[float, float, float, float] = wire(BALL_STATE)
    players: tuple = wire(PLAYER_STATES)
    play_mode: str = wire(PLAY_MODE)
    episode: int = wire(COUNT)


@message
class Think(Message):
    """Every percept of this cycle has been sent: in synchronous mode, answer now; in real-time mode,
    the end-of-cycle marker (after the cycle's see, if one is due before the next step)."""

    TYPE: ClassVar[str] = "think"
    cycle: int = wire(CYCLE)


@message
class Waiting(Message):
    """No cycle is being played, and why: before the kick-off, players still to connect (``players``)
    or the coach's ``start`` to come (``coach``); or the game is ``paused``. Sent to every player every
    WAITING_INTERVAL_S while it lasts, so a client can tell a slow start from a dead server."""

    TYPE: ClassVar[str] = "waiting"
    cycle: int = wire(CYCLE)
    reason: str = wire(choice(*WAITING_REASONS))
    connected: int = wire(integer(0, MAX_PLAYERS))  # players seated now
    expected: int = wire(integer(0, MAX_PLAYERS))  # seats of the arena


@message
class Shutdown(Message):
    """The server is ending; the client should exit."""

    TYPE: ClassVar[str] = "shutdown"
    cycle: int = wire(CYCLE)
    reason: str = wire(TEXT)


# ------------------------------------------------------------------------------ coach port: from client


@message
class CoachInit(Message):
    """Connect as the arena's coach."""

    TYPE: ClassVar[str] = "coach_init"
    version: int = wire(protocol_version, default=PROTOCOL_VERSION, required=True)
    client: str = wire(CLIENT, default="")


@message
class Start(Message):
    """Kick off now, even if not every expected player has connected."""

    TYPE: ClassVar[str] = "start"


@message
class Look(Message):
    """Ask for the noiseless state of the field; answered by ``look_ok``."""

    TYPE: ClassVar[str] = "look"


@message
class Advice(Message):
    """A payload for a team, everyone, or one player, delivered as ``hear`` from ``coach``."""

    TYPE: ClassVar[str] = "advice"
    target: str | tuple[str, int] = wire(_advice_target)
    payload: Any = wire(payload_value)


def advice_hear(payload: Any, cycle: int = MAX_CYCLE) -> Hear:
    """The ``hear`` that delivers an ``advice`` payload to a player. Encoded with the default cycle it
    is the largest frame that payload can become: the coach checks it against the server's
    ``max_message_bytes`` before forwarding a trainer's advice (docs/protocol.md §1)."""
    return Hear(cycle=cycle, sender="coach", direction=None, unum=None, message=payload)


# ``reset`` reseeds the arena's random stream with core.rng.seed_streams, which takes any int; the
# wire allows msgpack's non-negative signed 64-bit ints.
MAX_SEED = 2**63 - 1
SEED = integer(0, MAX_SEED)
# Actions that take ``episodes_left``: stop or pause once that many more episodes have ended.
COUNTDOWN_ACTIONS = ("stop", "pause")


@message
class EpisodeControl(Message):
    """Reset the field (reseeding the arena with ``seed`` if given), pause (now, or once
    ``episodes_left`` more episodes have ended), resume, or stop (now, or after ``episodes_left`` more
    episodes) (docs/protocol.md §7; docs/protocol.md §12, "Coach")."""

    TYPE: ClassVar[str] = "episode_control"
    action: str = wire(choice(*EPISODE_ACTIONS))
    episodes_left: int | None = wire(optional(COUNT), default=None)
    seed: int | None = wire(optional(SEED), default=None)

    def _check(self) -> None:
        if self.episodes_left is not None and self.action not in COUNTDOWN_ACTIONS:
            raise Invalid("bad_value",
                          f"episodes_left is only allowed with action 'stop' or 'pause', not {self.action!r}")
        if self.seed is not None and self.action != "reset":
            raise Invalid("bad_value", f"seed is only allowed with action 'reset', not {self.action!r}")


@message
class CoachBye(Message):
    """Disconnect the coach."""

    TYPE: ClassVar[str] = "coach_bye"


# -------------------------------------------------------------------------------- coach port: to client


@message
class CoachInitOk(Message):
    """Accepted coach: the simulation's parameters, landmarks and configuration."""

    TYPE: ClassVar[str] = "coach_init_ok"
    version: int = wire(protocol_version, default=PROTOCOL_VERSION, required=True)
    cycle: int = wire(CYCLE)
    play_mode: str = wire(PLAY_MODE)
    params: dict = wire(_params)
    landmarks: dict = wire(LANDMARKS)
    config: dict = wire(_config)


@message
class LookOk(Message):
    """The noiseless state: ``ball``, ``players``, ``play_mode``, ``episode``, ``episode_start`` (the cycle
    the episode under way began: a monitor that joins midway still knows its hold time), ``take_count``; ``paused``:
    the game stands still between two cycles (a ``pause`` took effect; no command is pending)."""

    TYPE: ClassVar[str] = "look_ok"
    cycle: int = wire(CYCLE)
    state: dict = wire(STATE)
    paused: bool = wire(boolean, default=False)  # standing still between two cycles


@message
class EpisodeEnd(Message):
    """An episode ended (one line of rcssserver's kwy log; docs/protocol.md §12, "Episode logs"); also on the
    monitor port."""

    TYPE: ClassVar[str] = "episode_end"
    cycle: int = wire(CYCLE)
    episode: int = wire(integer(1, MAX_CYCLE))
    start_cycle: int = wire(CYCLE)
    end_cycle: int = wire(CYCLE)
    end: str = wire(choice(*EPISODE_ENDS))
    # The players some of its cycles were played without (late, given up or gone) and how many, as the
    # episode log's ``missed``; empty when every player played it all (may be left out by a sender).
    missed: tuple[tuple[str, int], ...] = wire(
        sequence(fixed(text(PLAYER_NAME_CHARS), integer(1, MAX_CYCLE)), MAX_PLAYERS), default=())


@message
class PlayerReport(Message):
    """A player's ``report``, relayed to the coach."""

    TYPE: ClassVar[str] = "player_report"
    cycle: int = wire(CYCLE)
    side: str = wire(SIDE)
    unum: int = wire(UNUM)
    payload: Any = wire(payload_value)


@message
class PlayerSaid(Message):
    """A player's ``say``, relayed to the coach."""

    TYPE: ClassVar[str] = "player_said"
    cycle: int = wire(CYCLE)
    side: str = wire(SIDE)
    unum: int = wire(UNUM)
    message: str = wire(text(MAX_SAY_CHARS))


# ------------------------------------------------------------------------------------------ monitor port


@message
class Frame(Message):
    """The true state, published every cycle on the monitor topic ``frame``."""

    TYPE: ClassVar[str] = "frame"
    cycle: int = wire(CYCLE)
    ball: tuple[float, float, float, float] = wire(BALL_STATE)
    players: tuple = wire(PLAYER_STATES)
    play_mode: str = wire(PLAY_MODE)
    episode: int = wire(COUNT)
    episode_start: int = wire(CYCLE)  # the cycle the episode under way began
    take_count: int = wire(COUNT)
    # the keepers' GetOpen notes sent with the commands of the step that led here: (unum, note) rows
    getopen: tuple[tuple[int, tuple[float, ...]], ...] = wire(sequence(fixed(UNUM, getopen_note), MAX_UNUM),
                                                              default=())


# -------------------------------------------------------------------------------------- allowed sets


def _by_type(*classes: type[Message]) -> Mapping[str, type[Message]]:
    return MappingProxyType({cls.TYPE: cls for cls in classes})


PLAYER_TO_SERVER = _by_type(Init, Reconnect, Command, Report, Bye, SynchSee)
SERVER_TO_PLAYER = _by_type(InitOk, Error, SenseBody, See, Hear, Fullstate, Think, Waiting, Shutdown)
COACH_TO_SERVER = _by_type(CoachInit, Start, Look, Advice, EpisodeControl, CoachBye)
SERVER_TO_COACH = _by_type(CoachInitOk, LookOk, Error, EpisodeEnd, PlayerReport, PlayerSaid, Shutdown)
MONITOR_TOPICS: Mapping[bytes, type[Message]] = MappingProxyType(
    {MONITOR_FRAME_TOPIC: Frame, MONITOR_EPISODE_TOPIC: EpisodeEnd}
)


def decode_from_player(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    """Server side of the players port: one of :data:`PLAYER_TO_SERVER`."""
    return decode(data, PLAYER_TO_SERVER, max_bytes)


def decode_for_player(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    """Player side of the players port: one of :data:`SERVER_TO_PLAYER`."""
    return decode(data, SERVER_TO_PLAYER, max_bytes)


def decode_from_coach(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    """Server side of the coach port: one of :data:`COACH_TO_SERVER`."""
    return decode(data, COACH_TO_SERVER, max_bytes)


def decode_for_coach(data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    """Coach side of the coach port: one of :data:`SERVER_TO_COACH`."""
    return decode(data, SERVER_TO_COACH, max_bytes)


def decode_monitor(topic: bytes, data: bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Message:
    """A monitor subscriber's two frames: the topic names the one message type the data may hold."""
    cls = MONITOR_TOPICS.get(topic) if isinstance(topic, bytes) else None
    if cls is None:
        raise ProtocolError("unknown_type", f"unknown monitor topic {show(topic)}")
    return decode(data, {cls.TYPE: cls}, max_bytes)
