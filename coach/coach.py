"""The arena's online coach: a privileged client of the server's coach port (architecture, "Processes").

It keeps the ground-truth episode record (from the server's ``episode_end`` events) and may serve one
arena endpoint (ZeroMQ ROUTER) on which a trainer asks it to run episodes (``protocol.arena``). The game
plays freely until the first request (paused from the start with ``idle``: a trainer's own arenas, which
would otherwise burn CPU until their first request); then it stands still, paused, between requests. A request is
served in three steps:

1. the server is paused (if it is not yet: ``pause``, then ``look`` until it reports ``paused``, which
   it does only once the game has started and no command of a cycle is pending); the request's advice
   goes to the players, the episode restarts (``reset``; with the request's seed also the players'
   ``seed`` advice, so the arena plays as a fresh one with that seed), the server is told to pause after
   the request's episodes, and resumes;
2. the episodes end; the server pauses at that boundary by itself (it still delivers hears);
3. the keepers are asked for the reports wanted and the coach answers once every keeper has sent every
   chunk of each (or with an error after :data:`REPORT_TIMEOUT_S`).

Sockets stay in this one loop; every frame is decoded by ``protocol`` before it is acted on.
"""

from __future__ import annotations

import logging
import signal
import time
from dataclasses import dataclass, field
from typing import Any

import zmq

from protocol import PROTOCOL_VERSION, ProtocolError, bind, configure, encode
from protocol import messages as m
from protocol.arena import ARENA_MAX_MESSAGE_BYTES, EpisodesDone, RunEpisodes, StopArena, decode_from_trainer
from protocol.messages import decode_for_coach

log = logging.getLogger("keepaway.coach")


# How long the coach waits for the keepers' reports after a run's last episode before it answers
# the trainer with an error (a keeper that died or hangs never reports).
REPORT_TIMEOUT_S = 60.0
# How often the coach asks the server whether the game has started while a run waits for it.
LOOK_INTERVAL_S = 0.1


@dataclass
class PendingRun:
    """A trainer's RunEpisodes being served: waiting for the game to start, playing, then reporting."""

    identity: bytes
    request: RunEpisodes
    episodes: list = field(default_factory=list)
    reports: list = field(default_factory=list)
    chunks: dict = field(default_factory=dict)  # (unum, kind) -> chunk indices received
    wanted_chunks: dict = field(default_factory=dict)  # (unum, kind) -> chunks announced
    pause_sent: bool = False
    begun: bool = False
    cycle: int = 0  # the server's cycle at the last episode end
    reporting_since: float | None = None

    def take_report(self, side: str, unum: int, payload: object) -> None:
        self.reports.append([side, unum, payload])
        if side != "l" or type(payload) is not dict:
            return
        key = (unum, payload.get("kind"))
        chunk, chunks = payload.get("chunk"), payload.get("chunks")
        if type(chunk) is int and type(chunks) is int:
            self.chunks.setdefault(key, set()).add(chunk)
            self.wanted_chunks[key] = chunks

    def missing_reports(self, keepers: int) -> list[str]:
        """The reports asked for that some keeper has not sent every chunk of yet."""
        missing = []
        for unum in range(1, keepers + 1):
            for what in self.request.reports:
                key = (unum, f"pass_{what}")
                if len(self.chunks.get(key, ())) != self.wanted_chunks.get(key, -1):
                    missing.append(f"keeper {unum}'s {what}")
        return missing


@dataclass
class Coach:
    """Connects to ``server_endpoint`` (the coach port); optionally serves trainers on ``arena_port``."""

    server_endpoint: str
    host: str = "127.0.0.1"
    arena_port: int | None = None  # None: no arena endpoint; 0: a free port
    stop_after: int | None = None  # stop the server after this many episodes
    idle: bool = False  # with an arena endpoint: paused until the first request (module docstring)
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
        self.keepers = 0
        self.server_paused = False  # known to stand still between cycles (step 1 of a run)
        self._last_look = 0.0

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
        self.keepers = int(reply.config.get("keepers", 0))
        if self.arena_port is not None and self.idle:
            self.server.send(encode(m.EpisodeControl(action="pause")))
        if self.arena_port is not None:
            self.arena = self.ctx.socket(zmq.ROUTER)
            configure(self.arena, ARENA_MAX_MESSAGE_BYTES)
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
                self._tick()
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
                self.pending.take_report(msg.side, msg.unum, msg.payload)
            elif isinstance(msg, m.LookOk) and self.pending is not None and not self.pending.begun:
                self.server_paused = self.server_paused or msg.paused
            elif isinstance(msg, m.Shutdown):
                self.stop_reason = f"server shut down: {msg.reason}"
            elif isinstance(msg, m.Error):
                log.warning("server error: %s: %s", msg.code, msg.message)

    def _on_episode(self, msg: m.EpisodeEnd) -> None:
        record = (msg.episode, msg.start_cycle, msg.end_cycle, msg.end)
        self.episodes.append(record)
        run = self.pending
        if run is not None and len(run.episodes) < run.request.episodes:
            run.episodes.append(list(record))
            run.cycle = msg.cycle
            if len(run.episodes) == run.request.episodes:
                self.server_paused = True  # the server pauses at this boundary by itself
                for what in run.request.reports:
                    self.server.send(encode(m.Advice(target="keepers", payload={"kind": "report", "what": what})))
                run.reporting_since = time.monotonic()
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
                self.pending = PendingRun(ident, msg)
                self._tick()
            elif isinstance(msg, StopArena):
                self.server.send(encode(m.EpisodeControl(action="stop")))

    def _tick(self) -> None:
        """Time-driven steps of a pending run: pause the server and wait until it stands still (step 1);
        finish or time out the reporting step (3)."""
        run = self.pending
        if run is None:
            return
        now = time.monotonic()
        if not run.begun and not self.server_paused:
            if not run.pause_sent:
                run.pause_sent = True
                self.server.send(encode(m.EpisodeControl(action="pause")))
            if now - self._last_look >= LOOK_INTERVAL_S:
                self._last_look = now
                self.server.send(encode(m.Look()))
            return
        if not run.begun:
            self._begin(run)
        if run.reporting_since is None:
            return
        missing = run.missing_reports(self.keepers)
        if not missing:
            self.pending = None
            self._reply(run.identity, EpisodesDone(cycle=run.cycle, episodes=run.episodes, reports=run.reports))
        elif now - run.reporting_since > REPORT_TIMEOUT_S:
            self.pending = None
            self._reply(run.identity, m.Error(cycle=run.cycle, code="reports_missing",
                                              message=f"after {REPORT_TIMEOUT_S:g} s still missing: "
                                                      + ", ".join(missing)))

    def _begin(self, run: PendingRun) -> None:
        """Step 1 of a run (module docstring)."""
        request = run.request
        run.begun = True
        self.server_paused = False
        for target, payload in request.advice:
            self.server.send(encode(m.Advice(target=target, payload=payload)))
        if request.seed is not None:
            self.server.send(encode(m.Advice(target="all", payload={"kind": "seed", "seed": request.seed})))
        self.server.send(encode(m.EpisodeControl(action="reset", seed=request.seed)))
        self.server.send(encode(m.EpisodeControl(action="pause", episodes_left=request.episodes)))
        self.server.send(encode(m.EpisodeControl(action="resume")))

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
