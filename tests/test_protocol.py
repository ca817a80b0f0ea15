"""Messages, codec, validation and endpoints of the ``protocol`` package (docs/protocol.md)."""

from __future__ import annotations

import errno
import math
import pickle
import subprocess
import sys

import msgpack
import pytest
import zmq

from keepaway import protocol
from keepaway.protocol import (
    CLASSIC,
    COACH_TO_SERVER,
    CURRENT,
    DEFAULT_MAX_MESSAGE_BYTES,
    MONITOR_EPISODE_TOPIC,
    MONITOR_FRAME_TOPIC,
    PLAYER_TO_SERVER,
    PROTOCOL_VERSION,
    SERVER_TO_COACH,
    SERVER_TO_PLAYER,
    Advice,
    AtomicCommand,
    Bye,
    CoachBye,
    CoachInit,
    CoachInitOk,
    Command,
    EpisodeControl,
    EpisodeEnd,
    Error,
    Frame,
    Fullstate,
    Hear,
    Init,
    InitOk,
    Look,
    LookOk,
    PlayerReport,
    PlayerSaid,
    ProtocolError,
    Reconnect,
    Report,
    See,
    SenseBody,
    ServerParams,
    Shutdown,
    Start,
    SynchSee,
    Think,
    Waiting,
    decode,
    decode_for_coach,
    decode_for_player,
    decode_from_coach,
    decode_from_player,
    decode_monitor,
    encode,
    params,
)
from keepaway.protocol import messages as m
from keepaway.protocol.codec import MAX_PAYLOAD_DEPTH, Invalid
from keepaway.protocol.endpoints import bind, configure, connect_endpoint, parse_endpoint
from keepaway.protocol.errors import CODEC_ERROR_CODES
from keepaway.protocol.messages import MAX_COMMANDS, MONITOR_TOPICS

# ------------------------------------------------------------------------------- one sample per message

LANDMARKS = {
    "flags": (("f c", 0.0, 0.0), ("g r", 52.5, 0.0), ("f t l 10", -10.0, -39.0)),
    "lines": (("l r", 52.5, 0.0), ("l t", 0.0, -34.0)),
}
CONFIG = {"timing": "sync", "keepers": 3, "takers": 2, "seed": 7, "extra": {"nested": [1, 2.5, None]}}
COUNTS = {"kick": 1, "dash": 40, "turn": 12, "catch": 0, "move": 0, "turn_neck": 9, "change_view": 1, "say": 2}
BALL = (-6.0, -6.0, 0.25, -0.5)
PLAYERS = (
    ("l", 1, -8.5, -8.1, 0.1, 0.0, 45.0, -10.0, 3500.0, 1.0, 1.0, -1.0),
    ("r", 2, 8.0, 9.5, -0.3, 0.2, -135.0, 0.0, 4000.0, 0.9, 0.8, -1.0),
)
STATE = {"ball": BALL, "players": PLAYERS, "play_mode": "play_on", "episode": 3, "episode_start": 40, "take_count": 2}
PAYLOAD = {"trace": [1, 2.5, None, True, "x"], "weights": b"\x00\x01\x02", "empty": {}}

