"""A ``see`` frame of our server written as rcssserver's text by a compiled kernel, byte for byte as
:func:`keepaway.rcss.render.see` writes the message the frame holds.

A text client's see is the percept the front writes most (about two of every three cycles, each with some
fifty flags): decoding the frame into Python values and formatting each number took about 40 us a see,
a fifth of the time a cycle of five C++ players spends in the front (docs/design.md, "rcssserver's
protocol: the front"). Here one kernel reads the frame (``core.msgpack_in``) and writes the text
(``core.cpp_text``: ``%.6g`` and ``%d`` as C prints them), about 8 us.

It takes the frames our server writes (``server.percept_wire.write_see``: the map's fields in the order
of ``protocol.messages.See``, rows of the lengths that module writes) with numbers C's formats print the
way Python's do; for any other frame (another layout, a number ``put_number`` leaves to Python, an id
beyond the names) it returns :data:`NOT_WRITTEN` and the caller renders the decoded message in Python,
which writes the same text or fails as before. ``tests/test_rcss_render.py`` checks both ways agree.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from keepaway.core.cpp_text import put_number, put_text, put_whole
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

NOT_WRITTEN = -1
"""What :func:`write_see` returns for a frame it leaves to the Python renderer."""
MAX_SEE_BYTES = 16384  # a see of every flag, line and 22 players at the longest numbers is below 8,000
SEE_FRAME_START = b"\x86\xa4type\xa3see"
"""How our server's see frames begin (a map of six fields, the type first): the others need no kernel call."""

_KEYS = tuple(ascii(key) for key in ("type", "see", "cycle", "flags", "lines", "ball", "players"))
_L, _R = ascii("l"), ascii("r")
_SEE = ascii("(see ")
_SPACE, _CLOSE = (ord(c) for c in " )")
_NUMBER_BYTES = 21  # a space and the longest number: an int64's 20 characters (put_number's are fewer)
# the names a see writes, besides the landmarks' (TextView.flag_names, line_names)
_ANONYMOUS_FLAG, _NEAR_BALL, _BALL, _NEAR_PLAYER, _PLAYER = (ascii(f"(({name}) ") for name in ("F", "B", "b", "P", "p"))


class SeeNames(NamedTuple):
    """A view's names as the kernel writes them: ``((NAME) `` of each flag id, then of each line id, then
    ``((p "TEAM"`` of side l and of side r, one after another in ``text``, the i-th from ``starts[i]``
    to ``starts[i + 1]``; and the view's far lengths."""

    text: np.ndarray  # uint8
    starts: np.ndarray  # int64
    n_flags: int
    n_lines: int
    unum_far_length: float
    team_far_length: float
    row_bytes: int  # the most a row's text takes: the longest name and six numbers

    @classmethod
    def of(cls, flag_names: tuple[str, ...], line_names: tuple[str, ...], team_names: tuple[str, str],
           unum_far_length: float, team_far_length: float) -> SeeNames:
        """The names of a view (``rcss.render.TextView``'s fields of these names)."""
        names = [f"(({name}) " for name in flag_names + line_names] + [f'((p "{team}"' for team in team_names]
        encoded = [name.encode("latin-1") for name in names]
        starts = np.cumsum([0] + [len(name) for name in encoded]).astype(np.int64)
        row_bytes = 2 + max(len(name) for name in encoded) + 7 * _NUMBER_BYTES
        return cls(np.frombuffer(b"".join(encoded), np.uint8).copy(), starts, len(flag_names), len(line_names),
                   float(unum_far_length), float(team_far_length), row_bytes)



@borrowing
def _key(frame, n, end, key) -> int:
    start, length, n = read_str(frame, n, end)
    if n == BAD or not str_equals(frame, start, length, key):
        return BAD
    return n


@borrowing
def _rows(frame, n, end, key) -> tuple:
    """(rows, next) of the array of rows that follows ``key``; next is BAD if either is not there."""
    n = _key(frame, n, end, key)
    if n == BAD:
        return 0, BAD
    return read_array(frame, n, end)


