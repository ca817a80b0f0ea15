"""rcssserver's text to a player, read into our protocol's messages (docs/protocol.md §6): what lets our
players play on a real rcssserver (``keepaway player --rcss``).

One datagram of rcssserver holds one s-expression, NUL-terminated (rcssserver ``src/player.cpp``,
``src/serializerplayerstdv8.cpp`` and its successors). The pure functions below read each kind;
:class:`PlayerReader` keeps the little a player must remember between datagrams (its team and side, the
cycle a ``(think)`` answers, the parameters until its ``init_ok`` is complete) and turns every datagram
into our messages:

* ``(init l 1 before_kick_off)`` / ``(reconnect l before_kick_off)`` (``initsenderplayer.cpp``) is
  :class:`Joined`; then ``(server_param ...)`` and the ``(player_type (id 0) ...)`` of rcssserver's default
  type (``initsender.cpp``: ``(name value)`` lists from protocol version 8 on) make the ``init_ok``: our
  parameter table from rcssserver's names (``rcss.param_text``; the rest keep rcssserver 19's defaults, the
  ``current`` set), our landmarks (rcssserver's default landmark file, ``protocol.landmarks``), and the
  timing mode from ``synch_mode`` (rcssserver sends them after a reconnect too);
* ``(sense_body ...)`` of versions 8 to 19 (``bodysender.cpp``: stamina capacity from 13, collisions from
  12; the arm, focus, tackle and foul fields are not ours);
* ``(see ...)`` (``visualsenderplayer.cpp``): flags and goals by name, ``(F)`` and ``(G)`` nameless, lines,
  the ball ``(b)``/``(B)``, players ``(p "team" n)``, ``(p "team" n goalie)``, ``(p "team")``, ``(p)``
  and ``(P)`` with a pointing direction and a kick or tackle mark left out; a team name is our side if it
  is our team's, the other side otherwise. An object seen in low quality (a direction alone) is left out;
* ``(hear ...)`` (``audio.cpp``): the referee (``play_on``, ``training Keepaway 1``), the player itself,
  a teammate ``(hear T DIR our UNUM "msg")``, an opponent, a coach's free text; rcssserver's short forms
  without a message are left out;
* ``(think)`` (``stadium.cpp``, synchronous mode) is ``think`` for the cycle of the last ``sense_body``;
  ``(error NAME)`` and ``(warning NAME)`` are ``error`` with that code.

Untrusted text is bounded: a datagram longer than rcssserver's ``MaxMesg`` (8192 bytes, ``param.h``) or
not one balanced s-expression, a number that is not one, a value outside its field's range (every message
is checked by its ``from_wire``, as a decoded frame is) makes the datagram skipped with one log line (at
most one a second per kind, ``core.log_limit``), never an exception.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from keepaway.core.log_limit import KIND_ATTR, RepeatLimit
from keepaway.protocol import PROTOCOL_VERSION, ProtocolError
from keepaway.protocol import messages as m
from keepaway.protocol.landmarks import FLAG_INDEX, LINE_INDEX, to_wire
from keepaway.protocol.params import KernelParams, ServerParams, parameter_set
from keepaway.rcss.param_text import NOT_IN_RCSSSERVER, PLAYER_TYPE_PARAMS, RCSS_PARAM_NAMES
from keepaway.rcss.sexp import Sexp, SexpError, parse_all, unquote

log = logging.getLogger("keepaway.rcss")
repeat_limit = RepeatLimit()
log.addFilter(repeat_limit)

MAX_TEXT_CHARS = 8192  # rcssserver's MaxMesg (param.h): the longest datagram it sends
VERSIONS = range(8, 20)  # the protocol versions read here: (name value) parameter lists (8) to rcssserver 19's
OTHER_SIDE = {"l": "r", "r": "l"}
COACHES = ("coach", "online_coach_left", "online_coach_right")  # audio.cpp's names of the coaches
VISUAL_MARKS = ("k", "t")  # a seen player kicking or tackling (serializerplayerstdv13.cpp)
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_INTEGER = re.compile(r"[+-]?\d{1,10}")
_MAX_NUMBER_CHARS = 40
# What carries nothing a player of ours takes (parameters of the other types, substitutions, the score, acks).
_IGNORED = frozenset({"player_param", "change_player_type", "score", "ok"})


class RcssReadError(ValueError):
    """Text that is not a message of the kind it claims to be (a one-line reason)."""


@dataclass(frozen=True)
class Joined:
    """rcssserver's answer to ``init`` or ``reconnect``: the side it seated the player on, its uniform number
    (None after a reconnect, whose answer does not repeat it) and the play mode."""

    side: str
    unum: int | None
    play_mode: str


# ------------------------------------------------------------------------------------------------ atoms


def _atom(value: Any, what: str) -> str:
    if type(value) is not str:
        raise RcssReadError(f"{what} is a list, not a word")
    return value


def _float(value: Any, what: str) -> float:
    """A number as rcssserver prints it (``-0``, ``1e-05``); not ``nan``, ``inf`` or an over-long digit run."""
    text = _atom(value, what)
    if len(text) > _MAX_NUMBER_CHARS or not _NUMBER.fullmatch(text):
        raise RcssReadError(f"{what} {text[:20]!r} is not a number")
    number = float(text)
    if not math.isfinite(number):
        raise RcssReadError(f"{what} {text[:20]!r} is not a finite number")
    return number


def _int(value: Any, what: str) -> int:
    text = _atom(value, what)
    if not _INTEGER.fullmatch(text):
        raise RcssReadError(f"{what} {text[:20]!r} is not an integer")
    return int(text)


def _built(cls: type[m.Message], wire: dict[str, Any]) -> m.Message:
    """The message ``wire`` describes, checked field by field as a decoded frame is."""
    try:
        return cls.from_wire({"type": cls.TYPE, **wire})
    except ProtocolError as exc:
        raise RcssReadError(exc.message) from None


# ------------------------------------------------------------------------------------- joining, params


def read_joined(expr: Sexp) -> Joined:
    """``(init SIDE UNUM PLAYMODE)`` or ``(reconnect SIDE PLAYMODE)``. Any play mode but ``play_on`` is
    before the kick-off for our players (a Keepaway game knows only the two)."""
    reconnect = expr[0] == "reconnect"
    if len(expr) != (3 if reconnect else 4):
        raise RcssReadError(f"{expr[0]} takes {2 if reconnect else 3} words, got {len(expr) - 1}")
    side = _atom(expr[1], "the side")
    if side not in OTHER_SIDE:
        raise RcssReadError(f"the side {side[:20]!r} is neither l nor r")
    unum = None if reconnect else _int(expr[2], "the uniform number")
    if unum is not None and not 1 <= unum <= m.MAX_UNUM:
        raise RcssReadError(f"the uniform number {unum} is outside 1..{m.MAX_UNUM}")
    mode = _atom(expr[-1], "the play mode")
    return Joined(side, unum, "play_on" if mode == "play_on" else "before_kick_off")


def read_params(expr: Sexp) -> dict[str, str]:
    """``(server_param (name value) ...)`` or ``(player_type ...)``: each name's value as printed (a number,
    or a quoted string); the first of a repeated name counts."""
    values: dict[str, str] = {}
    for entry in expr[1:]:
        if type(entry) is not list or len(entry) != 2:
            raise RcssReadError(f"{expr[0]} has an entry that is not (name value)")
        values.setdefault(_atom(entry[0], "a parameter's name"), _atom(entry[1], "a parameter's value"))
    return values


def server_params(server: Mapping[str, str], player_type: Mapping[str, str]) -> ServerParams:
    """Our parameter table from rcssserver's ``server_param`` and its default type's ``player_type``
    (``rcss.param_text``); a parameter neither gives (an older protocol version sends fewer, and some of ours
    rcssserver does not have) keeps rcssserver 19's default, the ``current`` set. A value outside our
    table's range is an :class:`RcssReadError`."""
    changes = {}
    for name in KernelParams._fields:
        if name in PLAYER_TYPE_PARAMS:
            source, key = player_type, name
        elif name in NOT_IN_RCSSSERVER:
            continue
        else:
            source, key = server, RCSS_PARAM_NAMES.get(name, name)
        if key in source:
            changes[name] = _float(source[key], key)
    try:
        return parameter_set("current", keepaway_launch=False).replace(**changes)
    except ValueError as exc:
        raise RcssReadError(str(exc)) from None


