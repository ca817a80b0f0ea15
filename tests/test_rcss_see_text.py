"""The see kernel (``rcss.see_text``): for any frame it writes exactly what ``rcss.render.see`` writes for
the message the frame holds, or leaves the frame to it; it never writes past its buffer. (The recorded
rcssserver sees of tests/test_rcss_render.py go through the kernel too.)"""

from __future__ import annotations

import math

import msgpack
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from keepaway.protocol import messages as m
from keepaway.protocol.codec import encode
from keepaway.protocol.landmarks import FLAGS, LINES
from keepaway.rcss import render
from keepaway.rcss.front import percept
from keepaway.rcss.see_text import MAX_SEE_BYTES, NOT_WRITTEN, SEE_FRAME_START, SeeNames, write_see

VIEW = render.TextView(19.0, "l", ("keepers", "takers"), tuple(flag.name for flag in FLAGS),
                       tuple(line.name for line in LINES), unum_far_length=20.0, team_far_length=40.0)
NAMES = SeeNames.of(*VIEW.names)
FUZZ = settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def kernel_text(frame: bytes, out_bytes: int = MAX_SEE_BYTES) -> str | None:
    out = np.zeros(out_bytes + 64, np.uint8)
    out[out_bytes:] = 7  # a guard: the kernel gets out[:out_bytes] and must not write beyond it
    n = write_see(frame, len(frame), NAMES, out[:out_bytes])
    assert (out[out_bytes:] == 7).all(), "written past the buffer"
    return None if n == NOT_WRITTEN else out[:n].tobytes().decode("latin-1")


def python_text(frame: bytes) -> str | None:
    try:
        return render.see(percept(frame), VIEW)
    except Exception:
        return None


def check(frame: bytes) -> str | None:
    """The kernel's text is render.see's, or it leaves the frame (then render.see decides)."""
    ours = kernel_text(frame)
    if ours is not None:
        assert ours == python_text(frame)
    return ours


NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**63, 2**63 - 1),
                    st.sampled_from([0.0, -0.0, 1e-16, 9.999995e-5, 0.5, 2.5, 123456.5, 1e26, 1e-17, 18.2]))
DISTANCES = st.one_of(st.floats(0, 200), st.sampled_from([0.0, 19.99, 20.0, 20.01, 40.0, 40.5, 1e30]))
DIRECTIONS = st.one_of(st.integers(-180, 180), st.integers(-2**40, 2**40), st.floats(-180, 180))
CHANGES = st.one_of(st.none(), st.floats(-50, 50), NUMBERS)
FLAG_ROWS = st.tuples(st.one_of(st.none(), st.integers(-2, len(FLAGS) + 1)), DISTANCES, DIRECTIONS, CHANGES, CHANGES)
LINE_ROWS = st.tuples(st.integers(-1, len(LINES)), DISTANCES, DIRECTIONS)
BALL = st.one_of(st.none(), st.tuples(DISTANCES, DIRECTIONS, CHANGES, CHANGES))
PLAYER_ROWS = st.tuples(st.sampled_from([None, "l", "r", "x"]), st.one_of(st.none(), st.integers(0, 12)),
                        st.one_of(DISTANCES, st.none()), DIRECTIONS, CHANGES, CHANGES,
                        st.one_of(st.none(), DIRECTIONS), st.one_of(st.none(), DIRECTIONS))


def frame_of(cycle, flags, lines, ball, players) -> bytes:
    return msgpack.packb({"type": "see", "cycle": cycle, "flags": flags, "lines": lines, "ball": ball,
                          "players": players}, use_bin_type=True)


@FUZZ
@given(st.integers(0, 2**40), st.lists(FLAG_ROWS, max_size=60), st.lists(LINE_ROWS, max_size=4), BALL,
       st.lists(PLAYER_ROWS, max_size=22))
def test_any_see_frame_is_written_as_render_writes_it_or_left_to_it(cycle, flags, lines, ball, players):
    check(frame_of(cycle, flags, lines, ball, players))


# what a game's see holds: distances of 0.1 m steps, changes 0 or beyond put_number's SMALLEST
GAME_DISTANCES = st.floats(0, 60).map(lambda x: round(x, 1))
GAME_CHANGES = st.floats(-20, 20).filter(lambda x: x == 0 or abs(x) >= 1e-9)


@FUZZ
@given(st.integers(0, 10**6),
       st.lists(st.tuples(st.integers(0, len(FLAGS) - 1), GAME_DISTANCES, st.integers(-180, 180)), max_size=55),
       st.lists(st.tuples(st.sampled_from(["l", "r"]), st.integers(1, 11), GAME_DISTANCES, st.integers(-90, 90),
                          GAME_CHANGES, GAME_CHANGES, st.integers(-180, 180), st.integers(-180, 180)), max_size=10))
def test_our_servers_see_frames_are_written_by_the_kernel(cycle, flags, players):
    """A see as our server writes it (``encode`` of the message: the bytes of server.percept_wire's
    kernel) with a game's numbers is written by the kernel, not left to Python."""
    msg = m.See(cycle=cycle, flags=tuple((i, d, a, None, None) for i, d, a in flags), lines=((0, 3.5, 12),),
                ball=(3.7, 19, 0.0, -0.0), players=tuple(players))
    frame = encode(msg)
    assert frame.startswith(SEE_FRAME_START)
    assert check(frame) is not None


def test_frames_it_does_not_take():
    good = frame_of(5, [[1, 2.5, 3, None, None]], [[0, 1.5, 2]], [1.0, 2, None, None],
                    [["l", 1, 3.0, 4, 0.1, 0.2, 5, 6]])
    assert check(good) == (f'(see 5 (({FLAGS[1].name}) 2.5 3) ((B) 1 2) ((p "keepers" 1) 3 4 0.1 0.2 5 6) '
                           f'(({LINES[0].name}) 1.5 2))')
    reordered = msgpack.packb({"cycle": 5, "type": "see", "flags": [], "lines": [], "ball": None, "players": []})
    for frame in (good[:-1], good + b"\x00", reordered, b"", b"\x86", encode(m.Think(cycle=3)),
                  frame_of(5, [[1, math.nan, 3, None, None]], [], None, []),
                  frame_of(5, [[1, 2.5, 3.5, None, None]], [], None, []),
                  frame_of(5, [], [], None, [["l", 1, None, 4, None, None, None, None]])):
        assert kernel_text(frame) is None


@pytest.mark.parametrize("out_bytes", [0, 10, 30, 200, 1000])
def test_it_never_writes_past_its_buffer(out_bytes):
    rows = [[i % len(FLAGS), 123.456789, -179, -12.3456789, 1e-15] for i in range(2000)]
    players = [["r", 11, 1e25, -180, -1e25, 1e-16, -180, 180]] * 200
    assert kernel_text(frame_of(2**62, rows, [], [1e25, -180, -1e25, 1e-15], players), out_bytes) is None
