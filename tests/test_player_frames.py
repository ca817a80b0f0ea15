"""A player's per-cycle frames taken straight from their bytes (PlayerAgent.take_frame, agents.frames) are
taken exactly as the decoded messages (PlayerAgent.on_message): the same world model, talk and commands
after every sense_body, hear and think of a real game, and every frame the kernel does not take left to the
full decoder with the agent untouched."""

from __future__ import annotations

from dataclasses import replace

import msgpack
import numpy as np
import pytest

from keepaway.agents.player import PlayerAgent
from keepaway.agents.think import NOT_WRITTEN
from keepaway.protocol import ProtocolError, encode
from keepaway.protocol import messages as m
from keepaway.protocol.advice import SeedAdvice
from keepaway.protocol.messages import decode_for_player, decode_from_player
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame
from mutations import mutated_frames

PARAMS = parameter_set("classic")
CYCLES = 300


@pytest.fixture(scope="module")
def game() -> tuple[dict, dict]:
    """The init_ok of every player of a hand-coded game and every frame it got in CYCLES cycles (its
    percepts, then the cycle's think), by (team, unum)."""
    game = EmbeddedGame(ArenaSpec(PARAMS, seed=4))
    arena = game.arena
    inits, frames = {}, {}
    for slot, player in game.players:
        key = (player.team, slot.unum)
        config = {"mode": "sync", "keepers": 3, "takers": 2, "seed": 4}
        inits[key] = arena.init_ok(slot, player.team, config)
        frames[key] = []
    cycle_frames = arena.cycle_frames
    players = {slot.obj: (player.team, slot.unum) for slot, player in game.players}

    def recording(slot, with_see):
        out = cycle_frames(slot, with_see)
        frames[players[slot.obj]].extend(out)
        return out

    arena.cycle_frames = recording
    for _ in range(CYCLES):
        game.perceive()
        think = encode(m.Think(cycle=arena.cycle))
        for key in frames:
            frames[key].append(think)
        game.think()
        game.step()
    return inits, frames


def _agent(init: m.InitOk, mode: str = "sync") -> PlayerAgent:
    agent = PlayerAgent(init.team, seed=4)
    agent.on_message(replace(init, config={**init.config, "mode": mode}))
    return agent


def _same(a: PlayerAgent, b: PlayerAgent) -> bool:
    """The same world model, talk and cycle log."""
    arrays = list(zip(a.wm.state, b.wm.state)) + list(zip(a.talk, b.talk))
    return (all(np.array_equal(x, y, equal_nan=x.dtype.kind == "f") for x, y in arrays)
            and a._cycle == b._cycle and len(a._cycle_log) == len(b._cycle_log))


@pytest.mark.parametrize("mode", ["sync", "realtime"])
def test_every_frame_of_a_game_gives_the_agent_the_decoded_message_gives(game, mode):
    """In sync mode the think decides, in real-time mode the sense_body: both return the same command."""
    inits, frames = game
    taken = {kind: 0 for kind in m.SERVER_TO_PLAYER}
    commands = 0
    for key, init in inits.items():
        full, fast = _agent(init, mode), _agent(init, mode)
        for frame in frames[key]:
            msg = decode_for_player(frame)
            expected = full.on_message(msg)
            was_taken, command = fast.take_frame(frame)
            if not was_taken:
                command = fast.on_message(msg)
            elif command is not None:  # the frame of the command the decoded message gives, as encode packs it
                assert type(command) is bytes and command == encode(expected)
                command = decode_from_player(command)
            taken[msg.TYPE] += was_taken
            assert command == expected
            commands += command is not None
            assert _same(full, fast)
    assert commands == len(inits) * CYCLES
    assert taken["sense_body"] == taken["think"] == len(inits) * CYCLES
    assert taken["hear"] > 2 * len(inits) * CYCLES and taken["see"] > 900


def test_the_think_kernel_writes_what_its_steps_called_from_python_write(game):
    """agents.think.think finishes a think in the kernel (the commands told to the world model, the say,
    the frame); asked to leave every decision to the caller, the agent finishes it in Python
    (``_command``): the same frames, world model, talk and decision memory at every frame of a game."""
    inits, frames = game
    written = {True: 0, False: 0}  # by the kernel of each agent

    def counted(think, finish: bool):
        def call(*args):
            decision, n = think(*args[:13], finish, *args[14:])
            written[finish] += n != NOT_WRITTEN
            return decision, n
        return call

    for key, init in inits.items():
        kernel, steps = _agent(init), _agent(init)
        kernel._think, steps._think = counted(kernel._think, True), counted(steps._think, False)
        for frame in frames[key]:
            assert kernel.take_frame(frame) == steps.take_frame(frame)
            assert _same(kernel, steps)
            assert all(np.array_equal(x, y) for x, y in zip(kernel.memory, steps.memory))
    assert written == {True: len(inits) * CYCLES, False: 0}


