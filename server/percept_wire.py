"""A player's percept frames written by kernels, byte for byte as ``encode`` of their messages
(``protocol.messages.See``, ``SenseBody``, ``Hear``).

Every cycle the server sends each player a sense_body, about three hears and on two cycles of three a see.
Built as Python lists, a message object and a map for the packer, these were the message path that cost
most of the server's time per cycle (docs/design.md, "Processes and sockets"). Here kernels write the same
bytes straight from the perception model's records (``server.perception``) with ``core.msgpack_out``'s
writers: :func:`write_see` and :func:`write_sense_body` turn one observer's record into its frame,
:func:`see_frame` and :func:`sense_body_frame` compute the record and write it in one call from the
server's loop, and :func:`hear_frames` writes a cycle's hears for every listener into
:class:`HearBuffers`, with the draws of ``server.perception.hear_picks``. The ``*_payload`` functions give
the map a frame holds. ``tests/test_perception.py`` and ``tests/test_say.py`` check the frames against
``encode``.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import msgpack
import numpy as np

from keepaway.core.jit import borrowing, njit
from keepaway.core.msgpack_out import (
    FLOAT_BYTES,
    MAX_INT_BYTES,
    MAX_STR_HEADER_BYTES,
    packed,
    put_array,
    put_float,
    put_int,
    put_nil,
    put_raw,
    put_str,
)
from keepaway.core.objects import BALL
from keepaway.protocol.landmarks import N_FLAGS, N_LINES
from keepaway.protocol.params import KernelParams
from keepaway.server.perception import (
    FULL,
    PARTIAL,
    UNSEEN,
    SeeBuffers,
    SenseBodyBuffers,
    hear_direction,
    hear_picks,
    see_arena,
    sense_body_arena,
)
from keepaway.server.world import COLLIDED_BALL, COLLIDED_PLAYER, World, player_unum

# Names of world.counts' columns (server/world.py COUNT_*), the keys of sense_body's "counts".
COUNT_NAMES: tuple[str, ...] = ("kick", "dash", "turn", "catch", "move", "turn_neck", "change_view", "say")

_PACKER = msgpack.Packer(use_bin_type=True)


def _fragment(*parts: Any) -> np.ndarray:
    """Constant parts of a frame, packed one after another (bytes are taken as already packed)."""
    return np.concatenate([np.frombuffer(part, dtype=np.uint8) if isinstance(part, bytes) else packed(part)
                           for part in parts])


def _payload(frame: np.ndarray) -> dict:
    """A frame's message map without its type and cycle: the msgpack-ready payload of a percept."""
    wire = msgpack.unpackb(frame.tobytes())
    del wire["type"], wire["cycle"]
    return wire


# the message maps' keys in the order of their fields (protocol.messages.See, SenseBody)
_SEE_HEAD = _fragment(_PACKER.pack_map_header(6), "type", "see", "cycle")
_SEE_FLAGS, _SEE_LINES, _SEE_BALL, _SEE_PLAYERS = (packed(key) for key in ("flags", "lines", "ball", "players"))
_SIDE_L, _SIDE_R = packed("l"), packed("r")
_BODY_HEAD = _fragment(_PACKER.pack_map_header(8), "type", "sense_body", "cycle")
_BODY_VIEW_MODE, _BODY_STAMINA, _BODY_SPEED, _BODY_HEAD_ANGLE, _BODY_COLLISION = (
    packed(key) for key in ("view_mode", "stamina", "speed", "head_angle", "collision"))