SAMPLES = [
    Init(team="keepers", unum=3, client="py-keeper", fullstate=True, synch_see=True),
    Init(team="takers"),
    Reconnect(team="takers", unum=2),
    Command(
        cycle=41,
        commands=(
            AtomicCommand("dash", (100.0,)),
            AtomicCommand("dash", (50.0, -90.0)),
            AtomicCommand("turn", (30.0,)),
            AtomicCommand("kick", (80.0, -45.0)),
            AtomicCommand("turn_neck", (-30.0,)),
            AtomicCommand("tackle", (100.0,)),
            AtomicCommand("move", (-10.0, 5.5)),
            AtomicCommand("catch", (0.0,)),
            AtomicCommand("say", ("pass 2",)),
            AtomicCommand("change_view", ("wide",)),
            AtomicCommand("change_view", ("narrow", "low")),
            AtomicCommand("done", ()),
        ),
    ),
    Command(cycle=0),
    Command(cycle=5, getopen=(3.5, -7.0)),
    Command(cycle=5, getopen=(3.5, -7.0, -7.0, -7.0, 0.25, -7.0, -3.5, -1.5)),
    Report(cycle=100, payload=PAYLOAD),
    Bye(),
    SynchSee(),
    INIT_OK := InitOk(cycle=0, side="l", unum=1, team="keepers", play_mode="before_kick_off",
                      params=CLASSIC.to_dict(), landmarks=LANDMARKS, config=CONFIG),
    Error(cycle=12, code="say_dropped", message="say longer than say_msg_size"),
    SENSE_BODY := SenseBody(cycle=7, view_mode=("high", "normal"), stamina=(3500.0, 1.0, -1.0), speed=(0.42, -15),
              head_angle=30, counts=COUNTS, collision=("ball", "player")),
    SEE := See(
        cycle=7,
        flags=((0, 12.2, -30, 0.0, 0.0), (None, 2.5, 170, None, None)),
        lines=((1, 40.4, -88),),
        ball=(5.5, 10, -0.11, 3.2),
        players=(
            ("l", 2, 8.2, -45, 0.16, -1.2, 30, 30),
            ("r", None, 24.5, 12, None, None, None, None),
            (None, None, 61.0, 3, None, None, None, None),
        ),
    ),
    See(cycle=8, flags=(), lines=(), ball=None, players=()),
    HEAR := Hear(cycle=8, sender="our", direction=-40, unum=2, message="pass 3"),
    Hear(cycle=9, sender="referee", message="training Keepaway 1"),
    Hear(cycle=9, sender="coach", message={"mode": "learn", "epsilon": 0.01}),
    FULLSTATE := Fullstate(cycle=7, ball=BALL, players=PLAYERS, play_mode="play_on", episode=1),
    Think(cycle=7),
    Waiting(cycle=0, reason="players", connected=3, expected=5),
    Shutdown(cycle=900, reason="the coach stopped the run"),
    CoachInit(client="trainer"),
    Start(),
    Look(),
    Advice(target="keepers", payload={"mode": "freeze"}),
    Advice(target=("l", 2), payload=[0.1, 0.2]),
    EpisodeControl(action="stop", episodes_left=10),
    EpisodeControl(action="reset"),
    CoachBye(),
    CoachInitOk(cycle=0, play_mode="play_on", params=CURRENT.to_dict(), landmarks=LANDMARKS, config=CONFIG),
    LookOk(cycle=55, state=STATE),
    EPISODE_END := EpisodeEnd(cycle=93, episode=3, start_cycle=28, end_cycle=93, end="taken"),
    EpisodeEnd(cycle=93, episode=4, start_cycle=28, end_cycle=93, end="out", missed=(("keeper 1", 12),)),
    PlayerReport(cycle=93, side="l", unum=1, payload=PAYLOAD),
    PlayerSaid(cycle=93, side="r", unum=2, message="hello"),
    FRAME := Frame(cycle=55, ball=BALL, players=PLAYERS, play_mode="play_on", episode=3, episode_start=40,
                   take_count=2),
    Frame(cycle=55, ball=BALL, players=PLAYERS, play_mode="play_on", episode=3, episode_start=40, take_count=2,
          getopen=((1, (3.5, -7.0)), (2, (0.0, 0.0, 3.5, 3.5, -0.5)))),
]

PORT_SETS = {
    "player->server": (PLAYER_TO_SERVER, decode_from_player),
    "server->player": (SERVER_TO_PLAYER, decode_for_player),
    "coach->server": (COACH_TO_SERVER, decode_from_coach),
    "server->coach": (SERVER_TO_COACH, decode_for_coach),
}
ALL_SETS = [PLAYER_TO_SERVER, SERVER_TO_PLAYER, COACH_TO_SERVER, SERVER_TO_COACH]


def allowed_for(msg) -> dict:
    """Every message type that may travel on a port with ``msg``'s (monitor types included)."""
    merged = {}
    for allowed in [*ALL_SETS, {cls.TYPE: cls for cls in MONITOR_TOPICS.values()}]:
        if msg.TYPE in allowed:
            merged.update(allowed)
    return merged


def wire_bytes(**fields) -> bytes:
    return msgpack.packb(fields, use_bin_type=True)


def code_of(data: bytes, allowed=PLAYER_TO_SERVER, **kwargs) -> str:
    with pytest.raises(ProtocolError) as info:
        decode(data, allowed, **kwargs)
    assert "\n" not in info.value.message and info.value.message
    return info.value.code


# ------------------------------------------------------------------------------------------- round trip


def test_every_message_type_has_a_sample():
    types = {cls for allowed in ALL_SETS for cls in allowed.values()} | set(MONITOR_TOPICS.values())
    assert types == {type(m) for m in SAMPLES}


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: m.TYPE)
def test_every_message_round_trips_through_every_port_that_carries_it(msg):
    carried = False
    for name, (allowed, helper) in PORT_SETS.items():
        if msg.TYPE in allowed:
            carried = True
            assert decode(encode(msg), allowed) == msg, name
            assert helper(encode(msg)) == msg, name
    for topic, cls in MONITOR_TOPICS.items():
        if cls is type(msg):
            carried = True
            assert decode_monitor(topic, encode(msg)) == msg
    assert carried


