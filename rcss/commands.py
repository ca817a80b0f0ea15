"""What a text client sends rcssserver, read exactly as rcssserver reads it, into our protocol's messages,
with the replies rcssserver gives; and the inverse, the text our players send a real rcssserver.

Two ports, two readers. On the init port (rcssserver src/stadium.cpp, ``parsePlayerInit``) a datagram is
``(init TEAM [(version V)] [(goalie)])`` or ``(reconnect TEAM UNUM)``, read with C's ``sscanf``:
:func:`parse_connect`. A seated player's datagram holds one or more commands, ``(dash 100)(turn_neck
-19)(say "...")``, read by rcssserver's flex scanner and bison grammar (src/player_command_tok.lpp,
src/player_command_parser.ypp): :func:`parse_commands`. Each command acts as soon as it is read; the first
token that does not fit the grammar ends the datagram with ``(error illegal_command_form)``, the commands
before it standing (src/player.cpp, ``parseMsg``).
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from types import MappingProxyType

from keepaway.protocol.codec import Invalid
from keepaway.protocol.messages import (
    COMMAND_ARGUMENTS,
    MAX_SAY_CHARS,
    VIEW_QUALITIES,
    VIEW_WIDTHS,
    AtomicCommand,
)
from keepaway.rcss.sexp import SAY_CHARACTERS, atoi, command_tokens, unquote

# rcssserver reads a datagram into a buffer of MaxMesg bytes (src/param.h; src/remoteclient.cpp and
# src/stadium.cpp): the rest of a longer one is lost, and what was read is parsed.
MAX_DATAGRAM_BYTES = 8192
DEFAULT_CLIENT_VERSION = 3.0  # an init without (version V) (src/stadium.cpp)
# rcssserver seats a player whose (int) version has senders: 1 to 19 (src/player.cpp, setSenders).
MIN_CLIENT_VERSION, MAX_CLIENT_VERSION = 1, 19
MAX_TEAM_NAME_CHARS = 15  # "%15[...]" (src/stadium.cpp)

# ------------------------------------------------------------------------------------------------ replies

ILLEGAL_COMMAND_FORM = "(error illegal_command_form)"
UNKNOWN_COMMAND = "(error unknown_command)"
ILLEGAL_TEAMNAME = "(error illegal_teamname)"
ILLEGAL_TEAMNAME_OR_TOO_LONG = "(error illegal_teamname_or_too_long_teamname)"
# rcssserver's answer to a bad version, a full team and a second goalie alike (src/stadium.cpp, initPlayer)
NO_MORE_PLAYER = "(error no_more_player_or_goalie_or_illegal_client_version)"
NO_SUCH_TEAM_OR_PLAYER = "(error no_such_team_or_player)"
CANNOT_RECONNECT_WHILE_PLAYON = "(error cannot_reconnect_while_playon)"
NO_MORE_MONITOR = "(error no_more_monitor)"
NOT_NULL_TERMINATED = "(warning message_not_null_terminated)"
COMPRESSION_UNSUPPORTED = "(warning compression_unsupported)"
OK_GAUSSIAN_SEE = "(ok gaussian_see)"
# The front's own answers, by rcssserver's words (src/stadium.cpp, src/remoteclient.cpp, src/player.cpp):
NO_MORE_TEAM = "(error no_more_team)"  # an init naming a third team
ONLY_INIT_ON_INIT_PORT = "(error only_init_allowed_on_init_port)"  # a seated client (version >= 8) there
OK_SYNCH_SEE = "(ok synch_see)"  # a SynchSeeRequest, and an init of version >= 18 after its init messages


class ConnectRefused(ValueError):
    """rcssserver's refusal of a datagram on its init port: ``replies``, the datagrams it answers, one line
    each, in order (none for an empty datagram, which rcssserver ignores)."""

    def __init__(self, *replies: str) -> None:
        super().__init__(" ".join(replies) or "an empty datagram")
        self.replies = replies


# ------------------------------------------------------------------------------------------- init port


@dataclass(frozen=True, slots=True)
class InitRequest:
    """``(init TEAM [(version V)] [(goalie)])``: a team name of 1 to 15 characters from ``+`` .. ``_``
    (ASCII 0x2B to 0x5F) and ``a-z``, a supported version."""

    team: str
    version: float = DEFAULT_CLIENT_VERSION
    goalie: bool = False


@dataclass(frozen=True, slots=True)
class ReconnectRequest:
    """``(reconnect TEAM UNUM)``: any team name and number; the front answers ``NO_SUCH_TEAM_OR_PLAYER``
    for a seat it does not have."""

    team: str
    unum: int


_C_SPACE = " \t\n\v\f\r"  # C's isspace: what sscanf skips
_C_BLANKS = f"[{_C_SPACE}]*"
# glibc's sscanf "%lf": the characters it takes, even a dangling exponent ("1e" reads 1, "0x." 0, "0x" nothing).
_SCANF_DOUBLE = re.compile(_C_BLANKS + r"""(?P<sign>[+-]?)(?:
    (?P<nan>(?i:nan)) | (?P<inf>(?i:infinity|inf(?!i)))
    | 0[xX](?:(?P<hex>[0-9a-fA-F]+(?:\.[0-9a-fA-F]*)?|\.[0-9a-fA-F]+)(?:[pP](?P<hexp>[+-]?[0-9]*))?|\.(?P<bare>))
    | (?!0[xX])(?P<dec>[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE](?P<exp>[+-]?[0-9]*))?)""", re.X)
_SCANF_INT = re.compile(_C_BLANKS + r"([+-]?[0-9]+)")
# "%15[+-_a-zA-Z0-9]": "+-_" is the range '+' .. '_', which holds the digits and capitals
_TEAM_NAME = re.compile(_C_BLANKS + "([\x2b-\x5fa-z]{1,%d})" % MAX_TEAM_NAME_CHARS)
_RECONNECT = re.compile(r"\(reconnect " + _C_BLANKS + f"([^{_C_SPACE}]{{1,127}})")  # "%127s"
_DISPINIT = re.compile(_C_BLANKS.join((r"", r"\(", "dispinit", "version", "")))
_VERSION_HEAD = re.compile(r"\(" + _C_BLANKS + "version")
_CLOSE = re.compile(_C_BLANKS + r"\)" + _C_BLANKS)
_BLANK_RUN = re.compile(_C_BLANKS)


def _scanf_double(text: str, pos: int) -> tuple[float, int] | None:
    """``sscanf(text + pos, "%lf")`` as glibc reads it: the value and where reading stopped, or None."""
    match = _SCANF_DOUBLE.match(text, pos)
    if match is None:
        return None
    sign = -1.0 if match["sign"] == "-" else 1.0
    if match["nan"]:
        return math.nan, match.end()
    if match["inf"]:
        return sign * math.inf, match.end()
    if match["bare"] is not None:  # "0x." reads 0
        return sign * 0.0, match.end()
    if match["hex"] is not None:
        exponent = match["hexp"] or ""
        try:
            value = float.fromhex(f"0x{match['hex']}" + (f"p{exponent}" if exponent.strip("+-") else ""))
        except OverflowError:
            value = math.inf
        return sign * value, match.end()
    exponent = match["exp"] or ""
    return sign * float(match["dec"] + (f"e{exponent}" if exponent.strip("+-") else "")), match.end()


def supported_version(version: float) -> bool:
    """Whether rcssserver seats a client of this version: its integer part is 1 to 19."""
    return math.isfinite(version) and MIN_CLIENT_VERSION <= int(version) <= MAX_CLIENT_VERSION


def _received(datagram: bytes | str) -> bytes:
    """The bytes rcssserver reads of a datagram: at most MAX_DATAGRAM_BYTES (a ``str`` is its UTF-8)."""
    data = datagram.encode("utf-8", "surrogatepass") if isinstance(datagram, str) else bytes(datagram)
    return data[:MAX_DATAGRAM_BYTES]


def _c_string(data: bytes) -> str:
    """What C string functions see of ``data``: the bytes up to the first NUL, one character each."""
    return data.split(b"\0", 1)[0].decode("latin-1")


def parse_connect(datagram: bytes | str, *, play_on: bool = False) -> InitRequest | ReconnectRequest:
    """What a datagram from an unknown address asks, as rcssserver's init port reads it (src/stadium.cpp,
    ``parsePlayerInit``), or :class:`ConnectRefused` with rcssserver's replies. ``play_on``: the game is
    in play_on, when rcssserver refuses every reconnect. A monitor's ``(dispinit ...)``, which rcssserver
    seats on this port, is answered as when its monitors are all taken; a trainer's ``(init (version
    V))`` is a player's init with an illegal team name, as on rcssserver's player port."""
    data = _received(datagram)
    if not data:
        raise ConnectRefused()
    text = _c_string(data[:-1] if data.endswith(b"\n") else data)
    dispinit = _DISPINIT.match(text)
    if text.startswith("(dispinit)") or (dispinit and _scanf_double(text, dispinit.end())):
        raise ConnectRefused(NO_MORE_MONITOR)
    if text.startswith("(init "):
        return _init(text)
    if text.startswith("(reconnect "):
        if play_on:
            raise ConnectRefused(CANNOT_RECONNECT_WHILE_PLAYON)
        return _reconnect(text)
    raise ConnectRefused(UNKNOWN_COMMAND)


def _init(text: str) -> InitRequest:
    """``(init TEAM [(version V)] [(goalie)])`` read as rcssserver reads it: after the team name anything up
    to the first ``(`` is skipped, then options follow one another up to a ``)``."""
    name = _TEAM_NAME.match(text, len("(init "))
    if name is None:
        raise ConnectRefused(ILLEGAL_TEAMNAME)
    pos = _BLANK_RUN.match(text, name.end()).end()
    if not text.startswith(("(", ")"), pos):
        raise ConnectRefused(ILLEGAL_TEAMNAME_OR_TOO_LONG)
    pos = text.find("(", pos)
    pos = len(text) if pos < 0 else pos
    version, goalie = DEFAULT_CLIENT_VERSION, False
    while pos < len(text) and text[pos] != ")":
        if text.startswith("(version ", pos):
            read = _scanf_double(text, _VERSION_HEAD.match(text, pos).end())
            close = read and _CLOSE.match(text, read[1])
            if not close:
                raise ConnectRefused(ILLEGAL_COMMAND_FORM)
            version, pos = read[0], close.end()
        elif text.startswith("(goalie)", pos):
            goalie, pos = True, pos + len("(goalie)")
        else:
            raise ConnectRefused(ILLEGAL_COMMAND_FORM)
        if not text.startswith(("(", ")", *_C_SPACE), pos):
            raise ConnectRefused(ILLEGAL_COMMAND_FORM)
        pos = _BLANK_RUN.match(text, pos).end()
    if not supported_version(version):
        raise ConnectRefused(NO_MORE_PLAYER)
    return InitRequest(name[1], version, goalie)


def _reconnect(text: str) -> ReconnectRequest:
    """``(reconnect TEAM UNUM)``. rcssserver answers a malformed one and then looks for a player anyway,
    with a number it never read: two replies."""
    name = _RECONNECT.match(text)
    unum = name and _SCANF_INT.match(text, name.end())
    if not unum:
        raise ConnectRefused(ILLEGAL_COMMAND_FORM, NO_SUCH_TEAM_OR_PLAYER)
    return ReconnectRequest(name[1], atoi(unum[1]))


# ------------------------------------------------------------------------------------------ player port


@dataclass(frozen=True, slots=True)
class SenseBodyRequest:
    """``(sense_body)``: rcssserver sends the player's sense_body at once (src/player.cpp)."""


