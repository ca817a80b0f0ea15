"""The coach's logic without sockets: decoded messages and the time in, messages to send out.

:class:`CoachCore` is to ``coach/coach.py`` what ``server.arena.Arena`` is to the server's process and
``agents.player.PlayerAgent`` to a player's: every input is a message already decoded by ``protocol``
(from the server's coach port, or a trainer's request from the arena port) together with ``now``, a
monotonic time in seconds from the caller's clock; every output is a list of ``(destination, message)``
pairs, the destination being :data:`SERVER` or a trainer's identity on the arena port. Its timers are
data: :meth:`CoachCore.deadline` says when :meth:`CoachCore.tick` has something to do next.

It keeps the ground-truth episode record (from the server's ``episode_end`` events) and serves a
trainer's requests to run episodes (``protocol.arena``). With an arena endpoint the game plays freely
until the first request (paused from the start with ``idle``: a trainer's own arenas, which would
otherwise burn CPU until their first request); then it stands still, paused, between requests. A request
is served in three steps:

1. the server is paused (if it is not yet: ``pause``, then ``look`` every :data:`LOOK_INTERVAL_S` until it
   reports ``paused``, which it does only once the game has started and no command of a cycle is
   pending); the request's advice goes to the players, the episode restarts (``reset``; with the
   request's seed also the players' ``seed`` advice, so the arena plays as a fresh one with that seed),
   the server is told to pause after the request's episodes, and resumes;
2. the episodes end; the server pauses at that boundary by itself (it still delivers hears);
3. the keepers are asked for the reports wanted and the coach answers once every keeper has sent every
   chunk of each (or with ``reports_missing`` after :data:`REPORT_TIMEOUT_S`).

Frame limits agree end to end (docs/protocol.md §1): a request's advice is forwarded only if each
``hear`` it becomes fits the server's ``max_message_bytes`` (from ``coach_init_ok``'s config); else the
trainer gets ``too_large``, one line. The coach keeps its session: while a run is under way it looks at
the server at least every :data:`HEARTBEAT_S`; a ``not_initialised`` answer (the server no longer knows
this connection, e.g. ZeroMQ reconnected it) makes it send ``coach_init`` again, then a run not yet begun
starts over, a run under way is answered ``session_lost`` (its episodes may have gone to the old
connection), and a pending ``stop_arena`` is sent again.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

from keepaway.protocol import DEFAULT_MAX_MESSAGE_BYTES, PROTOCOL_VERSION, Message, ProtocolError, encode
from keepaway.protocol import messages as m
from keepaway.protocol.advice import REPORTED, KeeperReport, ReportRequest, SeedAdvice, decode_report
from keepaway.protocol.arena import EpisodesDone, RunEpisodes, StopArena
from keepaway.protocol.messages import advice_hear

log = logging.getLogger("keepaway.coach")

# How long the coach waits for the keepers' reports after a run's last episode before it answers the
# trainer with an error (a keeper that died or hangs never reports).
REPORT_TIMEOUT_S = 60.0
# How often the coach asks the server whether the game stands still while a run waits for it.
LOOK_INTERVAL_S = 0.1
# How often at least the coach looks at the server while a run is under way (module docstring).
HEARTBEAT_S = 1.0
COACH_CLIENT = "keepaway-coach"
# The acknowledgement of a trainer's stop_arena (a ``shutdown``), sent before the coach stops the server.
STOPPING = "stopping the arena: a trainer sent stop_arena"

SERVER = "server"
"""The destination of a message for the server's coach port; any other is a trainer's identity (bytes)."""

Destination = str | bytes
Outgoing = list[tuple[Destination, Message]]


def coach_init() -> m.CoachInit:
    """The coach's hello to the server (at the start, and again when the server lost the session)."""
    return m.CoachInit(version=PROTOCOL_VERSION, client=COACH_CLIENT)


@dataclass
class PendingRun:
    """A trainer's RunEpisodes being served: waiting for the game to stand still, playing, then reporting."""

    identity: bytes
    request: RunEpisodes
    episodes: list = field(default_factory=list)
    reports: list = field(default_factory=list)  # (side, unum, report)
    chunks: dict = field(default_factory=dict)  # (unum, report class) -> chunk indices received
    wanted_chunks: dict = field(default_factory=dict)  # (unum, report class) -> chunks announced
    pause_sent: bool = False
    begun: bool = False
    cycle: int = 0  # the server's cycle at the last episode end
    reporting_since: float | None = None

    def take_report(self, side: str, unum: int, report: KeeperReport) -> None:
        self.reports.append((side, unum, report))
        if side == "l":
            key = (unum, type(report))
            self.chunks.setdefault(key, set()).add(report.chunk)
            self.wanted_chunks[key] = report.chunks

    def missing_reports(self, keepers: int) -> list[str]:
        """The reports asked for that some keeper has not sent every chunk of yet."""
        missing = []
        for unum in range(1, keepers + 1):
            for what in self.request.reports:
                key = (unum, REPORTED[what])
                if len(self.chunks.get(key, ())) != self.wanted_chunks.get(key, -1):
                    missing.append(f"keeper {unum}'s {what}")
        return missing


