"""One arena's game without sockets: players, their command slots, the step, percepts and hearing.

The distributed server (``server/app.py``) wraps it with ZeroMQ and timing; the embedded mode drives it
directly. Everything here is deterministic given the seed and the commands submitted per cycle; the
coach's ``reset`` with a seed (:meth:`Arena.reset_episode`) makes the rest of the game depend only on that
seed and the commands that follow, whatever was played before (docs/protocol.md §12, "Coach").
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from keepaway.core.jit import SteadyCall
from keepaway.protocol import PROTOCOL_VERSION
from keepaway.protocol import messages as m
from keepaway.protocol.codec import encode
from keepaway.protocol.landmarks import to_wire as landmarks_to_wire
from keepaway.protocol.params import ServerParams
from keepaway.server import percept_wire, perception
from keepaway.server.command_frame import MAX_FRAME_BYTES, SAY, CommandBuffer
from keepaway.server.command_slots import (
    COMMAND_CODES,
    SAY_ALPHABET,
    put_command,
    say_allowed,
    take_command_frame,
    take_commands,
)
from keepaway.server.episode_log import EpisodeRecord
from keepaway.server.referee import END_CAUSES, new_referee_state, reset_field, start_game
from keepaway.server.simulation import new_causes, simulate_cycle
from keepaway.server.world import COUNT_CHANGE_VIEW, PARKED_Y, Commands, World, new_world

TEAMS = {"keepers": "l", "takers": "r"}
VIEW_WIDTHS = {"narrow": 0.5, "normal": 1.0, "wide": 2.0}
DEFAULT_VIEW_WIDTH = "normal"
SYNCH_SEE_PERIOD = {"narrow": 1, "normal": 2, "wide": 3}
REFEREE_EPISODE_MESSAGE = "training Keepaway 1"
# World arrays a reseeding reset keeps: the clock, who is connected, and the command counters (they
# count per connection in rcssserver and never go back; a client may compare successive sense_bodies).
KEPT_ON_RESEED = ("time", "enabled", "counts")


class QueuedHear(NamedTuple):
    """A hear waiting for its player's next percepts, encoded when queued (``Arena.take_hears``)."""

    sender: str
    frame: bytes