def test_encode_writes_packb_bytes_with_its_kept_packer_even_after_a_failure():
    """``encode`` keeps a Packer per thread: its bytes are ``msgpack.packb``'s for every message, and a
    message that cannot be packed leaves nothing behind in it."""
    unpackable = m.Report(cycle=0, payload={"x": object()})
    with pytest.raises(TypeError):
        encode(unpackable)
    for msg in SAMPLES:
        assert encode(msg) == msgpack.packb(msg.to_wire(), use_bin_type=True)


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: m.TYPE)
def test_from_wire_inverts_to_wire(msg):
    assert type(msg).from_wire(msg.to_wire()) == msg


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: m.TYPE)
def test_wire_maps_have_string_keys_only(msg):
    def check(value):
        if isinstance(value, dict):
            assert all(type(key) is str for key in value), value
            for child in value.values():
                check(child)
        elif isinstance(value, (list, tuple)):
            for child in value:
                check(child)

    wire = msg.to_wire()
    assert wire["type"] == msg.TYPE
    check(wire)
    check(msgpack.unpackb(encode(msg), raw=False))


def test_every_message_the_server_sends_carries_the_cycle():
    server_types = {*SERVER_TO_PLAYER.values(), *SERVER_TO_COACH.values(), *MONITOR_TOPICS.values()}
    for msg in SAMPLES:
        if type(msg) in server_types:
            assert "cycle" in msg.to_wire()
            with pytest.raises(ProtocolError) as info:
                type(msg).from_wire({k: v for k, v in msg.to_wire().items() if k != "cycle"})
            assert info.value.code == "missing_field"


def test_bye_encodes_to_the_hand_written_bytes():
    # fixmap of 1 entry (0x81), fixstr "type" (0xa4 + 4 bytes), fixstr "bye" (0xa3 + 3 bytes)
    assert encode(Bye()) == b"\x81\xa4type\xa3bye"


def test_command_wire_form_of_the_docs_decodes_to_atomic_commands():
    data = wire_bytes(type="command", cycle=12,
                      commands=[["dash", 100.0, 0.0], ["turn_neck", 30], ["say", "hello"]])
    msg = decode_from_player(data)
    assert msg == Command(cycle=12, commands=(AtomicCommand("dash", (100.0, 0.0)),
                                               AtomicCommand("turn_neck", (30.0,)),
                                               AtomicCommand("say", ("hello",))))
    assert type(msg.commands[1].args[0]) is float  # an int is accepted where a float is expected


def test_optional_fields_take_their_defaults():
    msg = decode_from_player(wire_bytes(type="init", version=PROTOCOL_VERSION, team="keepers"))
    assert msg == Init(team="keepers", unum=None, client="", fullstate=False, synch_see=False)
    assert decode_from_coach(wire_bytes(type="coach_init", version=1)) == CoachInit(client="")


def test_protocol_version_is_one_and_is_the_default_of_the_init_messages():
    assert PROTOCOL_VERSION == 1
    assert Init(team="keepers").version == Reconnect(team="keepers", unum=1).version == 1
    assert CoachInit().version == 1


def test_init_ok_params_rebuild_the_parameter_table():
    msg = decode_for_player(encode(INIT_OK))
    assert isinstance(msg, InitOk)
    assert ServerParams.from_dict(msg.params) == CLASSIC


# ------------------------------------------------------------------------------------ parameter ranges
def test_every_parameter_has_a_range_and_the_named_sets_lie_within_them():
    assert set(params.PARAMETER_RANGES) == set(params.KernelParams._fields)
    for name in params.PARAMETER_SETS:
        for launch in (True, False):
            table = params.parameter_set(name, keepaway_launch=launch)
            for key, allowed in params.PARAMETER_RANGES.items():
                assert getattr(table, key) in allowed, (name, key)


@pytest.mark.parametrize("name, value, allowed", [
    ("ball_decay", -0.1, "[0, 1]"),  # a fraction
    ("player_decay", 1.01, "[0, 1]"),
    ("effort_dec", -1.0, "[0, 1]"),
    ("simulator_step_ms", 0.0, "(0, inf)"),  # positive
    ("keepaway_length", -3.0, "(0, inf)"),
    ("inertia_moment", -1.0, "[0, inf)"),  # non-negative
    ("min_moment", -181.0, "[-180, 180]"),  # an angle
    ("visible_angle", 0.0, "(0, 360]"),
    ("take_cycles", 0.0, "[1, inf)"),  # a count of cycles
    ("movement_noise", 2.0, "{0, 1}"),  # a noise model
    ("failed_kick_uses_slot", 2, "{0, 1}"),  # a flag
])
def test_a_value_outside_its_range_is_refused_in_one_line_naming_the_range(name, value, allowed):
    message = f"server parameter {name}={value!r} is out of range: allowed {allowed}"
    for build in (lambda: CLASSIC.replace(**{name: value}), lambda: ServerParams(**{name: value}),
                  lambda: ServerParams.from_dict({name: value}),
                  lambda: params.parameter_set("current", **{name: value})):
        with pytest.raises(ValueError) as info:
            build()
        assert str(info.value) == message


