"""A show line of the game log written by a kernel: rcssserver's v5 ``(show ...)`` text straight from a
world's arrays or a table of numbers (``server.game_log`` holds the format's other lines and the files).

Why a kernel: the show line is the game log's cost, paid every cycle by the server's one thread and by
the embedded mode. Built in Python (a table from the world with numpy, then one ``%`` format of about
110 numbers) it took about 90 us a cycle, the game log's step 125 us, a tenth of the embedded mode's
time; here the table takes about 9 us and the line 16 us (the kernel itself 8 us, 75 ns a number).

**The numbers.** rcssserver quantizes positions and velocities to ``POS_PREC`` and angles to
``ANGLE_PREC`` (``Quantize``: ``rint(value / prec) * prec``) and prints every number as a default C++
ostream does, ``%.6g`` (``core.cpp_text``). A number that writer leaves to Python (NaN, an infinity, a
magnitude outside [``core.cpp_text.SMALLEST``, ``LARGEST``)), and a count that is not a whole number below 2^53, is left
as a *hole*: the kernel writes nothing there and records where it goes, and
:func:`server.game_log.show_line` fills it with Python's format of the same number (never in a game:
tests/test_show_line.py makes them).

**The players.** A show lists all 22 players in rcssserver's order (``l 1`` to ``l 11``, then ``r 1`` to
``r 11``: slots 0 to 21); a table holds the players on the pitch, each with its slot, and the others are
written from ``parked``, their entries' text made once by this same kernel.
"""

from __future__ import annotations

import math

import numpy as np

from keepaway.core.cpp_text import put_number, put_text, put_whole
from keepaway.core.jit import borrowing
from keepaway.protocol.params import MAX_TEAM_SIZE
from keepaway.server.world import COLLIDED_BALL, COLLIDED_PLAYER, COUNT_KICK, N_COUNTS

MAX_UNUM = MAX_TEAM_SIZE  # players per side in every show (rcssserver's MAX_PLAYER)
N_SLOTS = 2 * MAX_UNUM
N_RCG_COUNTS = 11  # kick dash turn catch move turn_neck change_view say tackle pointto attentionto
POS_PREC = 0.0001  # rcssserver's SerializerMonitorStdv3::PREC (positions, velocities)
ANGLE_PREC = 0.001  # ... DPREC (body, neck, view angle)
# A player's numbers in a show, in PlayerShow's order, each with the precision rcssserver quantizes it to
# (SerializerMonitorStdv3) or None
PLAYER_NUMBERS = {"x": POS_PREC, "y": POS_PREC, "vx": POS_PREC, "vy": POS_PREC, "body": ANGLE_PREC,
                  "neck": ANGLE_PREC, "view_angle": ANGLE_PREC, "stamina": None, "effort": None, "recovery": None,
                  "capacity": None}
N_NUMBERS = len(PLAYER_NUMBERS)
_VIEW_AT = list(PLAYER_NUMBERS).index("view_angle")  # the numbers that open "(v h" and "(s"
_STAMINA_AT = list(PLAYER_NUMBERS).index("stamina")
N_ROW = N_NUMBERS + N_RCG_COUNTS  # a player's numbers in a table row

# Player state bits (rcssserver's PlayerState)
STATE_DISABLE = 0x0
STATE_STAND = 0x1
STATE_KICK = 0x2
STATE_KICK_FAULT = 0x4
STATE_BALL_COLLIDE = 0x400
STATE_PLAYER_COLLIDE = 0x800

MAX_LINE_BYTES = 16384  # a line of 22 players at the longest numbers is below 9,000
MAX_HOLES = 4 + N_SLOTS * N_ROW  # every number of a line
HOLE_NUMBER, HOLE_COUNT = 0, 1  # a hole's kind: a %.6g number, a %d count
BAD_ORDER = -1  # write_show's length when the table's slots are not increasing within 0..21