# ---------------------------------------------------------------------------------------------- percepts


def read_sense_body(expr: Sexp) -> m.SenseBody:
    """``(sense_body T (view_mode Q W) (stamina S E [CAPACITY]) (speed A [DIR]) (head_angle H) (kick N) ...
    [(collision none|(ball)|(player)|(post)...)] ...)``; a capacity not sent (before version 13) is -1,
    a count not sent 0."""
    if len(expr) < 2:
        raise RcssReadError("sense_body has no time")
    fields: dict[str, list] = {}
    for item in expr[2:]:
        if type(item) is list and item and type(item[0]) is str:
            fields.setdefault(item[0], item[1:])
    missing = [name for name in ("view_mode", "stamina", "speed", "head_angle") if name not in fields]
    if missing:
        raise RcssReadError(f"sense_body has no {', '.join(missing)}")
    stamina = [_float(v, "the stamina") for v in fields["stamina"]]
    speed = fields["speed"]
    if len(stamina) not in (2, 3) or len(speed) not in (1, 2):
        raise RcssReadError("sense_body's stamina or speed has the wrong number of values")
    collision = fields.get("collision", ["none"])
    return _built(m.SenseBody, {
        "cycle": _int(expr[1], "the time"),
        "view_mode": fields["view_mode"],
        "stamina": stamina if len(stamina) == 3 else [*stamina, -1.0],
        "speed": [_float(speed[0], "the speed"), _int(speed[1], "the speed's direction") if len(speed) == 2 else 0],
        "head_angle": _int(_one(fields, "head_angle"), "the head angle"),
        "counts": {name: _int(_one(fields, name), name) if name in fields else 0 for name in m.COMMAND_COUNTS},
        "collision": [] if collision == ["none"] else [_atom(c[0], "a collision") if type(c) is list and c else ""
                                                       for c in collision],
    })