@dataclass(frozen=True, slots=True)
class ScoreRequest:
    """``(score)``: rcssserver answers ``(score TIME OUR THEIR)`` (src/serializerplayerstdv1.cpp)."""


@dataclass(frozen=True, slots=True)
class SynchSeeRequest:
    """``(synch_see)``: the player's see switches to synch mode (one see every 1, 2 or 3 cycles for
    narrow, normal, wide, always high quality) and rcssserver answers ``OK_SYNCH_SEE`` (src/player.cpp)."""


@dataclass(frozen=True, slots=True)
class EarRequest:
    """``(ear (on|off [TEAM] [partial|complete]))``: what the player hears of a team. ``side``: ``"our"``,
    ``"opp"``, ``"l"``, ``"r"``, or ``""`` for ``team_name`` (a word or a quoted string, quotes kept) or,
    without it, both teams; ``mode``: ``"partial"``, ``"complete"``, or ``""`` for both. rcssserver answers
    only a team name it does not know, with :attr:`unknown_team_reply` (src/player.cpp, ear)."""

    on: bool
    side: str = ""
    team_name: str = ""
    mode: str = ""

    @property
    def unknown_team_reply(self) -> str:
        return f"(error no team with name {self.team_name})"  # src/serializerplayerstdv1.cpp