@pytest.mark.parametrize("name, value, problem", [
    ("stamina_capacity", math.inf, "is not a finite number"),
    ("ball_decay", math.nan, "is not a finite number"),
    ("ball_decay", True, "is not a number"),
    ("ball_decay", "0.9", "is not a number"),
    ("see_behind_strict", "yes", "is not true/false"),
])
def test_a_value_of_the_wrong_kind_is_refused(name, value, problem):
    with pytest.raises(ValueError, match=f"^server parameter {name}=.* {problem}$"):
        CLASSIC.replace(**{name: value})


@pytest.mark.parametrize("changes, message", [
    ({"min_dash_power": 200.0}, "server parameter min_dash_power=200.0 must not exceed max_dash_power=100.0"),
    ({"unum_far_length": 40.0}, "server parameter unum_far_length=40.0 must be below unum_too_far_length=40.0"),
    ({"keepaway_width": 80.0}, "server parameter keepaway_width=80.0 must not exceed pitch_width=68.0"),
])
def test_bounds_that_must_be_ordered_are_refused_out_of_order(changes, message):
    with pytest.raises(ValueError) as info:
        CLASSIC.replace(**changes)
    assert str(info.value) == message


def test_values_on_the_bounds_and_flags_given_as_numbers_are_accepted():
    table = CLASSIC.replace(ball_decay=0.0, player_decay=1.0, visible_angle=360.0, dash_angle_step=0.0,
                            min_moment=-180.0, stamina_capacity=-1.0, failed_kick_uses_slot=1.0,
                            movement_noise=params.NOISE_POLAR, keepaway_width=68.0, min_dash_power=100.0)
    assert table.failed_kick_uses_slot == 1.0 and table.keepaway_width == 68.0


def test_unknown_parameters_and_names_that_are_not_strings_are_refused():
    with pytest.raises(ValueError, match="unknown server parameter 'warp'"):
        CLASSIC.replace(warp=1.0)
    with pytest.raises(ValueError, match="name=4 is not a string"):
        params.parameter_set("classic", name=4)
    with pytest.raises(ValueError, match="unknown parameter set"):
        params.parameter_set(["classic"])


def test_real_landmark_tables_fit_the_init_ok_limits():
    from keepaway.protocol.landmarks import FLAGS, LINES

    landmarks = {"flags": [[f.name, f.x, f.y] for f in FLAGS], "lines": [[ln.name, ln.x, ln.y] for ln in LINES]}
    msg = InitOk(cycle=0, side="r", unum=2, team="takers", play_mode="play_on", params=CLASSIC.to_dict(),
                 landmarks=landmarks, config={})
    decoded = decode_for_player(encode(msg))
    assert [name for name, _, _ in decoded.landmarks["flags"]] == [f.name for f in FLAGS]


# ------------------------------------------------------------------------------------------- validation

VALID_COMMAND = {"type": "command", "cycle": 5, "commands": [["turn", 10.0]]}


def with_(base: dict, **changes) -> bytes:
    return msgpack.packb({**base, **changes}, use_bin_type=True)


def without(base: dict, key: str) -> bytes:
    return msgpack.packb({k: v for k, v in base.items() if k != key}, use_bin_type=True)


def nested_list(depth: int) -> list:
    value: list = []
    for _ in range(depth - 1):
        value = [value]
    return value


INIT = {"type": "init", "version": 1, "team": "keepers"}
COACH = {"type": "advice", "target": "all", "payload": None}