def _one(fields: Mapping[str, list], name: str) -> Any:
    """The one value of a sense_body field ``(name value)``."""
    if len(fields[name]) != 1:
        raise RcssReadError(f"sense_body's {name} has {len(fields[name])} values")
    return fields[name][0]


def _seen_values(values: list, what: str) -> tuple[float, int, float | None, float | None]:
    """``dist dir [dist_chg dir_chg]`` of a flag, line or ball."""
    if len(values) not in (2, 4):
        raise RcssReadError(f"{what} has {len(values)} values")
    dist, direction = _float(values[0], f"{what}'s distance"), _int(values[1], f"{what}'s direction")
    if len(values) == 2:
        return dist, direction, None, None
    return dist, direction, _float(values[2], f"{what}'s distance change"), _float(values[3], f"{what}'s change")


def _seen_player(name: list, values: list, our_team: str, our_side: str) -> list:
    """A player's row (docs/protocol.md §6, ``see``) from its name and values: ``dist dir [point]`` or
    ``dist dir dist_chg dir_chg body head [point]``, a ``k`` or ``t`` mark at the end."""
    if values and values[-1] in VISUAL_MARKS:
        values = values[:-1]
    if len(values) not in (2, 3, 6, 7):
        raise RcssReadError(f"a player has {len(values)} values")
    if name[0] == "P" or len(name) == 1:
        side = None
    else:
        side = our_side if unquote(_atom(name[1], "a team name")) == our_team else OTHER_SIDE[our_side]
    unum = _int(name[2], "a player's uniform number") if len(name) >= 3 else None
    numbers = [_float(values[0], "a player's distance"), _int(values[1], "a player's direction")]
    if len(values) >= 6:
        numbers += [_float(values[2], "a player's distance change"), _float(values[3], "a player's change"),
                    _int(values[4], "a player's body"), _int(values[5], "a player's head")]
    else:
        numbers += [None] * 4
    return [side, unum, *numbers]