def test_a_seed_advice_replays_the_frames_taken_in_its_cycle(game):
    """A seed advice heard mid-cycle feeds a fresh world model the cycle's percepts again (the cycle log):
    those taken from frames too."""
    inits, frames = game
    init = inits[("keepers", 1)]
    full, fast = _agent(init), _agent(init)
    cycle_start = [i for i, f in enumerate(frames[("keepers", 1)]) if decode_for_player(f).TYPE == "sense_body"]
    upto = cycle_start[CYCLES // 2]
    for frame in frames[("keepers", 1)][:upto + 3]:  # into the middle of a cycle: its sense_body and more
        full.on_message(decode_for_player(frame))
        if not fast.take_frame(frame).taken:
            fast.on_message(decode_for_player(frame))
    cycle = full._cycle
    assert any(type(item) is bytes for item in fast._cycle_log)  # frames kept as their bytes
    for msg in (m.advice_hear(SeedAdvice(seed=9).to_wire(), cycle),
                m.Hear(cycle=cycle, sender="referee", message="training Keepaway 1")):
        full.on_message(msg)
        fast.on_message(msg)
    assert _same(full, fast)


def _first(frames: list[bytes], test) -> bytes:
    return next(f for f in frames if test(decode_for_player(f)))


@pytest.fixture(scope="module")
def samples(game) -> dict[str, bytes]:
    """A real frame of each kind the kernel takes, and the frames a keeper got before it."""
    frames = game[1][("keepers", 1)]
    return {
        "sense_body": _first(frames, lambda msg: msg.TYPE == "sense_body" and msg.cycle > 5),
        "our": _first(frames, lambda msg: msg.TYPE == "hear" and msg.sender == "our" and msg.message),
        "self": _first(frames, lambda msg: msg.TYPE == "hear" and msg.sender == "self"),
        "opp": next((f for k, fs in game[1].items() for f in fs if decode_for_player(f).TYPE == "hear"
                     and decode_for_player(f).sender == "opp")),
        "think": _first(frames, lambda msg: msg.TYPE == "think" and msg.cycle > 5),
    }


def _taken_alike(frame: bytes, init: m.InitOk) -> bool:
    """take_frame on a ready agent: True if it takes ``frame`` (then the agent equals one given the decoded
    frame, and returned its command); False if it leaves it (then the agent is untouched)."""
    fast, full = _agent(init, "realtime"), _agent(init, "realtime")
    took, command = fast.take_frame(frame)
    if not took:
        assert command is None and _same(fast, full)
        return False
    expected = full.on_message(decode_for_player(frame))  # the full decoder takes what it took
    assert command == (None if expected is None else encode(expected))
    assert _same(fast, full)
    return True


def _entries(frame: bytes) -> list[tuple[str, object]]:
    return list(msgpack.unpackb(frame).items())


def _pack(entries, **options) -> bytes:
    return msgpack.packb(dict(entries), use_bin_type=True, **options)


def _with(frame: bytes, key: str, value) -> bytes:
    return _pack([(k, value if k == key else v) for k, v in _entries(frame)] +
                 ([] if key in dict(_entries(frame)) else [(key, value)]))


def _without(frame: bytes, key: str) -> bytes:
    return _pack([(k, v) for k, v in _entries(frame) if k != key])


def _raw_map(parts: list[tuple[str, bytes]]) -> bytes:
    """A map of packed keys and the given raw value bytes (forms the packer would not choose)."""
    out = bytes([0x80 | len(parts)])
    for key, value in parts:
        out += msgpack.packb(key) + value
    return out


def _duplicated(frame: bytes, key: str) -> bytes:
    entries = _entries(frame)
    parts = [(k, msgpack.packb(v, use_bin_type=True)) for k, v in entries]
    return _raw_map(parts + [(key, msgpack.packb(dict(entries)[key], use_bin_type=True))])


def _wide_cycle(frame: bytes) -> bytes:
    """The cycle as a uint 64."""
    entries = _entries(frame)
    return _raw_map([(k, b"\xcf" + v.to_bytes(8, "big") if k == "cycle" else msgpack.packb(v, use_bin_type=True))
                     for k, v in entries])


def _counts(frame: bytes, **changes) -> dict:
    return {**dict(_entries(frame))["counts"], **changes}


TAKEN = {
    "sense_body": lambda f: f,
    "sense_body any key order": lambda f: _pack(reversed(_entries(f))),
    "sense_body uint 64 cycle": _wide_cycle,
    "sense_body collisions": lambda f: _with(f, "collision", ["ball", "post"]),
    "our": lambda f: f,
    "our any key order": lambda f: _pack(reversed(_entries(f))),
    "our without direction and unum": lambda f: _without(_without(f, "direction"), "unum"),
    "our uint 64 cycle": _wide_cycle,
    "self": lambda f: f,
    "opp": lambda f: f,
    "think": lambda f: f,
    "think uint 64 cycle": _wide_cycle,
}


@pytest.mark.parametrize("variant", list(TAKEN))
def test_forms_the_kernel_takes(samples, game, variant):
    base = samples[variant.split()[0]]
    assert _taken_alike(TAKEN[variant](base), game[0][("keepers", 1)])


LEFT = {
    "sense_body": {
        "int stamina": lambda f: _with(f, "stamina", [4000, 1.0, -1.0]),
        "float32": lambda f: _pack(_entries(f), use_single_float=True),
        "NaN effort": lambda f: _with(f, "stamina", [4000.0, float("nan"), -1.0]),
        "negative speed": lambda f: _with(f, "speed", [-0.5, 0]),
        "speed direction 181": lambda f: _with(f, "speed", [0.5, 181]),
        "bool head angle": lambda f: _with(f, "head_angle", True),
        "head angle -181": lambda f: _with(f, "head_angle", -181),
        "view quality x": lambda f: _with(f, "view_mode", ["x", "normal"]),
        "view mode of 3": lambda f: _with(f, "view_mode", ["high", "normal", "high"]),
        "negative count": lambda f: _with(f, "counts", _counts(f, dash=-1)),
        "count 2**31": lambda f: _with(f, "counts", _counts(f, dash=2**31)),
        "missing count": lambda f: _with(f, "counts", {k: v for k, v in _counts(f).items() if k != "say"}),
        "extra count": lambda f: _with(f, "counts", _counts(f, tackle=0)),
        "4 collisions": lambda f: _with(f, "collision", ["ball"] * 4),
        "collision x": lambda f: _with(f, "collision", ["x"]),
        "extra key": lambda f: _with(f, "view", 1),
        "missing key": lambda f: _without(f, "collision"),
        "duplicate key": lambda f: _duplicated(f, "stamina"),
        "trailing byte": lambda f: f + b"\xc0",
        "typed see": lambda f: _with(f, "type", "see"),
        "cycle -1": lambda f: _with(f, "cycle", -1),
    },
    "our": {
        "referee": lambda f: _with(f, "sender", "referee"),
        "coach": lambda f: _with(f, "sender", "coach"),
        "sender x": lambda f: _with(f, "sender", "x"),
        "non-ASCII text": lambda f: _with(f, "message", "héllo"),
        "text of 1025": lambda f: _with(f, "message", "a" * 1025),
        "text as bin": lambda f: _with(f, "message", b"abc"),
        "int message": lambda f: _with(f, "message", 7),
        "direction 181": lambda f: _with(f, "direction", 181),
        "float direction": lambda f: _with(f, "direction", 1.0),
        "unum 0": lambda f: _with(f, "unum", 0),
        "missing message": lambda f: _without(f, "message"),
        "extra key": lambda f: _with(f, "flags", []),
        "duplicate key": lambda f: _duplicated(f, "message"),
        "trailing byte": lambda f: f + b"\x00",
    },
    "think": {
        "extra key": lambda f: _with(f, "sender", "self"),
        "cycle 2**31": lambda f: _with(f, "cycle", 2**31),
        "float cycle": lambda f: _with(f, "cycle", 5.0),
        "type Think": lambda f: _with(f, "type", "Think"),
        "missing cycle": lambda f: _without(f, "cycle"),
        "duplicate key": lambda f: _duplicated(f, "cycle"),
        "array": lambda f: msgpack.packb(["think", 5]),
    },
}


@pytest.mark.parametrize("kind,change", [(kind, change) for kind, changes in LEFT.items() for change in changes])
def test_frames_the_kernel_leaves_to_the_full_decoder(samples, game, kind, change):
    assert not _taken_alike(LEFT[kind][change](samples[kind]), game[0][("keepers", 1)])


@pytest.mark.parametrize("kind", ["sense_body", "our", "self", "think"])
def test_no_prefix_of_a_frame_is_taken(samples, game, kind):
    frame = samples[kind]
    for end in range(len(frame)):
        assert not _taken_alike(frame[:end], game[0][("keepers", 1)])


@pytest.mark.parametrize("kind", ["sense_body", "our", "think"])
def test_mutated_frames_are_taken_only_as_the_full_decoder_takes_them(samples, game, kind):
    """Random bytes changed in real frames: whatever the kernel takes, the full decoder takes alike; what
    the full decoder refuses, the kernel leaves."""
    taken = refused = 0
    for frame in mutated_frames([samples[kind]], 600, 2, seed=11):
        try:
            decode_for_player(frame)
            valid = True
        except ProtocolError:
            valid = False
        took = _taken_alike(frame, game[0][("keepers", 1)])
        assert valid or not took
        taken += took
        refused += not valid
    assert taken > 5 and refused > 100  # both kinds occur