@dataclass(frozen=True, slots=True)
class AttentiontoRequest:
    """``(attentionto TEAM UNUM)`` / ``(attentionto off)``: whom the player listens to; ``side`` and
    ``team_name`` as in :class:`EarRequest`. No reply (src/player.cpp, attentionto)."""

    on: bool
    side: str = ""
    team_name: str = ""
    unum: int = 0


@dataclass(frozen=True, slots=True)
class PointtoRequest:
    """``(pointto DIST DIR)`` / ``(pointto off)``: the player's arm (its sense_body's ``arm``). No reply."""

    on: bool
    distance: float = 0.0
    direction: float = 0.0


@dataclass(frozen=True, slots=True)
class ChangeFocusRequest:
    """``(change_focus DIST DIR)`` (rcssserver 19): moves the player's focus point. No reply."""

    distance: float
    direction: float


Request = SenseBodyRequest | ScoreRequest | SynchSeeRequest | EarRequest | AttentiontoRequest | PointtoRequest \
    | ChangeFocusRequest


@dataclass(frozen=True, slots=True)
class ParsedDatagram:
    """One datagram of a seated player. ``commands``: those our protocol takes, in order (as many as the
    datagram holds, which may be more than a ``command`` message's MAX_COMMANDS); ``answers``:
    in rcssserver's order, reply texts to send as they are and the requests the front answers from its
    state; ``bye``: the player leaves (rcssserver closes its connection: nothing after the ``(bye)`` is
    done or answered)."""

    commands: tuple[AtomicCommand, ...] = ()
    answers: tuple[str | Request, ...] = ()
    bye: bool = False

    @property
    def done(self) -> bool:
        """A ``(done)`` came: in synchronous mode, the client's answer to this cycle is complete."""
        return any(command.name == "done" for command in self.commands)


