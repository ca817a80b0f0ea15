"""The arena's online coach: a privileged client of the server's coach port (architecture, "Processes").

It keeps the ground-truth episode record (from the server's ``episode_end`` events), forwards a
trainer's advice to the keepers, collects the players' reports, and serves one arena endpoint (ZeroMQ
ROUTER) on which a trainer asks it to run episodes. Sockets stay in this one loop; every frame is
decoded by ``protocol`` before it is acted on.
"""

from __future__ import annotations

import logging
import signal
from dataclasses import dataclass, field
from typing import Any

import zmq

from protocol import PROTOCOL_VERSION, ProtocolError, bind, configure, encode
from protocol import messages as m
from protocol.arena import EpisodesDone, RunEpisodes, StopArena, decode_from_trainer
from protocol.messages import decode_for_coach

log = logging.getLogger("keepaway.coach")


@dataclass
class PendingRun:
    """A trainer's RunEpisodes being served."""

    identity: bytes
    wanted: int
    episodes: list = field(default_factory=list)
    reports: list = field(default_factory=list)


@dataclass
class Coach:
    """Connects to ``server_endpoint`` (the coach port); optionally serves trainers on ``arena_port``."""

    server_endpoint: str
    host: str = "127.0.0.1"
    arena_port: int | None = None  # None: no arena endpoint; 0: a free port
    stop_after: int | None = None  # stop the server after this many episodes
    connect_timeout_s: float = 60.0
    episodes: list = field(default_factory=list)  # ground truth: (episode, start, end, end cause)
    stop_reason: str | None = None

    def __post_init__(self) -> None:
        self.ctx = zmq.Context()
        self.server = self.ctx.socket(zmq.DEALER)
        configure(self.server)
        self.arena: zmq.Socket | None = None
        self.pending: PendingRun | None = None
        self.bound_arena_port: int | None = None

    def connect(self) -> m.CoachInitOk:
        """Say hello to the server; raises ConnectionError in one line if it does not answer."""
        self.server.connect(self.server_endpoint)
        self.server.send(encode(m.CoachInit(version=PROTOCOL_VERSION, client="keepaway-coach")))
        if not self.server.poll(int(self.connect_timeout_s * 1000)):
            raise ConnectionError(f"no server at {self.server_endpoint} after {self.connect_timeout_s:g} s")
        reply = decode_for_coach(self.server.recv())
        if isinstance(reply, m.Error):
            raise ConnectionError(f"server refused the coach: {reply.code}: {reply.message}")
        if not isinstance(reply, m.CoachInitOk):
            raise ConnectionError(f"unexpected answer to init: {reply.TYPE}")
        if self.arena_port is not None:
            self.arena = self.ctx.socket(zmq.ROUTER)
            configure(self.arena)
            self.bound_arena_port = bind(self.arena, self.host, self.arena_port)
        return reply

    def install_signal_handlers(self) -> None:
        def handler(signum: int, _frame: Any) -> None:
            self.stop_reason = f"received {signal.Signals(signum).name}"

        signal.signal(signal.SIGINT, handler)
        signal.signal(signal.SIGTERM, handler)

    def run(self) -> None:
        """Serve until the server shuts down or a signal arrives."""
        poller = zmq.Poller()
        poller.register(self.server, zmq.POLLIN)
        if self.arena is not None:
            poller.register(self.arena, zmq.POLLIN)
        try:
            while self.stop_reason is None:
                events = dict(poller.poll(100))
                if self.server in events:
                    self._drain_server()
                if self.arena is not None and self.arena in events:
                    self._drain_arena()
        finally:
            self.close()

    def close(self) -> None:
        if self.pending is not None:
            self._reply(self.pending.identity, m.Error(cycle=0, code="arena_stopped",
                                                       message=self.stop_reason or "coach stopped"))
            self.pending = None
        for sock in (self.server, self.arena):
            if sock is not None:
                sock.close(linger=0)
        self.ctx.term()

    # -- server port --------------------------------------------------------------------------------
    def _drain_server(self) -> None:
        while True:
            try:
                data = self.server.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                msg = decode_for_coach(data)
            except ProtocolError as exc:
                log.warning("bad message from the server: %s: %s", exc.code, exc.message)
                continue
            if isinstance(msg, m.EpisodeEnd):
                self._on_episode(msg)
            elif isinstance(msg, m.PlayerReport) and self.pending is not None:
                self.pending.reports.append([msg.side, msg.unum, msg.payload])
            elif isinstance(msg, m.Shutdown):
                self.stop_reason = f"server shut down: {msg.reason}"
            elif isinstance(msg, m.Error):
                log.warning("server error: %s: %s", msg.code, msg.message)

    def _on_episode(self, msg: m.EpisodeEnd) -> None:
        record = (msg.episode, msg.start_cycle, msg.end_cycle, msg.end)
        self.episodes.append(record)
        if self.pending is not None:
            self.pending.episodes.append(list(record))
            if len(self.pending.episodes) >= self.pending.wanted:
                done = self.pending
                self.pending = None
                self._reply(done.identity, EpisodesDone(cycle=msg.cycle, episodes=done.episodes,
                                                        reports=done.reports))
        if self.stop_after is not None and len(self.episodes) >= self.stop_after:
            self.server.send(encode(m.EpisodeControl(action="stop")))

    # -- arena port ---------------------------------------------------------------------------------
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
                msg = decode_from_trainer(data)
            except ProtocolError as exc:
                self._reply(ident, m.Error(cycle=0, code=exc.code, message=exc.message))
                continue
            if isinstance(msg, RunEpisodes):
                if self.pending is not None:
                    self._reply(ident, m.Error(cycle=0, code="busy", message="a run is already in progress"))
                    continue
                if msg.advice is not None:
                    self.server.send(encode(m.Advice(target="keepers", payload=msg.advice)))
                self.pending = PendingRun(ident, msg.episodes)
            elif isinstance(msg, StopArena):
                self.server.send(encode(m.EpisodeControl(action="stop")))

    def _reply(self, ident: bytes, msg: Any) -> None:
        if self.arena is None:
            return
        try:
            self.arena.send_multipart([ident, encode(msg)], zmq.NOBLOCK)
        except zmq.ZMQError:
            log.warning("trainer %s vanished before its answer", ident.hex()[:10])

    def summary(self) -> dict:
        """The ground-truth record as a plain map."""
        return {"episodes": [{"episode": e, "start_cycle": s, "end_cycle": t, "end": c}
                             for e, s, t, c in self.episodes]}