_PRECS = np.array([np.nan if prec is None else prec for prec in PLAYER_NUMBERS.values()])
_WHOLE_LIMIT = 2.0 ** 53


def _text(text: str) -> np.ndarray:
    return np.frombuffer(text.encode("ascii"), np.uint8).copy()


_SHOW = _text("(show ")
_BALL = _text(" ((b)")
_ENTRY = _text(" ((")
_SIDES = _text("lr")
_STATE = _text(") 0 ")
_VIEW = _text(" (v h ")
_STAMINA = _text(") (s ")
_COUNTS = _text(") (c ")
_END = _text("))")
_HEX = _text("0123456789abcdef")
_SPACE, _MINUS, _ZERO, _X, _CLOSE = (ord(c) for c in " -0x)")


@borrowing
def _hole(holes, n_holes, at, x, kind) -> tuple:
    """A number left to the caller, recorded where it goes: (end, holes), the end unmoved."""
    holes[n_holes, 0] = at
    holes[n_holes, 1] = x
    holes[n_holes, 2] = kind
    return at, n_holes + 1


@borrowing
def _put_value(out, at, x, holes, n_holes) -> tuple:
    """A number, or a hole where it goes: (end, holes)."""
    end = put_number(out, at, x)
    if end < 0:
        return _hole(holes, n_holes, at, x, HOLE_NUMBER)
    return end, n_holes


@borrowing
def _put_count(out, at, x, holes, n_holes) -> tuple:
    """A count (%d of a whole float), or a hole: (end, holes)."""
    if abs(x) < _WHOLE_LIMIT and math.floor(x) == x:
        return put_whole(out, at, np.int64(x)), n_holes
    return _hole(holes, n_holes, at, x, HOLE_COUNT)


@borrowing
def _put_state(out, at, state) -> int:
    """rcssserver's ``std::hex << std::showbase``: 0 bare, else 0x and lower-case digits (as Python's
    ``#x``, a minus sign first for a negative state, which no game has)."""
    if state < 0:
        out[at] = _MINUS
        at += 1
        state = -state
    if state == 0:
        out[at] = _ZERO
        return at + 1
    out[at] = _ZERO
    out[at + 1] = _X
    at += 2
    shift = 0
    while state >> (shift + 4) > 0:
        shift += 4
    while shift >= 0:
        out[at] = _HEX[(state >> shift) & 15]
        at += 1
        shift -= 4
    return at


