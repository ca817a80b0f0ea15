"""One text client seated at our server through the front, without sockets: rcssserver's text from the
client in, our protocol's messages to the server out, and back (docs/protocol.md §16).

A :class:`TextSeat` is made for a client's first datagram (its ``(init ...)`` or ``(reconnect ...)``),
says which message joins it to our server, and from then on translates each way. The front
(``rcss.front``) owns the sockets; a seat owns the translation state: the client's version and side, the
team names it sees, the cycle the server is at, the commands of the answer under way.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import NamedTuple

from keepaway.protocol import PROTOCOL_VERSION
from keepaway.protocol import messages as m
from keepaway.protocol.codec import Message
from keepaway.protocol.params import ServerParams
from keepaway.rcss import render
from keepaway.rcss.commands import (
    CommandTextError,
    InitRequest,
    ParsedDatagram,
    ReconnectRequest,
    parse_commands,
)

log = logging.getLogger("keepaway.rcss")

CLIENT_PREFIX = "rcss-text"  # our ``init.client``: "rcss-text v12 keepers"
# Our error codes a text client is told of, as rcssserver words the same refusal (src/stadium.cpp,
# src/player.cpp); the others (budgets, missed cycles, a command for a later cycle) have no rcssserver
# counterpart and are logged only.
REFUSALS = {
    "no_more_player": "(error no_more_team_or_player_or_goalie)",
    "no_such_player": "(error reconnect)",
    "cannot_reconnect": "(error reconnect)",
    "illegal_teamname": "(error no_more_team_or_player_or_goalie)",
}
# our error code -> rcssserver's answer to the command it refuses, once the client is seated
COMMAND_ERRORS = {
    "dropped": "(error illegal_command_form)",  # a say rcssserver's grammar or say_msg_size would refuse
}


SIDE_TEAMS = {"l": "keepers", "r": "takers"}


@dataclass
class TeamNames:
    """The team names of the text clients, and which of our teams each is. As in rcssserver the first
    name the front hears gets the left side, which the Keepaway referee makes the keepers, the second
    the right side, and a third is refused; but ``"keepers"`` and ``"takers"`` (the keepaway-0.6 players'
    ``-t`` names, our players' teams) always name their own side, whichever joins first. A side no text
    client has named is seen under our team's name."""

    claims: dict[str, str] = field(default_factory=dict)  # side -> the name a text client gave it

    def team_of(self, name: str) -> str | None:
        """Our team (``"keepers"`` / ``"takers"``) for a text client's team ``name``; None: no side left."""
        for side, claimed in self.claims.items():
            if claimed == name:
                return SIDE_TEAMS[side]
        own = {team: side for side, team in SIDE_TEAMS.items()}.get(name)
        for side in (own,) if own else ("l", "r"):
            if side not in self.claims:
                self.claims[side] = name
                return SIDE_TEAMS[side]
        return None

    def names(self) -> tuple[str, str]:
        """The names of side l and side r, as a text client sees them."""
        return self.claims.get("l", SIDE_TEAMS["l"]), self.claims.get("r", SIDE_TEAMS["r"])


class Out(NamedTuple):
    """What one input of a seat gives: texts for the client, messages for our server."""

    texts: list[str]
    to_server: list[Message]


class TextSeat:
    """The translation state of one text client (sans-IO; the front feeds it)."""

    def __init__(self, request: InitRequest | ReconnectRequest, team: str, names: TeamNames, version: float) -> None:
        self.request = request
        self.team = team
        self.names = names
        self.version = version  # the init's, or for a reconnect the version the seat was taken with
        self.view: render.TextView | None = None  # once seated
        self.unum: int | None = None
        self.sync = True
        self.cycle = 0  # the cycle of the server's last percept
        self.pending: list[m.AtomicCommand] = []  # the commands of the answer under way (until done)
        self.pending_cycle = 0
        self.gone = False  # refused, the server shut down, or the client said bye

    @property
    def seated(self) -> bool:
        return self.view is not None

    def join_message(self) -> Message:
        """What joins the client to our server: ``init`` asking for pre-kick-off percepts as rcssserver
        sends them, or ``reconnect``."""
        if isinstance(self.request, ReconnectRequest):
            return m.Reconnect(version=PROTOCOL_VERSION, team=self.team, unum=self.request.unum)
        client = f"{CLIENT_PREFIX} v{self.version:g} {self.request.team}"[:m.MAX_CLIENT_CHARS]
        return m.Init(version=PROTOCOL_VERSION, team=self.team, client=client, pre_kick_off=True)

    # -- server -> client --------------------------------------------------------------------------------
    def on_server(self, msg: Message) -> Out:
        """The texts ``msg`` from our server becomes for the client (none for what rcssserver would not
        send), and the commands still waiting for a ``(done)`` when the server has stepped without it."""
        out = Out([], [])
        if isinstance(msg, m.InitOk):
            out.texts.extend(self._seated(msg))
        elif isinstance(msg, m.Error):
            out.texts.extend(self._error(msg))
        elif isinstance(msg, m.Shutdown):
            self.gone = True
        elif self.view is None:
            pass
        elif isinstance(msg, m.SenseBody):
            if self.pending and msg.cycle > self.pending_cycle:  # they act late, as they would have come
                out.to_server.append(self._take_pending())
            self.cycle = msg.cycle
            out.texts.append(render.sense_body(msg, self.view))
        elif isinstance(msg, m.See):
            out.texts.append(render.see(msg, self.view))
        elif isinstance(msg, m.Hear):
            text = render.hear(msg, self.view)
            if text is not None:
                out.texts.append(text)
        elif isinstance(msg, m.Think) and self.sync:  # rcssserver sends (think) in synchronous mode only
            self.cycle = msg.cycle
            out.texts.append(render.think())
        return out  # waiting, fullstate (never asked for): rcssserver sends no such text

    def _seated(self, msg: m.InitOk) -> list[str]:
        self.view = render.TextView(
            version=self.version, side=msg.side, team_names=self.names.names(),
            flag_names=tuple(name for name, _, _ in msg.landmarks["flags"]),
            line_names=tuple(name for name, _, _ in msg.landmarks["lines"]),
        )
        self.sync = msg.config.get("mode", "sync") == "sync"
        self.cycle, self.unum = msg.cycle, msg.unum
        if isinstance(self.request, ReconnectRequest):
            first = render.reconnect_reply(self.view, msg.play_mode)
        else:
            first = render.init_reply(self.view, msg.unum, msg.play_mode)
        return [first, *render.parameter_messages(ServerParams.from_dict(msg.params), self.view)]

    def _error(self, msg: m.Error) -> list[str]:
        if self.view is None:  # the server refused the seat
            self.gone = True
            return [REFUSALS.get(msg.code, REFUSALS["no_more_player"])]
        reply = COMMAND_ERRORS.get(msg.code)
        if reply is None:
            log.info("%s: %s: %s", self.describe(), msg.code, msg.message)
            return []
        return [reply]

    # -- client -> server --------------------------------------------------------------------------------
    def on_datagram(self, text: str) -> Out:
        """One datagram of the seated client: replies for it, messages for our server. In synchronous mode
        the commands wait for ``(done)``, which ends the client's answer to the cycle (one ``command``
        message, as our protocol answers a ``think``); in real-time mode each datagram's commands go at
        once."""
        try:
            parsed: ParsedDatagram = parse_commands(text, self.version)
        except CommandTextError as exc:
            return Out([exc.reply], [])
        out = Out(list(parsed.replies), [])
        if parsed.commands:
            if not self.pending:
                self.pending_cycle = self.cycle
            self.pending.extend(parsed.commands)
        if parsed.done or (self.pending and not self.sync):
            out.to_server.append(self._take_pending())
        if parsed.bye:
            out.to_server.append(m.Bye())
            self.gone = True
        return out

    def _take_pending(self) -> m.Command:
        """The waiting commands as one ``command`` (at most MAX_COMMANDS: beyond, rcssserver's slot rule
        would ignore them but for says and view changes, which a client sends one a cycle)."""
        cycle = self.pending_cycle if self.pending else self.cycle
        commands, self.pending = self.pending[:m.MAX_COMMANDS], []
        return m.Command(cycle=cycle, commands=tuple(commands))

    def describe(self) -> str:
        side = self.view.side if self.view is not None else "?"
        return f"text client {self.request.team!r} ({side} {self.unum or '?'}, v{self.version:g})"
