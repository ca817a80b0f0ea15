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

Frame limits agree end to end (docs/protocol.md 1): the coach forwards a request's advice only if each
``hear`` it becomes fits the server's ``max_message_bytes`` (from ``coach_init_ok``'s config), and answers
a reply that would not fit the arena port's limit with an error; either is ``too_large``, one line.
The coach keeps its session: while a run is pending it looks at the server at least every
:data:`HEARTBEAT_S`; a ``not_initialised`` answer (the server no longer knows this connection, e.g.
ZeroMQ reconnected it) makes it send ``coach_init`` again, then a run not yet begun starts over, a run
under way is answered ``session_lost`` (its episodes may have gone to the old connection), and a pending
``stop_arena`` is sent again.
"""

from __future__ import annotations

import logging
import signal
import time
from dataclasses import dataclass, field
from typing import Any

import zmq

from core.log_limit import RepeatLimit
from protocol import DEFAULT_MAX_MESSAGE_BYTES, PROTOCOL_VERSION, ProtocolError, configure, encode
from protocol import messages as m
from protocol.arena import ARENA_MAX_MESSAGE_BYTES, EpisodesDone, RunEpisodes, StopArena, decode_from_trainer
from protocol.messages import advice_hear, decode_for_coach
from protocol.security import KeyDir, PortGuard, no_answer, secure_client

log = logging.getLogger("keepaway.coach")
# As the server's: a flood of refused handshakes or bad requests costs one line a second (core/log_limit.py).
repeat_limit = RepeatLimit()
log.addFilter(repeat_limit)


# How long the coach waits for the keepers' reports after a run's last episode before it answers
# the trainer with an error (a keeper that died or hangs never reports).
REPORT_TIMEOUT_S = 60.0
# How often the coach asks the server whether the game has started while a run waits for it.
LOOK_INTERVAL_S = 0.1
# How often at least the coach looks at the server while a run is under way (module docstring).
HEARTBEAT_S = 1.0


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
    keys: KeyDir | None = None  # CURVE on both ports (protocol/security.py)
    episodes: list = field(default_factory=list)  # ground truth: (episode, start, end, end cause)
    stop_reason: str | None = None

    def __post_init__(self) -> None:
        self.ctx = zmq.Context()
        self.server = self.ctx.socket(zmq.DEALER)
        # the server is trusted: what it relays (a player's report, a little larger than the report the
        # server took) is taken up to the arena port's limit, where it goes next
        configure(self.server, ARENA_MAX_MESSAGE_BYTES)
        secure_client(self.server, self.keys)
        self.arena: zmq.Socket | None = None
        self.guard: PortGuard | None = None
        self.pending: PendingRun | None = None
        self.bound_arena_port: int | None = None
        self.keepers = 0
        self.server_max_bytes = DEFAULT_MAX_MESSAGE_BYTES  # the server's decoder limit (coach_init_ok)
        self.server_paused = False  # known to stand still between cycles (step 1 of a run)
        self.rejoining = False  # coach_init sent again after the server forgot this connection
        self.stop_requested = False  # a trainer's stop_arena (sent again after a rejoin)
        self._last_look = 0.0

    def connect(self) -> m.CoachInitOk:
        """Say hello to the server; raises ConnectionError in one line if it does not answer."""
        self.server.connect(self.server_endpoint)
        self.server.send(self._coach_init())
        if not self.server.poll(int(self.connect_timeout_s * 1000)):
            raise ConnectionError(no_answer(self.server_endpoint, self.connect_timeout_s))
        reply = decode_for_coach(self.server.recv(), ARENA_MAX_MESSAGE_BYTES)
        if isinstance(reply, m.Error):
            raise ConnectionError(f"server refused the coach: {reply.code}: {reply.message}")
        if not isinstance(reply, m.CoachInitOk):
            raise ConnectionError(f"unexpected answer to init: {reply.TYPE}")
        self._take_config(reply)
        if self.arena_port is not None and self.idle:
            self.server.send(encode(m.EpisodeControl(action="pause")))
        if self.arena_port is not None:
            self.arena = self.ctx.socket(zmq.ROUTER)
            configure(self.arena, ARENA_MAX_MESSAGE_BYTES)
            self.guard = PortGuard(self.ctx, self.keys, log)
            self.bound_arena_port = self.guard.bind(self.arena, self.host, self.arena_port)
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
        if self.guard is not None:
            self.guard.close()
        self.ctx.term()
        repeat_limit.flush()

    # -- server port --------------------------------------------------------------------------------
    @staticmethod
    def _coach_init() -> bytes:
        return encode(m.CoachInit(version=PROTOCOL_VERSION, client="keepaway-coach"))

    def _take_config(self, reply: m.CoachInitOk) -> None:
        self.keepers = int(reply.config.get("keepers", 0))
        limit = reply.config.get("max_message_bytes")
        if type(limit) is int and limit > 0:
            self.server_max_bytes = limit

    def _rejoin(self) -> None:
        """The server no longer knows this connection: say coach_init again (once until answered)."""
        if not self.rejoining:
            self.rejoining = True
            log.warning("the server lost this coach's session; joining again")
            self.server.send(self._coach_init())

    def _rejoined(self, reply: m.CoachInitOk) -> None:
        """Take up the session again (module docstring)."""
        self.rejoining = False
        self._take_config(reply)
        log.warning("joined the server again at cycle %d", reply.cycle)
        run = self.pending
        if run is not None and run.begun:
            self.pending = None
            self._reply(run.identity, m.Error(cycle=reply.cycle, code="session_lost",
                                              message="the coach lost its server session during the run; "
                                                      "it has joined again: send the request again"))
        elif run is not None:
            run.pause_sent = False
            self.server_paused = False
        if self.stop_requested:
            self.server.send(encode(m.EpisodeControl(action="stop")))

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
            if isinstance(msg, m.EpisodeEnd):
                self._on_episode(msg)
            elif isinstance(msg, m.PlayerReport) and self.pending is not None:
                self.pending.take_report(msg.side, msg.unum, msg.payload)
            elif isinstance(msg, m.LookOk) and self.pending is not None and not self.pending.begun:
                self.server_paused = self.server_paused or msg.paused
            elif isinstance(msg, m.Shutdown):
                self.stop_reason = f"server shut down: {msg.reason}"
            elif isinstance(msg, m.CoachInitOk) and self.rejoining:
                self._rejoined(msg)
            elif isinstance(msg, m.Error) and msg.code == "not_initialised":
                self._rejoin()
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
                too_large = self._advice_too_large(msg)
                if too_large is not None:
                    self._reply(ident, m.Error(cycle=0, code="too_large", message=too_large))
                    continue
                self.pending = PendingRun(ident, msg)
                self._tick()
            elif isinstance(msg, StopArena):
                self.stop_requested = True
                self.server.send(encode(m.EpisodeControl(action="stop")))

    def _advice_too_large(self, request: RunEpisodes) -> str | None:
        """Why the request's advice cannot be forwarded (a ``hear`` above the server's limit), or None."""
        for i, (target, payload) in enumerate(request.advice):
            size = len(encode(advice_hear(payload)))
            if size > self.server_max_bytes:
                return (f"advice {i} (to {target}) would reach the players as a {size}-byte hear; "
                        f"the server takes at most {self.server_max_bytes} bytes per message")
        return None

    def _tick(self) -> None:
        """Time-driven steps of a pending run: pause the server and wait until it stands still (step 1);
        finish or time out the reporting step (3)."""
        run = self.pending
        if run is None:
            return
        now = time.monotonic()
        if run.begun and now - self._last_look >= HEARTBEAT_S:
            self._last_look = now
            self.server.send(encode(m.Look()))  # answered not_initialised if the session is lost
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

    def summary(self) -> dict:
        """The ground-truth record as a plain map."""
        return {"episodes": [{"episode": e, "start_cycle": s, "end_cycle": t, "end": c}
                             for e, s, t, c in self.episodes]}