def _kinds(*kinds: str) -> frozenset[str]:
    return frozenset(kinds)


_NUM, _INT, _STR = _kinds("int", "real"), _kinds("int"), _kinds("str")
_SIDE, _MODE, _ON_OFF = _kinds("our", "opp", "l", "r"), _kinds("partial", "complete"), _kinds("on", "off")
_LP, _RP = _kinds("("), _kinds(")")
_WIDTH, _QUALITY = _kinds(*VIEW_WIDTHS), _kinds(*VIEW_QUALITIES)
_LEGS = {leg: (_LP, _kinds(leg), _NUM, _NUM, _RP) for leg in ("l", "r")}
# Each command's argument forms after "(NAME" (its closing ")" left out): src/player_command_parser.ypp.
_GRAMMAR = MappingProxyType({
    "dash": ((_NUM,), (_NUM, _NUM), _LEGS["l"], _LEGS["r"], _LEGS["l"] + _LEGS["r"], _LEGS["r"] + _LEGS["l"]),
    "turn": ((_NUM,),), "turn_neck": ((_NUM,),), "catch": ((_NUM,),),
    "kick": ((_NUM, _NUM),), "long_kick": ((_NUM, _NUM),), "move": ((_NUM, _NUM),),
    "change_focus": ((_NUM, _NUM),),
    "tackle": ((_NUM,), (_NUM, _ON_OFF | {"true", "false"})),
    "say": ((_STR,),),
    "change_view": ((_WIDTH, _QUALITY), (_WIDTH,)),
    "compression": ((_INT,),),
    "pointto": ((_NUM, _NUM), (_kinds("off"),)),
    "attentionto": ((_SIDE, _INT), (_STR, _INT), (_kinds("off"),)),
    "clang": ((_LP, _kinds("ver"), _INT, _INT, _RP),),
    "ear": tuple((_LP, _ON_OFF, *middle, _RP)
                 for middle in ((_SIDE, _MODE), (_STR, _MODE), (_SIDE,), (_STR,), (_MODE,), ())),
    **{name: ((),) for name in ("sense_body", "score", "bye", "done", "synch_see", "gaussian_see")},
})
_ILLEGAL = ("", ())  # what _statements yields at the first token that does not fit the grammar
_END = ("end", None)  # after the last token


def _statement(kind: str, tokens: Iterator[tuple[str, str | int | float]]) -> tuple[str, tuple]:
    """The command that opens with a token of ``kind``: its name and the values of its tokens other than
    parentheses once its last token is read, or ``_ILLEGAL`` at the first token that does not fit."""
    name = next(tokens, _END)[0] if kind == "(" else ""
    forms = [(*form, _RP) for form in _GRAMMAR.get(name, ())]
    values: list = []
    position = 0
    while forms:
        kind, value = next(tokens, _END)
        forms = [form for form in forms if position < len(form) and kind in form[position]]
        position += 1
        if kind not in ("(", ")"):
            values.append(value)
        if any(len(form) == position for form in forms):
            return name, tuple(values)
    return _ILLEGAL