CASES = [
    # (id, bytes, allowed set, expected code)
    ("reserved byte", b"\xc1", PLAYER_TO_SERVER, "malformed"),
    ("truncated map", wire_bytes(**VALID_COMMAND)[:-3], PLAYER_TO_SERVER, "malformed"),
    ("trailing garbage", wire_bytes(**VALID_COMMAND) + b"\x00", PLAYER_TO_SERVER, "malformed"),
    ("empty frame", b"", PLAYER_TO_SERVER, "malformed"),
    ("invalid utf-8", b"\x81\xa4type\xa2\xff\xfe", PLAYER_TO_SERVER, "malformed"),
    ("int key", b"\x82\xa4type\xa3bye\x01\x02", PLAYER_TO_SERVER, "malformed"),
    ("bin key", msgpack.packb({"type": "bye", b"x": 1}, use_bin_type=True), PLAYER_TO_SERVER, "malformed"),
    ("deep nesting", b"\x91" * 5000 + b"\xc0", PLAYER_TO_SERVER, "malformed"),  # 5000 one-element arrays
    ("not a map", msgpack.packb([1, 2]), PLAYER_TO_SERVER, "not_a_map"),
    ("no type", wire_bytes(cycle=1), PLAYER_TO_SERVER, "missing_field"),
    ("type not a str", wire_bytes(type=3), PLAYER_TO_SERVER, "bad_type"),
    ("unknown type", wire_bytes(type="teleport"), PLAYER_TO_SERVER, "unknown_type"),
    ("server type on a client port", encode(Think(cycle=1)), PLAYER_TO_SERVER, "unknown_type"),
    ("player type on the coach port", encode(Bye()), COACH_TO_SERVER, "unknown_type"),
    ("unknown field", with_(VALID_COMMAND, extra=1), PLAYER_TO_SERVER, "unknown_field"),
    ("missing field", without(VALID_COMMAND, "cycle"), PLAYER_TO_SERVER, "missing_field"),
    ("bool is not an int", with_(VALID_COMMAND, cycle=True), PLAYER_TO_SERVER, "bad_type"),
    ("float cycle", with_(VALID_COMMAND, cycle=5.0), PLAYER_TO_SERVER, "bad_type"),
    ("negative cycle", with_(VALID_COMMAND, cycle=-1), PLAYER_TO_SERVER, "bad_value"),
    ("huge cycle", with_(VALID_COMMAND, cycle=2**64 - 1), PLAYER_TO_SERVER, "bad_value"),
    ("NaN argument", with_(VALID_COMMAND, commands=[["dash", math.nan]]), PLAYER_TO_SERVER, "bad_value"),
    ("inf argument", with_(VALID_COMMAND, commands=[["kick", 10, -math.inf]]), PLAYER_TO_SERVER, "bad_value"),
    ("huge int argument", with_(VALID_COMMAND, commands=[["turn", 2**63]]), PLAYER_TO_SERVER, "bad_value"),
    ("bool argument", with_(VALID_COMMAND, commands=[["turn", True]]), PLAYER_TO_SERVER, "bad_type"),
    ("str argument", with_(VALID_COMMAND, commands=[["turn", "10"]]), PLAYER_TO_SERVER, "bad_type"),
    ("unknown command", with_(VALID_COMMAND, commands=[["fly", 1.0]]), PLAYER_TO_SERVER, "unknown_command"),
    ("too many arguments", with_(VALID_COMMAND, commands=[["turn", 1, 2]]), PLAYER_TO_SERVER, "bad_value"),
    ("too few arguments", with_(VALID_COMMAND, commands=[["kick", 1]]), PLAYER_TO_SERVER, "bad_value"),
    ("arguments to done", with_(VALID_COMMAND, commands=[["done", 1]]), PLAYER_TO_SERVER, "bad_value"),
    ("empty atomic command", with_(VALID_COMMAND, commands=[[]]), PLAYER_TO_SERVER, "bad_value"),
    ("command not an array", with_(VALID_COMMAND, commands=["turn"]), PLAYER_TO_SERVER, "bad_type"),
    ("command name not a str", with_(VALID_COMMAND, commands=[[1, 2]]), PLAYER_TO_SERVER, "bad_type"),
    ("getopen note of one number", with_(VALID_COMMAND, getopen=[1.0]), PLAYER_TO_SERVER, "bad_value"),
    ("getopen note with half a point", with_(VALID_COMMAND, getopen=[1.0, 2.0, 3.0, 4.0]), PLAYER_TO_SERVER,
     "bad_value"),
    ("getopen note not finite", with_(VALID_COMMAND, getopen=[1.0, float("nan")]), PLAYER_TO_SERVER, "bad_value"),
    ("getopen note too long", with_(VALID_COMMAND, getopen=[0.0] * (2 + 3 * 122)), PLAYER_TO_SERVER, "too_large"),
    ("bad view width", with_(VALID_COMMAND, commands=[["change_view", "huge"]]), PLAYER_TO_SERVER, "bad_value"),
    ("bad view quality", with_(VALID_COMMAND, commands=[["change_view", "wide", "hd"]]), PLAYER_TO_SERVER,
     "bad_value"),
    ("too many commands", with_(VALID_COMMAND, commands=[["turn", 1]] * (MAX_COMMANDS + 1)), PLAYER_TO_SERVER,
     "too_large"),
    ("say too long", with_(VALID_COMMAND, commands=[["say", "x" * 257]]), PLAYER_TO_SERVER, "too_large"),
    ("client name too long", with_(INIT, client="c" * 65), PLAYER_TO_SERVER, "too_large"),
    ("unknown team", with_(INIT, team="goalies"), PLAYER_TO_SERVER, "bad_value"),
    ("unum out of range", with_(INIT, unum=12), PLAYER_TO_SERVER, "bad_value"),
    ("fullstate not a bool", with_(INIT, fullstate=1), PLAYER_TO_SERVER, "bad_type"),
    ("other version", with_(INIT, version=2), PLAYER_TO_SERVER, "bad_version"),
    ("version not an int", with_(INIT, version="1"), PLAYER_TO_SERVER, "bad_type"),
    ("other version wins over unknown fields", with_(INIT, version=2, team=None, future_field=[1]),
     PLAYER_TO_SERVER, "bad_version"),
    ("reconnect without unum", without({**INIT, "type": "reconnect"}, "unum"), PLAYER_TO_SERVER, "missing_field"),
    ("payload too deep", wire_bytes(type="report", cycle=1, payload=nested_list(MAX_PAYLOAD_DEPTH + 1)),
     PLAYER_TO_SERVER, "malformed"),
    ("payload with ext type", msgpack.packb({"type": "report", "cycle": 1, "payload": msgpack.ExtType(5, b"x")}),
     PLAYER_TO_SERVER, "bad_type"),
    ("payload with timestamp", msgpack.packb({"type": "report", "cycle": 1, "payload": msgpack.Timestamp(1)}),
     PLAYER_TO_SERVER, "bad_type"),
    ("payload with bin key", msgpack.packb({"type": "report", "cycle": 1, "payload": {b"k": 1}},
                                           use_bin_type=True), PLAYER_TO_SERVER, "malformed"),
    ("advice to nobody", with_(COACH, target="goalies"), COACH_TO_SERVER, "bad_value"),
    ("advice to a bad player", with_(COACH, target=["l", 0]), COACH_TO_SERVER, "bad_value"),
    ("advice target a number", with_(COACH, target=3), COACH_TO_SERVER, "bad_type"),
    ("episodes_left without stop", wire_bytes(type="episode_control", action="reset", episodes_left=3),
     COACH_TO_SERVER, "bad_value"),
    ("unknown episode action", wire_bytes(type="episode_control", action="rewind"), COACH_TO_SERVER, "bad_value"),
    ("player hears a non-string", with_(HEAR.to_wire(), message=[1]), SERVER_TO_PLAYER, "bad_type"),
    ("waiting for an unknown reason", wire_bytes(type="waiting", cycle=0, reason="lunch", connected=1, expected=5),
     SERVER_TO_PLAYER, "bad_value"),
    ("see distance negative", with_(SEE.to_wire(), ball=[-1.0, 0, None, None]), SERVER_TO_PLAYER,
     "bad_value"),
    ("see direction a float", with_(SEE.to_wire(), ball=[1.0, 0.5, None, None]), SERVER_TO_PLAYER,
     "bad_type"),
    ("see flag entry too short", with_(SEE.to_wire(), flags=[[0, 1.0, 2]]), SERVER_TO_PLAYER,
     "bad_value"),
    ("sense_body count missing", with_(SENSE_BODY.to_wire(), counts={"kick": 0}), SERVER_TO_PLAYER,
     "missing_field"),
    ("sense_body count unknown",
     with_(SENSE_BODY.to_wire(), counts={**COUNTS, "point_to": 0}), SERVER_TO_PLAYER, "unknown_field"),
    ("init_ok unknown parameter", with_(INIT_OK.to_wire(), params={**CLASSIC.to_dict(), "warp": 1.0}),
     SERVER_TO_PLAYER, "bad_value"),
    ("init_ok infinite parameter", with_(INIT_OK.to_wire(), params={"ball_decay": math.inf}),
     SERVER_TO_PLAYER, "bad_value"),
    ("init_ok lists not flags", with_(INIT_OK.to_wire(), landmarks={"lines": []}), SERVER_TO_PLAYER,
     "missing_field"),
    ("fullstate NaN", with_(FULLSTATE.to_wire(), ball=[0.0, math.nan, 0.0, 0.0]), SERVER_TO_PLAYER,
     "bad_value"),
    ("episode end cause", with_(EPISODE_END.to_wire(), end="timeout"), SERVER_TO_COACH, "bad_value"),
    ("episode end missed", with_(EPISODE_END.to_wire(), missed=[["keeper 1", 0]]), SERVER_TO_COACH, "bad_value"),
]