def read_see(expr: Sexp, our_team: str, our_side: str) -> m.See:
    """``(see T ((name) values) ...)`` as our ``see`` (module docstring); the objects come in any order."""
    if len(expr) < 2:
        raise RcssReadError("see has no time")
    flags, lines, players, ball = [], [], [], None
    for item in expr[2:]:
        if type(item) is not list or not item or type(item[0]) is not list or not item[0]:
            raise RcssReadError("see has an entry that is not ((name) values)")
        name, values = item[0], item[1:]
        kind = _atom(name[0], "an object's kind")
        if len(values) == 1:
            continue  # low quality: a direction alone
        if kind in ("F", "G") and len(name) == 1:
            flags.append([None, *_seen_values(values, "a flag")])
        elif kind in ("f", "g"):
            flag_id = FLAG_INDEX.get(" ".join(_atom(word, "a flag's name") for word in name))
            if flag_id is not None:
                flags.append([flag_id, *_seen_values(values, "a flag")])
        elif kind == "l":
            line_id = LINE_INDEX.get(" ".join(_atom(word, "a line's name") for word in name))
            if line_id is not None:
                lines.append([line_id, *_seen_values(values, "a line")[:2]])
        elif kind in ("b", "B") and len(name) == 1:
            ball = list(_seen_values(values, "the ball"))
        elif kind in ("p", "P") and len(name) <= 4:
            players.append(_seen_player(name, values, our_team, our_side))
    return _built(m.See, {"cycle": _int(expr[1], "the time"), "flags": flags, "lines": lines, "ball": ball,
                          "players": players})


def read_hear(expr: Sexp) -> m.Hear | None:
    """``(hear T referee MSG)``, ``(hear T self "msg")``, ``(hear T DIR our UNUM "msg")``, ``(hear T DIR opp
    "msg")``, ``(hear T COACH "msg")``; None for what carries no message we take (rcssserver's short forms
    ``(hear T our UNUM)`` and ``(hear T opp)``, a coach's CLang)."""
    if len(expr) < 3:
        raise RcssReadError("hear has no sender")
    cycle = _int(expr[1], "the time")
    sender, rest = expr[2], expr[3:]
    if sender == "referee":
        wire = {"sender": "referee", "message": " ".join(unquote(_atom(w, "a referee word")) for w in rest)}
    elif sender == "self" and len(rest) == 1:
        wire = {"sender": "self", "message": unquote(_atom(rest[0], "the message"))}
    elif sender in COACHES:
        if len(rest) != 1 or type(rest[0]) is not str:
            return None
        wire = {"sender": "coach", "message": unquote(rest[0])}
    elif len(rest) >= 2 and rest[0] in ("our", "opp"):
        if (rest[0] == "our" and len(rest) != 3) or (rest[0] == "opp" and len(rest) != 2):
            raise RcssReadError(f"hear from {rest[0]} has {len(rest) + 1} words after the time")
        wire = {"sender": rest[0], "direction": _int(sender, "the direction"),
                "unum": _int(rest[1], "the uniform number") if rest[0] == "our" else None,
                "message": unquote(_atom(rest[-1], "the message"))}
    elif sender in ("our", "opp"):
        return None
    else:
        raise RcssReadError(f"hear from {str(sender)[:20]!r}")
    return _built(m.Hear, {"cycle": cycle, **wire})


# ------------------------------------------------------------------------------------------------ reader