@borrowing
def write_show(out, entry_at, holes, cycle, ball, n_players, slots, states, rows, parked, parked_at) -> tuple:
    """The show line of ``cycle`` into ``out``: the ball's (x, y, vx, vy), the ``n_players`` players of
    ``rows`` (the table's PLAYER_NUMBERS then N_RCG_COUNTS counts, as floats) in slots ``slots``
    (increasing, 0..21) with states ``states``, every other slot's entry copied from ``parked`` (slot s's text is
    ``parked[parked_at[s]:parked_at[s + 1]]``). Returns (length, holes): the holes (offset, value,
    kind) are in ``holes[:holes]``; ``entry_at[s]`` is where slot s's entry starts (``entry_at[22]``:
    the final parenthesis). Length BAD_ORDER, nothing else valid, if the slots are out of order."""
    for p in range(n_players):
        if not (0 <= slots[p] < N_SLOTS and (p == 0 or slots[p] > slots[p - 1])):
            return BAD_ORDER, 0
    at = put_text(out, 0, _SHOW)
    at = put_whole(out, at, cycle)
    at = put_text(out, at, _BALL)
    n_holes = 0
    for i in range(4):
        out[at] = _SPACE
        at, n_holes = _put_value(out, at + 1, np.rint(ball[i] / POS_PREC) * POS_PREC, holes, n_holes)
    out[at] = _CLOSE
    at += 1
    p = 0
    for slot in range(N_SLOTS):
        entry_at[slot] = at
        if p >= n_players or slots[p] != slot:
            at = put_text(out, at, parked, parked_at[slot], parked_at[slot + 1])
            continue
        at = put_text(out, at, _ENTRY)
        out[at] = _SIDES[slot // MAX_UNUM]
        out[at + 1] = _SPACE
        at = put_whole(out, at + 2, slot % MAX_UNUM + 1)
        at = put_text(out, at, _STATE)
        at = _put_state(out, at, states[p])
        for i in range(N_NUMBERS):
            if i == _VIEW_AT:
                at = put_text(out, at, _VIEW)
            elif i == _STAMINA_AT:
                at = put_text(out, at, _STAMINA)
            else:
                out[at] = _SPACE
                at += 1
            prec = _PRECS[i]
            value = rows[p, i] if np.isnan(prec) else np.rint(rows[p, i] / prec) * prec
            at, n_holes = _put_value(out, at, value, holes, n_holes)
        at = put_text(out, at, _COUNTS)
        for i in range(N_RCG_COUNTS):
            if i > 0:
                out[at] = _SPACE
                at += 1
            at, n_holes = _put_count(out, at, rows[p, N_NUMBERS + i], holes, n_holes)
        at = put_text(out, at, _END)
        p += 1
    entry_at[N_SLOTS] = at
    out[at] = _CLOSE
    return at + 1, n_holes


@borrowing
def world_table(w, b, factors, visible_angle, last_kicks, ball, states, rows) -> None:
    """Arena ``b`` of world ``w`` as a show table: the ball's numbers into ``ball``, each player's state
    and row into ``states`` and ``rows`` (player object o in row o - 1), its view angle
    ``visible_angle * factors[o]``. A kick that did not reach the ball is ``KICK | KICK_FAULT``, as in
    rcssserver: the world marks every kick command (``w.kicked``) but counts only those that reached the
    ball, so ``last_kicks`` (the kick counts at the previous show, updated here) tells them apart."""
    ball[0] = w.pos[b, 0, 0]
    ball[1] = w.pos[b, 0, 1]
    ball[2] = w.vel[b, 0, 0]
    ball[3] = w.vel[b, 0, 1]
    for o in range(1, w.pos.shape[1]):
        p = o - 1
        state = STATE_STAND if w.enabled[b, o] else STATE_DISABLE
        kicks = w.counts[b, o, COUNT_KICK]
        if w.kicked[b, o]:
            state |= STATE_KICK | (STATE_KICK_FAULT if kicks == last_kicks[b, o] else 0)
        if w.collision[b, o] & COLLIDED_BALL:
            state |= STATE_BALL_COLLIDE
        if w.collision[b, o] & COLLIDED_PLAYER:
            state |= STATE_PLAYER_COLLIDE
        states[p] = state
        row = (w.pos[b, o, 0], w.pos[b, o, 1], w.vel[b, o, 0], w.vel[b, o, 1], w.body[b, o], w.neck[b, o],
               visible_angle * factors[o], w.stamina[b, o], w.effort[b, o], w.recovery[b, o], w.capacity[b, o])
        for i in range(N_NUMBERS):
            rows[p, i] = row[i]
        for i in range(N_RCG_COUNTS):
            rows[p, N_NUMBERS + i] = w.counts[b, o, i] if i < N_COUNTS else 0
    for o in range(w.pos.shape[1]):
        last_kicks[b, o] = w.counts[b, o, COUNT_KICK]


__all__ = [
    "ANGLE_PREC", "BAD_ORDER", "HOLE_COUNT", "HOLE_NUMBER", "MAX_HOLES", "MAX_LINE_BYTES", "MAX_UNUM",
    "N_NUMBERS", "N_ROW", "N_RCG_COUNTS", "N_SLOTS", "PLAYER_NUMBERS", "POS_PREC", "STATE_BALL_COLLIDE",
    "STATE_DISABLE", "STATE_KICK", "STATE_KICK_FAULT", "STATE_PLAYER_COLLIDE", "STATE_STAND", "world_table",
    "write_show",
]
