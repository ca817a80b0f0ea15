"""One text client seated at our server through the front, without sockets: rcssserver's text from the
client in, our protocol's messages to the server out, and back (docs/protocol.md §16).

A :class:`TextSeat` is made for a client's first datagram (its ``(init ...)`` or ``(reconnect ...)``),
says which message joins it to our server, and from then on translates each way. The front
(``rcss.front``) owns the sockets; a seat owns the translation state: the client's version and side, the
team names it sees, the cycle the server is at, the commands of the answer under way.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from keepaway.core.jit import SteadyCall
from keepaway.protocol import PROTOCOL_VERSION
from keepaway.protocol import messages as m
from keepaway.protocol.codec import Message
from keepaway.protocol.params import ServerParams
from keepaway.rcss import render
from keepaway.rcss.commands import (
    NO_MORE_PLAYER,
    NO_SUCH_TEAM_OR_PLAYER,
    OK_SYNCH_SEE,
    EarRequest,
    InitRequest,
    ReconnectRequest,
    ScoreRequest,
    SenseBodyRequest,
    SynchSeeRequest,
    parse_commands,
)
from keepaway.rcss.see_text import MAX_SEE_BYTES, SEE_FRAME_START, SeeNames, write_see

log = logging.getLogger("keepaway.rcss")
# The datagram a synchronous client sends every cycle, read once (a NUL-terminated one reads the same in
# every version).
DONE_DATAGRAM = b"(done)\0"
DONE = parse_commands(DONE_DATAGRAM, 19.0)

CLIENT_PREFIX = "rcss-text"  # our ``init.client``: "rcss-text v12 keepers"


SIDE_TEAMS = {"l": "keepers", "r": "takers"}


@dataclass
class TeamNames:
    """The team names of the text clients, and which of our teams each is. As in rcssserver the first
    name the front hears gets the left side, which the Keepaway referee makes the keepers, the second
    the right side, and a third is refused; but ``"keepers"`` and ``"takers"`` (the keepaway-0.6 players'
    ``-t`` names, our players' teams) always name their own side, whichever joins first. A name holds its
    side while a text client of it is joining or seated; a side no text client names is seen under our
    team's name."""

    claims: dict[str, tuple[str, int]] = field(default_factory=dict)  # side -> (name, its clients)

    def join(self, name: str) -> str | None:
        """Our team (``"keepers"`` / ``"takers"``) for a joining text client of team ``name``, which it
        now holds; None: no side is left for the name."""
        for side, (claimed, clients) in self.claims.items():
            if claimed == name:
                self.claims[side] = (name, clients + 1)
                return SIDE_TEAMS[side]
        own = {team: side for side, team in SIDE_TEAMS.items()}.get(name)
        for side in (own,) if own else ("l", "r"):
            if side not in self.claims:
                self.claims[side] = (name, 1)
                return SIDE_TEAMS[side]
        return None

    def leave(self, team: str) -> None:
        """A text client of our ``team`` is gone (refused, or left)."""
        side = {t: s for s, t in SIDE_TEAMS.items()}[team]
        name, clients = self.claims[side]
        if clients > 1:
            self.claims[side] = (name, clients - 1)
        else:
            del self.claims[side]

    def names(self) -> tuple[str, str]:
        """The names of side l and side r, as a text client sees them."""
        return tuple(self.claims.get(side, (SIDE_TEAMS[side], 0))[0] for side in ("l", "r"))


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
        self.last_sense_body = ""
        self.held: str | None = None  # this cycle's sense_body, until the referee has spoken (on_server)
        # rcssserver turns synch_see on at the init of a client of version 18 or later (our server at the
        # init the seat sends), and for any client that asks with (synch_see) (our server at a synch_see)
        self.synch_see = int(version) >= render.SYNCH_SEE_VERSION
        self.see_names: SeeNames | None = None  # the view's names as the see kernel writes them
        self.see_out = np.empty(MAX_SEE_BYTES, np.uint8)
        self.write_see = SteadyCall(write_see)

    @property
    def seated(self) -> bool:
        return self.view is not None

    def join_message(self) -> Message:
        """What joins the client to our server: ``init`` asking for pre-kick-off percepts as rcssserver
        sends them, or ``reconnect``."""
        if isinstance(self.request, ReconnectRequest):
            return m.Reconnect(version=PROTOCOL_VERSION, team=self.team, unum=self.request.unum)
        client = f"{CLIENT_PREFIX} v{self.version:g} {self.request.team}"[:m.MAX_CLIENT_CHARS]
        return m.Init(version=PROTOCOL_VERSION, team=self.team, client=client, pre_kick_off=True,
                      synch_see=self.synch_see)

    # -- server -> client --------------------------------------------------------------------------------
    def on_server(self, msg: Message) -> Out:
        """The texts ``msg`` from our server becomes for the client (none for what rcssserver would not
        send), and the commands still waiting for a ``(done)`` when the server has stepped without it.
        Dispatched on ``msg.TYPE``: the front hands the cycle's percepts over as namespaces of their
        fields (``rcss.front.percept``).

        A cycle's ``sense_body`` is held until the next message: the referee's words of the cycle go out
        before it, as rcssserver writes them inside the step (src/stadium.cpp, ``sendRefereeAudio``), the
        players' says and the rest after it, as rcssserver flushes them after the body (``doSendSenseBody``).
        Our server sends a ``think`` after every cycle's percepts, in real-time mode too, so nothing is held
        past its cycle."""
        out = Out([], [])
        kind = msg.TYPE
        held, self.held = self.held, None
        if kind == m.Hear.TYPE and msg.sender == "referee" and held is not None:
            text = render.hear(msg, self.view)
            self.held = held
            return Out([text], [])
        if held is not None:
            out.texts.append(held)
        if kind == m.InitOk.TYPE:
            out.texts.extend(self._seated(msg))
        elif kind == m.Error.TYPE:
            out.texts.extend(self._error(msg))
        elif kind == m.Shutdown.TYPE:
            self.gone = True
        elif self.view is None:
            pass
        elif kind == m.SenseBody.TYPE:
            if self.pending and msg.cycle > self.pending_cycle:  # they act late, as they would have come
                out.to_server.append(self._take_pending())
            self.cycle = msg.cycle
            self.last_sense_body = self.held = render.sense_body(msg, self.view)
        elif kind == m.See.TYPE:
            self._follow_team_names()
            out.texts.append(render.see(msg, self.view))
        elif kind == m.Hear.TYPE:
            text = render.hear(msg, self.view)
            if text is not None:
                out.texts.append(text)
        elif kind == m.Think.TYPE and self.sync:  # rcssserver sends (think) in synchronous mode only
            self.cycle = msg.cycle
            out.texts.append(render.think())
        return out  # waiting, fullstate (never asked for): rcssserver sends no such text

    def on_see_frame(self, frame: bytes) -> Out | None:
        """A see frame of our server as :meth:`on_server` would take its message, written by a kernel
        (``rcss.see_text``), without decoding it; None for any other frame, and for a see the kernel
        leaves to :meth:`on_server`."""
        if self.view is None or not frame.startswith(SEE_FRAME_START):
            return None
        self._follow_team_names()
        n = self.write_see(frame, len(frame), self.see_names, self.see_out)
        if n < 0:
            return None
        held, self.held = self.held, None
        text = self.see_out[:n].tobytes().decode("latin-1")
        return Out([held, text] if held is not None else [text], [])

    def _follow_team_names(self) -> None:
        """A team named itself since the view was made: players are seen under its name."""
        names = self.names.names()
        if names != self.view.team_names:
            self._set_view(replace(self.view, team_names=names))

    def _set_view(self, view: render.TextView) -> None:
        self.view = view
        self.see_names = SeeNames.of(*view.names)

    def _seated(self, msg: m.InitOk) -> list[str]:
        self._set_view(view := render.TextView.of(msg, self.version, self.names.names()))
        self.sync = msg.config.get("mode", "sync") == "sync"
        self.cycle, self.unum = msg.cycle, msg.unum
        params = ServerParams.from_dict(msg.params)
        settings = {"synch_mode": self.sync}
        if isinstance(self.request, ReconnectRequest):
            return render.reconnect_messages(params, view, msg.play_mode, settings)
        return render.init_messages(params, view, msg.unum, msg.play_mode, settings)

    def _error(self, msg: m.Error) -> list[str]:
        """A refused seat gets rcssserver's refusal; once seated, our warnings (a dropped say, a missed
        cycle, a spent budget) have no rcssserver counterpart (rcssserver ignores a say beyond
        say_msg_size silently) and are logged only."""
        if self.view is not None:
            log.info("%s: %s: %s", self.describe(), msg.code, msg.message)
            return []
        self.gone = True
        reply = render.error(msg)
        if reply is None:
            reply = NO_SUCH_TEAM_OR_PLAYER if isinstance(self.request, ReconnectRequest) else NO_MORE_PLAYER
        return [reply]

    # -- client -> server --------------------------------------------------------------------------------
    def on_datagram(self, data: bytes) -> Out:
        """One datagram of the seated client: replies for it, messages for our server. In synchronous mode
        the commands wait for ``(done)``, which ends the client's answer to the cycle (one ``command``
        message, as our protocol answers a ``think``); in real-time mode each datagram's commands go at
        once."""
        parsed = DONE if data == DONE_DATAGRAM else parse_commands(data, self.version)
        out = Out([text for text in map(self._answer, parsed.answers) if text], [])
        if not self.synch_see and any(isinstance(answer, SynchSeeRequest) for answer in parsed.answers):
            self.synch_see = True
            out.to_server.append(m.SynchSee())
        commands = [command for command in parsed.commands if command.name != "done"]
        if commands:
            if not self.pending:
                self.pending_cycle = self.cycle
            self.pending.extend(commands)
        if (parsed.done and self.sync) or (self.pending and not self.sync):
            out.to_server.append(self._take_pending())
        if parsed.bye:
            out.to_server.append(m.Bye())
            self.gone = True
        return out

    def _answer(self, answer) -> str:
        """rcssserver's reply to one answer of a datagram: its text, or what a request asks of the state
        (src/player.cpp): the last sense_body again, the score (Keepaway keeps none: 0 0), synch_see (on
        from then on: :meth:`on_datagram` tells our server), an unknown team's ear; nothing for the
        requests rcssserver does not answer."""
        if isinstance(answer, str):
            return answer
        if isinstance(answer, SenseBodyRequest):
            return self.last_sense_body
        if isinstance(answer, ScoreRequest):
            return f"(score {self.cycle} 0 0)"
        if isinstance(answer, SynchSeeRequest):
            return OK_SYNCH_SEE
        if isinstance(answer, EarRequest) and answer.team_name:
            known = answer.team_name.strip('"') in self.view.team_names
            return "" if known else answer.unknown_team_reply
        return ""

    def _take_pending(self) -> m.Command:
        """The waiting commands as one ``command`` (at most MAX_COMMANDS: beyond, rcssserver's slot rule
        would ignore them but for says and view changes, which a client sends one a cycle)."""
        cycle = self.pending_cycle if self.pending else self.cycle
        commands, self.pending = self.pending[:m.MAX_COMMANDS], []
        return m.Command(cycle=cycle, commands=tuple(commands))

    def describe(self) -> str:
        side = self.view.side if self.view is not None else "?"
        return f"text client {self.request.team!r} ({side} {self.unum or '?'}, v{self.version:g})"