class ArenaError(Exception):
    """A request the arena refuses; ``code`` and a one-line ``message`` go back to the client."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


@dataclass
class PlayerSlot:
    """Server-side state of one player connection (docs/rules.md §2, §4, §5)."""

    obj: int
    side: str
    unum: int
    connected: bool = False
    fullstate: bool = False
    synch_see: bool = False
    pre_kick_off: bool = False  # sense_body (and think) while waiting for the kick-off, as rcssserver
    view_width: str = DEFAULT_VIEW_WIDTH
    see_phase_ms: float = 0.0  # virtual time of this player's first see (connect time, as rcssserver)
    hears: list[QueuedHear] = field(default_factory=list)

    def see_period_ms(self, send_step_ms: float) -> float:
        """Asynchronous see period: send_step x width factor (docs/rules.md §5.1; high quality only)."""
        return send_step_ms * VIEW_WIDTHS[self.view_width]


class Arena:
    """A Keepaway arena: the world of one game, its referee and its player slots."""

    def __init__(self, params: ServerParams, keepers: int, takers: int, seed: int) -> None:
        self.params = params
        self.kp = params.kernel()
        self.world: World = new_world(params, keepers, takers, batch=1, seed=seed)
        self.commands = Commands.empty(1, self.world.n_objects)
        self.referee = new_referee_state(1)
        self.causes = new_causes(1)
        self.started = False
        self.slots = [PlayerSlot(obj, self.world.side(obj), self.world.unum(obj))
                      for obj in range(1, self.world.n_objects)]
        self.pending_says: list[tuple[int, str]] = []
        self.see_out = perception.SeeBuffers.empty(1, self.world.n_objects, self.kp)
        self.body_out = perception.SenseBodyBuffers.empty(1, self.world.n_objects)
        self.see_buf = np.empty(percept_wire.see_frame_bytes(self.world.n_objects), dtype=np.uint8)
        self.body_buf = np.empty(percept_wire.SENSE_BODY_FRAME_BYTES, dtype=np.uint8)
        self.view_modes = {width: percept_wire.packed_view_mode("high", width) for width in VIEW_WIDTHS}
        # the kernels of every cycle, called without numba's typing of their arguments at each call
        self._simulate_cycle = SteadyCall(simulate_cycle)
        self._take_frame = SteadyCall(take_command_frame)
        self._take_commands = SteadyCall(take_commands)
        self._say_allowed = SteadyCall(say_allowed)
        self._frame = CommandBuffer.empty()  # a player's commands as the slot rules' kernel takes them
        self._say_dropped = f"say dropped: at most {int(params.say_msg_size)} characters from {SAY_ALPHABET}"
        self._see_frame = SteadyCall(percept_wire.see_frame)
        self._sense_body_frame = SteadyCall(percept_wire.sense_body_frame)
        self._hear_frames = SteadyCall(percept_wire.hear_frames)
        self._hear_buffers(len(self.slots))
        # what the referee said since the owner last took it (``take_referee_log``); None: not kept
        self.referee_log: list[str] | None = None
        self._noted: dict[int, tuple[float, ...]] = {}  # this cycle's GetOpen notes, by keeper unum
        # the keepers' GetOpen notes sent with the commands of the last step: (unum, note), by unum
        self.step_notes: tuple[tuple[int, tuple[float, ...]], ...] = ()

    # -- connections ---------------------------------------------------------------------------------
    @property
    def cycle(self) -> int:
        return self.world.time.item()  # the one arena's: item() is a quarter of int(time[0])'s cost

    @property
    def play_mode(self) -> str:
        return "play_on" if self.started else "before_kick_off"

    def slot(self, obj: int) -> PlayerSlot:
        return self.slots[obj - 1]

    def connect(self, team: str, unum: int | None = None, *, fullstate: bool = False,
                synch_see: bool = False, pre_kick_off: bool = False, now_ms: float = 0.0) -> PlayerSlot:
        """Give a new client a uniform number of ``team`` (the requested one if free)."""
        side = TEAMS.get(team)
        if side is None:
            raise ArenaError("illegal_teamname", f"team must be 'keepers' or 'takers', not {team!r}")
        free = [s for s in self.slots if s.side == side and not s.connected]
        if unum is not None:
            free = [s for s in free if s.unum == unum]
            if not free:
                raise ArenaError("no_more_player", f"{team} {unum} is taken or does not exist")
        if not free:
            raise ArenaError("no_more_player", f"all {team} are connected")
        free[0].pre_kick_off = pre_kick_off
        return self._enable(free[0], fullstate, synch_see, now_ms)

    def reconnect(self, team: str, unum: int, *, now_ms: float = 0.0) -> PlayerSlot:
        """Take over a uniform number whose client said bye or was dropped (rcssserver's reconnect)."""
        side = TEAMS.get(team)
        if side is None:
            raise ArenaError("illegal_teamname", f"team must be 'keepers' or 'takers', not {team!r}")
        for s in self.slots:
            if s.side == side and s.unum == unum:
                if s.connected:
                    raise ArenaError("cannot_reconnect", f"{team} {unum} is still connected")
                return self._enable(s, s.fullstate, s.synch_see, now_ms)
        raise ArenaError("no_such_player", f"there is no {team} {unum}")

    def set_synch_see(self, obj: int) -> None:
        """Player ``obj``'s see in synch_see mode from the next see on, for good (rcssserver's ``(synch_see)``:
        src/player.cpp, ``Player::synch_see``)."""
        self.slot(obj).synch_see = True

    def _enable(self, s: PlayerSlot, fullstate: bool, synch_see: bool, now_ms: float) -> PlayerSlot:
        s.connected, s.fullstate, s.synch_see = True, fullstate, synch_see
        s.see_phase_ms = now_ms
        s.hears.clear()
        self.world.enabled[0, s.obj] = True
        return s

    def release(self, obj: int) -> None:
        """Free the seat of a client that is gone without ``bye`` (docs/protocol.md §12, "Rejoin"), for a
        ``reconnect``: unlike :meth:`disconnect` the player stays on the pitch as it is, so for the game
        the rejoining client only takes over a player that missed some cycles."""
        self.slot(obj).connected = False

    def disconnect(self, obj: int) -> None:
        """bye: the player is disabled and parked off the pitch (docs/protocol.md §5, "bye")."""
        s = self.slot(obj)
        s.connected = False
        w = self.world
        w.enabled[0, obj] = False
        w.pos[0, obj] = (-3.0 * obj, PARKED_Y)
        w.vel[0, obj] = 0.0
        w.acc[0, obj] = 0.0

    def all_connected(self) -> bool:
        return all(s.connected for s in self.slots)

    def connected_slots(self) -> list[PlayerSlot]:
        return [s for s in self.slots if s.connected]

    # -- game ----------------------------------------------------------------------------------------
    def start(self) -> None:
        """Kick-off: the first play_on resets the field and starts episode 1 (docs/rules.md §8, "The kick-off")."""
        if not self.started:
            self.started = True
            start_game(0, self.world, self.referee, self.kp)
            self._referee_says("play_on")

    def submit(self, obj: int, commands: Iterable[m.AtomicCommand | tuple[str, tuple]]) -> list[str]:
        """Queue one client's atomic commands for this cycle, as (name, args) pairs (a decoded
        ``Command``'s); return one-line warnings for the client.

        Slot rule (docs/rules.md §2): the first accepted dash/turn/kick/tackle/move/catch wins, later
        ones are ignored; CLASSIC: a kick that cannot reach the ball does not use the slot. turn_neck
        has its own slot; say and change_view are unlimited. Numbers are finite (the codec checks);
        ranges are clamped by the kernels as rcssserver clamps them. The slot rules are a kernel's
        (``server.command_slots``), which a frame read straight from the wire goes through too
        (:meth:`submit_frame`); the commands' numbers are written into its buffer, up to
        ``MAX_COMMANDS`` (a ``Command``'s most) at a time.
        """
        out = self._frame
        warnings: list[str] = []
        count = 0
        for name, args in commands:
            if name == "change_view":
                self.world.counts[0, obj, COUNT_CHANGE_VIEW] += 1
                self.slot(obj).view_width = args[0]
                if len(args) > 1 and args[1] == "low":  # its content (directions only) is not modelled
                    warnings.append("change_view: low quality is not supported; the view stays high")
                continue
            code = COMMAND_CODES.get(name)
            if code is None:
                continue
            if count == len(out.command):
                self._take_commands(out, count, self.commands, obj, self.world, self.kp)
                count = 0
            if code == SAY:
                self._say(obj, args[0], warnings)
            put_command(out, count, code, () if code == SAY else args)
            count += 1
        self._take_commands(out, count, self.commands, obj, self.world, self.kp)
        return warnings

    def submit_frame(self, obj: int, frame: bytes) -> tuple[int, list[str]] | None:
        """One client's command frame as it came (``server.command_frame``): None if the kernel does not
        read it (then decode it in full and :meth:`submit_command` it), else its cycle and the warnings
        for the client. A frame of a later cycle than this one is not taken (the server answers it with
        ``bad_cycle``); as with :meth:`submit_command`, its note counts only in its own cycle."""
        if type(frame) is not bytes or len(frame) > MAX_FRAME_BYTES:
            return None
        out, now = self._frame, self.cycle
        cycle, count, noted, says, dropped, start, length = self._take_frame(
            frame, len(frame), out, now, self.commands, obj, self.world, self.kp)
        if cycle < 0:
            return None
        if says == 1:
            self.pending_says.append((obj, frame[start:start + length].decode("ascii")))
        elif says:
            self.pending_says.extend((obj, frame[at:at + size].decode("ascii"))
                                     for code, _, at, size in out.command[:count].tolist() if code == SAY)
        warnings = [self._say_dropped] * dropped
        if noted and cycle == now:
            self.note_getopen(obj, tuple(out.note[:noted].tolist()))
        return cycle, warnings

    def submit_command(self, obj: int, command: m.Command) -> list[str]:
        """A decoded ``Command``: its commands submitted (:meth:`submit`) if its cycle is this one or an
        earlier one, its note noted if its cycle is this one; the warnings for the client."""
        if command.cycle > self.cycle:
            return []
        warnings = self.submit(obj, command.commands)
        if command.cycle == self.cycle:
            self.note_getopen(obj, command.getopen)
        return warnings

    def _say(self, obj: int, text: str, warnings: list[str]) -> None:
        """A decoded say's text (counted by the slot rules' kernel): queued for the listeners, or dropped
        with a warning if it breaks the size or alphabet rule (``command_slots.say_allowed``, as a frame's)."""
        data = text.encode()  # a character beyond ASCII is out of the alphabet, whatever its bytes
        if self._say_allowed(data, 0, len(data), self.kp):
            self.pending_says.append((obj, text))
        else:
            warnings.append(self._say_dropped)

    def note_getopen(self, obj: int, note: tuple[float, ...]) -> None:
        """A keeper's GetOpen note sent with its commands of this cycle (``protocol.messages.getopen_note``);
        the last one of a cycle counts; a taker's, or an empty one, is no note."""
        s = self.slot(obj)
        if note and s.side == TEAMS["keepers"]:
            self._noted[s.unum] = note

    def step(self) -> EpisodeRecord | None:
        """Simulate one cycle; return the record of an episode that ended in it, if any."""
        self._simulate_cycle(self.world, self.commands, self.referee, self.kp, self.causes)
        self.commands.clear()
        self.step_notes = tuple(sorted(self._noted.items()))
        self._noted.clear()
        self._deliver_says()
        if self.referee.dropped[0]:
            self._referee_says("drop_ball", "play_on")
        cause = int(self.causes[0])
        if cause == 0:
            return None
        r = self.referee
        record = EpisodeRecord(episode=int(r.episode[0]) - 1, start_cycle=int(r.last_start_cycle[0]),
                               end_cycle=int(r.end_cycle[0]), end=END_CAUSES[cause])
        self._referee_says(REFEREE_EPISODE_MESSAGE)
        return record

    def reset_episode(self, seed: int | None = None, now_ms: float = 0.0) -> None:
        """The coach's "reset" (docs/protocol.md §12, "Coach"): restart the episode now, not logged; the
        episode and cycle counters go on and the players hear the referee's episode message.

        Without ``seed`` the field is reset from the running stream; everything else goes on. With
        ``seed`` the new episode plays exactly as the first episode of a fresh arena started with that
        seed, relative to this cycle (common random numbers across a trainer's requests): the world
        becomes a fresh one (:meth:`_restore_fresh`, ``now_ms`` being this cycle's virtual time for the
        see timers), then the kick-off's reset (docs/rules.md §7) places the players from the new stream.
        Exact only between cycles (the server pauses there, ``server/app.py``): percepts already sent
        for this cycle described the old episode. Before the kick-off the arena is only reseeded and
        the kick-off places the players.
        """
        if seed is None:
            reset_field(0, self.world, self.kp)
            self.referee.take_count[0] = 0
            self.referee.start_cycle[0] = self.cycle
        else:
            self._restore_fresh(seed, now_ms)
            if not self.started:
                return
            episode = int(self.referee.episode[0])
            start_game(0, self.world, self.referee, self.kp)
            self.referee.episode[0] = episode  # start_game numbers a fresh game's episode 1
        self._referee_says(REFEREE_EPISODE_MESSAGE)

    def _restore_fresh(self, seed: int, now_ms: float) -> None:
        """Everything a fresh arena with ``seed`` has at its kick-off but the clock, the connections and
        the command counters (``KEPT_ON_RESEED``): the random stream (``seed_streams(seed, 1)``), the
        ball at the centre, parked players, body and neck angles, stamina, effort, recovery, capacity,
        collision and kick flags; no pending commands or says; every view normal, and every see timer
        restarted at ``now_ms`` as if the player connected now (docs/rules.md §5.1: a see is due every period
        from the connection time). Queued hears stay (the coach's advice) but for the players' says, which
        belong to the old world.
        """
        w = self.world
        fresh = new_world(self.params, w.n_keepers, w.n_takers, batch=1, seed=seed)
        for name, value in zip(World._fields, fresh):
            if isinstance(value, np.ndarray) and name not in KEPT_ON_RESEED:
                getattr(w, name)[...] = value
        self.commands.clear()
        self.pending_says.clear()
        for s in self.slots:
            s.hears = [h for h in s.hears if h.sender not in m.PLAYER_HEAR_SENDERS]
            s.view_width = DEFAULT_VIEW_WIDTH
            s.see_phase_ms = now_ms

    def keep_referee_log(self) -> None:
        """Keep what the referee says from now on, for a game log (``server.game_log``)."""
        if self.referee_log is None:
            self.referee_log = []

    def take_referee_log(self) -> list[str]:
        """What the referee said since the last call (empty unless :meth:`keep_referee_log` was called)."""
        said, self.referee_log = self.referee_log or [], None if self.referee_log is None else []
        return said

    def _referee_says(self, *messages: str) -> None:
        """Referee messages are heard at once, in this cycle's percepts (docs/rules.md §5.5)."""
        if self.referee_log is not None:
            self.referee_log.extend(messages)
        frames = [encode(m.Hear(cycle=self.cycle, sender="referee", direction=None, unum=None, message=text))
                  for text in messages]
        for s in self.connected_slots():
            s.hears.extend(QueuedHear("referee", frame) for frame in frames)

    # -- hearing ------------------------------------------------------------------------------------
    def take_hears(self, s: PlayerSlot) -> list[bytes]:
        """The frames of the hears queued for ``s``, in order, now delivered: in its next percepts, or at
        once while the server is paused (docs/protocol.md §12, "Coach")."""
        out, s.hears = s.hears, []
        return [h.frame for h in out]

    def advice_targets(self, target: Any) -> list[int]:
        """The player objects a coach's advice ``target`` names: "keepers", "takers", "all", or one player
        as [side, unum] (docs/protocol.md §7)."""
        if target == "keepers":
            return [s.obj for s in self.slots if s.side == "l"]
        if target == "takers":
            return [s.obj for s in self.slots if s.side == "r"]
        if target == "all":
            return [s.obj for s in self.slots]
        side, unum = target
        return [s.obj for s in self.slots if s.side == side and s.unum == unum]

    def advise(self, objs: list[int], payload: Any) -> None:
        """Coach advice, heard by ``objs`` in their next percepts."""
        frame = encode(m.advice_hear(payload, self.cycle))
        for obj in objs:
            s = self.slot(obj)
            if s.connected:
                s.hears.append(QueuedHear("coach", frame))

    def _hear_buffers(self, says: int) -> None:
        """The buffers of ``_deliver_says``' kernel call, for up to ``says`` says a cycle."""
        self._hears = percept_wire.HearBuffers.empty(says, len(self.slots), int(self.params.say_msg_size))

    def _deliver_says(self) -> None:
        """Says of cycle t are heard in t+1 (docs/rules.md §5.5): self always, others as
        ``perception.hear_picks`` draws them. One kernel call draws them for every connected listener and
        writes their frames (``percept_wire.hear_frames``; a say's text was checked when it was taken,
        :meth:`submit`); here they are only cut apart and queued."""
        says = self.pending_says
        if not says:
            return
        says.sort(key=lambda said: said[0])  # arrival order must not matter (determinism)
        if len(says) > self._hears.speakers.shape[0]:
            self._hear_buffers(len(says))
        hears = self._hears
        listeners = self.connected_slots()
        texts = "".join(text for _, text in says).encode("ascii")
        hears.texts[:len(texts)] = np.frombuffer(texts, dtype=np.uint8)
        end = 0
        for i, (speaker, text) in enumerate(says):
            end += len(text)
            hears.speakers[i], hears.text_ends[i] = speaker, end
        for k, listener in enumerate(listeners):
            hears.listeners[k] = listener.obj
        p = self.params
        n = self._hear_frames(0, self.world, hears, len(says), len(listeners), p.hear_max, p.audio_cut_dist, self.cycle)
        ends = hears.frame_end[:n].tolist()
        frames = hears.frames[:ends[-1] if n else 0].tobytes()
        start = 0
        for k, sender, end in zip(hears.frame_listener[:n].tolist(), hears.frame_sender[:n].tolist(), ends):
            listeners[k].hears.append(QueuedHear(percept_wire.HEAR_SENDERS[sender], frames[start:end]))
            start = end
        says.clear()

    # -- percepts -----------------------------------------------------------------------------------
    def see_due(self, s: PlayerSlot, cycle: int) -> bool:
        """Synchronous-mode see schedule (:func:`server.perception.see_due`; synch-see: every 1/2/3
        cycles for narrow/normal/wide)."""
        if s.synch_see:
            return cycle % SYNCH_SEE_PERIOD[s.view_width] == 0
        return perception.see_due(cycle, self.params.simulator_step_ms,
                                  s.see_period_ms(self.params.send_step_ms), s.see_phase_ms)

    def see_frame(self, s: PlayerSlot) -> bytes:
        """``s``'s see of this cycle, encoded (``percept_wire.see_frame``: the bytes of ``encode(m.See(...))``)."""
        factor = perception.cone_factor(s.view_width, s.synch_see)
        n = self._see_frame(0, self.world, s.obj, factor, self.kp, self.see_out, self.cycle, self.see_buf)
        return self.see_buf[:n].tobytes()

    def sense_body_frame(self, s: PlayerSlot) -> bytes:
        """``s``'s sense_body of this cycle, encoded (``percept_wire.sense_body_frame``)."""
        n = self._sense_body_frame(0, self.world, s.obj, self.body_out, self.cycle, self.view_modes[s.view_width],
                                   self.body_buf)
        return self.body_buf[:n].tobytes()

    def fullstate_payload(self) -> dict:
        payload = perception.fullstate(self.world, 0)
        payload["play_mode"] = self.play_mode
        payload["episode"] = int(self.referee.episode[0])
        return payload

    def cycle_frames(self, s: PlayerSlot, with_see: bool) -> list[bytes]:
        """Percepts of this cycle for one player, encoded, in rcssserver's order: sense_body,
        (fullstate), hears, then see. Encoded here because the server sends them as they are and the
        percepts the server writes most are written straight from the perception buffers."""
        out = [self.sense_body_frame(s)]
        if s.fullstate:
            out.append(encode(m.Fullstate(cycle=self.cycle, **self.fullstate_payload())))
        out.extend(self.take_hears(s))
        if with_see:
            out.append(self.see_frame(s))
        return out

    def init_ok(self, s: PlayerSlot, team: str, config: dict) -> m.InitOk:
        """The answer to a player's init/reconnect: its number, the parameter table, the landmarks."""
        return m.InitOk(cycle=self.cycle, version=PROTOCOL_VERSION, side=s.side, unum=s.unum, team=team,
                        play_mode=self.play_mode, params=self.params.to_dict(),
                        landmarks=landmarks_to_wire(), config=config)

    def landmarks(self) -> dict:
        return landmarks_to_wire()


def player_name(s: PlayerSlot) -> str:
    """How logs name a player: ``keeper 1``, ``taker 2``."""
    return f"{'keeper' if s.side == 'l' else 'taker'} {s.unum}"


def truth_state(arena: Arena) -> dict:
    """The noiseless state for the coach's look and the monitor (ball, players, play mode, episode)."""
    state = arena.fullstate_payload()
    state["episode_start"] = int(arena.referee.start_cycle[0])
    state["take_count"] = int(arena.referee.take_count[0])
    return state


def compile_kernels(params: ServerParams, keepers: int, takers: int) -> None:
    """Compile (or load from numba's cache) every kernel a game uses, on a scratch arena, so that the
    first cycles of a real game run at full speed and no client's timeout counts compilation."""
    scratch = Arena(params, keepers, takers, seed=0)
    for s in scratch.slots:
        scratch.connect("keepers" if s.side == "l" else "takers")
    scratch.start()
    kick_say = m.Command(cycle=scratch.cycle, commands=(m.AtomicCommand("kick", (10.0, 0.0)),
                                                        m.AtomicCommand("say", ("a",))))
    for s in scratch.slots:
        scratch.see_due(s, scratch.cycle)
        scratch.cycle_frames(s, True)
        # the kick's reach, the hears' kernel, the slot rules of a frame and of a decoded command
        scratch.submit_frame(s.obj, encode(kick_say))
        scratch.submit_command(s.obj, kick_say)
    scratch.step()


__all__ = ["Arena", "ArenaError", "PlayerSlot", "TEAMS", "compile_kernels", "player_name", "truth_state"]