@borrowing
def _name(out, at, names, i) -> int:
    return put_text(out, at, names.text, names.starts[i], names.starts[i + 1])


@borrowing
def _value(frame, n, end, out, at, doubles) -> tuple:
    """One number of a row as ``_seen`` writes it: an int as ``%d`` (unless ``doubles``: a flag's changes
    are ``%.6g`` whatever they are), a double as ``%.6g``, after a space; nil writes nothing. (next, end
    of text); next is BAD for anything else or a number left to Python."""
    if is_nil(frame, n, end):
        return n + 1, at
    value, m = read_int(frame, n, end)
    if m != BAD:
        if doubles:
            return BAD, at
        out[at] = _SPACE
        return m, put_whole(out, at + 1, value)
    x, m = read_double(frame, n, end)
    if m == BAD:
        return BAD, at
    out[at] = _SPACE
    written = put_number(out, at + 1, x)
    return (BAD, at) if written < 0 else (m, written)


@borrowing
def _number(frame, n, end) -> tuple:
    """(value, next) of an int or double, for a comparison with a far length."""
    value, m = read_int(frame, n, end)
    if m != BAD:
        return float(value), m
    return read_double(frame, n, end)


@borrowing
def _values(frame, n, end, out, at, count, doubles) -> tuple:
    """``count`` numbers of a row (:func:`_value`), then the row's ``)``."""
    for _ in range(count):
        n, at = _value(frame, n, end, out, at, doubles)
        if n == BAD:
            return BAD, at
    out[at] = _CLOSE
    return n, at + 1


@borrowing
def _landmark(frame, n, end, out, at, names, first, count, width) -> tuple:
    """A flag row ``[id|nil, dist, dir, dist_chg, dir_chg]`` (width 5) or a line row ``[id, dist, dir]``
    (width 3): its name (flags ``first`` 0, lines after the flags) and numbers; a nameless flag is ``F``."""
    size, n = read_array(frame, n, end)
    if n == BAD or size != width:
        return BAD, at
    out[at] = _SPACE
    at += 1
    if width == 5 and is_nil(frame, n, end):
        at = put_text(out, at, _ANONYMOUS_FLAG)
        n += 1
    else:
        i, n = read_int(frame, n, end)
        if n == BAD or not 0 <= i < count:
            return BAD, at
        at = _name(out, at, names, first + i)
    at -= 1  # the name's trailing space: _value writes one before each number
    # the landmark rows' distance is %.6g and direction %d (render.see), whatever their types in the frame
    dist, n = read_double(frame, n, end)
    if n == BAD:
        return BAD, at
    out[at] = _SPACE
    at = put_number(out, at + 1, dist)
    direction, n = read_int(frame, n, end)
    if at < 0 or n == BAD:
        return BAD, at
    out[at] = _SPACE
    at = put_whole(out, at + 1, direction)
    return _values(frame, n, end, out, at, width - 3, True)