def _statements(text: str) -> Iterator[tuple[str, tuple]]:
    """The commands of ``text`` in order as rcssserver's parser completes them, then ``_ILLEGAL`` if a
    token does not fit (or the text holds no command), where rcssserver's parser stops."""
    tokens = command_tokens(text)
    kind, value = next(tokens, _END)
    if kind == "end":
        yield _ILLEGAL
    while kind != "end":
        statement = ("say", (value,)) if kind == "unquoted_say" else _statement(kind, tokens)
        yield statement
        if statement == _ILLEGAL:
            return
        kind, value = next(tokens, _END)


_LARGEST = sys.float_info.max


def _finite(value: float) -> float:
    """A number of the grammar as our protocol takes it: rcssserver reads ``1e999`` as infinite and clamps
    it as it clamps any large value, and the largest float clamps the same (docs/rules.md §2)."""
    return max(-_LARGEST, min(_LARGEST, float(value)))


def _team(word: str) -> tuple[str, str]:
    """A team token: ``(side, "")`` for our/opp/l/r (left, right), ``("", word)`` for a name."""
    return (word, "") if word in _SIDE else ("", word)


def _answer(name: str, values: tuple) -> AtomicCommand | str | Request | None:
    """What one command of rcssserver's grammar becomes (src/player.cpp): a command of ours, a reply, a
    request the front answers, or None where rcssserver does nothing a client could tell."""
    if name == "say":  # a message longer than our protocol's is longer than say_msg_size: rcssserver drops it
        message = unquote(values[0])
        return AtomicCommand(name, (message,)) if len(message) <= MAX_SAY_CHARS else None
    if name == "dash" and values[0] in ("l", "r"):
        return None  # rcssserver 19's dash of the legs: not ours
    if name in COMMAND_ARGUMENTS:
        values = values[:1] if name == "tackle" else values  # a tackle's foul flag: not ours
        return AtomicCommand(name, tuple(value if isinstance(value, str) else _finite(value) for value in values))
    match name, values:
        case "sense_body", _:
            return SenseBodyRequest()
        case "score", _:
            return ScoreRequest()
        case "synch_see", _:
            return SynchSeeRequest()
        case "gaussian_see", _:
            return OK_GAUSSIAN_SEE  # the see noise model: not ours
        case "clang", (_, low, high):
            return f"(ok clang (ver {low} {high}))"
        case "compression", _:  # rcssserver built without zlib; with it, "(ok compression N)" and gzip
            return COMPRESSION_UNSUPPORTED
        case "change_focus", (distance, direction):
            return ChangeFocusRequest(float(distance), float(direction))
        case "pointto", (distance, direction):
            return PointtoRequest(True, float(distance), float(direction))
        case "pointto", _:
            return PointtoRequest(False)
        case "attentionto", (team, unum):
            return AttentiontoRequest(True, *_team(team), unum)
        case "attentionto", _:
            return AttentiontoRequest(False)
        case "ear", (switch, *rest):
            mode = rest.pop() if rest and rest[-1] in _MODE else ""
            return EarRequest(switch == "on", *(_team(rest[0]) if rest else ("", "")), mode)
    return None  # long_kick: rcssserver 19's does nothing


def parse_commands(datagram: bytes | str, version: float) -> ParsedDatagram:
    """A seated player's datagram as rcssserver reads it (src/player.cpp, ``parseMsg``): the text up to its
    first NUL byte, read with rcssserver's grammar; ``version``, the client's, asks for a warning when the
    datagram does not end with a NUL byte (8 and later). Commands our protocol lacks are answered as
    rcssserver answers them: ``(gaussian_see)`` ``OK_GAUSSIAN_SEE``, ``(clang (ver A B))`` ``(ok clang (ver
    A B))``, ``(compression N)`` ``COMPRESSION_UNSUPPORTED``; ``(long_kick ...)`` and the legs' ``(dash (l P
    D) (r P D))`` nothing; the others are requests.

    A datagram of plain commands, as players send every cycle (``(dash 100)(turn_neck 0)(say "0FI")``),
    is read statement by statement with each statement's reading remembered (:func:`_plain_commands`);
    the same reading, a fiftieth of the time."""
    if type(datagram) is bytes and len(datagram) <= MAX_DATAGRAM_BYTES and _PLAIN_DATAGRAM.fullmatch(datagram):
        commands = _plain_commands(datagram, version)
        if commands is not None:
            return ParsedDatagram(commands)
    return _parse(datagram, version)


