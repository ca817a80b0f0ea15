"""The ``keepaway server`` process: ZeroMQ sockets, timing (synchronous / real-time) and logging.

Socket handling lives here and only here (zguide style): one poller loop, explicit linger, every frame
decoded and validated by ``protocol`` before the game (``server/arena.py``) sees it. A bad message gets
a one-line ``error`` reply and a (rate-limited, counted) log line; it never stops the loop. Input is read
fairly and in bounded amounts (``server/intake.py``): no client, however fast it sends, holds the loop
away from the game.

Rejoin (docs/protocol.md §12, "Rejoin"): a player whose connection is gone (unreachable, or given up after
``max_missed_cycles``) loses its seat to a ``reconnect`` for its number; the body stays on the pitch as
it was. The cycles of an episode stepped without a player's command are counted per player and logged
with the episode (``EpisodeRecord.missed``), so short-handed episodes are marked.

Pausing (docs/protocol.md §12, "Coach"): the clock stands still between cycles, before any percept of the
next cycle, so a pause that falls due at an episode's end (``pause`` with ``episodes_left``) holds the
arena exactly at the boundary: no player sees or acts in the new episode before ``resume``. While paused
the queued ``hear`` messages (the referee's episode message, the coach's advice) go out at once, bare, so
the players take the boundary and the advice while the clock stands still.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import signal
import struct
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import zmq

from keepaway.core.log_limit import KIND_ATTR, RepeatLimit
from keepaway.protocol import PROTOCOL_VERSION
from keepaway.protocol import messages as m
from keepaway.protocol.codec import encode
from keepaway.protocol.endpoints import MONITOR_EPISODE_TOPIC, MONITOR_FRAME_TOPIC, configure
from keepaway.protocol.errors import ProtocolError
from keepaway.protocol.messages import advice_hear, decode_from_coach, decode_from_player
from keepaway.protocol.security import PortGuard, open_keys
from keepaway.rcss.front import Front, FrontConfig
from keepaway.server.arena import TEAMS, Arena, ArenaError, PlayerSlot, player_name, truth_state
from keepaway.server.config import ServerConfig
from keepaway.server.episode_log import EpisodeRecord, JsonlLog, KwyLog
from keepaway.server.game_log import RCG_SUFFIX, ArenaGameLog, compile_kernels
from keepaway.server.intake import ROUND_MESSAGES, WINDOW_S, Intake

log = logging.getLogger("keepaway.server")
# A hung player's "missed cycle" would otherwise be logged every cycle timeout (core/log_limit.py).
repeat_limit = RepeatLimit()
log.addFilter(repeat_limit)

# Frames up to max_message_bytes are decoded; larger ones up to this factor are answered with a
# ``too_large`` error; beyond it ZeroMQ (MAXMSGSIZE) disconnects the sender before reading the frame.
HARD_LIMIT_FACTOR = 4
# While paused, sockets are polled this often (ms): a hear queued meanwhile goes out within it.
PAUSE_POLL_MS = 50
# Send flags as plain ints: pyzmq's send_multipart combines enum flags in Python for every frame, a
# cost paid ~30 times a cycle.
_NOBLOCK = int(zmq.NOBLOCK)
_NOBLOCK_MORE = int(zmq.NOBLOCK | zmq.SNDMORE)
_EVENTS, _POLLIN = int(zmq.EVENTS), int(zmq.POLLIN)
# pyzmq's compiled send, without the Python method its Socket puts over it (for routing_id and group,
# which the server does not use): the server sends about 60 frames a cycle (docs/design.md, "Processes
# and sockets").
_send_frame = zmq.backend.Socket.send
# The identities of the players seated from within the server's process (the rcssserver-protocol front's
# text clients, :class:`LocalLink`). A ZeroMQ peer may set any routing id, so a frame that comes over the
# players port under one of these is dropped (``_read_round``): no peer can speak for a text client.
LOCAL_PREFIX = b"\x00text"


def _recv_message(sock: zmq.Socket) -> list[bytes]:
    """``sock.recv_multipart(NOBLOCK)``, with the frames' "more" flags read from the frames themselves
    rather than by a ``getsockopt`` each (a whole message is delivered at once, so its other frames are
    there). Raises ``zmq.Again`` if no message waits."""
    part = sock.recv(_NOBLOCK, copy=False)
    frames = [part.bytes]
    while part.more:
        part = sock.recv(_NOBLOCK, copy=False)
        frames.append(part.bytes)
    return frames


@dataclass
class Connection:
    """A player client known by its ZeroMQ identity."""

    identity: bytes
    slot: PlayerSlot
    answered: int = -1  # last cycle this client answered (sync mode)
    missed: int = 0  # consecutive missed cycles
    hung: bool = False  # given up (missed max_missed_cycles, or unreachable): no longer waited for

    @property
    def name(self) -> str:
        return player_name(self.slot)


@dataclass
class BoundPorts:
    players: int
    coach: int
    monitor: int
    rcss: int | None = None  # the rcssserver-protocol front's UDP port (``rcss_port``)


class LocalLink:
    """A text client's link to the server in its own process (``rcss.front.ServerLink``): its frames go
    to the server's inbox, served by the loop as a ZeroMQ player's are (the same decoding, checks and
    budgets); the server's frames for it are handed to the front's ``deliver`` without a socket."""

    def __init__(self, server: Server, ident: bytes) -> None:
        self.server = server
        self.ident = ident

    def send(self, data: bytes) -> None:
        self.server.local_inbox.append((self.ident, data))

    def close(self) -> None:
        """The client is gone: the server finds its seat unreachable at the next send, as a vanished
        ZeroMQ player's."""
        self.server.local.pop(self.ident, None)


