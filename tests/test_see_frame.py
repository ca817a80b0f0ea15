"""A see taken straight from its frame (agents.frames, WorldModel.on_frame) is taken exactly as the
decoded message (WorldModel.on_see): the same world model after every see of a real game, and every frame
the kernel does not take left to the full decoder with the model untouched."""

from __future__ import annotations


import msgpack
import numpy as np
import pytest
from mutations import mutated_frames

from keepaway.agents.frames import NOT_TAKEN, SEE
from keepaway.agents.worldmodel import WorldModel
from keepaway.core.msgpack_in import BAD, read_double, read_int, read_str
from keepaway.protocol import ProtocolError
from keepaway.protocol.landmarks import to_wire as landmarks
from keepaway.protocol.messages import See, SenseBody, decode_for_player
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame

PARAMS = parameter_set("classic")


def _model(side: str, unum: int) -> WorldModel:
    return WorldModel(PARAMS, side, unum, 3, 2, landmarks()["flags"])


def _states_equal(a: WorldModel, b: WorldModel) -> bool:
    return all(np.array_equal(x, y, equal_nan=x.dtype.kind == "f") for x, y in zip(a.state, b.state))


def _feed(model: WorldModel, frame: bytes) -> None:
    """``frame`` through the full decoder, as the world model's on_* method of its type takes it."""
    msg = decode_for_player(frame)
    fields = {name: getattr(msg, name) for name in msg.__dataclass_fields__}
    if type(msg) is See:
        model.on_see(fields)
    elif type(msg) is SenseBody:
        model.on_sense_body(fields)


@pytest.fixture(scope="module")
def game_frames() -> list[tuple[str, int, list[bytes]]]:
    """Every percept frame of 300 cycles of a hand-coded game, per player and cycle, as the players got
    them: (side, unum, frames)."""
    game = EmbeddedGame(ArenaSpec(PARAMS, seed=4))
    recorded = []
    cycle_frames = game.arena.cycle_frames

    def recording(slot, with_see):
        frames = cycle_frames(slot, with_see)
        recorded.append((slot.side, slot.unum, frames))
        return frames

    game.arena.cycle_frames = recording
    for _ in range(300):
        game.cycle()
    return recorded


@pytest.fixture(scope="module")
def see_frames(game_frames) -> list[bytes]:
    return [f for _, _, frames in game_frames for f in frames if decode_for_player(f).TYPE == "see"]


def test_every_see_of_a_game_gives_the_model_the_decoded_see_gives(game_frames):
    models = {}
    sees = 0
    for side, unum, frames in game_frames:
        full, fast = models.setdefault((side, unum), (_model(side, unum), _model(side, unum)))
        for frame in frames:
            _feed(full, frame)
            if decode_for_player(frame).TYPE == "see":
                assert fast.on_frame(frame) == (SEE, decode_for_player(frame).cycle)
                sees += 1
            else:
                _feed(fast, frame)
            assert _states_equal(full, fast)
    assert sees > 900  # five players, a see on two cycles of three


def _entries(frame: bytes) -> list[tuple[str, object]]:
    return list(msgpack.unpackb(frame).items())


def _pack(entries, **options) -> bytes:
    return msgpack.packb(dict(entries), use_bin_type=True, **options)


def _raw_map(parts: list[tuple[str, bytes]]) -> bytes:
    """A map of packed keys and the given raw value bytes (forms the packer would not choose)."""
    out = bytes([0x80 | len(parts)])
    for key, value in parts:
        out += msgpack.packb(key) + value
    return out


def _with(frame: bytes, key: str, value) -> bytes:
    return _pack([(k, value if k == key else v) for k, v in _entries(frame)])


def _rich(see_frames) -> bytes:
    """A see with flags, the ball and players with every field."""
    return max(see_frames, key=lambda f: (decode_for_player(f).ball is not None,
                                          sum(p[6] is not None for p in decode_for_player(f).players),
                                          len(decode_for_player(f).flags)))


def _taken_alike(frame: bytes, before: bytes) -> bool:
    """on_frame on a model that has seen the see ``before``: True if it takes ``frame`` (then the model
    equals one fed the decoded frame); False if it leaves it (then the model is untouched)."""
    fast, full = _model("l", 1), _model("l", 1)
    for model in (fast, full):
        _feed(model, before)
    kind, cycle = fast.on_frame(frame)
    if kind == NOT_TAKEN:
        assert _states_equal(fast, full)
        return False
    _feed(full, frame)  # the full decoder must take what the kernel took
    assert (kind, cycle) == (SEE, decode_for_player(frame).cycle)
    assert _states_equal(fast, full)
    return True


@pytest.fixture(scope="module")
def rich(see_frames) -> bytes:
    return _rich(see_frames)


def test_other_forms_of_the_same_see_are_taken(rich, see_frames):
    entries = _entries(rich)
    assert _taken_alike(rich, see_frames[0])
    assert _taken_alike(_pack(reversed(entries)), see_frames[0])  # any key order
    cycle = decode_for_player(rich).cycle
    wide_cycle = b"\xcf" + cycle.to_bytes(8, "big")  # a uint 64 for a small int
    parts = [(k, wide_cycle if k == "cycle" else msgpack.packb(v, use_bin_type=True)) for k, v in entries]
    assert _taken_alike(_raw_map(parts), see_frames[0])
    flags = [(None, *row[1:]) for row in decode_for_player(rich).flags]  # only close flags: none kept
    assert _taken_alike(_with(rich, "flags", flags), see_frames[0])
    assert _taken_alike(_with(rich, "ball", None), see_frames[0])
    assert _taken_alike(_with(rich, "players", []), see_frames[0])


