"""A ``see`` frame straight from its msgpack bytes into the world model's see buffer, compiled.

A player decodes a see on two cycles of three, the largest message it gets. Through the full decoder it
goes msgpack -> dict and lists -> validated ``protocol.messages.See`` -> the buffer rows
(``WorldModel.on_see``), Python all the way: the largest share of a player process's time in the
distributed mode (``py-spy``, docs/design.md "Processes and sockets"). :func:`decode_see_frame` reads
the same bytes once, in a kernel, into the rows ``on_see`` would write.

It takes exactly the sees that the full decoder's fast path takes as they are (``protocol.codec.rows``
and the ``_seen_*`` row tests of ``protocol.messages``): a map of the six fields, each once; rows of the
right length whose numbers are doubles (distances >= 0), whose directions, ids and unums are ints in
range and whose sides are "l" or "r", with nil where the message allows it; at most as many flags with
an id as the buffer holds. For any other frame, valid or not, it returns -1 and the caller decodes the
frame in full, which takes it or reports what is wrong exactly as before. So a frame gives the same
world model either way (``tests/test_see_frame.py`` checks the rows against ``on_see`` and every
refusal against the full decoder).
"""

from __future__ import annotations

import numpy as np

from core.jit import borrowing
from core.msgpack_in import (
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
from protocol.messages import MAX_CYCLE, MAX_LANDMARKS, MAX_PLAYERS, MAX_UNUM, SIDES

SIDE_CODES = {side: code for code, side in enumerate(SIDES)}  # the see buffer's side codes: l 0, r 1
NO_SIDE = -1  # a player seen without its side
NO_UNUM = 0  # ... without its uniform number

_KEY_TYPE, _KEY_CYCLE, _KEY_FLAGS = ascii("type"), ascii("cycle"), ascii("flags")
_KEY_LINES, _KEY_BALL, _KEY_PLAYERS = ascii("lines"), ascii("ball"), ascii("players")
_SEE = ascii("see")
_SIDE_L, _SIDE_R = ascii(SIDES[0]), ascii(SIDES[1])
_FIELDS = 6
_FLAG_ROW, _LINE_ROW, _BALL_ROW, _PLAYER_ROW = 5, 3, 4, 8
_MAX_DOUBLE = np.finfo(np.float64).max


@borrowing
def _distance(buf, n, end) -> tuple:
    """A double in [0, max] (not NaN or infinite): a seen distance."""
    value, n = read_double(buf, n, end)
    if n == BAD or not 0.0 <= value <= _MAX_DOUBLE:
        return 0.0, BAD
    return value, n


@borrowing
def _change(buf, n, end) -> tuple:
    """nil (NaN) or a finite double: a distance or direction change."""
    if is_nil(buf, n, end):
        return np.nan, n + 1
    value, n = read_double(buf, n, end)
    if n == BAD or not -_MAX_DOUBLE <= value <= _MAX_DOUBLE:
        return 0.0, BAD
    return value, n


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
    dist, n = _distance(buf, n, end)
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
    dist, n = _distance(buf, n, end)
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
def decode_see_frame(buf: np.ndarray, end: int, row: int, see, landmarks: int) -> int:
    """The see frame ``buf[:end]`` into row ``row`` of the see buffer ``see``
    (``agents.worldmodel.SeeBuffer``): the flags with an id into the ``landmarks`` flags of init_ok's
    table, the ball, the players and last the cycle, as ``WorldModel.on_see`` writes them. Returns the cycle, or -1 if the frame is not one this kernel takes
    (module docstring); then the row's cycle is untouched and the caller decodes the frame in full."""
    fields, n = read_map(buf, 0, end)
    if n == BAD or fields != _FIELDS:
        return -1
    seen = 0  # a bit per field, each once
    cycle = -1
    for _ in range(fields):
        start, length, n = read_str(buf, n, end)
        if n == BAD:
            return -1
        if str_equals(buf, start, length, _KEY_TYPE):
            bit = 1
            start, length, n = read_str(buf, n, end)
            if n == BAD or not str_equals(buf, start, length, _SEE):
                return -1
        elif str_equals(buf, start, length, _KEY_CYCLE):
            bit = 2
            cycle, n = _int_in(buf, n, end, 0, MAX_CYCLE)
        elif str_equals(buf, start, length, _KEY_FLAGS):
            bit = 4
            n = _flags(buf, n, end, row, see, landmarks)
        elif str_equals(buf, start, length, _KEY_LINES):
            bit = 8
            n = _lines(buf, n, end)
        elif str_equals(buf, start, length, _KEY_BALL):
            bit = 16
            n = _ball(buf, n, end, row, see)
        elif str_equals(buf, start, length, _KEY_PLAYERS):
            bit = 32
            n = _players(buf, n, end, row, see)
        else:
            return -1
        if n == BAD or seen & bit:
            return -1
        seen |= bit
    if n != end:  # trailing bytes: the full decoder reports them
        return -1
    see.cycle[row] = cycle
    return cycle


__all__ = ["NO_SIDE", "NO_UNUM", "SIDE_CODES", "decode_see_frame"]
