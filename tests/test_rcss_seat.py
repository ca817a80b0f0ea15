"""The front's translation state of one text client (``rcss/seat.py``), without sockets: the team-name
rule, the answer of a synchronous cycle ending with ``(done)``, real-time commands at once, late commands,
the requests answered from the seat's state, and refusals in rcssserver's words."""

from __future__ import annotations

import pytest

from keepaway.protocol import messages as m
from keepaway.protocol.landmarks import to_wire
from keepaway.protocol.params import parameter_set
from keepaway.rcss.commands import InitRequest, ReconnectRequest
from keepaway.rcss.seat import TeamNames, TextSeat

PARAMS = parameter_set("current").to_dict()


def seated(mode: str = "sync", version: float = 12.0, team: str = "keepers") -> TextSeat:
    names = TeamNames()
    our_team = names.join(team)
    seat = TextSeat(InitRequest(team, version), our_team, names, version)
    out = seat.on_server(m.InitOk(cycle=0, side="l" if our_team == "keepers" else "r", unum=1, team=our_team,
                                  play_mode="before_kick_off", params=PARAMS, landmarks=to_wire(),
                                  config={"mode": mode}))
    assert out.texts[0] == f"(init {seat.view.side} 1 before_kick_off)"
    assert [t.split()[0] for t in out.texts[1:4]] == ["(server_param", "(player_param", "(player_type"]
    return seat


def body(cycle: int) -> m.SenseBody:
    return m.SenseBody(cycle=cycle, view_mode=("high", "normal"), stamina=(8000.0, 1.0, 130600.0), speed=(0.0, 0),
                       head_angle=0, counts={name: 0 for name in m.COMMAND_COUNTS}, collision=())


def test_team_names_keep_their_sides_and_others_take_the_free_one_left_first():
    names = TeamNames()
    assert names.join("takers") == "takers"
    assert names.join("A") == "keepers"  # the first free side, left first
    assert names.join("B") is None  # a third team
    assert names.names() == ("A", "takers")
    names.leave("keepers")
    assert names.join("B") == "keepers" and names.names() == ("B", "takers")
    assert names.join("keepers") is None  # its side is B's while a client of B is there


def test_a_synchronous_answer_is_one_command_once_done_comes():
    seat = seated()
    seat.on_server(body(7))
    sensed, think = seat.on_server(m.Think(cycle=7)).texts
    assert sensed.startswith("(sense_body 7 ") and think == "(think)"
    first = seat.on_datagram(b"(dash 100)(turn_neck -19)\0")
    assert first.to_server == [] and first.texts == []
    done = seat.on_datagram(b"(done)\0")
    assert done.to_server == [m.Command(cycle=7, commands=(m.AtomicCommand("dash", (100.0,)),
                                                           m.AtomicCommand("turn_neck", (-19.0,))))]
    assert seat.on_datagram(b"(done)\0").to_server == [m.Command(cycle=7)]  # done alone: an empty answer


def test_commands_without_done_go_late_when_the_server_has_stepped():
    seat = seated()
    seat.on_server(body(3))
    seat.on_datagram(b"(turn 30)\0")
    late = seat.on_server(body(4))
    assert late.to_server == [m.Command(cycle=3, commands=(m.AtomicCommand("turn", (30.0,)),))]
    assert late.texts[0].startswith("(sense_body 3 ")  # the held body of cycle 3 goes; cycle 4's is held


def test_real_time_commands_go_at_once_and_no_think_is_sent():
    seat = seated("realtime")
    seat.on_server(body(5))
    assert [text.split()[0] for text in seat.on_server(m.Think(cycle=5)).texts] == ["(sense_body"]  # no think
    assert seat.on_datagram(b"(kick 50 0)\0").to_server == [m.Command(cycle=5, commands=(
        m.AtomicCommand("kick", (50.0, 0.0)),))]


def test_requests_are_answered_from_the_seat():
    seat = seated()
    seat.on_server(body(9))
    (sensed,) = seat.on_server(m.Think(cycle=9)).texts[:1]
    assert seat.on_datagram(b"(score)(sense_body)\0").texts == ["(score 9 0 0)", sensed]
    assert seat.on_datagram(b"(synch_see)\0") == (["(ok synch_see)"], [m.SynchSee()])  # v12: switched now
    assert seat.on_datagram(b"(synch_see)\0") == (["(ok synch_see)"], [])  # once
    assert seated(version=19).on_datagram(b"(synch_see)\0") == (["(ok synch_see)"], [])  # on since its init
    assert seat.on_datagram(b"(ear (on nobody))\0").texts == ["(error no team with name nobody)"]
    assert seat.on_datagram(b"(fly)\0").texts == ["(error illegal_command_form)"]


def test_the_referees_words_come_before_the_cycles_body_and_the_players_says_after_it():
    """rcssserver writes the referee's words inside the step, before the cycle's sense_body, and flushes the
    players' says after it; our server sends sense_body, then the hears, then see and think."""
    seat = seated()
    texts = []
    for msg in (body(54), m.Hear(cycle=54, sender="referee", message="training Keepaway 1"),
                m.Hear(cycle=54, sender="our", direction=12, unum=2, message="abc"), m.Think(cycle=54)):
        texts += seat.on_server(msg).texts
    assert texts[0] == "(hear 54 referee training Keepaway 1)"
    assert texts[1].startswith("(sense_body 54 ") and texts[2] == '(hear 54 12 our 2 "abc")' and texts[3] == "(think)"


def test_bye_leaves_and_a_refused_seat_gets_rcssservers_refusal():
    seat = seated()
    out = seat.on_datagram(b"(bye)\0")
    assert out.to_server == [m.Bye()] and seat.gone
    names = TeamNames()
    refused = TextSeat(ReconnectRequest("keepers", 4), names.join("keepers"), names, 12.0)
    out = refused.on_server(m.Error(cycle=0, code="cannot_reconnect", message="x"))
    assert out.texts == ["(error no_such_team_or_player)"] and refused.gone


@pytest.mark.parametrize("version", [8.0, 12.0, 13.0, 14.0, 19.0])
def test_the_join_asks_for_pre_kick_off_percepts_and_synch_see_from_18(version):
    names = TeamNames()
    join = TextSeat(InitRequest("takers", version), names.join("takers"), names, version).join_message()
    assert join.team == "takers" and join.pre_kick_off and join.synch_see == (version >= 18)
