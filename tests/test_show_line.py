"""The show line writer (server/game_log.py: ``ShowTable``, ``show_line``), which formats a whole show in
one ``%`` format of numbers quantized over arrays, pinned to the format's definition number by number:
a line computed by hand from rcssserver's format, and :func:`reference_line`, the specification written
the slow, obvious way, on random shows full of halfway values, signed zeros and extreme magnitudes."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from keepaway.core.cpp_text import LARGEST, SMALLEST, put_number
from keepaway.protocol.params import parameter_set
from keepaway.server.game_log import N_RCG_COUNTS, PlayerShow, Show, ShowTable, WorldShows, show_line
from keepaway.server.show_text import (
    ANGLE_PREC,
    PLAYER_NUMBERS,
    POS_PREC,
    STATE_BALL_COLLIDE,
    STATE_KICK,
    STATE_PLAYER_COLLIDE,
    STATE_STAND,
)
from keepaway.server.world import COLLIDED_BALL, COLLIDED_PLAYER, new_world

SLOTS = [(side, unum) for side in "lr" for unum in range(1, 12)]


def reference_line(show: Show) -> str:
    """A show line as rcssserver writes it, one number at a time: positions and velocities quantized to
    POS_PREC, angles to ANGLE_PREC (``Quantize``: ``rint(v / prec) * prec``, Python's ``round(x, 0)``
    rounding half to even), every number printed by a default C++ ostream (6 significant digits), the
    state in hex with ``showbase`` (0 bare), all 22 players, the absent ones parked at (-+3 unum, -37)."""
    def quantized(value: float, prec: float) -> str:
        return format(round(value / prec, 0) * prec, ".6g")

    def entry(p: PlayerShow) -> str:
        state = f"{p.state:#x}" if p.state else "0"
        pos = " ".join(quantized(v, POS_PREC) for v in (p.x, p.y, p.vx, p.vy))
        angles = " ".join(quantized(v, ANGLE_PREC) for v in (p.body, p.neck))
        stamina = " ".join(format(v, ".6g") for v in (p.stamina, p.effort, p.recovery, p.capacity))
        return (f" (({p.side} {p.unum}) 0 {state} {pos} {angles} (v h {quantized(p.view_angle, ANGLE_PREC)}) "
                f"(s {stamina}) (c {' '.join(map(str, p.counts))}))")

    by_id = {(p.side, p.unum): p for p in show.players}
    players = [by_id.get((side, unum)) or PlayerShow(side, unum, 0, (-3.0 if side == "l" else 3.0) * unum, -37.0,
                                                     0.0, 0.0, 0.0, 0.0, 360.0, 8000.0, 1.0, 1.0, 130600.0)
               for side, unum in SLOTS]
    ball = " ".join(quantized(v, POS_PREC) for v in show.ball)
    return f"(show {show.cycle} ((b) {ball})" + "".join(map(entry, players)) + ")"


def test_a_show_line_computed_by_hand():
    """Signed zeros, rounding to 6 digits and to the exponent form, a present player with state 0, all
    four state bits, a count of a million (an integer, never 1e+06), the players given out of order."""
    keeper = PlayerShow("l", 2, 0, 0.00016, -3.14159, 0.0, -0.0, 179.9996, -0.0004, 45.0, 3999.99, 0.9876543, 1.0,
                        -1.0, (1000000, 2, 3, 0, 0, 0, 0, 0, 0, 0, 7))
    taker = PlayerShow("r", 11, STATE_STAND | STATE_KICK | STATE_BALL_COLLIDE | STATE_PLAYER_COLLIDE, 12.345678,
                       -7.77777, 0.123456, -1.0, -90.0004, 0.0126, 180.0, 8000.0, 1e-5, 0.5, 130600.0)

    def parked(side: str, unum: int) -> str:
        return (f" (({side} {unum}) 0 0 {-3 * unum if side == 'l' else 3 * unum} -37 0 0 0 0 (v h 360) "
                f"(s 8000 1 1 130600) (c 0 0 0 0 0 0 0 0 0 0 0))")

    expected = ("(show 1234 ((b) -0 52.5 1.23457e+06 0)" + parked("l", 1)
                + " ((l 2) 0 0 0.0002 -3.1416 0 -0 180 -0 (v h 45) (s 3999.99 0.987654 1 -1) "
                  "(c 1000000 2 3 0 0 0 0 0 0 0 7))"
                + "".join(parked(side, unum) for side, unum in SLOTS[2:-1])
                + " ((r 11) 0 0xc03 12.3457 -7.7778 0.1235 -1 -90 0.013 (v h 180) (s 8000 1e-05 0.5 130600) "
                  "(c 0 0 0 0 0 0 0 0 0 0 0)))")
    show = Show(1234, (-0.00004, 52.49996, 1234567.8, 1e-7), (taker, keeper))
    assert show_line(show) == expected
    assert show_line(ShowTable.of(show)) == expected
    assert reference_line(show) == expected


def test_a_player_show_lists_its_numbers_in_the_order_the_table_takes_them():
    assert PlayerShow._fields[3:3 + len(PLAYER_NUMBERS)] == tuple(PLAYER_NUMBERS)
    assert PlayerShow._fields[3 + len(PLAYER_NUMBERS):] == ("counts",)


halfway = st.integers(-10**8, 10**8).flatmap(
    lambda k: st.sampled_from([(k + 0.5) * POS_PREC, (k + 0.5) * ANGLE_PREC, (k + 0.5) * 0.05, k + 0.5]))
numbers = st.one_of(
    halfway,
    st.floats(min_value=-60.0, max_value=60.0),
    st.floats(min_value=-1e-3, max_value=1e-3),
    st.floats(min_value=-1e300, max_value=1e300),
    st.sampled_from([0.0, -0.0, math.inf, -math.inf, math.nan, 5e-324, 999999.5, 1e-5, 130600.0]),
)
players = st.builds(
    lambda slot, state, values, counts: PlayerShow(*slot, state, *values, counts),
    st.sampled_from(SLOTS),
    st.sampled_from([0, STATE_STAND, STATE_STAND | STATE_KICK, 0x7, 0x401, 0x801, 0xc07]),
    st.tuples(*[numbers] * len(PLAYER_NUMBERS)),
    st.tuples(*[st.integers(0, 2**52)] * N_RCG_COUNTS),
)
shows = st.builds(Show, st.integers(0, 10**9), st.tuples(*[numbers] * 4), st.lists(players, max_size=30).map(tuple))


@settings(max_examples=150, deadline=None)
@given(shows)
def test_show_lines_are_the_reference_number_by_number(show):
    """Any show, its players in any order, some of them twice (the last counts): the line is the
    reference's, byte for byte."""
    assert show_line(show) == reference_line(show)