@pytest.mark.parametrize("data, allowed, expected", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_each_invalid_input_gets_its_error_code(data, allowed, expected):
    assert expected in CODEC_ERROR_CODES
    assert code_of(data, allowed) == expected


def test_every_codec_error_code_is_exercised():
    assert {c[3] for c in CASES} == set(CODEC_ERROR_CODES)


def test_error_message_names_the_offending_position():
    with pytest.raises(ProtocolError) as info:
        decode_from_player(with_(VALID_COMMAND, commands=[["turn", 1.0], ["kick", 10.0, math.nan]]))
    assert info.value.message.startswith("command.commands[1][2]:")
    assert str(info.value) == f"bad_value: {info.value.message}"


def test_error_message_of_a_huge_string_stays_short():
    with pytest.raises(ProtocolError) as info:
        decode_from_player(with_(VALID_COMMAND, commands=[["x" * 1_000_000]]))
    assert info.value.code == "unknown_command"
    assert len(info.value.message) < 200


def test_frame_larger_than_the_limit_is_too_large():
    data = wire_bytes(type="report", cycle=1, payload=b"\x00" * 1000)
    assert decode(data, PLAYER_TO_SERVER, max_bytes=len(data)).payload == b"\x00" * 1000
    assert code_of(data, PLAYER_TO_SERVER, max_bytes=len(data) - 1) == "too_large"


def test_non_bytes_input_is_malformed():
    with pytest.raises(ProtocolError) as info:
        decode("not bytes", PLAYER_TO_SERVER)  # type: ignore[arg-type]
    assert info.value.code == "malformed"


def test_bytearray_and_memoryview_frames_decode():
    data = encode(Think(cycle=3))
    assert decode_for_player(bytearray(data)) == decode_for_player(memoryview(data)) == Think(cycle=3)


def test_payload_at_the_depth_limit_is_accepted():
    # nested_list(d) has d array levels; the outermost sits at depth 0, so d = MAX_PAYLOAD_DEPTH is the last
    # accepted one and re-encodes (msgpack's packer allows 511 levels).
    msg = decode_from_player(wire_bytes(type="report", cycle=1, payload=nested_list(MAX_PAYLOAD_DEPTH)))
    assert decode_from_player(encode(msg)) == msg


def test_payload_may_hold_nan_but_commands_may_not():
    msg = decode_from_player(wire_bytes(type="report", cycle=1, payload=[math.nan]))
    assert math.isnan(msg.payload[0])


def test_monitor_topics_select_the_message_type():
    frame = FRAME
    assert decode_monitor(MONITOR_FRAME_TOPIC, encode(frame)) == frame
    with pytest.raises(ProtocolError) as info:
        decode_monitor(MONITOR_EPISODE_TOPIC, encode(frame))
    assert info.value.code == "unknown_type"
    with pytest.raises(ProtocolError) as info:
        decode_monitor(b"gossip", encode(frame))
    assert info.value.code == "unknown_type"


def test_from_wire_rejects_another_type_and_non_maps():
    with pytest.raises(ProtocolError) as info:
        Init.from_wire(Bye().to_wire())
    assert info.value.code == "unknown_type"
    with pytest.raises(ProtocolError) as info:
        Init.from_wire([1])
    assert info.value.code == "not_a_map"


def test_protocol_error_survives_pickling():
    error = pickle.loads(pickle.dumps(ProtocolError("bad_value", "x is wrong")))
    assert (error.code, error.message) == ("bad_value", "x is wrong")


def test_protocol_package_imports_no_other_project_package():
    code = ("import sys, protocol, protocol.landmarks; "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'server', 'agents', 'coach', 'trainer'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_package_exports_the_public_surface():
    for name in protocol.__all__:
        assert hasattr(protocol, name), name
    assert set(params.__all__) <= set(protocol.__all__)


# -------------------------------------------------------------------------------------------- endpoints


@pytest.fixture
def context():
    ctx = zmq.Context()
    yield ctx
    ctx.destroy(linger=0)


def test_default_ports_and_message_limit():
    assert protocol.DEFAULT_PORTS == {"players": 6000, "coach": 6001, "monitor": 6002, "arena": 6003}
    assert DEFAULT_MAX_MESSAGE_BYTES == 4 * 1024 * 1024


def test_bind_to_port_zero_returns_the_port_bound(context):
    router = context.socket(zmq.ROUTER)
    configure(router)
    port = bind(router, "127.0.0.1", 0)
    assert 0 < port <= 65535
    assert router.getsockopt(zmq.LAST_ENDPOINT).decode() == f"tcp://127.0.0.1:{port}"
    dealer = context.socket(zmq.DEALER)
    configure(dealer)
    dealer.connect(connect_endpoint("127.0.0.1", port))
    dealer.send(encode(Bye()))
    assert router.poll(5000)
    identity, frame = router.recv_multipart()
    assert decode_from_player(frame) == Bye()


def test_configure_sets_linger_and_the_size_limit(context):
    dealer = context.socket(zmq.DEALER)
    configure(dealer, max_message_bytes=1234)
    assert dealer.getsockopt(zmq.LINGER) == 0
    assert dealer.getsockopt(zmq.MAXMSGSIZE) == 1234


def test_configured_router_raises_on_send_to_an_unknown_peer(context):
    router = context.socket(zmq.ROUTER)
    configure(router)
    bind(router, "127.0.0.1", 0)
    with pytest.raises(zmq.ZMQError) as info:
        router.send_multipart([b"gone", encode(Think(cycle=1))])
    assert info.value.errno == errno.EHOSTUNREACH


@pytest.mark.parametrize("endpoint, expected", [
    ("tcp://127.0.0.1:6000", ("127.0.0.1", 6000)),
    ("tcp://localhost:0", ("localhost", 0)),
    ("tcp://[::1]:6001", ("::1", 6001)),
    ("tcp://0.0.0.0:65535", ("0.0.0.0", 65535)),
])
def test_parse_endpoint(endpoint, expected):
    assert parse_endpoint(endpoint) == expected


@pytest.mark.parametrize("endpoint", [
    "udp://127.0.0.1:6000", "tcp://127.0.0.1", "tcp://:6000", "tcp://host:port", "tcp://host:70000",
    "tcp://host:-1", "tcp://host:６０００",
])
def test_parse_endpoint_rejects_malformed_endpoints(endpoint):
    with pytest.raises(ValueError):
        parse_endpoint(endpoint)


def test_connect_endpoint_brackets_ipv6_and_inverts_parse():
    assert connect_endpoint("::1", 6000) == "tcp://[::1]:6000"
    assert parse_endpoint(connect_endpoint("example.org", 6002)) == ("example.org", 6002)
    with pytest.raises(ValueError):
        connect_endpoint("127.0.0.1", 0)


def test_see_fast_path_gives_what_the_full_loader_gives():
    """The see flags' fast path (rows) must accept exactly what the full loader accepts unchanged."""
    good = [[0, 12.2, -30, 0.0, None], [None, 3.0, 180, None, None]]
    msg = decode_for_player(encode_map({"type": "see", "cycle": 1, "flags": good, "lines": [],
                                        "ball": None, "players": []}))
    assert msg.flags == ((0, 12.2, -30, 0.0, None), (None, 3.0, 180, None, None))
    ints = [[0, 12, -30, 0, None]]  # ints are converted by the full loader
    msg = decode_for_player(encode_map({"type": "see", "cycle": 1, "flags": ints, "lines": [],
                                        "ball": None, "players": []}))
    assert msg.flags == ((0, 12.0, -30, 0.0, None),) and type(msg.flags[0][1]) is float
    for bad, code in [([[0, float("nan"), 0, None, None]], "bad_value"), ([[True, 1.0, 0, None, None]], "bad_type"),
                      ([[0, 1.0, 0, None, None]] * 257, "too_large"), ([[0, -1.0, 0, None, None]], "bad_value")]:
        with pytest.raises(ProtocolError) as err:
            decode_for_player(encode_map({"type": "see", "cycle": 1, "flags": bad, "lines": [], "ball": None,
                                          "players": []}))
        assert err.value.code == code


def encode_map(value: dict) -> bytes:
    return msgpack.packb(value, use_bin_type=True)


SEE_ROWS = {  # a valid row of each of the see's fast-path fields
    "flags": [[0, 12.2, -30, 0.5, -0.25], [None, 3.0, 180, None, None]],
    "lines": [[3, 20.5, -90]],
    "ball": [2.5, 10, 0.1, -0.2],
    "players": [["l", 2, 5.5, -20, 0.1, 0.2, 10, -10], ["r", None, 30.0, 40, None, None, None, None],
                [None, None, 40.0, 0, None, None, None, None]],
}
ODD_VALUES = [None, True, False, 0, 1, -1, 12, 180, 181, -181, 256, 2**53 + 1, 0.0, -0.0, 1.5, -1.5, 1e308,
              float("nan"), float("inf"), float("-inf"), "l", "r", "x", b"l", [], [1.0], {}]


def _outcome(load, value):
    try:
        result = load(value)
    except Invalid as exc:
        return ("invalid", exc.code, exc.what, tuple(exc.path))
    return ("ok", result, repr(result))  # repr tells -0.0 from 0.0 and a float from an int


def test_see_fast_paths_agree_with_the_full_loaders_on_every_odd_value():
    """Every see field with a fast path (protocol.codec.row/rows) gives exactly what its full loader
    gives, value and type, or the same error, for each element of a valid row replaced by odd values,
    for rows too short or long, and for non-arrays."""
    loaders = {name: load for name, _, load, _, _, _ in m.See._WIRE}
    for name, good in SEE_ROWS.items():
        load = loaders[name]
        single = name == "ball"
        variants = [good, None, 5, "x", (), [], good + good if not single else good + [0.0]]
        for i, row in enumerate([good] if single else good):
            for j in range(len(row)):
                for odd in ODD_VALUES:
                    changed = [*row[:j], odd, *row[j + 1:]]
                    variants.append(changed if single else [*good[:i], changed, *good[i + 1:]])
            variants.append(row[:-1] if single else [*good[:i], row[:-1]])
            variants.append(row + [0] if single else [*good[:i], row + [0]])
        variants.append([good[0]] * (m.MAX_LANDMARKS + 1) if not single else good)
        for value in variants:
            assert _outcome(load, value) == _outcome(load.full, value), (name, value)