@dataclass
class Server:
    """One arena served over ZeroMQ. Create, :meth:`bind`, then :meth:`run` until it stops."""

    config: ServerConfig
    on_ready: Callable[[BoundPorts], None] | None = None
    arena: Arena = field(init=False)
    conns: dict[bytes, Connection] = field(init=False, default_factory=dict)
    coaches: dict[bytes, str] = field(init=False, default_factory=dict)  # identity -> the coach's client name
    episodes_done: int = field(init=False, default=0)
    stop_reason: str | None = field(init=False, default=None)
    exit_code: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        cfg = self.config
        self.arena = Arena(cfg.params, cfg.keepers, cfg.takers, cfg.seed)
        self.ctx = zmq.Context()
        self.players = self.ctx.socket(zmq.ROUTER)
        self.coach = self.ctx.socket(zmq.ROUTER)
        self.monitor = self.ctx.socket(zmq.XPUB)
        self.poller = zmq.Poller()
        for sock in (self.players, self.coach, self.monitor):
            configure(sock, cfg.max_message_bytes * HARD_LIMIT_FACTOR)
            self.poller.register(sock, zmq.POLLIN)
        self.front: Front | None = None  # the rcssserver-protocol front (rcss_port), made by bind()
        self.local: dict[bytes, Callable[[bytes], None]] = {}  # a text client's identity -> its deliver
        self.local_inbox: list[tuple[bytes, bytes]] = []  # the text clients' frames, for the next round
        self.local_made = 0  # text clients' links made so far: the next identity's number
        self.guard: PortGuard | None = None  # made by bind(): CURVE and ZAP with keys (protocol/security.py)
        self.monitor_topics: Counter[bytes] = Counter()  # the monitor's subscribed topic prefixes
        self.kwy: KwyLog | None = None
        self.jsonl: JsonlLog | None = None
        self.rcg: ArenaGameLog | None = None
        self.episodes_left: int | None = cfg.episodes
        self.paused = False
        self.standing_still = False  # paused between two cycles, no command pending (look_ok.paused)
        self.pause_after: int | None = None  # pause once this many more episodes have ended
        self.next_see: dict[bytes, float] = {}  # real-time mode: each player's next see (monotonic s)
        self.next_waiting = 0.0  # when the next ``waiting`` is due while no cycle is played (monotonic s)
        self.next_pre_kick_off = 0.0  # when the next pre-kick-off sense_body is due (monotonic s)
        self.intakes = {self.players: Intake(cfg.player_budget, cfg.unseated_budget),
                        self.coach: Intake(cfg.coach_budget, cfg.unseated_budget)}
        self.window_opened = time.monotonic()  # of the wall-time budget window (server/intake.py)
        self.percepts_cycle = -1  # the last cycle whose percepts went out
        self.absent: dict[int, int] = {}  # object -> cycles of this episode stepped without its command
        self.show_due = False  # the game log's show of the last step is still to be written (_write_show)
        self.look_answer: tuple[tuple[int, bool], bytes] | None = None  # the last look's answer (_look_ok)
        self._t0 = time.monotonic()

    # -- lifecycle -----------------------------------------------------------------------------------
    def bind(self) -> BoundPorts:
        """Compile the kernels, bind the sockets, open the logs; then announce the ports (``on_ready``)."""
        cfg = self.config
        compile_kernels(cfg.params, cfg.keepers, cfg.takers)
        self.guard = guard = PortGuard(self.ctx, open_keys(cfg.keys), log)
        ports = BoundPorts(
            players=guard.bind(self.players, cfg.host, cfg.players_port),
            coach=guard.bind(self.coach, cfg.host, cfg.coach_port),
            monitor=guard.bind(self.monitor, cfg.host, cfg.monitor_port),
        )
        if cfg.rcss_port is not None:
            self.front = Front(FrontConfig(host=cfg.host, port=cfg.rcss_port), self.poller, self._local_link)
            ports.rcss = self.front.bind()
        self.ports = ports
        if cfg.log_dir is not None:
            Path(cfg.log_dir).mkdir(parents=True, exist_ok=True)
            p = cfg.params
            self.kwy = KwyLog(Path(cfg.log_dir), cfg.keepers, cfg.takers, p.keepaway_length,
                              p.keepaway_width, fixed_name=cfg.kwy_name)
            self.jsonl = JsonlLog(Path(cfg.log_dir) / f"{cfg.kwy_name or 'keepaway'}.jsonl", seed=cfg.seed,
                                  config=cfg.summary(), params=p.to_dict())
            if cfg.game_log:
                self.rcg = ArenaGameLog(Path(cfg.log_dir) / f"{cfg.kwy_name or 'keepaway'}{RCG_SUFFIX}", self.arena)
        log.info("listening: players tcp://%s:%d coach tcp://%s:%d monitor tcp://%s:%d%s (%s mode, seed %d, %s)",
                 cfg.host, ports.players, cfg.host, ports.coach, cfg.host, ports.monitor,
                 "" if ports.rcss is None else f" rcss udp://{cfg.host}:{ports.rcss}", cfg.mode, cfg.seed,
                 "plain TCP" if cfg.keys is None else f"CURVE, keys {cfg.keys}")
        if self.on_ready is not None:
            self.on_ready(ports)
        return ports

    def request_stop(self, reason: str, exit_code: int = 0) -> None:
        if self.stop_reason is None:
            self.stop_reason = reason
            self.exit_code = exit_code

    def install_signal_handlers(self) -> None:
        def handler(signum: int, _frame: Any) -> None:
            self.request_stop(f"received {signal.Signals(signum).name}")

        signal.signal(signal.SIGINT, handler)
        signal.signal(signal.SIGTERM, handler)

    def run(self) -> int:
        """Serve until stopped (episodes/cycles done, coach stop, signal, hung players with on_hang=stop)."""
        try:
            poller = self.poller
            while self.stop_reason is None and not self._ready_to_start():
                self._send_waiting_if_due(self.config.start_on)
                self._send_pre_kick_off_if_due()
                self._poll(poller, 50)
            if self.stop_reason is None:
                self._start_game()
                (self._run_sync if self.config.mode == "sync" else self._run_realtime)(poller)
        finally:
            self.close()
        return self.exit_code

    def close(self) -> None:
        reason = self.stop_reason or "server stopped"
        self._write_show()
        self._close_budget_windows(seated=True)
        self._close_budget_windows(seated=False)
        shutdown = encode(m.Shutdown(cycle=self.arena.cycle, reason=reason))
        for ident in list(self.conns):
            self._send_raw(self.players, ident, shutdown)
        self._to_coaches(shutdown)
        for logger in (self.kwy, self.jsonl, self.rcg):
            if logger is not None:
                logger.close()
        if self.front is not None:
            self.front.close()
        for sock in (self.players, self.coach, self.monitor):
            sock.close(linger=0)
        if self.guard is not None:
            self.guard.close()
        self.ctx.term()
        log.info("stopped at cycle %d after %d episodes: %s", self.arena.cycle, self.episodes_done, reason)
        repeat_limit.flush()

    # -- timing loops --------------------------------------------------------------------------------
    def _run_sync(self, poller: zmq.Poller) -> None:
        """Synchronous mode: percepts of cycle t + think, then wait until every connected, non-hung
        player has answered t (or cycle_timeout_s passes), then step. Sockets are read only while
        waiting, so a command that arrives after the step acts one cycle later (docs/rules.md §8)."""
        cfg = self.config
        while self.stop_reason is None:
            self._hold_while_paused(poller)
            if self.stop_reason is not None:
                break
            cycle = self.arena.cycle
            self._send_cycle_percepts(think=True)
            self._write_show()
            deadline = time.monotonic() + cfg.cycle_timeout_s
            while self.stop_reason is None and not self._all_answered(cycle):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    self._missed_cycle(cycle)
                    break
                self._poll(poller, max(1, int(remaining * 1000)))
            if self.stop_reason is None:
                self._step()

    def _run_realtime(self, poller: zmq.Poller) -> None:
        """Real-time mode: a step every simulator_step_ms of wall time; sense_body right after it; each
        player's see on its own period from its connect time (asynchronous with the cycle, docs/rules.md §5.1);
        ``think``, the end-of-cycle marker, once no see of the player falls before the next step. A pause
        stops the step and see timers; they go on from where they stood on resume."""
        step_s = self.config.params.simulator_step_ms / 1000.0
        next_step = time.monotonic() + step_s
        sent_cycle = -1  # the last cycle whose sense_bodies went out
        to_think: set[bytes] = set()
        while self.stop_reason is None:
            if self.paused:
                held = self._hold_while_paused(poller)
                next_step += held
                for ident in self.next_see:
                    self.next_see[ident] += held
                continue
            if sent_cycle < self.arena.cycle:
                sent_cycle = self.arena.cycle
                self._send_cycle_percepts(think=False, see=False)
                self._write_show()
                to_think = set(self.conns)  # who got this cycle's sense_body and has no think yet
            now = time.monotonic()
            for ident, conn in list(self.conns.items()):
                due = self.next_see.setdefault(ident, now)  # a new player's (or a reset's) first see: now
                if now >= due:
                    self._send_raw(self.players, conn.identity, self.arena.see_frame(conn.slot))
                    self.next_see[ident] = due + conn.slot.see_period_ms(self.config.params.send_step_ms) / 1000.0
            # the end-of-cycle marker: once no see of this player falls before the next step
            self._send_thinks(to_think, next_step)
            wake = min([next_step] + list(self.next_see.values()))
            self._poll(poller, max(0, int((wake - time.monotonic()) * 1000)))
            if not self.paused and time.monotonic() >= next_step:
                self._send_thinks(to_think, -math.inf)  # a see the loop was late for goes with t+1
                self._step()
                next_step += step_s
                if next_step < time.monotonic():  # a slow cycle is not caught up (rcssserver)
                    next_step = time.monotonic() + step_s

    def _send_thinks(self, to_think: set[bytes], next_step: float) -> None:
        """Real-time mode: ``think`` for the current cycle to each player in ``to_think`` whose next see
        falls at or after ``next_step`` (so its percepts of the cycle are all out), in object order; they
        leave the set. ``-inf`` sends every one still waiting."""
        to_think.intersection_update(self.conns)
        ready = [self.conns[ident] for ident in to_think if self.next_see.get(ident, 0.0) >= next_step]
        if not ready:
            return
        think = encode(m.Think(cycle=self.arena.cycle))
        for conn in sorted(ready, key=lambda c: c.slot.obj):
            self._send_raw(self.players, conn.identity, think)
            to_think.discard(conn.identity)

    def _hold_while_paused(self, poller: zmq.Poller) -> float:
        """Stand still while paused (both modes): serve the sockets and send each player its queued
        hears at once, bare (no sense_body, no think), until resume or stop; returns the seconds held.
        Hears queued just before the resume still go out bare, so none waits for the next percepts."""
        if not self.paused:
            return 0.0
        self._write_show()  # before the coach may reset the field
        start = time.monotonic()
        self.standing_still = True
        try:
            while True:
                self._send_queued_hears()
                if not self.paused or self.stop_reason is not None:
                    return time.monotonic() - start
                self._send_waiting_if_due("paused")
                self._poll(poller, PAUSE_POLL_MS)
        finally:
            self.standing_still = False

    def _send_waiting_if_due(self, reason: str) -> None:
        """While no cycle is played: a ``waiting`` to every player each WAITING_INTERVAL_S (the first at
        once), so that a client can tell a slow start or a pause from a dead server."""
        now = time.monotonic()
        if now < self.next_waiting:
            return
        self.next_waiting = now + m.WAITING_INTERVAL_S
        data = encode(m.Waiting(cycle=self.arena.cycle, reason=reason,
                                connected=len(self.arena.connected_slots()), expected=len(self.arena.slots)))
        for conn in sorted(self.conns.values(), key=lambda c: c.slot.obj):
            self._send_raw(self.players, conn.identity, data)

    def _send_pre_kick_off_if_due(self) -> None:
        """Before the kick-off, to the players that asked for it in ``init`` (``pre_kick_off``): a
        ``sense_body`` every simulator_step_ms of wall time, and a ``think`` in synchronous mode, as
        rcssserver's timers send them while the clock stands at 0 (src/synctimer.cpp, src/stadium.cpp
        ``doSendThink``). The game has not begun, so the commands that answer them are dropped
        (:meth:`_on_player`)."""
        now = time.monotonic()
        if now < self.next_pre_kick_off:
            return
        self.next_pre_kick_off = now + self.config.params.simulator_step_ms / 1000.0
        think = encode(m.Think(cycle=self.arena.cycle)) if self.config.mode == "sync" else None
        for conn in sorted(self.conns.values(), key=lambda c: c.slot.obj):
            if conn.slot.pre_kick_off:
                self._send_raw(self.players, conn.identity, self.arena.sense_body_frame(conn.slot))
                if think is not None:
                    self._send_raw(self.players, conn.identity, think)

    def _ready_to_start(self) -> bool:
        if self.config.start_on == "players":
            return self.arena.all_connected()
        return self.arena.started

    def _start_game(self) -> None:
        self.look_answer = None
        self.arena.start()
        if self.rcg is not None:
            self.rcg.start_game()
        log.info("game started with %d players", len(self.conns))

    def _all_answered(self, cycle: int) -> bool:
        """Every player has answered ``cycle``, or is not waited for: given up, or its budget of the
        cycle spent (server/intake.py)."""
        intake = self.intakes[self.players]
        return all(c.answered >= cycle or c.hung or intake.spent(c.identity) for c in self.conns.values())

    def _missed_cycle(self, cycle: int) -> None:
        cfg = self.config
        for conn in self.conns.values():
            if conn.answered >= cycle or conn.hung:
                continue
            conn.missed += 1
            log.warning("%s missed cycle %d (%d in a row)", conn.name, cycle, conn.missed)
            if conn.missed >= cfg.max_missed_cycles:
                self._give_up_on(conn, f"{conn.name} missed {conn.missed} cycles in a row")
                self._send(conn, m.Error(cycle=cycle, code="missed_cycles",
                                         message=f"you missed {conn.missed} cycles in a row"))

    def _give_up_on(self, conn: Connection, why: str) -> None:
        """Stop waiting for a hung or vanished player; with on_hang=stop, stop the server (exit 3)."""
        conn.hung = True
        stop = self.config.on_hang == "stop"
        message = f"{why}; " + ("stopping" if stop else "no longer waiting for it")
        log.error(message)
        if stop:
            self.request_stop(message, exit_code=3)

    # -- the cycle -----------------------------------------------------------------------------------
    def _step(self) -> None:
        self._count_absent()
        record = self.arena.step()
        self._close_budget_windows(seated=True)
        self.show_due = self.rcg is not None
        if self._subscribed(MONITOR_FRAME_TOPIC):
            self._publish(MONITOR_FRAME_TOPIC, m.Frame(cycle=self.arena.cycle, **truth_state(self.arena),
                                                       getopen=self.arena.step_notes))
        if record is not None:
            self._episode_ended(record)
        cfg = self.config
        if cfg.max_cycles is not None and self.arena.cycle >= cfg.max_cycles:
            self.request_stop(f"reached {cfg.max_cycles} cycles")

    def _write_show(self) -> None:
        """The game log's show of the last step, if not yet written. The loops call this once the next
        cycle's percepts are out, while the players think, rather than between the step and those
        percepts, where the server works alone (docs/design.md, "Processes and sockets"): sending percepts
        changes nothing a show holds, and nothing else happens in between but a pause, which writes it
        first. It is the same show, and the last one is written when the server closes."""
        if self.show_due:
            self.show_due = False
            self.rcg.step()

    def _count_absent(self) -> None:
        """Before a step: count, per player, the step played without its command for this cycle (an
        empty seat, a given-up connection, or in synchronous mode no answer in time)."""
        cycle = self.arena.cycle
        sync = self.config.mode == "sync"
        present = {c.slot.obj for c in self.conns.values()
                   if not c.hung and (not sync or c.answered >= cycle)}
        for s in self.arena.slots:
            if s.obj not in present:
                self.absent[s.obj] = self.absent.get(s.obj, 0) + 1

    def _episode_ended(self, record: EpisodeRecord) -> None:
        self.episodes_done += 1
        if self.absent:
            record = dataclasses.replace(record, missed=tuple(
                (player_name(self.arena.slot(obj)), n) for obj, n in sorted(self.absent.items())))
            self.absent = {}
        for logger in (self.kwy, self.jsonl):
            if logger is not None:
                logger.write(record)
        end = m.EpisodeEnd(cycle=self.arena.cycle, episode=record.episode, start_cycle=record.start_cycle,
                           end_cycle=record.end_cycle, end=record.end, missed=record.missed)
        self._to_coaches(encode(end))
        if self._subscribed(MONITOR_EPISODE_TOPIC):
            self._publish(MONITOR_EPISODE_TOPIC, end)
        if self.episodes_left is not None:
            self.episodes_left -= 1
            if self.episodes_left <= 0:
                self.request_stop(f"{self.episodes_done} episodes done")
        if self.pause_after is not None:
            self.pause_after -= 1
            self._pause_if_due()

    def _send_queued_hears(self) -> None:
        for conn in sorted(self.conns.values(), key=lambda c: c.slot.obj):
            for frame in self.arena.take_hears(conn.slot):
                self._send_raw(self.players, conn.identity, frame)

    def _send_cycle_percepts(self, think: bool, see: bool = True) -> None:
        """Each player's percepts of this cycle (and ``think``), encoded first and then sent together,
        so that they leave in one burst and the player wakes once for them rather than once each."""
        arena = self.arena
        cycle = arena.cycle
        self.percepts_cycle = cycle
        think_frame = encode(m.Think(cycle=cycle)) if think else None
        # object order, not connection order: the see draws identity-loss randomness from the arena's
        # one stream, so the order must not depend on which process connected first (determinism)
        for conn in sorted(self.conns.values(), key=lambda c: c.slot.obj):
            with_see = see and arena.see_due(conn.slot, cycle)
            frames = arena.cycle_frames(conn.slot, with_see)
            if think_frame is not None:
                frames.append(think_frame)
            for data in frames:
                self._send_raw(self.players, conn.identity, data)

    # -- sockets -------------------------------------------------------------------------------------
    def _poll(self, poller: zmq.Poller, timeout_ms: int) -> None:
        """One poll round (``server/intake.py``): the seated peers' waiting messages that fit this
        window, then at most ROUND_MESSAGES frames per socket, each peer within its budget; the seated
        peers' messages are served first, then the others'."""
        seated = [(sock, frames) for sock, intake in self.intakes.items() for frames in intake.due()]
        unseated: list[tuple[zmq.Socket, list[bytes]]] = []
        wait_ms = 0 if seated else min(timeout_ms, int(WINDOW_S * 1000))  # windows end on time
        if self.front is not None:
            self.front.flush()  # the text clients' datagrams written since the last round
        events = dict(poller.poll(wait_ms))
        if self.monitor in events:
            self._drain_monitor()
        for sock, members in ((self.players, self.conns), (self.coach, self.coaches)):
            if sock in events:
                self._read_round(sock, members, seated, unseated)
        if self.front is not None:
            for key in events:
                self.front.on_event(key)  # the text clients' sockets: their frames go to local_inbox
            self._read_local(seated, unseated)
        for sock, frames in seated + unseated:
            self._serve(sock, frames)
        if time.monotonic() - self.window_opened >= WINDOW_S:
            self.window_opened = time.monotonic()
            self._close_budget_windows(seated=True)
            self._close_budget_windows(seated=False)

    def _read_round(self, sock: zmq.Socket, members: Any, seated: list, unseated: list) -> None:
        """Read up to ROUND_MESSAGES frames of ``sock``; those within their peer's budget go to
        ``seated`` or ``unseated`` (``members``: the peers that have joined), the rest wait or are
        dropped."""
        intake = self.intakes[sock]
        for _ in range(ROUND_MESSAGES):
            try:
                frames = _recv_message(sock)
            except zmq.Again:
                return
            if frames[0].startswith(LOCAL_PREFIX):
                log.warning("client %s: a routing id of the server's own text clients; dropped", frames[0].hex(),
                            extra={KIND_ATTR: ("local-id",)})
                continue
            member = frames[0] in members
            if intake.admit(frames[0], member, frames):
                (seated if member else unseated).append((sock, frames))
            if not sock.get(_EVENTS) & _POLLIN:  # nothing more: cheaper to ask than to fail a receive
                return

    def _read_local(self, seated: list, unseated: list) -> None:
        """The text clients' frames (:class:`LocalLink`), within their budgets as :meth:`_read_round`'s."""
        inbox, self.local_inbox = self.local_inbox, []
        intake = self.intakes[self.players]
        for ident, data in inbox:
            member = ident in self.conns
            frames = [ident, data]
            if intake.admit(ident, member, frames):
                (seated if member else unseated).append((self.players, frames))

    def _local_link(self, front: Front, deliver: Callable[[bytes], None]) -> LocalLink:
        """A link for a text client of the front in this process (``rcss.front.LinkMaker``)."""
        self.local_made += 1
        ident = LOCAL_PREFIX + struct.pack(">I", self.local_made)
        self.local[ident] = deliver
        return LocalLink(self, ident)

    def _serve(self, sock: zmq.Socket, frames: list[bytes]) -> None:
        if len(frames) != 2:
            self._error_raw(sock, frames[0], "malformed", "send exactly one msgpack frame per message")
            return
        (self._on_player if sock is self.players else self._on_coach)(frames[0], frames[1])

    def _close_budget_windows(self, seated: bool) -> None:
        """End the seated (or unseated) peers' budget window: each peer that went over its budget gets
        one counted ``over_budget`` error and the log one (rate-limited) line."""
        window = "cycle" if seated else f"{WINDOW_S:g} s"
        for sock, intake in self.intakes.items():
            budget = intake.budget(seated)
            for ident, count in intake.close_window(seated).items():
                who = self._peer_name(sock, ident)
                log.warning("%s: over_budget: dropped %d messages beyond its budget of %d per %s",
                            who, count, budget, window)
                self._send_raw(sock, ident, encode(m.Error(
                    cycle=self.arena.cycle, code="over_budget",
                    message=f"dropped {count} messages beyond your budget of {budget} per {window}")))

    def _peer_name(self, sock: zmq.Socket, ident: bytes) -> str:
        """How the log names a peer: a player's seat, a coach's client name, else its identity."""
        conn = self.conns.get(ident) if sock is self.players else None
        if conn is not None:
            return conn.name
        coach = self.coaches.get(ident) if sock is self.coach else None
        return f"coach {coach!r}" if coach is not None else f"client {ident.hex()[:10]}"

    def _drain_monitor(self) -> None:
        """Count the monitor's (un)subscriptions per topic prefix: at most ROUND_MESSAGES a round, like
        the other ports."""
        for _ in range(ROUND_MESSAGES):
            try:
                event = self.monitor.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            topic = event[1:]
            if event[:1] == b"\x01":
                self.monitor_topics[topic] += 1
            elif event[:1] == b"\x00" and self.monitor_topics[topic] > 0:
                self.monitor_topics[topic] -= 1
                if not self.monitor_topics[topic]:
                    del self.monitor_topics[topic]

    def _subscribed(self, topic: bytes) -> bool:
        """Whether a monitor subscriber takes ``topic`` (ZeroMQ matches subscriptions as prefixes): a
        frame is built and encoded every cycle only while someone watches frames, not for a subscriber
        that follows episodes only (``keepaway run``)."""
        return any(topic.startswith(prefix) for prefix in self.monitor_topics)

    def _send(self, conn: Connection, msg: Any) -> None:
        self._send_raw(self.players, conn.identity, encode(msg))

    def _send_raw(self, sock: zmq.Socket, ident: bytes, data: bytes) -> None:
        if sock is self.players:
            deliver = self.local.get(ident)
            if deliver is not None:
                deliver(data)
                return
        try:
            _send_frame(sock, ident, _NOBLOCK_MORE)
            _send_frame(sock, data, _NOBLOCK)
        except zmq.ZMQError as exc:  # peer gone (ROUTER_MANDATORY) or its queue is full
            if exc.errno != zmq.EHOSTUNREACH:
                return
            if sock is self.coach:
                self._coach_gone(ident)
                return
            conn = self.conns.get(ident)
            if conn is not None and not conn.hung:
                self._give_up_on(conn, f"{conn.name} is unreachable (disconnected?)")

    def _to_coaches(self, data: bytes) -> None:
        """Send ``data`` to every coach. A send can find a coach gone and drop it from the map, so the
        loop runs over a copy."""
        for ident in list(self.coaches):
            self._send_raw(self.coach, ident, data)

    def _coach_gone(self, ident: bytes) -> None:
        """A coach's connection is gone without ``coach_bye`` (killed, closed, or re-made by ZeroMQ under
        a new identity): forget it in one line; the game goes on without it."""
        name = self.coaches.pop(ident, None)
        if name is not None:
            log.warning("coach %r (%s) is gone without coach_bye; the game goes on without it", name,
                        ident.hex()[:10], extra={KIND_ATTR: ("coach", "gone")})

    def _error_raw(self, sock: zmq.Socket, ident: bytes, code: str, message: str) -> None:
        """Answer a refused message; the log line's kind is the client and the code, whatever the
        message says (core/log_limit.py), so a flood of varied bad input costs one line a second."""
        who = ident.hex()[:10]
        log.warning("client %s: %s: %s", who, code, message, extra={KIND_ATTR: (who, code)})
        self._send_raw(sock, ident, encode(m.Error(cycle=self.arena.cycle, code=code, message=message)))

    def _publish(self, topic: bytes, msg: Any) -> None:
        try:
            self.monitor.send_multipart([topic, encode(msg)], zmq.NOBLOCK)
        except zmq.Again:  # publishing never blocks the simulation
            pass

    # -- players port --------------------------------------------------------------------------------
    def _on_player(self, ident: bytes, data: bytes) -> None:
        self.look_answer = None  # a player that joins or leaves changes the true state
        conn = self.conns.get(ident)
        if conn is not None and len(data) <= self.config.max_message_bytes and self.arena.started:
            # a command frame read and taken by the kernel (``Arena.submit_frame``); any other in full
            taken = self.arena.submit_frame(conn.slot.obj, data)
            if taken is not None:
                self._answered(conn, *taken)
                return
        try:
            msg = decode_from_player(data, self.config.max_message_bytes)
        except ProtocolError as exc:
            self._error_raw(self.players, ident, exc.code, exc.message)
            return
        if isinstance(msg, (m.Init, m.Reconnect)):
            self._on_init(ident, conn, msg)
        elif conn is None:
            self._error_raw(self.players, ident, "not_initialised", "send init (or reconnect) first")
        elif isinstance(msg, m.Command):
            if self.arena.started:  # before the kick-off: an answer to a pre-kick-off think, dropped
                self._answered(conn, msg.cycle, self.arena.submit_command(conn.slot.obj, msg))
        elif isinstance(msg, m.Report):
            self._to_coaches(encode(m.PlayerReport(cycle=self.arena.cycle, side=conn.slot.side,
                                                   unum=conn.slot.unum, payload=msg.payload)))
        elif isinstance(msg, m.SynchSee):
            self.arena.set_synch_see(conn.slot.obj)
        elif isinstance(msg, m.Bye):
            log.info("%s said bye", conn.name)
            self.arena.disconnect(conn.slot.obj)
            del self.conns[ident]

    def _on_init(self, ident: bytes, conn: Connection | None, msg: m.Init | m.Reconnect) -> None:
        if conn is not None:
            self._error_raw(self.players, ident, "already_initialised",
                            f"this connection is already {conn.name}")
            return
        now_ms = self._virtual_ms()
        try:
            if isinstance(msg, m.Init):
                slot = self.arena.connect(msg.team, msg.unum, fullstate=msg.fullstate,
                                          synch_see=msg.synch_see, pre_kick_off=msg.pre_kick_off,
                                          now_ms=now_ms)
            else:
                self._release_if_gone(msg.team, msg.unum)
                slot = self.arena.reconnect(msg.team, msg.unum, now_ms=now_ms)
        except ArenaError as exc:
            self._error_raw(self.players, ident, exc.code, exc.message)
            return
        # waited for in this cycle only if its percepts are still to come
        cycle = self.arena.cycle
        conn = Connection(ident, slot, answered=cycle if self.percepts_cycle == cycle else cycle - 1)
        self.conns[ident] = conn
        log.info("%s connected (%s)", conn.name, "reconnect" if isinstance(msg, m.Reconnect) else "init")
        self._send(conn, self.arena.init_ok(slot, msg.team, self._client_config()))

    def _release_if_gone(self, team: str, unum: int) -> None:
        """Before a ``reconnect``: free the seat of ``team`` ``unum`` if its connection is gone. One
        given up (unreachable, or ``max_missed_cycles`` missed) is; another is probed first: it gets a
        one-line ``error``, and the send fails (ROUTER_MANDATORY) if the client has disconnected."""
        holder = next((c for c in self.conns.values()
                       if c.slot.side == TEAMS.get(team) and c.slot.unum == unum), None)
        if holder is None:
            return
        if not holder.hung:
            self._send(holder, m.Error(cycle=self.arena.cycle, code="cannot_reconnect",
                                       message=f"another client asked to reconnect as {holder.name}"))
        if holder.hung:
            log.warning("%s: its seat is taken back by a reconnect", holder.name)
            self.arena.release(holder.slot.obj)
            del self.conns[holder.identity]
            self.next_see.pop(holder.identity, None)

    def _answered(self, conn: Connection, cycle_of_frame: int, warnings: list[str]) -> None:
        """After a command frame of ``cycle_of_frame`` was submitted (``Arena.submit_frame`` or
        ``submit_command``: a later cycle than the server's is not taken): ``bad_cycle`` for such a
        frame, else its warnings; a frame of this cycle is the player's answer to it."""
        cycle = self.arena.cycle
        if cycle_of_frame > cycle:
            self._send(conn, m.Error(cycle=cycle, code="bad_cycle",
                                     message=f"command for cycle {cycle_of_frame} but the server is at {cycle}"))
            return
        for text in warnings:
            self._send(conn, m.Error(cycle=cycle, code="dropped", message=text))
        if cycle_of_frame == cycle:
            if conn.hung:
                log.warning("%s answers again (cycle %d); waiting for it again", conn.name, cycle)
            conn.answered = cycle
            conn.missed = 0
            conn.hung = False

    def _client_config(self) -> dict:
        cfg = self.config
        return {"mode": cfg.mode, "keepers": cfg.keepers, "takers": cfg.takers, "seed": cfg.seed,
                "max_message_bytes": cfg.max_message_bytes, "getopen_notes": cfg.getopen_notes}

    def _virtual_ms(self) -> float:
        if self.config.mode == "sync":
            return self.arena.cycle * self.config.params.simulator_step_ms
        return (time.monotonic() - self._t0) * 1000.0

    # -- coach port ----------------------------------------------------------------------------------
    def _look_ok(self) -> bytes:
        """The encoded answer to a ``look``, made once for all the looks of one state: the true state
        changes only by a step (the cycle is in the key), a start or a message that is served (a player's,
        a coach's other than a look), which clear it; a pause or resume is in the key too."""
        key = (self.arena.cycle, self.standing_still)
        if self.look_answer is None or self.look_answer[0] != key:
            self.look_answer = key, encode(m.LookOk(cycle=self.arena.cycle, state=truth_state(self.arena),
                                                    paused=self.standing_still))
        return self.look_answer[1]

    def _on_coach(self, ident: bytes, data: bytes) -> None:
        try:
            msg = decode_from_coach(data, self.config.max_message_bytes)
        except ProtocolError as exc:
            self._error_raw(self.coach, ident, exc.code, exc.message)
            return
        if isinstance(msg, m.CoachInit):
            self.coaches[ident] = msg.client
            log.info("coach %r connected", msg.client)
            self._send_raw(self.coach, ident, encode(m.CoachInitOk(
                cycle=self.arena.cycle, version=PROTOCOL_VERSION, params=self.config.params.to_dict(),
                landmarks=self.arena.landmarks(), config=self._client_config(),
                play_mode=self.arena.play_mode)))
            return
        if ident not in self.coaches:
            self._error_raw(self.coach, ident, "not_initialised", "send init first")
            return
        if not isinstance(msg, m.Look):
            self.look_answer = None  # a reset, a start or advice may change the true state
        if isinstance(msg, m.Start):
            if not self.arena.started:
                log.info("coach started the game")
                self.arena.start()
        elif isinstance(msg, m.Look):
            self._send_raw(self.coach, ident, self._look_ok())
        elif isinstance(msg, m.Advice):
            size = len(encode(advice_hear(msg.payload, self.arena.cycle)))
            if size > self.config.max_message_bytes:
                self._error_raw(self.coach, ident, "too_large",
                                f"advice: its hear would be {size} bytes; players take at most "
                                f"{self.config.max_message_bytes}")
                return
            self.arena.advise(self.arena.advice_targets(msg.target), msg.payload)
        elif isinstance(msg, m.EpisodeControl):
            self._on_episode_control(ident, msg)
        elif isinstance(msg, m.CoachBye):
            log.info("coach %r said bye", self.coaches.pop(ident))

    def _on_episode_control(self, ident: bytes, msg: m.EpisodeControl) -> None:
        if msg.action == "stop":
            if msg.episodes_left is None:
                self.request_stop("coach asked to stop")
            else:
                self.episodes_left = msg.episodes_left
        elif msg.action == "pause":
            if msg.episodes_left is None:
                self._pause_now()
            else:
                self.pause_after = msg.episodes_left  # replaces any countdown; 0 = now
                self._pause_if_due()
        elif msg.action == "resume":
            self.paused = False
            log.info("resumed at cycle %d", self.arena.cycle)
        elif msg.action == "reset":
            self.arena.reset_episode(msg.seed, now_ms=self._virtual_ms())
            self.absent = {}  # the restarted episode is not the one logged so far
            if msg.seed is not None:
                self.next_see.clear()  # real-time see timers restart as on connect, like the arena's
            log.info("episode reset at cycle %d%s", self.arena.cycle,
                     "" if msg.seed is None else f" with seed {msg.seed}")

    def _pause_if_due(self) -> None:
        """End a ``pause`` countdown that has reached 0: pause now."""
        if self.pause_after is not None and self.pause_after <= 0:
            self.pause_after = None
            self._pause_now()

    def _pause_now(self) -> None:
        """Pause before the next cycle's percepts: the loops check ``paused`` there, so a pause that
        falls due at an episode's end holds the arena exactly at the boundary."""
        self.paused = True
        log.info("paused at cycle %d", self.arena.cycle)
