"""Our server's messages to a player (docs/protocol.md §6) as rcssserver 19.0.0 writes them to a text
client of protocol version 8 to 19, byte for byte; sans-IO: messages in, text out. rcssserver ends every
message with a NUL byte (``std::ends``): the text here is without it, the front adds it.

rcssserver picks its writers by the integer part of the version the client gave in ``(init TEAM (version
V))`` (rcssserver src/player.cpp, ``Player::setSenders``); versions 8 to 19 differ in these messages only
here:

* ``sense_body`` (rcssserver src/bodysender.cpp, with the serializers of src/serializerplayerstdv8.cpp and
  its successors for 13, 14 and 18): 8 to 11 end with ``arm``,
  ``focus`` and ``tackle``; 12 adds ``collision``; 13 adds the stamina capacity; 14 adds ``foul``; 18
  adds the ``change_focus`` count and ``focus_point``.
* the parameter messages (:mod:`keepaway.rcss.param_text`): each version gets the parameters of its
  version or older, and ``player_type`` grows at 14, 18 and 19.
* ``see``: 13 adds a ``k`` to a player that kicked in the last cycle; our ``see`` does not say who kicked,
  so no player carries it (nor ``t``, tackling, nor an arm's direction: ours never tackle or point).

A version below 8 (other hear, sense_body and parameter formats) or above 19 has no writers here:
rcssserver answers such an ``init`` with ``(error no_more_player_or_goalie_or_illegal_client_version)``
(:func:`error` of a ``bad_version``).

What rcssserver writes that our messages do not carry is written as rcssserver writes it for a player
that never used it: the arm, the focus, the tackle, the fouls and the focus point are all zero or none;
the ``change_focus`` count is 0. What our messages carry that rcssserver's would not show is explained
at :func:`see` and :func:`hear`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from keepaway.protocol.messages import COLLISIONS, SIDES, Error, Hear, InitOk, See, SenseBody
from keepaway.protocol.params import ServerParams
from keepaway.rcss.commands import ILLEGAL_TEAMNAME, NO_MORE_PLAYER, NO_SUCH_TEAM_OR_PLAYER
from keepaway.rcss.param_text import ParamValue, cpp_number, parameter_lines

SUPPORTED_VERSIONS = range(8, 20)
"""The protocol versions rendered here (rcssserver's serializers v8, v13, v14 and v18 and its senders)."""

# sense_body's order of the command counts (rcssserver src/serializerplayerstdv1.cpp, v5 and v7)
BODY_COUNTS = ("kick", "dash", "turn", "say", "turn_neck", "catch", "move", "change_view")
# what rcssserver writes for a player that never pointed, focused, tackled, fouled or moved its focus
NO_ARM = "(arm (movable 0) (expires 0) (target 0 0) (count 0))"
NO_FOCUS = "(focus (target none) (count 0))"
NO_TACKLE = "(tackle (expires 0) (count 0))"
NO_FOUL = "(foul (charged 0) (card none))"
NO_CHANGE_FOCUS = "(change_focus 0)"
NO_FOCUS_POINT = "(focus_point 0 0)"
SYNCH_SEE_VERSION = 18  # rcssserver turns synch_see on for a player of this version or later at its init
SYNCH_SEE_REPLY = "(ok synch_see)"
# rcssserver's answers to a refused init or reconnect (rcssserver src/stadium.cpp), by our error code
ERROR_TEXTS = {
    "bad_version": NO_MORE_PLAYER,
    "no_more_player": NO_MORE_PLAYER,
    "no_such_player": NO_SUCH_TEAM_OR_PLAYER,
    "illegal_teamname": ILLEGAL_TEAMNAME,
}


@dataclass(frozen=True)
class TextView:
    """What rendering needs beyond a message: the client's protocol version as it asked for it, its side,
    the team names it sees for side l and side r, the landmark names by id (``InitOk.landmarks``), and
    the far lengths of our perception (``ServerParams``) that tell an anonymous ball or player near the
    observer from a far one (:func:`see`)."""

    version: float
    side: str
    team_names: tuple[str, str]
    flag_names: tuple[str, ...]
    line_names: tuple[str, ...]
    unum_far_length: float = ServerParams.unum_far_length
    team_far_length: float = ServerParams.team_far_length

    def __post_init__(self) -> None:
        if int(self.version) not in SUPPORTED_VERSIONS:
            raise ValueError(f"protocol version {self.version:g} is not rendered (versions "
                             f"{SUPPORTED_VERSIONS.start} to {SUPPORTED_VERSIONS.stop - 1})")
        if self.side not in SIDES:
            raise ValueError(f"side {self.side!r} is not one of {SIDES}")

    @classmethod
    def of(cls, init_ok: InitOk, version: float, team_names: tuple[str, str]) -> TextView:
        """The view of the player ``init_ok`` seated, for a client of ``version``."""
        return cls(version, init_ok.side, team_names, tuple(name for name, _, _ in init_ok.landmarks["flags"]),
                   tuple(name for name, _, _ in init_ok.landmarks["lines"]),
                   float(init_ok.params["unum_far_length"]), float(init_ok.params["team_far_length"]))

    @property
    def protocol(self) -> int:
        """The version rcssserver picks its writers by."""
        return int(self.version)

    @property
    def names(self) -> tuple:
        """The names a see writes and the far lengths that pick them, in ``rcss.see_text.SeeNames.of``'s order."""
        return self.flag_names, self.line_names, self.team_names, self.unum_far_length, self.team_far_length


def supported(version: float) -> bool:
    """Whether a client of ``version`` can be served: else answer its init with :func:`error` of a
    ``bad_version``."""
    return int(version) in SUPPORTED_VERSIONS


def _number(value: float | int) -> str:
    return str(value) if isinstance(value, int) else cpp_number(value)


def init_reply(view: TextView, unum: int, play_mode: str) -> str:
    """``(init l 1 before_kick_off)`` (rcssserver src/serializerplayerstdv1.cpp, serializeInit)."""
    return f"(init {view.side} {unum} {play_mode})"


def reconnect_reply(view: TextView, play_mode: str) -> str:
    """``(reconnect l before_kick_off)`` (rcssserver src/serializerplayerstdv1.cpp, serializeReconnect)."""
    return f"(reconnect {view.side} {play_mode})"


def parameter_messages(params: ServerParams, view: TextView,
                       settings: Mapping[str, ParamValue] | None = None) -> list[str]:
    """``server_param``, ``player_param`` and ``player_type`` as sent after the init or reconnect reply
    (:func:`keepaway.rcss.param_text.parameter_lines`); ``settings``: rcssserver server parameters that
    ``params`` does not hold (the ports, ``synch_mode``, ``fullstate_l``, ...), by rcssserver's names."""
    return parameter_lines(params, view.protocol, settings)


def init_messages(params: ServerParams, view: TextView, unum: int, play_mode: str,
                  settings: Mapping[str, ParamValue] | None = None) -> list[str]:
    """Everything a player gets at its init, in order (rcssserver src/player.cpp, ``Player::sendInit``):
    the reply, the parameter messages and, for 18 and later, ``(ok synch_see)``: rcssserver turns synch_see
    on for them (``Player::initObservationMode``)."""
    synch_see = [SYNCH_SEE_REPLY] if view.protocol >= SYNCH_SEE_VERSION else []
    return [init_reply(view, unum, play_mode), *parameter_messages(params, view, settings), *synch_see]


def reconnect_messages(params: ServerParams, view: TextView, play_mode: str,
                       settings: Mapping[str, ParamValue] | None = None) -> list[str]:
    """Everything a player gets when it takes its number back (rcssserver src/player.cpp,
    ``Player::sendReconnect``): the reply and the parameter messages."""
    return [reconnect_reply(view, play_mode), *parameter_messages(params, view, settings)]


def sense_body(msg: SenseBody, view: TextView) -> str:
    """rcssserver's ``sense_body`` (rcssserver src/bodysender.cpp; the module docstring for the versions)."""
    version = view.protocol
    quality, width = msg.view_mode
    stamina, effort, capacity = msg.stamina
    amount, direction = msg.speed
    parts = [f"(sense_body {msg.cycle}", f"(view_mode {quality} {width})",
             f"(stamina {cpp_number(stamina)} {cpp_number(effort)}"
             + (f" {cpp_number(capacity)})" if version >= 13 else ")"),
             f"(speed {cpp_number(amount)} {direction})", f"(head_angle {msg.head_angle})",
             *(f"({name} {msg.counts[name]})" for name in BODY_COUNTS)]
    if version >= 18:
        parts.append(NO_CHANGE_FOCUS)
    parts += [NO_ARM, NO_FOCUS, NO_TACKLE]
    if version >= 12:
        collided = [f"({name})" for name in COLLISIONS if name in msg.collision]
        parts.append("(collision " + (" ".join(collided) if collided else "none") + ")")
    if version >= 14:
        parts.append(NO_FOUL)
    if version >= 18:
        parts.append(NO_FOCUS_POINT)
    return " ".join(parts) + ")"


def _seen(name: str, *numbers: float | int | None) -> str:
    """``((name) n1 n2 ...)`` with the numbers a see row has (rcssserver src/serializer.h,
    serializeVisualObject)."""
    return f"(({name}) " + " ".join(_number(n) for n in numbers if n is not None) + ")"


def _player_name(view: TextView, side: str | None, unum: int | None, dist: float) -> str:
    if side is None:  # a player too far for its team (p) can only be farther than team_far_length
        return "P" if dist <= view.team_far_length else "p"
    team = view.team_names[SIDES.index(side)]
    return f'p "{team}"' if unum is None else f'p "{team}" {unum}'


def see(msg: See, view: TextView) -> str:
    """rcssserver's ``see`` (rcssserver src/visualsenderplayer.cpp, src/serializerplayerstdv8.cpp): the
    flags, the ball, the players, the lines, each in the order of our rows (the landmarks' order, then left
    players and right players by number: rcssserver's order when the players joined in that order).

    Our rows leave out what rcssserver's leave out, so every name follows from them, with two rules of
    our perception (docs/rules.md §5.2): an object outside the view cone but within ``visible_distance``
    is anonymous (``(F)``, ``(B)``, ``(P)``), and a ball loses its changes and a player its team only
    beyond ``unum_far_length`` and ``team_far_length``, which are longer: so a ball without changes
    nearer than ``unum_far_length`` is ``(B)``, and a player without a side nearer than
    ``team_far_length`` is ``(P)``. A flag without an id is ``(F)``: rcssserver writes ``(G)`` for a goal
    so close, but our row does not say which landmark it is."""
    parts = [f"(see {msg.cycle}"]
    names = view.flag_names
    for flag_id, dist, direction, dist_chg, dir_chg in msg.flags:
        name = "F" if flag_id is None else names[flag_id]
        if dist_chg is None and dir_chg is None:  # the common rows written at once, as _seen writes them
            parts.append("((%s) %.6g %d)" % (name, dist, direction))
        elif dist_chg is not None and dir_chg is not None:
            parts.append("((%s) %.6g %d %.6g %.6g)" % (name, dist, direction, dist_chg, dir_chg))
        else:
            parts.append(_seen(name, dist, direction, dist_chg, dir_chg))
    if msg.ball is not None:
        dist, direction, dist_chg, dir_chg = msg.ball
        close = dist_chg is None and dist <= view.unum_far_length
        parts.append(_seen("B" if close else "b", dist, direction, dist_chg, dir_chg))
    for side, unum, dist, direction, dist_chg, dir_chg, body, head in msg.players:
        parts.append(_seen(_player_name(view, side, unum, dist), dist, direction, dist_chg, dir_chg, body, head))
    lines = view.line_names
    for line_id, dist, direction in msg.lines:
        parts.append("((%s) %.6g %d)" % (lines[line_id], dist, direction))
    return " ".join(parts) + ")"


def hear(msg: Hear, view: TextView) -> str | None:
    """rcssserver's ``hear`` (rcssserver src/audio.cpp, src/serializerplayerstdv8.cpp): the referee's
    words as they are, a say in double quotes, a teammate's with its direction and number, an opponent's
    with its direction (rcssserver's full form: its short ``(hear T opp)`` comes only to a player that
    turned its partial ear on, ``(ear ...)``, which we do not model). The coach's advice is heard as rcssserver's
    online coach of the listener's side says a freeform message, ``(hear T online_coach_left (freeform
    "TEXT"))``, which is what a client that announced its clang versions hears; advice that is not text,
    or text with a double quote (a freeform message cannot hold one), is None: a text client cannot be
    told it."""
    head = f"(hear {msg.cycle}"
    if msg.sender == "referee":
        return f"{head} referee {msg.message})"
    if msg.sender == "self":
        return f'{head} self "{msg.message}")'
    if msg.sender in ("our", "opp"):
        if msg.direction is None or (msg.sender == "our" and msg.unum is None):
            raise ValueError(f"a hear from a player ({msg.sender}) needs its direction and a teammate its number")
        speaker = f"our {msg.unum}" if msg.sender == "our" else "opp"
        return f'{head} {msg.direction} {speaker} "{msg.message}")'
    if not isinstance(msg.message, str) or '"' in msg.message:
        return None
    coach = "online_coach_left" if view.side == "l" else "online_coach_right"
    return f'{head} {coach} (freeform "{msg.message}"))'


def error(msg: Error) -> str | None:
    """rcssserver's answer to a refused ``init`` or ``reconnect`` (rcssserver src/stadium.cpp), for the codes
    that have one (:data:`ERROR_TEXTS`); None for the others: rcssserver has no such refusal or warning (a
    dropped say, a missed cycle) and tells the client nothing."""
    return ERROR_TEXTS.get(msg.code)


def think() -> str:
    """``(think)``: every percept of the cycle has been sent (rcssserver src/stadium.cpp, synchronous mode)."""
    return "(think)"


__all__ = [
    "SUPPORTED_VERSIONS",
    "TextView",
    "error",
    "hear",
    "init_messages",
    "init_reply",
    "parameter_messages",
    "reconnect_messages",
    "reconnect_reply",
    "see",
    "sense_body",
    "supported",
    "think",
]
