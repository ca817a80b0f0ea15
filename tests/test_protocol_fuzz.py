"""Property tests of the codec: whatever arrives, ``decode`` returns a message or raises ProtocolError,
and whatever it accepts re-encodes to the same message (docs/protocol.md, "Errors")."""

from __future__ import annotations

import math

import msgpack
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_protocol import ALL_SETS, SAMPLES, allowed_for

from keepaway.protocol import (
    COMMAND_ARGUMENTS,
    MAX_COMMANDS,
    PLAYER_TO_SERVER,
    Advice,
    AtomicCommand,
    Command,
    Message,
    ProtocolError,
    Report,
    See,
    decode,
    encode,
)
from keepaway.protocol.messages import MAX_SAY_CHARS, VIEW_QUALITIES, VIEW_WIDTHS

FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# --------------------------------------------------------------------------------------------- helpers


def decode_or_reject(data: bytes, allowed) -> Message | None:
    """``decode``, with ProtocolError turned into None; any other exception fails the test."""
    try:
        return decode(data, allowed)
    except ProtocolError as exc:
        assert exc.code and exc.message and "\n" not in exc.message
        return None


def assert_accepted_message_is_stable(msg: Message, allowed) -> None:
    """An accepted message re-encodes and decodes to the same bytes (bytes, so NaN payloads compare)."""
    data = encode(msg)
    again = decode(data, allowed)
    assert type(again) is type(msg)
    assert encode(again) == data


def all_types_allowed() -> dict:
    merged = {}
    for allowed in ALL_SETS:
        merged.update(allowed)
    return merged


# ------------------------------------------------------------------------------------------ strategies

SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**63), max_value=2**64 - 1)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12)
    | st.binary(max_size=12)
)
MSGPACK_VALUES = st.recursive(
    SCALARS,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=16,
)
HOSTILE = st.sampled_from([
    math.nan, math.inf, -math.inf, 2**64 - 1, -(2**63), 2**53 + 1, True, False, None, "", "x" * 2000, b"\xff",
    [], {}, [[[[[]]]]], -1, 0, 1e308, -1e-320,
])
CYCLES = st.integers(0, 2**31 - 1)
FIELD_NAMES = sorted({name for msg in SAMPLES for name in msg.to_wire()} | {"x", ""})


def plain(value):
    """The value as msgpack decodes it (tuples become lists)."""
    return msgpack.unpackb(msgpack.packb(value, use_bin_type=True), raw=False)


def paths(value, prefix=()):
    """Every position inside a decoded wire value, the root included."""
    yield prefix
    if isinstance(value, dict):
        for key, child in value.items():
            yield from paths(child, (*prefix, key))
    elif isinstance(value, list):
        for index, child in enumerate(value):
            yield from paths(child, (*prefix, index))


def replace_at(value, path, new):
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(value, dict):
        return {**value, head: replace_at(value[head], rest, new)}
    return [replace_at(child, rest, new) if index == head else child for index, child in enumerate(value)]


@st.composite
def mutated_messages(draw):
    """A valid sample with one field removed or added, or one value anywhere replaced."""
    msg = draw(st.sampled_from(SAMPLES))
    wire = plain(msg.to_wire())
    path = draw(st.sampled_from(list(paths(wire))))
    target = wire
    for step in path:
        target = target[step]
    operation = draw(st.sampled_from(["replace", "hostile", "remove", "add"]))
    if operation == "replace":
        wire = replace_at(wire, path, draw(MSGPACK_VALUES))
    elif operation == "hostile":
        wire = replace_at(wire, path, draw(HOSTILE))
    elif operation == "remove" and isinstance(target, (dict, list)) and target:
        keys = list(target) if isinstance(target, dict) else list(range(len(target)))
        key = draw(st.sampled_from(keys))
        smaller = ({k: v for k, v in target.items() if k != key} if isinstance(target, dict)
                   else [v for i, v in enumerate(target) if i != key])
        wire = replace_at(wire, path, smaller)
    elif operation == "add" and isinstance(target, (dict, list)):
        extra = draw(MSGPACK_VALUES)
        bigger = {**target, draw(st.sampled_from(FIELD_NAMES)): extra} if isinstance(target, dict) else [*target, extra]
        wire = replace_at(wire, path, bigger)
    return msg, msgpack.packb(wire, use_bin_type=True)


NUMBER = st.floats(allow_nan=False, allow_infinity=False) | st.integers(-(2**53), 2**53).map(float)
ARGUMENT_VALUES = {
    "say": st.text(max_size=MAX_SAY_CHARS),
    "change_view": st.tuples(st.sampled_from(VIEW_WIDTHS), st.sampled_from(VIEW_QUALITIES)),
}