def test_a_flag_beyond_the_landmark_table_is_skipped(rich, see_frames):
    """Ids up to 255 are valid on the wire, but init_ok's table holds 55 flags: neither path reads past it."""
    flags = [list(row) for row in decode_for_player(rich).flags]
    extra = _with(rich, "flags", flags[:3] + [[112, 5.0, 0, None, None]] + flags[3:])
    assert _taken_alike(extra, see_frames[0])
    fast, plain = _model("l", 1), _model("l", 1)
    for model in (fast, plain):
        _feed(model, see_frames[0])
    fast.on_frame(extra)
    plain.on_frame(rich)
    assert _states_equal(fast, plain)


@pytest.mark.parametrize("change", [
    "int distance", "float32 distance", "NaN distance", "negative distance", "direction 181", "bool direction",
    "unum 0", "side x", "side as bin", "infinite change", "flag id 256", "extra key", "missing key",
    "duplicate key", "trailing byte", "tuple rows of a map", "not a see", "60 flags",
])
def test_frames_the_kernel_leaves_to_the_full_decoder(rich, see_frames, change):
    see = decode_for_player(rich)
    entries = _entries(rich)
    flag = list(see.flags[0])
    player = list(see.players[0])
    frames = {
        "int distance": lambda: _with(rich, "flags", [[flag[0], 7, *flag[2:]]]),
        "float32 distance": lambda: _pack(entries, use_single_float=True),
        "NaN distance": lambda: _with(rich, "ball", [float("nan"), 0, None, None]),
        "negative distance": lambda: _with(rich, "flags", [[flag[0], -1.0, *flag[2:]]]),
        "direction 181": lambda: _with(rich, "ball", [1.0, 181, None, None]),
        "bool direction": lambda: _with(rich, "ball", [1.0, True, None, None]),
        "unum 0": lambda: _with(rich, "players", [[player[0], 0, *player[2:]]]),
        "side x": lambda: _with(rich, "players", [["x", *player[1:]]]),
        "side as bin": lambda: _with(rich, "players", [[b"l", *player[1:]]]),
        "infinite change": lambda: _with(rich, "ball", [1.0, 0, float("inf"), 0.0]),
        "flag id 256": lambda: _with(rich, "flags", [[256, *flag[1:]]]),
        "extra key": lambda: _pack(entries + [("view", 1)]),
        "missing key": lambda: _pack([(k, v) for k, v in entries if k != "lines"]),
        "duplicate key": lambda: _raw_map([(k, msgpack.packb(v, use_bin_type=True)) for k, v in entries]
                                          + [("cycle", msgpack.packb(see.cycle))]),
        "trailing byte": lambda: rich + b"\xc0",
        "tuple rows of a map": lambda: _with(rich, "ball", {"d": 1.0}),
        "not a see": lambda: _with(rich, "type", "hear"),
        "60 flags": lambda: _with(rich, "flags", [[i % 55, 10.0, 0, None, None] for i in range(60)]),
    }
    assert not _taken_alike(frames[change](), see_frames[0])


def test_no_prefix_of_a_see_is_taken(rich, see_frames):
    for end in range(len(rich)):
        assert not _taken_alike(rich[:end], see_frames[0])


def test_mutated_frames_are_taken_only_as_the_full_decoder_takes_them(see_frames):
    """Random bytes changed in real sees: whatever the kernel takes, the full decoder takes alike; what the
    full decoder refuses, the kernel leaves."""
    taken = refused = 0
    for frame in mutated_frames(see_frames, 1500, 3, seed=7):
        try:
            decode_for_player(frame)
            valid = True
        except ProtocolError:
            valid = False
        took = _taken_alike(frame, see_frames[0])
        assert valid or not took
        taken += took
        refused += not valid
    assert taken > 100 and refused > 100  # both kinds occur


def test_readers_take_every_int_form_and_refuse_other_kinds():
    for value in (0, 5, 127, 128, 255, 256, 65535, 65536, 2**32, 2**62, -1, -32, -33, -128, -129, -2**15 - 1,
                  -2**31 - 1, -2**63):
        packed = np.frombuffer(msgpack.packb(value), dtype=np.uint8).copy()
        assert read_int(packed, 0, packed.size) == (value, packed.size)
        assert read_int(packed, 0, packed.size - 1)[1] == BAD or packed.size == 1
    for bad in (msgpack.packb(2**64 - 1), msgpack.packb(1.0), msgpack.packb(True), msgpack.packb(None)):
        buf = np.frombuffer(bad, dtype=np.uint8).copy()
        assert read_int(buf, 0, buf.size)[1] == BAD
    double = np.frombuffer(msgpack.packb(-2.5), dtype=np.uint8).copy()
    assert read_double(double, 0, double.size) == (-2.5, 9)
    single = np.frombuffer(msgpack.packb(2.5, use_single_float=True), dtype=np.uint8).copy()
    assert read_double(single, 0, single.size)[1] == BAD
    for text in ("l", "x" * 31, "y" * 32, "z" * 300):
        buf = np.frombuffer(msgpack.packb(text), dtype=np.uint8).copy()
        start, length, end = read_str(buf, 0, buf.size)
        assert (bytes(buf[start:start + length]).decode(), end) == (text, buf.size)
        assert read_str(buf, 0, buf.size - 1)[2] == BAD
