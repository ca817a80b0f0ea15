"""The arena's online coach process: a privileged client of the server's coach port (architecture,
"Processes"), around the sans-IO :class:`coach.core.CoachCore`.

:class:`Coach` owns the sockets: a DEALER to the server's coach port and, with an arena port, a ROUTER on
which trainers send their requests (``protocol.arena``). One poller loop decodes every frame with
``protocol`` before the core sees it, hands the core each message with the time of its clock
(``time.monotonic`` unless another is injected), sends what the core answers, and ticks the core after
every poll round; it waits no longer than the core's next deadline. What the coach does is the core's
(``coach/core.py``): pausing the server, delivering a request's advice, the reports and their timeout,
keeping the session.

Frame limits agree end to end (docs/protocol.md 1): an answer to a trainer above the arena port's limit
becomes a ``too_large`` error here, where it is encoded.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zmq

from keepaway.coach.core import SERVER, CoachCore, Outgoing, coach_init, log
from keepaway.core.log_limit import RepeatLimit
from keepaway.protocol import Message, ProtocolError, configure, encode
from keepaway.protocol import messages as m
from keepaway.protocol.arena import ARENA_MAX_MESSAGE_BYTES, decode_from_trainer
from keepaway.protocol.messages import decode_for_coach
from keepaway.protocol.security import KeyDir, PortGuard, no_answer, secure_client

# As the server's: a flood of refused handshakes or bad requests costs one line a second (core/log_limit.py).
repeat_limit = RepeatLimit()
log.addFilter(repeat_limit)
# The longest wait of the loop between two looks at the stop flag (a signal's).
POLL_S = 0.1


@dataclass
class Coach:
    """Connects to ``server_endpoint`` (the coach port); optionally serves trainers on ``arena_port``."""

    server_endpoint: str
    host: str = "127.0.0.1"
    arena_port: int | None = None  # None: no arena endpoint; 0: a free port
    stop_after: int | None = None  # stop the server after this many episodes
    idle: bool = False  # with an arena endpoint: paused until the first request (coach/core.py)
    connect_timeout_s: float = 60.0
    keys: KeyDir | None = None  # CURVE on both ports (protocol/security.py)
    clock: Callable[[], float] = time.monotonic
    core: CoachCore = field(init=False)

    def __post_init__(self) -> None:
        self.core = CoachCore(serves_arena=self.arena_port is not None, idle=self.idle, stop_after=self.stop_after)
        self.ctx = zmq.Context()
        self.server = self.ctx.socket(zmq.DEALER)
        # the server is trusted: what it relays (a player's report, a little larger than the report the
        # server took) is taken up to the arena port's limit, where it goes next
        configure(self.server, ARENA_MAX_MESSAGE_BYTES)
        secure_client(self.server, self.keys)
        self.arena: zmq.Socket | None = None
        self.guard: PortGuard | None = None
        self.bound_arena_port: int | None = None

    @property
    def episodes(self) -> list:
        """The ground-truth episode record: (episode, start, end, end cause)."""
        return self.core.episodes

    def connect(self) -> m.CoachInitOk:
        """Say hello to the server; raises ConnectionError in one line if it does not answer."""
        self.server.connect(self.server_endpoint)
        try:  # never blocks: a server that refused the handshake may already have left no peer to queue to
            self.server.send(encode(coach_init()), zmq.NOBLOCK)
        except zmq.Again:
            raise ConnectionError(no_answer(self.server_endpoint, 0)) from None
        if not self.server.poll(int(self.connect_timeout_s * 1000)):
            raise ConnectionError(no_answer(self.server_endpoint, self.connect_timeout_s))
        reply = decode_for_coach(self.server.recv(), ARENA_MAX_MESSAGE_BYTES)
        if isinstance(reply, m.Error):
            raise ConnectionError(f"server refused the coach: {reply.code}: {reply.message}")
        if not isinstance(reply, m.CoachInitOk):
            raise ConnectionError(f"unexpected answer to init: {reply.TYPE}")
        self._send(self.core.joined(reply))
        if self.arena_port is not None:
            self.arena = self.ctx.socket(zmq.ROUTER)
            configure(self.arena, ARENA_MAX_MESSAGE_BYTES)
            self.guard = PortGuard(self.ctx, self.keys, log)
            self.bound_arena_port = self.guard.bind(self.arena, self.host, self.arena_port)
        return reply

    def install_signal_handlers(self) -> None:
        def handler(signum: int, _frame: Any) -> None:
            self.core.stop_reason = f"received {signal.Signals(signum).name}"

        signal.signal(signal.SIGINT, handler)
        signal.signal(signal.SIGTERM, handler)

    def run(self) -> None:
        """Serve until the server shuts down or a signal arrives."""
        poller = zmq.Poller()
        poller.register(self.server, zmq.POLLIN)
        if self.arena is not None:
            poller.register(self.arena, zmq.POLLIN)
        try:
            while self.core.stop_reason is None:
                deadline = self.core.deadline()
                wait_s = POLL_S if deadline is None else min(POLL_S, max(0.0, deadline - self.clock()))
                events = dict(poller.poll(int(wait_s * 1000)))
                if self.server in events:
                    self._drain_server()
                if self.arena is not None and self.arena in events:
                    self._drain_arena()
                self._send(self.core.tick(self.clock()))
        finally:
            self.close()

    def close(self) -> None:
        self._send(self.core.stop())
        for sock in (self.server, self.arena):
            if sock is not None:
                sock.close(linger=0)
        if self.guard is not None:
            self.guard.close()
        self.ctx.term()
        repeat_limit.flush()

    def summary(self) -> dict:
        """The ground-truth record as a plain map."""
        return self.core.summary()

    # -- the sockets --------------------------------------------------------------------------------
    def _drain_server(self) -> None:
        while True:
            try:
                data = self.server.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                msg = decode_for_coach(data, ARENA_MAX_MESSAGE_BYTES)
            except ProtocolError as exc:
                log.warning("bad message from the server: %s: %s", exc.code, exc.message)
                continue
            self._send(self.core.from_server(msg, self.clock()))

    def _drain_arena(self) -> None:
        assert self.arena is not None
        while True:
            try:
                frames = self.arena.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            if len(frames) != 2:
                continue
            ident, data = frames
            try:
                msg: Message | ProtocolError = decode_from_trainer(data)
            except ProtocolError as exc:
                msg = exc
            self._send(self.core.from_trainer(ident, msg, self.clock()))

    def _send(self, out: Outgoing) -> None:
        for destination, msg in out:
            if destination == SERVER:
                self.server.send(encode(msg))
            else:
                self._reply(destination, msg)

    def _reply(self, ident: bytes, msg: Message) -> None:
        """Answer a trainer; an answer above the arena port's limit becomes a ``too_large`` error (the
        trainer's ZeroMQ would drop the connection, and the answer, without a word)."""
        if self.arena is None:
            return
        data = encode(msg)
        if len(data) > ARENA_MAX_MESSAGE_BYTES:
            log.warning("an answer of %d bytes is over the arena port's limit", len(data))
            data = encode(m.Error(cycle=getattr(msg, "cycle", 0), code="too_large",
                                  message=f"the answer would be {len(data)} bytes; the arena port takes at "
                                          f"most {ARENA_MAX_MESSAGE_BYTES}: ask for fewer episodes or reports"))
        try:
            self.arena.send_multipart([ident, data], zmq.NOBLOCK)
        except zmq.ZMQError:
            log.warning("trainer %s vanished before its answer", ident.hex()[:10])