@st.composite
def atomic_commands(draw):
    name = draw(st.sampled_from(sorted(COMMAND_ARGUMENTS)))
    required, extra = COMMAND_ARGUMENTS[name]
    count = draw(st.integers(len(required), len(required) + len(extra)))
    if name == "say":
        args = (draw(ARGUMENT_VALUES["say"]),)
    elif name == "change_view":
        args = draw(ARGUMENT_VALUES["change_view"])[:count]
    else:
        args = tuple(draw(NUMBER) for _ in range(count))
    return AtomicCommand(name, args)


PAYLOADS = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats(allow_nan=False) | st.text()
    | st.binary(),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=20,
)
DISTANCE = st.floats(min_value=0.0, max_value=200.0)
DIRECTION = st.integers(-180, 180)
CHANGE = st.none() | st.floats(-50.0, 50.0)
SEES = st.builds(
    See,
    cycle=CYCLES,
    flags=st.lists(st.tuples(st.none() | st.integers(0, 54), DISTANCE, DIRECTION, CHANGE, CHANGE),
                   max_size=55).map(tuple),
    lines=st.lists(st.tuples(st.integers(0, 3), DISTANCE, DIRECTION), max_size=4).map(tuple),
    ball=st.none() | st.tuples(DISTANCE, DIRECTION, CHANGE, CHANGE),
    players=st.lists(st.tuples(st.none() | st.sampled_from(["l", "r"]), st.none() | st.integers(1, 11), DISTANCE,
                               DIRECTION, CHANGE, CHANGE, st.none() | DIRECTION, st.none() | DIRECTION),
                     max_size=22).map(tuple),
)
VALID_MESSAGES = (
    st.builds(Command, cycle=CYCLES, commands=st.lists(atomic_commands(), max_size=MAX_COMMANDS).map(tuple))
    | st.builds(Report, cycle=CYCLES, payload=PAYLOADS)
    | st.builds(Advice, target=st.sampled_from(["keepers", "takers", "all"])
                | st.tuples(st.sampled_from(["l", "r"]), st.integers(1, 11)), payload=PAYLOADS)
    | SEES
)

# ---------------------------------------------------------------------------------------------- tests


@FUZZ
@given(st.binary(max_size=300))
def test_random_bytes_never_raise_anything_but_protocol_error(data):
    for allowed in ALL_SETS:
        decode_or_reject(data, allowed)


@FUZZ
@given(MSGPACK_VALUES)
def test_random_msgpack_values_never_raise_anything_but_protocol_error(value):
    data = msgpack.packb(value, use_bin_type=True)
    for allowed in ALL_SETS:
        decode_or_reject(data, allowed)


@FUZZ
@given(st.sampled_from(sorted(all_types_allowed())),
       st.dictionaries(st.sampled_from(FIELD_NAMES), MSGPACK_VALUES | HOSTILE, max_size=8))
def test_random_fields_under_a_known_type_never_raise_anything_but_protocol_error(message_type, fields):
    data = msgpack.packb({**fields, "type": message_type}, use_bin_type=True)
    allowed = all_types_allowed()
    msg = decode_or_reject(data, allowed)
    if msg is not None:
        assert_accepted_message_is_stable(msg, allowed)


ATOMIC_LIKE = st.lists(st.sampled_from(sorted(COMMAND_ARGUMENTS)) | HOSTILE | MSGPACK_VALUES, max_size=4)


@FUZZ
@given(CYCLES | HOSTILE, st.lists(ATOMIC_LIKE | HOSTILE, max_size=MAX_COMMANDS + 2))
def test_random_command_lists_never_raise_anything_but_protocol_error(cycle, commands):
    data = msgpack.packb({"type": "command", "cycle": cycle, "commands": commands}, use_bin_type=True)
    msg = decode_or_reject(data, PLAYER_TO_SERVER)
    if msg is not None:
        assert_accepted_message_is_stable(msg, PLAYER_TO_SERVER)


@FUZZ
@given(mutated_messages())
def test_mutated_valid_messages_are_rejected_cleanly_or_stay_stable(case):
    original, data = case
    allowed = allowed_for(original)
    msg = decode_or_reject(data, allowed)
    if msg is not None:
        assert_accepted_message_is_stable(msg, allowed)


@FUZZ
@given(st.sampled_from(SAMPLES), st.binary(min_size=1, max_size=20), st.data())
def test_truncated_or_extended_frames_are_malformed(msg, garbage, data):
    frame = encode(msg)
    cut = data.draw(st.integers(0, len(frame) - 1))  # msgpack is prefix-free: every strict prefix is incomplete
    for broken in (frame + garbage, frame[:cut]):
        try:
            decode(broken, allowed_for(msg))
        except ProtocolError as exc:
            assert exc.code == "malformed"
        else:
            raise AssertionError(f"accepted {broken!r}")


@FUZZ
@given(VALID_MESSAGES)
def test_valid_messages_round_trip(msg):
    allowed = allowed_for(msg)
    assert decode(encode(msg), allowed) == msg
    assert type(msg).from_wire(msg.to_wire()) == msg