# A datagram of statements that each read the same alone as among others, NUL-terminated: a name and
# words or numbers, or a say of a quoted message; the name of an unquoted say (whose message may run
# over the statements after it) is not among them.
_PLAIN_STATEMENT = rb'\((?!say )[a-z_]+(?: [-+.0-9A-Za-z]+)*\)|\(say "[-+.0-9A-Za-z*/?<>_ ]*"\)'
_PLAIN_DATAGRAM = re.compile(rb"(?:" + _PLAIN_STATEMENT + rb")+\0")
_PLAIN_STATEMENTS = re.compile(_PLAIN_STATEMENT)
_PLAIN_MEMORY = 4096  # statements remembered; when full, forgotten all at once
_plain_read: dict[bytes, AtomicCommand | None] = {}


def _plain_commands(datagram: bytes, version: float) -> tuple[AtomicCommand, ...] | None:
    """The commands of a datagram of plain statements, each read alone by :func:`_parse` (once, then
    remembered: NUL-terminated, a statement reads the same in every version); None if one of them is not
    one command of ours (an error, a request, a bye: then the whole datagram is read by :func:`_parse`)."""
    commands = []
    for statement in _PLAIN_STATEMENTS.findall(datagram):
        try:
            command = _plain_read[statement]
        except KeyError:
            parsed = _parse(statement + b"\0", version)
            alone = len(parsed.commands) == 1 and not parsed.answers and not parsed.bye
            command = parsed.commands[0] if alone else None
            if len(_plain_read) >= _PLAIN_MEMORY:
                _plain_read.clear()
            _plain_read[statement] = command
        if command is None:
            return None
        commands.append(command)
    return tuple(commands)


def _parse(datagram: bytes | str, version: float) -> ParsedDatagram:
    """:func:`parse_commands` by the grammar, token by token."""
    data = _received(datagram)
    if not data:
        return ParsedDatagram()  # rcssserver does not read an empty datagram
    commands: list[AtomicCommand] = []
    answers: list[str | Request] = [NOT_NULL_TERMINATED] if version >= 8 and data[-1] != 0 else []
    for name, values in _statements(_c_string(data)):
        if name == "bye":
            return ParsedDatagram(tuple(commands), tuple(answers), bye=True)
        answer = ILLEGAL_COMMAND_FORM if (name, values) == _ILLEGAL else _answer(name, values)
        if isinstance(answer, AtomicCommand):
            commands.append(answer)
        elif answer is not None:
            answers.append(answer)
    return ParsedDatagram(tuple(commands), tuple(answers))


# ------------------------------------------------------------------------------------- to rcssserver


def _number_text(value: float) -> str:
    """``100`` for a whole number C's atoi reads back, else the shortest text strtod reads back exactly."""
    negative_zero = value == 0 and math.copysign(1.0, value) < 0
    if value.is_integer() and -2**31 < value < 2**31 and not negative_zero:
        return str(int(value))
    return repr(value)


def command_text(command: AtomicCommand) -> str:
    """The text rcssserver reads back as ``command``: ``(dash 100 0)``, ``(turn_neck -19)``, ``(say
    "pass 3")``, ``(change_view normal high)``. ValueError for what our protocol refuses and for a say
    rcssserver's grammar cannot carry: an empty message, or a character outside ``[-0-9a-zA-Z
    ().+*/?<>_]``."""
    name, args = command
    required, extra = COMMAND_ARGUMENTS.get(name, ((), ()))
    if name not in COMMAND_ARGUMENTS or not len(required) <= len(args) <= len(required) + len(extra):
        raise ValueError(f"not a command of ours: {name!r} with {len(args)} arguments")
    try:
        loaded = [load(arg) for load, arg in zip(required + extra, args)]
    except Invalid as exc:
        raise ValueError(f"{name}: {exc.what}") from None
    if name == "say":
        if not loaded[0] or not SAY_CHARACTERS.fullmatch(loaded[0]):
            raise ValueError(f"rcssserver cannot read the say message {loaded[0]!r}")
        return f'(say "{loaded[0]}")'
    return "(" + " ".join([name, *(arg if isinstance(arg, str) else _number_text(arg) for arg in loaded)]) + ")"


def commands_text(commands: Iterable[AtomicCommand]) -> str:
    """One datagram's text for ``commands``: ``(dash 100 0)(turn_neck -19)(say "pass 3")``; none for no
    command (rcssserver answers an empty one with ``ILLEGAL_COMMAND_FORM``)."""
    return "".join(command_text(command) for command in commands)