@borrowing
def write_see(frame, end: int, names: SeeNames, out) -> int:
    """The text of see ``frame[:end]`` into ``out`` (at least :data:`MAX_SEE_BYTES`); its length, or
    :data:`NOT_WRITTEN` (module docstring), also when ``out`` has no room for it. Flags, the ball, players,
    then lines, as :func:`render.see`."""
    room = out.shape[0] - 1  # the last byte: the see's closing parenthesis
    if room < _NUMBER_BYTES + 5:  # "(see CYCLE"
        return NOT_WRITTEN
    size, n = read_map(frame, 0, end)
    if n == BAD or size != 6:
        return NOT_WRITTEN
    for i in range(3):  # "type" "see" "cycle"
        if n != BAD:
            n = _key(frame, n, end, _KEYS[i])
    if n == BAD:  # (a reader given BAD would read the frame's last byte)
        return NOT_WRITTEN
    cycle, n = read_int(frame, n, end)
    if n == BAD:
        return NOT_WRITTEN
    at = put_whole(out, put_text(out, 0, _SEE), cycle)
    rows, n = _rows(frame, n, end, _KEYS[3])
    for _ in range(rows):
        if n == BAD or at + names.row_bytes > room:
            return NOT_WRITTEN
        n, at = _landmark(frame, n, end, out, at, names, 0, names.n_flags, 5)
    if n == BAD:
        return NOT_WRITTEN
    lines_at = _key(frame, n, end, _KEYS[4])  # written last
    rows, n = _rows(frame, n, end, _KEYS[4])
    for _ in range(rows):  # skipped: [id, dist, dir], as _landmark reads them
        size, n = read_array(frame, n, end)
        if n == BAD or size != 3:
            return NOT_WRITTEN
        _, n = read_int(frame, n, end)
        if n != BAD:
            _, n = _number(frame, n, end)
        if n != BAD:
            _, n = read_int(frame, n, end)
    if n == BAD:
        return NOT_WRITTEN
    n = _key(frame, n, end, _KEYS[5])
    if n == BAD:
        return NOT_WRITTEN
    if is_nil(frame, n, end):
        n += 1
    else:
        size, n = read_array(frame, n, end)
        if n == BAD or size != 4 or at + names.row_bytes > room:
            return NOT_WRITTEN
        dist, m = _number(frame, n, end)
        if m == BAD:
            return NOT_WRITTEN
        _, m = _number(frame, m, end)  # direction
        close = m != BAD and is_nil(frame, m, end) and dist <= names.unum_far_length
        out[at] = _SPACE
        at = put_text(out, at + 1, _NEAR_BALL if close else _BALL) - 1
        n, at = _values(frame, n, end, out, at, 4, False)
        if n == BAD:
            return NOT_WRITTEN
    rows, n = _rows(frame, n, end, _KEYS[6])
    for _ in range(rows):
        if n == BAD or at + names.row_bytes > room:
            return NOT_WRITTEN
        size, n = read_array(frame, n, end)
        if n == BAD or size != 8:
            return NOT_WRITTEN
        out[at] = _SPACE
        at += 1
        if is_nil(frame, n, end):  # no side: P near, p far (render._player_name)
            n += 1
            if not is_nil(frame, n, end):
                return NOT_WRITTEN
            dist, m = _number(frame, n + 1, end)
            if m == BAD:
                return NOT_WRITTEN
            at = put_text(out, at, _NEAR_PLAYER if dist <= names.team_far_length else _PLAYER) - 1
            n += 1
        else:
            start, length, n = read_str(frame, n, end)
            if n == BAD:
                return NOT_WRITTEN
            if str_equals(frame, start, length, _L):
                at = _name(out, at, names, names.n_flags + names.n_lines)
            elif str_equals(frame, start, length, _R):
                at = _name(out, at, names, names.n_flags + names.n_lines + 1)
            else:
                return NOT_WRITTEN
            if is_nil(frame, n, end):
                n += 1
            else:
                unum, n = read_int(frame, n, end)
                if n == BAD:
                    return NOT_WRITTEN
                out[at] = _SPACE
                at = put_whole(out, at + 1, unum)
            out[at] = _CLOSE
            at += 1
        if is_nil(frame, n, end):  # a player's distance: render.see would write its row without it
            return NOT_WRITTEN
        n, at = _values(frame, n, end, out, at, 6, False)
        if n == BAD:
            return NOT_WRITTEN
    if n != end:
        return NOT_WRITTEN
    rows, n = read_array(frame, lines_at, end)
    for _ in range(rows):
        if at + names.row_bytes > room:
            return NOT_WRITTEN
        n, at = _landmark(frame, n, end, out, at, names, names.n_flags, names.n_lines, 3)
        if n == BAD:
            return NOT_WRITTEN
    out[at] = _CLOSE
    return at + 1


def compile_kernel() -> None:
    """Compile (or load from numba's cache) :func:`write_see`, so that no client's first see waits for it."""
    names = SeeNames(np.zeros(1, np.uint8), np.zeros(2, np.int64), 1, 0, 0.0, 0.0, 0)
    write_see(b"", 0, names, np.zeros(MAX_SEE_BYTES, np.uint8))


__all__ = ["MAX_SEE_BYTES", "NOT_WRITTEN", "SEE_FRAME_START", "SeeNames", "compile_kernel", "write_see"]
