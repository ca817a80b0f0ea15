"""A scripted player/coach over real ZeroMQ for integration tests (no game intelligence)."""

from __future__ import annotations

import time
from typing import Any

import msgpack
import zmq

from keepaway.protocol import PROTOCOL_VERSION, SERVER_TO_COACH, SERVER_TO_PLAYER, decode, encode
from keepaway.protocol import messages as m

# A message no port accepts: the server answers it with an ``unknown_type`` error naming "warp".
BARRIER = msgpack.packb({"type": "warp"})


class ScriptedClient:
    """A DEALER socket that sends protocol messages and collects what the server sends back."""

    def __init__(self, endpoint: str, allowed: Any = SERVER_TO_PLAYER, ignore: tuple[type, ...] = ()) -> None:
        self.ctx = zmq.Context.instance()
        self.sock = self.ctx.socket(zmq.DEALER)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(endpoint)
        self.allowed = allowed
        self.ignore = ignore  # message types recv sets aside in ``ignored`` instead of returning
        self.received: list = []
        self.ignored: list = []

    def send(self, msg: Any) -> None:
        self.sock.send(encode(msg))

    def send_raw(self, data: bytes) -> None:
        self.sock.send(data)

    def recv(self, timeout: float = 20.0) -> Any:
        deadline = time.monotonic() + timeout
        while True:
            if not self.sock.poll(max(0, int((deadline - time.monotonic()) * 1000))):
                raise TimeoutError("no message from the server")
            msg = decode(self.sock.recv(), self.allowed)
            if not isinstance(msg, self.ignore):
                self.received.append(msg)
                return msg
            self.ignored.append(msg)

    def recv_until(self, kind: type, timeout: float = 20.0) -> Any:
        deadline = time.monotonic() + timeout
        while True:
            msg = self.recv(max(0.01, deadline - time.monotonic()))
            if isinstance(msg, kind):
                return msg

    def until_barrier(self, timeout: float = 20.0) -> list:
        """Every message the server sent this client before it read :data:`BARRIER` (sent now): the
        server reads one client's messages in order and its answers keep their order, so the barrier's
        error is the acknowledgement that all of them have arrived."""
        self.send_raw(BARRIER)
        before = []
        deadline = time.monotonic() + timeout
        while True:
            msg = self.recv(max(0.01, deadline - time.monotonic()))
            if isinstance(msg, m.Error) and msg.code == "unknown_type" and "warp" in msg.message:
                return before
            before.append(msg)

    def close(self) -> None:
        self.sock.close(linger=0)


class ScriptedPlayer(ScriptedClient):
    def init(self, team: str, unum: int | None = None, **kw: Any) -> m.InitOk | m.Error:
        self.send(m.Init(version=kw.pop("version", PROTOCOL_VERSION), team=team, unum=unum, **kw))
        while True:
            msg = self.recv()
            if isinstance(msg, m.InitOk):
                self.me = (msg.side, msg.unum)
            if isinstance(msg, (m.InitOk, m.Error)):
                return msg

    def answer(self, cycle: int, *commands: tuple) -> None:
        self.send(m.Command(cycle=cycle, commands=[m.AtomicCommand(c[0], tuple(c[1:])) for c in commands]))

    def play_cycles(self, n: int, *commands: tuple, timeout: float = 20.0) -> list:
        """Answer the next ``n`` thinks with ``commands``; return all messages received meanwhile."""
        seen = []
        for _ in range(n):
            while True:
                msg = self.recv(timeout)
                seen.append(msg)
                if isinstance(msg, m.Think):
                    self.answer(msg.cycle, *commands)
                    break
                if isinstance(msg, m.Shutdown):
                    return seen
        return seen


TEAMS = ["keepers"] * 3 + ["takers"] * 2


def connect_all(endpoint: str, **init: Any) -> list[ScriptedPlayer]:
    """Three keepers and two takers, joined in that order (keepers 1..3, takers 1..2)."""
    players = []
    for team in TEAMS:
        p = ScriptedPlayer(endpoint)
        reply = p.init(team, **init)
        assert isinstance(reply, m.InitOk), reply
        players.append(p)
    return players


class ScriptedCoach(ScriptedClient):
    def __init__(self, endpoint: str) -> None:
        super().__init__(endpoint, SERVER_TO_COACH)

    def init(self) -> Any:
        self.send(m.CoachInit(version=PROTOCOL_VERSION, client="test-coach"))
        return self.recv_until(m.CoachInitOk)


def play_together(players: list[ScriptedPlayer], cycles: int) -> list[int]:
    """Answer ``cycles`` thinks with every player in ``players``, a cycle at a time (in synchronous mode
    none waits for another's timeout); return the cycles seen."""
    seen = []
    for _ in range(cycles):
        for i, p in enumerate(players):
            msg = p.recv_until(m.Think)
            if i == 0:
                seen.append(msg.cycle)
            p.answer(msg.cycle)
    return seen


def chase_and_kick_out(me: tuple[str, int], state: m.Fullstate, out_dir_deg: float = 180.0) -> tuple:
    """A deterministic test policy from exact state: run to the ball; a keeper kicks it towards
    ``out_dir_deg`` (out of the region), a taker stands on it (so it is taken)."""
    import math

    bx, by = state.ball[0], state.ball[1]
    row = next(p for p in state.players if (p[0], p[1]) == me)
    x, y, body = row[2], row[3], row[6]
    dx, dy = bx - x, by - y
    if math.hypot(dx, dy) < 1.0:
        if me[0] == "l":
            return ("kick", 100.0, out_dir_deg - body)
        return ("turn", 0.0)
    angle = math.degrees(math.atan2(dy, dx)) - body
    angle = (angle + 180.0) % 360.0 - 180.0
    if abs(angle) > 10.0:
        return ("turn", angle)
    return ("dash", 100.0)


def play_chasers(players: list["ScriptedPlayer"], timeout: float = 60.0) -> int:
    """Every player answers each think with :func:`chase_and_kick_out` until the server shuts down;
    returns the number of cycles played."""
    cycles = 0
    state: dict[int, m.Fullstate] = {}
    while True:
        for i, p in enumerate(players):
            while True:
                msg = p.recv(timeout)
                if isinstance(msg, m.Fullstate):
                    state[i] = msg
                elif isinstance(msg, m.Think):
                    p.answer(msg.cycle, chase_and_kick_out(p.me, state[i]))
                    break
                elif isinstance(msg, m.Shutdown):
                    return cycles
        cycles += 1
