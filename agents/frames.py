"""A player's per-cycle frames straight from their msgpack bytes, compiled: ``see`` into the world model's
see buffer, ``sense_body``, the players' ``hear`` and ``think`` into a few values.

Every cycle a player gets a sense_body, a think, about three hears (its own say, and its teammates' and
opponents') and on two cycles of three a see. Through the full decoder each goes msgpack -> dict and
lists -> validated message (``protocol.messages.decode_for_player``) -> what the agent takes from it,
Python all the way: the largest share of a player process's time in the distributed and embedded modes
(``py-spy``, docs/design.md, "Processes and sockets"). :func:`decode_frame` reads the same bytes once, in
a kernel: a see into the rows ``WorldModel.on_see`` would write, the other kinds into the values their
handlers take (:data:`SPEED_AMOUNT` ..., :data:`SENDER` ...).

It takes exactly the frames of those kinds that the full decoder takes as they are, without converting
a value: a map of the message's fields (the optional ones of a hear may be left out), each once, in any
order; numbers that are doubles where the message has floats (finite; distances, speeds and stamina
>= 0), ints in range where it has ints (any msgpack int form), nil where it allows it; names from the
message's vocabulary; for a see, rows of the right length (``protocol.codec.rows`` and the ``_seen_*``
row tests of ``protocol.messages``) and at most as many flags with an id as the buffer holds; for a
hear, a player's (sender ``self``, ``our`` or ``opp``, the ones of every cycle) with an ASCII text of at
most ``MAX_TEXT_CHARS``. For any other frame, valid or not (the referee's and the coach's hears among
them), it returns :data:`NOT_TAKEN` and the caller decodes the frame in full, which takes it or reports
what is wrong exactly as before. So a frame gives the same world model and the same command either way
(``tests/test_see_frame.py`` and ``tests/test_player_frames.py`` check the results against the decoded
messages and every refusal against the full decoder).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from keepaway.core.jit import borrowing
from keepaway.core.msgpack_in import (
    BAD,
    ascii,
    is_nil,
    read_array,
    read_double,
    read_int,
    read_map,
    read_str,
    str_equals,
)
from keepaway.protocol.messages import (
    COLLISIONS,
    COMMAND_COUNTS,
    MAX_CYCLE,
    MAX_LANDMARKS,
    MAX_PLAYERS,
    MAX_TEXT_CHARS,
    MAX_UNUM,
    PLAYER_HEAR_SENDERS,
    SERVER_TO_PLAYER,
    SIDES,
    VIEW_QUALITIES,
    VIEW_WIDTHS,
)

SIDE_CODES = {side: code for code, side in enumerate(SIDES)}  # the see buffer's side codes: l 0, r 1
NO_SIDE = -1  # a player seen without its side
NO_UNUM = 0  # ... without its uniform number

_SIDE_L, _SIDE_R = ascii(SIDES[0]), ascii(SIDES[1])
_FLAG_ROW, _LINE_ROW, _BALL_ROW, _PLAYER_ROW = 5, 3, 4, 8


def _names(names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``names`` as the table and lengths :func:`_name_index` looks them up in: their ASCII bytes, one
    row each (zero-padded), and their lengths."""
    table = np.zeros((len(names), max(map(len, names))), dtype=np.uint8)
    for i, name in enumerate(names):
        table[i, :len(name)] = ascii(name)
    return table, np.array([len(name) for name in names], dtype=np.int64)


FRAME_TYPES = ("see", "sense_body", "hear", "think")
"""The kinds of frame :func:`decode_frame` takes; it returns the index of the one it took."""
SEE, SENSE_BODY, HEAR, THINK = range(len(FRAME_TYPES))
NOT_TAKEN = -1
"""What :func:`decode_frame` returns for a frame it leaves to the full decoder."""

# The slots of decode_frame's values: a sense_body's ...
SPEED_AMOUNT, SPEED_DIRECTION, HEAD_ANGLE, STAMINA, EFFORT = range(5)
# ... and a hear's (the sender as an index of PLAYER_HEAR_SENDERS; the text as its bytes in the frame)
SENDER, TEXT_START, TEXT_LENGTH = range(5, 8)
FRAME_VALUES = 8

