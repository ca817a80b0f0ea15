"""A command frame read by the server's kernel (server.command_frame) is read exactly as the full decoder
decodes it (protocol.messages.decode_from_player): the same Command for every frame of a real game and its
variants, and every frame the kernel does not take left to the full decoder, which then takes it or
reports it as before. A game commanded through the kernel (``Arena.submit_frame``: read and taken in one
call) is the game commanded through the full decoder (``Arena.submit_command``)."""

from __future__ import annotations


import msgpack
import numpy as np
import pytest
from command_read import Read, read
from mutations import mutated_frames

from keepaway.protocol import ProtocolError
from keepaway.protocol import messages as m
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame
from keepaway.server.arena import Arena
from keepaway.server.command_frame import MAX_FRAME_BYTES

PARAMS = parameter_set("classic")



def _full(frame: bytes) -> m.Message | None:
    try:
        return m.decode_from_player(frame)
    except ProtocolError:
        return None


def _as_read(msg: m.Message | Read | None) -> Read | None:
    """A decoded Command as the kernel gives it: its commands as (name, args) pairs."""
    if type(msg) is not m.Command:
        return msg
    return Read(msg.cycle, tuple((c.name, c.args) for c in msg.commands), msg.getopen)


def _same(a: m.Message | Read | None, b: m.Message | Read | None) -> bool:
    """The same command, to the last bit and type (repr tells 1 from 1.0 and -0.0 from 0.0, == would
    not), or the same other message."""
    a, b = _as_read(a), _as_read(b)
    return type(a) is type(b) and repr(a) == repr(b)


def _taken_alike(frame: bytes) -> bool:
    """True if the kernel takes ``frame``, which the full decoder then decodes to the same command; False
    if it leaves the frame to the full decoder."""
    fast = read(frame)
    if fast is None:
        return False
    full = _full(frame)
    assert type(full) is m.Command and _same(fast, full)
    return True


@pytest.fixture(scope="module")
def game_frames() -> list[tuple[int, bytes]]:
    """Every command frame of 300 cycles of a hand-coded game whose keepers note their GetOpen values, as
    the players sent them: (object, frame)."""
    game = EmbeddedGame(ArenaSpec(PARAMS, seed=3), getopen_notes="values")
    recorded = []
    submit = game.submit

    def recording(slot, command):
        if command is not None:  # a player's frame (PlayerAgent.take_frame)
            recorded.append((slot.obj, command))
        submit(slot, command)

    game.submit = recording
    for _ in range(300):
        game.cycle()
    return recorded


def _pack(entries, **options) -> bytes:
    return msgpack.packb(dict(entries), use_bin_type=True, **options)


def _raw_map(parts: list[tuple[str, bytes]]) -> bytes:
    """A map of packed keys and the given raw value bytes (forms the packer would not choose)."""
    return bytes([0x80 | len(parts)]) + b"".join(msgpack.packb(key) + value for key, value in parts)


def _frame(commands=(("dash", 100.0), ("turn_neck", -3.78), ("say", "1EsAA10vy")), getopen=(), cycle=20,
           **extra) -> bytes:
    return _pack([("type", "command"), ("cycle", cycle), ("commands", [list(c) for c in commands]),
                  ("getopen", list(getopen)), *extra.items()])


NOTE = [1.5, -2.0, 0.0, 1.0, 0.25, 3, -4, 0.5]  # a target and two rated points, ints among them


def test_every_command_of_a_game_is_read_as_the_full_decoder_decodes_it(game_frames):
    noted = 0
    for _, frame in game_frames:
        assert _taken_alike(frame)
        noted += bool(m.decode_from_player(frame).getopen)
    assert len(game_frames) > 1400 and noted > 100