_BODY_COUNTS = _fragment("counts", _PACKER.pack_map_header(len(COUNT_NAMES)))
_COUNT_KEYS = _fragment(*COUNT_NAMES)
_COUNT_KEY_ENDS = np.cumsum([len(packed(name)) for name in COUNT_NAMES])
_COLLIDED_BALL_NAME, _COLLIDED_PLAYER_NAME = packed("ball"), packed("player")
# The largest see row of each kind (array header, ints, doubles; core/msgpack_out.py), and the rest.
_FLAG_ROW_BYTES = 1 + 2 * MAX_INT_BYTES + 3 * FLOAT_BYTES
_LINE_ROW_BYTES = 1 + 2 * MAX_INT_BYTES + FLOAT_BYTES
_PLAYER_ROW_BYTES = 1 + 6 * MAX_INT_BYTES + 4 * FLOAT_BYTES
_FRAME_HEAD_BYTES = 256
SENSE_BODY_FRAME_BYTES = 512
"""Room for any sense_body frame (its map is fixed but for the counts' ints, at most 9 bytes each)."""
# The hear of a player's say (protocol.messages.Hear's fields in order): "self" to the speaker itself,
# "our" with direction and uniform number to a teammate, "opp" with direction alone to an opponent.
HEAR_SELF, HEAR_OUR, HEAR_OPP = 0, 1, 2
HEAR_SENDERS = ("self", "our", "opp")  # by those codes
_HEAR_HEAD = _fragment(_PACKER.pack_map_header(6), "type", "hear", "cycle")
_HEAR_SENDER_SELF, _HEAR_SENDER_OUR, _HEAR_SENDER_OPP = (_fragment("sender", name) for name in HEAR_SENDERS)
_HEAR_DIRECTION, _HEAR_UNUM, _HEAR_MESSAGE = (packed(key) for key in ("direction", "unum", "message"))
HEAR_FRAME_BYTES = (_HEAR_HEAD.shape[0] + _HEAR_SENDER_SELF.shape[0] + _HEAR_DIRECTION.shape[0] + _HEAR_UNUM.shape[0]
                    + _HEAR_MESSAGE.shape[0] + 3 * MAX_INT_BYTES + max(len(name) for name in HEAR_SENDERS)
                    + MAX_STR_HEADER_BYTES)
"""Room for a hear frame but its text."""


# --------------------------------------------------------------------------------------------------
# see


def see_frame_bytes(n_objects: int) -> int:
    """Room for any see frame of an arena of ``n_objects`` world objects (ball included)."""
    return (_FRAME_HEAD_BYTES + N_FLAGS * _FLAG_ROW_BYTES + N_LINES * _LINE_ROW_BYTES
            + n_objects * _PLAYER_ROW_BYTES)


@borrowing
def write_see(out: SeeBuffers, b: int, obs: int, n_keepers: int, cycle: int, buf: np.ndarray) -> int:
    """One observer's ``see`` message (``protocol.messages.See``) as msgpack into ``buf``; returns its
    length. Rows in this order: flags, lines, the ball, players left then right. Omitted
    fields are nil: a CLOSE flag has no id, a NAMELESS player no side, a PARTIAL one no unum; changes
    and facing only at FULL; an unseen ball is nil."""
    p = obs - 1
    ball_slot = N_FLAGS + BALL
    n_slots = out.level.shape[2]
    n_flags = 0
    n_players = 0
    for slot in range(n_slots):
        if out.level[b, p, slot] != UNSEEN:
            if slot < ball_slot:
                n_flags += 1
            elif slot > ball_slot:
                n_players += 1
    n_lines = 0
    for k in range(N_LINES):
        if out.line_seen[b, p, k]:
            n_lines += 1
    n = put_raw(buf, 0, _SEE_HEAD)
    n = put_int(buf, n, cycle)
    n = put_raw(buf, n, _SEE_FLAGS)
    n = put_array(buf, n, n_flags)
    for slot in range(ball_slot):
        level = out.level[b, p, slot]
        if level == UNSEEN:
            continue
        n = put_array(buf, n, 5)
        n = put_int(buf, n, slot) if level >= PARTIAL else put_nil(buf, n)
        n = put_float(buf, n, out.dist[b, p, slot])
        n = put_int(buf, n, out.direction[b, p, slot])
        n = _put_changes(buf, n, out, b, p, slot, level == FULL)
    n = put_raw(buf, n, _SEE_LINES)
    n = put_array(buf, n, n_lines)
    for k in range(N_LINES):
        if out.line_seen[b, p, k]:
            n = put_array(buf, n, 3)
            n = put_int(buf, n, k)
            n = put_float(buf, n, out.line_dist[b, p, k])
            n = put_int(buf, n, out.line_dir[b, p, k])
    n = put_raw(buf, n, _SEE_BALL)
    level = out.level[b, p, ball_slot]
    if level == UNSEEN:
        n = put_nil(buf, n)
    else:
        n = put_array(buf, n, 4)
        n = put_float(buf, n, out.dist[b, p, ball_slot])
        n = put_int(buf, n, out.direction[b, p, ball_slot])
        n = _put_changes(buf, n, out, b, p, ball_slot, level == FULL)
    n = put_raw(buf, n, _SEE_PLAYERS)
    n = put_array(buf, n, n_players)
    for slot in range(ball_slot + 1, n_slots):
        level = out.level[b, p, slot]
        if level == UNSEEN:
            continue
        i = slot - N_FLAGS
        n = put_array(buf, n, 8)
        if level >= PARTIAL:
            n = put_raw(buf, n, _SIDE_L if i <= n_keepers else _SIDE_R)
        else:
            n = put_nil(buf, n)
        if level == FULL:
            n = put_int(buf, n, player_unum(i, n_keepers))
        else:
            n = put_nil(buf, n)
        n = put_float(buf, n, out.dist[b, p, slot])
        n = put_int(buf, n, out.direction[b, p, slot])
        n = _put_changes(buf, n, out, b, p, slot, level == FULL)
        if level == FULL:
            n = put_int(buf, n, out.body_dir[b, p, slot])
            n = put_int(buf, n, out.head_dir[b, p, slot])
        else:
            n = put_nil(buf, put_nil(buf, n))
    return n


