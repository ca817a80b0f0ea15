"""Fuzzing the live server loop: whatever a client sends, the server answers with one-line errors and
keeps serving everyone (spec: "Bad input gets a clear error and loses nothing")."""

from __future__ import annotations

import math

import msgpack
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from keepaway.protocol import messages as m
from scripted import ScriptedCoach, ScriptedPlayer


@pytest.fixture(scope="module")
def live_game(tmp_path_factory):
    from conftest import ProcessGroup

    group = ProcessGroup(tmp_path_factory.mktemp("fuzz-stderr"))
    try:
        srv = group.start_server(tmp_path_factory.mktemp("fuzz"), "--keepers", "1", "--takers", "1",
                                 "--start-on", "coach", "--cycle-timeout", "0.02", "--max-missed", "1000000")
        coach = ScriptedCoach(srv.coach_endpoint)
        coach.init()
        player = ScriptedPlayer(srv.players_endpoint)
        assert isinstance(player.init("keepers"), m.InitOk)
        coach.send(m.Start())
        yield srv, player, coach
    finally:
        group.cleanup()


def errors_until_barrier(client: ScriptedPlayer) -> list[m.Error]:
    """The errors among the messages before the barrier's answer: one case's."""
    return [msg for msg in client.until_barrier() if isinstance(msg, m.Error)]


json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats(allow_nan=True)
    | st.text(max_size=20) | st.binary(max_size=20),
    lambda children: st.lists(children, max_size=5) | st.dictionaries(st.text(max_size=10), children, max_size=5),
    max_leaves=20,
)

commands = st.lists(
    st.lists(st.sampled_from(["dash", "turn", "kick", "turn_neck", "say", "fly", "", "change_view"])
             .map(lambda s: [s]) | st.just([]), max_size=1).map(lambda x: x[0] if x else [])
    .flatmap(lambda head: st.lists(st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=12)
                                   | st.integers(-(2**63), 2**64 - 1), max_size=3).map(lambda args: head + args)),
    max_size=20,
)

# No shrinking: the examples run against one live server whose state goes on between them, so a failing
# example does not replay alike, and each replay that fails waits out a barrier's timeout (under a heavy
# load a shrink took over 15 minutes); the failing example is reported as generated.
FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck),
                phases=(Phase.explicit, Phase.reuse, Phase.generate))


@FUZZ
@given(data=st.binary(max_size=512) | json_values.map(lambda v: msgpack.packb(v, use_bin_type=True)))
def test_anything_from_an_unknown_client_gets_errors_only(live_game, data):
    srv, _, _ = live_game
    rogue = ScriptedPlayer(srv.players_endpoint)
    try:
        rogue.send_raw(data)
        for error in errors_until_barrier(rogue):
            assert error.code and "\n" not in error.message
    finally:
        rogue.close()
    assert srv.proc.poll() is None


@FUZZ
@given(cmds=commands, cycle=st.integers(-5, 2**40) | st.floats(allow_nan=True))
def test_random_commands_from_a_playing_client_never_break_the_loop(live_game, cmds, cycle):
    srv, player, coach = live_game
    player.send_raw(msgpack.packb({"type": "command", "cycle": cycle, "commands": cmds}, use_bin_type=True))
    for error in errors_until_barrier(player):
        assert error.code and "\n" not in error.message
    coach.send(m.Look())
    look = coach.recv_until(m.LookOk)
    x, y = look.state["players"][0][2:4]
    assert math.isfinite(x) and math.isfinite(y)
    assert srv.proc.poll() is None