def _arena_after(frames: list[tuple[int, bytes]], through_kernel: bool) -> tuple:
    """An arena that took ``frames`` as a cycle's commands, stepping after every five, each frame taken
    as the server takes it (``Arena.submit_frame``, the full decoder for a frame the kernel leaves) or
    decoded in full (``Arena.submit_command``): its world, pending says, notes, and the warnings it gave."""
    arena = Arena(PARAMS, 3, 2, seed=3)
    for slot in arena.slots:
        arena.connect("keepers" if slot.side == "l" else "takers")
    arena.start()
    warnings = []
    for i, (obj, frame) in enumerate(frames):
        taken = arena.submit_frame(obj, frame) if through_kernel else None
        if taken is None:
            command = m.decode_from_player(frame)
            assert command.cycle == arena.cycle  # every frame is taken as its cycle's answer
            taken = command.cycle, arena.submit_command(obj, command)
        assert taken[0] == arena.cycle
        warnings.append(taken[1])
        if i % 5 == 4:
            arena.step()
    return _state(arena), arena.pending_says, arena.step_notes, warnings


def _state(arena: Arena) -> list:
    """The arena's world and command slots, to the bit."""
    return [value.tobytes() if isinstance(value, np.ndarray) else value for value in (*arena.world, *arena.commands)]


def test_a_game_commanded_through_the_kernel_is_the_game_commanded_through_the_full_decoder(game_frames):
    assert _arena_after(game_frames, True) == _arena_after(game_frames, False)


@pytest.mark.parametrize("frame", [
    _frame(),
    _pack(reversed(list(msgpack.unpackb(_frame()).items()))),  # any key order
    _pack([("cycle", 0), ("type", "command")]),  # commands and getopen have defaults
    _pack([("type", "command"), ("cycle", m.MAX_CYCLE), ("getopen", NOTE)]),
    _raw_map([("type", msgpack.packb("command")), ("cycle", b"\xcf" + (20).to_bytes(8, "big"))]),  # a uint 64
    _raw_map([("type", b"\xd9\x07command"), ("cycle", b"\x14")]),  # a str 8
    _frame([("dash", 100), ("turn", -180), ("kick", 2**53, -2**53)]),  # ints where numbers go
    _frame([("dash", -0.0, 45.0), ("move", -1e308, 1e-320)]),
    _frame([("tackle", 50.0), ("catch", -90.0), ("done",), ("turn_neck", 3)]),
    _frame([("say", "x" * m.MAX_SAY_CHARS), ("say", ""), ("say", "bad chars ~ are the arena's to drop")]),
    _frame([("dash", 10.0)] * m.MAX_COMMANDS),
    _frame(getopen=[1.0, 2.0]),
    _frame(getopen=[0.5] * (2 + 3 * m.MAX_NOTE_POINTS)),
])
def test_other_forms_of_command_frames_are_taken(frame):
    assert _taken_alike(frame)


def _change(frame: bytes, **entries) -> bytes:
    return _pack({**msgpack.unpackb(frame), **entries}.items())


def _without(frame: bytes, key: str) -> bytes:
    return _pack([(k, v) for k, v in msgpack.unpackb(frame).items() if k != key])