# Every key of the frames taken, and each frame type's keys as bit masks over them: the ones it must
# have and the ones it may have, from the message declarations (protocol.messages).
_KEYS = ("type", "cycle", "flags", "lines", "ball", "players", "view_mode", "stamina", "speed", "head_angle",
         "counts", "collision", "sender", "direction", "unum", "message")
(_TYPE, _CYCLE, _FLAGS, _LINES, _BALL, _PLAYERS, _VIEW_MODE, _STAMINA, _SPEED, _HEAD_ANGLE, _COUNTS,
 _COLLISION, _SENDER, _DIRECTION, _UNUM, _MESSAGE) = range(len(_KEYS))


def _key_masks(frame_type: str) -> tuple[int, int]:
    """(required, allowed) keys of a frame type's message, as bits of :data:`_KEYS`."""
    cls = SERVER_TO_PLAYER[frame_type]
    required = allowed = 1 << _KEYS.index(cls.TAG)
    for field in dataclasses.fields(cls):
        bit = 1 << _KEYS.index(field.metadata["key"] or field.name)
        allowed |= bit
        if field.metadata["required"]:
            required |= bit
    return required, allowed


_REQUIRED = np.array([_key_masks(t)[0] for t in FRAME_TYPES], dtype=np.int64)
_ALLOWED = np.array([_key_masks(t)[1] for t in FRAME_TYPES], dtype=np.int64)
_KEY_NAMES, _KEY_LENGTHS = _names(_KEYS)
_TYPE_NAMES, _TYPE_LENGTHS = _names(FRAME_TYPES)
_QUALITY_NAMES, _QUALITY_LENGTHS = _names(VIEW_QUALITIES)
_WIDTH_NAMES, _WIDTH_LENGTHS = _names(VIEW_WIDTHS)
_COUNT_NAMES, _COUNT_LENGTHS = _names(COMMAND_COUNTS)
_COLLISION_NAMES, _COLLISION_LENGTHS = _names(COLLISIONS)
_SENDER_NAMES, _SENDER_LENGTHS = _names(PLAYER_HEAR_SENDERS)
_ASCII_END = 0x80
_MAX_DOUBLE = np.finfo(np.float64).max


@borrowing
def _non_negative(buf, n, end) -> tuple:
    """A double in [0, max] (not NaN or infinite): a seen distance, a speed, stamina."""
    value, n = read_double(buf, n, end)
    if n == BAD or not 0.0 <= value <= _MAX_DOUBLE:
        return 0.0, BAD
    return value, n


@borrowing
def _finite(buf, n, end) -> tuple:
    """A finite double."""
    value, n = read_double(buf, n, end)
    if n == BAD or not -_MAX_DOUBLE <= value <= _MAX_DOUBLE:
        return 0.0, BAD
    return value, n


@borrowing
def _change(buf, n, end) -> tuple:
    """nil (NaN) or a finite double: a distance or direction change."""
    if is_nil(buf, n, end):
        return np.nan, n + 1
    return _finite(buf, n, end)


@borrowing
def _int_in(buf, n, end, lo, hi) -> tuple:
    """An int in [lo, hi]."""
    value, n = read_int(buf, n, end)
    if n == BAD or not lo <= value <= hi:
        return 0, BAD
    return value, n


@borrowing
def _optional_int_in(buf, n, end, lo, hi, none) -> tuple:
    """nil (``none``) or an int in [lo, hi]."""
    if is_nil(buf, n, end):
        return none, n + 1
    return _int_in(buf, n, end, lo, hi)


@borrowing
def _direction(buf, n, end) -> tuple:
    """An int direction in [-180, 180], as a float."""
    value, n = _int_in(buf, n, end, -180, 180)
    return float(value), n


@borrowing
def _optional_direction(buf, n, end) -> tuple:
    """nil (NaN) or an int direction (a player's facing)."""
    if is_nil(buf, n, end):
        return np.nan, n + 1
    return _direction(buf, n, end)


@borrowing
def _rows(buf, n, end, max_rows) -> tuple:
    """(rows, next) of an array header of at most ``max_rows`` elements."""
    rows, n = read_array(buf, n, end)
    if n == BAD or rows > max_rows:
        return 0, BAD
    return rows, n


@borrowing
def _row(buf, n, end, width) -> int:
    """Past the header of an array of exactly ``width`` elements (a row)."""
    size, n = read_array(buf, n, end)
    return n if n != BAD and size == width else BAD