@borrowing
def _put_changes(buf: np.ndarray, n: int, out: SeeBuffers, b: int, p: int, slot: int, full: bool) -> int:
    """dist_chg and dir_chg of a FULL record, else two nils."""
    if full:
        return put_float(buf, put_float(buf, n, out.dist_chg[b, p, slot]), out.dir_chg[b, p, slot])
    return put_nil(buf, put_nil(buf, n))


@borrowing
def see_frame(b: int, w: World, obs: int, width_factor: float, kp: KernelParams, out: SeeBuffers, cycle: int,
              buf: np.ndarray) -> int:
    """Player object ``obs``'s see of this cycle (:func:`see_arena`) written into ``buf``
    (:func:`write_see`); returns its length. One call from the server's loop where two were: each call
    from Python unboxes the world's arrays again."""
    see_arena(b, w, obs, width_factor, kp, out)
    return write_see(out, b, obs, w.n_keepers, cycle, buf)


def see_payload(out: SeeBuffers, b: int, obs: int, n_keepers: int) -> dict:
    """One observer's see as the map the wire carries (:func:`write_see`), without type and cycle."""
    buf = np.empty(see_frame_bytes(out.level.shape[2] - N_FLAGS), dtype=np.uint8)
    return _payload(buf[: write_see(out, b, obs, n_keepers, 0, buf)])


# --------------------------------------------------------------------------------------------------
# sense_body


@borrowing
def write_sense_body(out: SenseBodyBuffers, b: int, obs: int, cycle: int, view_mode: np.ndarray,
                     buf: np.ndarray) -> int:
    """One player's ``sense_body`` message (``protocol.messages.SenseBody``, docs/rules.md §5.3) as
    msgpack into ``buf``; returns its length. The view mode is server-side connection state: the caller
    passes it packed (:func:`packed_view_mode`)."""
    p = obs - 1
    n = put_raw(buf, 0, _BODY_HEAD)
    n = put_int(buf, n, cycle)
    n = put_raw(buf, n, _BODY_VIEW_MODE)
    n = put_raw(buf, n, view_mode)
    n = put_raw(buf, n, _BODY_STAMINA)
    n = put_array(buf, n, 3)
    n = put_float(buf, n, out.stamina[b, p])
    n = put_float(buf, n, out.effort[b, p])
    n = put_float(buf, n, out.capacity[b, p])
    n = put_raw(buf, n, _BODY_SPEED)
    n = put_array(buf, n, 2)
    n = put_float(buf, n, out.speed[b, p])
    n = put_int(buf, n, out.speed_dir[b, p])
    n = put_raw(buf, n, _BODY_HEAD_ANGLE)
    n = put_int(buf, n, out.head_angle[b, p])
    n = put_raw(buf, n, _BODY_COUNTS)
    start = 0
    for c in range(_COUNT_KEY_ENDS.shape[0]):
        n = put_raw(buf, n, _COUNT_KEYS[start:_COUNT_KEY_ENDS[c]])
        n = put_int(buf, n, out.counts[b, p, c])
        start = _COUNT_KEY_ENDS[c]
    bits = out.collision[b, p]
    n = put_raw(buf, n, _BODY_COLLISION)
    n = put_array(buf, n, (1 if bits & COLLIDED_BALL else 0) + (1 if bits & COLLIDED_PLAYER else 0))
    if bits & COLLIDED_BALL:
        n = put_raw(buf, n, _COLLIDED_BALL_NAME)
    if bits & COLLIDED_PLAYER:
        n = put_raw(buf, n, _COLLIDED_PLAYER_NAME)
    return n