BASE = _frame(getopen=NOTE)
LEFT = {  # frames the kernel leaves: False if the full decoder refuses them too, True if it takes them
    "cycle a str": (_change(BASE, cycle="20"), False),
    "cycle a bool": (_change(BASE, cycle=True), False),
    "cycle negative": (_change(BASE, cycle=-1), False),
    "cycle beyond the range": (_change(BASE, cycle=m.MAX_CYCLE + 1), False),
    "cycle a float": (_change(BASE, cycle=20.0), False),
    "a bool argument": (_frame([("dash", True)]), False),
    "a str argument": (_frame([("dash", "100")]), False),
    "a nil argument": (_frame([("turn", None)]), False),
    "NaN": (_frame([("dash", float("nan"))]), False),
    "infinity": (_frame([("kick", 10.0, float("-inf"))]), False),
    "NaN in the note": (_frame(getopen=[float("nan"), 1.0]), False),
    "an int beyond exact doubles": (_frame([("dash", 2**53 + 1)]), False),
    "unknown command": (_frame([("sprint", 100.0)]), False),
    "command name an int": (_frame([(3, 100.0)]), False),
    "empty command": (_frame([()]), False),
    "command not an array": (_change(BASE, commands=["dash"]), False),
    "commands a map": (_change(BASE, commands={"dash": 1.0}), False),
    "commands nil": (_change(BASE, commands=None), False),
    "too many arguments": (_frame([("turn", 1.0, 2.0)]), False),
    "too few arguments": (_frame([("kick", 1.0)]), False),
    "dash of three": (_frame([("dash", 1.0, 2.0, 3.0)]), False),
    "say too long": (_frame([("say", "x" * (m.MAX_SAY_CHARS + 1))]), False),
    "say as bin": (_frame([("say", b"hello")]), False),
    "too many commands": (_frame([("dash", 10.0)] * (m.MAX_COMMANDS + 1)), False),
    "note of one number": (_frame(getopen=[1.0]), False),
    "note of three numbers": (_frame(getopen=[1.0, 2.0, 3.0]), False),
    "note too long": (_frame(getopen=[0.5] * (5 + 3 * m.MAX_NOTE_POINTS)), False),
    "note a map": (_change(BASE, getopen={}), False),
    "missing cycle": (_without(BASE, "cycle"), False),
    "missing type": (_without(BASE, "type"), False),
    "another type": (_change(BASE, type="report"), False),
    "extra key": (_change(BASE, view="wide"), False),
    "trailing byte": (BASE + b"\xc0", False),
    "not a map": (msgpack.packb([["dash", 1.0]]), False),
    "type a bin key": (b"\x82" + msgpack.packb("cycle") + b"\x14" + b"\xc4\x04type" + msgpack.packb("command"),
                       False),
    # valid, but not in a form the kernel reads: the full decoder takes them
    "change_view": (_frame([("change_view", "wide", "high")]), True),
    "a float32": (_pack(msgpack.unpackb(BASE).items(), use_single_float=True), True),
    "a non-ASCII say": (_frame([("say", "é")]), True),
    "a duplicate key": (_raw_map([(k, msgpack.packb(v)) for k, v in msgpack.unpackb(BASE).items()]
                                 + [("cycle", msgpack.packb(21))]), True),
}


@pytest.mark.parametrize("case", LEFT)
def test_frames_the_kernel_leaves_to_the_full_decoder(case):
    """... which then takes them, or refuses them with the very error it gives without the kernel."""
    frame, valid = LEFT[case]
    assert read(frame) is None
    assert (_full(frame) is not None) == valid
    arena = Arena(PARAMS, 3, 2, seed=3)
    arena.connect("keepers")
    before = _state(arena)
    assert arena.submit_frame(1, frame) is None  # left to the full decoder: nothing taken
    assert _state(arena) == before


def test_no_prefix_of_a_command_frame_is_taken(game_frames):
    for frame in (BASE, max((f for _, f in game_frames), key=len)):
        for end in range(len(frame)):
            assert read(frame[:end]) is None


def test_mutated_frames_are_taken_only_as_the_full_decoder_takes_them(game_frames):
    """Random bytes changed in real frames: whatever the kernel takes, the full decoder takes alike; what
    the full decoder refuses, the kernel leaves."""
    taken = refused = 0
    for frame in mutated_frames([f for _, f in game_frames] + [BASE], 3000, 3, seed=11):
        valid = _full(frame) is not None
        took = _taken_alike(frame)
        assert valid or not took
        taken += took
        refused += not valid
    assert taken > 200 and refused > 200  # both kinds occur


def test_the_longest_frame_the_kernel_takes_fits_its_buffer():
    longest = _pack([("type", "command"), ("cycle", m.MAX_CYCLE),
                     ("commands", [["say", "x" * m.MAX_SAY_CHARS]] * m.MAX_COMMANDS),
                     ("getopen", [2**63 - 1 - i for i in range(2 + 3 * m.MAX_NOTE_POINTS)])])
    assert len(longest) <= MAX_FRAME_BYTES
    assert read(longest) is None and _full(longest) is None  # the note's ints are too large
    fits = longest.replace(b"\xcf\x7f", b"\xcb\x40")  # as large doubles: valid
    assert len(fits) == len(longest) and _taken_alike(fits)