@borrowing
def _landmark(buf, n, end, width, nameless) -> tuple:
    """(id, dist, direction, next): the header of a flag or line row of ``width`` values and the three
    they start with; a ``nameless`` (flag) row's id may be nil (-1)."""
    n = _row(buf, n, end, width)
    if n == BAD:
        return 0, 0.0, 0.0, BAD
    if nameless:
        landmark, n = _optional_int_in(buf, n, end, 0, MAX_LANDMARKS - 1, -1)
    else:
        landmark, n = _int_in(buf, n, end, 0, MAX_LANDMARKS - 1)
    if n == BAD:
        return 0, 0.0, 0.0, BAD
    dist, n = _non_negative(buf, n, end)
    if n == BAD:
        return 0, 0.0, 0.0, BAD
    direction, n = _direction(buf, n, end)
    return landmark, dist, direction, n


@borrowing
def _flags(buf, n, end, row, see, landmarks) -> int:
    """The flags: those with an id below ``landmarks`` into the flag rows (the id-less close flags and
    ids beyond the landmark table are skipped, as ``WorldModel.on_see`` skips them)."""
    rows, n = _rows(buf, n, end, MAX_LANDMARKS)
    kept = 0
    for _ in range(rows):
        flag, dist, direction, n = _landmark(buf, n, end, _FLAG_ROW, True)
        if n == BAD:
            return BAD
        for _change_field in range(2):
            _chg, n = _change(buf, n, end)
            if n == BAD:
                return BAD
        if 0 <= flag < landmarks:
            if kept == see.flag_id.shape[1]:  # on_see refuses it (a ValueError): leave it to that
                return BAD
            see.flag_id[row, kept] = flag
            see.flag_obs[row, kept, 0] = dist
            see.flag_obs[row, kept, 1] = direction
            kept += 1
    see.n_flags[row] = kept
    return n


@borrowing
def _lines(buf, n, end) -> int:
    """The lines: checked, not kept (the players localise by the flags)."""
    rows, n = _rows(buf, n, end, MAX_LANDMARKS)
    for _ in range(rows):
        _line, _dist, _direction_value, n = _landmark(buf, n, end, _LINE_ROW, False)
        if n == BAD:
            return BAD
    return n


@borrowing
def _sighting(buf, n, end) -> tuple:
    """(dist, direction, dist_chg, dir_chg, next): the four values a ball or player row starts with."""
    dist, n = _non_negative(buf, n, end)
    if n == BAD:
        return 0.0, 0.0, 0.0, 0.0, BAD
    direction, n = _direction(buf, n, end)
    if n == BAD:
        return 0.0, 0.0, 0.0, 0.0, BAD
    dist_chg, n = _change(buf, n, end)
    if n == BAD:
        return 0.0, 0.0, 0.0, 0.0, BAD
    dir_chg, n = _change(buf, n, end)
    return dist, direction, dist_chg, dir_chg, n


@borrowing
def _ball(buf, n, end, row, see) -> int:
    if is_nil(buf, n, end):
        see.ball_seen[row] = False
        return n + 1
    n = _row(buf, n, end, _BALL_ROW)
    if n == BAD:
        return BAD
    dist, direction, dist_chg, dir_chg, n = _sighting(buf, n, end)
    if n == BAD:
        return BAD
    see.ball_seen[row] = True
    see.ball_obs[row, 0] = dist
    see.ball_obs[row, 1] = direction
    see.ball_obs[row, 2] = dist_chg
    see.ball_obs[row, 3] = dir_chg
    return n


@borrowing
def _side(buf, n, end) -> tuple:
    """nil (NO_SIDE), "l" (0) or "r" (1)."""
    if is_nil(buf, n, end):
        return NO_SIDE, n + 1
    start, length, n = read_str(buf, n, end)
    if n == BAD:
        return NO_SIDE, BAD
    if str_equals(buf, start, length, _SIDE_L):
        return 0, n
    if str_equals(buf, start, length, _SIDE_R):
        return 1, n
    return NO_SIDE, BAD