@borrowing
def sense_body_frame(b: int, w: World, obs: int, out: SenseBodyBuffers, cycle: int, view_mode: np.ndarray,
                     buf: np.ndarray) -> int:
    """Player object ``obs``'s sense_body of this cycle (:func:`sense_body_arena`) written into ``buf``
    (:func:`write_sense_body`), in one call as :func:`see_frame`; returns its length."""
    sense_body_arena(b, w, obs, out)
    return write_sense_body(out, b, obs, cycle, view_mode, buf)


def packed_view_mode(view_quality: str, view_width: str) -> np.ndarray:
    """A sense_body's ``view_mode`` value, packed for :func:`write_sense_body`."""
    return packed([view_quality, view_width])


def sense_body_payload(out: SenseBodyBuffers, b: int, obs: int, view_quality: str, view_width: str) -> dict:
    """One player's sense_body as the map the wire carries (:func:`write_sense_body`), without type and
    cycle."""
    buf = np.empty(SENSE_BODY_FRAME_BYTES, dtype=np.uint8)
    return _payload(buf[: write_sense_body(out, b, obs, 0, packed_view_mode(view_quality, view_width), buf)])


# --------------------------------------------------------------------------------------------------
# hear


@borrowing
def write_hear(buf: np.ndarray, n: int, cycle: int, sender: int, direction: int, unum: int,
               text: np.ndarray) -> int:
    """A hear of a player's say as msgpack at ``buf[n:]``, byte for byte ``encode(Hear(...))``: ``sender``
    one of HEAR_SELF, HEAR_OUR, HEAR_OPP; ``direction`` (HEAR_OUR, HEAR_OPP) and ``unum`` (HEAR_OUR) nil
    where the sender has none; ``text`` the say's ASCII bytes. Returns the position after it."""
    n = put_raw(buf, n, _HEAR_HEAD)
    n = put_int(buf, n, cycle)
    if sender == HEAR_SELF:
        n = put_raw(buf, n, _HEAR_SENDER_SELF)
    elif sender == HEAR_OUR:
        n = put_raw(buf, n, _HEAR_SENDER_OUR)
    else:
        n = put_raw(buf, n, _HEAR_SENDER_OPP)
    n = put_raw(buf, n, _HEAR_DIRECTION)
    n = put_nil(buf, n) if sender == HEAR_SELF else put_int(buf, n, direction)
    n = put_raw(buf, n, _HEAR_UNUM)
    n = put_int(buf, n, unum) if sender == HEAR_OUR else put_nil(buf, n)
    n = put_raw(buf, n, _HEAR_MESSAGE)
    return put_str(buf, n, text)


@njit(cache=True)
def _say_text(texts: np.ndarray, text_ends: np.ndarray, i: int) -> np.ndarray:
    """The i-th say's text in ``texts`` (the says' texts one after another, each ending at ``text_ends``)."""
    return texts[text_ends[i - 1] if i > 0 else 0:text_ends[i]]