def test_quantizing_over_arrays_is_pythons_rounding_of_every_number():
    """A large sample: halfway values of every precision, both signs, any bit pattern (finite)."""
    rng = np.random.default_rng(7)
    k = rng.integers(-10**9, 10**9, 6_000).astype(float)
    bits = rng.integers(0, 2**63, 6_000, dtype=np.int64).view(np.float64)
    values = np.concatenate(((k + 0.5) * POS_PREC, (k + 0.5) * ANGLE_PREC, k + 0.5, rng.uniform(-60, 60, 6_000),
                             -rng.uniform(0, 1e-4, 6_000), bits[np.isfinite(bits) & (np.abs(bits) < 1e300)]))
    values = values[: len(values) // len(PLAYER_NUMBERS) * len(PLAYER_NUMBERS)].reshape(-1, len(PLAYER_NUMBERS))
    for row in values.tolist():
        show = Show(0, tuple(row[:4]), (PlayerShow("l", 1, STATE_STAND, *row),))
        assert show_line(show) == reference_line(show)


def test_a_world_table_writes_the_line_of_its_show():
    """The writers' path (the world's arrays straight to a table) and the readers' (its PlayerShows)
    give the same line, with kicks, collisions, view widths and a disabled player."""
    params = parameter_set("classic")
    world = new_world(params, 3, 2)
    rng = np.random.default_rng(3)
    world.enabled[0, 1:] = True
    world.enabled[0, 4] = False
    shows = WorldShows(world, params.visible_angle)
    for _ in range(50):
        world.pos[0] = rng.uniform(-30, 30, world.pos[0].shape).round(rng.integers(0, 6))
        world.vel[0] = rng.normal(0, 1, world.vel[0].shape)
        world.body[0], world.neck[0] = rng.uniform(-180, 180, (2, world.n_objects))
        world.stamina[0] = rng.uniform(0, 8000, world.n_objects)
        world.kicked[0] = rng.random(world.n_objects) < 0.3
        world.counts[0] += rng.integers(0, 2, world.counts[0].shape)
        world.collision[0] = rng.choice([0, COLLIDED_BALL, COLLIDED_PLAYER, COLLIDED_BALL | COLLIDED_PLAYER],
                                        world.n_objects)
        world.time[0] += 1
        factors = [1.0] + random.Random(int(world.time[0])).choices([0.5, 1.0, 2.0], k=world.n_objects - 1)
        table = shows.table(0, factors)
        assert show_line(table) == reference_line(table.show()) == show_line(ShowTable.of(table.show()))
        assert [p.view_angle for p in table.show().players] == [params.visible_angle * f for f in factors[1:]]


def test_a_table_with_players_out_of_order_is_refused():
    table = ShowTable.of(Show(0, (0.0,) * 4, (PlayerShow("l", 1, 1, *[0.0] * 6), PlayerShow("r", 1, 1, *[0.0] * 6))))
    with pytest.raises(ValueError, match="rcssserver's order"):
        show_line(table._replace(slots=table.slots[::-1]))


@njit(cache=False)
def _printed(values, out, ends):
    """Each value through the show kernel's number writer, back to back; a hole's end is -1."""
    at = 0
    for i in range(len(values)):
        ends[i] = put_number(out, at, values[i])
        if ends[i] >= 0:
            at = ends[i]
    return at


def test_the_number_writer_prints_what_printf_prints():
    """``%.6g`` of the exact double: halfway values n + 1/2 scaled by every power of ten the writer
    uses and the doubles either side of them (where a rounding decided on a rounded product would go
    wrong), quantized positions and angles, random bit patterns and magnitudes; beyond its range, holes."""
    rng = np.random.default_rng(11)
    n = 20_000
    ties = (rng.integers(100_000, 1_000_000, n) + 0.5) * 10.0 ** -rng.integers(-21, 21, n).astype(float)
    bits = rng.integers(0, 2**63, n, dtype=np.int64).view(np.float64)
    values = np.concatenate((
        ties, np.nextafter(ties, np.inf), np.nextafter(ties, -np.inf),
        np.rint(rng.uniform(-60, 60, n) / POS_PREC) * POS_PREC,
        np.rint(rng.uniform(-180, 180, n) / ANGLE_PREC) * ANGLE_PREC,
        bits[np.isfinite(bits)], 10.0 ** rng.uniform(-17, 27, n) * rng.choice([-1.0, 1.0], n),
        [0.0, -0.0, 1e-5, 1e-4, 999999.5, 9999995.0, 0.000999995, 130600.0, SMALLEST, np.nextafter(SMALLEST, 0.0),
         LARGEST, np.nextafter(LARGEST, 0.0), 5e-324, math.inf, -math.inf, math.nan]))
    out = np.zeros(16 * len(values), np.uint8)
    ends = np.zeros(len(values), np.int64)
    text = out[:_printed(values, out, ends)].tobytes().decode("ascii")
    at = 0
    printed = holes = 0
    for value, end in zip(values.tolist(), ends.tolist()):
        if end < 0:
            assert not SMALLEST <= abs(value) < LARGEST or value != value, value
            holes += 1
            continue
        assert text[at:end] == format(value, ".6g"), value
        at = end
        printed += 1
    assert printed > 100_000 and holes > 1_000