@borrowing
def _players(buf, n, end, row, see) -> int:
    """The players, the first as many as the buffer holds kept (``on_see`` keeps as many)."""
    rows, n = _rows(buf, n, end, MAX_PLAYERS)
    kept = 0
    for _ in range(rows):
        n = _row(buf, n, end, _PLAYER_ROW)
        if n == BAD:
            return BAD
        side, n = _side(buf, n, end)
        if n == BAD:
            return BAD
        unum, n = _optional_int_in(buf, n, end, 1, MAX_UNUM, NO_UNUM)
        if n == BAD:
            return BAD
        dist, direction, dist_chg, dir_chg, n = _sighting(buf, n, end)
        if n == BAD:
            return BAD
        body, n = _optional_direction(buf, n, end)
        if n == BAD:
            return BAD
        head, n = _optional_direction(buf, n, end)
        if n == BAD:
            return BAD
        if kept < see.player_obs.shape[1]:
            see.player_side[row, kept] = side
            see.player_unum[row, kept] = unum
            obs = see.player_obs[row, kept]
            obs[0] = dist
            obs[1] = direction
            obs[2] = dist_chg
            obs[3] = dir_chg
            obs[4] = body
            obs[5] = head
            kept += 1
    see.n_players[row] = kept
    return n


@borrowing
def _name_index(buf, start, length, names, lengths) -> int:
    """The index in ``names`` (a :func:`_names` table, with its ``lengths``) of the str bytes
    ``buf[start:start + length]``; -1 for none."""
    for i in range(lengths.shape[0]):
        if lengths[i] == length:
            j = 0
            while j < length and buf[start + j] == names[i, j]:
                j += 1
            if j == length:
                return i
    return -1


@borrowing
def _name(buf, n, end, names, lengths) -> tuple:
    """(index, next) of a str that is one of ``names`` (as :func:`_name_index`)."""
    start, length, n = read_str(buf, n, end)
    if n == BAD:
        return -1, BAD
    index = _name_index(buf, start, length, names, lengths)
    return index, n if index >= 0 else BAD


@borrowing
def _view_mode(buf, n, end) -> int:
    """[quality, width]: checked, not kept (the players never change their view)."""
    n = _row(buf, n, end, 2)
    if n == BAD:
        return BAD
    _quality, n = _name(buf, n, end, _QUALITY_NAMES, _QUALITY_LENGTHS)
    if n == BAD:
        return BAD
    _width, n = _name(buf, n, end, _WIDTH_NAMES, _WIDTH_LENGTHS)
    return n


@borrowing
def _stamina(buf, n, end, values) -> int:
    """[stamina, effort, capacity]: the first two kept."""
    n = _row(buf, n, end, 3)
    if n == BAD:
        return BAD
    stamina, n = _non_negative(buf, n, end)
    if n == BAD:
        return BAD
    effort, n = _non_negative(buf, n, end)
    if n == BAD:
        return BAD
    _capacity, n = _finite(buf, n, end)
    values[STAMINA] = stamina
    values[EFFORT] = effort
    return n


@borrowing
def _speed(buf, n, end, values) -> int:
    """[amount, direction]."""
    n = _row(buf, n, end, 2)
    if n == BAD:
        return BAD
    amount, n = _non_negative(buf, n, end)
    if n == BAD:
        return BAD
    direction, n = _int_in(buf, n, end, -180, 180)
    values[SPEED_AMOUNT] = amount
    values[SPEED_DIRECTION] = direction
    return n


@borrowing
def _counts(buf, n, end) -> int:
    """The map of command counts: every command's once, ints >= 0; checked, not kept."""
    size, n = read_map(buf, n, end)
    if n == BAD or size != _COUNT_LENGTHS.shape[0]:
        return BAD
    seen = 0
    for _ in range(size):
        command, n = _name(buf, n, end, _COUNT_NAMES, _COUNT_LENGTHS)
        if n == BAD or seen & (1 << command):
            return BAD
        seen |= 1 << command
        _count, n = _int_in(buf, n, end, 0, MAX_CYCLE)
        if n == BAD:
            return BAD
    return n


@borrowing
def _collision(buf, n, end) -> int:
    """The collisions of the cycle, at most one per kind's count of names; checked, not kept."""
    size, n = _rows(buf, n, end, _COLLISION_LENGTHS.shape[0])
    for _ in range(size):
        _kind, n = _name(buf, n, end, _COLLISION_NAMES, _COLLISION_LENGTHS)
        if n == BAD:
            return BAD
    return n