class HearBuffers(NamedTuple):
    """What :func:`hear_frames` takes and writes, for up to ``S`` says and ``L`` listeners a cycle: the says
    and listeners (filled in by the caller), each listener's draws, and the hear frames. A listener hears
    at most every say, as its own or another's, so ``F = 2 L S`` frames are room enough."""

    speakers: np.ndarray  # (S,) int64: the speaker of each say, in object order
    texts: np.ndarray  # (S * say_msg_size,) uint8: the says' ASCII texts one after another
    text_ends: np.ndarray  # (S,) int64: where each say's text ends in texts
    listeners: np.ndarray  # (L,) int64: the listeners' player objects
    picks: np.ndarray  # (L, S) int64: row k, the says drawn for listener k (hear_picks)
    frames: np.ndarray  # (F * (HEAR_FRAME_BYTES + say_msg_size),) uint8: the hear frames one after another
    frame_listener: np.ndarray  # (F,) int64: frame f's listener, an index into listeners
    frame_sender: np.ndarray  # (F,) int64: frame f's sender, HEAR_SELF, HEAR_OUR or HEAR_OPP
    frame_end: np.ndarray  # (F,) int64: where frame f ends in frames

    @classmethod
    def empty(cls, says: int, listeners: int, say_msg_size: int) -> "HearBuffers":
        """Buffers for ``says`` says of at most ``say_msg_size`` characters and ``listeners`` listeners."""
        frames = listeners * 2 * says
        return cls(
            speakers=np.empty(says, dtype=np.int64),
            texts=np.empty(says * say_msg_size, dtype=np.uint8),
            text_ends=np.empty(says, dtype=np.int64),
            listeners=np.empty(listeners, dtype=np.int64),
            picks=np.empty((listeners, says), dtype=np.int64),
            frames=np.empty(frames * (HEAR_FRAME_BYTES + say_msg_size), dtype=np.uint8),
            frame_listener=np.empty(frames, dtype=np.int64),
            frame_sender=np.empty(frames, dtype=np.int64),
            frame_end=np.empty(frames, dtype=np.int64),
        )


@njit(cache=True)
def hear_frames(b: int, w: World, hears: HearBuffers, n_speakers: int, n_listeners: int, hear_max: float,
                cut: float, cycle: int) -> int:
    """The hears of this cycle's says (``hears.speakers[:n_speakers]``, each say's text in ``hears.texts``
    up to its ``text_ends``), for each of ``hears.listeners[:n_listeners]`` in turn: its own says
    (``self``), then the says :func:`hear_picks` draws for it (the draws in that order, into row k of
    ``picks``), with the direction and, from a teammate, the number. Written one after another into
    ``hears.frames`` (:func:`write_hear`); frame f is for listener index ``frame_listener[f]``, from a
    sender ``frame_sender[f]`` and ends at ``frame_end[f]``. Returns the number of frames. The server's one
    kernel call a cycle (``server.arena.Arena``), on buffers it keeps."""
    speakers, texts, text_ends, listeners, picks = (hears.speakers, hears.texts, hears.text_ends, hears.listeners,
                                                    hears.picks)
    buf, frame_listener, frame_sender, frame_end = (hears.frames, hears.frame_listener, hears.frame_sender,
                                                    hears.frame_end)
    keepers = w.n_keepers
    n = 0
    f = 0
    for k in range(n_listeners):
        listener = listeners[k]
        for i in range(n_speakers):
            if speakers[i] == listener:
                n = write_hear(buf, n, cycle, HEAR_SELF, 0, 0, _say_text(texts, text_ends, i))
                frame_listener[f], frame_sender[f], frame_end[f] = k, HEAR_SELF, n
                f += 1
        for j in range(hear_picks(b, w, speakers[:n_speakers], listener, hear_max, cut, picks[k])):
            i = picks[k, j]
            speaker = speakers[i]
            sender = HEAR_OUR if (speaker <= keepers) == (listener <= keepers) else HEAR_OPP
            n = write_hear(buf, n, cycle, sender, hear_direction(b, w, listener, speaker),
                           player_unum(speaker, keepers), _say_text(texts, text_ends, i))
            frame_listener[f], frame_sender[f], frame_end[f] = k, sender, n
            f += 1
    return f


__all__ = [
    "COUNT_NAMES",
    "HEAR_FRAME_BYTES",
    "hear_frames",
    "HEAR_OPP",
    "HEAR_OUR",
    "HEAR_SELF",
    "HEAR_SENDERS",
    "HearBuffers",
    "packed_view_mode",
    "see_frame",
    "see_frame_bytes",
    "see_payload",
    "sense_body_frame",
    "SENSE_BODY_FRAME_BYTES",
    "sense_body_payload",
    "write_hear",
    "write_see",
    "write_sense_body",
]