class PlayerReader:
    """One player's reading of rcssserver's datagrams: ``read(text)`` returns what the text holds, our
    messages for the agent and :class:`Joined` for the socket edge (module docstring). ``team`` is the
    name the player joined with: its own team in a ``see``."""

    def __init__(self, team: str, unum: int | None = None) -> None:
        self.team = team
        self.unum = unum  # the uniform number a reconnect asked for
        self.joined: Joined | None = None
        self.cycle = 0  # the time of the last sense_body: the cycle a (think) answers
        self.ready = False  # init_ok made
        self._server: dict[str, str] | None = None
        self._readers = {
            "init": self._on_joined, "reconnect": self._on_joined, "server_param": self._on_server_param,
            "player_type": self._on_player_type, "sense_body": self._on_sense_body, "see": self._on_see,
            "hear": self._on_hear, "think": self._on_think, "error": self._on_error, "warning": self._on_error,
        }

    def read(self, text: str) -> list[m.Message | Joined]:
        """The messages one datagram's text holds; none, and one log line, if it is not what it claims."""
        if len(text) > MAX_TEXT_CHARS:
            return self._skipped("text", f"{len(text)} characters, more than {MAX_TEXT_CHARS}", text)
        try:
            expressions = parse_all(text)
        except SexpError as exc:
            return self._skipped("text", str(exc), text)
        found: list[m.Message | Joined] = []
        for expr in expressions:
            head = expr[0] if expr and type(expr[0]) is str else ""
            reader = self._readers.get(head)
            if reader is None:
                if head not in _IGNORED:
                    self._skipped(head or "text", "not a message a player takes", text)
                continue
            try:
                found += reader(expr)
            except RcssReadError as exc:
                self._skipped(head, str(exc), text)
        return found

    def _skipped(self, kind: str, reason: str, text: str) -> list:
        log.warning("skipped a message from rcssserver: %s: %s: %.80r", kind, reason, text,
                    extra={KIND_ATTR: ("skipped", kind[:20])})
        return []

    def _on_joined(self, expr: Sexp) -> list:
        if self.joined is not None:
            return []
        joined = read_joined(expr)
        if joined.unum is None:
            if self.unum is None:
                raise RcssReadError("a reconnect's answer, but no reconnect was asked for")
            joined = Joined(joined.side, self.unum, joined.play_mode)
        self.joined = joined
        return [joined]

    def _on_server_param(self, expr: Sexp) -> list:
        self._server = read_params(expr)
        return []

    def _on_player_type(self, expr: Sexp) -> list:
        """The default type (id 0) completes the init_ok (module docstring)."""
        values = read_params(expr)
        joined = self.joined
        if values.get("id") != "0" or self._server is None or joined is None or self.ready:
            return []
        params = server_params(self._server, values)
        mode = "sync" if _float(self._server.get("synch_mode", "0"), "synch_mode") else "realtime"
        init_ok = _built(m.InitOk, {
            "version": PROTOCOL_VERSION, "cycle": self.cycle, "side": joined.side, "unum": joined.unum,
            "team": self.team, "play_mode": joined.play_mode, "params": params.to_dict(), "landmarks": to_wire(),
            "config": {"mode": mode}})
        self.ready = True
        return [init_ok]

    def _on_sense_body(self, expr: Sexp) -> list:
        body = read_sense_body(expr)
        self.cycle = body.cycle
        return [body]

    def _on_see(self, expr: Sexp) -> list:
        return [read_see(expr, self.team, self.joined.side)] if self.joined is not None else []

    def _on_hear(self, expr: Sexp) -> list:
        heard = read_hear(expr)
        return [] if heard is None else [heard]

    def _on_think(self, expr: Sexp) -> list:
        """Every (think) is reported, before the init_ok too: a synchronous server waits for its (done)."""
        return [_built(m.Think, {"cycle": self.cycle})]

    def _on_error(self, expr: Sexp) -> list:
        """``(error NAME)`` or ``(warning NAME)``: an ``error`` whose code is the name."""
        words = " ".join(w if type(w) is str else "(...)" for w in expr[1:])
        code = _atom(expr[1], "the error's name") if len(expr) > 1 else expr[0]
        return [_built(m.Error, {"cycle": self.cycle, "code": code[:m.MAX_CODE_CHARS],
                                 "message": f"{expr[0]} {words}"[:m.MAX_TEXT_CHARS]})]