@borrowing
def _text(buf, n, end, values) -> int:
    """A say's text: ASCII (so as many characters as bytes), at most MAX_TEXT_CHARS."""
    start, length, n = read_str(buf, n, end)
    if n == BAD or length > MAX_TEXT_CHARS:
        return BAD
    for i in range(start, start + length):
        if buf[i] >= _ASCII_END:
            return BAD
    values[TEXT_START] = start
    values[TEXT_LENGTH] = length
    return n


@borrowing
def decode_frame(buf: np.ndarray, end: int, row: int, see, landmarks: int, values: np.ndarray) -> tuple:
    """The frame ``buf[:end]``, if it is one this kernel takes (module docstring): (kind, cycle), the
    kind an index of :data:`FRAME_TYPES`. A see goes into row ``row`` of the see buffer ``see``
    (``agents.tracking.SeeBuffer``) as ``agents.percept_wire.see_into_buffer`` writes it (the flags with an
    id into the ``landmarks`` flags of init_ok's table, the ball, the players and last the cycle); a
    sense_body's and a hear's values into their slots of ``values`` (:data:`FRAME_VALUES` floats). Returns
    (:data:`NOT_TAKEN`, -1) for any other frame: then the see buffer's cycle is untouched (its rows and
    ``values`` are scratch) and the caller decodes the frame in full."""
    fields, n = read_map(buf, 0, end)
    if n == BAD:
        return NOT_TAKEN, -1
    seen = 0  # a bit per key, each once
    kind = NOT_TAKEN
    cycle = -1
    for _ in range(fields):
        start, length, n = read_str(buf, n, end)
        if n == BAD:
            return NOT_TAKEN, -1
        key = _name_index(buf, start, length, _KEY_NAMES, _KEY_LENGTHS)
        if key == _TYPE:
            kind, n = _name(buf, n, end, _TYPE_NAMES, _TYPE_LENGTHS)
        elif key == _CYCLE:
            cycle, n = _int_in(buf, n, end, 0, MAX_CYCLE)
        elif key == _FLAGS:
            n = _flags(buf, n, end, row, see, landmarks)
        elif key == _LINES:
            n = _lines(buf, n, end)
        elif key == _BALL:
            n = _ball(buf, n, end, row, see)
        elif key == _PLAYERS:
            n = _players(buf, n, end, row, see)
        elif key == _VIEW_MODE:
            n = _view_mode(buf, n, end)
        elif key == _STAMINA:
            n = _stamina(buf, n, end, values)
        elif key == _SPEED:
            n = _speed(buf, n, end, values)
        elif key == _HEAD_ANGLE:
            angle, n = _int_in(buf, n, end, -180, 180)
            values[HEAD_ANGLE] = angle
        elif key == _COUNTS:
            n = _counts(buf, n, end)
        elif key == _COLLISION:
            n = _collision(buf, n, end)
        elif key == _SENDER:
            sender, n = _name(buf, n, end, _SENDER_NAMES, _SENDER_LENGTHS)  # the referee's and the coach's: not taken
            values[SENDER] = sender
        elif key == _DIRECTION:
            _direction_value, n = _optional_int_in(buf, n, end, -180, 180, 0)
        elif key == _UNUM:
            _unum, n = _optional_int_in(buf, n, end, 1, MAX_UNUM, NO_UNUM)
        elif key == _MESSAGE:
            n = _text(buf, n, end, values)
        else:
            return NOT_TAKEN, -1
        if n == BAD or seen & (1 << key):
            return NOT_TAKEN, -1
        seen |= 1 << key
    if n != end or kind == NOT_TAKEN:  # trailing bytes, no type: the full decoder reports them
        return NOT_TAKEN, -1
    if seen & _REQUIRED[kind] != _REQUIRED[kind] or seen & ~_ALLOWED[kind]:
        return NOT_TAKEN, -1
    if kind == SEE:
        see.cycle[row] = cycle
    return kind, cycle


__all__ = ["EFFORT", "FRAME_TYPES", "FRAME_VALUES", "HEAD_ANGLE", "HEAR", "NOT_TAKEN", "NO_SIDE", "NO_UNUM",
           "SEE", "SENDER", "SENSE_BODY", "SIDE_CODES", "SPEED_AMOUNT", "SPEED_DIRECTION", "STAMINA", "TEXT_LENGTH",
           "TEXT_START", "THINK", "decode_frame"]