@dataclass
class CoachCore:
    """The coach's state machine (module docstring). ``serves_arena``: a trainer's requests come in (the
    process has an arena endpoint); ``idle``: with one, the game stays paused until the first request;
    ``stop_after``: stop the server after this many episodes."""

    serves_arena: bool = False
    idle: bool = False
    stop_after: int | None = None
    episodes: list = field(default_factory=list)  # ground truth: (episode, start, end, end cause)
    stop_reason: str | None = None  # set once the coach should end (the server shut down, a signal)
    keepers: int = 0
    server_max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES  # the server's decoder limit (coach_init_ok)
    pending: PendingRun | None = None
    server_paused: bool = False  # known to stand still between cycles (step 1 of a run)
    rejoining: bool = False  # coach_init sent again after the server forgot this connection
    stop_requested: bool = False  # a trainer's stop_arena (sent again after a rejoin)
    last_look: float = float("-inf")

    # -- inputs -------------------------------------------------------------------------------------
    def joined(self, reply: m.CoachInitOk) -> Outgoing:
        """The server accepted the coach's first ``coach_init``."""
        self._take_config(reply)
        return [(SERVER, m.EpisodeControl(action="pause"))] if self.serves_arena and self.idle else []

    def from_server(self, msg: Message, now: float) -> Outgoing:
        """A message from the server's coach port."""
        if isinstance(msg, m.EpisodeEnd):
            return self._on_episode(msg, now)
        if isinstance(msg, m.PlayerReport):
            self._on_report(msg)
        elif isinstance(msg, m.LookOk) and self.pending is not None and not self.pending.begun:
            self.server_paused = self.server_paused or msg.paused
        elif isinstance(msg, m.Shutdown):
            self.stop_reason = f"server shut down: {msg.reason}"
        elif isinstance(msg, m.CoachInitOk) and self.rejoining:
            return self._rejoined(msg)
        elif isinstance(msg, m.Error) and msg.code == "not_initialised":
            return self._rejoin()
        elif isinstance(msg, m.Error):
            log.warning("server error: %s: %s", msg.code, msg.message)
        return []

    def from_trainer(self, identity: bytes, msg: Message | ProtocolError, now: float) -> Outgoing:
        """A trainer's request from the arena port, or why its frame could not be decoded."""
        if isinstance(msg, ProtocolError):
            return [(identity, m.Error(cycle=0, code=msg.code, message=msg.message))]
        if isinstance(msg, StopArena):
            self.stop_requested = True
            return [(identity, m.Shutdown(cycle=0, reason=STOPPING)), (SERVER, m.EpisodeControl(action="stop"))]
        if not isinstance(msg, RunEpisodes):
            return []
        if self.pending is not None:
            return [(identity, m.Error(cycle=0, code="busy", message="a run is already in progress"))]
        too_large = self._advice_too_large(msg)
        if too_large is not None:
            return [(identity, m.Error(cycle=0, code="too_large", message=too_large))]
        self.pending = PendingRun(identity, msg)
        return self.tick(now)

    def tick(self, now: float) -> Outgoing:
        """Time-driven steps of a pending run: pause the server and look until it stands still, then begin
        (step 1); look at least every HEARTBEAT_S while it runs; finish or time out the reporting step
        (3). Call it after every round of inputs and at :meth:`deadline`."""
        run = self.pending
        if run is None:
            return []
        out: Outgoing = []
        if run.begun and now >= self.last_look + HEARTBEAT_S:
            self.last_look = now
            out.append((SERVER, m.Look()))  # answered not_initialised if the session is lost
        if not run.begun and not self.server_paused:
            if not run.pause_sent:
                run.pause_sent = True
                out.append((SERVER, m.EpisodeControl(action="pause")))
            if now >= self.last_look + LOOK_INTERVAL_S:
                self.last_look = now
                out.append((SERVER, m.Look()))
            return out
        if not run.begun:
            out += self._begin(run)
        if run.reporting_since is None:
            return out
        missing = run.missing_reports(self.keepers)
        if not missing:
            self.pending = None
            out.append((run.identity, EpisodesDone(cycle=run.cycle, episodes=run.episodes, reports=run.reports)))
        elif now >= run.reporting_since + REPORT_TIMEOUT_S:
            self.pending = None
            out.append((run.identity, m.Error(cycle=run.cycle, code="reports_missing",
                                              message=f"after {REPORT_TIMEOUT_S:g} s still missing: "
                                                      + ", ".join(missing))))
        return out

    def deadline(self) -> float | None:
        """When :meth:`tick` next has something to do on its own (a look, the report timeout), or None
        while only messages can move the coach on."""
        run = self.pending
        if run is None:
            return None
        if not run.begun:
            return None if self.server_paused else self.last_look + LOOK_INTERVAL_S
        heartbeat = self.last_look + HEARTBEAT_S
        if run.reporting_since is None:
            return heartbeat
        return min(heartbeat, run.reporting_since + REPORT_TIMEOUT_S)

    def stop(self) -> Outgoing:
        """The coach is ending: a pending run is answered ``arena_stopped``."""
        run, self.pending = self.pending, None
        if run is None:
            return []
        return [(run.identity, m.Error(cycle=0, code="arena_stopped", message=self.stop_reason or "coach stopped"))]

    # -- steps --------------------------------------------------------------------------------------
    def _take_config(self, reply: m.CoachInitOk) -> None:
        self.keepers = int(reply.config.get("keepers", 0))
        limit = reply.config.get("max_message_bytes")
        if type(limit) is int and limit > 0:
            self.server_max_bytes = limit

    def _rejoin(self) -> Outgoing:
        """The server no longer knows this connection: say coach_init again (once until answered)."""
        if self.rejoining:
            return []
        self.rejoining = True
        log.warning("the server lost this coach's session; joining again")
        return [(SERVER, coach_init())]

    def _rejoined(self, reply: m.CoachInitOk) -> Outgoing:
        """Take up the session again (module docstring)."""
        self.rejoining = False
        self._take_config(reply)
        log.warning("joined the server again at cycle %d", reply.cycle)
        out: Outgoing = []
        run = self.pending
        if run is not None and run.begun:
            self.pending = None
            out.append((run.identity, m.Error(cycle=reply.cycle, code="session_lost",
                                              message="the coach lost its server session during the run; "
                                                      "it has joined again: send the request again")))
        elif run is not None:
            run.pause_sent = False
            self.server_paused = False
        if self.stop_requested:
            out.append((SERVER, m.EpisodeControl(action="stop")))
        return out

    def _on_episode(self, msg: m.EpisodeEnd, now: float) -> Outgoing:
        record = (msg.episode, msg.start_cycle, msg.end_cycle, msg.end)
        self.episodes.append(record)
        out: Outgoing = []
        run = self.pending
        if run is not None and len(run.episodes) < run.request.episodes:
            run.episodes.append(list(record))
            run.cycle = msg.cycle
            if len(run.episodes) == run.request.episodes:
                self.server_paused = True  # the server pauses at this boundary by itself
                out += [(SERVER, m.Advice(target="keepers", payload=ReportRequest(what=what).to_wire()))
                        for what in run.request.reports]
                run.reporting_since = now
        if self.stop_after is not None and len(self.episodes) >= self.stop_after:
            out.append((SERVER, m.EpisodeControl(action="stop")))
        return out

    def _on_report(self, msg: m.PlayerReport) -> None:
        """A keeper's report for the pending run; one that is not a valid report is logged and dropped."""
        if self.pending is None:
            return
        try:
            report = decode_report(msg.payload)
        except ProtocolError as exc:
            log.warning("dropped a report of %s %d: %s: %s", msg.side, msg.unum, exc.code, exc.message)
            return
        self.pending.take_report(msg.side, msg.unum, report)

    def _advice_too_large(self, request: RunEpisodes) -> str | None:
        """Why the request's advice cannot be forwarded (a ``hear`` above the server's limit), or None."""
        for i, (target, advice) in enumerate(request.advice):
            size = len(encode(advice_hear(advice.to_wire())))
            if size > self.server_max_bytes:
                return (f"advice {i} (to {target}) would reach the players as a {size}-byte hear; "
                        f"the server takes at most {self.server_max_bytes} bytes per message")
        return None

    def _begin(self, run: PendingRun) -> Outgoing:
        """Step 1 of a run (module docstring)."""
        request = run.request
        run.begun = True
        self.server_paused = False
        out: Outgoing = [(SERVER, m.Advice(target=target, payload=advice.to_wire()))
                         for target, advice in request.advice]
        if request.seed is not None:
            out.append((SERVER, m.Advice(target="all", payload=SeedAdvice(seed=request.seed).to_wire())))
        out += [(SERVER, m.EpisodeControl(action="reset", seed=request.seed)),
                (SERVER, m.EpisodeControl(action="pause", episodes_left=request.episodes)),
                (SERVER, m.EpisodeControl(action="resume"))]
        return out

    def summary(self) -> dict[str, Any]:
        """The ground-truth record as a plain map."""
        return {"episodes": [{"episode": e, "start_cycle": s, "end_cycle": t, "end": c}
                             for e, s, t, c in self.episodes]}


__all__ = ["HEARTBEAT_S", "LOOK_INTERVAL_S", "REPORT_TIMEOUT_S", "SERVER", "STOPPING", "CoachCore", "Outgoing",
           "PendingRun", "coach_init"]
